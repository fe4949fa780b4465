// The polynomial terms of an element's configuration, checked against its method and K (terms.c).

#ifndef MJFLEX_NATIVE_TERMS_H_
#define MJFLEX_NATIVE_TERMS_H_

#include "schema.h"

// largest |sum of the coefficients of the sigma^k z_j terms| of a dualquat element, relative to the sum of all
// |coefficients| (mjflex.core.polynomial.REST_STRESS_RTOL): the terms must not stress the element at rest
#define MJFX_REST_STRESS_RTOL 1e-12

// The terms of what a configuration gave (exponents, coefficients, order) checked against the method and K
// (embedded 6x6): the terms (exps: MJFX_TERM_COLUMNS per row, malloc'd with coefs) into *exps, *coefs, *nterms
// and their largest exponent into *top; nothing without terms. 0, or -1 with the message (head: the element's).
int mjfx_parse_terms(const char* head, int form, const mjfxValues* v, int method, const double K6[36], int** exps,
                     double** coefs, int* nterms, int* top, char* err, int errsz);

#endif  // MJFLEX_NATIVE_TERMS_H_

// Entry points for Python (ctypes, mjflex/native/library.py) that the C library uses too (see api.c).

#ifndef MJFLEX_NATIVE_API_H_
#define MJFLEX_NATIVE_API_H_

#include "elements.h"

// The first row of a table (with chain: nchain dof ids, and nterms rows of terms) whose indices or
// ranges leave the arrays of model m or of the tables, or -1 (api.c: the check of the tables Python
// passes through ctypes and publishes to the dispatcher).
int mjfx_check_rows(const mjModel* m, const mjfxElement* el, int n, const int* chain, int nchain, const int* exps,
                    const double* coefs, int nterms);

#endif  // MJFLEX_NATIVE_API_H_

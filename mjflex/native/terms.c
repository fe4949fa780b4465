// The polynomial terms of an element's configuration, checked against its method and K (see config.h).

#include "terms.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "flexure_math.h"
#include "matrix.h"

// Hessian at rest of the terms in the layout of K (mjflex.core.polynomial.PolynomialTerms.rest_stiffness)
static void rest_stiffness(int method, const int* exps, const double* coefs, int n, double H[36]) {
  static const int DQ_DISPLACEMENT[6] = {1, 2, 3, 5, 6, 7};
  memset(H, 0, 36 * sizeof(double));
  for (int r = 0; r < n; r++) {
    const int* e = exps + MJFX_TERM_COLUMNS * r;
    double c = coefs[r];
    int z[6], sum = 0;
    for (int k = 0; k < 6; k++) {
      z[k] = method == MJFX_TWIST ? e[k] : e[DQ_DISPLACEMENT[k]];
      sum += z[k];
    }
    double scale = method == MJFX_TWIST ? 1.0 : 0.25;
    if (method == MJFX_TWIST || e[4] == 0) {
      if (sum == 2) {
        int i = -1, j = -1;
        for (int k = 0; k < 6; k++) {
          if (z[k] == 2) i = j = k;
          else if (z[k] == 1) (i < 0 ? (i = k) : (j = k));
        }
        H[6 * i + j] += scale * c;
        H[6 * j + i] += scale * c;
      } else if (method == MJFX_DUALQUAT && sum == 0) {
        for (int k = 0; k < 3; k++) H[7 * k] -= 0.25 * c * e[0];
      }
    } else if (e[4] == 1 && sum == 0) {
      for (int k = 0; k < 3; k++) {
        H[6 * k + 3 + k] -= 0.25 * c;
        H[6 * (3 + k) + k] -= 0.25 * c;
      }
    }
  }
}

// a row of exponents with its index, the sort key of the repeat check (qsort takes no context: each key is whole)
typedef struct {
  int exps[MJFX_TERM_COLUMNS];
  int row;
} mjfxTermKey;

static int compare_rows(const void* a, const void* b) {
  const mjfxTermKey *ka = a, *kb = b;
  int c = memcmp(ka->exps, kb->exps, sizeof(ka->exps));
  return c ? c : (ka->row > kb->row) - (ka->row < kb->row);
}

// No row of exponents may repeat another. Rows sorted by their exponents, then by row (O(n log n): 100,000 terms
// in milliseconds; comparing all pairs took seconds): equal rows are neighbours. The message names the first row
// that repeats an earlier one, and the earliest row it repeats (what comparing all pairs in order would find).
// 0, or -1 with the message.
static int check_repeats(const char* head, int form, const int* exps, int nt, char* err, int errsz) {
  if (nt < 2) return 0;
  mjfxTermKey* keys = malloc(sizeof(mjfxTermKey) * nt);
  if (!keys) return mjfx_fail(err, errsz, head, "out of memory for %d terms", nt);
  for (int r = 0; r < nt; r++) {
    memcpy(keys[r].exps, exps + MJFX_TERM_COLUMNS * r, sizeof(keys[r].exps));
    keys[r].row = r;
  }
  qsort(keys, nt, sizeof(mjfxTermKey), compare_rows);
  int first = -1, earliest = -1;
  for (int k = 1, start = 0; k < nt; k++) {
    if (memcmp(keys[k].exps, keys[start].exps, sizeof(keys[k].exps))) {
      start = k;
    } else if (first < 0 || keys[k].row < first) {
      first = keys[k].row, earliest = keys[start].row;  // keys[start]: the group's smallest row
    }
  }
  free(keys);
  if (first < 0) return 0;
  return mjfx_fail(err, errsz, head, "%s row %d repeats row %d: list each term once (add the coefficients)",
                   mjfx_key(MJFX_A_EXPONENTS, form), first, earliest);
}

int mjfx_parse_terms(const char* head, int form, const mjfxValues* v, int method, const double K6[36], int** exps_out,
                     double** coefs_out, int* nterms, int* top_out, char* err, int errsz) {
  int nvar = method == MJFX_TWIST ? 6 : 8;
  int order = v->count[MJFX_A_ORDER] > 0 ? (int)v->num[v->first[MJFX_A_ORDER]] : 2;
  const char* okey = mjfx_key(MJFX_A_ORDER, form);
  const char* ekey = mjfx_key(MJFX_A_EXPONENTS, form);
  if (method == MJFX_DUALQUAT && order % 2) {
    return mjfx_fail(err, errsz, head, "%s must be an integer >= 2 and even for a dualquat element (its potential is "
                     "even in q); got %d. Fix %s", okey, order, okey);
  }
  int ne = v->count[MJFX_A_EXPONENTS] > 0 ? v->count[MJFX_A_EXPONENTS] : 0;
  int nc = v->count[MJFX_A_COEFFICIENTS] > 0 ? v->count[MJFX_A_COEFFICIENTS] : 0;
  if (ne == 0 && nc == 0) {
    if (order != 2) {
      return mjfx_fail(err, errsz, head, "%s is %d but there are no terms; add %s and %s or drop %s", okey, order,
                       ekey, mjfx_key(MJFX_A_COEFFICIENTS, form), okey);
    }
    return 0;
  }
  if (ne % nvar) {
    return mjfx_fail(err, errsz, head, "%s has %d integers, not a multiple of %d: give one row of %d exponents (%s) "
                     "per term", ekey, ne, nvar, nvar,
                     method == MJFX_TWIST ? "tau_1 tau_2 tau_3 t_1 t_2 t_3" : "sigma xi_1 xi_2 xi_3 s' x'_1 x'_2 x'_3");
  }
  int nt = ne / nvar;
  if (nc != nt) {
    return mjfx_fail(err, errsz, head, "%d rows of exponents but %d coefficients: give one coefficient per term", nt,
                     nc);
  }
  if (nt > MJFX_MAX_TERMS) {
    return mjfx_fail(err, errsz, head, "%d terms are more than mjflex handles (%d)", nt, MJFX_MAX_TERMS);
  }
  const double* raw = v->num + v->first[MJFX_A_EXPONENTS];
  int* exps = calloc((size_t)nt * MJFX_TERM_COLUMNS, sizeof(int));
  double* coefs = malloc(sizeof(double) * nt);
  if (!exps || !coefs) {
    free(exps), free(coefs);
    return mjfx_fail(err, errsz, head, "out of memory for %d terms", nt);
  }
  memcpy(coefs, v->num + v->first[MJFX_A_COEFFICIENTS], sizeof(double) * nt);
  int rc = 0, top = 0;
  double scale = 0.0;
  for (int r = 0; r < nt && !rc; r++) {
    int deg = 0;
    for (int k = 0; k < nvar; k++) {
      int x = (int)raw[nvar * r + k];  // in [0, MJFX_MAX_EXPONENT]: the table's bounds
      exps[MJFX_TERM_COLUMNS * r + k] = x;
      deg += x;
      if (x > top) top = x;
    }
    if (deg < 2) {  // the coefficients are finite: the table's bounds
      rc = mjfx_fail(err, errsz, head, "%s row %d is a %s term: the constant is arbitrary and linear terms stress the "
                     "element at rest; drop it (terms start at degree 2)", ekey, r, deg == 0 ? "constant" : "linear");
    } else if (method == MJFX_DUALQUAT && deg % 2) {
      rc = mjfx_fail(err, errsz, head, "%s row %d has odd degree %d: q and -q are the same displacement, so "
                     "dual-quaternion potentials are even; use terms of even degree", ekey, r, deg);
    } else if (deg > order) {
      rc = mjfx_fail(err, errsz, head, "%s row %d has degree %d, above %s %d; raise %s or drop the term", ekey, r, deg,
                     okey, order, okey);
    }
    scale += fabs(coefs[r]);
  }
  if (!rc) rc = check_repeats(head, form, exps, nt, err, errsz);
  if (!rc && method == MJFX_DUALQUAT) {  // sigma^k z_j terms must cancel (no generalized force at rest)
    static const int DQ_DISPLACEMENT[6] = {1, 2, 3, 5, 6, 7};
    for (int jj = 0; jj < 6 && !rc; jj++) {
      int j = DQ_DISPLACEMENT[jj];
      double stress = 0.0;
      for (int r = 0; r < nt; r++) {
        const int* e = exps + MJFX_TERM_COLUMNS * r;
        int others = 0;
        for (int k = 1; k < 8; k++) {
          if (k != j) others += e[k];
        }
        if (e[j] == 1 && others == 0) stress += coefs[r];
      }
      if (fabs(stress) > MJFX_REST_STRESS_RTOL * scale) {
        rc = mjfx_fail(err, errsz, head, "the terms sigma^k z_%d exert a generalized force %.6g at rest: the element "
                       "would be stressed at rest. Their coefficients must add up to zero", j, stress);
      }
    }
  }
  if (!rc) {
    double H[36], KH[36];
    rest_stiffness(method, exps, coefs, nt, H);
    int any = 0;
    for (int i = 0; i < 36; i++) {
      KH[i] = K6[i] + H[i];
      any |= H[i] != 0.0;
    }
    char problem[600];
    if (any && mjfx_check_matrix(KH, 6, "K + the terms' stiffness at rest", 1, problem, sizeof(problem))) {
      rc = mjfx_fail(err, errsz, head, "%s. Fix K or the terms", problem);
    }
  }
  if (rc) {
    free(exps), free(coefs);
    return rc;
  }
  *exps_out = exps, *coefs_out = coefs, *nterms = nt, *top_out = top;
  return 0;
}


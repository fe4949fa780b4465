// Parsing and validation of an mjflex.flexure instance's configuration (see config.h).

#include "config.h"

#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

const char* const MJFX_ATTRIBUTES[MJFX_NATTRIBUTE] = {
    "site_a", "site_b", "method", "K", "B", "order", "exponents", "coefficients",
    "enabled", "viscous", "strain_per_radian", "strain_scale", "source", "stop_lower", "stop_upper", "stop_stiffness",
    "stop_damping", "rest_pos", "rest_quat", "site",
};

enum { A_SITE_A, A_SITE_B, A_METHOD, A_K, A_B, A_ORDER, A_EXPONENTS, A_COEFFICIENTS, A_ENABLED, A_VISCOUS, A_STRAIN,
       A_STRAIN_SCALE, A_SOURCE, A_STOP_LOWER, A_STOP_UPPER, A_STOP_STIFFNESS, A_STOP_DAMPING, A_REST_POS, A_REST_QUAT,
       A_SITE };

// planar coordinates [theta_z; x; y] within [rx, ry, rz, x, y, z] (mjflex.core.stops.PLANAR_INDEX)
static const int PLANAR_INDEX[3] = {2, 3, 4};

void mjfx_element_head(const char* name, int form, char* out, int size) {
  if (form == MJFX_FORM_RECORD) {
    snprintf(out, size, "flexure '%.200s': ", name);
  } else {
    snprintf(out, size, "mjflex: flexure '%.200s' (plugin instance of %s): ", name, MJFX_PLUGIN_NAME);
  }
}

// the message: head (mjfx_element_head) and the problem; returns -1
static int fail(char* err, int errsz, const char* head, const char* fmt, ...) {
  int len = snprintf(err, errsz, "%s", head);
  if (len >= 0 && len < errsz) {
    va_list args;
    va_start(args, fmt);
    vsnprintf(err + len, errsz - len, fmt, args);
    va_end(args);
  }
  return -1;
}

//------------------------------------------------------------------------------ tokens

static const char* skip_space(const char* s) {
  while (*s && isspace((unsigned char)*s)) s++;
  return s;
}

// copy the token at s (up to white space) into out, shortened to fit
static void token_text(const char* s, char* out, int size) {
  int i = 0;
  while (s[i] && !isspace((unsigned char)s[i]) && i < size - 1 && i < 40) {
    out[i] = s[i];
    i++;
  }
  out[i] = 0;
  if (s[i] && !isspace((unsigned char)s[i])) snprintf(out + (i > size - 4 ? size - 4 : i), 4, "...");
}

// Parse white-space separated numbers; stores at most max, returns how many there are, or -1
// for a token that is not a number (copied into bad).
static int parse_numbers(const char* s, double* out, int max, char* bad, int badsz) {
  int n = 0;
  for (s = skip_space(s); *s; s = skip_space(s)) {
    char* end;
    errno = 0;
    double v = strtod(s, &end);
    if (end == s || (*end && !isspace((unsigned char)*end))) {
      token_text(s, bad, badsz);
      return -1;
    }
    if (n < max) out[n] = v;
    n++;
    s = end;
  }
  return n;
}

// Parse white-space separated integers (no sign, decimals or exponents); as parse_numbers.
static int parse_ints(const char* s, int* out, int max, char* bad, int badsz) {
  int n = 0;
  for (s = skip_space(s); *s; s = skip_space(s)) {
    const char* p = s;
    if (*p == '+' || *p == '-') p++;
    const char* digits = p;
    while (isdigit((unsigned char)*p)) p++;
    if (p == digits || (*p && !isspace((unsigned char)*p)) || p - digits > 9) {
      token_text(s, bad, badsz);
      return -1;
    }
    if (n < max) out[n] = (int)strtol(s, NULL, 10);
    n++;
    s = p;
  }
  return n;
}

static int is_blank(const char* s) {
  return *skip_space(s) == 0;
}

// "true", "false" or empty (default); -1 otherwise
static int parse_bool(const char* s, int fallback) {
  const char* p = skip_space(s);
  if (!*p) return fallback;
  size_t len = strlen(p);
  while (len && isspace((unsigned char)p[len - 1])) len--;
  if (len == 4 && !strncmp(p, "true", 4)) return 1;
  if (len == 5 && !strncmp(p, "false", 5)) return 0;
  return -1;
}

//------------------------------------------------------------------------------ matrices

double mjfx_min_eigenvalue(const double* M, int n) {
  if (!M || n < 1 || n > 6) return NAN;  // a ctypes caller's n: never past the 6 x 6 below
  double a[6][6];
  for (int i = 0; i < n; i++) {
    for (int j = 0; j < n; j++) a[i][j] = M[n * i + j];
  }
  for (int sweep = 0; sweep < 100; sweep++) {
    double off = 0.0, scale = 0.0;
    for (int i = 0; i < n; i++) {
      scale += a[i][i] * a[i][i];
      for (int j = i + 1; j < n; j++) off += a[i][j] * a[i][j];
    }
    if (off <= 1e-40 * scale || off == 0.0) break;
    for (int p = 0; p < n; p++) {
      for (int q = p + 1; q < n; q++) {
        if (a[p][q] == 0.0) continue;
        double theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
        double t = (theta >= 0 ? 1.0 : -1.0) / (fabs(theta) + sqrt(theta * theta + 1.0));
        double c = 1.0 / sqrt(t * t + 1.0), s = t * c;
        for (int k = 0; k < n; k++) {  // columns p, q
          double akp = a[k][p], akq = a[k][q];
          a[k][p] = c * akp - s * akq;
          a[k][q] = s * akp + c * akq;
        }
        for (int k = 0; k < n; k++) {  // rows p, q
          double apk = a[p][k], aqk = a[q][k];
          a[p][k] = c * apk - s * aqk;
          a[q][k] = s * apk + c * aqk;
        }
      }
    }
  }
  double lo = a[0][0];
  for (int i = 1; i < n; i++) lo = fmin(lo, a[i][i]);
  return lo;
}

int mjfx_check_matrix(const double* M, int n, const char* key, int stiffness, char* err, int errsz) {
  if (n != 3 && n != 6) {
    snprintf(err, errsz, "%s is %dx%d: give a 3x3 or a 6x6 matrix", key, n, n);
    return -1;
  }
  for (int i = 0; i < n * n; i++) {
    if (!isfinite(M[i])) {
      snprintf(err, errsz, "%s[%d, %d] = %g is not finite; give finite numbers", key, i / n, i % n, M[i]);
      return -1;
    }
  }
  for (int i = 0; i < n * n; i++) {
    if (fabs(M[i]) > MJFX_MAX_MATRIX_ENTRY) {
      snprintf(err, errsz,
               "%s[%d, %d] = %.3g is beyond %g, where the element's energy and forces overflow float64 for "
               "displacements MuJoCo accepts; check its units (SI: N m/rad, N/m)",
               key, i / n, i % n, M[i], MJFX_MAX_MATRIX_ENTRY);
      return -1;
    }
  }
  const char* what = stiffness ? "stiffness" : "damping";
  for (int i = 0; i < n; i++) {
    for (int j = 0; j < n; j++) {
      double scale = sqrt(fabs(M[n * i + i])) * sqrt(fabs(M[n * j + j]));
      double asym = fabs(M[n * i + j] - M[n * j + i]) / fmax(scale, 2.2250738585072014e-308);
      if (asym > MJFX_SYMMETRY_RTOL) {
        snprintf(err, errsz,
                 "%s is not symmetric: %s[%d, %d] = %.6g but %s[%d, %d] = %.6g (relative asymmetry %.3g > %g). A %s "
                 "matrix must be symmetric; if the difference is round-off, write (M + M^T) / 2",
                 key, key, i, j, M[n * i + j], key, j, i, M[n * j + i], asym, MJFX_SYMMETRY_RTOL, what);
        return -1;
      }
    }
  }
  double scaled[36], s[6];
  for (int i = 0; i < n; i++) {
    double dii = fabs(M[n * i + i]);
    s[i] = dii > 0 ? 1.0 / sqrt(dii) : 1.0;
  }
  for (int i = 0; i < n; i++) {
    for (int j = 0; j < n; j++) scaled[n * i + j] = s[i] * (0.5 * (M[n * i + j] + M[n * j + i])) * s[j];
  }
  double lam = mjfx_min_eigenvalue(scaled, n);
  if (lam < -MJFX_PSD_RTOL) {
    snprintf(err, errsz,
             "%s is not positive semi-definite: its smallest eigenvalue relative to its diagonal is %.3g (tolerance "
             "%g). A %s matrix must be positive semi-definite: %s",
             key, lam, MJFX_PSD_RTOL, what,
             stiffness ? "check the signs of the coupling block K_c (rows 0-2, columns 3-5 for 6x6; row 0, columns "
                         "1-2 for 3x3)"
                       : "a damping with an indefinite symmetric part generates energy; check its signs");
    return -1;
  }
  return 0;
}

// a K or B given as 3/6/9/36 numbers into a 6x6 matrix; *planar set from the count
static int read_matrix(const char* name, const char* key, const char* text, int want_planar, double M6[36],
                       int* planar, double* given, char* err, int errsz) {
  double v[36];
  char bad[48];
  int n = parse_numbers(text, v, 36, bad, sizeof(bad));
  if (n < 0) {
    return fail(err, errsz, name, "%s has '%s', which is not a number. Write %s as numbers separated by spaces",
                key, bad, key);
  }
  int ok = want_planar < 0 ? (n == 3 || n == 6 || n == 9 || n == 36)
                           : (want_planar ? (n == 3 || n == 9) : (n == 6 || n == 36));
  if (!ok) {
    const char* allowed = want_planar < 0 ? "6 numbers (the diagonal) or 36 (a 6x6 matrix, row-major) for a spatial "
                                            "element, 3 or 9 for a planar one [theta_z; x; y]"
                          : want_planar ? "3 or 9 numbers, as K (a planar element)"
                                        : "6 or 36 numbers, as K (a spatial element)";
    return fail(err, errsz, name, "%s has %d numbers. Give %s", key, n, allowed);
  }
  int dim = (n == 3 || n == 9) ? 3 : 6;
  double M[36] = {0};
  if (n == dim) {
    for (int i = 0; i < dim; i++) M[dim * i + i] = v[i];
  } else {
    memcpy(M, v, sizeof(double) * dim * dim);
  }
  if (given) memcpy(given, M, sizeof(double) * dim * dim);
  char problem[600];
  if (mjfx_check_matrix(M, dim, key, key[0] == 'K', problem, sizeof(problem))) {
    return fail(err, errsz, name, "%s. Fix its %s attribute", problem, key);
  }
  memset(M6, 0, 36 * sizeof(double));
  if (dim == 3) {
    for (int i = 0; i < 3; i++) {
      for (int j = 0; j < 3; j++) M6[6 * PLANAR_INDEX[i] + PLANAR_INDEX[j]] = M[3 * i + j];
    }
  } else {
    memcpy(M6, M, 36 * sizeof(double));
  }
  *planar = dim == 3;
  return 0;
}

//------------------------------------------------------------------------------ polynomial terms

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
static int check_repeats(const char* name, const int* exps, int nt, char* err, int errsz) {
  if (nt < 2) return 0;
  mjfxTermKey* keys = malloc(sizeof(mjfxTermKey) * nt);
  if (!keys) return fail(err, errsz, name, "out of memory for %d terms", nt);
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
  return fail(err, errsz, name, "exponents row %d repeats row %d: list each term once (add the coefficients)", first,
              earliest);
}

static int parse_terms(const char* name, const char* const* values, int method, const double K6[36],
                       mjfxParsed* out, char* err, int errsz) {
  const char* es = values[A_EXPONENTS];
  const char* cs = values[A_COEFFICIENTS];
  const char* os = values[A_ORDER];
  int nvar = method == MJFX_TWIST ? 6 : 8;
  char bad[48];
  int order = 2;
  if (!is_blank(os)) {
    int o;
    int k = parse_ints(os, &o, 1, bad, sizeof(bad));
    if (k != 1 || o < 2 || (method == MJFX_DUALQUAT && o % 2)) {
      return fail(err, errsz, name, "order must be an integer >= 2%s; got '%.40s'. Fix its order attribute",
                  method == MJFX_DUALQUAT ? " and even for a dualquat element (its potential is even in q)" : "",
                  skip_space(os));
    }
    order = o;
  }
  int ne = parse_ints(es, NULL, 0, bad, sizeof(bad));
  if (ne < 0) {
    return fail(err, errsz, name, "exponents has '%s', which is not an integer. Write the exponents as integers",
                bad);
  }
  int nc = parse_numbers(cs, NULL, 0, bad, sizeof(bad));
  if (nc < 0) {
    return fail(err, errsz, name, "coefficients has '%s', which is not a number", bad);
  }
  if (ne == 0 && nc == 0) {
    if (order != 2) {
      return fail(err, errsz, name, "order is %d but there are no terms; add exponents and coefficients or drop "
                  "order", order);
    }
    return 0;
  }
  if (ne % nvar) {
    return fail(err, errsz, name, "exponents has %d integers, not a multiple of %d: give one row of %d exponents "
                "(%s) per term", ne, nvar, nvar,
                method == MJFX_TWIST ? "tau_1 tau_2 tau_3 t_1 t_2 t_3" : "sigma xi_1 xi_2 xi_3 s' x'_1 x'_2 x'_3");
  }
  int nt = ne / nvar;
  if (nc != nt) {
    return fail(err, errsz, name, "%d rows of exponents but %d coefficients: give one coefficient per term", nt, nc);
  }
  if (nt > MJFX_MAX_TERMS) {
    return fail(err, errsz, name, "%d terms are more than mjflex handles (%d)", nt, MJFX_MAX_TERMS);
  }
  if (is_blank(os)) {
    return fail(err, errsz, name, "terms need the order of the potential (the highest degree of its terms); add "
                "the order attribute");
  }
  int* raw = malloc(sizeof(int) * ne);
  int* exps = calloc((size_t)nt * MJFX_TERM_COLUMNS, sizeof(int));
  double* coefs = malloc(sizeof(double) * nt);
  if (!raw || !exps || !coefs) {
    free(raw), free(exps), free(coefs);
    return fail(err, errsz, name, "out of memory for %d terms", nt);
  }
  parse_ints(es, raw, ne, bad, sizeof(bad));
  parse_numbers(cs, coefs, nt, bad, sizeof(bad));
  int rc = 0, top = 0;
  double scale = 0.0;
  for (int r = 0; r < nt && !rc; r++) {
    int deg = 0;
    for (int k = 0; k < nvar; k++) {
      int v = raw[nvar * r + k];
      if (v < 0 || v > MJFX_MAX_EXPONENT) {
        rc = fail(err, errsz, name, "exponents row %d has %d: exponents must be integers in [0, %d]", r, v,
                  MJFX_MAX_EXPONENT);
        break;
      }
      exps[MJFX_TERM_COLUMNS * r + k] = v;
      deg += v;
      if (v > top) top = v;
    }
    if (rc) break;
    if (!isfinite(coefs[r])) {
      rc = fail(err, errsz, name, "coefficient %d is %g: coefficients must be finite", r, coefs[r]);
    } else if (deg < 2) {
      rc = fail(err, errsz, name, "exponents row %d is a %s term: the constant is arbitrary and linear terms stress "
                "the element at rest; drop it (terms start at degree 2)", r, deg == 0 ? "constant" : "linear");
    } else if (method == MJFX_DUALQUAT && deg % 2) {
      rc = fail(err, errsz, name, "exponents row %d has odd degree %d: q and -q are the same displacement, so "
                "dual-quaternion potentials are even; use terms of even degree", r, deg);
    } else if (deg > order) {
      rc = fail(err, errsz, name, "exponents row %d has degree %d, above order %d; raise order or drop the term", r,
                deg, order);
    }
    scale += fabs(coefs[r]);
  }
  if (!rc) rc = check_repeats(name, exps, nt, err, errsz);
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
        rc = fail(err, errsz, name, "the terms sigma^k z_%d exert a generalized force %.6g at rest: the element "
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
      rc = fail(err, errsz, name, "%s. Fix K or the terms", problem);
    }
  }
  free(raw);
  if (rc) {
    free(exps), free(coefs);
    return rc;
  }
  out->exps = exps, out->coefs = coefs, out->nterms = nt;
  out->el.terms_top = top;
  return 0;
}

//------------------------------------------------------------------------------ end stops

static const char* const STOP_COORDINATES[2][6] = {{"rx", "ry", "rz", "x", "y", "z"}, {"theta", "x", "y"}};
static const char* const STOP_KEYS[2] = {"stop_lower", "stop_upper"};

// The stops' damping (stop_damping: empty, 1 number or one per coordinate; finite, >= 0) into e->stop_b (embedded
// like stop_k; 0 where a coordinate has no limit) and e->stop_damped (some coordinate with a limit is damped). lim:
// the limits parse_stops read (n of each).
static int parse_stop_damping(const char* name, const char* text, int planar, double lim[2][6], mjfxElement* e,
                              char* err, int errsz) {
  int n = planar ? 3 : 6;
  const char* const* coord = STOP_COORDINATES[planar ? 1 : 0];
  double b[6];
  char bad[48];
  for (int i = 0; i < 6; i++) e->stop_b[i] = 0.0;
  e->stop_damped = 0;
  if (is_blank(text)) return 0;
  int count = parse_numbers(text, b, 6, bad, sizeof(bad));
  if (count < 0) return fail(err, errsz, name, "stop_damping has '%s', which is not a number", bad);
  if (count != 1 && count != n) {
    return fail(err, errsz, name, "stop_damping has %d numbers; give 1 (every coordinate) or %d (one per coordinate "
                "%s) [N m s/rad, N s/m], or drop it for conservative stops", count, n,
                planar ? "[theta x y]" : "[rx ry rz x y z]");
  }
  for (int i = 1; i < n && count == 1; i++) b[i] = b[0];
  for (int i = 0; i < n; i++) {
    if (!isfinite(b[i]) || b[i] < 0 || b[i] > MJFX_MAX_MATRIX_ENTRY) {
      return fail(err, errsz, name, "stop_damping of %s is %g; give a finite number >= 0 (at most %g) [N m s/rad, "
                  "N s/m]", coord[i], b[i], MJFX_MAX_MATRIX_ENTRY);
    }
    int j = planar ? PLANAR_INDEX[i] : i, limited = isfinite(lim[0][i]) || isfinite(lim[1][i]);
    e->stop_b[j] = limited ? b[i] : 0.0;
    e->stop_damped |= limited && b[i] > 0;
  }
  return 0;
}

// The rest pose (rest_pos: 3 numbers [m]; rest_quat: 4, a unit quaternion w-first, norm 1 within
// MJFX_REST_QUAT_TOL, normalized here) into out; out->has_rest when either is given (the other: identity).
static int parse_rest(const char* name, const char* const* values, mjfxParsed* out, char* err, int errsz) {
  static const double identity[7] = {0, 0, 0, 1, 0, 0, 0};
  memcpy(out->rest_pos, identity, 3 * sizeof(double));
  memcpy(out->rest_quat, identity + 3, 4 * sizeof(double));
  out->has_rest = 0;
  static const char* const KEYS[2] = {"rest_pos", "rest_quat"};
  static const char* const WHAT[2] = {"the position of frame b in frame a at rest [m]",
                                      "the orientation of frame b in frame a at rest, a unit quaternion w x y z"};
  double* dest[2] = {out->rest_pos, out->rest_quat};
  for (int s = 0; s < 2; s++) {
    const char* text = values[A_REST_POS + s];
    if (is_blank(text)) continue;
    int want = s ? 4 : 3;
    double v[4];
    char bad[48];
    int count = parse_numbers(text, v, 4, bad, sizeof(bad));
    if (count < 0) return fail(err, errsz, name, "%s has '%s', which is not a number; give %s", KEYS[s], bad, WHAT[s]);
    if (count != want) {
      return fail(err, errsz, name, "%s has %d numbers; give %d: %s", KEYS[s], count, want, WHAT[s]);
    }
    for (int i = 0; i < want; i++) {
      if (!isfinite(v[i]) || fabs(v[i]) > MJFX_MAX_MATRIX_ENTRY) {
        return fail(err, errsz, name, "%s has %g; give finite numbers: %s", KEYS[s], v[i], WHAT[s]);
      }
    }
    if (s) {
      double norm = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2] + v[3] * v[3]);
      if (!(fabs(norm - 1.0) <= MJFX_REST_QUAT_TOL)) {
        return fail(err, errsz, name, "rest_quat (%g %g %g %g) has norm %.9g, so it is not a rotation; give a unit "
                    "quaternion w x y z (norm 1 within %g: write enough digits, or normalize it)", v[0], v[1], v[2],
                    v[3], norm, MJFX_REST_QUAT_TOL);
      }
      for (int i = 0; i < 4; i++) v[i] /= norm;
    }
    memcpy(dest[s], v, want * sizeof(double));
    out->has_rest = 1;
  }
  return 0;
}

// The end stops (stop_lower, stop_upper, stop_stiffness; the rules of mjflex.mjcf.stops) into e: limits and
// stiffness on the stop coordinates (planar ones embedded at PLANAR_INDEX), stiffness 0 and limits -inf /
// +inf where a coordinate has no stop; e->stops when any limit is finite. K6: the element's (embedded) K.
static int parse_stops(const char* name, const char* const* values, int planar, const double K6[36], mjfxElement* e,
                       char* err, int errsz) {
  int n = planar ? 3 : 6;
  const char* const* coord = STOP_COORDINATES[planar ? 1 : 0];
  const char* units = planar ? "[theta x y]" : "[rx ry rz x y z]";
  double lim[2][6], k[6];
  char bad[48];
  int any = 0;
  for (int i = 0; i < 6; i++) e->stop_lo[i] = -INFINITY, e->stop_hi[i] = INFINITY, e->stop_k[i] = e->stop_b[i] = 0.0;
  e->stops = e->stop_damped = 0;
  for (int s = 0; s < 2; s++) {
    const char* key = STOP_KEYS[s];
    for (int i = 0; i < 6; i++) lim[s][i] = s ? INFINITY : -INFINITY;
    const char* text = values[A_STOP_LOWER + s];
    if (is_blank(text)) continue;
    int count = parse_numbers(text, lim[s], 6, bad, sizeof(bad));
    if (count < 0) {
      return fail(err, errsz, name, "%s has '%s', which is not a number. Give one limit per coordinate %s [rad, m], "
                  "%s where a coordinate has no stop", key, bad, units, s ? "inf" : "-inf");
    }
    if (count != n) {
      return fail(err, errsz, name, "%s has %d numbers; give %d, one per coordinate %s of this %s element (%s "
                  "where a coordinate has no stop)", key, count, n, units, planar ? "planar" : "spatial",
                  s ? "inf" : "-inf");
    }
    for (int i = 0; i < n; i++) {
      double v = lim[s][i];
      if (isnan(v)) {
        return fail(err, errsz, name, "%s of %s is NaN; write %s for a coordinate without a stop", key, coord[i],
                    s ? "inf" : "-inf");
      }
      if (s ? v == -INFINITY : v == INFINITY) {
        return fail(err, errsz, name, "%s of %s is %s, a stop that would push at every pose; write %s for a "
                    "coordinate without a stop", key, coord[i], s ? "-inf" : "inf", s ? "inf" : "-inf");
      }
      int rotation = planar ? i == 0 : i < 3;
      if (rotation && isfinite(v) && fabs(v) > MJFX_PI_TOLERANT) {
        return fail(err, errsz, name, "%s of %s is %g rad, beyond pi: a rotation coordinate (a component of the "
                    "rotation vector) lies in [-pi, pi], so this stop could never act. Give radians (not degrees) "
                    "in [-pi, pi], or %s for no stop", key, coord[i], v, s ? "inf" : "-inf");
      }
      any |= isfinite(v);
    }
  }
  for (int i = 0; i < n; i++) {
    if (lim[0][i] > lim[1][i]) {
      return fail(err, errsz, name, "stop_lower of %s (%g) is above its stop_upper (%g); a range needs lower <= "
                  "upper", coord[i], lim[0][i], lim[1][i]);
    }
  }
  const char* ks = values[A_STOP_STIFFNESS];
  if (!any) {
    if (!is_blank(ks) || !is_blank(values[A_STOP_DAMPING])) {
      const char* key = !is_blank(ks) ? "stop_stiffness" : "stop_damping";
      return fail(err, errsz, name, "%s is given but there is no stop; add stop_lower or stop_upper, or drop %s", key,
                  key);
    }
    return 0;
  }
  int derived = is_blank(ks);
  if (derived) {
    for (int i = 0; i < n; i++) {
      int j = planar ? PLANAR_INDEX[i] : i;
      k[i] = MJFX_STOP_STIFFNESS_FACTOR * K6[7 * j];
    }
  } else {
    int count = parse_numbers(ks, k, 6, bad, sizeof(bad));
    if (count < 0) {
      return fail(err, errsz, name, "stop_stiffness has '%s', which is not a number", bad);
    }
    if (count != 1 && count != n) {
      return fail(err, errsz, name, "stop_stiffness has %d numbers; give 1 (every coordinate) or %d (one per "
                  "coordinate %s) [N m/rad, N/m], or drop it to derive the stiffness from K", count, n, units);
    }
    for (int i = 1; i < n && count == 1; i++) k[i] = k[0];
    for (int i = 0; i < n; i++) {
      if (!isfinite(k[i]) || k[i] < 0 || k[i] > MJFX_MAX_MATRIX_ENTRY) {
        return fail(err, errsz, name, "stop_stiffness of %s is %g; give a finite number >= 0 (at most %g)",
                    coord[i], k[i], MJFX_MAX_MATRIX_ENTRY);
      }
    }
  }
  for (int i = 0; i < n; i++) {
    int j = planar ? PLANAR_INDEX[i] : i, limited = isfinite(lim[0][i]) || isfinite(lim[1][i]);
    if (limited && !(k[i] > 0)) {
      if (derived) {
        return fail(err, errsz, name, "the stop on %s needs a stiffness: K[%d, %d] is 0, so none can be derived from "
                    "it (%g x K_ii); give stop_stiffness", coord[i], i, i, MJFX_STOP_STIFFNESS_FACTOR);
      }
      return fail(err, errsz, name, "stop_stiffness of %s is 0, so its stop would do nothing; give it a positive "
                  "stiffness or drop the limit", coord[i]);
    }
    e->stop_lo[j] = lim[0][i], e->stop_hi[j] = lim[1][i], e->stop_k[j] = limited ? k[i] : 0.0;
  }
  e->stops = 1;
  return parse_stop_damping(name, values[A_STOP_DAMPING], planar, lim, e, err, errsz);
}

//------------------------------------------------------------------------------ JSON

typedef struct {
  const char* s;
  int depth;
} Json;

static int json_value(Json* j);

static void json_space(Json* j) {
  while (*j->s == ' ' || *j->s == '\t' || *j->s == '\n' || *j->s == '\r') j->s++;
}

static int json_string(Json* j) {
  if (*j->s != '"') return 0;
  for (j->s++; *j->s != '"'; j->s++) {
    unsigned char c = (unsigned char)*j->s;
    if (c < 0x20) return 0;
    if (c == '\\') {
      j->s++;
      if (*j->s == 'u') {
        for (int k = 1; k <= 4; k++) {
          if (!isxdigit((unsigned char)j->s[k])) return 0;
        }
        j->s += 4;
      } else if (!strchr("\"\\/bfnrt", *j->s) || !*j->s) {
        return 0;
      }
    }
  }
  j->s++;
  return 1;
}

static int json_number(Json* j) {
  const char* s = j->s;
  if (*s == '-') s++;
  if (*s == '0') {
    s++;
  } else if (isdigit((unsigned char)*s)) {
    while (isdigit((unsigned char)*s)) s++;
  } else {
    return 0;
  }
  if (*s == '.') {
    s++;
    if (!isdigit((unsigned char)*s)) return 0;
    while (isdigit((unsigned char)*s)) s++;
  }
  if (*s == 'e' || *s == 'E') {
    s++;
    if (*s == '+' || *s == '-') s++;
    if (!isdigit((unsigned char)*s)) return 0;
    while (isdigit((unsigned char)*s)) s++;
  }
  j->s = s;
  return 1;
}

static int json_container(Json* j, char open, char close, int object) {
  if (*j->s != open || ++j->depth > 200) return 0;
  j->s++;
  json_space(j);
  if (*j->s == close) {
    j->s++;
    j->depth--;
    return 1;
  }
  for (;;) {
    json_space(j);
    if (object) {
      if (!json_string(j)) return 0;
      json_space(j);
      if (*j->s++ != ':') return 0;
    }
    if (!json_value(j)) return 0;
    json_space(j);
    if (*j->s == ',') {
      j->s++;
      continue;
    }
    if (*j->s++ != close) return 0;
    j->depth--;
    return 1;
  }
}

static int json_value(Json* j) {
  json_space(j);
  switch (*j->s) {
    case '{': return json_container(j, '{', '}', 1);
    case '[': return json_container(j, '[', ']', 0);
    case '"': return json_string(j);
    case 't': return !strncmp(j->s, "true", 4) ? (j->s += 4, 1) : 0;
    case 'f': return !strncmp(j->s, "false", 5) ? (j->s += 5, 1) : 0;
    case 'n': return !strncmp(j->s, "null", 4) ? (j->s += 4, 1) : 0;
    default: return json_number(j);
  }
}

int mjfx_json_object(const char* text) {
  Json j = {text, 0};
  json_space(&j);
  if (*j.s != '{' || !json_value(&j)) return 0;
  json_space(&j);
  return *j.s == 0;
}

//------------------------------------------------------------------------------ the element

int mjfx_parse_config(const char* element, int form, const char* const* values, mjfxParsed* out, char* err,
                      int errsz) {
  char name[300];  // the messages' head: the static functions above take it as `name`
  mjfx_element_head(element, form, name, sizeof(name));
  mjfxElement* e = &out->el;
  out->exps = NULL, out->coefs = NULL, out->nterms = 0;
  out->strain_per_radian = out->strain_scale = 0;
  const char* method = skip_space(values[A_METHOD]);
  if (!*method || !strcmp(method, "twist")) {
    e->method = MJFX_TWIST;
  } else if (!strcmp(method, "dualquat")) {
    e->method = MJFX_DUALQUAT;
  } else {
    return fail(err, errsz, name, "unknown method '%.40s'. Use method=\"twist\" or \"dualquat\"", method);
  }
  if (is_blank(values[A_K])) {
    return fail(err, errsz, name, "the stiffness K is missing. Add <config key=\"K\" value=\"...\"/>: 6 numbers (the "
                "diagonal) or 36 (a 6x6 matrix, row-major) for a spatial element, 3 or 9 for a planar one");
  }
  int planar = 0, bplanar = 0;
  if (read_matrix(name, "K", values[A_K], -1, e->K, &planar, NULL, err, errsz)) return -1;
  memset(e->B, 0, sizeof(e->B));
  int has_b = !is_blank(values[A_B]);
  if (has_b && read_matrix(name, "B", values[A_B], planar, e->B, &bplanar, NULL, err, errsz)) return -1;
  e->kstruct = mjfx_matrix_structure(e->K);
  e->bstruct = mjfx_matrix_structure(e->B);
  int enabled = parse_bool(values[A_ENABLED], 1), viscous = parse_bool(values[A_VISCOUS], 1);
  if (enabled < 0 || viscous < 0) {
    const char* key = enabled < 0 ? "enabled" : "viscous";
    return fail(err, errsz, name, "%s must be true or false; got '%.40s'", key,
                skip_space(values[enabled < 0 ? A_ENABLED : A_VISCOUS]));
  }
  e->enabled = enabled;
  e->viscous = viscous && has_b;
  if (!is_blank(values[A_STRAIN])) {
    double v;
    char bad[48];
    int k = parse_numbers(values[A_STRAIN], &v, 1, bad, sizeof(bad));
    if (k != 1 || !isfinite(v) || v < 0 || v > MJFX_MAX_MATRIX_ENTRY) {
      return fail(err, errsz, name, "strain_per_radian must be one finite non-negative number; got '%.40s'",
                  skip_space(values[A_STRAIN]));
    }
    out->strain_per_radian = v;
  }
  if (!is_blank(values[A_STRAIN_SCALE])) {
    double v;
    char bad[48];
    int k = parse_numbers(values[A_STRAIN_SCALE], &v, 1, bad, sizeof(bad));
    if (k != 1 || !isfinite(v) || v <= 0 || v > MJFX_MAX_MATRIX_ENTRY) {
      return fail(err, errsz, name, "strain_scale must be one finite positive number (the strain, or rotation in "
                  "rad without strain_per_radian, shown red); got '%.40s'", skip_space(values[A_STRAIN_SCALE]));
    }
    out->strain_scale = v;
  }
  if (!is_blank(values[A_SOURCE]) && !mjfx_json_object(values[A_SOURCE])) {
    return fail(err, errsz, name, "source must be a JSON object such as {\"formula\": \"...\"} (standard JSON: "
                "double quotes, no NaN); got '%.60s'", skip_space(values[A_SOURCE]));
  }
  if (parse_stops(name, values, planar, e->K, e, err, errsz)) return -1;
  if (parse_rest(name, values, out, err, errsz)) return -1;
  e->terms_lo = e->terms_hi = e->terms_top = 0;
  if (parse_terms(name, values, e->method, e->K, out, err, errsz)) return -1;
  e->terms_hi = out->nterms;
  out->planar = planar;
  return 0;
}

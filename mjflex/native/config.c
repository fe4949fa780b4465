// An element's configuration checked across its attributes (see config.h); each attribute's own grammar and
// bounds are the table's (schema.c), the polynomial terms' checks terms.c's.

#include "config.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "matrix.h"
#include "terms.h"

// planar coordinates [theta_z; x; y] within [rx, ry, rz, x, y, z] (mjflex.core.stops.PLANAR_INDEX)
static const int PLANAR_INDEX[3] = {2, 3, 4};

// K or B (attribute row: 3, 6, 9 or 36 numbers; want_planar -1: either size) as its 6x6 embedding M6, *planar
// from its size; the full 3x3 or 6x6 matrix is stored in v as the row's value (for Python). 0 or -1.
static int read_matrix(const char* head, int form, int row, mjfxValues* v, int want_planar, double M6[36],
                       int* planar, char* err, int errsz) {
  const char* key = mjfx_key(row, form);
  int n = v->count[row];
  const double* x = v->num + v->first[row];
  int ok = want_planar < 0 ? (n == 3 || n == 6 || n == 9 || n == 36)
                           : (want_planar ? (n == 3 || n == 9) : (n == 6 || n == 36));
  if (!ok) {
    const char* allowed = want_planar < 0 ? MJFX_SCHEMA[MJFX_A_K].shape
                          : want_planar ? "3 or 9 numbers, as K (a planar element)"
                                        : "6 or 36 numbers, as K (a spatial element)";
    return mjfx_fail(err, errsz, head, "%s has %d numbers. Give %s", key, n, allowed);
  }
  int dim = (n == 3 || n == 9) ? 3 : 6;
  double M[36] = {0};
  if (n == dim) {
    for (int i = 0; i < dim; i++) M[dim * i + i] = x[i];
  } else {
    memcpy(M, x, sizeof(double) * dim * dim);
  }
  char problem[600];
  if (mjfx_check_matrix(M, dim, key, row == MJFX_A_K, problem, sizeof(problem))) {
    return mjfx_fail(err, errsz, head, "%s. Fix %s", problem, key);
  }
  if (mjfx_values_set(v, row, M, dim * dim)) return mjfx_fail(err, errsz, head, "out of memory");
  memset(M6, 0, 36 * sizeof(double));
  for (int i = 0; i < dim; i++) {
    for (int j = 0; j < dim; j++) {
      M6[dim == 3 ? 6 * PLANAR_INDEX[i] + PLANAR_INDEX[j] : 6 * i + j] = M[dim * i + j];
    }
  }
  *planar = dim == 3;
  return 0;
}

//------------------------------------------------------------------------------ end stops

// The end stops (stop_lower, stop_upper, stop_stiffness, stop_damping) into e: limits, stiffness and damping on the
// stop coordinates (planar ones embedded at PLANAR_INDEX), stiffness and damping 0 and limits -inf / +inf where a
// coordinate has no stop; e->stops when any limit is finite. planar: -1 without K (the arguments form: the
// coordinates from the limits, no stiffness derived). K6: the element's (embedded) K.
static int check_stops(const char* head, int form, const mjfxValues* v, int planar, const double K6[36],
                       mjfxElement* e, char* err, int errsz) {
  const int rows[4] = {MJFX_A_STOP_LOWER, MJFX_A_STOP_UPPER, MJFX_A_STOP_STIFFNESS, MJFX_A_STOP_DAMPING};
  const char* key[4];
  for (int s = 0; s < 4; s++) key[s] = mjfx_key(rows[s], form);
  for (int i = 0; i < 6; i++) e->stop_lo[i] = -INFINITY, e->stop_hi[i] = INFINITY, e->stop_k[i] = e->stop_b[i] = 0;
  e->stops = e->stop_damped = 0;
  int given[2] = {v->count[rows[0]], v->count[rows[1]]};
  if (planar < 0) {  // no K: the limits give the coordinates
    for (int s = 0; s < 2; s++) {
      if (given[s] >= 0 && given[s] != 3 && given[s] != 6) {
        return mjfx_fail(err, errsz, head, "%s has %d limits: give one per coordinate, 6 %s for a spatial element, 3 "
                         "%s for a planar one", key[s], given[s], MJFX_COORDINATE_LIST[0], MJFX_COORDINATE_LIST[1]);
      }
    }
    if (given[0] >= 0 && given[1] >= 0 && given[0] != given[1]) {
      return mjfx_fail(err, errsz, head, "%s has %d limits but %s %d; give one per coordinate to both", key[0],
                       given[0], key[1], given[1]);
    }
    planar = (given[0] >= 0 ? given[0] : given[1]) == 3;
  }
  int n = planar ? 3 : 6, any = 0;
  const char* const* coord = MJFX_COORDINATES[planar];
  double lim[2][6];
  for (int s = 0; s < 2; s++) {
    for (int i = 0; i < 6; i++) lim[s][i] = s ? INFINITY : -INFINITY;
    if (given[s] < 0) continue;
    if (given[s] != n) {
      return mjfx_fail(err, errsz, head, "%s has %d limits but the element is %s: give %d, one per coordinate %s (%s "
                       "where a coordinate has no stop)", key[s], given[s], planar ? "planar" : "spatial", n,
                       MJFX_COORDINATE_LIST[planar], s ? "inf" : "-inf");
    }
    for (int i = 0; i < n; i++) {
      double x = v->num[v->first[rows[s]] + i];
      if (isnan(x)) {
        return mjfx_fail(err, errsz, head, "%s of %s is NaN; write %s (a record: null) for a coordinate without a "
                         "stop", key[s], coord[i], s ? "inf" : "-inf");
      }
      if (s ? x == -INFINITY : x == INFINITY) {
        return mjfx_fail(err, errsz, head, "%s of %s is %s, a stop that would push at every pose; write %s (a "
                         "record: null) for a coordinate without a stop", key[s], coord[i], s ? "-inf" : "inf",
                         s ? "inf" : "-inf");
      }
      if ((planar ? i == 0 : i < 3) && isfinite(x) && fabs(x) > MJFX_PI_TOLERANT) {
        return mjfx_fail(err, errsz, head, "%s of %s is %g rad, beyond pi: a rotation coordinate (a component of "
                         "the rotation vector) lies in [-pi, pi], so this stop could never act. Give radians (not "
                         "degrees) in [-pi, pi], or no stop", key[s], coord[i], x);
      }
      lim[s][i] = x;
      any |= isfinite(x);
    }
  }
  for (int i = 0; i < n; i++) {
    if (lim[0][i] > lim[1][i]) {
      return mjfx_fail(err, errsz, head, "%s of %s (%g) is above its %s (%g); a range needs lower <= upper", key[0],
                       coord[i], lim[0][i], key[1], lim[1][i]);
    }
  }
  for (int s = 2; s < 4; s++) {
    if (!any && v->count[rows[s]] >= 0) {
      return mjfx_fail(err, errsz, head, "%s is given but there is no stop; add %s or %s, or drop %s", key[s], key[0],
                       key[1], key[s]);
    }
  }
  if (!any) return 0;
  double k[6], b[6] = {0};
  for (int s = 2; s < 4; s++) {  // given: one number for every coordinate, or one each (counts: the table's)
    int count = v->count[rows[s]];
    for (int i = 0; i < n && count > 0; i++) (s == 2 ? k : b)[i] = v->num[v->first[rows[s]] + (count == 1 ? 0 : i)];
  }
  int derived = v->count[rows[2]] < 0;
  for (int i = 0; i < n; i++) {
    int j = planar ? PLANAR_INDEX[i] : i, limited = isfinite(lim[0][i]) || isfinite(lim[1][i]);
    if (derived && K6) k[i] = MJFX_STOP_STIFFNESS_FACTOR * K6[7 * j];
    if (limited && derived && K6 && !(k[i] > 0 && k[i] <= MJFX_MAX_MATRIX_ENTRY)) {
      if (k[i] > 0) {
        return mjfx_fail(err, errsz, head, "the stop on %s would derive its stiffness %g x K[%d, %d] = %g, beyond "
                         "%g (the stops' stiffness's bound); give %s", coord[i], MJFX_STOP_STIFFNESS_FACTOR, i, i, k[i],
                         MJFX_MAX_MATRIX_ENTRY, key[2]);
      }
      return mjfx_fail(err, errsz, head, "the stop on %s needs a stiffness: K[%d, %d] is 0, so none can be derived "
                       "from it (%g x K_ii); give %s", coord[i], i, i, MJFX_STOP_STIFFNESS_FACTOR, key[2]);
    }
    if (limited && !derived && !(k[i] > 0)) {
      return mjfx_fail(err, errsz, head, "%s of %s is 0, so its stop would do nothing; give it a positive stiffness or "
                       "drop the limit", key[2], coord[i]);
    }
    e->stop_lo[j] = lim[0][i], e->stop_hi[j] = lim[1][i];
    e->stop_k[j] = limited && K6 ? k[i] : 0.0;
    e->stop_b[j] = limited ? b[i] : 0.0;
    e->stop_damped |= limited && b[i] > 0;
  }
  e->stops = 1;
  return 0;
}

//------------------------------------------------------------------------------ the element

// The rest pose (rest_pos, rest_quat; their counts and finiteness: the table's) into out: the quaternion must be a
// rotation (norm 1 within MJFX_REST_QUAT_TOL; normalized here).
static int check_rest(const char* head, int form, const mjfxValues* v, mjfxParsed* out, char* err, int errsz) {
  static const double identity[7] = {0, 0, 0, 1, 0, 0, 0};
  memcpy(out->rest_pos, identity, 3 * sizeof(double));
  memcpy(out->rest_quat, identity + 3, 4 * sizeof(double));
  out->has_rest = v->count[MJFX_A_REST_POS] >= 0 || v->count[MJFX_A_REST_QUAT] >= 0;
  if (v->count[MJFX_A_REST_POS] >= 0) memcpy(out->rest_pos, v->num + v->first[MJFX_A_REST_POS], 3 * sizeof(double));
  if (v->count[MJFX_A_REST_QUAT] < 0) return 0;
  const double* q = v->num + v->first[MJFX_A_REST_QUAT];
  double norm = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  if (!(fabs(norm - 1.0) <= MJFX_REST_QUAT_TOL)) {
    return mjfx_fail(err, errsz, head, "%s (%g %g %g %g) has norm %.9g, so it is not a rotation; give a unit "
                     "quaternion w x y z (norm 1 within %g: write enough digits, or normalize it)",
                     mjfx_key(MJFX_A_REST_QUAT, form), q[0], q[1], q[2], q[3], norm, MJFX_REST_QUAT_TOL);
  }
  for (int i = 0; i < 4; i++) out->rest_quat[i] = q[i] / norm;
  return 0;
}

void mjfx_free_parsed(mjfxParsed* p) {
  free(p->exps);
  free(p->coefs);
  mjfx_free_values(&p->values);
  p->exps = NULL, p->coefs = NULL, p->nterms = 0;
}

int mjfx_parse_config(const char* element, int form, const char* const* values, mjfxParsed* out, char* err,
                      int errsz) {
  char head[300];
  mjfx_element_head(element, form, head, sizeof(head));
  memset(out, 0, sizeof(mjfxParsed));
  mjfxValues* v = &out->values;
  if (mjfx_read_values(head, form, values, form == MJFX_FORM_ARGUMENTS, v, err, errsz)) return -1;
  mjfxElement* e = &out->el;
  e->method = v->count[MJFX_A_METHOD] > 0 ? (int)v->num[v->first[MJFX_A_METHOD]] : MJFX_TWIST;  // choices' order
  e->enabled = v->count[MJFX_A_ENABLED] > 0 ? (int)v->num[v->first[MJFX_A_ENABLED]] : 1;
  int viscous = v->count[MJFX_A_VISCOUS] > 0 ? (int)v->num[v->first[MJFX_A_VISCOUS]] : 1;
  int planar = -1, bplanar, rc = 0, has_k = v->count[MJFX_A_K] >= 0;  // no K: the arguments form
  if (has_k) rc = read_matrix(head, form, MJFX_A_K, v, -1, e->K, &planar, err, errsz);
  int has_b = v->count[MJFX_A_B] >= 0;
  if (!rc && has_b) rc = read_matrix(head, form, MJFX_A_B, v, planar, e->B, &bplanar, err, errsz);
  e->kstruct = mjfx_matrix_structure(e->K);
  e->bstruct = mjfx_matrix_structure(e->B);
  e->viscous = viscous && has_b;
  if (!rc) rc = check_stops(head, form, v, planar, has_k ? e->K : NULL, e, err, errsz);
  if (!rc) rc = check_rest(head, form, v, out, err, errsz);
  if (!rc && has_k) {
    rc = mjfx_parse_terms(head, form, v, e->method, e->K, &out->exps, &out->coefs, &out->nterms, &e->terms_top, err,
                          errsz);
  }
  if (rc) {
    mjfx_free_parsed(out);
    return -1;
  }
  e->terms_lo = 0, e->terms_hi = out->nterms;
  out->planar = planar == 1;
  return 0;
}

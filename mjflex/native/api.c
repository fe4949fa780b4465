// Entry points for Python (ctypes, mjflex/native/library.py): the element struct's layout, the
// table of a model's elements (both forms, read by instances.c), the configuration check, the
// shared constants, batch versions of the element math (tested against mjflex.core), and the
// watch's contents.

#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <mujoco/mjplugin.h>

#include "api.h"
#include "config.h"
#include "elements.h"
#include "flexure_math.h"
#include "instances.h"
#include "matrix.h"
#include "terms.h"

#define FIELD(name) {#name, offsetof(mjfxElement, name)}
static const struct {
  const char* name;
  size_t offset;
} FIELDS[] = {
    FIELD(site_a),   FIELD(site_b),   FIELD(body_a),   FIELD(body_b),    FIELD(method),   FIELD(enabled),
    FIELD(viscous),  FIELD(offset),   FIELD(free_a),   FIELD(free_b),    FIELD(chain_a0), FIELD(chain_a1),
    FIELD(chain_b0), FIELD(chain_b1), FIELD(terms_lo), FIELD(terms_hi),  FIELD(terms_top), FIELD(kstruct),
    FIELD(bstruct),  FIELD(qa),       FIELD(qb),       FIELD(p0),        FIELD(lever_a),  FIELD(lever_b),
    FIELD(inv_mass), FIELD(inv_inertia), FIELD(kdiag), FIELD(bdiag),     FIELD(K),        FIELD(B),
    FIELD(R0),       FIELD(stops),    FIELD(stop_lo),  FIELD(stop_hi),  FIELD(stop_k),   FIELD(stop_damped),
    FIELD(rest),     FIELD(stop_b),
};

// byte offset of a field of mjfxElement (-1: no such field); sizeof with name NULL
long mjfx_element_field(const char* name) {
  if (!name) return (long)sizeof(mjfxElement);
  for (size_t i = 0; i < sizeof(FIELDS) / sizeof(FIELDS[0]); i++) {
    if (!strcmp(FIELDS[i].name, name)) return (long)FIELDS[i].offset;
  }
  return -1;
}

// whether plugin instance i of m is an mjflex.flexure instance
int mjfx_is_instance(const mjModel* m, int i) {
  if (i < 0 || i >= m->nplugin) return 0;
  const mjpPlugin* p = mjp_getPluginAtSlot(m->plugin[i]);
  return p && p->name && !strcmp(p->name, MJFX_PLUGIN_NAME);
}

// the plugin's configuration attributes, in order (NULL past the end)
const char* mjfx_attribute(int i) {
  return i >= 0 && i < MJFX_NATTRIBUTE ? MJFX_SCHEMA[i].key : NULL;
}

//------------------------------------------------------------------------------ argument checks
// Python passes these functions its own, validated tables; the checks keep a wrong argument from a ctypes
// caller from reading or writing past an array (tests/test_native_lifecycle.py calls each with bad ones).

// the terms' arguments: nterms >= 0 rows of exponents in [0, top] (the columns the method reads), top in
// [0, MJFX_MAX_EXPONENT] (the kernel's table of powers)
static int terms_ok(int method, const int* exps, int nterms, int top) {
  if (nterms < 0 || top < 0 || top > MJFX_MAX_EXPONENT) return 0;
  if (!nterms) return 1;
  if (!exps) return 0;
  int nvar = method == MJFX_TWIST ? 6 : 8;
  for (long r = 0; r < nterms; r++) {
    for (int k = 0; k < nvar; k++) {
      int e = exps[MJFX_TERM_COLUMNS * r + k];
      if (e < 0 || e > top) return 0;
    }
  }
  return 1;
}

static void fill_nan(double* out, long count) {
  for (long i = 0; out && i < count; i++) out[i] = NAN;
}

// a free joint's dof address (6 dofs from it) or -1
static int free_ok(const mjModel* m, int adr) {
  return adr == -1 || (adr >= 0 && adr <= m->nv - 6);
}

// The first row of an element table that could make mjfx_evaluate read or write outside the arrays of
// model m (sizes and indices), or of chain (nchain dof ids in [0, nv)) and the terms' tables (nterms
// rows); -1 when every row is sound. A size < 0 or a missing array: 0.
int mjfx_check_rows(const mjModel* m, const mjfxElement* el, int n, const int* chain, int nchain, const int* exps,
                    const double* coefs, int nterms) {
  if (!m || n < 0 || nchain < 0 || nterms < 0 || (n && !el) || (nchain && !chain) || (nterms && (!exps || !coefs))) {
    return 0;
  }
  for (int k = 0; k < nchain; k++) {
    if (chain[k] < 0 || chain[k] >= m->nv) return 0;
  }
  for (int i = 0; i < n; i++) {
    const mjfxElement* e = el + i;
    int ok = (e->method == MJFX_TWIST || e->method == MJFX_DUALQUAT) && (e->enabled | 1) == 1 &&
             (e->viscous | 1) == 1 && (e->offset | 1) == 1 && e->site_a >= 0 && e->site_a < m->nsite &&
             e->site_b >= 0 && e->site_b < m->nsite && e->body_a >= 0 && e->body_a < m->nbody && e->body_b >= 0 &&
             e->body_b < m->nbody && e->kstruct >= MJFX_FULL && e->kstruct <= MJFX_ZERO && e->bstruct >= MJFX_FULL &&
             e->bstruct <= MJFX_ZERO && free_ok(m, e->free_a) && free_ok(m, e->free_b) && e->chain_a0 >= 0 && e->chain_a0 <= e->chain_a1 && e->chain_a1 <= nchain &&
             e->chain_b0 >= 0 && e->chain_b0 <= e->chain_b1 && e->chain_b1 <= nchain && e->terms_lo >= 0 &&
             e->terms_lo <= e->terms_hi && e->terms_hi <= nterms;
    if (!ok || !terms_ok(e->method, exps ? exps + MJFX_TERM_COLUMNS * (long)e->terms_lo : NULL,
                         e->terms_hi - e->terms_lo, e->terms_top)) {
      return i;
    }
  }
  return -1;
}

// mjfx_evaluate for ctypes: the table checked first (mjfx_check_rows); -2 and nothing evaluated when a
// row is not sound.
int mjfx_evaluate_checked(const mjModel* m, const mjData* d, const mjfxElement* el, int n, const int* chain,
                          int nchain, const int* exps, const double* coefs, int nterms, int mode, double* qfrc,
                          double* out6, double* out1, mjfxScan* scan) {
  if (!m || !d || mjfx_check_rows(m, el, n, chain, nchain, exps, coefs, nterms) >= 0) return -2;
  if (((mode & (MJFX_WRENCH | MJFX_COORDS)) && !out6) || ((mode & (MJFX_ENERGY | MJFX_POWER)) && !out1) ||
      ((mode & MJFX_APPLY) && !qfrc)) {
    return -2;
  }
  return mjfx_evaluate(m, d, el, n, chain, exps, coefs, mode, qfrc, out6, out1, scan);
}

// The sizes of a table from mjfx_read_table: out[0] elements, out[1] dof ids of the chains, out[2] terms, out[3]
// numbers of the elements' values.
void mjfx_table_sizes(const Table* t, int out[4]) {
  out[0] = t ? t->n : 0, out[1] = t ? t->nchain : 0, out[2] = t ? t->nterms : 0, out[3] = 0;
  for (int k = 0; t && t->values && k < t->n; k++) out[3] += t->values[k].nnum;
}

// Copy the values of a table's elements (mjfxValues; n x MJFX_NATTRIBUTE counts and firsts) into Python's arrays,
// sized by mjfx_table_sizes: element k's numbers start at base[k] of num.
void mjfx_table_values(const Table* t, int* count, int* first, int* base, double* num) {
  for (int k = 0, at = 0; t && t->values && k < t->n; k++) {
    const mjfxValues* v = t->values + k;
    memcpy(count + MJFX_NATTRIBUTE * k, v->count, sizeof(v->count));
    memcpy(first + MJFX_NATTRIBUTE * k, v->first, sizeof(v->first));
    if (v->nnum) memcpy(num + at, v->num, sizeof(double) * v->nnum);
    base[k] = at, at += v->nnum;
  }
}

// Copy a table into Python's arrays, sized by mjfx_table_sizes (exps: MJFX_TERM_COLUMNS per term); NULL
// arrays are skipped.
void mjfx_table_copy(const Table* t, mjfxElement* el, int* chain, int* exps, double* coefs, int* instance) {
  if (!t) return;
  if (el) memcpy(el, t->el, sizeof(mjfxElement) * t->n);
  if (chain) memcpy(chain, t->chain, sizeof(int) * t->nchain);
  if (exps) memcpy(exps, t->exps, sizeof(int) * MJFX_TERM_COLUMNS * t->nterms);
  if (coefs) memcpy(coefs, t->coefs, sizeof(double) * t->nterms);
  if (instance) memcpy(instance, t->instance, sizeof(int) * t->n);
}

// Parse and check element `name`'s configuration strings values[MJFX_NATTRIBUTE], written in `form` (config.c's
// rules, without a model: sites are not looked up): -1 with the message in err, or the number of numbers of its
// values (mjfxValues), copied into num when they fit in cap, with each attribute's count and first, and the
// element's parsed fields in el (NULL: not copied).
int mjfx_parse_values(const char* name, int form, const char* const* values, mjfxElement* el, int* count,
                      int* first, double* num, int cap, char* err, int errsz) {
  if (!name || !values || !err || errsz < 1 || form < 0 || form > MJFX_FORM_ARGUMENTS) return -1;
  for (int i = 0; i < MJFX_NATTRIBUTE; i++) {
    if (!values[i]) {
      snprintf(err, errsz, "mjflex: mjfx_parse_values: invalid arguments");
      return -1;
    }
  }
  mjfxParsed parsed;
  if (mjfx_parse_config(name, form, values, &parsed, err, errsz)) return -1;
  const mjfxValues* v = &parsed.values;
  int n = v->nnum;
  if (el) *el = parsed.el;
  if (count) memcpy(count, v->count, sizeof(v->count));
  if (first) memcpy(first, v->first, sizeof(v->first));
  if (num && n && n <= cap) memcpy(num, v->num, sizeof(double) * n);
  mjfx_free_parsed(&parsed);
  return n;
}

// Check element `name`'s configuration as a plugin instance (mjfx_parse_values): 0, or -1 with the message.
int mjfx_check_config(const char* name, const char* const* values, char* err, int errsz) {
  int n = mjfx_parse_values(name, MJFX_FORM_PLUGIN, values, NULL, NULL, NULL, NULL, 0, err, errsz);
  return n < 0 ? -1 : 0;
}

// The constants Python holds too (tests/test_native_constants.py compares them); NaN for an unknown name.
double mjfx_constant(const char* name) {
  static const struct {
    const char* name;
    double value;
  } CONSTANTS[] = {
      {"MAX_MATRIX_ENTRY", MJFX_MAX_MATRIX_ENTRY},
      {"MAX_STIFFNESS", MJFX_MAX_MATRIX_ENTRY},  // of the stops' stiffness and damping (the table's bound)
      {"SYMMETRY_RTOL", MJFX_SYMMETRY_RTOL},
      {"PSD_RTOL", MJFX_PSD_RTOL},
      {"COINCIDENCE_RTOL", MJFX_COINCIDENCE_RTOL},
      {"COINCIDENCE_ANGLE", MJFX_COINCIDENCE_ANGLE},
      {"REST_STRESS_RTOL", MJFX_REST_STRESS_RTOL},
      {"MAX_TERMS", MJFX_MAX_TERMS},
      {"MAX_ORDER", MJFX_MAX_ORDER},
      {"REST_QUAT_TOLERANCE", MJFX_REST_QUAT_TOL},
      {"MAX_EXPONENT", MJFX_MAX_EXPONENT},
      {"TERM_COLUMNS", MJFX_TERM_COLUMNS},
      {"STOP_STIFFNESS_FACTOR", MJFX_STOP_STIFFNESS_FACTOR},
      {"MAX_ROTATION_LIMIT", MJFX_PI_TOLERANT},
      {"DEFAULT_STRAIN_SCALE", MJFX_DEFAULT_STRAIN_SCALE},
      {"DEFAULT_ROTATION_SCALE", MJFX_DEFAULT_ROTATION_SCALE},
      {"NATTRIBUTE", MJFX_NATTRIBUTE},
      {"FORM_PLUGIN", MJFX_FORM_PLUGIN},
      {"FORM_RECORD", MJFX_FORM_RECORD},
      {"FORM_ARGUMENTS", MJFX_FORM_ARGUMENTS},
      {"TWIST", MJFX_TWIST},
      {"DUALQUAT", MJFX_DUALQUAT},
      {"FULL", MJFX_FULL},
      {"DIAGONAL", MJFX_DIAGONAL},
      {"ZERO", MJFX_ZERO},
      {"APPLY", MJFX_APPLY},
      {"WRENCH", MJFX_WRENCH},
      {"ENERGY", MJFX_ENERGY},
      {"POWER", MJFX_POWER},
      {"COORDS", MJFX_COORDS},
  };
  for (size_t i = 0; name && i < sizeof(CONSTANTS) / sizeof(CONSTANTS[0]); i++) {
    if (!strcmp(CONSTANTS[i].name, name)) return CONSTANTS[i].value;
  }
  return NAN;
}

//------------------------------------------------------------------------------ batch math (for the tests)

// Wrenches (n x 6) and powers (n) of n elements given as stacked arrays (every array has n rows);
// velocities may be NULL when viscous is 0; terms shared by all (nterms may be 0). 0, or -1 for an
// argument out of range (then out and power are NaN).
int mjfx_wrench_batch(int n, int method, const double* Ra, const double* pa, const double* Rb, const double* pb,
                      const double* K, const double* B, int viscous, const double* wa, const double* va,
                      const double* wb, const double* vb, const int* exps, const double* coefs, int nterms, int top,
                      double* out, double* power) {
  if (n < 0 || !out || !power) return -1;
  if ((method != MJFX_TWIST && method != MJFX_DUALQUAT) || !Ra || !pa || !Rb || !pb || !K ||
      (viscous && (!B || !wa || !va || !wb || !vb)) || !terms_ok(method, exps, nterms, top) || (nterms && !coefs)) {
    fill_nan(out, 6L * n);
    fill_nan(power, n);
    return -1;
  }
  mjfxTerms terms = {exps, coefs, nterms, top};
  for (int i = 0; i < n; i++) {
    double q[4], p[3], w[3], v[3], mb[3], fb[3];
    const double* R = Rb + 9 * i;
    mjfx_relative_pose(Ra + 9 * i, pa + 3 * i, R, pb + 3 * i, q, p);
    if (viscous) mjfx_relative_velocity(R, pa + 3 * i, pb + 3 * i, wa + 3 * i, va + 3 * i, wb + 3 * i, vb + 3 * i, w, v);
    mjfxInput in = {.q = q, .p = p, .K = K + 36 * i, .B = B ? B + 36 * i : NULL,
                    .kstruct = mjfx_matrix_structure(K + 36 * i),
                    .bstruct = B ? mjfx_matrix_structure(B + 36 * i) : MJFX_ZERO, .method = method,
                    .viscous = viscous, .w = w, .v = v, .terms = &terms};
    mjfx_wrench_b(&in, mb, fb, power + i);
    double* o = out + 6 * i;
    for (int k = 0; k < 3; k++) {  // to world axes
      o[k] = R[3 * k] * mb[0] + R[3 * k + 1] * mb[1] + R[3 * k + 2] * mb[2];
      o[3 + k] = R[3 * k] * fb[0] + R[3 * k + 1] * fb[1] + R[3 * k + 2] * fb[2];
    }
  }
  return 0;
}

// Elastic energies (n) of n elements; 0, or -1 for an argument out of range (then out is NaN).
int mjfx_potential_batch(int n, int method, const double* Ra, const double* pa, const double* Rb, const double* pb,
                         const double* K, const int* exps, const double* coefs, int nterms, int top, double* out) {
  if (n < 0 || !out) return -1;
  if ((method != MJFX_TWIST && method != MJFX_DUALQUAT) || !Ra || !pa || !Rb || !pb || !K ||
      !terms_ok(method, exps, nterms, top) || (nterms && !coefs)) {
    fill_nan(out, n);
    return -1;
  }
  mjfxTerms terms = {exps, coefs, nterms, top};
  for (int i = 0; i < n; i++) {
    double q[4], p[3];
    mjfx_relative_pose(Ra + 9 * i, pa + 3 * i, Rb + 9 * i, pb + 3 * i, q, p);
    mjfxInput in = {.q = q, .p = p, .K = K + 36 * i, .kstruct = mjfx_matrix_structure(K + 36 * i),
                    .bstruct = MJFX_ZERO, .method = method, .terms = &terms};
    out[i] = mjfx_potential(&in);
  }
  return 0;
}

// Finite twists (n x 6); 0, or -1 for an argument out of range.
int mjfx_twist_batch(int n, const double* Ra, const double* pa, const double* Rb, const double* pb, double* out) {
  if (n < 0 || !Ra || !pa || !Rb || !pb || !out) return -1;
  for (int i = 0; i < n; i++) mjfx_twist(Ra + 9 * i, pa + 3 * i, Rb + 9 * i, pb + 3 * i, out + 6 * i);
  return 0;
}

// Number of tallies of a watch (0 for NULL).
int mjfx_watch_size_of(const mjfxWatch* w) {
  return w ? w->n : 0;
}

// How often element i diverged in the watch's run; v describes the first divergence.
int mjfx_watch_first(const mjfxWatch* w, int i, mjfxVerdict* v) {
  v->element = -1;
  if (!w || i < 0 || i >= w->n || w->tally[i].count == 0) return 0;
  const mjfxTally* t = w->tally + i;
  v->element = i, v->first = 1, v->nonfinite = t->bad < 0, v->accel = t->accel, v->step = t->time;
  v->bad = t->bad;
  return t->count;
}

// What the next look would report for d (nothing is changed).
void mjfx_watch_peek(const mjfxWatch* w, const mjModel* m, const mjData* d, mjfxVerdict* v) {
  v->element = -1;
  if (w) mjfx_watch_judge((mjfxWatch*)w, m, d, 0, v);
}

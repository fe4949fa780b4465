// Entry points for Python (ctypes, mjflex/mj/_native.py): the element struct's layout, batch
// versions of the element math (tested against mjflex.core), and the watch's contents.

#include <stddef.h>
#include <string.h>

#include <mujoco/mjplugin.h>

#include "config.h"
#include "elements.h"
#include "flexure_math.h"

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
    FIELD(R0),       FIELD(stops),    FIELD(stop_lo),  FIELD(stop_hi),  FIELD(stop_k),
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
  return i >= 0 && i < MJFX_NATTRIBUTE ? MJFX_ATTRIBUTES[i] : NULL;
}

// Wrenches (n x 6) and powers (n) of n elements given as stacked arrays (every array has n
// rows); velocities may be NULL when viscous is 0; terms shared by all (nterms may be 0).
void mjfx_wrench_batch(int n, int method, const double* Ra, const double* pa, const double* Rb, const double* pb,
                       const double* K, const double* B, int viscous, const double* wa, const double* va,
                       const double* wb, const double* vb, const int* exps, const double* coefs, int nterms, int top,
                       double* out, double* power) {
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
}

void mjfx_potential_batch(int n, int method, const double* Ra, const double* pa, const double* Rb, const double* pb,
                          const double* K, const int* exps, const double* coefs, int nterms, int top, double* out) {
  mjfxTerms terms = {exps, coefs, nterms, top};
  for (int i = 0; i < n; i++) {
    double q[4], p[3];
    mjfx_relative_pose(Ra + 9 * i, pa + 3 * i, Rb + 9 * i, pb + 3 * i, q, p);
    mjfxInput in = {.q = q, .p = p, .K = K + 36 * i, .kstruct = mjfx_matrix_structure(K + 36 * i),
                    .bstruct = MJFX_ZERO, .method = method, .terms = &terms};
    out[i] = mjfx_potential(&in);
  }
}

void mjfx_twist_batch(int n, const double* Ra, const double* pa, const double* Rb, const double* pb, double* out) {
  for (int i = 0; i < n; i++) mjfx_twist(Ra + 9 * i, pa + 3 * i, Rb + 9 * i, pb + 3 * i, out + 6 * i);
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

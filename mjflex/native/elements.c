// Elements on an mjData: the shared evaluation loop, the map of a wrench to generalized
// forces, the rest offset, and the per-mjData divergence watch (see elements.h).

#include "elements.h"

#include <math.h>
#include <stdatomic.h>
#include <stdio.h>
#include <string.h>

#include "flexure_kernel.h"  // MJFX_LANES of the base build

// The thread-local log handler the Python bindings and mujoco.batch set around their calls
// (absent from the public headers); weak, so that a MuJoCo without it still loads us.
extern mjfLogHandler _mjPRIVATE_setTlsLogHandler(mjfLogHandler handler) __attribute__((weak));

// An element whose wrench alone accelerates one of its bodies beyond this [m/s^2, rad/s^2]
// is the candidate that a bad state MuJoCo then finds is blamed on: a hundredth of mjMAXVAL,
// the bound of MuJoCo's own checks, so that several elements pushing one body together, or a
// joint-space acceleration that a chain's inverse mass amplifies, are found too.
#define CANDIDATE_ACCEL (0.01 * mjMAXVAL)

//------------------------------------------------------------------------------ evaluation

// the loop for the base build's lanes (evaluate_base.c): 2 with GNU C (SSE2 on x86-64, any such CPU), else 1
int mjfx_evaluate_base(const mjModel* m, const mjData* d, const mjfxElement* el, int n, const int* chain,
                       const int* exps, const double* coefs, int mode, double* qfrc, double* out6, double* out1,
                       mjfxScan* scan);
#define BASE_LANES MJFX_LANES

// and for 4 (evaluate_avx.c), where the compiler and the CPU have AVX
#if MJFX_HAVE_AVX_BUILD
int mjfx_evaluate_lanes4(const mjModel* m, const mjData* d, const mjfxElement* el, int n, const int* chain,
                         const int* exps, const double* coefs, int mode, double* qfrc, double* out6, double* out1,
                         mjfxScan* scan);
#endif

// 0: not chosen yet; else the lanes in use
static _Atomic int g_lanes = 0;

int mjfx_lanes_available(int lanes) {
  if (lanes == BASE_LANES) return 1;
#if MJFX_HAVE_AVX_BUILD
  if (lanes == 4) {
    __builtin_cpu_init();
    return __builtin_cpu_supports("avx") != 0;
  }
#endif
  return 0;
}

int mjfx_set_lanes(int lanes) {
  int previous = atomic_load(&g_lanes);
  if (lanes == 0) lanes = mjfx_lanes_available(4) ? 4 : BASE_LANES;
  if (!mjfx_lanes_available(lanes)) return -1;
  atomic_store(&g_lanes, lanes);
  return previous;
}

int mjfx_lanes(void) {
  int lanes = atomic_load_explicit(&g_lanes, memory_order_relaxed);
  if (!lanes) {
    mjfx_set_lanes(0);
    lanes = atomic_load(&g_lanes);
  }
  return lanes;
}

int mjfx_evaluate(const mjModel* m, const mjData* d, const mjfxElement* el, int n, const int* chain,
                  const int* exps, const double* coefs, int mode, double* qfrc, double* out6, double* out1,
                  mjfxScan* scan) {
#if MJFX_HAVE_AVX_BUILD
  if (mjfx_lanes() == 4) return mjfx_evaluate_lanes4(m, d, el, n, chain, exps, coefs, mode, qfrc, out6, out1, scan);
#endif
  return mjfx_evaluate_base(m, d, el, n, chain, exps, coefs, mode, qfrc, out6, out1, scan);
}

//------------------------------------------------------------------------------ element set-up

void mjfx_relative_offset(const double Ra[9], const double pa[3], const double Rb[9], const double pb[3],
                          double R0[9], double p0[3], double* dist, double* angle) {
  for (int i = 0; i < 3; i++) {
    for (int j = 0; j < 3; j++) {  // R0 = R_a^T R_b
      R0[3 * i + j] = Ra[i] * Rb[j] + Ra[3 + i] * Rb[3 + j] + Ra[6 + i] * Rb[6 + j];
    }
  }
  double dp[3] = {pb[0] - pa[0], pb[1] - pa[1], pb[2] - pa[2]};
  for (int i = 0; i < 3; i++) p0[i] = Ra[i] * dp[0] + Ra[3 + i] * dp[1] + Ra[6 + i] * dp[2];
  *dist = sqrt(p0[0] * p0[0] + p0[1] * p0[1] + p0[2] * p0[2]);
  double q[4];
  mjfx_quat_from_rot(R0, q);
  double s = sqrt(q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  *angle = s == 0.0 ? 0.0 : 2.0 * atan2(s, q[0]);
}

void mjfx_rest_offset(const mjData* d, int sa, int sb, double R0[9], double p0[3], double* dist, double* angle) {
  mjfx_relative_offset(d->site_xmat + 9 * sa, d->site_xpos + 3 * sa, d->site_xmat + 9 * sb, d->site_xpos + 3 * sb, R0,
                       p0, dist, angle);
}

void mjfx_element_prepare(const mjModel* m, mjfxElement* e) {
  e->offset = !mjfx_offset_is_identity(e->R0, e->p0);
  memcpy(e->qa, m->site_quat + 4 * e->site_a, 4 * sizeof(double));
  double q0[4], inv[4];
  mjfx_quat_from_rot(e->R0, q0);
  inv[0] = q0[0], inv[1] = -q0[1], inv[2] = -q0[2], inv[3] = -q0[3];
  if (e->offset) {
    mjfx_quat_mul(m->site_quat + 4 * e->site_b, inv, e->qb);
  } else {
    memcpy(e->qb, m->site_quat + 4 * e->site_b, 4 * sizeof(double));
  }
  e->kstruct = mjfx_matrix_structure(e->K);
  e->bstruct = mjfx_matrix_structure(e->B);
  for (int i = 0; i < 6; i++) e->kdiag[i] = e->K[7 * i], e->bdiag[i] = e->B[7 * i];
  double R[9];
  mjfx_rot_from_quat(e->qb, R);
  const double *pa = m->site_pos + 3 * e->site_a, *pb = m->site_pos + 3 * e->site_b, *p0 = e->p0;
  for (int i = 0; i < 3; i++) {
    e->lever_a[i] = pa[i];
    e->lever_b[i] = e->offset ? pb[i] - (R[3 * i] * p0[0] + R[3 * i + 1] * p0[1] + R[3 * i + 2] * p0[2]) : pb[i];
  }
}

void mjfx_compose_rest(const double pos[3], const double quat[4], double R0[9], double p0[3]) {
  double Rr[9], R[9], p[3];
  mjfx_rot_from_quat(quat, Rr);
  for (int i = 0; i < 3; i++) {
    for (int j = 0; j < 3; j++) R[3 * i + j] = Rr[3 * i] * R0[j] + Rr[3 * i + 1] * R0[3 + j] + Rr[3 * i + 2] * R0[6 + j];
    p[i] = Rr[3 * i] * p0[0] + Rr[3 * i + 1] * p0[1] + Rr[3 * i + 2] * p0[2] + pos[i];
  }
  memcpy(R0, R, sizeof(R));
  memcpy(p0, p, sizeof(p));
}

int mjfx_offset_is_identity(const double R0[9], const double p0[3]) {
  static const double I[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  for (int i = 0; i < 9; i++) {
    if (R0[i] != I[i]) return 0;
  }
  return p0[0] == 0.0 && p0[1] == 0.0 && p0[2] == 0.0;
}

static double norm3(const double* v) {
  return sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
}

double mjfx_length_scale(const mjModel* m, int sa, int sb) {
  double total = norm3(m->site_pos + 3 * sa) + norm3(m->site_pos + 3 * sb);
  int sites[2] = {sa, sb};
  for (int s = 0; s < 2; s++) {
    for (int body = m->site_bodyid[sites[s]]; body > 0; body = m->body_parentid[body]) {
      total += norm3(m->body_pos + 3 * body);
    }
  }
  return total;
}

void mjfx_inverse_inertia(const mjModel* m, int ba, int bb, double* inv_mass, double* inv_inertia) {
  double im = 0.0, ii = 0.0;
  int bodies[2] = {ba, bb};
  for (int k = 0; k < 2; k++) {
    int b = bodies[k];
    if (b <= 0) continue;
    if (m->body_mass[b] > 0) im = fmax(im, 1.0 / m->body_mass[b]);
    const double* I = m->body_inertia + 3 * b;
    double lo = fmin(I[0], fmin(I[1], I[2]));
    if (lo > 0) ii = fmax(ii, 1.0 / lo);
  }
  *inv_mass = im;
  *inv_inertia = ii;
}

int mjfx_free_dofadr(const mjModel* m, int body) {
  if (body > 0 && m->body_parentid[body] == 0 && m->body_jntnum[body] == 1) {
    int j = m->body_jntadr[body];
    if (m->jnt_type[j] == mjJNT_FREE) return m->jnt_dofadr[j];
  }
  return -1;
}

int mjfx_dof_chain(const mjModel* m, int body, int* out) {
  while (body > 0 && m->body_dofnum[body] == 0) body = m->body_parentid[body];
  if (body == 0) return 0;
  int n = 0;
  for (int j = m->body_dofadr[body] + m->body_dofnum[body] - 1; j >= 0 && n < m->nv; j = m->dof_parentid[j]) {
    out[n++] = j;
  }
  return n;
}

//------------------------------------------------------------------------------ divergence watch

size_t mjfx_watch_size(int n) {
  return sizeof(mjfxWatch) + (size_t)(n > 0 ? n : 0) * sizeof(mjfxTally);
}

void mjfx_watch_clear(mjfxWatch* w, int n) {
  int exact = w->exact;
  memset(w, 0, mjfx_watch_size(n));
  w->cand = -1;
  w->n = n;
  w->exact = exact;
}

static const int BAD_WARNINGS[3] = {mjWARN_BADQPOS, mjWARN_BADQVEL, mjWARN_BADQACC};

// a candidate from the last step (or the one before) of the evaluation at time t
static int recent(const mjfxWatch* w, const mjModel* m, double t) {
  double h = m->opt.timestep;
  return w->cand >= 0 && w->cand_time <= t && w->cand_time >= t - 1.5 * h;
}

static int counted(const mjfxWatch* w, int e, double step, long resets) {
  const mjfxTally* t = w->tally + e;
  return t->count > 0 && t->last == step && t->last_run == resets;
}

static void tally(mjfxWatch* w, int e, double step, long resets, mjfxVerdict* v) {
  mjfxTally* t = w->tally + e;
  t->last_run = resets;
  v->first = t->count == 0;
  if (t->count == 0) {
    t->time = step;
    t->bad = v->nonfinite ? -1 : v->bad;
    t->accel = v->accel;
  }
  t->count++;
  t->last = step;
}

void mjfx_watch_judge(mjfxWatch* w, const mjModel* m, const mjData* d, int commit, mjfxVerdict* v) {
  v->element = -1;
  int now[3], rose = -1, any = -1;
  for (int i = 0; i < 3; i++) {
    now[i] = d->warning[BAD_WARNINGS[i]].number;
    if (now[i] > w->seen[i] && rose < 0) rose = i;
    if (now[i] > 0 && any < 0) any = i;
  }
  // a reset: MuJoCo's (the plugin's reset callback), or time running backwards where no callback tells
  int reset = w->reset || (!w->exact && w->started && d->time < w->last_time);
  if (reset && rose < 0) {
    if (any >= 0) {
      rose = any;  // MuJoCo's auto-reset: it zeroes the counters, then counts the bad state again
    } else if (commit) {
      long resets = w->resets;
      mjfx_watch_clear(w, w->n);  // the user's mj_resetData (or a new mjData): a new run
      w->resets = resets + 1;
      return;
    } else {
      return;
    }
  }
  if (rose >= 0 && recent(w, m, w->last_time) && w->cand < w->n) {
    int e = w->cand;
    if (!counted(w, e, w->cand_step, w->cand_resets)) {  // not counted for this event already (non-finite)
      v->element = e;
      v->nonfinite = isinf(w->cand_accel);
      v->accel = w->cand_accel;
      v->step = w->cand_step;
      v->bad = rose;
      if (commit) {
        tally(w, e, w->cand_step, w->cand_resets, v);
      } else {
        v->first = w->tally[e].count == 0;
      }
    }
    if (commit) w->cand = -1;
  }
  if (commit) {
    for (int i = 0; i < 3; i++) w->seen[i] = now[i];
    if (reset) w->resets++;
    w->reset = 0;
  }
}

void mjfx_watch_record(mjfxWatch* w, const mjModel* m, const mjData* d, const mjfxScan* scan, int commit,
                       mjfxVerdict* v) {
  double t = d->time;
  v->element = -1;
  if (!commit) return;
  // the step this evaluation belongs to: exact where the plugin's advance marks the steps
  // (a later time only when the user moved the clock), else the first evaluation a whole
  // step after the previous start
  double h = m->opt.timestep;
  if (!w->started || t < w->step_start) {
    w->step_start = t;
  } else if (w->exact ? t > w->step_start + 1.0000001 * h : t >= w->step_start + (1.0 - 1e-9) * h) {
    w->step_start = t;
  }
  w->started = 1;
  w->last_time = t;
  if (w->cand >= 0 && !recent(w, m, t)) w->cand = -1;
  if (scan->nonfinite >= 0 && scan->nonfinite < w->n) {
    int e = scan->nonfinite;
    w->cand = e, w->cand_accel = INFINITY, w->cand_time = t, w->cand_step = w->step_start;
    w->cand_resets = w->resets;
    if (!counted(w, e, w->step_start, w->resets)) {
      v->element = e;
      v->nonfinite = 1;
      v->accel = INFINITY;
      v->step = w->step_start;
      v->bad = -1;
      tally(w, e, w->step_start, w->resets, v);
    }
    return;
  }
  if (scan->largest >= 0 && scan->largest < w->n && scan->accel > CANDIDATE_ACCEL &&
      (w->cand < 0 || scan->accel >= w->cand_accel)) {
    w->cand = scan->largest, w->cand_accel = scan->accel, w->cand_time = t, w->cand_step = w->step_start;
    w->cand_resets = w->resets;
  }
}

void mjfx_watch_step_end(mjfxWatch* w, const mjData* d) {
  w->step_start = d->time;
  w->exact = 1;  // steps are marked exactly from now on
  w->started = 1;
}

//------------------------------------------------------------------------------ reports

static const char* BAD_NAMES[3] = {"qpos", "qvel", "qacc"};

int mjfx_report_text(const mjModel* m, const mjfxVerdict* v, const char* element, char* buf, int size) {
  double h = m->opt.timestep;
  double index = h > 0 ? nearbyint(v->step / h) : 0.0;
  const char* model = m->names;  // the model's name comes first in names
  int len = snprintf(buf, size,
                     "mjflex: flexure '%.200s' of model '%.100s' diverged in the step from t = %.9g s (step index "
                     "%.0f, counting from 0): ",
                     element, model[0] ? model : "unnamed", v->step, index);
  if (len < 0 || len >= size) return len;
  if (v->nonfinite) {
    len += snprintf(buf + len, size - len,
                    "its wrench is not finite (a NaN or infinite state, or forces beyond float64).");
  } else {
    len += snprintf(buf + len, size - len,
                    "MuJoCo found a bad %s, and this element's force alone accelerates one of its bodies at %.3g "
                    "(m/s^2 or rad/s^2; MuJoCo's limit is 1e10).",
                    v->bad >= 0 && v->bad < 3 ? BAD_NAMES[v->bad] : "state", v->accel);
  }
  if (len < 0 || len >= size) return len;
  len += snprintf(buf + len, size - len,
                  " Reduce the time step (mjflex.step_advice(model) gives the largest stable one) or check the "
                  "qpos/qvel you set. Later divergences of this element in this run (until mj_resetData) are "
                  "counted, not printed: Flexures.divergences(data).");
  return len;
}

int mjfx_errors_caught_here(void) {
  if (!_mjPRIVATE_setTlsLogHandler) return 0;
  mjfLogHandler previous = _mjPRIVATE_setTlsLogHandler(NULL);
  _mjPRIVATE_setTlsLogHandler(previous);
  return previous != NULL;
}

int mjfx_report_raises(const mjModel* m) {
  return (m->opt.disableflags & mjDSBL_AUTORESET) && mjfx_errors_caught_here();
}

void mjfx_report(const mjModel* m, const mjfxVerdict* v, const char* element) {
  if (v->element < 0) return;
  int raises = mjfx_report_raises(m);
  if (!raises && !v->first) return;  // a repeat: counted, not printed
  char buf[900];
  mjfx_report_text(m, v, element, buf, sizeof(buf));
  if (raises) {
    mju_error("%s", buf);
  } else {
    mju_warning("%s", buf);
  }
}

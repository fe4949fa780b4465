// Elements on an mjData: the shared evaluation loop, the map of a wrench to generalized
// forces, the rest offset, and the per-mjData divergence watch (see elements.h).

#include "elements.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

// The thread-local log handler the Python bindings and mujoco.batch set around their calls
// (absent from the public headers); weak, so that a MuJoCo without it still loads us.
extern mjfLogHandler _mjPRIVATE_setTlsLogHandler(mjfLogHandler handler) __attribute__((weak));

// An element whose wrench alone accelerates one of its bodies beyond this [m/s^2, rad/s^2]
// is the candidate that a bad state MuJoCo then finds is blamed on: a hundredth of mjMAXVAL,
// the bound of MuJoCo's own checks, so that several elements pushing one body together, or a
// joint-space acceleration that a chain's inverse mass amplifies, are found too.
#define CANDIDATE_ACCEL (0.01 * mjMAXVAL)

//------------------------------------------------------------------------------ evaluation

#if defined(__GNUC__)
#define HOT static inline __attribute__((always_inline))
#else
#define HOT static inline
#endif

HOT void cross3(double out[3], const double a[3], const double b[3]) {
  double x = a[1] * b[2] - a[2] * b[1];
  double y = a[2] * b[0] - a[0] * b[2];
  double z = a[0] * b[1] - a[1] * b[0];
  out[0] = x, out[1] = y, out[2] = z;
}

// The pose of an element: the relative pose (q_ab with w >= 0, p_ab) of frame b, corrected by the
// rest offset (X_Wb* = X_Wb X_ab0^-1), seen from frame a, and frame b*'s world pose (Rb, pb).
// The relative quaternion comes from MuJoCo's body quaternions and the sites' constant local
// orientations (as MuJoCo composes site frames), without a matrix-to-quaternion conversion.
HOT void element_pose(const mjData* d, const mjfxElement* e, const double* Ra, const double* pa, double q[4],
                      double p[3], const double** Rb, const double** pb, double Rb_buf[9], double pb_buf[3]) {
  double qa[4], qb[4];
  mjfx_quat_mul(d->xquat + 4 * e->body_a, e->qa, qa);
  mjfx_quat_mul(d->xquat + 4 * e->body_b, e->qb, qb);
  mjfx_quat_conj_mul(qa, qb, q);
  if (q[0] < 0.0) q[0] = -q[0], q[1] = -q[1], q[2] = -q[2], q[3] = -q[3];
  const double* site_p = d->site_xpos + 3 * e->site_b;
  if (!e->offset) {
    *Rb = d->site_xmat + 9 * e->site_b;
    *pb = site_p;
  } else {
    mjfx_rot_from_quat(qb, Rb_buf);
    const double* p0 = e->p0;
    for (int i = 0; i < 3; i++) {
      pb_buf[i] = site_p[i] - (Rb_buf[3 * i] * p0[0] + Rb_buf[3 * i + 1] * p0[1] + Rb_buf[3 * i + 2] * p0[2]);
    }
    *Rb = Rb_buf, *pb = pb_buf;
  }
  const double* b = *pb;
  double dp[3] = {b[0] - pa[0], b[1] - pa[1], b[2] - pa[2]};
  for (int i = 0; i < 3; i++) p[i] = Ra[i] * dp[0] + Ra[3 + i] * dp[1] + Ra[6 + i] * dp[2];
}

// world angular velocity of body and linear velocity of its point p
HOT void point_velocity(const mjModel* m, const mjData* d, int body, const double p[3], double w[3],
                           double v[3]) {
  const double* cvel = d->cvel + 6 * body;
  const double* c = d->subtree_com + 3 * m->body_rootid[body];
  double r[3] = {p[0] - c[0], p[1] - c[1], p[2] - c[2]}, wr[3];
  w[0] = cvel[0], w[1] = cvel[1], w[2] = cvel[2];
  cross3(wr, w, r);
  for (int i = 0; i < 3; i++) v[i] = 1.0 * cvel[3 + i] + 1.0 * wr[i];
}

// add sign * (moment mo about p, force f) on body to qfrc (J^T of the wrench)
HOT void apply(const mjModel* m, const mjData* d, double* qfrc, int body, int free_adr, const int* chain, int c0,
               int c1, const double mo[3], const double f[3], const double p[3], double sign) {
  if (free_adr < 0 && c0 == c1) return;  // a body that does not move (the world, a fixed base)
  if (free_adr >= 0) {
    // free joint: dofs are the world velocity of the body origin, then the body-frame angular velocity
    const double* o = d->xpos + 3 * body;
    const double* R = d->xmat + 9 * body;
    double r[3] = {p[0] - o[0], p[1] - o[1], p[2] - o[2]}, rf[3], mm[3];
    cross3(rf, r, f);
    for (int k = 0; k < 3; k++) mm[k] = 1.0 * mo[k] + 1.0 * rf[k];
    for (int k = 0; k < 3; k++) {
      qfrc[free_adr + k] += sign * f[k];
      qfrc[free_adr + 3 + k] += sign * (R[k] * mm[0] + R[3 + k] * mm[1] + R[6 + k] * mm[2]);
    }
    return;
  }
  const double* c = d->subtree_com + 3 * m->body_rootid[body];
  double r[3] = {p[0] - c[0], p[1] - c[1], p[2] - c[2]}, rf[3], mc[3];
  cross3(rf, r, f);
  for (int k = 0; k < 3; k++) mc[k] = 1.0 * mo[k] + 1.0 * rf[k];
  for (int k = c0; k < c1; k++) {
    int j = chain[k];
    const double* cd = d->cdof + 6 * j;
    qfrc[j] += sign * (cd[0] * mc[0] + cd[1] * mc[1] + cd[2] * mc[2] + cd[3] * f[0] + cd[4] * f[1] + cd[5] * f[2]);
  }
}

int mjfx_evaluate(const mjModel* m, const mjData* d, const mjfxElement* el, int n, const int* chain,
                  const int* exps, const double* coefs, int mode, double* qfrc, double* out6, double* out1,
                  mjfxScan* scan) {
  int spring_on = !(m->opt.disableflags & mjDSBL_SPRING);
  int damper_on = !(m->opt.disableflags & mjDSBL_DAMPER);
  if (scan) {
    scan->nonfinite = scan->largest = -1;
    scan->accel = 0.0;
  }
  for (int i = 0; i < n; i++) {
    const mjfxElement* e = el + i;
    if (!e->enabled) {
      if (mode & (MJFX_WRENCH | MJFX_COORDS)) memset(out6 + 6 * i, 0, 6 * sizeof(double));
      if (mode & (MJFX_ENERGY | MJFX_POWER)) out1[i] = 0.0;
      continue;
    }
    const double* Ra = d->site_xmat + 9 * e->site_a;
    const double* pa = d->site_xpos + 3 * e->site_a;
    double q[4], p[3], Rb_buf[9], pb_buf[3];
    const double *Rb, *pb;
    element_pose(d, e, Ra, pa, q, p, &Rb, &pb, Rb_buf, pb_buf);
    mjfxTerms terms = {exps + MJFX_TERM_COLUMNS * e->terms_lo, coefs + e->terms_lo,
                       spring_on ? e->terms_hi - e->terms_lo : 0, e->terms_top};
    mjfxInput in = {.Ra = Ra, .pa = pa, .Rb = Rb, .pb = pb, .q = q, .p = p, .K = e->K, .B = e->B,
                    .kstruct = spring_on ? e->kstruct : MJFX_ZERO, .bstruct = e->bstruct,
                    .method = (mode & MJFX_COORDS) ? MJFX_TWIST : e->method, .terms = &terms};
    if (mode & MJFX_COORDS) {
      mjfx_coordinates(&in, out6 + 6 * i);
      continue;
    }
    if (mode & MJFX_ENERGY) {
      out1[i] = mjfx_potential(&in);
      continue;
    }
    double wa[3], va[3], wb[3], vb[3];
    if (damper_on && e->viscous) {
      point_velocity(m, d, e->body_a, pa, wa, va);
      point_velocity(m, d, e->body_b, pb, wb, vb);
      in.viscous = 1;
      in.wa = wa, in.va = va, in.wb = wb, in.vb = vb;
    }
    double mo[3], f[3], power;
    mjfx_wrench(&in, mo, f, &power);
    if (!isfinite(mo[0] + mo[1] + mo[2] + f[0] + f[1] + f[2] + power)) {
      if (scan) scan->nonfinite = i;
      return i;
    }
    if (scan) {  // the acceleration this element alone gives its bodies (a bound: max force / min mass)
      double fm = fabs(f[0]), mm = fabs(mo[0]);
      for (int k = 1; k < 3; k++) {
        if (fabs(f[k]) > fm) fm = fabs(f[k]);
        if (fabs(mo[k]) > mm) mm = fabs(mo[k]);
      }
      double accel = fm * e->inv_mass, angular = mm * e->inv_inertia;
      if (angular > accel) accel = angular;
      if (accel > scan->accel) scan->accel = accel, scan->largest = i;
    }
    if (mode & MJFX_WRENCH) {
      double* o = out6 + 6 * i;
      o[0] = mo[0], o[1] = mo[1], o[2] = mo[2], o[3] = f[0], o[4] = f[1], o[5] = f[2];
    }
    if (mode & MJFX_POWER) out1[i] = power;
    if (mode & MJFX_APPLY) {
      apply(m, d, qfrc, e->body_b, e->free_b, chain, e->chain_b0, e->chain_b1, mo, f, pb, 1.0);
      apply(m, d, qfrc, e->body_a, e->free_a, chain, e->chain_a0, e->chain_a1, mo, f, pb, -1.0);
    }
  }
  return -1;
}

//------------------------------------------------------------------------------ element set-up

void mjfx_rest_offset(const mjData* d, int sa, int sb, double R0[9], double p0[3], double* dist, double* angle) {
  const double* Ra = d->site_xmat + 9 * sa;
  const double* Rb = d->site_xmat + 9 * sb;
  const double* pa = d->site_xpos + 3 * sa;
  const double* pb = d->site_xpos + 3 * sb;
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
                  " Reduce the time step (mjflex.normal_modes gives the stiffest mode) or check the "
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

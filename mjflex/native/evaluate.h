// The evaluation loop of mjfx_evaluate (elements.h) for MJFX_LANES lanes: included once per
// lane count, by evaluate_base.c (2 lanes, any x86-64 or other CPU) and evaluate_avx.c (4 lanes,
// AVX), each defining MJFX_EVALUATE, the name of the function it builds. Consecutive enabled
// elements of one kind (method, matrix structures, damping, rest offset, terms, free bodies) are
// evaluated together, one per lane; a lane's numbers do not depend on the others (see
// flexure_kernel.h), and the results are added to qfrc in element order, so every build gives
// the same bits.

#include <math.h>
#include <string.h>

#include "elements.h"
#include "flexure_kernel.h"

#if defined(__GNUC__)
#define EV_INLINE static inline __attribute__((always_inline))
#define EV_NOINLINE static __attribute__((noinline))
#else
#define EV_INLINE static inline
#define EV_NOINLINE static
#endif

// what a group of elements shares
#define KIND_METHOD 1
#define KIND_VISCOUS 32
#define KIND_OFFSET 64
#define KIND_TERMS 128
#define KIND_FREE_A 256
#define KIND_FREE_B 512
#define KIND_STOPS 1024
#define KIND_STOP_DAMPING 2048

// the kind of an element (its method, or the twist's for the twist coordinates query)
EV_INLINE int kind_of(const mjfxElement* e, int spring_on, int damper_on, int coords) {
  return (coords ? MJFX_TWIST : e->method) | (spring_on ? e->kstruct : MJFX_ZERO) << 1 | e->bstruct << 3 |
         (damper_on & e->viscous) << 5 |
         e->offset << 6 | (spring_on & (e->terms_hi > e->terms_lo)) << 7 | (e->free_a >= 0) << 8 |
         (e->free_b >= 0) << 9 | (spring_on & !coords & e->stops) << 10 |
         (spring_on & damper_on & !coords & e->stop_damped) << 11;  // stop_damped: the element has stops
}

// the end stops' limits, stiffness and damping of each lane (when the kind has stops)
EV_INLINE void lanes_stops(const mjfxElement* const e[MJFX_LANES], int kind, mjfxLanes* x) {
  x->has_stops = (kind & KIND_STOPS) != 0;
  x->stop_damped = (kind & KIND_STOP_DAMPING) != 0;
  if (!x->has_stops) return;
  for (int l = 0; l < MJFX_LANES; l++) {
    x->lo[l] = e[l]->stop_lo, x->hi[l] = e[l]->stop_hi, x->ks[l] = e[l]->stop_k, x->bs[l] = e[l]->stop_b;
  }
}

// A group's results, one column per lane: the wrench on body B (moment about pb, world axes), pb,
// the body-frame moments of free bodies A and B (their rotational dofs' generalized forces), the
// power, the sum of the wrench and power (not finite: something is not), and the acceleration the
// element alone gives its bodies (for the divergence scan).
enum { R_M = 0, R_F = 3, R_PB = 6, R_TA = 9, R_TB = 12, R_POWER = 15, R_SUM = 16, R_ACCEL = 17, R_ROWS = 18 };
typedef struct {
  double row[R_ROWS][MJFX_LANES];
} Results;

EV_INLINE void put(Results* r, int row, mjfxVec v) {
  memcpy(r->row[row], &v, sizeof(v));
}

EV_INLINE void put3(Results* r, int row, mjfxV3 v) {
  put(r, row, v.x), put(r, row + 1, v.y), put(r, row + 2, v.z);
}

// The pose of each lane's element: the relative pose (q_ab with w >= 0, p_ab) of frame b*, the rest
// offset removed (X_Wb* = X_Wb X_ab0^-1), seen from frame a, and frame b*'s world pose (Rb, pb). The
// relative quaternion comes from MuJoCo's body quaternions and the sites' constant local orientations
// (as MuJoCo composes site frames), without a matrix-to-quaternion conversion. Also kept: qa and qb,
// the local orientations of frames a and b* in their bodies.
typedef struct {
  mjfxVec qa[4], qb[4];
} Local;

EV_INLINE void group_pose(const mjData* d, const mjfxElement* const e[MJFX_LANES], int offset, mjfxLanes* x,
                          mjfxVec Rb[9], mjfxV3* pb, Local* local) {
  const double *xqa[MJFX_LANES], *xqb[MJFX_LANES], *qa[MJFX_LANES], *qb[MJFX_LANES];
  for (int l = 0; l < MJFX_LANES; l++) {
    xqa[l] = d->xquat + 4 * e[l]->body_a, xqb[l] = d->xquat + 4 * e[l]->body_b;
    qa[l] = e[l]->qa, qb[l] = e[l]->qb;
  }
  mjfxVec A[4], wa[4], wb[4];
  for (int i = 0; i < 4; i++) A[i] = MJFX_GATHER(xqa, i), local->qa[i] = MJFX_GATHER(qa, i);
  q4_mul(A, local->qa, wa);
  for (int i = 0; i < 4; i++) A[i] = MJFX_GATHER(xqb, i), local->qb[i] = MJFX_GATHER(qb, i);
  q4_mul(A, local->qb, wb);
  q4_conj_mul(wa, wb, x->q);
  mjfxVec sign = x->q[0];
  for (int l = 0; l < MJFX_LANES; l++) MJFX_LANE(sign, l) = MJFX_LANE(x->q[0], l) < 0.0 ? -1.0 : 1.0;
  for (int i = 0; i < 4; i++) x->q[i] = sign * x->q[i];
  const double *sb[MJFX_LANES], *pa[MJFX_LANES];
  for (int l = 0; l < MJFX_LANES; l++) sb[l] = d->site_xpos + 3 * e[l]->site_b, pa[l] = d->site_xpos + 3 * e[l]->site_a;
  if (offset) {
    const double* p0[MJFX_LANES];
    for (int l = 0; l < MJFX_LANES; l++) p0[l] = e[l]->p0;
    q4_rot(wb, Rb);
    *pb = v3_sub(v3_gather(sb), v3_rot(Rb, v3_gather(p0)));
  } else {
    const double* Rs[MJFX_LANES];
    for (int l = 0; l < MJFX_LANES; l++) Rs[l] = d->site_xmat + 9 * e[l]->site_b;
    for (int i = 0; i < 9; i++) Rb[i] = MJFX_GATHER(Rs, i);
    *pb = v3_gather(sb);
  }
  x->p = q4_apply(wa, v3_sub(*pb, v3_gather(pa)), 1);  // R_Wa^T (pb - pa)
}

// Velocity of frame b* (origin pb, axes Rb) relative to frame a in frame b*'s axes: the bodies' angular
// velocities and the velocities of their points at pb (cvel: [w; v at the subtree's centre of mass]).
EV_INLINE void group_velocity(const mjModel* m, const mjData* d, const mjfxElement* const e[MJFX_LANES],
                              const mjfxVec Rb[9], mjfxV3 pb, mjfxLanes* x) {
  const double *ca[MJFX_LANES], *cb[MJFX_LANES], *la[MJFX_LANES], *lb[MJFX_LANES], *oa[MJFX_LANES], *ob[MJFX_LANES];
  for (int l = 0; l < MJFX_LANES; l++) {
    int ba = e[l]->body_a, bb = e[l]->body_b;
    ca[l] = d->cvel + 6 * ba, cb[l] = d->cvel + 6 * bb;
    la[l] = ca[l] + 3, lb[l] = cb[l] + 3;
    oa[l] = d->subtree_com + 3 * m->body_rootid[ba], ob[l] = d->subtree_com + 3 * m->body_rootid[bb];
  }
  mjfxV3 wa = v3_gather(ca), wb = v3_gather(cb);
  mjfxV3 va = v3_add(v3_gather(la), v3_cross(wa, v3_sub(pb, v3_gather(oa))));
  mjfxV3 vb = v3_add(v3_gather(lb), v3_cross(wb, v3_sub(pb, v3_gather(ob))));
  x->w = v3_rot_t(Rb, v3_sub(wb, wa));
  x->v = v3_rot_t(Rb, v3_sub(vb, va));
}

// Wrenches of a group of elements of one kind (lanes past the group repeat its last element) into r.
EV_INLINE void group_wrench(const mjModel* m, const mjData* d, const mjfxElement* const e[MJFX_LANES], int kind,
                            int method, const int* exps, const double* coefs, Results* r) {
  mjfxLanes x;
  mjfxVec Rb[9];
  mjfxV3 pb;
  Local local;
  group_pose(d, e, kind & KIND_OFFSET, &x, Rb, &pb, &local);
  x.method = method, x.kstruct = (kind >> 1) & 3, x.bstruct = (kind >> 3) & 3;
  x.viscous = (kind & KIND_VISCOUS) != 0;
  x.has_terms = (kind & KIND_TERMS) != 0;
  lanes_stops(e, kind, &x);
  mjfxTerms terms[MJFX_LANES];
  for (int l = 0; l < MJFX_LANES; l++) {
    x.K[l] = e[l]->K, x.B[l] = e[l]->B, x.Kd[l] = e[l]->kdiag, x.Bd[l] = e[l]->bdiag;
    if (x.has_terms) {
      terms[l].exps = exps + MJFX_TERM_COLUMNS * e[l]->terms_lo, terms[l].coefs = coefs + e[l]->terms_lo;
      terms[l].n = e[l]->terms_hi - e[l]->terms_lo, terms[l].top = e[l]->terms_top;
      x.terms[l] = terms + l;
    }
  }
  if (x.viscous || x.stop_damped) {
    group_velocity(m, d, e, Rb, pb, &x);
  } else {
    x.w = x.v = v3(mjfx_all(0.0), mjfx_all(0.0), mjfx_all(0.0));
  }
  mjfxV3 mb, fb;
  mjfxVec power;
  mjfx_kernel(&x, &mb, &fb, &power);
  mjfxV3 mo = v3_rot(Rb, mb), f = v3_rot(Rb, fb);  // to world axes
  put3(r, R_M, mo), put3(r, R_F, f), put3(r, R_PB, pb), put(r, R_POWER, power);
  put(r, R_SUM, mo.x + mo.y + mo.z + f.x + f.y + f.z + power);
  // the acceleration the element alone gives its bodies (a bound: largest component / smallest inertia)
  const double *im[MJFX_LANES], *ii[MJFX_LANES], *sp[MJFX_LANES];
  for (int l = 0; l < MJFX_LANES; l++) im[l] = &e[l]->inv_mass, ii[l] = &e[l]->inv_inertia;
  put(r, R_ACCEL, mjfx_max(v3_max_abs(f) * MJFX_GATHER(im, 0), v3_max_abs(mo) * MJFX_GATHER(ii, 0)));
  // Free bodies: the moments about their origins in their own axes (their rotational dofs'
  // generalized forces), from the wrench in frame b*: R_WB^T R_Wb* = R(qb), and the lever arm
  // R_WB^T (pb - x_B) is the constant position of b* in B; likewise for A, where
  // R_WA^T R_Wb* = R(qa q_ab) and R_WA^T (pb - x_A) = R(qa) p_ab + (site a's position in A).
  if (kind & KIND_FREE_B) {
    mjfxVec Rl[9];
    q4_rot(local.qb, Rl);
    for (int l = 0; l < MJFX_LANES; l++) sp[l] = e[l]->lever_b;
    put3(r, R_TB, v3_add(v3_rot(Rl, mb), v3_cross(v3_gather(sp), v3_rot(Rl, fb))));
  }
  if (kind & KIND_FREE_A) {
    mjfxVec qab[4], Rl[9];
    q4_mul(local.qa, x.q, qab);
    q4_rot(qab, Rl);
    for (int l = 0; l < MJFX_LANES; l++) sp[l] = e[l]->lever_a;
    mjfxV3 lever = v3_add(q4_apply(local.qa, x.p, 0), v3_gather(sp));
    put3(r, R_TA, v3_add(v3_rot(Rl, mb), v3_cross(lever, v3_rot(Rl, fb))));
  }
}

// one function per method, each compact
EV_NOINLINE void group_twist(const mjModel* m, const mjData* d, const mjfxElement* const e[MJFX_LANES], int kind,
                             const int* exps, const double* coefs, Results* r) {
  group_wrench(m, d, e, kind, MJFX_TWIST, exps, coefs, r);
}

EV_NOINLINE void group_dualquat(const mjModel* m, const mjData* d, const mjfxElement* const e[MJFX_LANES],
                                int kind, const int* exps, const double* coefs, Results* r) {
  group_wrench(m, d, e, kind, MJFX_DUALQUAT, exps, coefs, r);
}

// energies or twists of a group (MJFX_ENERGY, MJFX_COORDS)
EV_NOINLINE void group_queries(const mjData* d, const mjfxElement* const e[MJFX_LANES], int kind, int count,
                               int coords, const int* exps, const double* coefs, double* out6, double* out1) {
  mjfxLanes x;
  mjfxVec Rb[9];
  mjfxV3 pb;
  mjfxTerms terms[MJFX_LANES];
  Local local;
  group_pose(d, e, kind & KIND_OFFSET, &x, Rb, &pb, &local);
  x.method = kind & KIND_METHOD, x.kstruct = (kind >> 1) & 3, x.has_terms = (kind & KIND_TERMS) != 0;
  lanes_stops(e, kind, &x);
  for (int l = 0; l < MJFX_LANES; l++) {
    x.K[l] = e[l]->K, x.Kd[l] = e[l]->kdiag;
    terms[l].exps = exps + MJFX_TERM_COLUMNS * e[l]->terms_lo, terms[l].coefs = coefs + e[l]->terms_lo;
    terms[l].n = e[l]->terms_hi - e[l]->terms_lo, terms[l].top = e[l]->terms_top;
    x.terms[l] = terms + l;
  }
  if (coords) {
    mjfxV3 tau, t;
    mjfx_kernel_twist(&x, &tau, &t);
    for (int l = 0; l < count; l++) v3_lane(tau, l, out6 + 6 * l), v3_lane(t, l, out6 + 6 * l + 3);
    return;
  }
  mjfxVec u = mjfx_kernel_potential(&x);
  for (int l = 0; l < count; l++) out1[l] = MJFX_LANE(u, l);
}

// add sign * (moment mo about p, force f) on body to qfrc through its dof chain (J^T of the wrench)
EV_NOINLINE void apply_chain(const mjModel* m, const mjData* d, double* qfrc, int body, const int* chain, int c0,
                             int c1, const double mo[3], const double f[3], const double p[3], double sign) {
  const double* c = d->subtree_com + 3 * m->body_rootid[body];
  double r[3] = {p[0] - c[0], p[1] - c[1], p[2] - c[2]};
  double mc[3] = {mo[0] + (r[1] * f[2] - r[2] * f[1]), mo[1] + (r[2] * f[0] - r[0] * f[2]),
                  mo[2] + (r[0] * f[1] - r[1] * f[0])};
  for (int k = c0; k < c1; k++) {
    int j = chain[k];
    const double* cd = d->cdof + 6 * j;
    qfrc[j] += sign * (cd[0] * mc[0] + cd[1] * mc[1] + cd[2] * mc[2] + cd[3] * f[0] + cd[4] * f[1] + cd[5] * f[2]);
  }
}

int MJFX_EVALUATE(const mjModel* m, const mjData* d, const mjfxElement* el, int n, const int* chain, const int* exps,
                  const double* coefs, int mode, double* qfrc, double* out6, double* out1, mjfxScan* scan) {
  int spring_on = !(m->opt.disableflags & mjDSBL_SPRING);
  int damper_on = !(m->opt.disableflags & mjDSBL_DAMPER);
  int coords = (mode & MJFX_COORDS) != 0;
  if (scan) {
    scan->nonfinite = scan->largest = -1;
    scan->accel = 0.0;
  }
  int i = 0;
  while (i < n) {
    const mjfxElement* first = el + i;
    if (!first->enabled) {
      if (mode & (MJFX_WRENCH | MJFX_COORDS)) memset(out6 + 6 * i, 0, 6 * sizeof(double));
      if (mode & (MJFX_ENERGY | MJFX_POWER)) out1[i] = 0.0;
      i++;
      continue;
    }
    // the group: consecutive enabled elements of one kind, up to MJFX_LANES
    int kind = kind_of(first, spring_on, damper_on, coords), count = 1, method = kind & KIND_METHOD;
    const mjfxElement* e[MJFX_LANES];
    e[0] = first;
    while (count < MJFX_LANES && i + count < n && el[i + count].enabled &&
           kind_of(el + i + count, spring_on, damper_on, coords) == kind) {
      e[count] = el + i + count;
      count++;
    }
    for (int l = count; l < MJFX_LANES; l++) e[l] = e[count - 1];
    if (mode & (MJFX_COORDS | MJFX_ENERGY)) {
      group_queries(d, e, kind, count, coords, exps, coefs, out6 ? out6 + 6 * i : NULL, out1 ? out1 + i : NULL);
      i += count;
      continue;
    }
    Results r;
    if (method == MJFX_TWIST) {
      group_twist(m, d, e, kind, exps, coefs, &r);
    } else {
      group_dualquat(m, d, e, kind, exps, coefs, &r);
    }
    for (int l = 0; l < count; l++, i++) {
      const mjfxElement* t = e[l];
      if (!isfinite(r.row[R_SUM][l])) {
        if (scan) scan->nonfinite = i;
        return i;
      }
      double mo[3] = {r.row[R_M][l], r.row[R_M + 1][l], r.row[R_M + 2][l]};
      double f[3] = {r.row[R_F][l], r.row[R_F + 1][l], r.row[R_F + 2][l]};
      if (scan && r.row[R_ACCEL][l] > scan->accel) scan->accel = r.row[R_ACCEL][l], scan->largest = i;
      if (mode & MJFX_WRENCH) {
        double* o = out6 + 6 * i;
        o[0] = mo[0], o[1] = mo[1], o[2] = mo[2], o[3] = f[0], o[4] = f[1], o[5] = f[2];
        if (t->rest) {  // about site b: + (pb - site b) x f
          const double* s = d->site_xpos + 3 * t->site_b;
          double a[3] = {r.row[R_PB][l] - s[0], r.row[R_PB + 1][l] - s[1], r.row[R_PB + 2][l] - s[2]};
          o[0] += a[1] * f[2] - a[2] * f[1], o[1] += a[2] * f[0] - a[0] * f[2], o[2] += a[0] * f[1] - a[1] * f[0];
        }
      }
      if (mode & MJFX_POWER) out1[i] = r.row[R_POWER][l];
      if (!(mode & MJFX_APPLY)) continue;
      double pb[3] = {r.row[R_PB][l], r.row[R_PB + 1][l], r.row[R_PB + 2][l]};
      if (t->free_b >= 0) {  // free joint: world force on the origin, then the body-frame moment
        double* q = qfrc + t->free_b;
        q[0] += f[0], q[1] += f[1], q[2] += f[2];
        q[3] += r.row[R_TB][l], q[4] += r.row[R_TB + 1][l], q[5] += r.row[R_TB + 2][l];
      } else if (t->chain_b1 > t->chain_b0) {
        apply_chain(m, d, qfrc, t->body_b, chain, t->chain_b0, t->chain_b1, mo, f, pb, 1.0);
      }
      if (t->free_a >= 0) {
        double* q = qfrc + t->free_a;
        q[0] -= f[0], q[1] -= f[1], q[2] -= f[2];
        q[3] -= r.row[R_TA][l], q[4] -= r.row[R_TA + 1][l], q[5] -= r.row[R_TA + 2][l];
      } else if (t->chain_a1 > t->chain_a0) {
        apply_chain(m, d, qfrc, t->body_a, chain, t->chain_a0, t->chain_a1, mo, f, pb, -1.0);
      }
    }
  }
  return -1;
}

// The per-element kernel of mjflex, evaluated for MJFX_LANES elements at once (see flexure_math.h
// for the conventions). Each lane of an mjfxVec is one element; lanes never mix, so a lane's result
// does not depend on what the other lanes hold: one element alone (its input in every lane) gives
// the same bits as the same element beside any other. The scalar API (flexure_math.c) and the
// MuJoCo loop (elements.c, two elements of a model at a time) both run this code: it is the one
// implementation of the per-step math. No -ffast-math, no contraction: each lane computes the same
// IEEE operations in the same order as a scalar build would (MJFX_LANES 1 without GNU C).
//
// The maps of both methods are dual-number matrices applied to dual vectors x^ = x0 + eps x1
// (primary x0, dual x1), so that one map gives both halves of a 6-vector:
//
// Twist: Gamma_ab = [[P, D], [0, P]] with P + eps D = P^ = (S^a_b)^-1 (eq. 44) evaluated in dual
// arithmetic at tau^ = tau + eps t, i.e. P^ = I - tau^x / 2 + c^ (tau^x)^2 with the dual scalar
// c^ = c(a) + eps g(a) (tau.t) (c, g: mjfx_jl_inv_coefs). Using u x (u x x) = u (u.x) - (u.u) x,
//   P^ x^ = k^ x^ - tau^ x x^ / 2 + (c^ tau^) (tau^ . x^),   k^ = 1 - c^ (tau^ . tau^),
// and P^T x^ the same with + tau^ x x^ / 2: a few dot and cross products, no matrix is formed.
// [m; f] = Gamma_ab [y1; y2] is f + eps m = P^ (y2 + eps y1); the twist rate Gamma_ab^T V (eq. 58
// in frame b, V = [w; v] the velocity of b relative to a) is r1 + eps r2 = P^T (w + eps v).
//
// Dual quaternion: Lambda_ab = [[sigma - xi^x, s' - x'^x], [0, sigma - xi^x]] (eq. 85) is the dual
// matrix s^ - x^ x with s^ = sigma + eps s', x^ = xi + eps x'; Lambda_ab^T = s^ + x^ x.

#ifndef MJFLEX_NATIVE_FLEXURE_KERNEL_H_
#define MJFLEX_NATIVE_FLEXURE_KERNEL_H_

#include <math.h>
#include <stddef.h>

#include "flexure_scalar.h"

// GNU C vector extensions (GCC, clang); any other C11 compiler, or -DMJFX_SCALAR, builds one lane.
#if defined(__GNUC__) && !defined(MJFX_SCALAR)
#define MJFX_HOT static inline __attribute__((always_inline))
#ifndef MJFX_LANES
#define MJFX_LANES 2
#endif
typedef double mjfxVec __attribute__((vector_size(8 * MJFX_LANES)));
#define MJFX_LANE(x, l) ((x)[l])
#else
#define MJFX_HOT static inline
#undef MJFX_LANES
#define MJFX_LANES 1
typedef double mjfxVec;
#define MJFX_LANE(x, l) (x)
#endif

// every lane a
MJFX_HOT mjfxVec mjfx_all(double a) {
  mjfxVec v = {0};
  return v + a;
}

// lane-wise gather of base[l][i]
#if MJFX_LANES == 8
#define MJFX_GATHER(base, i) ((mjfxVec){(base)[0][i], (base)[1][i], (base)[2][i], (base)[3][i], (base)[4][i], (base)[5][i], (base)[6][i], (base)[7][i]})
#elif MJFX_LANES == 4
#define MJFX_GATHER(base, i) ((mjfxVec){(base)[0][i], (base)[1][i], (base)[2][i], (base)[3][i]})
#elif MJFX_LANES == 2
#define MJFX_GATHER(base, i) ((mjfxVec){(base)[0][i], (base)[1][i]})
#else
#define MJFX_GATHER(base, i) ((base)[0][i])
#endif

//------------------------------------------------------------------------------ 3-vectors of lanes

typedef struct {
  mjfxVec x, y, z;
} mjfxV3;

MJFX_HOT mjfxV3 v3(mjfxVec x, mjfxVec y, mjfxVec z) {
  mjfxV3 r = {x, y, z};
  return r;
}
MJFX_HOT mjfxV3 v3_add(mjfxV3 a, mjfxV3 b) {
  return v3(a.x + b.x, a.y + b.y, a.z + b.z);
}
MJFX_HOT mjfxV3 v3_sub(mjfxV3 a, mjfxV3 b) {
  return v3(a.x - b.x, a.y - b.y, a.z - b.z);
}
MJFX_HOT mjfxV3 v3_scale(mjfxVec s, mjfxV3 a) {
  return v3(s * a.x, s * a.y, s * a.z);
}
MJFX_HOT mjfxVec v3_dot(mjfxV3 a, mjfxV3 b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}
MJFX_HOT mjfxV3 v3_cross(mjfxV3 a, mjfxV3 b) {
  return v3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
// R v and R^T v, R row-major (9 lanes-vectors)
MJFX_HOT mjfxV3 v3_rot(const mjfxVec R[9], mjfxV3 v) {
  return v3(R[0] * v.x + R[1] * v.y + R[2] * v.z, R[3] * v.x + R[4] * v.y + R[5] * v.z,
            R[6] * v.x + R[7] * v.y + R[8] * v.z);
}
MJFX_HOT mjfxV3 v3_rot_t(const mjfxVec R[9], mjfxV3 v) {
  return v3(R[0] * v.x + R[3] * v.y + R[6] * v.z, R[1] * v.x + R[4] * v.y + R[7] * v.z,
            R[2] * v.x + R[5] * v.y + R[8] * v.z);
}
#if MJFX_LANES > 1
typedef long long mjfxMask __attribute__((vector_size(8 * MJFX_LANES)));
// lane-wise |a| and max(a, b) (a, b not NaN)
MJFX_HOT mjfxVec mjfx_abs(mjfxVec a) {
  return (mjfxVec)((mjfxMask)a & 0x7fffffffffffffffLL);
}
MJFX_HOT mjfxVec mjfx_max(mjfxVec a, mjfxVec b) {
  mjfxMask take = a > b;
  return (mjfxVec)((take & (mjfxMask)a) | (~take & (mjfxMask)b));
}
// lane-wise a where x > 0, else 0
MJFX_HOT mjfxVec mjfx_where_positive(mjfxVec x, mjfxVec a) {
  mjfxMask take = x > mjfx_all(0.0);
  return (mjfxVec)(take & (mjfxMask)a);
}
#else
MJFX_HOT mjfxVec mjfx_abs(mjfxVec a) {
  return fabs(a);
}
MJFX_HOT mjfxVec mjfx_max(mjfxVec a, mjfxVec b) {
  return a > b ? a : b;
}
MJFX_HOT mjfxVec mjfx_where_positive(mjfxVec x, mjfxVec a) {
  return x > 0.0 ? a : 0.0;
}
#endif
// largest |component|
MJFX_HOT mjfxVec v3_max_abs(mjfxV3 a) {
  return mjfx_max(mjfx_max(mjfx_abs(a.x), mjfx_abs(a.y)), mjfx_abs(a.z));
}

// lane l of a 3-vector into out[3]
MJFX_HOT void v3_lane(mjfxV3 a, int l, double out[3]) {
  out[0] = MJFX_LANE(a.x, l), out[1] = MJFX_LANE(a.y, l), out[2] = MJFX_LANE(a.z, l);
}
// 3-vector of lanes from base[l][0..3)
MJFX_HOT mjfxV3 v3_gather(const double* const base[MJFX_LANES]) {
  return v3(MJFX_GATHER(base, 0), MJFX_GATHER(base, 1), MJFX_GATHER(base, 2));
}

//------------------------------------------------------------------------------ quaternions of lanes

MJFX_HOT void q4_mul(const mjfxVec a[4], const mjfxVec b[4], mjfxVec out[4]) {
  mjfxVec w = a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3];
  mjfxVec x = a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2];
  mjfxVec y = a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1];
  mjfxVec z = a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0];
  out[0] = w, out[1] = x, out[2] = y, out[3] = z;
}

// a^* b
MJFX_HOT void q4_conj_mul(const mjfxVec a[4], const mjfxVec b[4], mjfxVec out[4]) {
  mjfxVec w = a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3];
  mjfxVec x = a[0] * b[1] - a[1] * b[0] - a[2] * b[3] + a[3] * b[2];
  mjfxVec y = a[0] * b[2] + a[1] * b[3] - a[2] * b[0] - a[3] * b[1];
  mjfxVec z = a[0] * b[3] - a[1] * b[2] + a[2] * b[1] - a[3] * b[0];
  out[0] = w, out[1] = x, out[2] = y, out[3] = z;
}

// R(q) v and R(q)^T v for a unit quaternion q = (w, u): with t = 2 u x v,
// R v = v + w t + u x t and R^T v = v - w t + u x t
MJFX_HOT mjfxV3 q4_apply(const mjfxVec q[4], mjfxV3 v, int inverse) {
  mjfxV3 u = v3(q[1], q[2], q[3]);
  mjfxV3 t = v3_scale(mjfx_all(2.0), v3_cross(u, v));
  mjfxV3 wt = v3_scale(q[0], t);
  return v3_add(inverse ? v3_sub(v, wt) : v3_add(v, wt), v3_cross(u, t));
}

// rotation matrix (row-major) of a unit quaternion
MJFX_HOT void q4_rot(const mjfxVec q[4], mjfxVec R[9]) {
  mjfxVec ww = q[0] * q[0], xx = q[1] * q[1], yy = q[2] * q[2], zz = q[3] * q[3];
  mjfxVec wx = q[0] * q[1], wy = q[0] * q[2], wz = q[0] * q[3], xy = q[1] * q[2], xz = q[1] * q[3];
  mjfxVec yz = q[2] * q[3];
  R[0] = ww + xx - yy - zz, R[1] = 2 * (xy - wz), R[2] = 2 * (xz + wy);
  R[3] = 2 * (xy + wz), R[4] = ww - xx + yy - zz, R[5] = 2 * (yz - wx);
  R[6] = 2 * (xz - wy), R[7] = 2 * (yz + wx), R[8] = ww - xx - yy + zz;
}

//------------------------------------------------------------------------------ the kernel

// Inputs of MJFX_LANES element evaluations of one kind (method and matrix structures shared).
typedef struct {
  mjfxVec q[4];     // relative pose: unit quaternion of R_ab, w >= 0
  mjfxV3 p;         // and p_ab
  mjfxV3 w, v;      // velocity of frame b relative to frame a, frame b axes (when viscous)
  const double* K[MJFX_LANES];  // 36 each, row-major
  const double* B[MJFX_LANES];
  const double* Kd[MJFX_LANES];  // their diagonals, 6 each (read when diagonal)
  const double* Bd[MJFX_LANES];
  const mjfxTerms* terms[MJFX_LANES];  // read when has_terms
  const double* lo[MJFX_LANES];  // end stops, 6 each (read when has_stops): lower and upper limits, stiffness
  const double* hi[MJFX_LANES];
  const double* ks[MJFX_LANES];
  const double* bs[MJFX_LANES];  // the stops' damping, 6 each (read when stop_damped; w and v given then)
  int method, kstruct, bstruct, viscous, has_terms, has_stops, stop_damped;
} mjfxLanes;

// The coordinates and what the maps need.
typedef struct {
  mjfxV3 e1, e2;        // [tau; t] or [xi; x']
  mjfxVec k0, k1;       // twist: k^
  mjfxV3 u0, u1;        // twist: c^ tau^
  mjfxVec w, s_d;       // dual quaternion: sigma, s'
} mjfxCoords;

// The rotation vector (principal log, angle alpha in [0, pi]) of q, w >= 0: tau = (alpha / n) q_v, and
// the twist maps' c(alpha), g(alpha) (mjfx_angle_coefs).
MJFX_HOT mjfxV3 mjfx_rotation_vector(const mjfxVec q[4], mjfxVec* c, mjfxVec* g) {
  mjfxV3 qv = v3(q[1], q[2], q[3]);
  mjfxVec n2 = v3_dot(qv, qv), s = n2;
  int small = 1;
  *c = *g = n2;
  for (int l = 0; l < MJFX_LANES; l++) small &= mjfx_angle_small(MJFX_LANE(n2, l), MJFX_LANE(q[0], l));
  if (small) {
    MJFX_ANGLE_SERIES(mjfxVec, n2, q[0], s, *c, *g);
  } else {
    for (int l = 0; l < MJFX_LANES; l++) {
      double sl, cl, gl;
      mjfx_angle_coefs(MJFX_LANE(n2, l), MJFX_LANE(q[0], l), &sl, &cl, &gl);
      MJFX_LANE(s, l) = sl, MJFX_LANE(*c, l) = cl, MJFX_LANE(*g, l) = gl;
    }
  }
  return v3_scale(s, qv);
}

MJFX_HOT void mjfx_coords(int method, const mjfxVec q[4], mjfxV3 p, mjfxCoords* k) {
  mjfxV3 qv = v3(q[1], q[2], q[3]);
  if (method == MJFX_TWIST) {
    mjfxVec c, g;
    mjfxV3 tau = mjfx_rotation_vector(q, &c, &g);
    mjfxVec a2 = v3_dot(tau, tau);
    k->e1 = tau;
    k->k0 = 1.0 - c * a2;
    k->u0 = v3_scale(c, tau);
    // t = P p
    mjfxV3 t = v3_add(v3_sub(v3_scale(k->k0, p), v3_scale(mjfx_all(0.5), v3_cross(tau, p))),
                      v3_scale(v3_dot(tau, p), k->u0));
    k->e2 = t;
    mjfxVec e = v3_dot(tau, t);
    k->k1 = -e * (2.0 * c + g * a2);
    k->u1 = v3_add(v3_scale(c, t), v3_scale(g * e, tau));
    return;
  }
  // dual part (eqs 37-38): s' = -xi.p / 2, x' = (w p - xi x p) / 2
  k->w = q[0];
  k->e1 = qv;
  k->s_d = -0.5 * v3_dot(qv, p);
  k->e2 = v3_sub(v3_scale(0.5 * q[0], p), v3_scale(mjfx_all(0.5), v3_cross(qv, p)));
}

// The method's dual map of x^ = x0 + eps x1 into o0 + eps o1: Gamma's P^ (sign -1) or P^T
// (sign +1) for the twist, Lambda (sign -1) or Lambda^T (sign +1) for the dual quaternion.
MJFX_HOT void mjfx_map(int method, const mjfxCoords* k, double sign, mjfxV3 x0, mjfxV3 x1, mjfxV3* o0,
                       mjfxV3* o1) {
  mjfxV3 c0 = v3_cross(k->e1, x0), c12 = v3_add(v3_cross(k->e1, x1), v3_cross(k->e2, x0));
  if (method == MJFX_TWIST) {
    mjfxVec h = mjfx_all(0.5 * sign);
    mjfxVec s0 = v3_dot(k->e1, x0), s1 = v3_dot(k->e1, x1) + v3_dot(k->e2, x0);
    *o0 = v3_add(v3_add(v3_scale(k->k0, x0), v3_scale(h, c0)), v3_scale(s0, k->u0));
    *o1 = v3_add(v3_add(v3_add(v3_add(v3_scale(k->k0, x1), v3_scale(k->k1, x0)), v3_scale(h, c12)),
                        v3_scale(s1, k->u0)),
                 v3_scale(s0, k->u1));
    return;
  }
  mjfxVec sg = mjfx_all(sign);
  *o0 = v3_add(v3_scale(k->w, x0), v3_scale(sg, c0));
  *o1 = v3_add(v3_add(v3_scale(k->w, x1), v3_scale(k->s_d, x0)), v3_scale(sg, c12));
}

// [y1; y2] = M [a; b] for 6x6 row-major matrices M[l] of the given structure (diagonals D[l])
MJFX_HOT void mjfx_mat6(const double* const M[MJFX_LANES], const double* const D[MJFX_LANES], int structure,
                        mjfxV3 a, mjfxV3 b, mjfxV3* y1, mjfxV3* y2) {
  if (structure == MJFX_ZERO) {
    mjfxVec z = mjfx_all(0.0);
    *y1 = *y2 = v3(z, z, z);
    return;
  }
  if (structure == MJFX_DIAGONAL) {
    *y1 = v3(MJFX_GATHER(D, 0) * a.x, MJFX_GATHER(D, 1) * a.y, MJFX_GATHER(D, 2) * a.z);
    *y2 = v3(MJFX_GATHER(D, 3) * b.x, MJFX_GATHER(D, 4) * b.y, MJFX_GATHER(D, 5) * b.z);
    return;
  }
  mjfxVec r[6];
  for (int i = 0; i < 6; i++) {
    int o = 6 * i;
    r[i] = MJFX_GATHER(M, o) * a.x + MJFX_GATHER(M, o + 1) * a.y + MJFX_GATHER(M, o + 2) * a.z +
           MJFX_GATHER(M, o + 3) * b.x + MJFX_GATHER(M, o + 4) * b.y + MJFX_GATHER(M, o + 5) * b.z;
  }
  *y1 = v3(r[0], r[1], r[2]);
  *y2 = v3(r[3], r[4], r[5]);
}

// the coordinates of lane l as the terms see them (twist: tau, t; dual quaternion: sigma, xi, s', x')
MJFX_HOT void mjfx_coords_lane(int method, const mjfxCoords* k, int l, double z[MJFX_TERM_COLUMNS]) {
  if (method == MJFX_TWIST) {
    v3_lane(k->e1, l, z);
    v3_lane(k->e2, l, z + 3);
    z[6] = z[7] = 0.0;
    return;
  }
  z[0] = MJFX_LANE(k->w, l), z[4] = MJFX_LANE(k->s_d, l);
  v3_lane(k->e1, l, z + 1);
  v3_lane(k->e2, l, z + 5);
}

//------------------------------------------------------------------------------ end stops

// End stops (mjflex.core.stops derives all of this): one-sided limits [lo_i, hi_i] (-inf / +inf: none)
// on the stop coordinates z = [tau; p] (the rotation vector of R_ab and p_ab, for both methods), energy
// U = sum_i k_i / 2 (max(z_i - hi_i, 0)^2 + max(lo_i - z_i, 0)^2), gradient
// G_i = k_i (max(z_i - hi_i, 0) - max(lo_i - z_i, 0)), and wrench on B (about b's origin, b axes)
// m = -P(tau) G_tau (P = J_r^-T, eq. 44), f = -R_ab^T G_p. An element without stops never gets here
// (its group's kind has no stops), so it pays nothing for them.
// Damped stops (stop_damped) replace G by the total stop force G'_i: with the coordinates' rates
// zdot = [P^T w; R_ab v] (w, v: the velocity of b relative to a in b's axes), beyond an upper limit
// G'_i = max(k_i over_i + b_i zdot_i, 0), beyond a lower one G'_i = -max(k_i under_i - b_i zdot_i, 0),
// inside the range 0: the damping acts only beyond the limit, and the clamp at 0 (continuous) keeps the
// stop from ever pulling the body back in. The dissipated power sum_i (G'_i - G_i) zdot_i is >= 0.

// k_i (over^2 + under^2) of coordinate i of each lane at z, and its derivative G_i into grad
MJFX_HOT mjfxVec mjfx_stop_axis(const mjfxLanes* in, int i, mjfxVec z, mjfxVec* grad) {
  mjfxVec zero = mjfx_all(0.0), k = MJFX_GATHER(in->ks, i);
  mjfxVec over = mjfx_max(z - MJFX_GATHER(in->hi, i), zero), under = mjfx_max(MJFX_GATHER(in->lo, i) - z, zero);
  *grad = k * (over - under);
  return k * (over * over + under * under);
}

// The stops' energy at [tau; p] and its gradient (g1: rotation, g2: position)
MJFX_HOT mjfxVec mjfx_stop_energy(const mjfxLanes* in, mjfxV3 tau, mjfxV3 p, mjfxV3* g1, mjfxV3* g2) {
  mjfxVec z[6] = {tau.x, tau.y, tau.z, p.x, p.y, p.z}, g[6], u = mjfx_all(0.0);
  for (int i = 0; i < 6; i++) u = u + mjfx_stop_axis(in, i, z[i], g + i);
  *g1 = v3(g[0], g[1], g[2]), *g2 = v3(g[3], g[4], g[5]);
  return 0.5 * u;
}

// tau and what P(tau) x = k0 x - tau x x / 2 + (tau . x) u0 needs: the twist's own (k), else computed
MJFX_HOT mjfxV3 mjfx_stop_rotation(const mjfxLanes* in, const mjfxCoords* k, mjfxVec* k0, mjfxV3* u0) {
  if (in->method == MJFX_TWIST) {
    *k0 = k->k0, *u0 = k->u0;
    return k->e1;
  }
  mjfxVec c, g;
  mjfxV3 tau = mjfx_rotation_vector(in->q, &c, &g);
  *k0 = 1.0 - c * v3_dot(tau, tau), *u0 = v3_scale(c, tau);
  return tau;
}

// The damped stops' force G' (g1: rotation, g2: position) at [tau; p] with rates [zr; zp]; returns the power
// their damping dissipates
MJFX_HOT mjfxVec mjfx_stop_damped(const mjfxLanes* in, mjfxV3 tau, mjfxV3 p, mjfxV3 zr, mjfxV3 zp, mjfxV3* g1,
                                  mjfxV3* g2) {
  mjfxVec z[6] = {tau.x, tau.y, tau.z, p.x, p.y, p.z}, r[6] = {zr.x, zr.y, zr.z, zp.x, zp.y, zp.z}, g[6];
  mjfxVec zero = mjfx_all(0.0), pwr = zero;
  for (int i = 0; i < 6; i++) {
    mjfxVec k = MJFX_GATHER(in->ks, i), b = MJFX_GATHER(in->bs, i);
    mjfxVec over = mjfx_max(z[i] - MJFX_GATHER(in->hi, i), zero), under = mjfx_max(MJFX_GATHER(in->lo, i) - z[i], zero);
    mjfxVec eo = k * over, eu = k * under;
    mjfxVec go = mjfx_max(eo + mjfx_where_positive(over, b) * r[i], zero);
    mjfxVec gu = mjfx_max(eu - mjfx_where_positive(under, b) * r[i], zero);
    g[i] = go - gu;
    pwr = pwr + ((go - eo) - (gu - eu)) * r[i];
  }
  *g1 = v3(g[0], g[1], g[2]), *g2 = v3(g[3], g[4], g[5]);
  return pwr;
}

// add the stops' wrench on B to (m, f) (b axes) and their dissipated power to *power; returns their energy
MJFX_HOT mjfxVec mjfx_stop_wrench(const mjfxLanes* in, const mjfxCoords* k, mjfxV3* m, mjfxV3* f, mjfxVec* power) {
  mjfxVec k0;
  mjfxV3 u0, g1, g2;
  mjfxV3 tau = mjfx_stop_rotation(in, k, &k0, &u0);
  mjfxVec u = mjfx_stop_energy(in, tau, in->p, &g1, &g2);
  if (in->stop_damped) {  // rates: zr = P^T w = k0 w + tau x w / 2 + (tau . w) u0, zp = R_ab v
    mjfxV3 zr = v3_add(v3_add(v3_scale(k0, in->w), v3_scale(mjfx_all(0.5), v3_cross(tau, in->w))),
                       v3_scale(v3_dot(tau, in->w), u0));
    *power = *power + mjfx_stop_damped(in, tau, in->p, zr, q4_apply(in->q, in->v, 0), &g1, &g2);
  }
  mjfxV3 pg = v3_add(v3_sub(v3_scale(k0, g1), v3_scale(mjfx_all(0.5), v3_cross(tau, g1))), v3_scale(v3_dot(tau, g1), u0));
  *m = v3_sub(*m, pg);
  *f = v3_sub(*f, q4_apply(in->q, g2, 1));
  return u;
}

//------------------------------------------------------------------------------ the element

// Wrench of each lane's element on its body B: moment about the origin of frame b and force, frame
// b axes; the dissipated power (0 unless viscous).
MJFX_HOT void mjfx_kernel(const mjfxLanes* in, mjfxV3* m, mjfxV3* f, mjfxVec* power) {
  mjfxCoords k;
  int method = in->method;
  mjfx_coords(method, in->q, in->p, &k);
  mjfxV3 y1, y2, mb, fb;
  mjfx_mat6(in->K, in->Kd, in->kstruct, k.e1, k.e2, &y1, &y2);
  mjfxVec pwr = mjfx_all(0.0);
  if (in->viscous && in->bstruct != MJFX_ZERO) {
    // rate of the coordinates: Gamma_ab^T V (eq. 58) or Lambda_ab^T V / 2 (eqs 84, 97)
    mjfxV3 r1, r2, b1, b2;
    mjfx_map(method, &k, 1.0, in->w, in->v, &r1, &r2);
    if (method != MJFX_TWIST) {
      mjfxVec half = mjfx_all(0.5);
      r1 = v3_scale(half, r1), r2 = v3_scale(half, r2);
    }
    mjfx_mat6(in->B, in->Bd, in->bstruct, r1, r2, &b1, &b2);
    pwr = v3_dot(r1, b1) + v3_dot(r2, b2);
    y1 = v3_add(y1, b1), y2 = v3_add(y2, b2);
  }
  double scale = method == MJFX_TWIST ? -1.0 : -2.0;
  if (in->has_terms) {
    mjfxVec grad[MJFX_TERM_COLUMNS];
    for (int l = 0; l < MJFX_LANES; l++) {
      double z[MJFX_TERM_COLUMNS], gl[MJFX_TERM_COLUMNS] = {0};
      mjfx_coords_lane(method, &k, l, z);
      mjfx_terms_eval(method, z, in->terms[l], gl, 1);
      for (int i = 0; i < MJFX_TERM_COLUMNS; i++) MJFX_LANE(grad[i], l) = gl[i];
    }
    if (method == MJFX_TWIST) {
      y1 = v3_add(y1, v3(grad[0], grad[1], grad[2]));
      y2 = v3_add(y2, v3(grad[3], grad[4], grad[5]));
      mjfx_map(method, &k, -1.0, y2, y1, &fb, &mb);
    } else {
      mjfxVec q = mjfx_all(0.25);
      y1 = v3_add(y1, v3_scale(q, v3(grad[1], grad[2], grad[3])));
      y2 = v3_add(y2, v3_scale(q, v3(grad[5], grad[6], grad[7])));
      mjfxV3 mm, ff;
      mjfx_map(method, &k, -1.0, y2, y1, &ff, &mm);
      // sigma and s' columns of eq. 116, times 1/4 because scale = -2 stands for -1/2
      mb = v3_sub(v3_sub(mm, v3_scale(0.25 * grad[0], k.e1)), v3_scale(0.25 * grad[4], k.e2));
      fb = v3_sub(ff, v3_scale(0.25 * grad[4], k.e1));
    }
  } else {
    mjfx_map(method, &k, -1.0, y2, y1, &fb, &mb);
  }
  if (method != MJFX_TWIST) pwr = 4.0 * pwr;
  mjfxVec sc = mjfx_all(scale);
  *m = v3_scale(sc, mb);
  *f = v3_scale(sc, fb);
  if (in->has_stops) mjfx_stop_wrench(in, &k, m, f, &pwr);
  *power = pwr;
}

// Elastic energy of each lane's element (K, the terms and the end stops).
MJFX_HOT mjfxVec mjfx_kernel_potential(const mjfxLanes* in) {
  mjfxCoords k;
  int method = in->method;
  mjfx_coords(method, in->q, in->p, &k);
  mjfxV3 y1, y2;
  mjfx_mat6(in->K, in->Kd, in->kstruct, k.e1, k.e2, &y1, &y2);
  double scale = method == MJFX_TWIST ? 0.5 : 2.0;
  mjfxVec u = mjfx_all(scale) * (v3_dot(k.e1, y1) + v3_dot(k.e2, y2));
  if (in->has_terms) {
    for (int l = 0; l < MJFX_LANES; l++) {
      double z[MJFX_TERM_COLUMNS];
      mjfx_coords_lane(method, &k, l, z);
      MJFX_LANE(u, l) += mjfx_terms_eval(method, z, in->terms[l], NULL, 0);
    }
  }
  if (in->has_stops) {
    mjfxVec k0;
    mjfxV3 u0, g1, g2;
    mjfxV3 tau = mjfx_stop_rotation(in, &k, &k0, &u0);
    u = u + mjfx_stop_energy(in, tau, in->p, &g1, &g2);
  }
  return u;
}

// Finite twist [tau; t] of each lane's relative pose.
MJFX_HOT void mjfx_kernel_twist(const mjfxLanes* in, mjfxV3* tau, mjfxV3* t) {
  mjfxCoords k;
  mjfx_coords(MJFX_TWIST, in->q, in->p, &k);
  *tau = k.e1, *t = k.e2;
}

#endif  // MJFLEX_NATIVE_FLEXURE_KERNEL_H_

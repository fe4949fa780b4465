// The one-element API of mjflex's per-element math (see flexure_math.h) over the lane kernel (flexure_kernel.h,
// an element alone in every lane), and quaternions; the scalar functions below the kernel are
// flexure_scalar.c's. mjflex/core/_kernels.py derives every formula. No allocation.

#include "flexure_math.h"

#include "flexure_kernel.h"

#include <math.h>
#include <string.h>

#if defined(__GNUC__)
#define HOT static inline __attribute__((always_inline))
#else
#define HOT static inline
#endif

//------------------------------------------------------------------------------ helpers

// R^T v (row-major R)
HOT void mat_t_vec(double out[3], const double R[9], const double v[3]) {
  double x = R[0] * v[0] + R[3] * v[1] + R[6] * v[2];
  double y = R[1] * v[0] + R[4] * v[1] + R[7] * v[2];
  double z = R[2] * v[0] + R[5] * v[1] + R[8] * v[2];
  out[0] = x;
  out[1] = y;
  out[2] = z;
}

//------------------------------------------------------------------------------ rotations

HOT void quat_from_rot9(double r00, double r01, double r02, double r10, double r11, double r12, double r20,
                           double r21, double r22, double q[4]) {
  double tr = r00 + r11 + r22, w, x, y, z;
  if (tr >= r00 && tr >= r11 && tr >= r22) {
    double s = 2.0 * sqrt(1.0 + tr), i = 1.0 / s;
    w = 0.25 * s, x = (r21 - r12) * i, y = (r02 - r20) * i, z = (r10 - r01) * i;
  } else if (r00 >= r11 && r00 >= r22) {
    double s = 2.0 * sqrt(1.0 + r00 - r11 - r22), i = 1.0 / s;
    w = (r21 - r12) * i, x = 0.25 * s, y = (r01 + r10) * i, z = (r02 + r20) * i;
  } else if (r11 >= r22) {
    double s = 2.0 * sqrt(1.0 + r11 - r00 - r22), i = 1.0 / s;
    w = (r02 - r20) * i, x = (r01 + r10) * i, y = 0.25 * s, z = (r12 + r21) * i;
  } else {
    double s = 2.0 * sqrt(1.0 + r22 - r00 - r11), i = 1.0 / s;
    w = (r10 - r01) * i, x = (r02 + r20) * i, y = (r12 + r21) * i, z = 0.25 * s;
  }
  double n = 1.0 / sqrt(w * w + x * x + y * y + z * z);
  if (w < 0.0) n = -n;
  q[0] = w * n, q[1] = x * n, q[2] = y * n, q[3] = z * n;
}

void mjfx_quat_from_rot(const double R[9], double q[4]) {
  quat_from_rot9(R[0], R[1], R[2], R[3], R[4], R[5], R[6], R[7], R[8], q);
}

void mjfx_quat_mul(const double a[4], const double b[4], double out[4]) {
  double w = a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3];
  double x = a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2];
  double y = a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1];
  double z = a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0];
  out[0] = w, out[1] = x, out[2] = y, out[3] = z;
}

void mjfx_rot_from_quat(const double q[4], double R[9]) {
  double ww = q[0] * q[0], xx = q[1] * q[1], yy = q[2] * q[2], zz = q[3] * q[3];
  double wx = q[0] * q[1], wy = q[0] * q[2], wz = q[0] * q[3], xy = q[1] * q[2], xz = q[1] * q[3], yz = q[2] * q[3];
  R[0] = ww + xx - yy - zz, R[1] = 2 * (xy - wz), R[2] = 2 * (xz + wy);
  R[3] = 2 * (xy + wz), R[4] = ww - xx + yy - zz, R[5] = 2 * (yz - wx);
  R[6] = 2 * (xz - wy), R[7] = 2 * (yz + wx), R[8] = ww - xx - yy + zz;
}

// column i of A dotted with column j of B
HOT double col_dot(const double A[9], int i, const double B[9], int j) {
  return A[i] * B[j] + A[3 + i] * B[3 + j] + A[6 + i] * B[6 + j];
}

// quaternion of R_ab = R_WA^T R_WB (w >= 0)
HOT void relative_quat(const double Ra[9], const double Rb[9], double q[4]) {
  quat_from_rot9(col_dot(Ra, 0, Rb, 0), col_dot(Ra, 0, Rb, 1), col_dot(Ra, 0, Rb, 2), col_dot(Ra, 1, Rb, 0),
                 col_dot(Ra, 1, Rb, 1), col_dot(Ra, 1, Rb, 2), col_dot(Ra, 2, Rb, 0), col_dot(Ra, 2, Rb, 1),
                 col_dot(Ra, 2, Rb, 2), q);
}

// p_ab = R_WA^T (p_WB - p_WA)
HOT void relative_position(const double Ra[9], const double pa[3], const double pb[3], double p[3]) {
  double d[3] = {pb[0] - pa[0], pb[1] - pa[1], pb[2] - pa[2]};
  mat_t_vec(p, Ra, d);
}

//------------------------------------------------------------------------------ one element

// an input in every lane (diag: room for the diagonals of K and B)
static void lanes_of(const mjfxInput* in, mjfxLanes* x, double diag[12]) {
  const double *q = in->q, *p = in->p;
  memset(x, 0, sizeof(*x));
  for (int i = 0; i < 4; i++) x->q[i] = mjfx_all(q[i]);
  x->p = v3(mjfx_all(p[0]), mjfx_all(p[1]), mjfx_all(p[2]));
  x->viscous = in->viscous && in->B && in->w && in->v;
  if (x->viscous) {
    const double *w = in->w, *v = in->v;
    x->w = v3(mjfx_all(w[0]), mjfx_all(w[1]), mjfx_all(w[2]));
    x->v = v3(mjfx_all(v[0]), mjfx_all(v[1]), mjfx_all(v[2]));
  }
  for (int i = 0; i < 6; i++) diag[i] = in->K ? in->K[7 * i] : 0.0, diag[6 + i] = in->B ? in->B[7 * i] : 0.0;
  x->has_terms = in->terms && in->terms->n > 0;
  for (int l = 0; l < MJFX_LANES; l++) {
    x->K[l] = in->K, x->B[l] = in->B, x->terms[l] = in->terms, x->Kd[l] = diag, x->Bd[l] = diag + 6;
  }
  x->method = in->method, x->kstruct = in->kstruct, x->bstruct = in->B ? in->bstruct : MJFX_ZERO;
}

void mjfx_wrench_b(const mjfxInput* in, double m[3], double f[3], double* power) {
  mjfxLanes x;
  double diag[12];
  lanes_of(in, &x, diag);
  mjfxV3 mv, fv;
  mjfxVec pv;
  mjfx_kernel(&x, &mv, &fv, &pv);
  v3_lane(mv, 0, m);
  v3_lane(fv, 0, f);
  *power = MJFX_LANE(pv, 0);
}

double mjfx_potential(const mjfxInput* in) {
  mjfxLanes x;
  double diag[12];
  lanes_of(in, &x, diag);
  return MJFX_LANE(mjfx_kernel_potential(&x), 0);
}

void mjfx_coordinates(const mjfxInput* in, double xi[6]) {
  mjfxLanes x;
  double diag[12];
  lanes_of(in, &x, diag);
  mjfxV3 tau, t;
  mjfx_kernel_twist(&x, &tau, &t);
  v3_lane(tau, 0, xi);
  v3_lane(t, 0, xi + 3);
}

void mjfx_relative_pose(const double Ra[9], const double pa[3], const double Rb[9], const double pb[3], double q[4],
                        double p[3]) {
  relative_quat(Ra, Rb, q);
  relative_position(Ra, pa, pb, p);
}

void mjfx_relative_velocity(const double Rb[9], const double pa[3], const double pb[3], const double wa[3],
                            const double va[3], const double wb[3], const double vb[3], double w[3], double v[3]) {
  // velocity of the point of A at p_WB: va + wa x (pb - pa)
  double r[3] = {pb[0] - pa[0], pb[1] - pa[1], pb[2] - pa[2]}, dw[3], dv[3];
  double wr[3] = {wa[1] * r[2] - wa[2] * r[1], wa[2] * r[0] - wa[0] * r[2], wa[0] * r[1] - wa[1] * r[0]};
  for (int i = 0; i < 3; i++) dw[i] = wb[i] - wa[i], dv[i] = vb[i] - (va[i] + wr[i]);
  mat_t_vec(w, Rb, dw);
  mat_t_vec(v, Rb, dv);
}

void mjfx_twist(const double Ra[9], const double pa[3], const double Rb[9], const double pb[3], double xi[6]) {
  double q[4], p[3];
  mjfx_relative_pose(Ra, pa, Rb, pb, q, p);
  mjfxInput in = {.q = q, .p = p, .method = MJFX_TWIST};
  mjfx_coordinates(&in, xi);
}

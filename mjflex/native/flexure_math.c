// The per-element math of mjflex (see flexure_math.h). A port of mjflex/core/_kernels.py and
// _poly_kernels.py, whose docstrings derive every formula (paper's equation numbers in
// brackets). Everything works on one element with 3-vectors on the stack: no allocation.

#include "flexure_math.h"

#include <math.h>
#include <string.h>

// the per-element helpers are inlined into the one exported kernel (mjfx_wrench): no calls per element
#if defined(__GNUC__)
#define HOT static inline __attribute__((always_inline))
#else
#define HOT static inline
#endif

// Taylor coefficients in x = a^2 of c(a) = (1 - (a/2) cot(a/2)) / a^2 and of g(a) = c'(a) / a
// (mjflex.core._series.JL_INV_COEFFS, JL_INV_RATE_COEFFS, exact to the last digit shown).
#define NSERIES 12
static const double JL_C[NSERIES] = {
    0.08333333333333333,    0.001388888888888889,   3.306878306878307e-05,  8.267195767195768e-07,
    2.08767569878681e-08,   5.284190138687493e-10,  1.3382536530684679e-11, 3.3896802963225827e-13,
    8.586062056277845e-15,  2.174868698558062e-16,  5.5090028283602295e-18, 1.3954464685812522e-19,
};
static const double JL_G[NSERIES] = {
    0.002777777777777778,  0.00013227513227513228, 4.96031746031746e-06,   1.670140559029448e-07,
    5.2841901386874934e-09, 1.6059043836821613e-10, 4.745552414851616e-12,  1.3737699290044552e-13,
    3.914763657404511e-15, 1.1018005656720459e-16, 3.069982230878755e-18,  8.483296895110721e-20,
};
// below this angle [rad] the series are used (mjflex.core._series.SERIES_THRESHOLD)
#define SERIES_THRESHOLD 1.0

int mjfx_series_coefficients(double* c, double* g, int n) {
  for (int k = 0; k < n && k < NSERIES; k++) {
    c[k] = JL_C[k];
    g[k] = JL_G[k];
  }
  return NSERIES;
}

//------------------------------------------------------------------------------ 3-vectors

HOT void cross(double out[3], const double a[3], const double b[3]) {
  double x = a[1] * b[2] - a[2] * b[1];
  double y = a[2] * b[0] - a[0] * b[2];
  double z = a[0] * b[1] - a[1] * b[0];
  out[0] = x;
  out[1] = y;
  out[2] = z;
}

HOT double dot(const double a[3], const double b[3]) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

// out = ca a + cb b
HOT void lin(double out[3], double ca, const double a[3], double cb, const double b[3]) {
  for (int i = 0; i < 3; i++) out[i] = ca * a[i] + cb * b[i];
}

// out = ca a + cb b + cc c
HOT void lin3(double out[3], double ca, const double a[3], double cb, const double b[3], double cc,
                        const double c[3]) {
  for (int i = 0; i < 3; i++) out[i] = ca * a[i] + cb * b[i] + cc * c[i];
}

// R v, R^T v (row-major R)
HOT void mat_vec(double out[3], const double R[9], const double v[3]) {
  double x = R[0] * v[0] + R[1] * v[1] + R[2] * v[2];
  double y = R[3] * v[0] + R[4] * v[1] + R[5] * v[2];
  double z = R[6] * v[0] + R[7] * v[1] + R[8] * v[2];
  out[0] = x;
  out[1] = y;
  out[2] = z;
}

HOT void mat_t_vec(double out[3], const double R[9], const double v[3]) {
  double x = R[0] * v[0] + R[3] * v[1] + R[6] * v[2];
  double y = R[1] * v[0] + R[4] * v[1] + R[7] * v[2];
  double z = R[2] * v[0] + R[5] * v[1] + R[8] * v[2];
  out[0] = x;
  out[1] = y;
  out[2] = z;
}

// [y1; y2] = M [a; b] for a 6x6 row-major M of the given structure
HOT void mat6_vec(double y1[3], double y2[3], const double M[36], int structure, const double a[3],
                     const double b[3]) {
  if (structure == MJFX_ZERO) {
    y1[0] = y1[1] = y1[2] = y2[0] = y2[1] = y2[2] = 0.0;
    return;
  }
  if (structure == MJFX_DIAGONAL) {
    for (int i = 0; i < 3; i++) {
      y1[i] = M[7 * i] * a[i];
      y2[i] = M[7 * (i + 3)] * b[i];
    }
    return;
  }
  double r[6];
  for (int i = 0; i < 6; i++) {
    const double* row = M + 6 * i;
    r[i] = row[0] * a[0] + row[1] * a[1] + row[2] * a[2] + row[3] * b[0] + row[4] * b[1] + row[5] * b[2];
  }
  y1[0] = r[0], y1[1] = r[1], y1[2] = r[2], y2[0] = r[3], y2[1] = r[4], y2[2] = r[5];
}

int mjfx_matrix_structure(const double M[36]) {
  int offdiag = 0, diag = 0;
  for (int i = 0; i < 6; i++) {
    for (int j = 0; j < 6; j++) {
      if (M[6 * i + j] != 0.0) {
        if (i == j) diag = 1;
        else offdiag = 1;
      }
    }
  }
  return offdiag ? MJFX_FULL : (diag ? MJFX_DIAGONAL : MJFX_ZERO);
}

//------------------------------------------------------------------------------ scalar functions

// Terms of the series that matter at x = a^2: successive coefficients shrink by about
// 1 / (2 pi)^2, so term k is ~(x / 39.5)^k of the first; the rest are below round-off.
HOT int series_terms(double x) {
  return x < 1e-6 ? 3 : x < 1e-4 ? 4 : x < 1e-3 ? 5 : x < 1e-2 ? 6 : x < 0.1 ? 8 : NSERIES;
}

// c(a) = (1 - (a/2) cot(a/2)) / a^2 and g(a) = c'(a) / a, given cos(a/2) and sin(a/2), 0 <= a < 2 pi
HOT void jl_inv_coefs(double a, double cos_h, double sin_h, double* c, double* g) {
  if (a < SERIES_THRESHOLD) {
    double x = a * a, cc = 0.0, gg = 0.0;
    for (int k = series_terms(x) - 1; k >= 0; k--) {
      cc = cc * x + JL_C[k];
      gg = gg * x + JL_G[k];
    }
    *c = cc;
    *g = gg;
    return;
  }
  double h = 0.5 * a;
  double cot = cos_h / sin_h;
  double one_m = 1.0 - h * cot;
  double dc_dh = (-cot + h / (sin_h * sin_h)) / (4.0 * h * h) - one_m / (2.0 * h * h * h);
  *c = one_m / (a * a);
  *g = dc_dh / (4.0 * h);
}

// alpha / n = 2 atan2(n, w) / n, the factor from the vector part of a unit quaternion (w >= 0, n its
// norm) to the rotation vector. Below about 6 degrees by the series 2/w sum (-r^2)^k / (2k + 1),
// r = n / w, with the terms that matter at r^2 (the rest below round-off); atan2 above.
static const double ODD_INV[9] = {1.0,       1.0 / 3.0,  1.0 / 5.0,  1.0 / 7.0, 1.0 / 9.0,
                                  1.0 / 11.0, 1.0 / 13.0, 1.0 / 15.0, 1.0 / 17.0};

HOT double half_angle_ratio(double n, double w) {
  if (n < 0.1 * w) {
    double iw = 1.0 / w, r = n * iw, r2 = r * r;
    int terms = r2 < 1e-8 ? 3 : r2 < 1e-5 ? 4 : r2 < 1e-3 ? 6 : 9;
    double acc = 0.0;
    for (int k = terms - 1; k >= 0; k--) acc = acc * -r2 + ODD_INV[k];
    return 2.0 * iw * acc;
  }
  return 2.0 * atan2(n, w) / n;
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

void mjfx_quat_conj_mul(const double a[4], const double b[4], double out[4]) {
  double w = a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3];
  double x = a[0] * b[1] - a[1] * b[0] - a[2] * b[3] + a[3] * b[2];
  double y = a[0] * b[2] + a[1] * b[3] - a[2] * b[0] - a[3] * b[1];
  double z = a[0] * b[3] - a[1] * b[2] + a[2] * b[1] - a[3] * b[0];
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

//------------------------------------------------------------------------------ coordinates

// Symmetric 3x3 matrix as its 6 entries (xx, yy, zz, xy, xz, yz).
typedef double Sym[6];

HOT void sym_vec(double out[3], const Sym S, const double v[3]) {
  double x = S[0] * v[0] + S[3] * v[1] + S[4] * v[2];
  double y = S[3] * v[0] + S[1] * v[1] + S[5] * v[2];
  double z = S[4] * v[0] + S[5] * v[1] + S[2] * v[2];
  out[0] = x, out[1] = y, out[2] = z;
}

// The displacement coordinates of an element and what the maps need.
//
// Twist: P = I - tau^/2 + c (tau^)^2 = S - tau^/2 with the symmetric S = I + c (tau tau^T - a^2 I)
// (eq. 44), and D = dP[t] = Dsym - t^/2 with the symmetric
// Dsym = c (t tau^T + tau t^T - 2 (tau.t) I) + g (tau.t) (tau tau^T - a^2 I), using
// u^ v^ = v u^T - (u.v) I. Then P y = S y - tau x y / 2, P^T y = S y + tau x y / 2, and likewise
// D, so every product below is one symmetric matrix times a vector plus a cross product.
typedef struct {
  double e1[3], e2[3];  // [tau; t] or [xi_v; x']
  Sym S, Dsym;          // twist
  double c, g;          // twist: coefficients at the angle
  double w, s_d;        // dual quaternion: sigma, s'
} Coords;

HOT void coords(const mjfxInput* in, Coords* k) {
  double qq[4], pp[3];
  const double *q = in->q, *p = in->p;
  if (!q) {
    relative_quat(in->Ra, in->Rb, qq);
    relative_position(in->Ra, in->pa, in->pb, pp);
    q = qq, p = pp;
  }
  if (in->method == MJFX_TWIST) {
    // rotation vector (principal log, angle in [0, pi]) of q, w >= 0
    double n = sqrt(q[1] * q[1] + q[2] * q[2] + q[3] * q[3]), alpha = 0.0;
    double* tau = k->e1;
    if (n == 0.0) {
      tau[0] = tau[1] = tau[2] = 0.0;
    } else {
      double s = half_angle_ratio(n, q[0]);
      alpha = s * n;
      tau[0] = s * q[1], tau[1] = s * q[2], tau[2] = s * q[3];
    }
    jl_inv_coefs(alpha, q[0], n, &k->c, &k->g);
    double a2 = dot(tau, tau), c = k->c;
    Sym T2 = {tau[0] * tau[0] - a2, tau[1] * tau[1] - a2, tau[2] * tau[2] - a2,
              tau[0] * tau[1],      tau[0] * tau[2],      tau[1] * tau[2]};
    for (int i = 0; i < 6; i++) k->S[i] = (i < 3 ? 1.0 : 0.0) + c * T2[i];
    double tp[3], *t = k->e2;
    cross(tp, tau, p);
    sym_vec(t, k->S, p);
    for (int i = 0; i < 3; i++) t[i] -= 0.5 * tp[i];
    double e = dot(tau, t), ge = k->g * e;
    Sym sym = {2.0 * (t[0] * tau[0] - e), 2.0 * (t[1] * tau[1] - e), 2.0 * (t[2] * tau[2] - e),
               t[0] * tau[1] + tau[0] * t[1], t[0] * tau[2] + tau[0] * t[2], t[1] * tau[2] + tau[1] * t[2]};
    for (int i = 0; i < 6; i++) k->Dsym[i] = c * sym[i] + ge * T2[i];
    return;
  }
  k->w = q[0];
  k->e1[0] = q[1], k->e1[1] = q[2], k->e1[2] = q[3];
  // dual part (eqs 37-38): s' = -xi.p / 2, x' = (w p - xi x p) / 2
  double xp[3];
  k->s_d = -0.5 * dot(k->e1, p);
  cross(xp, k->e1, p);
  lin(k->e2, 0.5 * q[0], p, -0.5, xp);
}

//------------------------------------------------------------------------------ rates and maps

// rate of the coordinates from the world velocities of the frames
HOT void coords_rate(const mjfxInput* in, const Coords* k, double r1[3], double r2[3]) {
  double wa[3], va[3], wb[3], vb[3];
  mat_t_vec(wa, in->Ra, in->wa);
  mat_t_vec(va, in->Ra, in->va);
  mat_t_vec(wb, in->Rb, in->wb);
  mat_t_vec(vb, in->Rb, in->vb);
  double dw[3], sw[3], dv[3], sv[3];
  for (int i = 0; i < 3; i++) dw[i] = wb[i] - wa[i], sw[i] = wb[i] + wa[i], dv[i] = vb[i] - va[i], sv[i] = vb[i] + va[i];
  double x1[3], x2[3], x3[3];
  if (in->method == MJFX_TWIST) {
    // Jr^-1 V_b - Jl^-1 V_a (eq. 58): r1 = P^T wb - P wa, r2 = D^T wb + P^T vb - D wa - P va
    const double *tau = k->e1, *t = k->e2;
    double s1[3], s2[3], s3[3];
    cross(x1, tau, sw);
    cross(x2, t, sw);
    cross(x3, tau, sv);
    sym_vec(s1, k->S, dw);
    sym_vec(s2, k->Dsym, dw);
    sym_vec(s3, k->S, dv);
    for (int i = 0; i < 3; i++) {
      r1[i] = s1[i] + 0.5 * x1[i];
      r2[i] = s2[i] + 0.5 * x2[i] + s3[i] + 0.5 * x3[i];
    }
    return;
  }
  // (Lambda_ab^T V_b - Lambda_ba^T V_a) / 2 (eqs 84, 97): the sums and differences of the velocities
  cross(x1, k->e1, sw);
  cross(x2, k->e2, sw);
  cross(x3, k->e1, sv);
  for (int i = 0; i < 3; i++) {
    r1[i] = 0.5 * (k->w * dw[i] + x1[i]);
    r2[i] = 0.5 * (k->s_d * dw[i] + x2[i] + k->w * dv[i] + x3[i]);
  }
}

// [m; f] = Gamma_ab [y1; y2] (twist, eq. 46) or Lambda_ab [y1; y2] (dual quaternion, eq. 85), b frame
HOT void force_map(int method, const Coords* k, const double y1[3], const double y2[3], double m[3],
                      double f[3]) {
  double x1[3], x2[3], x3[3];
  cross(x1, k->e1, y1);
  cross(x2, k->e2, y2);
  cross(x3, k->e1, y2);
  if (method == MJFX_TWIST) {  // m = P y1 + D y2, f = P y2
    double s1[3], s2[3], s3[3];
    sym_vec(s1, k->S, y1);
    sym_vec(s2, k->Dsym, y2);
    sym_vec(s3, k->S, y2);
    for (int i = 0; i < 3; i++) {
      m[i] = s1[i] - 0.5 * x1[i] + s2[i] - 0.5 * x2[i];
      f[i] = s3[i] - 0.5 * x3[i];
    }
    return;
  }
  for (int i = 0; i < 3; i++) {  // m = (sigma - xi^) y1 + (s' - x'^) y2, f = (sigma - xi^) y2
    m[i] = k->w * y1[i] - x1[i] + k->s_d * y2[i] - x2[i];
    f[i] = k->w * y2[i] - x3[i];
  }
}

//------------------------------------------------------------------------------ polynomial terms

// powers 0..top of the coordinates into pw[k][p]; returns the number of coordinates
static int fill_powers(int method, const Coords* k, double pw[MJFX_TERM_COLUMNS][MJFX_MAX_EXPONENT + 1], int top) {
  double z[MJFX_TERM_COLUMNS];
  int nvar;
  if (method == MJFX_TWIST) {
    nvar = 6;
    for (int i = 0; i < 3; i++) z[i] = k->e1[i], z[3 + i] = k->e2[i];
  } else {
    nvar = 8;
    z[0] = k->w, z[4] = k->s_d;
    for (int i = 0; i < 3; i++) z[1 + i] = k->e1[i], z[5 + i] = k->e2[i];
  }
  for (int i = 0; i < nvar; i++) {
    double v = 1.0;
    pw[i][0] = 1.0;
    for (int p = 1; p <= top; p++) {
      v *= z[i];
      pw[i][p] = v;
    }
  }
  return nvar;
}

// value of the terms; their gradient dU/dz into grad[0:nvar] if want_grad
static double terms_eval(int nvar, const mjfxTerms* t, double pw[MJFX_TERM_COLUMNS][MJFX_MAX_EXPONENT + 1],
                         double grad[MJFX_TERM_COLUMNS], int want_grad) {
  double suffix_k[MJFX_TERM_COLUMNS];
  if (want_grad) {
    for (int i = 0; i < nvar; i++) grad[i] = 0.0;
  }
  double value = 0.0;
  for (int r = 0; r < t->n; r++) {
    const int* e = t->exps + MJFX_TERM_COLUMNS * r;
    double c = t->coefs[r];
    if (!want_grad) {
      double v = c;
      for (int i = 0; i < nvar; i++) v *= pw[i][e[i]];
      value += v;
      continue;
    }
    double suffix = 1.0;
    for (int i = nvar - 1; i >= 0; i--) {
      suffix_k[i] = suffix;
      suffix *= pw[i][e[i]];
    }
    value += c * suffix;
    double prefix = c;
    for (int i = 0; i < nvar; i++) {
      int ei = e[i];
      if (ei > 0) grad[i] += prefix * ei * pw[i][ei - 1] * suffix_k[i];
      prefix *= pw[i][ei];
    }
  }
  return value;
}

//------------------------------------------------------------------------------ element kernels

void mjfx_wrench(const mjfxInput* in, double m[3], double f[3], double* power) {
  Coords k;
  int method = in->method;
  coords(in, &k);
  double y1[3], y2[3];
  mat6_vec(y1, y2, in->K, in->kstruct, k.e1, k.e2);
  double pwr = 0.0;
  if (in->viscous && in->B && in->bstruct != MJFX_ZERO) {
    double r1[3], r2[3], b1[3], b2[3];
    coords_rate(in, &k, r1, r2);
    mat6_vec(b1, b2, in->B, in->bstruct, r1, r2);
    pwr = dot(r1, b1) + dot(r2, b2);
    for (int i = 0; i < 3; i++) y1[i] = 1.0 * y1[i] + 1.0 * b1[i], y2[i] = 1.0 * y2[i] + 1.0 * b2[i];
  }
  double mb[3], fb[3], scale;
  if (in->terms && in->terms->n > 0) {
    double pw[MJFX_TERM_COLUMNS][MJFX_MAX_EXPONENT + 1], grad[MJFX_TERM_COLUMNS];
    int nvar = fill_powers(method, &k, pw, in->terms->top);
    terms_eval(nvar, in->terms, pw, grad, 1);
    if (method == MJFX_TWIST) {
      for (int i = 0; i < 3; i++) y1[i] = y1[i] + grad[i], y2[i] = y2[i] + grad[3 + i];
      force_map(method, &k, y1, y2, mb, fb);
      scale = -1.0;
    } else {
      for (int i = 0; i < 3; i++) y1[i] = y1[i] + 0.25 * grad[1 + i], y2[i] = y2[i] + 0.25 * grad[5 + i];
      double mm[3], ff[3];
      force_map(method, &k, y1, y2, mm, ff);
      // sigma and s' columns of eq. 116, times 1/4 because scale = -2 stands for -1/2
      lin3(mb, 1.0, mm, -0.25 * grad[0], k.e1, -0.25 * grad[4], k.e2);
      lin(fb, 1.0, ff, -0.25 * grad[4], k.e1);
      scale = -2.0;
    }
  } else {
    force_map(method, &k, y1, y2, mb, fb);
    scale = method == MJFX_TWIST ? -1.0 : -2.0;
  }
  if (method != MJFX_TWIST) pwr *= 4.0;
  double mw[3], fw[3];
  mat_vec(mw, in->Rb, mb);
  mat_vec(fw, in->Rb, fb);
  for (int i = 0; i < 3; i++) m[i] = scale * mw[i], f[i] = scale * fw[i];
  *power = pwr;
}

double mjfx_potential(const mjfxInput* in) {
  Coords k;
  coords(in, &k);
  double y1[3], y2[3];
  mat6_vec(y1, y2, in->K, in->kstruct, k.e1, k.e2);
  double scale = in->method == MJFX_TWIST ? 0.5 : 2.0;
  double u = scale * (dot(k.e1, y1) + dot(k.e2, y2));
  if (in->terms && in->terms->n > 0) {
    double pw[MJFX_TERM_COLUMNS][MJFX_MAX_EXPONENT + 1], grad[MJFX_TERM_COLUMNS];
    int nvar = fill_powers(in->method, &k, pw, in->terms->top);
    u += terms_eval(nvar, in->terms, pw, grad, 0);
  }
  return u;
}

void mjfx_twist(const double Ra[9], const double pa[3], const double Rb[9], const double pb[3], double xi[6]) {
  Coords k;
  mjfxInput in = {.Ra = Ra, .pa = pa, .Rb = Rb, .pb = pb, .method = MJFX_TWIST};
  coords(&in, &k);
  for (int i = 0; i < 3; i++) xi[i] = k.e1[i], xi[3 + i] = k.e2[i];
}

void mjfx_coordinates(const mjfxInput* in, double xi[6]) {
  Coords k;
  mjfxInput twist = *in;
  twist.method = MJFX_TWIST;
  coords(&twist, &k);
  for (int i = 0; i < 3; i++) xi[i] = k.e1[i], xi[3 + i] = k.e2[i];
}

// The scalar parts of mjflex's per-element math, below the lane kernel (flexure_kernel.h) and the one-element
// API (flexure_math.h): the methods and matrix structures, the polynomial terms' layout and evaluation, and the
// functions of the rotation angle with their series. No MuJoCo here.

#ifndef MJFLEX_NATIVE_FLEXURE_SCALAR_H_
#define MJFLEX_NATIVE_FLEXURE_SCALAR_H_

#if defined(__GNUC__)
#define MJFX_INLINE static inline __attribute__((always_inline))
#else
#define MJFX_INLINE static inline
#endif

#define MJFX_TWIST 0
#define MJFX_DUALQUAT 1

// largest exponent of one coordinate in a polynomial term (mjflex.core.polynomial.MAX_EXPONENT)
#define MJFX_MAX_EXPONENT 16
// columns of a term's exponent row (6 twist coordinates, 8 dual-quaternion coordinates)
#define MJFX_TERM_COLUMNS 8

// structure of a 6x6 matrix, detected once (mjfx_matrix_structure) so that the per-step
// products skip the zero blocks
#define MJFX_FULL 0
#define MJFX_DIAGONAL 1
#define MJFX_ZERO 2

// The polynomial terms of one element: rows of exponents (MJFX_TERM_COLUMNS ints each, the
// twist using the first 6) and their coefficients; top is the largest exponent.
typedef struct mjfxTerms_ {
  const int* exps;
  const double* coefs;
  int n;
  int top;
} mjfxTerms;

// MJFX_DIAGONAL, MJFX_ZERO or MJFX_FULL for a 6x6 row-major matrix.
int mjfx_matrix_structure(const double M[36]);

// Series coefficients used near zero angle (for a test against mjflex.core.series).
int mjfx_series_coefficients(double* c, double* g, int n);

// The scalar functions of the angle alpha of a unit quaternion (w >= 0, vector part of squared
// norm n2): s = alpha / n, the factor from the vector part to the rotation vector, and the twist
// maps' c(alpha) = (1 - (alpha/2) cot(alpha/2)) / alpha^2 and g(alpha) = c'(alpha) / alpha.
// Below about 11 degrees (n < w / 10: mjfx_angle_small) all three are series in
// rho = (n / w)^2 = tan^2(alpha / 2) (MJFX_ANGLE_SERIES), which the lanes evaluate together; above,
// each lane on its own (mjfx_angle_coefs: atan2, then series in alpha^2 or closed forms,
// flexure_scalar.c). One element gives the same bits either way.
void mjfx_angle_coefs(double n2, double w, double* s, double* c, double* g);
void mjfx_jl_inv_coefs(double a, double cos_h, double sin_h, double* c, double* g);
// Series in rho < 0.01 (flexure_scalar.c, exact rationals; tests/test_native_math.py checks them):
// atan(r) / r = sum (-rho)^k / (2k + 1) (9 terms), and c, g as functions of rho, from the Taylor
// series of c and g in alpha^2 (Bernoulli numbers) composed with alpha^2 = 4 atan(r)^2 (8 terms
// each). Their coefficients are O(1e-3) at most and alternate: term k is below 0.01^k of the
// first, the first left out (which bounds what is left out) below 2e-18 of it.
#define MJFX_ODD_TERMS 9
#define MJFX_SMALL_TERMS 8
extern const double mjfx_odd_inv[MJFX_ODD_TERMS];
extern const double mjfx_small_c[MJFX_SMALL_TERMS];
extern const double mjfx_small_g[MJFX_SMALL_TERMS];

MJFX_INLINE int mjfx_angle_small(double n2, double w) {
  return n2 < 0.01 * (w * w);
}

// sum_{k < 8} a[k] z^k by Estrin's scheme (z2 = z^2, z4 = z^4): a short chain of dependent operations
#define MJFX_ESTRIN8(a, z, z2, z4)                                                                        \
  ((((a)[0] + (a)[1] * (z)) + ((a)[2] + (a)[3] * (z)) * (z2)) +                                         \
   (((a)[4] + (a)[5] * (z)) + ((a)[6] + (a)[7] * (z)) * (z2)) * (z4))

// s, c, g by their series, written once for scalars and lanes (T), so that both compute the same
// operations: s = (2 / w) atan(r) / r, the three polynomials in rho side by side
#define MJFX_ANGLE_SERIES(T, n2, w, s, c, g)                                                             \
  do {                                                                                                   \
    T iw_ = 1.0 / (w), rho_ = (n2) * iw_ * iw_, nrho_ = -rho_, rho2_ = rho_ * rho_, rho4_ = rho2_ * rho2_; \
    T atan_ = MJFX_ESTRIN8(mjfx_odd_inv, nrho_, rho2_, rho4_) + mjfx_odd_inv[8] * (rho4_ * rho4_);     \
    (s) = 2.0 * iw_ * atan_;                                                                             \
    (c) = MJFX_ESTRIN8(mjfx_small_c, rho_, rho2_, rho4_);                                                \
    (g) = MJFX_ESTRIN8(mjfx_small_g, rho_, rho2_, rho4_);                                                \
  } while (0)

MJFX_INLINE void mjfx_angle_series(double n2, double w, double* s, double* c, double* g) {
  MJFX_ANGLE_SERIES(double, n2, w, *s, *c, *g);
}

// Gradient dU/dz of an element's polynomial terms at the coordinates z (twist: tau, t; dual
// quaternion: sigma, xi, s', x') into grad (6 or 8), and their value U.
double mjfx_terms_eval(int method, const double* z, const mjfxTerms* t, double* grad, int want_grad);

#endif  // MJFLEX_NATIVE_FLEXURE_SCALAR_H_

// The scalar functions below the lane kernel (see flexure_scalar.h): the series and closed forms of the angle
// functions, the polynomial terms, the structure of a matrix. mjflex/core/_kernels.py and _poly_kernels.py
// derive every formula. No allocation.

#include "flexure_scalar.h"

#include <math.h>

#if defined(__GNUC__)
#define HOT static inline __attribute__((always_inline))
#else
#define HOT static inline
#endif

// Taylor coefficients in x = a^2 of c(a) = (1 - (a/2) cot(a/2)) / a^2 and of g(a) = c'(a) / a: the
// first 12 are mjflex.core.series.JL_INV_COEFFS, JL_INV_RATE_COEFFS (exact to the last digit shown),
// the last 8 exact too, from c_k = (-1)^k B_(2k+2) / (2k+2)!, g_k = 2 (k+1) c_(k+1) (Bernoulli numbers).
#define NSERIES 20
static const double JL_C[NSERIES] = {
    0.08333333333333333,    0.001388888888888889,   3.306878306878307e-05,  8.267195767195768e-07,
    2.08767569878681e-08,   5.284190138687493e-10,  1.3382536530684679e-11, 3.3896802963225827e-13,
    8.586062056277845e-15,  2.174868698558062e-16,  5.5090028283602295e-18, 1.3954464685812522e-19,
    3.534707039629467e-21,  8.953517427037546e-23,  2.267952452337683e-24,  5.744790668872202e-26,
    1.455172475614865e-27,  3.6859949406653103e-29, 9.336734257095045e-31,  2.36502241570063e-32,
};
static const double JL_G[NSERIES] = {
    0.002777777777777778,  0.00013227513227513228, 4.96031746031746e-06,   1.670140559029448e-07,
    5.2841901386874934e-09, 1.6059043836821613e-10, 4.745552414851616e-12,  1.3737699290044552e-13,
    3.914763657404511e-15, 1.1018005656720459e-16, 3.069982230878755e-18,  8.483296895110721e-20,
    2.327914531029762e-21, 6.350266866545513e-23,  1.7234372006616606e-24, 4.656551921967568e-26,
    1.2532382798262054e-27, 3.3612243325542163e-29, 8.987085179662393e-31, 2.3962687049928537e-32,
};
// below this angle [rad] the series are used: the closed forms cancel below it (g's by up to 3e-13
// near 1 rad, the core's threshold mjflex.core.series.SERIES_THRESHOLD; a few 1e-15 from 2.2 rad on)
#define SERIES_THRESHOLD 2.2

int mjfx_series_coefficients(double* c, double* g, int n) {
  for (int k = 0; k < n && k < NSERIES; k++) {
    c[k] = JL_C[k];
    g[k] = JL_G[k];
  }
  return NSERIES;
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
// 1 / (2 pi)^2, so term k is ~(x / 39.5)^k of the first; the rest are below round-off
// (the 21st at x = 2.2^2 is 1e-17 of the first).
HOT int series_terms(double x) {
  return x < 1e-6 ? 3 : x < 1e-4 ? 4 : x < 1e-3 ? 5 : x < 1e-2 ? 6 : x < 0.1 ? 8 : x < 1.0 ? 12 : x < 2.56 ? 16
                                                                                                      : NSERIES;
}

// c(a) = (1 - (a/2) cot(a/2)) / a^2 and g(a) = c'(a) / a, given cos(a/2) and sin(a/2), 0 <= a < 2 pi
void mjfx_jl_inv_coefs(double a, double cos_h, double sin_h, double* c, double* g) {
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

// The series of flexure_kernel.h in rho = tan^2(alpha / 2): 1 / (2k + 1), and c, g (exact rationals)
const double mjfx_odd_inv[MJFX_ODD_TERMS] = {1.0,        1.0 / 3.0,  1.0 / 5.0,  1.0 / 7.0, 1.0 / 9.0,
                                             1.0 / 11.0, 1.0 / 13.0, 1.0 / 15.0, 1.0 / 17.0};
const double mjfx_small_c[MJFX_SMALL_TERMS] = {
    1.0 / 12.0,           1.0 / 180.0,          -1.0 / 315.0,           31.0 / 14175.0,
    -773.0 / 467775.0,    280913.0 / 212837625.0, -2095427.0 / 1915538625.0, 454756559.0 / 488462349375.0,
};
const double mjfx_small_g[MJFX_SMALL_TERMS] = {
    1.0 / 360.0,            1.0 / 1890.0,           -31.0 / 113400.0,     82.0 / 467775.0,
    -80032.0 / 638512875.0, 183374.0 / 1915538625.0, -55304.0 / 723647925.0, 818343842.0 / 12993098493375.0,
};

void mjfx_angle_coefs(double n2, double w, double* s, double* c, double* g) {
  if (mjfx_angle_small(n2, w)) {
    mjfx_angle_series(n2, w, s, c, g);  // the lanes' own code (flexure_kernel.h)
    return;
  }
  // alpha / n = 2 atan2(n, w) / n, then c and g at alpha
  double n = sqrt(n2), ratio = 2.0 * atan2(n, w) / n;
  *s = ratio;
  mjfx_jl_inv_coefs(ratio * n, w, n, c, g);
}

//------------------------------------------------------------------------------ polynomial terms

// value of the terms at z (6 twist or 8 dual-quaternion coordinates); their gradient dU/dz into
// grad[0:nvar] if want_grad
double mjfx_terms_eval(int method, const double* z, const mjfxTerms* t, double* grad, int want_grad) {
  int nvar = method == MJFX_TWIST ? 6 : 8, top = t->top;
  double pw[MJFX_TERM_COLUMNS][MJFX_MAX_EXPONENT + 1], suffix_k[MJFX_TERM_COLUMNS];
  for (int i = 0; i < nvar; i++) {  // powers 0..top of the coordinates
    double v = 1.0;
    pw[i][0] = 1.0;
    for (int p = 1; p <= top; p++) {
      v *= z[i];
      pw[i][p] = v;
    }
  }
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

// The checks of a stiffness or damping matrix (see matrix.h).

#include "matrix.h"

#include <math.h>
#include <stdio.h>

#include "schema.h"

double mjfx_min_eigenvalue(const double* M, int n) {
  if (!M || n < 1 || n > 6) return NAN;  // a ctypes caller's n: never past the 6 x 6 below
  double a[6][6];
  for (int i = 0; i < n; i++) {
    for (int j = 0; j < n; j++) a[i][j] = M[n * i + j];
  }
  for (int sweep = 0; sweep < 100; sweep++) {
    double off = 0.0, scale = 0.0;
    for (int i = 0; i < n; i++) {
      scale += a[i][i] * a[i][i];
      for (int j = i + 1; j < n; j++) off += a[i][j] * a[i][j];
    }
    if (off <= 1e-40 * scale || off == 0.0) break;
    for (int p = 0; p < n; p++) {
      for (int q = p + 1; q < n; q++) {
        if (a[p][q] == 0.0) continue;
        double theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
        double t = (theta >= 0 ? 1.0 : -1.0) / (fabs(theta) + sqrt(theta * theta + 1.0));
        double c = 1.0 / sqrt(t * t + 1.0), s = t * c;
        for (int k = 0; k < n; k++) {  // columns p, q
          double akp = a[k][p], akq = a[k][q];
          a[k][p] = c * akp - s * akq;
          a[k][q] = s * akp + c * akq;
        }
        for (int k = 0; k < n; k++) {  // rows p, q
          double apk = a[p][k], aqk = a[q][k];
          a[p][k] = c * apk - s * aqk;
          a[q][k] = s * apk + c * aqk;
        }
      }
    }
  }
  double lo = a[0][0];
  for (int i = 1; i < n; i++) lo = fmin(lo, a[i][i]);
  return lo;
}

int mjfx_check_matrix(const double* M, int n, const char* key, int stiffness, char* err, int errsz) {
  if (n != 3 && n != 6) {
    snprintf(err, errsz, "%s is %dx%d: give a 3x3 or a 6x6 matrix", key, n, n);
    return -1;
  }
  for (int i = 0; i < n * n; i++) {
    if (!isfinite(M[i])) {
      snprintf(err, errsz, "%s[%d, %d] = %g is not finite; give finite numbers", key, i / n, i % n, M[i]);
      return -1;
    }
  }
  for (int i = 0; i < n * n; i++) {
    if (fabs(M[i]) > MJFX_MAX_MATRIX_ENTRY) {
      snprintf(err, errsz,
               "%s[%d, %d] = %.3g is beyond %g, where the element's energy and forces overflow float64 for "
               "displacements MuJoCo accepts; check its units (SI: N m/rad, N/m)",
               key, i / n, i % n, M[i], MJFX_MAX_MATRIX_ENTRY);
      return -1;
    }
  }
  const char* what = stiffness ? "stiffness" : "damping";
  for (int i = 0; i < n; i++) {
    for (int j = 0; j < n; j++) {
      double scale = sqrt(fabs(M[n * i + i])) * sqrt(fabs(M[n * j + j]));
      double asym = fabs(M[n * i + j] - M[n * j + i]) / fmax(scale, 2.2250738585072014e-308);
      if (asym > MJFX_SYMMETRY_RTOL) {
        snprintf(err, errsz,
                 "%s is not symmetric: %s[%d, %d] = %.6g but %s[%d, %d] = %.6g (relative asymmetry %.3g > %g). A %s "
                 "matrix must be symmetric; if the difference is round-off, write (M + M^T) / 2",
                 key, key, i, j, M[n * i + j], key, j, i, M[n * j + i], asym, MJFX_SYMMETRY_RTOL, what);
        return -1;
      }
    }
  }
  double scaled[36], s[6];
  for (int i = 0; i < n; i++) {
    double dii = fabs(M[n * i + i]);
    s[i] = dii > 0 ? 1.0 / sqrt(dii) : 1.0;
  }
  for (int i = 0; i < n; i++) {
    for (int j = 0; j < n; j++) scaled[n * i + j] = s[i] * (0.5 * (M[n * i + j] + M[n * j + i])) * s[j];
  }
  double lam = mjfx_min_eigenvalue(scaled, n);
  if (lam < -MJFX_PSD_RTOL) {
    snprintf(err, errsz,
             "%s is not positive semi-definite: its smallest eigenvalue relative to its diagonal is %.3g (tolerance "
             "%g). A %s matrix must be positive semi-definite: %s",
             key, lam, MJFX_PSD_RTOL, what,
             stiffness ? "check the signs of the coupling block K_c (rows 0-2, columns 3-5 for 6x6; row 0, columns "
                         "1-2 for 3x3)"
                       : "a damping with an indefinite symmetric part generates energy; check its signs");
    return -1;
  }
  return 0;
}

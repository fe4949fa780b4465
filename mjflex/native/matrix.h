// The checks of an element's stiffness or damping matrix: finite, bounded, symmetric, positive semi-definite.

#ifndef MJFLEX_NATIVE_MATRIX_H_
#define MJFLEX_NATIVE_MATRIX_H_

// Tolerances (mjflex.core.validation holds them equal: tests/test_native_constants.py).
#define MJFX_SYMMETRY_RTOL 1e-8
#define MJFX_PSD_RTOL 1e-10

// Check that a 6x6 matrix (or 3x3 when n == 3) is finite, within MJFX_MAX_MATRIX_ENTRY,
// symmetric and positive semi-definite; returns 0 or -1 with the problem in err.
int mjfx_check_matrix(const double* M, int n, const char* key, int stiffness, char* err, int errsz);

// Smallest eigenvalue of a symmetric n x n matrix (n <= 6), by Jacobi rotations.
double mjfx_min_eigenvalue(const double* M, int n);

#endif  // MJFLEX_NATIVE_MATRIX_H_

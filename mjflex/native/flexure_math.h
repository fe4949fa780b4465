// The per-element math of mjflex in C: finite twist and dual quaternion, elastic + viscous,
// polynomial terms. No MuJoCo here: poses and velocities come in as plain arrays.
//
// Conventions (as in the Python package): 6-vectors angular first, wrenches [moment; force],
// rotation matrices row-major with R_WB x_B = x_W, quaternions w-first.
//
// An element is evaluated from its relative state: the pose of frame b seen from frame a (a unit
// quaternion and a position) and, for damping, the velocity of frame b relative to frame a in
// frame b's axes. The wrench comes back in frame b (the element's own frame): the callers rotate
// it once into whatever frame they need.
//
// This is the one implementation of the per-step math; mjflex.core (numpy/numba) is the
// independent reference it is tested against (tests/test_native_math.py).

#ifndef MJFLEX_NATIVE_FLEXURE_MATH_H_
#define MJFLEX_NATIVE_FLEXURE_MATH_H_

#include "flexure_scalar.h"

// Inputs of one element evaluation.
typedef struct mjfxInput_ {
  const double* q;   // relative pose: unit quaternion of R_ab = R_WA^T R_WB with w >= 0 (4)
  const double* p;   // and p_ab = R_WA^T (p_WB - p_WA) (3)
  const double* K;   // 36, row-major
  const double* B;   // 36, or NULL
  int kstruct, bstruct;
  int method;
  int viscous;       // evaluate the damping (w, v and B must be given)
  const double* w;   // velocity of frame b relative to frame a, frame b axes: R_WB^T (w_WB - w_WA) (3)
  const double* v;   // and R_WB^T (v_WB - v_WA - w_WA x (p_WB - p_WA)) (3)
  const mjfxTerms* terms;  // NULL or n == 0: quadratic potential only
} mjfxInput;

// Wrench of the element on body B: moment about the origin of frame b and force, in frame b's
// axes [N m; N]; *power: the dissipated power [W] (0 unless viscous).
void mjfx_wrench_b(const mjfxInput* in, double m[3], double f[3], double* power);

// Elastic energy [J] (K and the terms; B and velocities are not read).
double mjfx_potential(const mjfxInput* in);

// The finite twist [tau; t] of an input's relative pose (method and K not read).
void mjfx_coordinates(const mjfxInput* in, double xi[6]);

// Relative pose of frame b seen from frame a, given their world poses: q (w >= 0) and p.
void mjfx_relative_pose(const double Ra[9], const double pa[3], const double Rb[9], const double pb[3], double q[4],
                        double p[3]);

// Velocity of frame b relative to frame a in frame b's axes (mjfxInput's w, v), given the world
// angular velocities of the frames and the world linear velocities of their origins.
void mjfx_relative_velocity(const double Rb[9], const double pa[3], const double pb[3], const double wa[3],
                            const double va[3], const double wb[3], const double vb[3], double w[3], double v[3]);

// Finite twist [tau; t] of frame b relative to frame a (world poses).
void mjfx_twist(const double Ra[9], const double pa[3], const double Rb[9], const double pb[3], double xi[6]);

// Unit quaternion (w >= 0) of a rotation matrix (Shepperd), as mjflex.core.
void mjfx_quat_from_rot(const double R[9], double q[4]);

// Quaternion product a b, and the rotation matrix (row-major) of a unit quaternion.
void mjfx_quat_mul(const double a[4], const double b[4], double out[4]);
void mjfx_rot_from_quat(const double q[4], double R[9]);

#endif  // MJFLEX_NATIVE_FLEXURE_MATH_H_

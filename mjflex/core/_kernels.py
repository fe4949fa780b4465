"""Compiled scalar kernels of the screw-theory core (numba ``nopython``; no mujoco).

This module (and :mod:`._planar_kernels` for the planar versions) is the single
implementation of the math; the public functions in
:mod:`mjflex.core.transforms` and :mod:`mjflex.core.elements` validate and broadcast their
arguments and then call the ``*_batch`` loops below (the spatial elements' in :mod:`._poly_kernels`,
which run the per-element kernels here unchanged without terms). Everything works on one element
at a time with 3-vectors held in tuples, so nothing is allocated per element.

Conventions (see the package docstring): 6-vectors angular first; quaternions w-first;
``R`` row-major ``(3, 3)`` with ``R @ x_B = x_A`` for ``R_AB``.

Notation of the derivations below (standard SE(3) Lie-group calculus, written so that it
matches the paper's dual-number formulas):

* ``xi = [tau; t]`` is the finite twist of ``T_ab`` (``T_ab = exp(xi^)``),
  ``alpha = |tau|``.
* ``P(tau) = I - tau^/2 + c(alpha) (tau^)^2`` is the inverse left Jacobian of SO(3)
  (eq. 44), ``c(a) = (1 - (a/2) cot(a/2)) / a^2``, and
  ``D(tau, t) = dP(tau)[t] = -t^/2 + c (tau^ t^ + t^ tau^) + g (tau . t) (tau^)^2``,
  ``g = c'(a)/a``, its directional derivative: ``P + eps D`` is eq. 44 evaluated in dual
  arithmetic. The 6x6 inverse Jacobians of SE(3) are
  ``Jl^-1 = [[P, 0], [D, P]]`` and ``Jr^-1 = Jl^-1(-xi) = [[P^T, 0], [D^T, P^T]]``, and the
  paper's ``Gamma_ab = Jr^-T = [[P, D], [0, P]]`` (eq. 46).
* A body-frame virtual displacement ``delta`` of B (``T_b' = T_b exp(delta^)``) changes the
  twist by ``Jr^-1 delta``; the twist rate is ``Jr^-1 V_b - Jl^-1 V_a`` with body-frame
  velocities ``V`` (eq. 58); the elastic wrench of B on the element, in b coordinates
  about b's origin, is ``Gamma K xi`` (eq. 49) and the element pushes B with its negative.
* Dual-quaternion method: ``q = (sigma, xi_v) + eps (s', x')``,
  ``Lambda = [[sigma I - xi_v^, s' I - x'^], [0, sigma I - xi_v^]]`` (eq. 85),
  ``d[xi_v; x'] = Lambda^T delta / 2`` (eq. 84), the wrench is ``2 Lambda K [xi_v; x']``
  (eq. 87) and the rate uses ``Lambda_ba`` (eq. 85 with ``+xi_v^``, ``+x'^``, eq. 97).
"""

import math

from numba import njit

from .series import EXP_S3_COEFFS, JL_INV_COEFFS, JL_INV_RATE_COEFFS, SERIES_THRESHOLD

TWIST = 0
DUALQUAT = 1

_C = JL_INV_COEFFS
_G = JL_INV_RATE_COEFFS
_S3 = EXP_S3_COEFFS
_TH = SERIES_THRESHOLD
PI = math.pi
TWO_PI = 2.0 * math.pi

# --------------------------------------------------------------------------- 3-vectors


@njit(cache=True, error_model="numpy", fastmath={"contract"})
def _cross(a, b):
    return (
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    )


@njit(cache=True, error_model="numpy", fastmath={"contract"})
def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@njit(cache=True, error_model="numpy", fastmath={"contract"})
def lin(ca, a, cb, b):
    """``ca * a + cb * b``."""
    return (ca * a[0] + cb * b[0], ca * a[1] + cb * b[1], ca * a[2] + cb * b[2])


@njit(cache=True, error_model="numpy", fastmath={"contract"})
def lin3(ca, a, cb, b, cc, c):
    """``ca * a + cb * b + cc * c``."""
    return (
        ca * a[0] + cb * b[0] + cc * c[0],
        ca * a[1] + cb * b[1] + cc * c[1],
        ca * a[2] + cb * b[2] + cc * c[2],
    )


@njit(cache=True, error_model="numpy", fastmath={"contract"})
def _mat_vec(R, v, r=3, c=1):
    """``R @ v`` for a row-major 9-tuple ``R``; ``R.T @ v`` with the strides ``r=1, c=3``."""
    return (
        R[0] * v[0] + R[c] * v[1] + R[2 * c] * v[2],
        R[r] * v[0] + R[r + c] * v[1] + R[r + 2 * c] * v[2],
        R[2 * r] * v[0] + R[2 * r + c] * v[1] + R[2 * r + 2 * c] * v[2],
    )


# Loaders: the matrices and vectors of one element as tuples (kept in registers by numba). They
# read rows of 2-D arrays, the layout MuJoCo uses (``xmat`` is (n, 9)) and the provider's tables
# use; batch arrays of shape (n, 3, 3) or (n, 6, 6) are passed as their (n, 9) / (n, 36) views
# (``flat_rows``).


@njit(cache=True, error_model="numpy", fastmath={"contract"}, inline="always")
def load3(a, i, at=0):
    """3-tuple ``a[i, at:at + 3]`` of a 2-D array."""
    return (a[i, at], a[i, at + 1], a[i, at + 2])


@njit(cache=True, error_model="numpy", fastmath={"contract"}, inline="always")
def load9(a, i, at=0):
    """Row-major 3x3 matrix stored in ``a[i, at:at + 9]``, as a 9-tuple."""
    return (
        a[i, at], a[i, at + 1], a[i, at + 2], a[i, at + 3], a[i, at + 4], a[i, at + 5],
        a[i, at + 6], a[i, at + 7], a[i, at + 8],
    )  # fmt: skip


@njit(cache=True, error_model="numpy", fastmath={"contract"}, inline="always")
def load36(a, i, at=0):
    """Row-major 6x6 matrix stored in ``a[i, at:at + 36]``, as a 36-tuple."""
    return (
        a[i, at], a[i, at + 1], a[i, at + 2], a[i, at + 3], a[i, at + 4], a[i, at + 5],
        a[i, at + 6], a[i, at + 7], a[i, at + 8], a[i, at + 9], a[i, at + 10], a[i, at + 11],
        a[i, at + 12], a[i, at + 13], a[i, at + 14], a[i, at + 15], a[i, at + 16], a[i, at + 17],
        a[i, at + 18], a[i, at + 19], a[i, at + 20], a[i, at + 21], a[i, at + 22], a[i, at + 23],
        a[i, at + 24], a[i, at + 25], a[i, at + 26], a[i, at + 27], a[i, at + 28], a[i, at + 29],
        a[i, at + 30], a[i, at + 31], a[i, at + 32], a[i, at + 33], a[i, at + 34], a[i, at + 35],
    )  # fmt: skip


@njit(cache=True, error_model="numpy", fastmath={"contract"}, inline="always")
def flat_rows(a):
    """The (n, k) view of a C-contiguous (n, ...) array: one row per batch entry."""
    return a.reshape((a.shape[0], a.size // a.shape[0]))


@njit(cache=True, error_model="numpy", fastmath={"contract"})
def _row6(M, i, a, b):
    j = 6 * i
    return M[j] * a[0] + M[j + 1] * a[1] + M[j + 2] * a[2] + M[j + 3] * b[0] + M[j + 4] * b[1] + M[j + 5] * b[2]


@njit(cache=True, error_model="numpy", fastmath={"contract"})
def mat6_vec(M, a, b):
    """``M @ [a; b]`` for a row-major 36-tuple ``M``, returned as two 3-tuples."""
    top = (_row6(M, 0, a, b), _row6(M, 1, a, b), _row6(M, 2, a, b))
    return top, (_row6(M, 3, a, b), _row6(M, 4, a, b), _row6(M, 5, a, b))


# --------------------------------------------------------------------------- scalar functions


@njit(cache=True, error_model="numpy", fastmath={"contract"})
def _horner(coeffs, x):
    acc = 0.0
    for k in range(coeffs.shape[0] - 1, -1, -1):
        acc = acc * x + coeffs[k]
    return acc


@njit(cache=True, error_model="numpy", fastmath={"contract"})
def jl_inv_coefs(a, cos_h, sin_h):
    """``(c(a), g(a))`` given ``cos(a/2)``, ``sin(a/2)``, for ``0 <= a < 2 pi``.

    ``c(a) = (1 - (a/2) cot(a/2)) / a**2`` and ``g(a) = c'(a) / a``; series below the
    threshold (both evaluated in one Horner loop), closed forms above.
    """
    if a < _TH:
        x = a * a
        c = 0.0
        g = 0.0
        for k in range(_C.shape[0] - 1, -1, -1):
            c = c * x + _C[k]
            g = g * x + _G[k]
        return c, g
    h = 0.5 * a
    cot = cos_h / sin_h
    one_m = 1.0 - h * cot
    dc_dh = (-cot + h / (sin_h * sin_h)) / (4.0 * h * h) - one_m / (2.0 * h * h * h)
    return one_m / (a * a), dc_dh / (4.0 * h)


@njit(cache=True, error_model="numpy", fastmath={"contract"})
def jl_inv_coef(a):
    """``c(a) = (1 - (a/2) cot(a/2)) / a**2``, for ``0 <= a < 2 pi``."""
    return jl_inv_coefs(a, math.cos(0.5 * a), math.sin(0.5 * a))[0]


@njit(cache=True, error_model="numpy", fastmath={"contract"})
def exp_coefs(a):
    """``(sin(a/2) / a, (1 - cos a) / a**2, (a - sin a) / a**3)`` without cancellation."""
    if a == 0.0:
        return 0.5, 0.5, _S3[0]
    sh = math.sin(0.5 * a) / a
    if a < _TH:
        c3 = _horner(_S3, a * a)
    else:
        c3 = (a - math.sin(a)) / (a * a * a)
    return sh, 2.0 * sh * sh, c3


# --------------------------------------------------------------------------- rotations


@njit(cache=True, error_model="numpy", fastmath={"contract"})
def quat_from_rot9(r00, r01, r02, r10, r11, r12, r20, r21, r22):
    """Unit quaternion ``(w, x, y, z)``, ``w >= 0``, of a rotation matrix (Shepperd).

    Each branch divides by the largest of ``4 w^2, 4 x^2, 4 y^2, 4 z^2``, so the result
    keeps the relative precision of the off-diagonal entries (small rotations stay exact to
    round-off). At exactly a half turn (``w = 0``) the sign makes the component of largest
    magnitude positive.
    """
    tr = r00 + r11 + r22
    if tr >= r00 and tr >= r11 and tr >= r22:
        s = 2.0 * math.sqrt(1.0 + tr)
        i = 1.0 / s
        w, x, y, z = 0.25 * s, (r21 - r12) * i, (r02 - r20) * i, (r10 - r01) * i
    elif r00 >= r11 and r00 >= r22:
        s = 2.0 * math.sqrt(1.0 + r00 - r11 - r22)
        i = 1.0 / s
        w, x, y, z = (r21 - r12) * i, 0.25 * s, (r01 + r10) * i, (r02 + r20) * i
    elif r11 >= r22:
        s = 2.0 * math.sqrt(1.0 + r11 - r00 - r22)
        i = 1.0 / s
        w, x, y, z = (r02 - r20) * i, (r01 + r10) * i, 0.25 * s, (r12 + r21) * i
    else:
        s = 2.0 * math.sqrt(1.0 + r22 - r00 - r11)
        i = 1.0 / s
        w, x, y, z = (r10 - r01) * i, (r02 + r20) * i, (r12 + r21) * i, 0.25 * s
    n = 1.0 / math.sqrt(w * w + x * x + y * y + z * z)
    if w < 0.0:
        n = -n
    return w * n, x * n, y * n, z * n


@njit(cache=True, error_model="numpy", fastmath={"contract"})
def _col_dot(A, i, B, j):
    """Column i of A dotted with column j of B (row-major 9-tuples)."""
    return A[i] * B[j] + A[3 + i] * B[3 + j] + A[6 + i] * B[6 + j]


@njit(cache=True, error_model="numpy", fastmath={"contract"})
def relative_quat(R_WA, R_WB):
    """Quaternion of ``R_ab = R_WA^T R_WB`` (w >= 0)."""
    return quat_from_rot9(
        _col_dot(R_WA, 0, R_WB, 0), _col_dot(R_WA, 0, R_WB, 1), _col_dot(R_WA, 0, R_WB, 2),
        _col_dot(R_WA, 1, R_WB, 0), _col_dot(R_WA, 1, R_WB, 1), _col_dot(R_WA, 1, R_WB, 2),
        _col_dot(R_WA, 2, R_WB, 0), _col_dot(R_WA, 2, R_WB, 1), _col_dot(R_WA, 2, R_WB, 2),
    )  # fmt: skip


@njit(cache=True, error_model="numpy", fastmath={"contract"})
def relative_position(R_WA, p_WA, p_WB):
    """``p_ab = R_WA^T (p_WB - p_WA)``: origin of b in a coordinates (tuples)."""
    return _mat_vec(R_WA, (p_WB[0] - p_WA[0], p_WB[1] - p_WA[1], p_WB[2] - p_WA[2]), 1, 3)


@njit(cache=True, error_model="numpy", fastmath={"contract"})
def rotvec_from_quat(w, x, y, z):
    """Rotation vector (principal log, angle in [0, pi]) of a unit quaternion with ``w >= 0``.

    Returns ``(tau, alpha, sin(alpha/2))``.
    """
    n = math.sqrt(x * x + y * y + z * z)
    if n == 0.0:
        return (0.0, 0.0, 0.0), 0.0, 0.0
    alpha = 2.0 * math.atan2(n, w)
    s = alpha / n
    return (s * x, s * y, s * z), alpha, n


@njit(cache=True, error_model="numpy", fastmath={"contract"})
def write_rot_from_quat(w, x, y, z, R):
    """Rotation matrix of a unit quaternion into the (3, 3) array ``R``."""
    R[0, 0] = 1.0 - 2.0 * (y * y + z * z)
    R[0, 1] = 2.0 * (x * y - w * z)
    R[0, 2] = 2.0 * (x * z + w * y)
    R[1, 0] = 2.0 * (x * y + w * z)
    R[1, 1] = 1.0 - 2.0 * (x * x + z * z)
    R[1, 2] = 2.0 * (y * z - w * x)
    R[2, 0] = 2.0 * (x * z - w * y)
    R[2, 1] = 2.0 * (y * z + w * x)
    R[2, 2] = 1.0 - 2.0 * (x * x + y * y)


# --------------------------------------------------------------------------- twist method


@njit(cache=True, error_model="numpy", fastmath={"contract"})
def _p_apply(sign, tau, c, y):
    """``P y`` (sign=+1) or ``P^T y`` (sign=-1)."""
    ty = _cross(tau, y)
    return lin3(1.0, y, -0.5 * sign, ty, c, _cross(tau, ty))


@njit(cache=True, error_model="numpy", fastmath={"contract"})
def _d_apply(sign, tau, t, c, g, y):
    """``D y`` (sign=+1) or ``D^T y`` (sign=-1)."""
    ty = _cross(t, y)
    tauy = _cross(tau, y)
    a = lin(-0.5 * sign, ty, c, _cross(tau, ty))
    return lin3(1.0, a, c, _cross(t, tauy), g * dot(tau, t), _cross(tau, tauy))


@njit(cache=True, error_model="numpy", fastmath={"contract"})
def twist_from_quat_pos(w, x, y, z, p):
    """Finite twist ``(tau, t)`` of the displacement ``(q, p)``, and ``(c, g)`` at its angle."""
    tau, alpha, sin_h = rotvec_from_quat(w, x, y, z)
    c, g = jl_inv_coefs(alpha, w, sin_h)
    return tau, _p_apply(1.0, tau, c, p), (c, g)


@njit(cache=True, error_model="numpy", fastmath={"contract"})
def _twist_rate(tau, t, c, g, wa, va, wb, vb):
    """``Jr^-1 V_b - Jl^-1 V_a`` for body-frame velocities (eq. 58).

    With ``P^T y = y + tau x y / 2 + c tau x (tau x y)`` and ``D^T y`` likewise, the
    differences ``P^T y_b - P y_a`` only need the sum and difference of ``y_a`` and ``y_b``.
    """
    dw, sw = lin(1.0, wb, -1.0, wa), lin(1.0, wb, 1.0, wa)
    dv, sv = lin(1.0, vb, -1.0, va), lin(1.0, vb, 1.0, va)
    tdw = _cross(tau, dw)
    r1 = lin3(1.0, dw, 0.5, _cross(tau, sw), c, _cross(tau, tdw))
    tdv = _cross(tau, dv)
    pv = lin3(1.0, dv, 0.5, _cross(tau, sv), c, _cross(tau, tdv))
    dd = lin3(0.5, _cross(t, sw), c, lin(1.0, _cross(tau, _cross(t, dw)), 1.0, _cross(t, tdw)),
               g * dot(tau, t), _cross(tau, tdw))  # fmt: skip
    return r1, lin(1.0, dd, 1.0, pv)


@njit(cache=True, error_model="numpy", fastmath={"contract"})
def _twist_gamma(tau, t, c, g, y1, y2):
    """``Gamma [y1; y2] = [P y1 + D y2; P y2]`` (eq. 46)."""
    m = lin(1.0, _p_apply(1.0, tau, c, y1), 1.0, _d_apply(1.0, tau, t, c, g, y2))
    return m, _p_apply(1.0, tau, c, y2)


# --------------------------------------------------------------------------- dual quaternions


@njit(cache=True, error_model="numpy", fastmath={"contract"})
def dual_part(w, xv, p):
    """Dual part ``(s', x')`` of the unit dual quaternion of ``(q_r, p)`` (eqs 37-38)."""
    s_d = -0.5 * dot(xv, p)
    x_d = lin(0.5 * w, p, -0.5, _cross(xv, p))
    return s_d, x_d


@njit(cache=True, error_model="numpy", fastmath={"contract"})
def _lambda_t_apply(sign, w, xv, s_d, x_d, a, b):
    """``Lambda_ab^T [a; b]`` (sign=+1) or ``Lambda_ba^T [a; b]`` (sign=-1), eqs 85/97."""
    r1 = lin(w, a, sign, _cross(xv, a))
    r2 = lin3(s_d, a, sign, _cross(x_d, a), 1.0, lin(w, b, sign, _cross(xv, b)))
    return r1, r2


@njit(cache=True, error_model="numpy", fastmath={"contract"})
def _lambda_apply(w, xv, s_d, x_d, y1, y2):
    """``Lambda_ab [y1; y2]`` (eq. 85)."""
    m = lin3(w, y1, -1.0, _cross(xv, y1), 1.0, lin(s_d, y2, -1.0, _cross(x_d, y2)))
    return m, lin(w, y2, -1.0, _cross(xv, y2))


# --------------------------------------------------------------------------- element kernels
# All arguments are tuples (rotations row-major 9-tuples, K and B row-major 36-tuples): the
# kernels touch no arrays, so no reference counting happens per element.


@njit(cache=True, error_model="numpy", fastmath={"contract"})
def coords(method, R_WA, p_WA, R_WB, p_WB):
    """Displacement coordinates of the element and what the wrench map needs.

    Returns ``(e1, e2, aux)`` where ``[e1; e2]`` is ``xi`` (twist) or ``[xi_v; x']``
    (dual quaternion) and ``aux`` is ``(c, g)`` (twist) or ``(sigma, s')`` (dual quaternion).
    """
    w, x, y, z = relative_quat(R_WA, R_WB)
    p = relative_position(R_WA, p_WA, p_WB)
    if method == TWIST:
        return twist_from_quat_pos(w, x, y, z, p)
    xv = (x, y, z)
    s_d, x_d = dual_part(w, xv, p)
    return xv, x_d, (w, s_d)


@njit(cache=True, error_model="numpy", fastmath={"contract"})
def spatial_potential(method, R_WA, p_WA, R_WB, p_WB, K):
    """Elastic energy of one element [J] (eq. 39 or eq. 80)."""
    e1, e2, _ = coords(method, R_WA, p_WA, R_WB, p_WB)
    y1, y2 = mat6_vec(K, e1, e2)
    scale = 0.5 if method == TWIST else 2.0
    return scale * (dot(e1, y1) + dot(e2, y2))


@njit(cache=True, error_model="numpy", fastmath={"contract"})
def _rate(method, e1, e2, aux, R_WA, R_WB, w_WA, v_WA, w_WB, v_WB):
    """Rate of the displacement coordinates from world-frame velocities."""
    wa = _mat_vec(R_WA, w_WA, 1, 3)
    va = _mat_vec(R_WA, v_WA, 1, 3)
    wb = _mat_vec(R_WB, w_WB, 1, 3)
    vb = _mat_vec(R_WB, v_WB, 1, 3)
    if method == TWIST:
        return _twist_rate(e1, e2, aux[0], aux[1], wa, va, wb, vb)
    w, s_d = aux
    b1, b2 = _lambda_t_apply(1.0, w, e1, s_d, e2, wb, vb)
    a1, a2 = _lambda_t_apply(-1.0, w, e1, s_d, e2, wa, va)
    return lin(0.5, b1, -0.5, a1), lin(0.5, b2, -0.5, a2)


@njit(cache=True, error_model="numpy", fastmath={"contract"}, inline="always")
def generalized_forces(method, R_WA, p_WA, R_WB, p_WB, K, B, viscous, w_WA, v_WA, w_WB, v_WB):
    """Coordinates of one element and the quadratic generalized forces on them.

    Returns ``(e1, e2, aux, y1, y2, power)``: the coordinates as in :func:`coords`,
    ``[y1; y2] = K [e1; e2] + B rate`` and ``rate^T B rate`` (0 unless ``viscous``).
    """
    e1, e2, aux = coords(method, R_WA, p_WA, R_WB, p_WB)
    y1, y2 = mat6_vec(K, e1, e2)
    power = 0.0
    if viscous:
        r1, r2 = _rate(method, e1, e2, aux, R_WA, R_WB, w_WA, v_WA, w_WB, v_WB)
        b1, b2 = mat6_vec(B, r1, r2)
        power = dot(r1, b1) + dot(r2, b2)
        y1 = lin(1.0, y1, 1.0, b1)
        y2 = lin(1.0, y2, 1.0, b2)
    return e1, e2, aux, y1, y2, power


@njit(cache=True, error_model="numpy", fastmath={"contract"}, inline="always")
def force_map(method, e1, e2, aux, y1, y2):
    """``(m, f, scale)``: the wrench on B in b coordinates is ``scale * [m; f]``.

    ``[m; f] = Gamma_ab [y1; y2]`` with ``scale = -1`` (twist, eq. 49) or
    ``Lambda_ab [y1; y2]`` with ``scale = -2`` (dual quaternion, eq. 87).
    """
    if method == TWIST:
        m, f = _twist_gamma(e1, e2, aux[0], aux[1], y1, y2)
        return m, f, -1.0
    m, f = _lambda_apply(aux[0], e1, aux[1], e2, y1, y2)
    return m, f, -2.0


@njit(cache=True, error_model="numpy", fastmath={"contract"}, inline="always")
def to_world(method, m, f, scale, R_WB, power):
    """``(scale R_WB m, scale R_WB f, power)``, the power times 4 for the dual-quaternion method."""
    m = _mat_vec(R_WB, m)
    f = _mat_vec(R_WB, f)
    return lin(scale, m, 0.0, m), lin(scale, f, 0.0, f), power if method == TWIST else 4.0 * power


@njit(cache=True, error_model="numpy", fastmath={"contract"})
def spatial_wrench(method, R_WA, p_WA, R_WB, p_WB, K, B, viscous, w_WA, v_WA, w_WB, v_WB):
    """Wrench of one element on body B and its dissipated power.

    Returns ``(m, f, power)``: moment about ``p_WB`` and force on B in world axes, and
    ``rate^T B rate`` (times 4 for the dual-quaternion method) [W], 0 unless ``viscous``.
    """
    e1, e2, aux, y1, y2, power = generalized_forces(
        method, R_WA, p_WA, R_WB, p_WB, K, B, viscous, w_WA, v_WA, w_WB, v_WB
    )
    m, f, scale = force_map(method, e1, e2, aux, y1, y2)
    return to_world(method, m, f, scale, R_WB, power)


# --------------------------------------------------------------------------- batch loops
# Every array argument has a leading batch axis of length n or 1 (broadcast).


@njit(cache=True, error_model="numpy", fastmath={"contract"}, inline="always")
def row_of(a, i):
    """The row of a batch-first array `a` for item i: i, or 0 where `a` holds one row (broadcast)."""
    return i if a.shape[0] > 1 else 0


# The quadratic loops are kept apart from the polynomial ones (_poly_kernels), which run the same kernels when there
# are no terms but cost 25 % more per element (scripts/bench_core.py).
@njit(cache=True, error_model="numpy", fastmath={"contract"})
def spatial_wrench_batch(method, R_WA, p_WA, R_WB, p_WB, K, B, viscous, w_WA, v_WA, w_WB, v_WB, out, power):
    R_WA, R_WB, K, B = flat_rows(R_WA), flat_rows(R_WB), flat_rows(K), flat_rows(B)
    for i in range(out.shape[0]):
        m, f, power[i] = spatial_wrench(
            method, load9(R_WA, row_of(R_WA, i)), load3(p_WA, row_of(p_WA, i)), load9(R_WB, row_of(R_WB, i)),
            load3(p_WB, row_of(p_WB, i)), load36(K, row_of(K, i)), load36(B, row_of(B, i)), viscous,
            load3(w_WA, row_of(w_WA, i)), load3(v_WA, row_of(v_WA, i)), load3(w_WB, row_of(w_WB, i)),
            load3(v_WB, row_of(v_WB, i)),
        )  # fmt: skip
        for j in range(3):
            out[i, j] = m[j]
            out[i, 3 + j] = f[j]


@njit(cache=True, error_model="numpy", fastmath={"contract"})
def spatial_potential_batch(method, R_WA, p_WA, R_WB, p_WB, K, out):
    R_WA, R_WB, K = flat_rows(R_WA), flat_rows(R_WB), flat_rows(K)
    for i in range(out.shape[0]):
        out[i] = spatial_potential(
            method, load9(R_WA, row_of(R_WA, i)), load3(p_WA, row_of(p_WA, i)), load9(R_WB, row_of(R_WB, i)),
            load3(p_WB, row_of(p_WB, i)), load36(K, row_of(K, i)),
        )  # fmt: skip


@njit(cache=True, error_model="numpy", fastmath={"contract"})
def _quat_of(R, i):
    """Unit quaternion of the rotation matrix in row ``i`` of an (n, 9) array."""
    r = load9(R, i)
    return quat_from_rot9(r[0], r[1], r[2], r[3], r[4], r[5], r[6], r[7], r[8])


@njit(cache=True, error_model="numpy", fastmath={"contract"})
def twist_from_transform_batch(R, p, out):
    R = flat_rows(R)
    for i in range(out.shape[0]):
        w, x, y, z = _quat_of(R, row_of(R, i))
        tau, t, _ = twist_from_quat_pos(w, x, y, z, load3(p, row_of(p, i)))
        for k in range(3):
            out[i, k] = tau[k]
            out[i, 3 + k] = t[k]


@njit(cache=True, error_model="numpy", fastmath={"contract"})
def transform_from_twist_batch(xi, R_out, p_out):
    for i in range(R_out.shape[0]):
        tau = (xi[i, 0], xi[i, 1], xi[i, 2])
        t = (xi[i, 3], xi[i, 4], xi[i, 5])
        a = math.sqrt(dot(tau, tau))
        sh, c2, c3 = exp_coefs(a)
        # Rodrigues through the quaternion (cos(a/2), sin(a/2)/a * tau), eqs 16-17
        write_rot_from_quat(math.cos(0.5 * a), sh * tau[0], sh * tau[1], sh * tau[2], R_out[i])
        tt = _cross(tau, t)
        p = lin3(1.0, t, c2, tt, c3, _cross(tau, tt))  # p = J_l(tau) t, eq. 19
        for k in range(3):
            p_out[i, k] = p[k]


@njit(cache=True, error_model="numpy", fastmath={"contract"})
def dual_quaternion_from_transform_batch(R, p, out):
    R = flat_rows(R)
    for i in range(out.shape[0]):
        w, x, y, z = _quat_of(R, row_of(R, i))
        s_d, x_d = dual_part(w, (x, y, z), load3(p, row_of(p, i)))
        out[i, 0], out[i, 1], out[i, 2], out[i, 3] = w, x, y, z
        out[i, 4], out[i, 5], out[i, 6], out[i, 7] = s_d, x_d[0], x_d[1], x_d[2]


@njit(cache=True, error_model="numpy", fastmath={"contract"})
def transform_from_dual_quaternion_batch(q, R_out, p_out):
    for i in range(R_out.shape[0]):
        w, xv = q[i, 0], (q[i, 1], q[i, 2], q[i, 3])
        s_d, x_d = q[i, 4], (q[i, 5], q[i, 6], q[i, 7])
        write_rot_from_quat(w, xv[0], xv[1], xv[2], R_out[i])
        # p = 2 vec(q_d * conj(q_r)) = 2 (w x' - s' xi + xi x x')
        p = lin3(2.0 * w, x_d, -2.0 * s_d, xv, 2.0, _cross(xv, x_d))
        for k in range(3):
            p_out[i, k] = p[k]

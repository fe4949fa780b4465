"""An element wrench written from the definitions, independently of mjflex (reference for the dynamics tests).

Nothing here calls mjflex: quaternions and rotation matrices are written out, the twist is the
SE(3) logarithm (rotation vector, then ``t = J_l(tau)^-1 p``), the Jacobian of the twist is the
inverse of SE(3)'s right Jacobian ``J_r(xi) = phi_1(-ad_xi)`` (SO(3)'s closed form and its
derivative by a complex step, not the paper's dual-number formulas), and the dual-quaternion
coordinates are differentiated here by the product rule. Checked against ``mjflex.wrench_on_b``
to 1e-14 on random states (angles 1e-9 to 3 rad) by
``tests/test_mj_dynamics.py::test_reference_wrench_agrees_with_mjflex``.
"""

import numpy as np

from tests.helpers import hat


def quat_mul(a, b):
    w1, x1, y1, z1 = a
    w2, x2, y2, z2 = b
    return np.array([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                     w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2])  # fmt: skip


def rotation_matrix(q):
    """Rotation matrix of a unit quaternion (w, x, y, z)."""
    w, x, y, z = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])  # fmt: skip


def _rotation_vector(q):
    """Rotation vector of a unit quaternion, angle in [0, pi]."""
    w, v = (q[0], q[1:]) if q[0] >= 0 else (-q[0], -q[1:])
    s = np.linalg.norm(v)
    return 2.0 * v / w if s < 1e-8 else 2.0 * np.arctan2(s, w) / s * v


def _right_jacobian_so3(tau):
    """SO(3)'s right Jacobian ``J_r(tau) = sum_k (-tau^)^k / (k+1)!`` in closed form, also for complex ``tau``.

    The coefficients are analytic in ``z = tau . tau`` (series below ``z = 1e-6``), so a complex
    step through this function differentiates it exactly.
    """
    z = tau @ tau
    if abs(z) < 1e-6:
        c1, c2 = 0.5 - z / 24 + z**2 / 720, 1 / 6 - z / 120 + z**2 / 5040
    else:
        a = np.sqrt(z)
        c1, c2 = (1 - np.cos(a)) / z, (a - np.sin(a)) / (a * z)
    T = hat(tau)
    return np.eye(3) - c1 * T + c2 * T @ T


def _right_jacobian_se3(xi):
    """SE(3)'s right Jacobian ``J_r(xi) = phi_1(-ad_xi)``, angular-first.

    ``ad_xi = [[tau^, 0], [t^, tau^]]`` is block triangular, so a function of it is
    ``[[f(tau^), 0], [Df(tau^)[t^], f(tau^)]]``: the lower block is the derivative of ``J_r(tau)``
    along ``t``, taken here by a complex step (exact to round-off).
    """
    tau, t = xi[:3], xi[3:]
    step = 1e-30
    J = _right_jacobian_so3(tau)
    dJ = _right_jacobian_so3(tau + 1j * step * t).imag / step
    return np.block([[J, np.zeros((3, 3))], [dJ, J]])


def reference_wrench(method, q_Wa, p_Wa, q_Wb, p_Wb, V_a, V_b, K, B):
    """Wrench of the element on body B, world axes, moment about frame b's origin.

    Written from the definitions (sec. 4-5 of the paper): the coordinates of X_ab = X_Wa^-1 X_Wb
    (twist: the SE(3) logarithm; dual quaternion: [xi; x']), their derivative with respect to a
    body-frame twist of frame b (twist: J_r^-1, from a matrix exponential; dual quaternion:
    differentiated here), energy 1/2 x^T K x (twist) or 2 x^T K x (dual quaternion), and the
    Rayleigh damping of the coordinate rates. V_a, V_b: body-frame twists [w; v] of frames a, b.
    """
    q_ab = quat_mul(q_Wa * [1, -1, -1, -1], q_Wb)
    R_ab = rotation_matrix(q_ab)
    p_ab = rotation_matrix(q_Wa).T @ (p_Wb - p_Wa)
    Ad_ba = np.block([[R_ab.T, np.zeros((3, 3))], [hat(-R_ab.T @ p_ab) @ R_ab.T, R_ab.T]])  # twists in a -> in b
    relative = V_b - Ad_ba @ V_a
    if method == "twist":
        tau = _rotation_vector(q_ab)
        xi = np.r_[tau, np.linalg.solve(_right_jacobian_so3(-tau), p_ab)]  # p = J_l(tau) t, J_l(tau) = J_r(-tau)
        Jr = _right_jacobian_se3(xi)  # d xi = Jr^-1 (body twist of b)
        rate = np.linalg.solve(Jr, relative)
        W_b = -np.linalg.solve(Jr.T, K @ xi + B @ rate)
    else:
        s, x = (q_ab[0], q_ab[1:]) if q_ab[0] >= 0 else (-q_ab[0], -q_ab[1:])
        xd = 0.5 * (s * p_ab - np.cross(x, p_ab))
        d_x = 0.5 * (s * np.eye(3) + hat(x))  # from q' = q (1, dw/2)
        d_s = -0.5 * x
        J = np.zeros((6, 6))
        J[:3, :3] = d_x
        J[3:, :3] = 0.5 * (np.outer(p_ab, d_s) + hat(p_ab) @ d_x)  # d x' from ds and dx, p fixed
        J[3:, 3:] = 0.5 * (s * np.eye(3) - hat(x)) @ R_ab  # d x' from dp = R_ab dv
        c = np.r_[x, xd]
        W_b = -4.0 * J.T @ (K @ c + B @ (J @ relative))
    R_Wb = rotation_matrix(q_Wb)
    return np.r_[R_Wb @ W_b[:3], R_Wb @ W_b[3:]]

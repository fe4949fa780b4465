r"""End stops of an element: one-sided limits on its coordinates, their energy and their wrench.

A disc, a bushing or a flexure stops moving at its range. An element's stops act on its **stop
coordinates**, the same for both methods (a stop does not change meaning when the method
changes):

``z = [r; p_ab] = [rx, ry, rz, x, y, z]``

* ``r = log(R_ab)``: the rotation vector of frame b relative to frame a [rad] (the finite
  twist's ``tau``; its components lie in ``[-pi, pi]``; about one axis it is the angle itself);
* ``p_ab = R_WA^T (p_WB - p_WA)``: the position of frame b's origin in frame a [m], i.e. the
  translation along each of frame a's axes (not the twist's ``t``, which mixes in the rotation).

Planar elements use ``[theta, x, y]``: the rotation about the frame's z axis and the position in
its x-y plane (the spatial coordinates ``rz, x, y`` of the same motion).

Energy and force
----------------
Each coordinate ``i`` may have a lower limit ``l_i`` and an upper limit ``u_i`` (``-inf`` /
``+inf``: no stop) and a stiffness ``k_i >= 0``. Beyond a limit the stop stores

``U_s = sum_i k_i / 2 (max(z_i - u_i, 0)^2 + max(l_i - z_i, 0)^2)``

a one-sided quadratic penalty: zero within the range, its force ``k_i * overshoot`` continuous
(starting from zero at the limit), its stiffness ``k_i`` beyond it (the energy is C1; its second
derivative jumps at the limit, which a single-step integrator does not notice and which limits
RK4 to second order in the step where a stop engages or lets go). The force is exactly minus the
gradient of ``U_s`` with respect to the bodies' motion. With ``G = dU_s/dz``
(``G_i = k_i (max(z_i - u_i, 0) - max(l_i - z_i, 0))``) and a virtual body-frame displacement
``delta = [d_theta; d_p]`` of body B (``R_WB <- R_WB exp(d_theta^)``,
``p_WB <- p_WB + R_WB d_p``):

* ``dr = J_r^-1(r) d_theta`` with the inverse right Jacobian of SO(3),
  ``J_r^-1(r) = P(r)^T``, ``P(r) = I - r^/2 + c(a) (r^)^2`` (eq. 44 of the paper,
  ``c(a) = (1 - (a/2) cot(a/2)) / a^2``, ``a = |r|``);
* ``dp_ab = R_ab d_p``.

So the stop's wrench on B, about frame b's origin in b's axes, is ``m = -P(r) G_r``,
``f = -R_ab^T G_p``; in world axes ``m_W = -R_WB P(r) G_r``, ``f_W = -R_WA G_p`` (the force
acts along frame a's axes). The stop exerts the equal and opposite wrench on body A (about the
same point): ``U_s`` depends only on ``X_ab``, so the pair does no work under a common rigid
motion. The stops are conservative: they add energy ``U_s`` and no dissipation.

Stiffness
---------
A stop's stiffness is given, or derived from the element's own stiffness:
``k_i = STIFFNESS_FACTOR * K_ii`` (:func:`derived_stop_stiffness`; ``K_ii`` the diagonal of ``K``
in the element frame, for a planar element the diagonal of its 3x3 ``K``). With the factor 100,
a static load that would carry the free element past a limit by ``d`` carries it past by
``d / 101`` (when the coordinate's own stiffness is ``K_ii``), and the frequency of a mode that
the coordinate dominates rises by up to ``sqrt(1 + 100) ~ 10`` while the stop is engaged: take
the time step from :func:`mjflex.normal_modes` at a pose where the stop is engaged (it sees the
stop's stiffness), or about ``10x`` smaller than the free element's bound for that mode. A
coordinate with ``K_ii = 0`` has no stiffness to derive one from: give the stop's.

Damping
-------
A stop may be damped: ``b_i >= 0`` [N m s/rad, N s/m] acts on the rate ``zdot_i`` of its
coordinate, and only beyond the limit. The rates come from the relative velocity through the
same Jacobians: ``rdot = P(r)^T w`` (``w = R_WB^T (w_WB - w_WA)``, the angular velocity of b
relative to a in b's axes; ``P(r)^T = J_r^-1(r)``, eq. 44 of the paper) and
``pdot_ab = R_WA^T (v_WB - v_WA - w_WA x (p_WB - p_WA))``. The total stop force on a coordinate
is clamped so that it never attracts (as a contact's, Hunt and Crossley's argument): beyond an
upper limit it is ``G'_i = max(k_i over_i + b_i zdot_i, 0)``, beyond a lower one
``G'_i = -max(k_i under_i - b_i zdot_i, 0)``, inside the range 0, and it replaces ``G`` in the
wrench above. The clamp is continuous (a ``max``, not a switch on the sign of ``zdot``), so the
force is a continuous function of the velocity; like MuJoCo's joint limits with their ``solref``
damping, the damping force starts at the limit with the entry velocity. The stops dissipate
``sum_i (G'_i - G_i) zdot_i >= 0`` (:func:`stop_dissipation_power`): ``b_i zdot_i^2`` where the
clamp is open, ``k_i over_i |zdot_i|`` where it holds. Without damping (``b = 0``) the force is
exactly ``-dU_s`` as before.

Rest pose
---------
With ``rest=(p_r, q_r)`` (:mod:`mjflex.core.rest`) the coordinates are those of frame b* (frame b
less the rest pose): ``z = 0`` at ``X_ab = X_r``, so limits count from the rest pose; the wrench
keeps its reference point ``p_WB``.

Near a half turn the rotation vector changes branch (``|r| = pi``; see
:mod:`mjflex.core.elements`): rotation limits lie in ``[-pi, pi]``, where the coordinates are
continuous except at the half turn itself.
"""

import numpy as np

from . import _kernels as _k
from .rest import frame_at_rest
from .transforms import twist_from_transform
from .validation import as_array, check_rotation, numeric_array

#: The stop coordinates of a spatial element and of a planar one, in order.
SPATIAL_COORDINATES = ("rx", "ry", "rz", "x", "y", "z")
PLANAR_COORDINATES = ("theta", "x", "y")
#: Indices of the planar coordinates ``[theta_z; x; y]`` within ``[rx, ry, rz, x, y, z]`` (of a planar element's
#: 3x3 ``K`` within the 6x6 of the same element).
PLANAR_INDEX = (2, 3, 4)
#: The derived stiffness of a stop: this times the element's stiffness ``K_ii`` of its coordinate.
STIFFNESS_FACTOR = 100.0


def derived_stop_stiffness(K) -> np.ndarray:
    """The stiffness of the stops derived from the element's: ``STIFFNESS_FACTOR * diag(K)``.

    Parameters
    ----------
    K : array_like, shape (6, 6) or (3, 3)
        The element's stiffness in its frame (planar: ``[theta; x; y]``), ``N m/rad``, ``N/m``.

    Returns
    -------
    k : ndarray, shape (6,) or (3,)
        The stops' stiffness of each coordinate [N m/rad, N/m].

    Examples
    --------
    >>> import mjflex
    >>> print(mjflex.derived_stop_stiffness([[2.0, 0, 0], [0, 1e4, 0], [0, 0, 1e4]]))
    [2.e+02 1.e+06 1.e+06]
    """
    K = np.asarray(K, dtype=float)
    if K.ndim != 2 or K.shape[0] != K.shape[1] or K.shape[0] not in (3, 6):
        raise ValueError(f"K must be 6x6 or 3x3 (planar); got shape {K.shape}")
    return STIFFNESS_FACTOR * np.diagonal(K).copy()


def _vector(x, name, n):
    a = numeric_array(x, name)
    if a.ndim < 1 or a.shape[-1] != n:
        raise ValueError(f"{name} must have shape (..., {n}); got shape {a.shape}")
    return a


def _limits(lower, upper, stiffness, n):
    """``(lower, upper, stiffness)`` as float arrays of core shape ``(n,)``; ValueError saying what is wrong."""
    lo = np.full(n, -np.inf) if lower is None else _vector(lower, "lower", n)
    hi = np.full(n, np.inf) if upper is None else _vector(upper, "upper", n)
    k = _vector(stiffness, "stiffness", n)
    for name, a in (("lower", lo), ("upper", hi)):
        if np.isnan(a).any():
            raise ValueError(f"{name} has NaN; use -inf (lower) or +inf (upper) for a coordinate without a stop")
    if np.any(lo == np.inf) or np.any(hi == -np.inf):
        raise ValueError("a lower limit of +inf or an upper limit of -inf would push at every pose; use -inf / +inf")
    if np.any(lo > hi):
        raise ValueError("lower > upper on some coordinate: a stop range needs lower <= upper")
    if not np.isfinite(k).all() or np.any(k < 0):
        raise ValueError("stiffness must be finite and >= 0")
    return lo, hi, k


def _gradient(z, lo, hi, k):
    """``(U_s, G)``: the stops' energy ``(...)`` and its gradient ``(..., n)`` at coordinates ``z``."""
    with np.errstate(invalid="ignore"):  # z - inf on coordinates without a stop is -inf: no overshoot
        over, under = np.maximum(z - hi, 0.0), np.maximum(lo - z, 0.0)
    return 0.5 * np.sum(k * (over * over + under * under), axis=-1), k * (over - under)


def _damped(z, zdot, lo, hi, k, b):
    """``(G', P)``: the damped stops' total force ``(..., n)`` (module docstring) and dissipated power ``(...)``."""
    with np.errstate(invalid="ignore"):
        over, under = np.maximum(z - hi, 0.0), np.maximum(lo - z, 0.0)
    eo, eu = k * over, k * under
    go = np.maximum(eo + np.where(over > 0, b, 0.0) * zdot, 0.0)
    gu = np.maximum(eu - np.where(under > 0, b, 0.0) * zdot, 0.0)
    return go - gu, np.sum(((go - eo) - (gu - eu)) * zdot, axis=-1)


def _damping(damping, n):
    b = _vector(damping, "damping", n)
    if not np.isfinite(b).all() or np.any(b < 0):
        raise ValueError("damping must be finite and >= 0 [N m s/rad, N s/m]")
    return b


def _spatial(R_WA, p_WA, R_WB, p_WB, check, rest=None):
    """``(R_WA, p_WA, R_Wb*, p_Wb*, z)``: float arrays, frame b* of the rest pose (b without one), stop coordinates."""
    if check:
        R_WA, R_WB = check_rotation(R_WA, "R_WA"), check_rotation(R_WB, "R_WB")
        p_WA, p_WB = as_array(p_WA, "p_WA", (3,)), as_array(p_WB, "p_WB", (3,))
    R_WA, R_WB, p_WA, p_WB = (np.asarray(a, dtype=float) for a in (R_WA, R_WB, p_WA, p_WB))
    if rest is not None:
        R_WB, p_WB = frame_at_rest(R_WB, p_WB, rest)
    R_ab = np.swapaxes(R_WA, -1, -2) @ R_WB
    p_ab = np.einsum("...ji,...j->...i", R_WA, p_WB - p_WA)
    r = twist_from_transform(R_ab, np.zeros(R_ab.shape[:-1]), check=False)[..., :3]
    return R_WA, p_WA, R_WB, p_WB, np.concatenate(np.broadcast_arrays(r, p_ab), axis=-1)


def _p_map(r, x, sign):
    """``P(r) x`` (sign -1) or ``P(r)^T x`` (sign +1): ``x + sign r x x / 2 + c(|r|) r x (r x x)`` (eq. 44)."""
    a = np.linalg.norm(r, axis=-1)
    c = np.vectorize(_k.jl_inv_coef, otypes=[float])(a)[..., None]
    return x + sign * 0.5 * np.cross(r, x) + c * np.cross(r, np.cross(r, x))


def _rates(R_WA, p_WA, R_Wb, p_Wb, z, velocities):
    """The rates ``zdot`` of the stop coordinates ``z`` of frames a and b* (module docstring) from the world
    velocities ``(w_WA, v_WA, w_WB, v_WB)`` (None: zero; ``v_WB`` of frame b*'s origin)."""
    names = ("w_WA", "v_WA", "w_WB", "v_WB")
    w_WA, v_WA, w_WB, v_WB = (np.zeros(3) if v is None else as_array(v, name, (3,))
                              for v, name in zip(velocities, names, strict=True))  # fmt: skip
    w_b = np.einsum("...ji,...j->...i", R_Wb, w_WB - w_WA)
    dp = v_WB - v_WA - np.cross(w_WA, p_Wb - p_WA)
    return np.concatenate(np.broadcast_arrays(_p_map(z[..., :3], w_b, 1.0), np.einsum("...ji,...j->...i", R_WA, dp)),
                          axis=-1)  # fmt: skip


def stop_coordinates(R_WA, p_WA, R_WB, p_WB, *, rest=None, check=True) -> np.ndarray:
    """The stop coordinates ``[rx, ry, rz, x, y, z]`` of frame b relative to frame a (module docstring).

    Parameters
    ----------
    R_WA, R_WB : array_like, shape (..., 3, 3)
        Orientations of frames a and b in world coordinates.
    p_WA, p_WB : array_like, shape (..., 3)
        Origins of frames a and b in world coordinates [m].
    rest : tuple (pos, quat), optional
        The element's rest pose (:mod:`mjflex.core.rest`): the coordinates count from it.
    check : bool
        Validate the arguments.

    Returns
    -------
    z : ndarray, shape (..., 6)
        The rotation vector of ``R_ab`` [rad], then ``p_ab``, the position of b in a [m].

    Examples
    --------
    >>> import numpy as np
    >>> import mjflex
    >>> R_WB, _ = mjflex.transform_from_twist([0.0, 0.0, 0.2, 0.0, 0.0, 0.0])  # b turned 0.2 rad about z
    >>> print(mjflex.stop_coordinates(np.eye(3), np.zeros(3), R_WB, [0.01, 0.0, 0.0]))
    [0.   0.   0.2  0.01 0.   0.  ]
    """
    return _spatial(R_WA, p_WA, R_WB, p_WB, check, rest)[-1]


def stop_potential(R_WA, p_WA, R_WB, p_WB, lower, upper, stiffness, *, rest=None, check=True) -> np.ndarray:
    """Energy stored in an element's end stops [J] (module docstring).

    Parameters
    ----------
    R_WA, R_WB : array_like, shape (..., 3, 3)
        Orientations of frames a and b in world coordinates.
    p_WA, p_WB : array_like, shape (..., 3)
        Origins of frames a and b in world coordinates [m].
    lower, upper : array_like, shape (..., 6), or None
        Limits of the stop coordinates ``[rx, ry, rz, x, y, z]`` [rad, m]; ``-inf`` / ``+inf``
        (or None for all six) where a coordinate has no stop.
    stiffness : array_like, shape (..., 6)
        The stops' stiffness of each coordinate [N m/rad, N/m], ``>= 0``
        (:func:`derived_stop_stiffness` derives one from the element's ``K``).
    rest : tuple (pos, quat), optional
        The element's rest pose (:mod:`mjflex.core.rest`): the coordinates count from it.
    check : bool
        Validate the arguments.

    Returns
    -------
    U : ndarray, shape (...)
        ``sum_i k_i / 2 (max(z_i - u_i, 0)^2 + max(l_i - z_i, 0)^2)`` [J].

    Examples
    --------
    >>> import numpy as np
    >>> import mjflex
    >>> R_WB, _ = mjflex.transform_from_twist([0.0, 0.0, 0.2, 0.0, 0.0, 0.0])
    >>> upper = [np.inf, np.inf, 0.15, np.inf, np.inf, np.inf]  # rz at most 0.15 rad
    >>> print(f"{mjflex.stop_potential(np.eye(3), np.zeros(3), R_WB, np.zeros(3), None, upper, [100.0] * 6):.4f} J")
    0.1250 J
    """
    z = _spatial(R_WA, p_WA, R_WB, p_WB, check, rest)[-1]
    return _gradient(z, *_limits(lower, upper, stiffness, 6))[0][()]


def stop_wrench_on_b(
    R_WA, p_WA, R_WB, p_WB, lower, upper, stiffness, *, damping=None,
    w_WA=None, v_WA=None, w_WB=None, v_WB=None, rest=None, check=True,
) -> np.ndarray:  # fmt: skip
    """Wrench that an element's end stops exert on body B: minus the gradient of :func:`stop_potential`, plus
    their damping.

    Parameters
    ----------
    R_WA, R_WB : array_like, shape (..., 3, 3)
        Orientations of frames a and b in world coordinates.
    p_WA, p_WB : array_like, shape (..., 3)
        Origins of frames a and b in world coordinates [m].
    lower, upper : array_like, shape (..., 6), or None
        Limits of the stop coordinates [rad, m] (see :func:`stop_potential`).
    stiffness : array_like, shape (..., 6)
        The stops' stiffness of each coordinate [N m/rad, N/m].
    damping : array_like, shape (..., 6), optional
        The stops' damping of each coordinate [N m s/rad, N s/m], ``>= 0``, acting beyond a limit
        only, clamped so that the stop never attracts (module docstring). None: conservative.
    w_WA, w_WB : array_like, shape (..., 3), optional
        Angular velocities of frames a and b, world axes [rad/s]. Zero when omitted.
    v_WA, v_WB : array_like, shape (..., 3), optional
        Linear velocities of the origins of frames a and b, world axes [m/s]. Zero when omitted.
    rest : tuple (pos, quat), optional
        The element's rest pose (:mod:`mjflex.core.rest`): the coordinates count from it.
    check : bool
        Validate the arguments.

    Returns
    -------
    wrench : ndarray, shape (..., 6)
        ``[moment about p_WB; force]`` on body B in world axes [N m; N]: ``-R_WB P(r) G_r`` and
        ``-R_WA G_p`` (``G'`` with damping). The stops exert the opposite wrench on body A.

    Examples
    --------
    >>> import numpy as np
    >>> import mjflex
    >>> upper = [np.inf] * 3 + [0.001, np.inf, np.inf]  # x at most 1 mm
    >>> W = mjflex.stop_wrench_on_b(np.eye(3), np.zeros(3), np.eye(3), [0.003, 0.0, 0.0], None, upper, [1e4] * 6)
    >>> print(np.round(W, 9) + 0.0)  # 2 mm past the stop at 1e4 N/m: 20 N back along -x
    [  0.   0.   0. -20.   0.   0.]
    """
    return _stop_wrench_and_power(R_WA, p_WA, R_WB, p_WB, lower, upper, stiffness, damping,
                                  (w_WA, v_WA, w_WB, v_WB), rest, check)[0]  # fmt: skip


def stop_dissipation_power(
    R_WA, p_WA, R_WB, p_WB, lower, upper, stiffness, damping, *,
    w_WA=None, v_WA=None, w_WB=None, v_WB=None, rest=None, check=True,
) -> np.ndarray:  # fmt: skip
    """Power dissipated by an element's damped end stops [W]: ``sum_i (G'_i - G_i) zdot_i >= 0`` (module docstring).

    Equals minus the power of the damped stops' wrenches on A and B together, less the rate of
    their energy. Arguments as in :func:`stop_wrench_on_b`.

    Parameters
    ----------
    R_WA, R_WB : array_like, shape (..., 3, 3)
        Orientations of frames a and b in world coordinates.
    p_WA, p_WB : array_like, shape (..., 3)
        Origins of frames a and b in world coordinates [m].
    lower, upper : array_like, shape (..., 6), or None
        Limits of the stop coordinates [rad, m] (see :func:`stop_potential`).
    stiffness : array_like, shape (..., 6)
        The stops' stiffness of each coordinate [N m/rad, N/m].
    damping : array_like, shape (..., 6)
        The stops' damping of each coordinate [N m s/rad, N s/m].
    w_WA, w_WB : array_like, shape (..., 3), optional
        Angular velocities of frames a and b, world axes [rad/s]. Zero when omitted.
    v_WA, v_WB : array_like, shape (..., 3), optional
        Linear velocities of the origins of frames a and b, world axes [m/s]. Zero when omitted.
    rest : tuple (pos, quat), optional
        The element's rest pose (:mod:`mjflex.core.rest`).
    check : bool
        Validate the arguments.

    Returns
    -------
    power : ndarray, shape (...)
        Dissipated power [W].

    Examples
    --------
    >>> import numpy as np
    >>> import mjflex
    >>> upper = [np.inf] * 3 + [0.001, np.inf, np.inf]  # x at most 1 mm
    >>> P = mjflex.stop_dissipation_power(np.eye(3), np.zeros(3), np.eye(3), [0.003, 0.0, 0.0], None, upper,
    ...                                   [1e4] * 6, [50.0] * 6, v_WB=[0.1, 0.0, 0.0])
    >>> print(f"{P:.3f} W")  # moving on into the stop at 0.1 m/s: b v^2
    0.500 W
    """
    return _stop_wrench_and_power(R_WA, p_WA, R_WB, p_WB, lower, upper, stiffness, damping,
                                  (w_WA, v_WA, w_WB, v_WB), rest, check)[1][()]  # fmt: skip


def _stop_wrench_and_power(R_WA, p_WA, R_WB, p_WB, lower, upper, stiffness, damping, velocities, rest, check):
    """(wrench on B about p_WB (..., 6), dissipated power (...)) of the stops (module docstring)."""
    w_WA, v_WA, w_WB, v_WB = velocities
    p_B = np.asarray(p_WB, dtype=float)
    R_WA, p_WA, R_Wb, p_b, z = _spatial(R_WA, p_WA, R_WB, p_WB, check, rest)
    if rest is not None and w_WB is not None:  # the velocity of the point of B at frame b*'s origin
        u = np.cross(np.asarray(w_WB, dtype=float), p_b - p_B)
        v_WB = u if v_WB is None else np.asarray(v_WB, dtype=float) + u
    limits = _limits(lower, upper, stiffness, 6)
    if damping is None:
        if any(v is not None for v in velocities):
            raise ValueError("velocities were given but damping is None: pass the stops' damping, or drop them")
        _, G = _gradient(z, *limits)
        power = np.zeros(G.shape[:-1])
    else:
        zdot = _rates(R_WA, p_WA, R_Wb, p_b, z, (w_WA, v_WA, w_WB, v_WB))
        G, power = _damped(z, zdot, *limits, _damping(damping, 6))
    m = -np.einsum("...ij,...j->...i", R_Wb, _p_map(z[..., :3], G[..., :3], -1.0))
    f = -np.einsum("...ij,...j->...i", R_WA, G[..., 3:])
    m = m + np.cross(p_b - p_B, f)  # about p_WB
    return np.concatenate(np.broadcast_arrays(m, f), axis=-1), power


# --------------------------------------------------------------------------- planar


def _planar(theta_WA, p_WA, theta_WB, p_WB, check):
    if check:
        theta_WA, theta_WB = as_array(theta_WA, "theta_WA", ()), as_array(theta_WB, "theta_WB", ())
        p_WA, p_WB = as_array(p_WA, "p_WA", (2,)), as_array(p_WB, "p_WB", (2,))
    theta_WA, theta_WB, p_WA, p_WB = (np.asarray(a, dtype=float) for a in (theta_WA, theta_WB, p_WA, p_WB))
    d = theta_WB - theta_WA
    theta = np.arctan2(np.sin(d), np.cos(d))  # the rotation in [-pi, pi], as the spatial rotation vector's rz
    c, s = np.cos(theta_WA), np.sin(theta_WA)
    dp = p_WB - p_WA
    p_ab = np.stack(np.broadcast_arrays(c * dp[..., 0] + s * dp[..., 1], -s * dp[..., 0] + c * dp[..., 1]), axis=-1)
    theta, p_ab = np.broadcast_arrays(theta[..., None], p_ab)
    return c, s, np.concatenate([theta[..., :1], p_ab], axis=-1)


def planar_stop_potential(theta_WA, p_WA, theta_WB, p_WB, lower, upper, stiffness, *, check=True) -> np.ndarray:
    """Energy stored in a planar element's end stops [J], on the coordinates ``[theta, x, y]``.

    Parameters
    ----------
    theta_WA, theta_WB : array_like, shape (...)
        Orientation angles of frames a and b in the world plane [rad].
    p_WA, p_WB : array_like, shape (..., 2)
        Origins of frames a and b in world coordinates [m].
    lower, upper : array_like, shape (..., 3), or None
        Limits of ``[theta, x, y]`` [rad, m], ``theta`` the rotation of b relative to a in
        ``[-pi, pi]`` and ``x, y`` the position of b in a; ``-inf`` / ``+inf`` (or None) where
        a coordinate has no stop.
    stiffness : array_like, shape (..., 3)
        The stops' stiffness of each coordinate [N m/rad, N/m].
    check : bool
        Validate the arguments.

    Returns
    -------
    U : ndarray, shape (...)
        Energy [J]; equals :func:`stop_potential` of the same motion in the x-y plane with the
        limits on ``rz, x, y``.

    Examples
    --------
    >>> import mjflex
    >>> U = mjflex.planar_stop_potential(0.0, [0.0, 0.0], 0.3, [0.0, 0.0], [-0.2] * 3, [0.2] * 3, [10.0] * 3)
    >>> print(f"{U:.3f} J")  # 0.1 rad past the stop at 10 N m/rad
    0.050 J
    """
    _, _, z = _planar(theta_WA, p_WA, theta_WB, p_WB, check)
    return _gradient(z, *_limits(lower, upper, stiffness, 3))[0][()]


def planar_stop_wrench_on_b(theta_WA, p_WA, theta_WB, p_WB, lower, upper, stiffness, *, check=True) -> np.ndarray:
    """Wrench that a planar element's end stops exert on body B: minus the gradient of :func:`planar_stop_potential`.

    Parameters
    ----------
    theta_WA, theta_WB : array_like, shape (...)
        Orientation angles of frames a and b in the world plane [rad].
    p_WA, p_WB : array_like, shape (..., 2)
        Origins of frames a and b in world coordinates [m].
    lower, upper : array_like, shape (..., 3), or None
        Limits of ``[theta, x, y]`` [rad, m] (see :func:`planar_stop_potential`).
    stiffness : array_like, shape (..., 3)
        The stops' stiffness of each coordinate [N m/rad, N/m].
    check : bool
        Validate the arguments.

    Returns
    -------
    wrench : ndarray, shape (..., 3)
        ``[moment about p_WB; fx; fy]`` on body B, world axes [N m; N; N]: ``-G_theta`` and
        ``-R(theta_WA) G_p``.

    Examples
    --------
    >>> import mjflex
    >>> print(mjflex.planar_stop_wrench_on_b(0.0, [0.0, 0.0], 0.3, [0.0, 0.0], [-0.2] * 3, [0.2] * 3, [10.0] * 3) + 0.0)
    [-1.  0.  0.]
    """
    c, s, z = _planar(theta_WA, p_WA, theta_WB, p_WB, check)
    _, G = _gradient(z, *_limits(lower, upper, stiffness, 3))
    fx, fy = -(c * G[..., 1] - s * G[..., 2]), -(s * G[..., 1] + c * G[..., 2])
    return np.stack(np.broadcast_arrays(-G[..., 0], fx, fy), axis=-1)

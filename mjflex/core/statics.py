"""Static deflection of one element: where frame b comes to rest under a wrench applied at its origin.

Frame a is held; a wrench ``w = [moment; force]`` acts on body B at the origin of frame b. The
element's own wrench on B (:func:`mjflex.wrench_on_b`, exact at any deflection) balances it:

    wrench_on_b(X_ab) + w(X_ab) = 0,

with ``w`` fixed in frame a (a dead load, as MuJoCo's ``xfrc_applied`` is fixed in the world) or
turning with frame b (a follower load). The linear answer is ``K^-1 w``; the exact one is found by
Newton's method on the element's finite twist, from the linear answer, with the load applied in
increments when a full step does not converge (large deflections).

A load applied elsewhere (at a body's centre of mass, as ``xfrc_applied`` is) is a different
wrench at frame b: move it first, ``m_b = m + (p - p_b) x f``.
"""

from dataclasses import dataclass

import numpy as np

from . import validation
from .elements import wrench_on_b
from .transforms import transform_from_twist, twist_from_transform


@dataclass(frozen=True)
class Deflection:
    """Where frame b rests relative to frame a under a load (:func:`static_deflection`).

    Attributes
    ----------
    R : ndarray, shape (3, 3)
        Orientation of frame b in frame a (``R_ab``).
    p : ndarray, shape (3,)
        Position of b's origin in frame a [m].
    coordinates : ndarray, shape (6,)
        ``[rotation vector; p]`` [rad; m]: the coordinates of an element's stops.
    twist : ndarray, shape (6,)
        The finite twist ``[tau; t]`` (:meth:`mjflex.Flexures.displacements`' coordinates).
    residual : float
        Largest remaining component of the wrench balance [N m or N].

    Examples
    --------
    >>> import numpy as np
    >>> import mjflex
    >>> d = mjflex.static_deflection([2, 2, 1, 1e4, 1e4, 1e4], [0, 0, 0.1, 0, 0, 0])
    >>> print(np.round(d.coordinates, 6))  # 0.1 N m about z on 1 N m/rad
    [0.  0.  0.1 0.  0.  0. ]
    """

    R: np.ndarray
    p: np.ndarray
    coordinates: np.ndarray
    twist: np.ndarray
    residual: float


def _result(xi, residual):
    R, p = transform_from_twist(xi, check=False)
    r = twist_from_transform(R, np.zeros(3), check=False)[:3]  # the rotation vector
    return Deflection(R, p, np.concatenate([r, p]), np.asarray(xi, dtype=float).copy(), residual)


def _balance(xi, K, w, method, terms, follower):
    R, p = transform_from_twist(xi, check=False)
    load = np.concatenate([R @ w[:3], R @ w[3:]]) if follower else w
    return wrench_on_b(np.eye(3), np.zeros(3), R, p, K, method=method, terms=terms, check=False) + load


def static_deflection(K, wrench, *, method="twist", terms=None, exact=True, follower=False, tol=1e-12,
                      max_iterations=50) -> Deflection:  # fmt: skip
    """The deflection of an element (frame a held) under a wrench applied at the origin of frame b.

    Parameters
    ----------
    K : array_like, shape (6, 6) or (6,)
        The element's stiffness in its frame, rows ``[rx, ry, rz, x, y, z]`` (N m/rad, N/m); a
        6-vector is the diagonal. Positive definite for the linear answer.
    wrench : array_like, shape (6,)
        ``[moment about b's origin; force]`` [N m; N] applied to body B, in frame a's axes (a
        dead load) or, with ``follower``, in frame b's axes (turning with it).
    method : {"twist", "dualquat"}
        The element's displacement measure (the exact deflection depends on it).
    terms : PolynomialTerms, optional
        Higher-order terms of the potential (:func:`mjflex.potential`).
    exact : bool
        Solve the exact (large-deflection) balance; False gives the linear ``K^-1 w``.
    follower : bool
        The wrench turns with frame b.
    tol : float
        Converged when the balance is below ``tol`` times the wrench's largest component.
    max_iterations : int
        Newton iterations per load increment.

    Returns
    -------
    Deflection
        Frame b's pose in frame a, in stop coordinates and as a finite twist.

    Examples
    --------
    A disc of 20 N m/rad in bending under 5 N m: 0.25 rad (linear). With a 3 N shear on top, the
    exact deflection also moves b along z (the shear force turns with the bent disc's frame):

    >>> import numpy as np
    >>> import mjflex
    >>> K = [20, 20, 10, 2e5, 2e5, 1e6]
    >>> print(np.round(mjflex.static_deflection(K, [5, 0, 0, 0, 0, 0], exact=False).coordinates, 4))
    [0.25 0.   0.   0.   0.   0.  ]
    >>> d = mjflex.static_deflection(K, [5, 0, 0, 0, 3, 0])
    >>> print(f"{d.coordinates[0]:.4f} rad, y {d.coordinates[4] * 1e6:.2f} um, z {d.coordinates[5] * 1e6:.2f} um")
    0.2500 rad, y 14.74 um, z 1.48 um
    """
    K = np.asarray(K, dtype=float)
    K = np.diag(K) if K.shape == (6,) else K
    validation.as_array(K, "K", (6, 6))
    w = validation.as_array(wrench, "wrench", (6,))
    try:
        linear = np.linalg.solve(K, w)
    except np.linalg.LinAlgError:
        raise ValueError("K is singular: a direction without stiffness has no static deflection under a load; "
                         "give the element stiffness in every direction the load acts in") from None  # fmt: skip
    if not exact:
        R, p = transform_from_twist(linear, check=False)
        return Deflection(R, p, linear.copy(), twist_from_transform(R, p, check=False), 0.0)
    tol = tol * max(np.abs(w).max(), 1e-300)
    for n in (1, 4, 16, 64):  # the whole load at once, else in increments, each from the linear predictor
        xi, ok = np.zeros(6), True
        for k in range(1, n + 1):
            xi, ok = _newton(xi + linear / n, K, (k / n) * w, method, terms, follower, tol, max_iterations)
            if not ok:
                break
        if ok:
            return _result(xi, float(np.abs(_balance(xi, K, w, method, terms, follower)).max()))
    raise RuntimeError("static_deflection did not converge: the load may exceed what the element can hold "
                       "(a twist element's rotation beyond pi), or K is far from its terms' stiffness")  # fmt: skip


def _newton(xi, K, w, method, terms, follower, tol, iterations, h=1e-7):
    def balance(x):
        return _balance(x, K, w, method, terms, follower)

    for _ in range(iterations):
        r = balance(xi)
        if np.abs(r).max() <= tol:
            return xi, True
        J = np.stack([(balance(xi + d) - balance(xi - d)) / (2 * h) for d in h * np.eye(6)], axis=1)
        xi = xi + np.linalg.lstsq(J, -r, rcond=None)[0]
        if not np.isfinite(xi).all():
            return xi, False
    return xi, bool(np.abs(balance(xi)).max() <= tol)

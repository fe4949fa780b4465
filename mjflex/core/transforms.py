"""Finite twists and unit dual quaternions of rigid displacements (paper secs 3.4-3.5).

A rigid displacement ``X_AB = (R_AB, p_AB)`` maps coordinates in B to coordinates in A:
``x_A = R_AB x_B + p_AB``. Its finite twist ``xi = [tau; t]`` (angular first) satisfies
``X_AB = exp(xi^)``: ``tau`` is the rotation vector of ``R_AB`` [rad] and
``p_AB = J_l(tau) t`` with the left Jacobian of SO(3) (eqs 16-19), so ``xi`` are SE(3)
exponential coordinates, the same as ``scipy``'s ``RigidTransform.as_exp_coords()``. The
logarithm is the principal one, rotation angle in ``[0, pi]``; at exactly ``pi`` the axis
sign makes its largest-magnitude component positive (the log is two-valued there).

The unit dual quaternion is ``q = q_r + eps q_d``, ``q_r = (sigma, xi_1, xi_2, xi_3)``
(w-first, ``sigma >= 0``) the rotation, and ``q_d = (s', x'_1, x'_2, x'_3) = (0, p) q_r / 2``
(eqs 34-38). It equals ``RigidTransform.as_dual_quat(scalar_first=True)`` up to the overall
sign, which this module fixes by ``sigma >= 0``.

Precision: rotations are read through Shepperd's quaternion extraction and the angle through
``atan2``, so small rotations keep the relative precision of the off-diagonal entries of
``R`` (1e-12 rad round-trips to ~1e-16 relative); near-zero closed forms are replaced by
series (``_series.py``).
"""

import math

import numpy as np

from . import _kernels as _k
from ._batch import flatten
from .validation import as_array, check_rotation, check_unit_dual_quaternion


def _coordinates(R, p, check, kernel, width):
    """``(..., width)`` coordinates of poses ``(R, p)`` by a batch ``kernel(R, p, out)``."""
    if check:
        R, p = check_rotation(R, "R"), as_array(p, "p", (3,))
    R, p = np.ascontiguousarray(R, dtype=np.float64), np.ascontiguousarray(p, dtype=np.float64)
    shape, (R_, p_) = flatten([R, p], [R.shape[:-2], p.shape[:-1]], ["R", "p"])
    out = np.empty((math.prod(shape), width))
    kernel(R_, p_, out)
    return out.reshape(shape + (width,))


def _pose(x, name, kernel):
    """``(R, p)`` of coordinates ``x`` (C-contiguous float64, ``(..., k)``) by a batch ``kernel(x, R, p)``."""
    shape, (x_,) = flatten([x], [x.shape[:-1]], [name])
    R = np.empty((len(x_), 3, 3))
    p = np.empty((len(x_), 3))
    kernel(x_, R, p)
    return R.reshape(shape + (3, 3)), p.reshape(shape + (3,))


def twist_from_transform(R, p, *, check=True):
    """Finite twist (SE(3) logarithm) of a rigid displacement.

    Parameters
    ----------
    R : array_like, shape (..., 3, 3)
        Rotation ``R_AB`` of frame B relative to frame A (columns: B's axes in A coordinates).
    p : array_like, shape (..., 3)
        Position ``p_AB`` of B's origin in A coordinates [m].
    check : bool
        Validate the arguments (finite, ``R`` orthonormal with ``det R = +1``).

    Returns
    -------
    xi : ndarray, shape (..., 6)
        ``[tau; t]``: rotation vector [rad] (angle in [0, pi]) and translational part [m],
        with ``(R, p) = exp(xi^)``.

    Examples
    --------
    >>> import numpy as np
    >>> import mjflex
    >>> c, s = np.cos(0.3), np.sin(0.3)
    >>> R = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])  # 0.3 rad about z
    >>> print(np.round(mjflex.twist_from_transform(R, [0.1, 0.0, 0.0]), 4) + 0.0)
    [ 0.      0.      0.3     0.0992 -0.015   0.    ]
    """
    return _coordinates(R, p, check, _k.twist_from_transform_batch, 6)


def transform_from_twist(xi, *, check=True):
    """Rigid displacement ``exp(xi^)`` of a finite twist (eqs 16-19).

    Parameters
    ----------
    xi : array_like, shape (..., 6)
        ``[tau; t]``: rotation vector [rad] (any angle) and translational part [m].
    check : bool
        Validate that ``xi`` is finite.

    Returns
    -------
    R : ndarray, shape (..., 3, 3)
        Rotation ``R_AB``.
    p : ndarray, shape (..., 3)
        Position ``p_AB`` [m].

    Examples
    --------
    >>> import numpy as np
    >>> import mjflex
    >>> R, p = mjflex.transform_from_twist([0.0, 0.0, np.pi / 2, 0.1, 0.0, 0.0])  # a quarter turn about z
    >>> print(np.round(R, 6) + 0.0)
    [[ 0. -1.  0.]
     [ 1.  0.  0.]
     [ 0.  0.  1.]]
    >>> print(np.round(mjflex.twist_from_transform(R, p), 6) + 0.0)  # the inverse
    [0.       0.       1.570796 0.1      0.       0.      ]
    >>> R, p = mjflex.transform_from_twist(np.zeros((4, 2, 6)))  # any leading axes
    >>> print(R.shape, p.shape)
    (4, 2, 3, 3) (4, 2, 3)
    """
    xi = np.ascontiguousarray(as_array(xi, "xi", (6,)) if check else xi, dtype=np.float64)
    return _pose(xi, "xi", _k.transform_from_twist_batch)


def dual_quaternion_from_transform(R, p, *, check=True):
    """Unit dual quaternion of a rigid displacement (eqs 34-38).

    Parameters
    ----------
    R : array_like, shape (..., 3, 3)
        Rotation ``R_AB``.
    p : array_like, shape (..., 3)
        Position ``p_AB`` of B's origin in A coordinates [m].
    check : bool
        Validate the arguments.

    Returns
    -------
    q : ndarray, shape (..., 8)
        ``(sigma, xi_1, xi_2, xi_3, s', x'_1, x'_2, x'_3)``: real part w-first with
        ``sigma >= 0``, then dual part w-first [m]; ``q_d = (0, p) q_r / 2``.

    Examples
    --------
    >>> import numpy as np
    >>> import mjflex
    >>> q = mjflex.dual_quaternion_from_transform(np.eye(3), [0.2, 0.0, 0.0])  # a pure translation
    >>> print(np.round(q, 6) + 0.0)  # (w, x, y, z, w', x', y', z')
    [1.  0.  0.  0.  0.  0.1 0.  0. ]
    """
    return _coordinates(R, p, check, _k.dual_quaternion_from_transform_batch, 8)


def transform_from_dual_quaternion(q, *, check=True):
    """Rigid displacement of a unit dual quaternion.

    Parameters
    ----------
    q : array_like, shape (..., 8)
        ``(sigma, xi_1, xi_2, xi_3, s', x'_1, x'_2, x'_3)`` as returned by
        :func:`dual_quaternion_from_transform`; ``q`` and ``-q`` give the same result.
    check : bool
        Validate that ``q`` is a finite unit dual quaternion (``|q_r| = 1``,
        ``q_r . q_d = 0``).

    Returns
    -------
    R : ndarray, shape (..., 3, 3)
        Rotation ``R_AB``.
    p : ndarray, shape (..., 3)
        Position ``p_AB`` [m], ``p = 2 vec(q_d conj(q_r))``.

    Examples
    --------
    >>> import numpy as np
    >>> import mjflex
    >>> R, p = mjflex.transform_from_twist([0.1, -0.2, 0.3, 0.01, 0.02, 0.03])
    >>> R2, p2 = mjflex.transform_from_dual_quaternion(mjflex.dual_quaternion_from_transform(R, p))
    >>> print(np.allclose(R2, R, atol=1e-14), np.allclose(p2, p, atol=1e-14))
    True True
    """
    q = np.ascontiguousarray(check_unit_dual_quaternion(q, "q") if check else q, dtype=np.float64)
    return _pose(q, "q", _k.transform_from_dual_quaternion_batch)

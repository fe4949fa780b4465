r"""An element's rest pose: the relative pose of its frames at which its energy is zero.

By default an element is relaxed when its frames a and b coincide. A **rest pose**
``X_r = (p_r, q_r)`` (the position [m] and the unit quaternion, w-first, of frame b in frame a)
moves that: the element's energy, wrench and stop coordinates count from ``X_ab = X_r``. A rest
pose the compiled model does not hold preloads the element: a finger's coupler pressed against
its stop by a spring, as MuJoCo's joint ``springref`` does for a joint spring.

It is the element of an ordinary frame pair ``(a, b*)``, where frame ``b*`` is fixed to body B
at ``X_Wb* = X_Wb X_r^-1``: ``R_Wb* = R_Wb R_r^T``, ``p_Wb* = p_Wb - R_Wb* p_r``. At
``X_ab = X_r`` frame ``b*`` coincides with frame a. The functions of :mod:`mjflex.core.elements`
and :mod:`mjflex.core.stops` take ``rest=(p_r, q_r)`` and evaluate the element on ``(a, b*)``;
the wrench they return keeps its reference point ``p_WB`` (the moment of the wrench at ``p_Wb*``,
moved to ``p_WB``), and a velocity of frame b's origin is moved to ``p_Wb*`` the same way.

In a model, the sites' measured rounding residual ``X_res`` (the rest offset of
:mod:`mjflex.mjcf.schema`) comes first and the rest pose second:
``X_Wb* = X_Wb X_res^-1 X_r^-1``, i.e. the offset the C engine removes is ``X_r X_res``. The
residual belongs to site b's placement (frame b less the residual is where the element frame was
put), so the rest pose stays exact in frame a.
"""

import numpy as np

from .validation import numeric_array

#: Largest ``|norm - 1|`` of a rest pose's quaternion: one written with 7 significant digits passes,
#: one that is not a rotation does not (the C library's ``MJFX_REST_QUAT_TOL``).
REST_QUAT_TOLERANCE = 1e-6


def rest_pose(rest, name="rest"):
    """A rest pose checked: ``(p_r (..., 3), q_r (..., 4) normalized, R_r (..., 3, 3))``.

    Parameters
    ----------
    rest : tuple (pos, quat)
        ``pos`` array_like (..., 3): position of frame b in frame a at rest [m]; ``quat``
        array_like (..., 4): orientation of frame b in frame a at rest, a unit quaternion
        w-first (norm 1 within ``REST_QUAT_TOLERANCE``; it is normalized here).
    name : str
        How the messages call the argument (e.g. ``"rest of flexure 'hinge'"``).

    Returns
    -------
    p_r : ndarray, shape (..., 3)
    q_r : ndarray, shape (..., 4)
    R_r : ndarray, shape (..., 3, 3)

    Raises
    ------
    ValueError
        Not a pair, a wrong count, a value that is not finite, or a quaternion that is not a rotation.

    Examples
    --------
    >>> import numpy as np
    >>> from mjflex.core.rest import rest_pose
    >>> p, q, R = rest_pose(([0.0, 0.0, 0.01], [np.cos(0.1), 0.0, 0.0, np.sin(0.1)]))
    >>> print(np.round(R, 4))  # 0.2 rad about z
    [[ 0.9801 -0.1987  0.    ]
     [ 0.1987  0.9801  0.    ]
     [ 0.      0.      1.    ]]
    """
    if isinstance(rest, dict) or not isinstance(rest, tuple | list) or len(rest) != 2:
        raise ValueError(f"{name} must be a pose (pos, quat): pos [x, y, z] [m] and quat [w, x, y, z], the pose of "
                         f"frame b in frame a at which the element's energy is zero; got {rest!r:.80}")  # fmt: skip
    p = numeric_array(rest[0], f"{name} pos")
    q = numeric_array(rest[1], f"{name} quat")
    for a, what, n in ((p, "pos", 3), (q, "quat", 4)):
        if a.ndim < 1 or a.shape[-1] != n:
            raise ValueError(f"{name} {what} must have {n} numbers; got shape {a.shape}")
        if not np.isfinite(a).all():
            raise ValueError(f"{name} {what} is not finite: give finite numbers; got {a}")
    norm = np.linalg.norm(q, axis=-1)
    if np.any(np.abs(norm - 1.0) > REST_QUAT_TOLERANCE):
        bad = float(np.ravel(norm)[np.argmax(np.abs(np.ravel(norm) - 1.0))])
        raise ValueError(f"{name} quat has norm {bad:.9g}, so it is not a rotation: give a unit quaternion "
                         f"[w, x, y, z] (norm 1 within {REST_QUAT_TOLERANCE:g}: write enough digits, or normalize "
                         "it)")  # fmt: skip
    q = q / norm[..., None]
    w, x, y, z = np.moveaxis(q, -1, 0)
    R = np.stack(
        [
            np.stack([w * w + x * x - y * y - z * z, 2 * (x * y - w * z), 2 * (x * z + w * y)], axis=-1),
            np.stack([2 * (x * y + w * z), w * w - x * x + y * y - z * z, 2 * (y * z - w * x)], axis=-1),
            np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), w * w - x * x - y * y + z * z], axis=-1),
        ],
        axis=-2,
    )
    return p, q, R


def frame_at_rest(R_WB, p_WB, rest):
    """Frame b* of a rest pose: ``(R_Wb*, p_Wb*)`` with ``R_Wb* = R_WB R_r^T``, ``p_Wb* = p_WB - R_Wb* p_r``.

    Parameters
    ----------
    R_WB : array_like, shape (..., 3, 3)
        Orientation of frame b in world coordinates.
    p_WB : array_like, shape (..., 3)
        Origin of frame b in world coordinates [m].
    rest : tuple (pos, quat)
        The rest pose (:func:`rest_pose`).

    Returns
    -------
    R_Wb : ndarray, shape (..., 3, 3)
    p_Wb : ndarray, shape (..., 3)
        Frame b*, which coincides with frame a when the element is at rest [m].

    Examples
    --------
    >>> import numpy as np
    >>> from mjflex.core.rest import frame_at_rest
    >>> R, p = frame_at_rest(np.eye(3), [0.0, 0.0, 0.01], ([0.0, 0.0, 0.01], [1.0, 0.0, 0.0, 0.0]))
    >>> print(p + 0.0)  # frame b 1 cm above frame a is the rest pose: b* is at frame a
    [0. 0. 0.]
    """
    p_r, _, R_r = rest_pose(rest)
    R_Wb = np.asarray(R_WB, dtype=float) @ np.swapaxes(R_r, -1, -2)
    p_Wb = np.asarray(p_WB, dtype=float) - np.einsum("...ij,...j->...i", R_Wb, p_r)
    return R_Wb, p_Wb

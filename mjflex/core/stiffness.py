"""Moving stiffness and damping matrices between frames; the centre of stiffness.

A 6x6 stiffness ``K_A`` (angular rows first) expressed in frame A about A's origin stores
energy ``1/2 delta_A^T K_A delta_A`` for a small twist ``delta_A`` in A coordinates. The
same element seen from a frame B with pose ``X_AB = (R_AB, p_AB)`` in A sees
``delta_A = Ad_{X_AB} delta_B``, hence (eq. 54)

    K_B = Ad_{X_AB}^T K_A Ad_{X_AB},    Ad_{X_AB} = [[R_AB, 0], [p_AB^ R_AB, R_AB]].

The same holds for damping matrices.
"""

import numpy as np

from .validation import as_array, check_psd_matrix, check_rotation


def _hat(v):
    z = np.zeros(v.shape[:-1])
    x, y, w = v[..., 0], v[..., 1], v[..., 2]
    return np.stack([np.stack([z, -w, y], -1), np.stack([w, z, -x], -1), np.stack([-y, x, z], -1)], -2)


def adjoint_from_transform(R_AB, p_AB, *, check=True):
    """Adjoint matrix of a rigid displacement, for twists ordered ``[omega; v]``.

    Parameters
    ----------
    R_AB : array_like, shape (..., 3, 3)
        Orientation of frame B in A.
    p_AB : array_like, shape (..., 3)
        Origin of B in A coordinates [m].
    check : bool
        Validate the arguments.

    Returns
    -------
    Ad : ndarray, shape (..., 6, 6)
        ``[[R, 0], [p^ R, R]]``: maps a twist in B coordinates about B's origin to the same
        twist in A coordinates about A's origin.

    Examples
    --------
    >>> import numpy as np
    >>> import mjflex
    >>> Ad = mjflex.adjoint_from_transform(np.eye(3), [0.1, 0.0, 0.0])  # B 0.1 m along x of A
    >>> print(Ad @ [0.0, 0.0, 1.0, 0.0, 0.0, 0.0] + 0.0)  # a unit spin about B's z seen at A's origin
    [ 0.   0.   1.   0.  -0.1  0. ]
    """
    if check:
        R_AB, p_AB = check_rotation(R_AB, "R_AB"), as_array(p_AB, "p_AB", (3,))
    R_AB, p_AB = np.asarray(R_AB, dtype=float), np.asarray(p_AB, dtype=float)
    shape = np.broadcast_shapes(R_AB.shape[:-2], p_AB.shape[:-1])
    Ad = np.zeros(shape + (6, 6))
    Ad[..., :3, :3] = R_AB
    Ad[..., 3:, 3:] = R_AB
    Ad[..., 3:, :3] = _hat(p_AB) @ R_AB
    return Ad


def stiffness_in_frame(K_A, R_AB, p_AB, *, check=True):
    """A stiffness (or damping) matrix re-expressed in another frame (the paper's equation 54).

    Parameters
    ----------
    K_A : array_like, shape (..., 6, 6)
        Matrix in frame A coordinates about A's origin, rows ``[rotation; translation]``.
    R_AB : array_like, shape (..., 3, 3)
        Orientation of the new frame B in A.
    p_AB : array_like, shape (..., 3)
        Origin of B in A coordinates [m].
    check : bool
        Validate the arguments (``K_A`` finite, symmetric, positive semi-definite).

    Returns
    -------
    K_B : ndarray, shape (..., 6, 6)
        ``Ad^T K_A Ad``: the same element in B coordinates about B's origin (exactly
        symmetric).

    Examples
    --------
    >>> import numpy as np
    >>> import mjflex
    >>> K_A = np.diag([1.0, 1.0, 1.0, 1e4, 1e4, 1e4])  # a bushing at A's origin
    >>> K_B = mjflex.stiffness_in_frame(K_A, np.eye(3), [0.1, 0.0, 0.0])  # the same element seen from 0.1 m away
    >>> print(f"{K_B[2, 2]:.1f} N m/rad")  # rotation about z at B also stretches the bushing: 1 + 1e4 * 0.1^2
    101.0 N m/rad
    """
    if check:
        K_A = check_psd_matrix(K_A, "K_A", 6, what="stiffness")
    Ad = adjoint_from_transform(R_AB, p_AB, check=check)
    K_B = np.swapaxes(Ad, -1, -2) @ np.asarray(K_A, dtype=float) @ Ad
    return 0.5 * (K_B + np.swapaxes(K_B, -1, -2))


def centre_of_stiffness(K, *, check=True):
    """Point about which the coupling block of a stiffness matrix is symmetric.

    Moving the reference point of ``K`` by ``r`` (no rotation) changes the coupling block to
    ``K_c - r^ K_t``; its antisymmetric part vanishes when
    ``((tr K_t) I - K_t) r = vex(K_c - K_c^T)`` (Loncaric's centre of stiffness, paper
    sec. 4.1). About this point rotation and translation couple only symmetrically (e.g. a
    leaf spring's centre is its midpoint).

    Parameters
    ----------
    K : array_like, shape (..., 6, 6)
        Stiffness about the origin of some frame F, in F coordinates.
    check : bool
        Validate ``K``.

    Returns
    -------
    r : ndarray, shape (..., 3)
        Position of the centre of stiffness in F coordinates [m]; the stiffness there is
        ``stiffness_in_frame(K, np.eye(3), r)``.

    Raises
    ------
    ValueError
        When the centre does not exist or is not unique: ``(tr K_t) I - K_t`` is singular,
        which happens when the translational block ``K_t`` has two or more zero eigenvalues
        (the element is translationally free along a plane).

    Examples
    --------
    >>> import numpy as np
    >>> import mjflex
    >>> K_A = np.diag([1.0, 1.0, 1.0, 1e4, 2e4, 3e4])
    >>> K_F = mjflex.stiffness_in_frame(K_A, np.eye(3), [0.05, -0.02, 0.01])  # the same spring, about another point
    >>> print(np.round(mjflex.centre_of_stiffness(K_F), 12) + 0.0)  # where it is uncoupled again, in F coordinates
    [-0.05  0.02 -0.01]
    """
    K = check_psd_matrix(K, "K", 6, what="stiffness") if check else np.asarray(K, dtype=float)
    Kc, Kt = K[..., :3, 3:], K[..., 3:, 3:]
    A = Kc - np.swapaxes(Kc, -1, -2)
    a = np.stack([A[..., 2, 1], A[..., 0, 2], A[..., 1, 0]], -1)
    M = np.trace(Kt, axis1=-2, axis2=-1)[..., None, None] * np.eye(3) - Kt
    lam = np.linalg.eigvalsh(0.5 * (M + np.swapaxes(M, -1, -2)))
    scale = np.maximum(np.abs(lam).max(axis=-1), np.finfo(float).tiny)
    bad = lam[..., 0] <= 1e-12 * scale
    if bad.any():
        i = tuple(np.argwhere(bad)[0]) if bad.ndim else ()
        where = f"K[{', '.join(map(str, i))}]" if i else "K"
        raise ValueError(
            f"{where} has no unique centre of stiffness: its translational block K_t has "
            f"eigenvalues {np.linalg.eigvalsh(Kt[i])} (two or more zero), so (tr K_t) I - K_t is "
            "singular. Such an element is free to translate in a plane; pick the reference point "
            "from its geometry instead."
        )
    return np.linalg.solve(M, a[..., None])[..., 0]

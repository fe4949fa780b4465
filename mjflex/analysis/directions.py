"""Principal directions of compliance of each element, and how much each one matters.

For an element with stiffness ``K`` (element frame E, about its origin) the reduction and the
native builders work in *principal coordinates*: the twist is taken about the element's centre
of stiffness ``c`` (:func:`mjflex.core.centre_of_stiffness`), then projected on the
eigenvectors ``Q_o`` of the rotational block and ``Q_t`` of the translational block. In these
coordinates ``delta_P = T delta_E`` with ``T = blockdiag(Q_o^T, Q_t^T) Ad(I, -c)``, and a
flexure built at its centre (notch hinges, leaf springs) has a diagonal ``K_P``: six
independent directions, each a rotation about an axis through ``c`` or a translation.

Two measures say whether a direction matters for a frequency band:

* its **local frequency** ``sqrt(k_i / m_i)``, with ``m_i = 1 / (J_i M^-1 J_i^T)`` the apparent
  inertia of the two bodies for that relative motion (from the model's own mass matrix), an
  intuition for where the direction sits in the spectrum;
* its **modal strain-energy share**: in each normal mode of the full model (mass-normalized,
  ``omega^2`` = twice the strain energy), the fraction ``k_i delta_i^2 / omega^2`` stored in that
  direction. Holding a direction rigid raises ``omega^2`` by about that share when the
  direction acts in series with the rest of the mode (exactly ``1 / (1 - share)`` for two
  springs in series), but by more when the rest of the mechanism stiffens it in parallel
  (closed loops): :func:`mjflex.reduce` uses the share to order the directions and checks the
  choice with the exact constrained eigenproblem.
"""

from dataclasses import dataclass

import mujoco
import numpy as np

from ..core import adjoint_from_transform, centre_of_stiffness
from ..mjcf import schema

LABELS = ("rx", "ry", "rz", "x", "y", "z")


@dataclass
class Directions:
    """Principal directions of one element (see the module docstring).

    Attributes
    ----------
    element : str
    body_a, body_b : int
        Body ids in the source model.
    sites : tuple of str
        Names of the element's sites a and b.
    T : ndarray (6, 6)
        Element twist (element axes, about the element origin) to principal coordinates.
    k, b : ndarray (6,)
        Principal stiffness and damping (diagonal of ``K_P``, ``B_P``).
    coupling : float
        Largest ``|K_P[i, j]| / sqrt(K_P[i, i] K_P[j, j])`` off the diagonal (0 for flexures
        built at their centre).
    labels : tuple of str
        Nearest element axis of each direction, e.g. ``"rz"`` for the hinge axis.
    axes_world : ndarray (6, 3)
        World direction of each principal direction (rotation axis or translation).
    centre_world : ndarray (3,)
        Centre of stiffness in world coordinates [m]; the rotation axes pass through it.
    J : ndarray (6, nv)
        Principal relative velocity of the element's bodies per unit ``qvel`` at ``qpos0``.
    local_hz : ndarray (6,)
        Local frequency of each direction [Hz].
    K_P, B_P : ndarray (6, 6)
        Stiffness and damping in principal coordinates.
    """

    element: str
    body_a: int
    body_b: int
    sites: tuple
    T: np.ndarray
    k: np.ndarray
    b: np.ndarray
    coupling: float
    labels: tuple
    axes_world: np.ndarray
    centre_world: np.ndarray
    J: np.ndarray
    local_hz: np.ndarray
    K_P: np.ndarray
    B_P: np.ndarray

    def restricted(self, keep) -> tuple[np.ndarray, np.ndarray]:
        """``K`` and ``B`` (element frame) of only the principal directions ``keep``."""
        mask = np.zeros(6)
        mask[list(keep)] = 1.0
        K = self.T.T @ np.diag(mask * np.diag(self.K_P)) @ self.T
        B = self.T.T @ np.diag(mask * np.diag(self.B_P)) @ self.T
        return 0.5 * (K + K.T), 0.5 * (B + B.T)


def element_matrices(record):
    """``(K, B)`` ``(6, 6)`` of an element's record, element frame (a planar one embedded, no damping as zeros)."""
    K = schema.embed_planar(record.K) if record.planar else record.K
    B = np.zeros((6, 6)) if record.B is None else (schema.embed_planar(record.B) if record.planar else record.B)
    return K, B


def _principal_axes(block, normal=None):
    """Eigenvectors of a symmetric 3x3 block, ordered and signed to match the frame axes when possible.

    With ``normal`` (unit, block coordinates), one axis is the normal itself and the other two
    are the eigenvectors of the block restricted to the plane normal to it (used when a scene
    is planar, so that in-plane and out-of-plane directions never mix, even for an isotropic
    block).
    """
    off = block - np.diag(np.diag(block))
    if normal is not None:
        u = np.linalg.svd(np.outer(normal, normal))[0][:, 1:]  # orthonormal basis of the plane
        _, v = np.linalg.eigh(u.T @ block @ u)
        Q = np.column_stack([u @ v, normal])
    elif np.abs(off).max() <= 1e-12 * max(np.abs(block).max(), 1e-300):
        return np.eye(3)
    else:
        _, Q = np.linalg.eigh(block)
    order = np.argmax(np.abs(Q), axis=0)
    if len(set(order)) == 3:
        Q = Q[:, np.argsort(order)]
    return Q * np.sign(Q[np.argmax(np.abs(Q), axis=0), range(3)])


def _centre(K, extent):
    """Centre of stiffness in element coordinates; the origin if it is undefined or far outside the model."""
    try:
        c = centre_of_stiffness(K, check=False)
    except ValueError:
        return np.zeros(3)
    return c if np.linalg.norm(c) <= extent else np.zeros(3)


def relative_jacobian(model, data, body_a, body_b, point, R_WE):
    """Twist rate of body b relative to body a at ``point``, element axes, per unit qvel (6, nv)."""
    J = np.zeros((6, model.nv))
    for body, sign in ((body_b, 1.0), (body_a, -1.0)):
        if body == 0:
            continue
        jacp, jacr = np.zeros((3, model.nv)), np.zeros((3, model.nv))
        mujoco.mj_jac(model, data, jacp, jacr, point, body)
        J[:3] += sign * R_WE.T @ jacr
        J[3:] += sign * R_WE.T @ jacp
    return J


def element_directions(model, flex, normal=None, qpos=None) -> list[Directions]:
    """:class:`Directions` of every element of ``flex`` (its model at ``qpos``, default ``qpos0``).

    Planar elements (3x3) are embedded in 6x6 with zero out-of-plane stiffness. ``normal``
    (world, unit): the plane of a planar scene; each element's principal axes then split into
    in-plane and out-of-plane ones (see :func:`_principal_axes`).
    """
    data = mujoco.MjData(model)
    if qpos is not None:
        data.qpos[:] = qpos
    mujoco.mj_forward(model, data)
    M = np.zeros((model.nv, model.nv))
    mujoco.mj_fullM(model, data, M)
    Minv = np.linalg.inv(M) if model.nv else M
    extent = max(float(model.stat.extent), 1e-3)
    out = []
    for rec, (sa, sb) in zip(flex.records, flex.site_ids, strict=True):
        sa, sb = int(sa), int(sb)
        K, B = element_matrices(rec)
        R_WE, p_WE = data.site_xmat[sa].reshape(3, 3).copy(), data.site_xpos[sa].copy()
        c = _centre(K, extent)
        Ad_EC = adjoint_from_transform(np.eye(3), c, check=False)
        K_C = Ad_EC.T @ K @ Ad_EC
        n_E = None if normal is None else R_WE.T @ normal
        Q_o, Q_t = _principal_axes(K_C[:3, :3], n_E), _principal_axes(K_C[3:, 3:], n_E)
        T = np.zeros((6, 6))
        T[:3, :3], T[3:, 3:] = Q_o.T, Q_t.T
        T = T @ adjoint_from_transform(np.eye(3), -c, check=False)
        Tinv = np.linalg.inv(T)
        K_P, B_P = Tinv.T @ K @ Tinv, Tinv.T @ B @ Tinv
        k = np.diag(K_P).copy()
        scale = np.sqrt(np.outer(np.maximum(k, 1e-300), np.maximum(k, 1e-300)))
        coupling = float(np.max(np.abs(K_P - np.diag(k)) / scale))
        axes = np.vstack([(R_WE @ Q_o).T, (R_WE @ Q_t).T])
        labels = tuple(LABELS[int(np.argmax(np.abs(Q_o[:, i])))] for i in range(3)) + tuple(
            LABELS[3 + int(np.argmax(np.abs(Q_t[:, i])))] for i in range(3)
        )
        centre_world = p_WE + R_WE @ c
        ba, bb = int(model.site_bodyid[sa]), int(model.site_bodyid[sb])
        J = T @ relative_jacobian(model, data, ba, bb, p_WE, R_WE)
        inv_inertia = np.einsum("ij,jk,ik->i", J, Minv, J)
        local = np.sqrt(np.maximum(k, 0.0) * inv_inertia) / (2.0 * np.pi)
        names = tuple(mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_SITE, i) for i in (sa, sb))
        out.append(Directions(rec.name, ba, bb, names, T, k, np.diag(B_P).copy(), coupling, labels, axes,
                              centre_world, J, local, K_P, B_P))  # fmt: skip
    return out


def energy_shares(directions, freq, modes, mask):
    """Strain-energy share of each principal direction in the selected modes.

    Parameters
    ----------
    directions : list of Directions
    freq : ndarray (nmodes,)
        Natural frequencies [Hz].
    modes : ndarray (nv, nmodes)
        Mass-normalized mode shapes in ``qvel`` coordinates.
    mask : ndarray of bool (nmodes,)
        The modes to measure (non-rigid ones only: the share divides by ``omega^2``).

    Returns
    -------
    ndarray (n_elements, 6, n_selected)
        ``k_i delta_i^2 / omega^2``; the shares of one mode sum to ~1 over all directions.
    """
    w2 = (2.0 * np.pi * freq[mask]) ** 2
    phi = modes[:, mask]
    return np.stack([d.k[:, None] * (d.J @ phi) ** 2 / w2 for d in directions]) if directions else np.zeros((0, 6, 0))


def damping_ratios(directions, freq, modes, mask, keep):
    """Damping ratio each element adds to each selected mode through its directions ``keep[e]`` (n_el, n_sel)."""
    w = 2.0 * np.pi * freq[mask]
    phi = modes[:, mask]
    out = np.zeros((len(directions), int(mask.sum())))
    for e, d in enumerate(directions):
        idx = sorted(keep[e])
        if idx:
            delta = d.J[idx] @ phi
            out[e] = np.einsum("im,ij,jm->m", delta, d.B_P[np.ix_(idx, idx)], delta) / (2.0 * w)
    return out

"""When a scene is planar, and what a planar variant changes.

A scene stays in a plane with normal ``n`` when nothing pushes it out: gravity lies in the
plane, every element's stiffness and damping couple no in-plane direction (rotation about
``n``, translations normal to it) with an out-of-plane one, every free body has ``n`` as a
principal axis of inertia (else its spin about ``n`` needs an out-of-plane moment), and the
initial velocities are in-plane (angular velocity along ``n``, linear velocity normal to it).
Then the out-of-plane modes are never excited, and a variant can put its free bodies on planar
joints and its elements in 3x3 planar form, their rest poses and stops with them (a rest pose must
lie in the plane, stops along its axes with the out-of-plane coordinates free at zero).
:func:`plane_of` checks all of it and says what fails.
"""

import mujoco
import numpy as np

from ..analysis.directions import element_matrices
from ..core import stiffness_in_frame
from ..core.rest import REST_QUAT_TOLERANCE, rest_pose
from ..mjcf import schema
from ..mjcf.stops import Stops

TOL = 1e-9  # relative: these are exact properties of a planar model, not approximations


def plane_frame(R_WE, n):
    """Rotation ``R_EF`` from an element frame E to the frame F with ``z = n`` and x closest to E's x."""
    x = R_WE[:, 0] - (R_WE[:, 0] @ n) * n
    if np.linalg.norm(x) < 1e-6:
        x = R_WE[:, 1] - (R_WE[:, 1] @ n) * n
    x /= np.linalg.norm(x)
    R_WF = np.column_stack([x, np.cross(n, x), n])
    return R_WE.T @ R_WF


def _coupled(M):
    inside, outside = list(schema.PLANAR_INDEX), [0, 1, 5]
    return np.abs(M[np.ix_(inside, outside)]).max() > TOL * max(np.abs(M).max(), 1e-300)


def _velocities_in_plane(model, data, n, bodies):
    worst, scale = 0.0, 1e-300
    for b in bodies:
        vel = np.zeros(6)
        mujoco.mj_objectVelocity(model, data, mujoco.mjtObj.mjOBJ_XBODY, b, vel, 0)
        w, v = vel[:3], vel[3:]
        worst = max(worst, np.linalg.norm(w - (w @ n) * n), abs(v @ n))
        scale = max(scale, np.linalg.norm(w), np.linalg.norm(v))
    return worst <= TOL * scale


def plane_of(model, flex, free_bodies, plane, state=None):
    """The unit normal of a planar scene, or ``(None, reason)``.

    Parameters
    ----------
    plane : "auto" or array_like (3,)
        ``"auto"``: the common z axis of the element frames, if there is one.
    state : tuple, optional
        ``(qpos, qvel)`` of the scene's initial state, checked for in-plane velocities.
    free_bodies : iterable of int
        The bodies that would move on planar joints (their inertia is checked).

    Returns
    -------
    (normal, reason) : (ndarray or None, str or None)
    """
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    if isinstance(plane, str):  # the common z axis of all element frames (mjflex's compliant axis), if there is one
        axes = [data.site_xmat[int(a)].reshape(3, 3)[:, 2] for a, _ in flex.site_ids]
        n = axes[0] if all(abs(abs(a @ axes[0]) - 1.0) < TOL for a in axes) else None
    else:
        n = np.asarray(plane, dtype=float)
    if n is None:
        return None, "the element frames do not share one z axis"
    if n.shape != (3,) or not np.linalg.norm(n) > 0:
        raise ValueError(f"plane must be 'auto' or a nonzero normal vector (3,); got {plane!r}")
    n = n / np.linalg.norm(n)
    g = model.opt.gravity
    if abs(g @ n) > TOL * max(np.linalg.norm(g), 1e-300):
        return None, f"gravity {g.tolist()} has a component along the normal {np.round(n, 6).tolist()}"
    for rec, (a, _) in zip(flex.records, flex.site_ids, strict=True):
        R_EF = plane_frame(data.site_xmat[int(a)].reshape(3, 3), n)
        if any(_coupled(stiffness_in_frame(M, R_EF, np.zeros(3), check=False)) for M in element_matrices(rec)):
            return None, f"element {rec.name!r} couples in-plane and out-of-plane motion"
        if planar_fit(rec, R_EF):
            return None, planar_fit(rec, R_EF)
    for b in free_bodies:
        R = data.ximat[b].reshape(3, 3)
        I_n = R @ np.diag(model.body_inertia[b]) @ R.T @ n
        if np.linalg.norm(I_n - (I_n @ n) * n) > TOL * max(model.body_inertia[b].max(), 1e-300):
            name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b)
            return None, f"the normal is not a principal axis of inertia of body {name!r}"
    if state is not None:
        data.qpos[:], data.qvel[:] = state
        mujoco.mj_forward(model, data)
        if not _velocities_in_plane(model, data, n, range(1, model.nbody)):
            return None, "the scene's initial velocities leave the plane"
    return n, None


def out_of_plane(dirs, n):
    """Boolean (n_el, 6): principal directions leaving the plane (rotations not about ``n``, translations along it)."""
    out = np.zeros((len(dirs), 6), dtype=bool)
    for e, d in enumerate(dirs):
        dots = np.abs(d.axes_world @ n)
        out[e, :3], out[e, 3:] = dots[:3] < 0.5, dots[3:] > 0.5
    return out


def in_plane_modes(model, modes, n):
    """Boolean (nmodes,): modes whose kinetic energy is mostly in-plane (out-of-plane share below 1/2)."""
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    out_share = np.zeros(modes.shape[1])
    total = np.zeros(modes.shape[1])
    for b in range(1, model.nbody):
        jacp, jacr = np.zeros((3, model.nv)), np.zeros((3, model.nv))
        mujoco.mj_jacBodyCom(model, data, jacp, jacr, b)
        v, w = jacp @ modes, jacr @ modes
        R = data.ximat[b].reshape(3, 3)
        I = R @ np.diag(model.body_inertia[b]) @ R.T
        w_out = w - np.outer(n, n @ w)
        m = model.body_mass[b]
        out_share += m * (n @ v) ** 2 + np.einsum("im,ij,jm->m", w_out, I, w_out)
        total += m * np.sum(v**2, axis=0) + np.einsum("im,ij,jm->m", w, I, w)
    return out_share < 0.5 * np.maximum(total, 1e-300)


def _planar_rest(rec, R_EF):
    """The rest pose in frame F (both sites turned by ``R_EF``: ``X_r -> R_EF^T X_r R_EF``) as an in-plane pose
    (a rotation about z, a translation in x-y), or ``(None, why)`` when it leaves the plane."""
    if rec.rest is None:
        return None, None
    p_r, _, R_r = rest_pose(rec.rest, f"rest of flexure {rec.name!r}")
    R, p = R_EF.T @ R_r @ R_EF, R_EF.T @ p_r
    size = max(float(np.linalg.norm(p)), 1e-300)
    if np.abs(R[:, 2] - [0.0, 0.0, 1.0]).max() > REST_QUAT_TOLERANCE or abs(p[2]) > TOL * size:
        return None, f"element {rec.name!r}'s rest pose leaves the plane"
    half = 0.5 * np.arctan2(R[1, 0], R[0, 0])
    return ((float(p[0]), float(p[1]), 0.0), (float(np.cos(half)), 0.0, 0.0, float(np.sin(half)))), None


def _planar_stops(rec, R_EF):
    """The element's stops in frame F's planar coordinates ``[theta, x, y]`` (limits, stiffness and damping carried
    exactly), or ``(None, why)``: F's axes must be E's up to sign (the coordinates then map one to one) and the
    out-of-plane coordinates, zero in the plane, must lie within their limits."""
    stops = rec.stops
    if not stops:
        return None, None
    P = np.asarray(R_EF)
    if np.abs(np.abs(P) - np.round(np.abs(P))).max() > TOL or not np.allclose(np.abs(P).sum(axis=0), 1.0):
        return None, f"element {rec.name!r}'s stops do not lie along the plane's axes"
    lower, upper = stops.limits_for(6)
    k, b = stops.stiffness_for(element_matrices(rec)[0]), stops.damping_for(6)
    new = {key: np.empty(6) for key in ("lower", "upper", "stiffness", "damping")}
    for f in range(6):  # coordinate f of F is sign s times coordinate j of E (twist coordinates turn with the frame)
        j = 3 * (f // 3) + int(np.argmax(np.abs(P[:, f % 3])))
        sign = float(np.sign(P[j % 3, f % 3]))
        lo, hi = sorted((sign * lower[j], sign * upper[j]))
        new["lower"][f], new["upper"][f], new["stiffness"][f], new["damping"][f] = lo, hi, k[j], b[j]
    out = [f for f in range(6) if f not in schema.PLANAR_INDEX]
    if np.any(new["lower"][out] > 0.0) or np.any(new["upper"][out] < 0.0):
        return None, f"element {rec.name!r}'s stops hold an out-of-plane coordinate away from zero"
    idx = list(schema.PLANAR_INDEX)

    def limits(values):
        return None if np.all(np.isinf(values[idx])) else [None if np.isinf(v) else float(v) for v in values[idx]]

    damping = new["damping"][idx].tolist() if np.any(new["damping"][idx]) else None
    return Stops(lower=limits(new["lower"]), upper=limits(new["upper"]), stiffness=new["stiffness"][idx].tolist(),
                 damping=damping), None  # fmt: skip


def planar_fit(rec, R_EF):
    """Why the element's rest pose or stops cannot be planar in frame F, or None."""
    return _planar_rest(rec, R_EF)[1] or _planar_stops(rec, R_EF)[1]


def planar_record(rec, R_EF):
    """The element's record as a planar (3x3) one in frame F (``z`` the normal), its rest pose and stops carried
    over (:func:`planar_fit` says when they cannot be; ValueError then)."""
    why = planar_fit(rec, R_EF)
    if why:
        raise ValueError(f"{why}: it cannot be a planar record")
    idx = list(schema.PLANAR_INDEX)
    K, B = (stiffness_in_frame(M, R_EF, np.zeros(3), check=False)[np.ix_(idx, idx)] for M in element_matrices(rec))
    return schema.FlexureRecord(rec.name, rec.method, K, B if rec.B is not None else None, rec.enabled, rec.viscous,
                                rec.strain_per_radian, rec.source, stops=_planar_stops(rec, R_EF)[0],
                                rest=_planar_rest(rec, R_EF)[0])  # fmt: skip

"""Keyframes of a model whose joints change: grown by new joints' rest values, or mapped from one model to another.

:func:`mjflex.make_compliant` adds joints to a body (a keyframe gets their rest values: the body
stays where it was) or replaces its joints (:mod:`mjflex.mj.replace`: the new joints' values are
solved from the body's pose relative to its parent in each keyframe, and their velocities from
its relative velocity). MjSpec checks the keyframes' sizes against the joints whenever it
compiles, so they are emptied (:func:`stash_keys`) while the joints change and written back after.
"""

from dataclasses import dataclass

import mujoco
import numpy as np

_T = mujoco.mjtJoint
_HINGE, _SLIDE, _BALL, _FREE = int(_T.mjJNT_HINGE), int(_T.mjJNT_SLIDE), int(_T.mjJNT_BALL), int(_T.mjJNT_FREE)


@dataclass
class KeyframeEdit:
    """What :func:`make_compliant` inserted into one keyframe: the new joints' rest values."""

    key: str | int  # the keyframe's name, or its index when unnamed
    qpos_addresses: tuple[int, ...]  # in the compliant model's qpos
    qpos_values: tuple[float, ...]
    qvel_addresses: tuple[int, ...]  # zeros inserted in qvel (empty when the keyframe gives no qvel)


def stash_keys(spec):
    """Empty the keyframes' qpos/qvel (so that the spec compiles while joints change); their old values."""
    saved = []
    for key in spec.keys:
        saved.append((np.array(key.qpos, dtype=float), np.array(key.qvel, dtype=float)))
        key.qpos, key.qvel = [], []
    return saved


def restore_keys(spec, saved):
    for key, (qpos, qvel) in zip(spec.keys, saved, strict=True):
        key.qpos, key.qvel = qpos.tolist(), qvel.tolist()


def grow_keys(spec, saved, model, joints, rigid_nq, rigid_nv):
    """Insert the new joints' rest values (``qpos0``; zero velocity) into every keyframe that gives qpos/qvel."""
    qadr, vadr = addresses(model, joints)
    edits = []
    for i, (key, (qpos, qvel)) in enumerate(zip(spec.keys, saved, strict=True)):
        new_q, new_v = qpos, qvel
        if qpos.size:
            if qpos.size != rigid_nq:
                raise ValueError(f"keyframe {key.name or i!r} has {qpos.size} qpos values, the model nq={rigid_nq}")
            new_q = insert(qpos, qadr, model.qpos0[qadr], model.nq)
        if qvel.size:
            if qvel.size != rigid_nv:
                raise ValueError(f"keyframe {key.name or i!r} has {qvel.size} qvel values, the model nv={rigid_nv}")
            new_v = insert(qvel, vadr, np.zeros(len(vadr)), model.nv)
        key.qpos, key.qvel = new_q.tolist(), new_v.tolist()
        if qpos.size or qvel.size:
            edits.append(KeyframeEdit(key.name or i, tuple(qadr) if qpos.size else (),
                                      tuple(model.qpos0[qadr].tolist()) if qpos.size else (),
                                      tuple(vadr) if qvel.size else ()))  # fmt: skip
    return tuple(edits)


def addresses(model, joints) -> tuple[list, list]:
    """The qpos and qvel addresses ``(sorted lists)`` of the named joints."""
    qadr = sorted(int(a) + k for j in joints for a, n in [joint_span(model, j, "q")] for k in range(n))
    vadr = sorted(int(a) + k for j in joints for a, n in [joint_span(model, j, "v")] for k in range(n))
    return qadr, vadr


def insert(old, addresses, values, size):
    out = np.empty(size)
    mask = np.ones(size, dtype=bool)
    mask[addresses] = False
    out[mask], out[addresses] = old, values
    return out


def joint_span(model, joint, which):
    j = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, joint)
    n = {_SLIDE: (1, 1), _HINGE: (1, 1), _BALL: (4, 3)}[int(model.jnt_type[j])]
    return (model.jnt_qposadr[j], n[0]) if which == "q" else (model.jnt_dofadr[j], n[1])


def dofs_of(model, j):
    """The dof slice of joint ``j``."""
    n = {_HINGE: 1, _SLIDE: 1, _BALL: 3, _FREE: 6}[int(model.jnt_type[j])]
    return slice(model.jnt_dofadr[j], model.jnt_dofadr[j] + n)


def _joint_map(source, target, body):
    """``[(source joint, target joint)]`` of every joint not of ``body`` (the bodies are the same in both models)."""
    pairs = []
    for b in range(source.nbody):
        if b == body:
            continue
        if source.body_jntnum[b] != target.body_jntnum[b]:
            raise ValueError(f"body #{b} has {source.body_jntnum[b]} joints in one model and {target.body_jntnum[b]} "
                             "in the other; the keyframes cannot be mapped")  # fmt: skip
        pairs += [(source.body_jntadr[b] + k, target.body_jntadr[b] + k) for k in range(source.body_jntnum[b])]
    return pairs


def _spans(model, j):
    nq = {_HINGE: 1, _SLIDE: 1, _BALL: 4, _FREE: 7}[int(model.jnt_type[j])]
    d = dofs_of(model, j)
    return slice(model.jnt_qposadr[j], model.jnt_qposadr[j] + nq), d


def _relative(model, data, body):
    """Pose ``(R_PB, p_PB)`` of ``body`` in its parent, and its ``(6, nv)`` relative-velocity Jacobian:
    angular velocity in B's axes, velocity of B's origin relative to the parent in P's axes."""
    parent = int(model.body_parentid[body])
    R_WB, R_WP = data.xmat[body].reshape(3, 3), data.xmat[parent].reshape(3, 3)
    x = data.xpos[body]
    J = np.zeros((6, model.nv))
    for sign, b in ((1.0, body), (-1.0, parent)):
        jacp, jacr = np.zeros((3, model.nv)), np.zeros((3, model.nv))
        mujoco.mj_jac(model, data, jacp, jacr, x, b)
        J[:3] += sign * R_WB.T @ jacr
        J[3:] += sign * R_WP.T @ jacp
    return R_WP.T @ R_WB, R_WP.T @ (x - data.xpos[parent]), J


def _kinematics(model, data):
    mujoco.mj_kinematics(model, data)
    mujoco.mj_comPos(model, data)


def _rotvec(R):
    q = np.empty(4)
    mujoco.mju_mat2Quat(q, np.ascontiguousarray(R).ravel())
    v = np.empty(3)
    mujoco.mju_quat2Vel(v, q, 1.0)
    return v


def map_state(source, target, body, qpos, qvel):
    """``(qpos, qvel)`` of ``target`` with ``body`` where ``source`` has it in ``(qpos, qvel)``.

    The two models differ only in the joints of ``body``: the other joints keep their values; the
    body's joints in ``target`` are solved (Gauss-Newton on its pose relative to its parent, then
    least squares on its relative velocity). Returns also the pose residual ``[rad, m]``: zero to
    round-off when ``target``'s joints can reach the pose, the nearest pose's distance otherwise.
    """
    src = mujoco.MjData(source)
    src.qpos[:], src.qvel[:] = qpos, qvel
    _kinematics(source, src)
    R_goal, p_goal, J_src = _relative(source, src, body)
    v_goal = J_src @ src.qvel
    out = mujoco.MjData(target)
    out.qpos[:], out.qvel[:] = target.qpos0, 0.0
    for js, jt in _joint_map(source, target, body):
        (qs, vs), (qt, vt) = _spans(source, js), _spans(target, jt)
        out.qpos[qt], out.qvel[vt] = src.qpos[qs], src.qvel[vs]
    ids = range(target.body_jntadr[body], target.body_jntadr[body] + target.body_jntnum[body])
    dofs = np.concatenate([np.arange(target.nv)[dofs_of(target, j)] for j in ids]) if len(ids) else np.zeros(0, int)
    residual = np.zeros(6)
    for _ in range(50):
        _kinematics(target, out)
        R, p, J = _relative(target, out, body)
        residual = np.concatenate([_rotvec(R.T @ R_goal), p_goal - p])
        if np.abs(residual).max() < 1e-15 * (1 + np.abs(p_goal).max()) or not len(dofs):
            break
        step = np.zeros(target.nv)
        step[dofs] = np.linalg.lstsq(J[:, dofs], residual, rcond=None)[0]
        if np.abs(step).max() < 1e-16:
            break
        mujoco.mj_integratePos(target, out.qpos, step, 1.0)
    _kinematics(target, out)
    _, _, J = _relative(target, out, body)
    if len(dofs):
        out.qvel[dofs] = np.linalg.lstsq(J[:, dofs], v_goal, rcond=None)[0]
    return out.qpos.copy(), out.qvel.copy(), float(np.abs(residual).max())


def map_keys(spec, saved, source, target, body, wanted=None):
    """Write every keyframe of ``spec`` for ``target`` from its values ``saved`` (``(qpos, qvel)`` for ``source``).

    A keyframe without qpos or qvel keeps it empty. ``wanted`` (optional): per keyframe, values
    to write as they are instead (the originals an undo puts back). Returns ``[(name, qpos, qvel,
    residual)]`` of the keyframes written.
    """
    written = []
    for i, (key, (qpos, qvel)) in enumerate(zip(spec.keys, saved, strict=True)):
        label = key.name or i
        if not qpos.size and not qvel.size:
            continue
        if wanted is not None and i < len(wanted) and wanted[i] is not None:
            key.qpos, key.qvel = (np.asarray(w).tolist() for w in wanted[i])
            written.append((label, np.asarray(wanted[i][0]), np.asarray(wanted[i][1]), 0.0))
            continue
        for what, values, size in (("qpos", qpos, source.nq), ("qvel", qvel, source.nv)):
            if values.size not in (0, size):
                raise ValueError(f"keyframe {label!r} has {values.size} {what} values; the model has {size}")
        q, v, residual = map_state(source, target, body, qpos if qpos.size else source.qpos0,
                                   qvel if qvel.size else np.zeros(source.nv))  # fmt: skip
        key.qpos = q.tolist() if qpos.size else []
        key.qvel = v.tolist() if qvel.size else []
        written.append((label, q, v, residual))
    return written


def mapped_keys(spec, saved, rigid, compliant, body, joints, replacement):
    """Keyframes of a replacement: the new joints' values solved from each keyframe's pose (module ``replace``)."""
    written = map_keys(spec, saved, rigid, compliant, body)
    replacement.saved["keys_before"] = saved
    replacement.saved["keys_after"] = [(np.array(k.qpos, dtype=float), np.array(k.qvel, dtype=float))
                                       for k in spec.keys]  # fmt: skip
    qadr, vadr = addresses(compliant, [j.name for j in joints])
    by_name = {label: (q, v) for label, q, v, _ in written}
    edits = []
    for i, key in enumerate(spec.keys):
        label = key.name or i
        if label not in by_name:
            continue
        q = by_name[label][0]
        edits.append(KeyframeEdit(label, tuple(qadr) if len(key.qpos) else (),
                                  tuple(q[qadr].tolist()) if len(key.qpos) else (),
                                  tuple(vadr) if len(key.qvel) else ()))  # fmt: skip
    return tuple(edits)

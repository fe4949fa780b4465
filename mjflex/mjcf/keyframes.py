"""Keyframes of a model whose joints change: grown by the new joints' rest values, and shrunk back.

:func:`mjflex.make_compliant` adds joints to a body (a keyframe gets their rest values: the body
stays where it was, whatever the body's other joints hold). MjSpec checks the keyframes' sizes
against the joints whenever it compiles, so they are emptied (:func:`stash_keys`) while the joints
change and written back after.
"""

from dataclasses import dataclass

import mujoco
import numpy as np

from .coordinates import DOFS, QPOS


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
    kind = int(model.jnt_type[j])
    return (model.jnt_qposadr[j], QPOS[kind]) if which == "q" else (model.jnt_dofadr[j], DOFS[kind])

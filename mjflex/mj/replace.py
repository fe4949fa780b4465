"""Joints replaced by a flexure element: the work of ``mjflex.make_compliant(..., replace_joints=True)``.

Most models have joints where the compliance belongs: a vertebra's three hinges tied to the next
level by equality constraints, a robot's series-elastic joint, a bushing modelled as a hinge.
Replacing them removes the body's joints to its parent (a body's joints in MuJoCo are always
between it and its parent), lets :func:`mjflex.make_compliant` give the body the free motion the
element needs, and carries over what named the joints:

* **Ranges** become the element's stops, in element coordinates (rotation-vector components of
  frame b relative to frame a, then the position of b's origin in a): a limited hinge or slide whose
  axis lies along an element axis gives that coordinate ``[lo - ref, hi - ref]`` (its sign flipped
  for an axis against the element's; ``ref`` is the joint's value at ``qpos0``, where the element is
  unstressed). A hinge's angle equals the rotation-vector component exactly for rotation about its
  axis alone, and to second order in the other components otherwise. A ball joint's range is a
  cone, ``|rotation| <= range[1]``; it becomes the circumscribed box ``[-range[1], range[1]]`` on
  the three rotations: exact along each element axis, up to ``sqrt(3)`` times the angle along a
  diagonal. The range of a joint whose axis is not along an element axis is not carried (the
  report says so; align the element frame with the joint, which is the default).
* **Equality constraints** of type ``joint``: one that drives a replaced joint (``joint1``) is
  removed: the element now determines that joint's motion. One in which a replaced joint drives
  kept joints (``joint2``, a spine's driving level) is rewritten when the couplings are linear:
  the first follower becomes the driver of the others (``q_k = a_k + c_k q_d`` and
  ``q_r = a_r + c_r q_d`` give ``q_k = a_k - c_k a_r / c_r + (c_k / c_r) q_r``, in MuJoCo's
  deviations from ``qpos0``), so the remaining levels stay coupled among themselves; a non-linear
  driver's followers are refused with their names (``equalities="remove"`` drops them instead).
  ``equalities="refuse"`` refuses whenever an equality names a replaced joint.
* **Actuators** on a replaced joint (transmission ``joint`` or ``jointinparent``) become site
  transmissions between the element's sites (``site = element/b``, ``refsite = element/a``) with
  the gear along the joint's axis in the element frame (rotation components for a hinge or a
  ball joint, translation components for a slide): the same torque or force between the two
  bodies, and a length that is the element's rotation (translation) along that axis, so a
  position servo holds the same angle (an affine gain or bias is shifted by ``gear * ref``). An
  inherited control range becomes the explicit range it compiled to.
* **Sensors** of a replaced joint (``jointpos``, ``jointvel``, ``ballquat``, ``ballangvel``,
  ``jointlimit*``, ``jointactuatorfrc``) have no joint to read and no sensor of the same size reads
  the element's coordinate: they are removed and reported (the element's displacement is
  :meth:`mjflex.Flexures.displacements`; a ``framequat`` sensor of site ``element/b`` with
  ``refsite`` ``element/a`` reads its rotation in a model).
* **Fixed tendons** that sum a replaced joint's position are refused with their names: no
  coordinate of the element means the same. Edit the tendon first.
* **Keyframes**: the new joints' values are solved from each keyframe's pose of the body relative
  to its parent (the body is where it was, to round-off), and their velocities from the relative
  velocity.
* Joint properties that the element does not carry (stiffness, damping, armature, friction loss, a
  spring reference other than ``ref``) are listed in the report's notes: give them in ``K`` and
  ``B``.

:func:`mjflex.make_rigid` restores all of it: the joints with their attributes and classes, the
equalities and sensors in their places (so the compiled model's ids are the original ones), the
actuators' transmissions and the keyframes.
"""

import math
from dataclasses import dataclass, field

import mujoco
import numpy as np

from . import keyframes

_T = mujoco.mjtJoint
_HINGE, _SLIDE, _BALL, _FREE = int(_T.mjJNT_HINGE), int(_T.mjJNT_SLIDE), int(_T.mjJNT_BALL), int(_T.mjJNT_FREE)
_KIND = {_HINGE: "hinge", _SLIDE: "slide", _BALL: "ball", _FREE: "free"}
_S = mujoco.mjtSensor
JOINT_SENSORS = {
    int(s)
    for s in (_S.mjSENS_JOINTPOS, _S.mjSENS_JOINTVEL, _S.mjSENS_BALLQUAT, _S.mjSENS_BALLANGVEL,
              _S.mjSENS_JOINTLIMITPOS, _S.mjSENS_JOINTLIMITVEL, _S.mjSENS_JOINTLIMITFRC, _S.mjSENS_JOINTACTFRC)
}  # fmt: skip
_JOINT_TRN = {int(mujoco.mjtTrn.mjTRN_JOINT), int(mujoco.mjtTrn.mjTRN_JOINTINPARENT)}
EQUALITY_CHOICES = ("auto", "remove", "refuse")
#: Attributes never copied when a spec element is snapshotted and re-created.
_SKIP = {"id", "signature", "compiler", "info", "parent", "frame", "classname", "plugin", "default"}
#: An axis this close to an element axis (1 - |cos|) counts as along it.
ALIGNED = 1e-9


@dataclass(frozen=True)
class Edit:
    """One change :func:`mjflex.make_compliant` made to something that named a replaced joint.

    ``kind``: ``"equality"``, ``"actuator"`` or ``"sensor"``; ``name``: its name (``"#i"``, its
    index, when unnamed); ``action``: ``"removed"``, ``"rewritten"`` or ``"carried"``;
    ``detail``: what and why, in words.
    """

    kind: str
    name: str
    action: str
    detail: str


@dataclass
class Replacement:
    """What ``replace_joints=True`` did (the ``replaced`` attribute of :class:`mjflex.Compliance`).

    ``joints``: the joints removed, in order. ``lower``, ``upper`` (6,): the stops their ranges
    give, element coordinates ``[rx, ry, rz, x, y, z]`` [rad, m] (``-inf``/``inf``: none).
    ``edits``: the equalities, actuators and sensors changed (:class:`Edit`). ``notes``: what was
    not carried (joint springs, dampers, ranges off the element axes...), in words.
    """

    joints: tuple[str, ...]
    lower: np.ndarray
    upper: np.ndarray
    edits: tuple[Edit, ...] = ()
    notes: tuple[str, ...] = ()
    saved: dict = field(default_factory=dict, repr=False)

    @property
    def has_stops(self) -> bool:
        return bool(np.isfinite(self.lower).any() or np.isfinite(self.upper).any())


# ------------------------------------------------------------------ snapshots of spec elements


def snapshot(obj) -> dict:
    """The settable attributes of a spec element (and its default class), to re-create it."""
    out = {}
    for name in dir(type(obj)):
        if name.startswith("_") or name in _SKIP or not isinstance(getattr(type(obj), name), property):
            continue
        value = getattr(obj, name)
        out[name] = value.copy() if isinstance(value, np.ndarray) else value
    out["_class"] = getattr(getattr(obj, "classname", None), "name", None)
    return out


def _restore_attributes(obj, saved):
    for name, value in saved.items():
        if name.startswith("_"):
            continue
        try:
            setattr(obj, name, value)
        except (AttributeError, TypeError):  # read-only attributes (computed by MuJoCo)
            pass


def _recreate(spec, adder, saved):
    default = spec.find_default(saved["_class"]) if saved.get("_class") not in (None, "main") else None
    obj = adder(default) if default is not None else adder()
    _restore_attributes(obj, saved)
    return obj


def _rebuild_tail(spec, kind, wanted):
    """Make ``spec``'s ``kind`` elements (``"equalities"``, ``"sensors"``) the snapshots ``wanted``, in order.

    The elements that already match from the start stay; from the first difference on, all are
    deleted and re-created in order (MjSpec appends only: an element's place is its compiled id).
    """
    current = list(getattr(spec, kind))
    keep = 0
    while keep < min(len(current), len(wanted)) and _same(snapshot(current[keep]), wanted[keep]):
        keep += 1
    for obj in current[keep:]:
        spec.delete(obj)
    adder = {"equalities": lambda d=None: spec.add_equality(d) if d is not None else spec.add_equality(),
             "sensors": lambda d=None: spec.add_sensor()}[kind]  # fmt: skip
    for saved in wanted[keep:]:
        _recreate(spec, adder, saved)


def _same(a, b) -> bool:
    if a.keys() != b.keys():
        return False
    for k in a:
        x, y = a[k], b[k]
        if isinstance(x, np.ndarray) or isinstance(y, np.ndarray):
            if not np.array_equal(np.asarray(x), np.asarray(y)):
                return False
        elif x != y:
            return False
    return True


# ------------------------------------------------------------------ the plan: checks before any change


@dataclass
class Plan:
    """What will be done, checked before the spec is touched (a refusal leaves it as it was)."""

    body: str
    joints: list  # (name, rigid joint id)
    equalities: dict  # index -> ("remove", reason) or ("rewrite", name2, polycoef, reason)
    sensors: list  # indices
    actuators: list  # (index, rigid joint id)


def _label(obj, i, kind):
    return obj.name or f"{kind} #{i}"


def make_plan(spec, rigid, body, equalities="auto") -> Plan:
    """Check what names the body's joints; raise ValueError naming what cannot be carried."""
    if equalities not in EQUALITY_CHOICES:
        raise ValueError(f"equalities={equalities!r}: use one of {EQUALITY_CHOICES}")
    ib = mujoco.mj_name2id(rigid, mujoco.mjtObj.mjOBJ_BODY, body.name)
    ids = list(range(rigid.body_jntadr[ib], rigid.body_jntadr[ib] + rigid.body_jntnum[ib]))
    joints = [(mujoco.mj_id2name(rigid, mujoco.mjtObj.mjOBJ_JOINT, j) or "", j) for j in ids]
    names = {n for n, _ in joints if n}
    _refuse_tendons(spec, body, names)
    return Plan(body.name, joints, _equality_plan(spec, body, names, equalities),
                [i for i, s in enumerate(spec.sensors) if int(s.type) in JOINT_SENSORS and s.objname in names],
                [(i, dict(joints)[a.target]) for i, a in enumerate(spec.actuators)
                 if int(a.trntype) in _JOINT_TRN and a.target in names])  # fmt: skip


def _refuse_tendons(spec, body, names):
    found = []
    for i, tendon in enumerate(spec.tendons):
        try:
            wraps = list(tendon.path)
        except TypeError:
            continue
        named = [w.target.name for w in wraps
                 if int(w.type) == int(mujoco.mjtWrap.mjWRAP_JOINT) and w.target.name in names]  # fmt: skip
        if named:
            found.append(f"{_label(tendon, i, 'tendon')} (sums {', '.join(named)})")
    if found:
        raise ValueError(
            f"body {body.name!r}: fixed tendon(s) {'; '.join(found)} sum the positions of joints that "
            "replace_joints would remove, and no coordinate of the element means the same. Remove those joints from "
            "the tendons (or the tendons, with what uses them) first, or replace other joints"
        )


def _polycoef(eq):
    return np.asarray(eq.data[:5], dtype=float)


def _equality_plan(spec, body, names, choice):
    plan, refused, drivers = {}, [], {}
    for i, eq in enumerate(spec.equalities):
        if int(eq.type) != int(mujoco.mjtEq.mjEQ_JOINT):
            continue
        r1, r2 = eq.name1 in names, bool(eq.name2) and eq.name2 in names
        if not (r1 or r2):
            continue
        label = _label(eq, i, "equality")
        if choice == "refuse":
            refused.append(f"{label} ({eq.name1} = f({eq.name2 or 'constant'}))")
        elif r1 or choice == "remove":
            why = (
                f"the element now determines the motion of {eq.name1}"
                if r1
                else f"removed on request (equalities='remove'): {eq.name1} no longer follows {eq.name2}"
            )
            plan[i] = ("remove", why)
        else:
            drivers.setdefault(eq.name2, []).append(i)
    for driver, followers in drivers.items():
        eqs = [spec.equalities[i] for i in followers]
        coefs = [_polycoef(e) for e in eqs]
        if any(np.any(c[2:] != 0) for c in coefs) or not any(c[1] != 0 for c in coefs):
            refused += [f"{_label(e, i, 'equality')} ({e.name1} = poly({driver}), coefficients {c.tolist()})"
                        for i, e, c in zip(followers, eqs, coefs, strict=True)]  # fmt: skip
            continue
        root = next(k for k, c in enumerate(coefs) if c[1] != 0)
        a_r, c_r = coefs[root][0], coefs[root][1]
        new_root = eqs[root].name1
        for k, (i, e, c) in enumerate(zip(followers, eqs, coefs, strict=True)):
            if k == root:
                plan[i] = ("remove", f"{new_root} drives the levels {driver} drove (it is replaced by the element)")
            else:
                poly = [c[0] - c[1] * a_r / c_r, c[1] / c_r, 0.0, 0.0, 0.0]
                plan[i] = ("rewrite", new_root, poly,
                           f"{e.name1} followed {driver} (replaced); it now follows {new_root}, which followed "
                           f"{driver} too: {e.name1} = {poly[0]:.6g} + {poly[1]:.6g} {new_root}")  # fmt: skip
    if refused:
        raise ValueError(
            f"body {body.name!r}: equality constraint(s) {'; '.join(refused)} name joints that replace_joints would "
            "remove and cannot be rewritten to keep their meaning"
            + (" (equalities='refuse')" if choice == "refuse" else " (a non-linear coupling to a replaced driver)")
            + ". Choose: equalities='remove' drops them (the joints they coupled move on their own), or edit them "
            "first (e.g. make another joint the driver)"
        )
    return plan


# ------------------------------------------------------------------ the element frame the joints suggest


def joint_frame(rigid, body_name) -> tuple[np.ndarray, np.ndarray]:
    """World pose ``(p_WE, R_WE)`` at ``qpos0`` of the element frame the body's joints suggest.

    Origin: the anchor of the first hinge or ball joint (the body's origin for slides alone).
    Axes: the body's, when every hinge and slide axis lies along one of them; else z along the
    joints' one axis direction; else x along the first axis and y in the plane of the first two.
    """
    data = mujoco.MjData(rigid)
    mujoco.mj_kinematics(rigid, data)
    ib = mujoco.mj_name2id(rigid, mujoco.mjtObj.mjOBJ_BODY, body_name)
    ids = range(rigid.body_jntadr[ib], rigid.body_jntadr[ib] + rigid.body_jntnum[ib])
    R_WB, p = data.xmat[ib].reshape(3, 3).copy(), data.xpos[ib].copy()
    rotational = [j for j in ids if rigid.jnt_type[j] in (_HINGE, _BALL)]
    if rotational:
        p = data.xanchor[rotational[0]].copy()
    axes = [data.xaxis[j].copy() for j in ids if rigid.jnt_type[j] in (_HINGE, _SLIDE)]
    if all(np.abs(R_WB.T @ a).max() > 1 - ALIGNED for a in axes):
        return p, R_WB
    distinct = [axes[0]]
    for a in axes[1:]:
        if abs(abs(a @ distinct[0]) - 1) > ALIGNED:
            distinct.append(a)
            break
    if len(distinct) == 1:
        z = distinct[0] / np.linalg.norm(distinct[0])
        x = R_WB[:, int(np.argmin(np.abs(R_WB.T @ z)))]
        x = x - (x @ z) * z
        x /= np.linalg.norm(x)
        return p, np.column_stack([x, np.cross(z, x), z])
    x = distinct[0] / np.linalg.norm(distinct[0])
    y = distinct[1] - (distinct[1] @ x) * x
    y /= np.linalg.norm(y)
    return p, np.column_stack([x, y, np.cross(x, y)])


# ------------------------------------------------------------------ ranges -> stops


def stops_from_ranges(rigid, joints, R_BE) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """``(lower, upper, notes)``: the stops (element coordinates) that the joints' ranges give.

    ``joints``: ``(name, id)`` in the rigid model; ``R_BE``: the element frame's axes in the
    body's frame. See the module docstring for the mapping.
    """
    lower, upper, notes = np.full(6, -np.inf), np.full(6, np.inf), []
    for name, j in joints:
        kind, label = int(rigid.jnt_type[j]), name or f"joint #{j}"
        if not rigid.jnt_limited[j]:
            continue
        lo, hi = (float(v) for v in rigid.jnt_range[j])
        if kind == _BALL:
            lower[:3], upper[:3] = np.maximum(lower[:3], -hi), np.minimum(upper[:3], hi)
            notes.append(f"ball joint {label}'s cone range {math.degrees(hi):.4g} deg became stops of +-"
                         f"{math.degrees(hi):.4g} deg on rx, ry, rz (the circumscribed box: exact along each element "
                         "axis, up to sqrt(3) times the angle along a diagonal)")  # fmt: skip
            continue
        if kind not in (_HINGE, _SLIDE):
            continue
        axis = R_BE.T @ rigid.jnt_axis[j]
        k = int(np.argmax(np.abs(axis)))
        if abs(axis[k]) < 1 - 1e-6:
            notes.append(f"the range of {_KIND[kind]} {label} was not carried: its axis {np.round(axis, 4).tolist()} "
                         "(element frame) is not along an element axis; give stops yourself or align the element "
                         "frame with the joint")  # fmt: skip
            continue
        ref = float(rigid.qpos0[rigid.jnt_qposadr[j]])
        bounds = sorted(np.sign(axis[k]) * (v - ref) for v in (lo, hi))
        c = k if kind == _HINGE else 3 + k
        lower[c], upper[c] = max(lower[c], bounds[0]), min(upper[c], bounds[1])
    return lower, upper, notes


def dropped_properties(rigid, joints) -> list[str]:
    """Notes on joint properties the element does not carry (give them in K and B)."""
    notes = []
    for name, j in joints:
        label, dofs = name or f"joint #{j}", keyframes.dofs_of(rigid, j)
        found = []
        if rigid.jnt_stiffness[j]:
            found.append(f"stiffness {rigid.jnt_stiffness[j]:.6g} (give it in K)")
        q = rigid.jnt_qposadr[j]
        if rigid.jnt_stiffness[j] and rigid.jnt_type[j] in (_HINGE, _SLIDE) and rigid.qpos_spring[q] != rigid.qpos0[q]:
            found.append(f"spring reference {rigid.qpos_spring[q]:.6g} != ref {rigid.qpos0[q]:.6g} (the element is "
                         "unstressed at ref)")  # fmt: skip
        for what, values, hint in (("damping", rigid.dof_damping, "give it in B or damping_ratio"),
                                   ("armature", rigid.dof_armature, "not carried"),
                                   ("friction loss", rigid.dof_frictionloss, "not carried")):  # fmt: skip
            if np.any(values[dofs]):
                found.append(f"{what} {values[dofs].max():.6g} ({hint})")
        if found:
            notes.append(f"{_KIND[int(rigid.jnt_type[j])]} {label}: " + ", ".join(found))
    return notes


# ------------------------------------------------------------------ apply and undo


def begin(spec, plan: Plan, old_joints) -> Replacement:
    """Remove ``old_joints`` (the body's joints) and rewrite or remove the equalities and sensors that name them.

    Everything is snapshotted first, for :func:`undo`. The actuators follow in :func:`park_actuators` and
    :func:`finish` (they need joints, then the element's sites, to compile).
    """
    saved = {
        "body": plan.body,
        "joints": [snapshot(j) for j in old_joints],
        "equalities": [snapshot(e) for e in spec.equalities],
        "sensors": [snapshot(s) for s in spec.sensors],
        "actuators": {i: snapshot(spec.actuators[i]) for i, _ in plan.actuators},
        "rewritten": {i for i, step in plan.equalities.items() if step[0] == "rewrite"},
    }
    edits, wanted = [], []
    for i, eq in enumerate(spec.equalities):
        step = plan.equalities.get(i)
        if step is None:
            wanted.append(snapshot(eq))
        elif step[0] == "remove":
            edits.append(Edit("equality", _label(eq, i, "equality"), "removed", step[1]))
        else:
            s = snapshot(eq)
            s["name2"] = step[1]
            s["data"] = np.concatenate([step[2], np.asarray(eq.data[5:], dtype=float)])
            wanted.append(s)
            edits.append(Edit("equality", _label(eq, i, "equality"), "rewritten", step[3]))
    removed = set(plan.sensors)
    for i in plan.sensors:
        s = spec.sensors[i]
        edits.append(Edit("sensor", _label(s, i, "sensor"), "removed",
                          f"{mujoco.mjtSensor(int(s.type)).name[7:].lower()} of {s.objname}: no joint to read; read "
                          "the element with Flexures.displacements, or a framequat sensor of its site b with refsite "
                          "its site a"))  # fmt: skip
    saved["kept_sensors"] = [i for i in range(len(saved["sensors"])) if i not in removed]
    saved["kept_equalities"] = [i for i in range(len(saved["equalities"]))
                                if plan.equalities.get(i, ("",))[0] != "remove"]  # fmt: skip
    _rebuild_tail(spec, "equalities", wanted)
    _rebuild_tail(spec, "sensors", [s for i, s in enumerate(saved["sensors"]) if i not in removed])
    for joint in old_joints:
        spec.delete(joint)
    return Replacement(tuple(n or f"#{j}" for n, j in plan.joints), np.full(6, -np.inf), np.full(6, np.inf),
                       tuple(edits), (), saved)  # fmt: skip


def park_actuators(spec, plan: Plan, joint: str) -> None:
    """Point the replaced joints' actuators at ``joint`` (a new joint) for the compilations before :func:`finish`."""
    for i, _ in plan.actuators:
        spec.actuators[i].target = joint


def finish(spec, replacement: Replacement, plan: Plan, rigid, element, R_BE, stops) -> None:
    """Carry the actuators onto the element's sites (they exist now); record the stops and the notes.

    ``stops``: ``(lower, upper, notes)`` of :func:`stops_from_ranges`.
    """
    edits = [_carry_actuator(spec.actuators[i], i, rigid, jid, element, R_BE) for i, jid in plan.actuators]
    lower, upper, notes = stops
    replacement.lower, replacement.upper = np.asarray(lower, dtype=float), np.asarray(upper, dtype=float)
    replacement.edits = (*replacement.edits, *edits)
    replacement.notes = (*notes, *dropped_properties(rigid, plan.joints))


def _carry_actuator(act, i, rigid, jid, element, R_BE) -> Edit:
    """A joint actuator becomes a site transmission between the element's sites, gear along the joint axis."""
    kind, g = int(rigid.jnt_type[jid]), np.asarray(act.gear, dtype=float)
    if kind == _FREE:
        raise ValueError(f"actuator {_label(act, i, 'actuator')} drives a free joint, which has no axis to carry")
    in_parent = int(act.trntype) == int(mujoco.mjtTrn.mjTRN_JOINTINPARENT)
    gear = np.zeros(6)
    if kind == _BALL:
        R = R_BE.T if not in_parent else R_BE.T @ _body_rotation(rigid, jid).T
        gear[3:] = R @ g[:3]
    else:
        axis = R_BE.T @ rigid.jnt_axis[jid]
        gear[(3 if kind == _HINGE else 0) : (6 if kind == _HINGE else 3)] = g[0] * axis
    ia = i  # actuator ids are their places in the spec
    offset = g[0] * float(rigid.qpos0[rigid.jnt_qposadr[jid]]) if kind != _BALL else 0.0
    if offset and int(act.biastype) == int(mujoco.mjtBias.mjBIAS_AFFINE):
        act.biasprm = [act.biasprm[0] + act.biasprm[1] * offset, *act.biasprm[1:]]
    if offset and int(act.gaintype) == int(mujoco.mjtGain.mjGAIN_AFFINE):
        act.gainprm = [act.gainprm[0] + act.gainprm[1] * offset, *act.gainprm[1:]]
    if act.inheritrange > 0:
        act.inheritrange = 0.0
        act.ctrlrange = rigid.actuator_ctrlrange[ia].tolist()
        act.ctrllimited = mujoco.mjtLimited.mjLIMITED_TRUE
    if np.any(rigid.actuator_lengthrange[ia]):
        act.lengthrange = (rigid.actuator_lengthrange[ia] - offset).tolist()
    joint = mujoco.mj_id2name(rigid, mujoco.mjtObj.mjOBJ_JOINT, jid) or f"#{jid}"
    act.trntype, act.target, act.refsite = mujoco.mjtTrn.mjTRN_SITE, f"{element}/b", f"{element}/a"
    act.gear = gear.tolist()
    return Edit("actuator", _label(act, i, "actuator"), "carried",
                f"{_KIND[kind]} {joint} -> site transmission {element}/b relative to {element}/a, gear "
                f"{np.round(gear, 9).tolist()} (element frame)")  # fmt: skip


def _body_rotation(model, jid):
    """``R_PB`` at ``qpos0`` of the joint's body in its parent (for gears given in the parent's frame)."""
    q = model.body_quat[model.jnt_bodyid[jid]]
    R = np.empty(9)
    mujoco.mju_quat2Mat(R, q)
    return R.reshape(3, 3)


def undo(spec, replacement: Replacement) -> None:
    """Put back the joints, equalities, sensors and actuators (keyframes and the element are the caller's)."""
    saved = replacement.saved
    body = spec.body(saved["body"])
    for s in saved["joints"]:
        _recreate(spec, lambda d=None, b=body: b.add_joint(d) if d is not None else b.add_joint(), s)
    for i, s in saved["actuators"].items():
        _restore_attributes(spec.actuators[i], s)
    _rebuild_tail(spec, "equalities", _merged(spec.equalities, saved["equalities"], saved["kept_equalities"],
                                              saved["rewritten"]))  # fmt: skip
    _rebuild_tail(spec, "sensors", _merged(spec.sensors, saved["sensors"], saved["kept_sensors"], set()))


def _merged(current, originals, kept, rewritten):
    """The originals in their places: removed and rewritten ones as they were, the others as they are now (the user
    may have edited them since), and elements added since after them."""
    current = [snapshot(x) for x in current]
    out = list(originals)
    for k, i in enumerate(kept):
        if k < len(current) and i not in rewritten:
            out[i] = current[k]
    return out + current[len(kept) :]

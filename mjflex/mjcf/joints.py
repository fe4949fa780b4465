"""Joints replaced by a flexure element: the work of ``mjflex.make_compliant(..., replace_joints=True)``.

Most models have joints where the compliance belongs: a vertebra's three hinges tied to the next
level by equality constraints, a robot's series-elastic joint, a bushing modelled as a hinge.
Replacing them hands the body's motion relative to its parent (a body's joints in MuJoCo are
always to its parent) to the element: the joints stop being a joint model (no spring, damper or
friction loss: the element's stiffness and damping take over) and become *coordinates* of the
motion the element needs; :func:`mjflex.make_compliant` adds the missing ones (slides along the
element axes, hinges about the element axes the joints do not turn about, at the joints' anchor)
so that the body moves in all of the element's directions. Every joint keeps its name, axis,
anchor, reference and **armature** (the inertia of a rotor or gear train behind the joint, there
whatever the stiffness; dropping it would change the model's inertia, its stable time step, and
the effective mass that soft equality constraints and limits scale their stiffness with), so
everything that names it keeps its meaning, exactly:

* **Actuators** keep their joint transmission: a motor applies the same torque about the same
  axis between the same bodies, a servo holds the same angle. Only an inherited control range
  (``inheritrange``, from the joint's range, where the range goes) becomes the explicit range it
  compiled to. (A site transmission between the element's sites with ``refsite`` would measure
  the element's rotation vector, but MuJoCo's moment arm for it is the angular velocity, not the
  rotation vector's gradient: at a loaded, bent element a servo on it is not conservative, and
  its flutter diverges at any time step. A joint transmission has neither problem.)
* **Sensors** (``jointpos``, ``jointvel``, ``ballquat``, ...) read the same coordinate; fixed
  **tendons** sum the same coordinates; **keyframes** keep every value and get the rest values of
  the added joints (the body is where it was).
* **Equality constraints** of type ``joint``: one that drives a replaced joint (``joint1``; or
  one between two replaced joints) is removed, since the element now determines that motion (left
  in, it would override the element). One in which a replaced joint drives another joint
  (``joint2``: a spine's driving level) is kept as it is: the follower follows the same coordinate,
  now moved by the element. ``equalities="remove"`` removes every joint equality that names a
  replaced joint; ``equalities="refuse"`` refuses (naming them) so that the user decides.
* **Ranges** (``stops=``): ``"limits"`` (the default) keeps them as MuJoCo's joint limits on the
  coordinates, with their ``solref``, ``solimp`` and margin: constraints, dissipative and stable at
  the file's time step, exact on the joint's angle, as the rigid model had them; sensors that read
  a limit keep reading it. ``"element"`` turns them into the element's stops, in element
  coordinates (rotation-vector components of frame b relative to frame a, then the position of
  b's origin in a): a limited hinge or slide whose axis lies along an element axis gives that
  coordinate ``[lo - ref, hi - ref]`` (its sign flipped for an axis against the element's; ``ref``
  is the joint's value at ``qpos0``, where the element is unstressed). A hinge's angle equals the
  rotation-vector component exactly for rotation about its axis alone, and to second order in the
  other components otherwise. A ball joint's range is a cone, ``|rotation| <= range[1]``; it
  becomes the circumscribed box ``[-range[1], range[1]]`` on the three rotations: exact along each
  element axis, up to ``sqrt(3)`` times the angle along a diagonal. A range beyond ``pi`` from the
  rest, or of a joint whose axis is not along an element axis, is not carried (the report says so;
  align the element frame with the joint, which is the default). The sensors that read a joint's
  **limit** (``jointlimitpos``, ``jointlimitvel``, ``jointlimitfrc``) then have none left to read:
  they are removed and reported.
* Joint properties that the element does not carry (stiffness, damping, friction loss) are listed
  in the report's notes: give them in ``K`` and ``B``.
* **Some of the joints** (``replace_joints=["name", ...]``): the others stay joints with their own
  joint model (range, spring, damper, armature); the element leaves their directions alone (its
  stiffness there must be zero, and each must lie along an element axis). The element frame comes
  from the replaced joints: :mod:`mjflex.mjcf.coordinates` has the rule (one hinge: its axis is the
  element's z) and the checks.

:func:`mjflex.make_rigid` restores all of it: the joints' attributes, the removed equalities and
sensors in their places (so the compiled model's ids are the original ones), the actuators'
ranges and the keyframes.
"""

from dataclasses import dataclass, field

import mujoco
import numpy as np

from .coordinates import DOFS, HINGE, KIND, SLIDE

_S = mujoco.mjtSensor
#: Sensors that read a joint's limit: none is left once the range becomes the element's stops (``stops="element"``).
LIMIT_SENSORS = {int(_S.mjSENS_JOINTLIMITPOS), int(_S.mjSENS_JOINTLIMITVEL), int(_S.mjSENS_JOINTLIMITFRC)}
#: What makes a joint a joint model (the element takes over): reset to MuJoCo's built-in values on the replaced
#: joints. Their name, type, axis, anchor, reference, armature and actuation settings stay.
STRIPPED = ("damping", "frictionloss", "solimp_friction", "solref_friction", "springdamper", "springref",
            "springyield", "stiffness")  # fmt: skip
#: A joint's limit: kept with ``stops="limits"``, reset (the range becomes element stops or nothing) otherwise.
LIMIT = ("limited", "margin", "range", "solimp_limit", "solref_limit")
#: How a replaced joint's range goes on: MuJoCo's joint limit on the coordinate, or the element's stops.
STOP_KINDS = ("limits", "element")
_JOINT_TRN = {int(mujoco.mjtTrn.mjTRN_JOINT), int(mujoco.mjtTrn.mjTRN_JOINTINPARENT)}
EQUALITY_CHOICES = ("auto", "remove", "refuse")
#: Attributes never copied when a spec element is snapshotted and re-created.
_SKIP = {"id", "signature", "compiler", "info", "parent", "frame", "classname", "plugin", "default"}


@dataclass(frozen=True)
class Edit:
    """One change :func:`mjflex.make_compliant` made to something that named a replaced joint.

    ``kind``: ``"equality"``, ``"actuator"`` or ``"sensor"``; ``name``: its name (``"#i"``, its
    index, when unnamed); ``action``: ``"removed"``, ``"kept"`` or ``"changed"``; ``detail``:
    what and why, in words.
    """

    kind: str
    name: str
    action: str
    detail: str


@dataclass
class Replacement:
    """What ``replace_joints`` did (the ``replaced`` attribute of :class:`mjflex.Compliance`).

    Attributes
    ----------
    joints : tuple of str
        The replaced joints, in order: now the element's coordinates (no spring, damper or
        friction loss; their armature kept), with their names, axes and anchors.
    lower, upper : ndarray, shape (6,)
        Their ranges in element coordinates ``[rx, ry, rz, x, y, z]`` [rad, m] (``-inf`` /
        ``inf``: none): the element's stops where ``stops == "element"``.
    stops : {"limits", "element", "given", "none"}
        What became of the ranges: MuJoCo's joint limits kept on the coordinates (``"limits"``),
        the element's stops ``lower``/``upper`` (``"element"``), the stops given as
        :class:`mjflex.Stops` (``"given"``), or none (``stops=False``, or no range).
    kept : tuple of str
        The body's joints that stay joints (``replace_joints=[...]`` named the others).
    edits : tuple of Edit
        The equalities, sensors and actuators removed, kept or changed, with the reason.
    notes : tuple of str
        What was not carried (joint springs, dampers, ranges off the element axes...), in words.
    saved : dict
        What :func:`mjflex.make_rigid` puts back: snapshots of the joints' attributes and of the
        equalities, sensors and actuators as they were (not for reading).

    Examples
    --------
    >>> import mujoco
    >>> import mjflex
    >>> spec = mujoco.MjSpec.from_string(
    ...     '<mujoco><compiler angle="radian"/><worldbody><body name="base"><geom size="0.05"/>'
    ...     '<body name="arm" pos="0 0 0.1"><joint name="elbow" axis="0 1 0" range="-1 0.5" damping="0.1"/>'
    ...     '<geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02"/></body></body></worldbody>'
    ...     '<actuator><motor joint="elbow"/></actuator></mujoco>'
    ... )
    >>> c = mjflex.make_compliant(spec, "arm", [50, 50, 5, 1e5, 1e5, 1e5], replace_joints=True)
    >>> print(c.replaced.joints, c.replaced.stops)  # the elbow's range stays MuJoCo's joint limit
    ('elbow',) limits
    >>> print(c.replaced.lower[2], c.replaced.upper[2])  # the range on the element's rz: the elbow's axis
    -1.0 0.5
    >>> c.joints  # added: the translations and the other rotations the element needs
    ('arm_compliance/x', 'arm_compliance/y', 'arm_compliance/z', 'arm_compliance/rx', 'arm_compliance/ry')
    >>> c.replaced.notes
    ('hinge elbow: damping 0.1 (give it in B or damping_ratio)',)
    """

    joints: tuple[str, ...]
    lower: np.ndarray
    upper: np.ndarray
    edits: tuple[Edit, ...] = ()
    notes: tuple[str, ...] = ()
    saved: dict = field(default_factory=dict, repr=False)
    stops: str = "none"
    kept: tuple[str, ...] = ()

    @property
    def has_stops(self) -> bool:
        """Whether any replaced joint had a range, i.e. whether ``lower``/``upper`` hold a finite limit."""
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
    for saved in wanted[keep:]:  # re-created with its default class
        default = spec.find_default(saved["_class"]) if saved.get("_class") not in (None, "main") else None
        _restore_attributes(adder(default), saved)


def _same(a, b) -> bool:
    def equal(x, y):
        arrays = isinstance(x, np.ndarray) or isinstance(y, np.ndarray)
        return np.array_equal(np.asarray(x), np.asarray(y)) if arrays else x == y

    return a.keys() == b.keys() and all(equal(a[k], b[k]) for k in a)


# ------------------------------------------------------------------ the plan: checks before any change


@dataclass
class Plan:
    """What will be done, checked before the spec is touched (a refusal leaves it as it was)."""

    body: str
    joints: list  # (name, rigid joint id) of the replaced joints
    equalities: dict  # index -> ("remove" | "keep", reason)
    sensors: list  # indices of limit sensors to remove
    actuators: list  # indices of actuators whose inherited range becomes explicit
    keep_limits: bool = True  # the ranges stay MuJoCo's joint limits (stops="limits")
    places: list = field(default_factory=list)  # the replaced joints' places among the body's joints


def _label(obj, i, kind):
    return obj.name or f"{kind} #{i}"


def make_plan(spec, rigid, body, joints, equalities="auto", keep_limits=True) -> Plan:
    """Check what names the replaced ``joints`` (``(name, id)`` in ``rigid``, of ``body``); raise ValueError when
    ``equalities="refuse"`` meets one. ``keep_limits``: their ranges stay MuJoCo's joint limits."""
    if equalities not in EQUALITY_CHOICES:
        raise ValueError(f"equalities={equalities!r}: use one of {EQUALITY_CHOICES}")
    names = {n for n, _ in joints if not n.startswith("#")}
    first = rigid.body_jntadr[mujoco.mj_name2id(rigid, mujoco.mjtObj.mjOBJ_BODY, body.name)]
    sensors = [i for i, s in enumerate(spec.sensors) if int(s.type) in LIMIT_SENSORS and s.objname in names]
    actuators = [i for i, a in enumerate(spec.actuators)
                 if int(a.trntype) in _JOINT_TRN and a.target in names and a.inheritrange > 0]  # fmt: skip
    if keep_limits:  # the limits stay: so do the sensors that read them and the ranges that actuators inherit
        sensors, actuators = [], []
    return Plan(body.name, list(joints), _equality_plan(spec, body, names, equalities), sensors, actuators,
                keep_limits, [int(j - first) for _, j in joints])  # fmt: skip


def _equality_plan(spec, body, names, choice):
    plan, refused = {}, []
    for i, eq in enumerate(spec.equalities):
        if int(eq.type) != int(mujoco.mjtEq.mjEQ_JOINT):
            continue
        r1, r2 = eq.name1 in names, bool(eq.name2) and eq.name2 in names
        if not (r1 or r2):
            continue
        label = _label(eq, i, "equality")
        if choice == "refuse":
            refused.append(f"{label} ({eq.name1} = f({eq.name2 or 'constant'}))")
        elif r1:
            plan[i] = ("remove", f"the element now determines the motion of {eq.name1}" + (
                f" (and of {eq.name2})" if r2 else ""))  # fmt: skip
        elif choice == "remove":
            plan[i] = ("remove", f"removed on request (equalities='remove'): {eq.name1} no longer follows {eq.name2}")
        else:
            plan[i] = ("keep", f"{eq.name1} follows {eq.name2} as before: the same coordinate, moved by the element")
    if refused:
        raise ValueError(
            f"body {body.name!r}: equality constraint(s) {'; '.join(refused)} name joints that replace_joints would "
            "hand to the element (equalities='refuse'). Choose: equalities='auto' removes those that drive a "
            "replaced joint (the element determines its motion) and keeps those a replaced joint drives; "
            "equalities='remove' removes them all; or edit them first"
        )
    return plan


def dropped_properties(rigid, joints, springs_carried=False) -> list[str]:
    """Notes on joint properties the element does not carry (give them in K and B); the armature stays."""
    notes = []
    for name, j in joints:
        label, kind = name or f"joint #{j}", int(rigid.jnt_type[j])
        dofs = slice(rigid.jnt_dofadr[j], rigid.jnt_dofadr[j] + DOFS[kind])
        found = []
        if rigid.jnt_stiffness[j]:
            found.append(f"stiffness {rigid.jnt_stiffness[j]:.6g} (give it in K)")
        q = rigid.jnt_qposadr[j]
        if rigid.jnt_stiffness[j] and kind in (HINGE, SLIDE) and rigid.qpos_spring[q] != rigid.qpos0[q]:
            found.append(
                f"spring reference {rigid.qpos_spring[q]:.6g} != ref {rigid.qpos0[q]:.6g} ("
                + ("carried over: the element rests there)" if springs_carried else "the element is unstressed at ref)")
            )
        for what, values, hint in (("damping", rigid.dof_damping, "give it in B or damping_ratio"),
                                   ("friction loss", rigid.dof_frictionloss, "not carried")):  # fmt: skip
            if np.any(values[dofs]):
                found.append(f"{what} {values[dofs].max():.6g} ({hint})")
        if found:
            notes.append(f"{KIND[kind]} {label}: " + ", ".join(found))
    return notes


# ------------------------------------------------------------------ apply and undo


def apply(spec, plan: Plan, rigid, stops, kind="limits", kept=(), springs_carried=False) -> Replacement:
    """Strip the replaced joints of their joint model and carry over what named them (snapshots for :func:`undo`).

    ``stops``: ``(lower, upper, notes)`` of :func:`mjflex.mjcf.coordinates.stops_from_ranges`; ``kind``: what
    became of the ranges (:attr:`Replacement.stops`); ``kept``: the names of the body's joints left as they are;
    ``springs_carried``: the joints' spring references became the element's rest pose.
    """
    body = spec.body(plan.body)
    joints = list(body.joints)
    saved = {
        "body": plan.body,
        "places": list(plan.places),
        "joints": [snapshot(joints[k]) for k in plan.places],
        "equalities": [snapshot(e) for e in spec.equalities],
        "sensors": [snapshot(s) for s in spec.sensors],
        "actuators": {i: snapshot(spec.actuators[i]) for i in plan.actuators},
    }
    edits, wanted = [], []
    for i, eq in enumerate(spec.equalities):
        step = plan.equalities.get(i)
        if step is None or step[0] == "keep":
            wanted.append(snapshot(eq))
        if step is not None:
            edits.append(Edit("equality", _label(eq, i, "equality"), "removed" if step[0] == "remove" else "kept",
                              step[1]))  # fmt: skip
    removed = set(plan.sensors)
    for i in plan.sensors:
        s = spec.sensors[i]
        edits.append(Edit("sensor", _label(s, i, "sensor"), "removed",
                          f"{mujoco.mjtSensor(int(s.type)).name[7:].lower()} of {s.objname}: the joint has no limit "
                          "left to read (its range became the element's stops, or none)"))  # fmt: skip
    for i in plan.actuators:
        act = spec.actuators[i]
        act.inheritrange = 0.0
        act.ctrlrange = rigid.actuator_ctrlrange[i].tolist()  # actuator ids are their places in the spec
        act.ctrllimited = mujoco.mjtLimited.mjLIMITED_TRUE
        edits.append(Edit("actuator", _label(act, i, "actuator"), "changed",
                          f"its control range inherited from {act.target}'s range is now explicit: "
                          f"{np.round(rigid.actuator_ctrlrange[i], 9).tolist()}"))  # fmt: skip
    saved["kept_sensors"] = [i for i in range(len(saved["sensors"])) if i not in removed]
    saved["kept_equalities"] = [i for i in range(len(saved["equalities"]))
                                if plan.equalities.get(i, ("",))[0] != "remove"]  # fmt: skip
    _rebuild_tail(spec, "equalities", wanted)
    _rebuild_tail(spec, "sensors", [s for i, s in enumerate(saved["sensors"]) if i not in removed])
    blank = mujoco.MjSpec().worldbody.add_body().add_joint()
    for k in plan.places:
        for attr in STRIPPED + (() if plan.keep_limits else LIMIT):  # set on the joint, they override its class's
            setattr(joints[k], attr, getattr(blank, attr))  # values (also in a saved file)
    lower, upper, notes = stops
    return Replacement(tuple(n for n, _ in plan.joints), np.asarray(lower, dtype=float),
                       np.asarray(upper, dtype=float), tuple(edits),
                       (*notes, *dropped_properties(rigid, plan.joints, springs_carried)), saved, kind,
                       tuple(kept))  # fmt: skip


def undo(spec, replacement: Replacement) -> None:
    """Put back the joints' attributes, the equalities, sensors and actuator ranges (the caller removes the added
    joints, the element and the keyframe entries)."""
    saved = replacement.saved
    joints = list(spec.body(saved["body"]).joints)
    for k, s in zip(saved["places"], saved["joints"], strict=True):
        _restore_attributes(joints[k], s)
    for i, s in saved["actuators"].items():
        _restore_attributes(spec.actuators[i], s)
    _rebuild_tail(spec, "equalities", _merged(spec.equalities, saved["equalities"], saved["kept_equalities"]))
    _rebuild_tail(spec, "sensors", _merged(spec.sensors, saved["sensors"], saved["kept_sensors"]))


def _merged(current, originals, kept):
    """The originals in their places: the removed ones as they were, the kept ones as they are now (the user may
    have edited them since), and elements added since after them."""
    current = [snapshot(x) for x in current]
    out = list(originals)
    for k, i in enumerate(kept):
        if k < len(current):
            out[i] = current[k]
    return out + current[len(kept) :]

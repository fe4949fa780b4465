"""Where :func:`mjflex.make_compliant` puts things: the arguments that say it, checked, and the joints it adds.

* :func:`directions_named`, :func:`matrix6`: the element directions asked for and a K or B for them;
* :func:`find_body`, :func:`check_body`, :func:`pairs`, :func:`kept`: the body, and the contact pairs to keep;
* :func:`frame_argument`, :func:`element_pose`: the element frame from a site or a pose, at ``qpos0``;
* :func:`joint_attributes`, :func:`add_joints`: the joints that give the body the element's directions.
"""

import warnings

import mujoco
import numpy as np

from ..analysis.damping import DIRECTIONS
from ..mjcf import naming
from ..mjcf.spec import quaternion_from_rotation, rotation_from_quaternion, unit_quaternion

GROUPS = {"all": DIRECTIONS, "rotations": DIRECTIONS[:3], "translations": DIRECTIONS[3:]}
_SLIDE, _HINGE, _BALL = mujoco.mjtJoint.mjJNT_SLIDE, mujoco.mjtJoint.mjJNT_HINGE, mujoco.mjtJoint.mjJNT_BALL
#: Joint attributes reset to MuJoCo's built-in defaults on the joints added (a body's ``childclass``
#: or the model's ``<default>`` would otherwise give them armature, ranges, damping, springs...).
CLEAN = ("actfrclimited", "actfrcrange", "actgravcomp", "armature", "damping", "frictionloss", "group", "limited",
         "margin", "range", "ref", "solimp_friction", "solimp_limit", "solref_friction", "solref_limit",
         "springdamper", "springref", "springyield", "stiffness")  # fmt: skip


def directions_named(directions) -> tuple[str, ...]:
    """The element directions ``directions`` names (a group of ``GROUPS`` or names), checked, in the order of
    ``DIRECTIONS``."""
    if isinstance(directions, str):
        directions = GROUPS.get(directions, (directions,))
    try:
        asked = list(directions)
    except TypeError:
        raise ValueError(
            f"directions must be names of {DIRECTIONS} (or 'all', 'rotations'); got {directions!r}"
        ) from None
    unknown = [d for d in asked if d not in DIRECTIONS]
    if unknown:
        raise ValueError(
            f"directions {unknown} unknown: use names of {DIRECTIONS} (rotations about and translations along the "
            "element frame's axes), or 'all', 'rotations', 'translations'"
        )
    if not asked:
        raise ValueError(
            "directions is empty: the body would keep no degree of freedom, and the element would act on nothing; "
            "name at least one of " + ", ".join(DIRECTIONS)
        )
    return tuple(d for d in DIRECTIONS if d in asked)


def matrix6(value, directions, what):
    """A K or B given for the six directions or for the chosen ones only, as 6x6 (zero elsewhere)."""
    a = np.asarray(value, dtype=float)
    n = len(directions)
    if n < 6 and a.shape in ((n,), (n, n)):
        idx = [DIRECTIONS.index(d) for d in directions]
        out = np.zeros((6, 6))
        out[np.ix_(idx, idx)] = np.diag(a) if a.ndim == 1 else a
        return out
    if a.shape in ((6,), (6, 6)):
        return np.diag(a) if a.ndim == 1 else a
    raise ValueError(f"{what} must be 6 numbers or 6x6 (or {n} / {n}x{n} for the directions {directions}); "
                     f"got shape {a.shape}")  # fmt: skip


def find_body(spec, body):
    """The ``MjsBody`` to make compliant (a name or the body), checked: in the spec, named, not the world."""
    if isinstance(body, mujoco.MjsBody):
        found, label = body, body.name
    elif isinstance(body, str):
        found, label = (spec.worldbody if body == "world" else spec.body(body)), body
    else:
        raise TypeError(f"body must be a body's name or an MjsBody; got {type(body).__name__}")
    if found is None:
        raise ValueError(f"body {body!r} is not in the spec"
                         + naming.spec_hint(spec, body, "body"))  # fmt: skip
    if found.name == "world" or found.parent is None:
        raise ValueError("the world body has no parent to be compliant against; name the body to make compliant "
                         "(e.g. a robot's hand or its mount)")  # fmt: skip
    if not found.name:
        raise ValueError(f"body {label!r} has no name; name it (the element and the excludes refer to it by name)")
    return found


def check_body(spec, body, replace_joints=False):
    """Refuse a body with joints (without ``replace_joints``) or a mocap body."""
    joints = [j.name or f"#{i}" for i, j in enumerate(body.joints)]
    if joints and (replace_joints is False or replace_joints is None):
        raise ValueError(
            f"body {body.name!r} already has joints ({', '.join(joints)}): make_compliant turns the weld between a "
            "body and its parent into an element, and a joint's motion would deflect the element. Pass "
            "replace_joints=True to replace these joints by the element (or replace_joints=[names] for some of them; "
            "their ranges stay MuJoCo's joint limits, equalities and actuators that name them are carried over), "
            "make a welded body compliant (e.g. the hand rather than the wrist link), or add a body between the "
            "joint and the part"
        )
    if body.mocap:
        raise ValueError(f"body {body.name!r} is a mocap body, which cannot have joints; make a child of it compliant")


def frame_argument(frame, pos, quat):
    """The frame that ``pos``/``quat`` are given in: ``frame``, or the parent's with a FutureWarning when unsaid."""
    if frame is None and (pos is not None or quat is not None):
        warnings.warn(
            "make_compliant(pos=..., quat=...) without frame= gives the element frame in the parent body's frame, "
            "while add_flexure's pos= is in the world frame; this default is deprecated. Pass frame='parent' to keep "
            "it, or frame='world' (or a body's name) for the frame you mean; without frame=, a future release will "
            "read pos= in the world frame, as add_flexure does",
            FutureWarning,
            stacklevel=3,
        )
        return "parent"
    return frame


def frame_pose(spec, model, data, body, parent, frame):
    """``(R_WF, p_WF)`` at ``qpos0`` of the frame that ``pos``/``quat`` are given in."""
    if isinstance(frame, mujoco.MjsBody):
        frame = "world" if frame is spec.worldbody else frame.name
    if not isinstance(frame, str):
        raise TypeError(f"frame must be 'parent', 'body', 'world' or a body's name; got {frame!r}")
    name = {"parent": parent.name or "world", "body": body.name}.get(frame, frame)
    i = 0 if name in ("", "world") else mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, name)
    if i < 0:
        raise ValueError(f"frame={frame!r} is neither 'parent', 'body', 'world' nor a body of the spec"
                         + naming.spec_hint(spec, frame, "body"))  # fmt: skip
    return data.xmat[i].reshape(3, 3), data.xpos[i]


def element_pose(spec, model, body, parent, site, pos, quat, frame=None):
    """World pose ``(p_WE, R_WE)`` of the element frame at ``qpos0``, and the frame as reported (a site's
    name, or ``(pos, quat)`` in the parent's frame)."""
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    if site is not None:
        if pos is not None or quat is not None:
            raise ValueError("give the element frame as site=... or as pos=/quat= (with frame=), not both")
        name = site if isinstance(site, str) else getattr(site, "name", None)
        found = spec.site(name) if isinstance(name, str) else None
        if found is None:
            raise ValueError(f"site {name!r} is not in the spec"
                             + naming.spec_hint(spec, name, "site"))  # fmt: skip
        if found.parent.name not in (body.name, parent.name):
            raise ValueError(
                f"site {name!r} belongs to body {found.parent.name or 'world'!r}, not to {body.name!r} or its parent "
                f"{parent.name or 'world'!r}: the element frame must move with one of the two bodies; use a site of "
                "either, or give pos=/quat= (with frame=)"
            )
        i = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, name)
        return data.site_xpos[i].copy(), data.site_xmat[i].reshape(3, 3).copy(), name
    i = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, body.name)
    if pos is None and quat is None:  # the body's own frame
        return data.xpos[i].copy(), data.xmat[i].reshape(3, 3).copy(), None
    R_WF, p_WF = frame_pose(spec, model, data, body, parent, frame)
    p = np.zeros(3) if pos is None else np.asarray(pos, dtype=float)
    q = unit_quaternion((1.0, 0.0, 0.0, 0.0) if quat is None else quat, "quat")
    if p.shape != (3,) or not np.isfinite(p).all():
        raise ValueError(f"pos must be 3 finite numbers (the element origin in frame {frame!r}); got {pos!r}")
    p_WE, R_WE = p_WF + R_WF @ p, R_WF @ rotation_from_quaternion(q)
    j = 0 if parent.name in ("", "world") else mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, parent.name)
    R_WP, p_WP = data.xmat[j].reshape(3, 3), data.xpos[j]
    p_PE, q_PE = R_WP.T @ (p_WE - p_WP), quaternion_from_rotation(R_WP.T @ R_WE)
    return p_WE, R_WE, (tuple(p_PE.tolist()), tuple(q_PE.tolist()))


def add_joints(body, element, directions, R_BE, p_BE, attributes):
    """Slides along the chosen element axes, then a ball (all three rotations) or hinges, at the element origin."""
    blank = mujoco.MjSpec().worldbody.add_body().add_joint()
    plan = [(f"{element}/{d}", _SLIDE, R_BE[:, "xyz".index(d)]) for d in directions if d in "xyz"]
    rotations = [d for d in directions if d.startswith("r")]
    if len(rotations) == 3:
        plan.append((f"{element}/ball", _BALL, np.array([0.0, 0.0, 1.0])))
    else:
        plan += [(f"{element}/{d}", _HINGE, R_BE[:, "xyz".index(d[1])]) for d in rotations]
    added = []
    for name, kind, axis in plan:
        joint = body.add_joint(name=name, type=kind, axis=axis, pos=p_BE)
        added.append(joint)
        for attr in CLEAN:
            if hasattr(blank, attr):
                setattr(joint, attr, getattr(blank, attr))
        for attr, value in attributes.items():
            setattr(joint, attr, value)
    return added


def joint_attributes(attributes):
    """The user's joint attributes, checked before anything is added: names of ``MjsJoint`` attributes."""
    attributes = dict(attributes or {})
    blank = mujoco.MjSpec().worldbody.add_body().add_joint()
    for attr, value in attributes.items():
        if attr in ("name", "type", "axis", "pos", "parent", "frame") or not hasattr(blank, attr):
            raise ValueError(f"joint_attributes: {attr!r} is not a joint attribute make_compliant lets you set "
                             "(e.g. armature, damping, range with limited)")  # fmt: skip
        try:
            setattr(blank, attr, value)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"joint_attributes: {attr}={value!r} is not valid ({exc})") from None
    return attributes


def pairs(spec, collide):
    """``collide`` as a set of frozensets of body names ('*' for any body); raises on unknown bodies."""
    out = set()
    for item in collide or ():
        pair = (item, "*") if isinstance(item, str) else tuple(item)
        if len(pair) != 2:
            raise ValueError(f"collide: {item!r} is neither a body name nor a pair of body names")
        for name in pair:
            if name not in ("*", "world") and spec.body(name) is None:
                raise ValueError(f"collide: {name!r} is not a body of the spec"
                                 + naming.spec_hint(spec, name, "body"))  # fmt: skip
        out.add(frozenset(pair))
    return out


def kept(pair, wanted):
    """Whether the body pair ``pair`` is one of ``wanted`` (:func:`pairs`): to keep colliding."""
    a, b = pair
    return frozenset((a, b)) in wanted or frozenset((a, "*")) in wanted or frozenset((b, "*")) in wanted


def pin_length_ranges(spec, rigid) -> tuple[tuple[int, str, tuple[float, float]], ...]:
    """Write into ``spec`` the actuator length ranges that MuJoCo's compiler computed for ``rigid`` (those the file
    leaves to it: ``lengthrange="0 0"``); returns ``(actuator id, name, (low, high))`` of each [m or rad].

    A muscle's force-length curve is scaled by its length range. The compiler finds it by simulating the model, and
    with a body held by an element instead of a joint that simulation need not converge ("Lengthrange computation
    did not converge"); the rigid model's range is the one the muscle was tuned with.
    """
    pinned = []
    for i, act in enumerate(spec.actuators):
        computed = rigid.actuator_lengthrange[i]
        if not np.any(act.lengthrange) and np.any(computed):
            act.lengthrange = computed.tolist()
            pinned.append((i, act.name or f"#{i}", (float(computed[0]), float(computed[1]))))
    return tuple(pinned)


def unpin_length_ranges(spec, pinned) -> None:
    """Leave the ranges :func:`pin_length_ranges` wrote (and not changed since) to the compiler again."""
    for i, _, value in pinned:
        if i < len(spec.actuators) and np.array_equal(spec.actuators[i].lengthrange, value):
            spec.actuators[i].lengthrange = [0.0, 0.0]

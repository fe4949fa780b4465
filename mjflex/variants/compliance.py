"""A compliant part in an existing model: a welded body given joints and a flexure element, in one call.

:func:`make_compliant` turns the weld between a body and its parent (a robot's hand on its wrist
link, a sensor on its mount) into a visco-elastic element: it gives the body the degrees of
freedom the element acts on, with clean joint settings, adds the element at a site (or a pose in
the parent's frame) through :func:`mjflex.add_flexure`, restores the contact filtering that the
weld implied, keeps the keyframes valid and reports all of it in a :class:`Compliance`.
:func:`make_rigid` undoes it.

Why the contact filtering needs restoring: MuJoCo never collides two bodies of one weld group,
nor a weld group with its parent group. Joints under a body split it from its parent's group, so
the body now collides with its grandparent and with the parent's other jointed children (a
gripper's mount with the link before the wrist, which it touches in every pose of a real arm).
Those pairs get ``<exclude>`` elements, except the ones the user asks to keep (``collide``).
"""

import dataclasses
import warnings
from dataclasses import dataclass, field

import mujoco
import numpy as np

from ..analysis.damping import DIRECTIONS, checked_ratios, damping_from_ratios
from ..mjcf import joints as joint_replacement
from ..mjcf import keyframes, naming
from ..mjcf.build import add_flexure, joints_checked, remove_flexure
from ..mjcf.elements import element_record, spec_elements, write_record
from ..mjcf.keyframes import KeyframeEdit
from ..mjcf.spec import compile_spec, quaternion_from_rotation, rotation_from_quaternion, unit_quaternion
from ..mjcf.stops import Stops
from ..runtime import contacts
from ..runtime.flexures import Flexures

_GROUPS = {"all": DIRECTIONS, "rotations": DIRECTIONS[:3], "translations": DIRECTIONS[3:]}
_SLIDE, _HINGE, _BALL = mujoco.mjtJoint.mjJNT_SLIDE, mujoco.mjtJoint.mjJNT_HINGE, mujoco.mjtJoint.mjJNT_BALL
#: Joint attributes reset to MuJoCo's built-in defaults on the joints added (a body's ``childclass``
#: or the model's ``<default>`` would otherwise give them armature, ranges, damping, springs...).
_CLEAN = ("actfrclimited", "actfrcrange", "actgravcomp", "armature", "damping", "frictionloss", "group", "limited",
          "margin", "range", "ref", "solimp_friction", "solimp_limit", "solref_friction", "solref_limit",
          "springdamper", "springref", "springyield", "stiffness")  # fmt: skip


@dataclass
class Compliance:
    """What :func:`make_compliant` did to a spec (all names as in the spec).

    Attributes
    ----------
    element : str
        The flexure element's name (sites ``element/a``, ``element/b``; record ``mjflex:element``).
    body, parent : str
        The body made compliant and the body it is now joined to (``"world"`` possible).
    directions : tuple of str
        The element directions the body may move in, of ``("rx", "ry", "rz", "x", "y", "z")``
        (rotations about and translations along the element frame's axes).
    joints : tuple of str
        The joints added to the body, in order: slides, then a ball (three rotations) or hinges.
    frame : str or tuple
        The site that gives the element frame, or ``(pos, quat)`` of the frame in the parent's frame.
    K, B : ndarray, shape (6, 6)
        The element's stiffness and damping (None without damping), element frame.
    damping_ratio : ndarray, shape (6,), or None
        The ratios ``B`` was computed from (:func:`mjflex.damping_from_ratios`), per direction.
    excludes : tuple of (str, str)
        The ``<exclude>`` body pairs added: the pairs the weld had filtered.
    kept : tuple of (str, str)
        Pairs the weld had filtered that were left colliding (``collide``).
    keyframes : tuple of KeyframeEdit
        The values inserted into each keyframe: the new joints' rest values, or with
        ``replace_joints`` the values that put the body where the keyframe had it.
    replaced : Replacement or None
        With ``replace_joints``: the joints removed, the stops their ranges give (``lower``,
        ``upper``), the equalities, actuators and sensors changed (``edits``) and what was not
        carried (``notes``); :mod:`mjflex.mjcf.joints`. None otherwise.

    Examples
    --------
    >>> import mujoco
    >>> import mjflex
    >>> spec = mujoco.MjSpec.from_string(
    ...     '<mujoco><worldbody><body name="link" pos="0 0 0.5"><joint name="shoulder" axis="0 1 0"/>'
    ...     '<geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02"/>'
    ...     '<site name="flange" pos="0.3 0 0" quat="0.7071068 0 0.7071068 0"/>'
    ...     '<body name="tool" pos="0.3 0 0"><geom type="box" pos="0.05 0 0" size="0.05 0.02 0.02"/></body>'
    ...     "</body></worldbody></mujoco>"
    ... )
    >>> compliance = mjflex.make_compliant(spec, "tool", K=[50, 30], directions=("ry", "rz"), site="flange")
    >>> compliance.element, compliance.joints, compliance.parent
    ('tool_compliance', ('tool_compliance/ry', 'tool_compliance/rz'), 'link')
    """

    element: str
    body: str
    parent: str
    directions: tuple[str, ...]
    joints: tuple[str, ...]
    frame: object
    K: np.ndarray
    B: np.ndarray | None
    damping_ratio: np.ndarray | None
    excludes: tuple[tuple[str, str], ...] = ()
    kept: tuple[tuple[str, str], ...] = ()
    keyframes: tuple[KeyframeEdit, ...] = field(default_factory=tuple)
    replaced: "joint_replacement.Replacement | None" = None

    def __repr__(self):
        replaced = ""
        if self.replaced is not None:
            r = self.replaced
            replaced = (f", replaced={list(r.joints)} (stops: {'yes' if r.has_stops else 'none'}, "
                        f"{len(r.edits)} edits, {len(r.notes)} notes)")  # fmt: skip
        return (
            f"Compliance(body={self.body!r} on {self.parent!r}, element={self.element!r}, "
            f"directions={''.join(f'{d} ' for d in self.directions).strip()!r}, joints={list(self.joints)}, "
            f"excludes={list(self.excludes)}, kept={list(self.kept)}, keyframes edited={len(self.keyframes)}"
            f"{replaced})"
        )


def _directions(directions) -> tuple[str, ...]:
    if isinstance(directions, str):
        directions = _GROUPS.get(directions, (directions,))
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


def _matrix6(value, directions, what):
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


def _find_body(spec, body):
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


def _check_body(spec, body, replace_joints=False):
    joints = [j.name or f"#{i}" for i, j in enumerate(body.joints)]
    if joints and not replace_joints:
        raise ValueError(
            f"body {body.name!r} already has joints ({', '.join(joints)}): make_compliant turns the weld between a "
            "body and its parent into an element, and a joint's motion would deflect the element. Pass "
            "replace_joints=True to replace these joints by the element (their ranges become its stops, equalities "
            "and actuators that name them are carried over), make a welded body compliant (e.g. the hand rather than "
            "the wrist link), or add a body between the joint and the part"
        )
    if body.mocap:
        raise ValueError(f"body {body.name!r} is a mocap body, which cannot have joints; make a child of it compliant")


def _frame_argument(frame, pos, quat):
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


def _frame_pose(spec, model, data, body, parent, frame):
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


def _element_pose(spec, model, body, parent, site, pos, quat, frame=None):
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
    R_WF, p_WF = _frame_pose(spec, model, data, body, parent, frame)
    p = np.zeros(3) if pos is None else np.asarray(pos, dtype=float)
    q = unit_quaternion((1.0, 0.0, 0.0, 0.0) if quat is None else quat, "quat")
    if p.shape != (3,) or not np.isfinite(p).all():
        raise ValueError(f"pos must be 3 finite numbers (the element origin in frame {frame!r}); got {pos!r}")
    p_WE, R_WE = p_WF + R_WF @ p, R_WF @ rotation_from_quaternion(q)
    j = 0 if parent.name in ("", "world") else mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, parent.name)
    R_WP, p_WP = data.xmat[j].reshape(3, 3), data.xpos[j]
    p_PE, q_PE = R_WP.T @ (p_WE - p_WP), quaternion_from_rotation(R_WP.T @ R_WE)
    return p_WE, R_WE, (tuple(p_PE.tolist()), tuple(q_PE.tolist()))


def _add_joints(body, element, directions, R_BE, p_BE, attributes):
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
        for attr in _CLEAN:
            if hasattr(blank, attr):
                setattr(joint, attr, getattr(blank, attr))
        for attr, value in attributes.items():
            setattr(joint, attr, value)
    return added


def _joint_attributes(attributes):
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


def _pairs(spec, collide):
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


def _kept(pair, wanted):
    a, b = pair
    return frozenset((a, b)) in wanted or frozenset((a, "*")) in wanted or frozenset((b, "*")) in wanted


def make_compliant(spec, body, K, *, B=None, damping_ratio=None, site=None, pos=None, quat=None, frame=None,
                   directions="all", name=None, method="twist", collide=(), joint_attributes=None, keyframe=None,
                   others="locked", actuator_stiffness=False, constraints="ignore", kind="plugin",
                   replace_joints=False, equalities="auto", stops=None, strict=False) -> Compliance:  # fmt: skip
    """Make a body of ``spec`` compliant relative to its parent, in place: its weld, or its joints with
    ``replace_joints=True``, become a flexure element; returns what was done.

    The body (a robot's hand, a sensor, a tool, a vertebra; any body of any model, attached or
    not) gets the degrees of freedom of the chosen ``directions`` of the element frame (three
    slides and a ball joint for all six), with MuJoCo's built-in joint settings whatever the
    body's ``childclass`` or the model's defaults say (no armature, range, damping, friction loss
    or spring unless ``joint_attributes`` asks), and a flexure element between it and its parent,
    written by :func:`mjflex.add_flexure` (of the form ``kind``: a plugin instance by default).
    The body pairs that MuJoCo filtered in the rigid model and would collide now (the body with
    its grandparent's weld group, and so on; :mod:`mjflex.runtime.contacts`) get ``<exclude>``
    elements, except those in ``collide``; every keyframe gets the new joints' rest values (zero
    deflection) at their qpos and qvel addresses. A kept pair that touches at ``qpos0`` or a
    keyframe is reported by a warning.

    With ``replace_joints=True`` the body's joints (to its parent) are handed to the element
    instead of refused (:mod:`mjflex.mjcf.joints` has the rules): they lose their joint model
    (range, spring, damper, armature, friction loss) and stay as the element's coordinates, with
    their names, axes and anchors, so the actuators, sensors, tendons and keyframes that name them
    keep their meaning exactly; the body gets joints for the element directions they do not cover
    (slides, hinges about the element axes). Their ranges become the element's stops
    (:class:`mjflex.Stops`, with the derived stiffness; also in ``Compliance.replaced.lower`` /
    ``upper``); an equality that drives a replaced joint is removed (the element determines that
    motion now), one a replaced joint drives is kept (``equalities``); limit sensors are removed.
    Without ``site`` or ``pos``, the element frame is the joints' own: the anchor of the first
    hinge (or ball), axes along the hinge and slide axes. :func:`make_rigid` puts it all back.

    Parameters
    ----------
    spec : mujoco.MjSpec
        The model; it must compile before and after.
    body : str or mujoco.MjsBody
        The body to make compliant: welded to its parent (no joints, unless ``replace_joints``),
        not the world. Names are the spec's, prefixes of ``MjSpec.attach`` included
        (``"left/hand"``).
    K : array_like, shape (6, 6) or (6,), or (n, n) / (n,) for n directions
        Stiffness in the element frame, rows ``[rx, ry, rz, x, y, z]`` (N m/rad, N/m); a vector
        is the diagonal (:mod:`mjflex.units` converts N m/deg and N/mm). Given for the chosen
        directions only, it is zero in the others (which the joints do not move).
    B : array_like, optional
        Damping, same layout as ``K``. Or:
    damping_ratio : float or array_like, optional
        Damping ratios (fractions of critical: 0.01 is 1 %), one for all or one per chosen
        direction: ``B`` is computed by :func:`mjflex.damping_from_ratios` at ``keyframe`` with
        ``others``, ``actuator_stiffness`` and ``constraints`` (default: the other joints locked,
        i.e. the inertia of the body and all it carries about the element frame). A ratio above 1
        (overdamped; ``10`` meant as 10 % is ``0.1``) is warned about, or refused under ``strict``.
    site : str or mujoco.MjsSite, optional
        A site of the body or of its parent whose frame is the element frame (e.g. a robot's
        ``"attachment_site"``). Or:
    pos, quat : array_like, optional
        The element frame's origin [m] and orientation (w-first) in the frame ``frame``. Default
        (neither site nor pose): the body's own frame, or the replaced joints' frame.
    frame : str or mujoco.MjsBody, optional
        What ``pos``/``quat`` are given in: ``"parent"`` (the body's parent), ``"body"``,
        ``"world"`` or any body of the spec (its frame at ``qpos0``). Without it, ``pos``/``quat``
        are read in the parent's frame with a FutureWarning: a future release reads them in the
        world frame, as :func:`mjflex.add_flexure` does.
    directions : str or sequence of str
        ``"all"`` (default), ``"rotations"``, ``"translations"`` or names of
        ``("rx", "ry", "rz", "x", "y", "z")``: the element-frame directions the body may move in.
    name : str, optional
        Element name (default ``body + "_compliance"``); joints are ``name/x``, ``name/ball``, ...
    method : {"twist", "dualquat"}
        The element's displacement measure.
    collide : iterable
        Body pairs ``(body1, body2)`` (or single body names: all their pairs) to keep colliding
        although the weld had filtered them.
    joint_attributes : dict, optional
        Attributes set on every added joint (e.g. ``{"armature": 1e-4}``).
    keyframe, others, actuator_stiffness, constraints
        The linearization used for ``damping_ratio`` (:func:`mjflex.damping_from_ratios`).
    kind : {"plugin", "record"}
        How the element is written (:func:`mjflex.add_flexure`): an ``mjflex.flexure`` plugin
        instance (default; the model runs in any MuJoCo program) or a text record.
    replace_joints : bool
        Replace the body's joints by the element (see above) instead of refusing a body with
        joints.
    equalities : {"auto", "remove", "refuse"}
        What happens to joint equality constraints that name a replaced joint (with
        ``replace_joints``): ``"auto"`` removes those that drive a replaced joint (``joint1``)
        and keeps those in which it drives another (``joint2``); ``"remove"`` removes them all;
        ``"refuse"`` refuses (ValueError naming them).
    stops : Stops or bool, optional
        The element's end stops (:class:`mjflex.Stops`). Default (None): with ``replace_joints``,
        the replaced joints' ranges (where they have any), without it none; False: none.
    strict : bool
        Refuse (ValueError) what is only warned about otherwise: a damping ratio above 1.

    Returns
    -------
    Compliance
        Its joints, element, excludes and keyframe edits, and with ``replace_joints`` what was
        replaced (``replaced``); :func:`make_rigid` takes it to undo.

    Raises
    ------
    ValueError
        The world or an unknown body (with close names), a body with joints (without
        ``replace_joints``) or a mocap body, a site of another body, no direction, a ratio <= 0
        or NaN, both ``B`` and ``damping_ratio``, a name taken; with ``replace_joints``, an
        equality under ``equalities="refuse"`` (named, with the choices). The spec is left as it
        was.

    Examples
    --------
    A tool on an arm's flange: six degrees of freedom relative to the arm's link (three slides and a ball joint),
    the element at the flange site, 2 % damping in each of its modes:

    >>> import mujoco
    >>> import mjflex
    >>> spec = mujoco.MjSpec.from_string(
    ...     '<mujoco><worldbody><body name="link" pos="0 0 0.5"><joint name="shoulder" axis="0 1 0"/>'
    ...     '<geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02"/>'
    ...     '<site name="flange" pos="0.3 0 0" quat="0.7071068 0 0.7071068 0"/>'
    ...     '<body name="tool" pos="0.3 0 0"><geom type="box" pos="0.05 0 0" size="0.05 0.02 0.02"/></body>'
    ...     "</body></worldbody></mujoco>"
    ... )
    >>> compliance = mjflex.make_compliant(
    ...     spec, "tool", K=[50, 50, 30, 1e5, 1e5, 1e5], site="flange", damping_ratio=0.02
    ... )
    >>> compliance.joints
    ('tool_compliance/x', 'tool_compliance/y', 'tool_compliance/z', 'tool_compliance/ball')
    >>> model = spec.compile()
    >>> model.nq, model.nv  # the shoulder, three slides and a ball joint
    (8, 7)
    >>> mjflex.Flexures(model)
    Flexures(1 elements: tool_compliance)
    """
    target = _find_body(spec, body)
    _check_body(spec, target, replace_joints)
    parent = target.parent
    dirs = _directions(directions)
    name = name or f"{target.name}_compliance"
    K6 = _matrix6(K, dirs, "K")
    if B is not None and damping_ratio is not None:
        raise ValueError("give B or damping_ratio, not both")
    B6 = None if B is None else _matrix6(B, dirs, "B")
    ratios = None
    if damping_ratio is not None:
        given = checked_ratios(damping_ratio, len(dirs) if np.ndim(damping_ratio) else 1, strict=strict, stacklevel=3)
        ratios = np.full(6, given.mean())
        ratios[[DIRECTIONS.index(d) for d in dirs]] = given if given.size == len(dirs) else given[0]
    wanted = _pairs(spec, collide)
    joint_attributes = _joint_attributes(joint_attributes)
    taken = [j for j in (f"{name}/{d}" for d in (*DIRECTIONS, "ball")) if spec.joint(j) is not None]
    if taken:
        raise ValueError(f"joint(s) {taken} exist already: pick another name= for the element")
    rigid = compile_spec(spec, "make a body compliant")
    plan = (
        joint_replacement.make_plan(spec, rigid, target, equalities) if replace_joints and len(target.joints) else None
    )
    frame = _frame_argument(frame, pos, quat) if site is None else frame
    if plan is not None and site is None and pos is None and quat is None:
        p_WE, R_WE = joint_replacement.joint_frame(rigid, target.name)  # the joints' anchor and axes
        pos, quat, frame = p_WE, quaternion_from_rotation(R_WE), "world"
    p_WE, R_WE, frame = _element_pose(spec, rigid, target, parent, site, pos, quat, frame)
    data = mujoco.MjData(rigid)
    mujoco.mj_kinematics(rigid, data)
    ib = mujoco.mj_name2id(rigid, mujoco.mjtObj.mjOBJ_BODY, target.name)
    R_WB, p_WB = data.xmat[ib].reshape(3, 3), data.xpos[ib]
    R_BE = R_WB.T @ R_WE
    ranges = joint_replacement.stops_from_ranges(rigid, plan.joints, R_BE) if plan is not None else None
    stops = _element_stops(stops, ranges)
    added = joint_replacement.missing_directions(rigid, target.name, R_BE, dirs) if plan is not None else dirs
    saved, joints, excludes, element, replacement = keyframes.stash_keys(spec), [], [], None, None
    try:
        if plan is not None:
            replacement = joint_replacement.apply(spec, plan, rigid, ranges)
        joints = _add_joints(target, name, added, R_BE, R_WB.T @ (p_WE - p_WB), joint_attributes)
        place = {"site": frame} if isinstance(frame, str) else {"pos": p_WE, "quat": quaternion_from_rotation(R_WE)}
        parent_name = "world" if parent.name in ("", "world") else parent.name
        with joints_checked(False):  # the element replaces the weld (or the joints): not in parallel with them
            add_flexure(spec, name, parent_name, target.name, K=K6, B=B6, method=method, exclude_contact=False,
                        kind=kind, stops=stops, **place)  # fmt: skip
        element = name
        compliant = compile_spec(spec, "make a body compliant")
        exposed = [tuple(contacts.body_name(compliant, b) for b in p) for p in contacts.exposed_pairs(rigid, compliant)]
        for pair in exposed:
            unnamed = [b for b in pair if b.startswith("#")]
            if unnamed and not _kept(pair, wanted):
                raise ValueError(
                    f"body {unnamed[0]} (an id) has no name, and its contacts with {pair} must be excluded once "
                    f"{target.name!r} has joints; name it in the model, or keep the pair with collide="
                )
            if not _kept(pair, wanted):
                excludes.append(spec.add_exclude(bodyname1=pair[0], bodyname2=pair[1]))
        edits = keyframes.grow_keys(spec, saved, compliant, [j.name for j in joints], rigid.nq, rigid.nv)
        if ratios is not None:
            B6 = _damping(spec, name, ratios, keyframe, others, actuator_stiffness, constraints)
            write_record(spec, name, dataclasses.replace(element_record(spec, name), B=B6))
        _warn_kept(spec, name)
    except BaseException:
        keyframes.stash_keys(spec)  # MjSpec checks the keyframes' sizes when joints go
        for obj in (*excludes, *joints):
            spec.delete(obj)
        if replacement is not None:
            joint_replacement.undo(spec, replacement)
        if element is not None and any(e.name == element for e in spec_elements(spec)):
            remove_flexure(spec, element)
        keyframes.restore_keys(spec, saved)
        raise
    kept = tuple(p for p in exposed if _kept(p, wanted))
    return Compliance(name, target.name, parent_name, dirs, tuple(j.name for j in joints), frame, K6, B6, ratios,
                      tuple((e.bodyname1, e.bodyname2) for e in excludes), kept, edits, replacement)  # fmt: skip


def _element_stops(stops, ranges):
    """The ``stops=`` for the element: the user's, none (False), or the replaced joints' ranges (None)."""
    if stops is False:
        return None
    if stops is None:
        if ranges is None or not (np.isfinite(ranges[0]).any() or np.isfinite(ranges[1]).any()):
            return None
        return Stops(lower=ranges[0].tolist(), upper=ranges[1].tolist())
    if not isinstance(stops, Stops):
        raise TypeError(f"stops must be a mjflex.Stops, False (none) or None (the replaced joints' ranges); got "
                        f"{type(stops).__name__}")  # fmt: skip
    return stops


def _damping(spec, name, ratios, keyframe, others, actuator_stiffness, constraints):
    model = compile_spec(spec, "compute the damping from ratios")
    with warnings.catch_warnings():  # contacts are reported once, by _warn_kept; the ratios were checked
        warnings.simplefilter("ignore")
        flex = Flexures(model)
        return damping_from_ratios(model, name, ratios, flex=flex, keyframe=keyframe, others=others,
                                   actuator_stiffness=actuator_stiffness, constraints=constraints)  # fmt: skip


def _warn_kept(spec, name):
    """Validate the new element as :class:`Flexures` reads it, and pass on its contact warnings once."""
    model = compile_spec(spec, "make a body compliant")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        Flexures(model)
    for w in caught:
        if name in str(w.message):
            warnings.warn(str(w.message), w.category, stacklevel=4)


def make_rigid(spec, compliance: Compliance) -> None:
    """Undo :func:`make_compliant` on ``spec``, in place: back to the rigid body.

    Removes the joints, the element and the ``<exclude>`` elements it added, and the values it
    inserted into the keyframes (at the addresses the joints have now, so keyframes edited or
    added since keep their other values). The compiled model then has the rigid model's sizes,
    body poses and keyframes.

    Parameters
    ----------
    spec : mujoco.MjSpec
        The spec :func:`make_compliant` edited, edited again in place.
    compliance : Compliance
        What :func:`make_compliant` returned.

    Examples
    --------
    >>> import mujoco
    >>> import mjflex
    >>> spec = mujoco.MjSpec.from_string(
    ...     '<mujoco><worldbody><body name="link" pos="0 0 0.5"><joint name="shoulder" axis="0 1 0"/>'
    ...     '<geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02"/>'
    ...     '<site name="flange" pos="0.3 0 0" quat="0.7071068 0 0.7071068 0"/>'
    ...     '<body name="tool" pos="0.3 0 0"><geom type="box" pos="0.05 0 0" size="0.05 0.02 0.02"/></body>'
    ...     "</body></worldbody></mujoco>"
    ... )
    >>> compliance = mjflex.make_compliant(spec, "tool", K=[50, 50, 30, 1e5, 1e5, 1e5], site="flange")
    >>> spec.compile().nq
    8
    >>> mjflex.make_rigid(spec, compliance)
    >>> spec.compile().nq  # the shoulder alone, as before
    1
    """
    if not isinstance(compliance, Compliance):
        raise TypeError(f"make_rigid expects the Compliance that make_compliant returned; got {type(compliance)}")
    missing = [j for j in compliance.joints if spec.joint(j) is None]
    if missing:
        raise ValueError(f"the spec has no joint(s) {missing} of {compliance.element!r}: is it compliant (the same "
                         "spec make_compliant edited), or was make_rigid called already?")  # fmt: skip
    model = compile_spec(spec, "make a body rigid again")
    qadr, vadr = keyframes.addresses(model, compliance.joints)
    shrunk = [
        (
            np.delete(qpos, qadr) if qpos.size == model.nq else qpos,
            np.delete(qvel, vadr) if qvel.size == model.nv else qvel,
        )
        for qpos, qvel in keyframes.stash_keys(spec)  # emptied while the joints go (MjSpec checks the keyframes' sizes)
    ]
    for j in compliance.joints:
        spec.delete(spec.joint(j))
    if compliance.replaced is not None:
        joint_replacement.undo(spec, compliance.replaced)
    keyframes.restore_keys(spec, shrunk)
    remove_flexure(spec, compliance.element)
    _delete_excludes(spec, compliance.excludes)


def _delete_excludes(spec, pairs):
    added = {frozenset(p) for p in pairs}
    for e in list(spec.excludes):
        if frozenset((e.bodyname1, e.bodyname2)) in added:
            added.discard(frozenset((e.bodyname1, e.bodyname2)))
            spec.delete(e)

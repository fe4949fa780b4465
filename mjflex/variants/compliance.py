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
from ..core.rest import rest_pose
from ..core.stops import stop_coordinates
from ..mjcf import coordinates, keyframes
from ..mjcf import joints as joint_replacement
from ..mjcf.build import add_flexure, joints_checked, remove_flexure
from ..mjcf.elements import element_record, spec_elements, write_record
from ..mjcf.keyframes import KeyframeEdit
from ..mjcf.spec import compile_spec, quaternion_from_rotation
from ..mjcf.stops import Stops
from ..runtime import contacts
from ..runtime.flexures import Flexures
from . import placement
from .closures import Closure, closures

#: The ``stops=`` kinds for replaced joints: MuJoCo's joint limits kept (the default), or the element's stops.
STOP_KINDS = joint_replacement.STOP_KINDS


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
        (rotations about and translations along the element frame's axes); with kept joints
        (``replace_joints=[...]``) those they move are not the element's.
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
        With ``replace_joints``: the joints replaced and kept, what became of their ranges
        (``stops``: MuJoCo's limits kept, or the element's stops ``lower``, ``upper``), the
        equalities, actuators and sensors changed (``edits``) and what was not carried
        (``notes``); :mod:`mjflex.mjcf.joints`. None otherwise.
    closures : tuple of Closure
        Each equality constraint's violation at the operating pose (``keyframe``, at rest) in the
        rigid and in the compliant model (:mod:`mjflex.variants.closures`); one that opens more
        than 10 times is warned about. Empty when the model has no equality.
    closure_note : str or None
        Why the closures were not measured (a model with no rest at the operating pose).
    rest : tuple (pos, quat) or None
        The element's rest pose (frame b in frame a; m, w-first quaternion): given (``rest=``),
        or where the replaced joints' springs rested (their ``springref``); None: the compiled pose.
    lengthranges : tuple of (int, str, (float, float))
        The actuators (id, name) whose length range [m or rad] MuJoCo's compiler computed for the
        rigid model, now written into the spec: its simulation need not converge with the body
        held by an element, and muscles keep the range they were tuned with. :func:`make_rigid`
        leaves them to the compiler again.

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
    closures: tuple[Closure, ...] = ()
    closure_note: str | None = None
    rest: tuple | None = None
    lengthranges: tuple = ()

    def __repr__(self):
        replaced = ""
        if self.replaced is not None:
            r = self.replaced
            kept = f", kept={list(r.kept)}" if r.kept else ""
            replaced = (f", replaced={list(r.joints)}{kept} (stops: {r.stops}, {len(r.edits)} edits, "
                        f"{len(r.notes)} notes)")  # fmt: skip
        if self.closures:
            opened = sorted({c.equality for c in self.closures if c.opened})
            replaced += f", closures: {len(self.closures)} ({'opened: ' + ', '.join(opened) if opened else 'held'})"
        return (
            f"Compliance(body={self.body!r} on {self.parent!r}, element={self.element!r}, "
            f"directions={''.join(f'{d} ' for d in self.directions).strip()!r}, joints={list(self.joints)}, "
            f"excludes={list(self.excludes)}, kept={list(self.kept)}, keyframes edited={len(self.keyframes)}"
            f"{replaced})"
        )


def make_compliant(spec, body, K, *, B=None, damping_ratio=None, site=None, pos=None, quat=None, frame=None,
                   directions="all", name=None, method="twist", collide=(), joint_attributes=None, keyframe=None,
                   others="locked", actuator_stiffness=False, constraints="ignore", kind="plugin",
                   replace_joints=False, equalities="auto", stops=None, rest=None,
                   strict=False) -> Compliance:  # fmt: skip
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
    instead of refused (:mod:`mjflex.mjcf.joints` has the rules): they lose their spring, damper
    and friction loss and stay as the element's coordinates, with their names, axes, anchors and
    armature, so the actuators, sensors, tendons and keyframes that name them keep their meaning
    exactly; the body gets joints for the element directions they do not cover (slides, hinges
    about the element axes). Their ranges stay MuJoCo's joint limits by default
    (``stops="limits"``); ``stops="element"`` makes them the element's stops. An equality that
    drives a replaced joint is removed (the element determines that motion now), one a replaced
    joint drives is kept (``equalities``). ``replace_joints=["name", ...]`` replaces some of the
    body's joints and keeps the others as joints (the element leaves their directions alone).
    Without ``site`` or ``pos``, the element frame is the replaced joints' own: the anchor of the
    first hinge (or ball); one hinge's axis is the element's z, the compliant axis of
    :mod:`mjflex.geometry`'s hinges (several hinges: the body's axes where the joints lie along
    them; :mod:`mjflex.mjcf.coordinates` has the rule), and a ``K`` that is not softest about a
    lone replaced hinge is warned about. :func:`make_rigid` puts it all back.

    The report gives the closures of the model's equality constraints at the operating pose
    (``keyframe`` at rest) before and after (``Compliance.closures``), and warns when one opens
    more than 10 times further: a soft ``solref`` scales with the effective mass at the
    constraint, which added joints change.

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
        The linearization used for ``damping_ratio`` (:func:`mjflex.damping_from_ratios`);
        ``keyframe`` is also the operating pose of the closure report (its controls, at rest).
    kind : {"plugin", "record"}
        How the element is written (:func:`mjflex.add_flexure`): an ``mjflex.flexure`` plugin
        instance (default; the model runs in any MuJoCo program) or a text record.
    replace_joints : bool, str or list of str
        Replace the body's joints by the element (True: all of them; names: those, the others
        stay joints) instead of refusing a body with joints.
    equalities : {"auto", "remove", "refuse"}
        What happens to joint equality constraints that name a replaced joint (with
        ``replace_joints``): ``"auto"`` removes those that drive a replaced joint (``joint1``)
        and keeps those in which it drives another (``joint2``); ``"remove"`` removes them all;
        ``"refuse"`` refuses (ValueError naming them).
    stops : {"limits", "element"}, dict, Stops or False, optional
        What stops the motion. Default (None): with ``replace_joints``, ``"limits"``; without it,
        none. ``"limits"``: the replaced joints keep MuJoCo's joint limits (range, ``solref``,
        ``solimp``, margin: constraints, dissipative and stable at the file's time step, exactly
        as the rigid model stops). ``"element"``: their ranges become the element's stops
        (:class:`mjflex.Stops` with the derived stiffness, in element coordinates: explicit
        forces, in the element's energy, which need a short enough step); a dict of
        :class:`mjflex.Stops`' other arguments (``{"stiffness": 500}``) gives them to those
        stops. A :class:`mjflex.Stops`: those element stops (the replaced joints' limits go).
        False: none.
        ``"limits"`` and ``"element"`` need replaced joints.
    rest : tuple (pos, quat) or False, optional
        The element's rest pose: the pose of frame b in frame a at which its energy is zero
        (:func:`mjflex.add_flexure`; m, w-first unit quaternion). Default (None): with
        ``replace_joints``, where the replaced joints' springs rested (their ``springref``, for
        joints with a stiffness), so that the element keeps their preload; else the compiled
        pose. False: the compiled pose. Element stops made from the ranges count from it.
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
        or NaN, both ``B`` and ``damping_ratio``, a name taken, an element that already joins the
        body to its parent (make_rigid it first; :func:`mjflex.add_flexure` adds one in parallel
        on purpose), a stop kind without replaced joints; with ``replace_joints``, a name that is
        not a joint of the body, redundant joints that would give the body more than six degrees
        of freedom (named), a kept joint off the element axes or with stiffness in ``K``, an
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
    target = placement.find_body(spec, body)
    placement.check_body(spec, target, replace_joints)
    _refuse_second_element(spec, target)
    parent = target.parent
    name = name or f"{target.name}_compliance"
    if B is not None and damping_ratio is not None:
        raise ValueError("give B or damping_ratio, not both")
    wanted = placement.pairs(spec, collide)
    joint_attributes = placement.joint_attributes(joint_attributes)
    taken = [j for j in (f"{name}/{d}" for d in (*DIRECTIONS, "ball")) if spec.joint(j) is not None]
    if taken:
        raise ValueError(f"joint(s) {taken} exist already: pick another name= for the element")
    rigid = compile_spec(spec, "make a body compliant")
    replaced, kept = [], []
    if replace_joints is not False and replace_joints is not None:
        replaced, kept = coordinates.replaced_and_kept(rigid, target.name, replace_joints)
    stop_kind, given = _stop_kind(stops, replaced, target.name)
    plan = None
    if replaced:
        plan = joint_replacement.make_plan(spec, rigid, target, replaced, equalities, keep_limits=stop_kind == "limits")
    frame = placement.frame_argument(frame, pos, quat) if site is None else frame
    if plan is not None and site is None and pos is None and quat is None:
        p_WE, R_WE = coordinates.joint_frame(rigid, target.name, [j for _, j in replaced])
        pos, quat, frame = p_WE, quaternion_from_rotation(R_WE), "world"
    p_WE, R_WE, frame = placement.element_pose(spec, rigid, target, parent, site, pos, quat, frame)
    data = mujoco.MjData(rigid)
    mujoco.mj_kinematics(rigid, data)
    ib = mujoco.mj_name2id(rigid, mujoco.mjtObj.mjOBJ_BODY, target.name)
    R_WB, p_WB = data.xmat[ib].reshape(3, 3), data.xpos[ib]
    R_BE = R_WB.T @ R_WE
    dirs, K6, B6, ratios = _element_matrices(rigid, target.name, kept, R_BE, directions, K, B, damping_ratio, strict)
    ranges = coordinates.stops_from_ranges(rigid, replaced, R_BE) if plan is not None else None
    p_BE = R_WB.T @ (p_WE - p_WB)
    rest_pose = _rest_pose(rest, rigid, target.name, replaced, R_BE, p_BE, name)
    element_stops = _element_stops(stop_kind, given, ranges, rest_pose)
    added = coordinates.missing_directions(rigid, target.name, R_BE, dirs) if plan is not None else dirs
    if plan is not None:
        too_many = coordinates.too_many_dofs(rigid, target.name, added)
        if too_many:
            raise ValueError(too_many)
        coordinates.axis_mismatch(rigid, name, replaced, R_BE, K6, dirs, stacklevel=2)
    saved, joints, excludes, element, replacement = keyframes.stash_keys(spec), [], [], None, None
    pinned = placement.pin_length_ranges(spec, rigid)
    try:
        if plan is not None:
            limited = any(rigid.jnt_limited[j] for _, j in replaced)
            kind_done = stop_kind if stop_kind in ("given", "none") or limited else "none"
            kind_done = "none" if kind_done == "element" and element_stops is None else kind_done
            notes = ranges[2] if stop_kind == "element" else []
            carried = rest is None and rest_pose is not None
            replacement = joint_replacement.apply(spec, plan, rigid, (ranges[0], ranges[1], notes), kind_done,
                                                  [n for n, _ in kept], springs_carried=carried)  # fmt: skip
        joints = placement.add_joints(target, name, added, R_BE, p_BE, joint_attributes)
        place = {"site": frame} if isinstance(frame, str) else {"pos": p_WE, "quat": quaternion_from_rotation(R_WE)}
        parent_name = "world" if parent.name in ("", "world") else parent.name
        with joints_checked(False):  # the element replaces the weld (or the joints): not in parallel with them
            add_flexure(spec, name, parent_name, target.name, K=K6, B=B6, method=method, exclude_contact=False,
                        kind=kind, stops=element_stops, rest=rest_pose, **place)  # fmt: skip
        element = name
        compliant = compile_spec(spec, "make a body compliant")
        exposed = [tuple(contacts.body_name(compliant, b) for b in p) for p in contacts.exposed_pairs(rigid, compliant)]
        for pair in exposed:
            unnamed = [b for b in pair if b.startswith("#")]
            if unnamed and not placement.kept(pair, wanted):
                raise ValueError(
                    f"body {unnamed[0]} (an id) has no name, and its contacts with {pair} must be excluded once "
                    f"{target.name!r} has joints; name it in the model, or keep the pair with collide="
                )
            if not placement.kept(pair, wanted):
                excludes.append(spec.add_exclude(bodyname1=pair[0], bodyname2=pair[1]))
        edits = keyframes.grow_keys(spec, saved, compliant, [j.name for j in joints], rigid.nq, rigid.nv)
        if ratios is not None:
            model = compile_spec(spec, "compute the damping from ratios")
            with warnings.catch_warnings():  # contacts are reported once, by _warn_kept; the ratios were checked
                warnings.simplefilter("ignore")
                B6 = damping_from_ratios(model, name, ratios, flex=Flexures(model), keyframe=keyframe, others=others,
                                         actuator_stiffness=actuator_stiffness, constraints=constraints)  # fmt: skip
            write_record(spec, name, dataclasses.replace(element_record(spec, name), B=B6))
        _warn_kept(spec, name)
        kept_eq = replacement.saved["kept_equalities"] if replacement is not None else list(range(rigid.neq))
        matched = [(i, k) for k, i in enumerate(kept_eq)]  # (rigid id, compliant id)
        closed, note = closures(rigid, compile_spec(spec, "make a body compliant"), matched, keyframe, name)
    except BaseException:
        keyframes.stash_keys(spec)  # MjSpec checks the keyframes' sizes when joints go
        for obj in (*excludes, *joints):
            spec.delete(obj)
        if replacement is not None:
            joint_replacement.undo(spec, replacement)
        if element is not None and any(e.name == element for e in spec_elements(spec)):
            remove_flexure(spec, element)
        keyframes.restore_keys(spec, saved)
        placement.unpin_length_ranges(spec, pinned)
        raise
    return Compliance(name, target.name, parent_name, dirs, tuple(j.name for j in joints), frame, K6, B6, ratios,
                      tuple((e.bodyname1, e.bodyname2) for e in excludes), tuple(p for p in exposed
                      if placement.kept(p, wanted)), edits, replacement, closed, note, rest_pose, pinned)  # fmt: skip


def _refuse_second_element(spec, body):
    """ValueError when an element already joins ``body`` to its parent: make_compliant would add one in parallel."""
    parent = body.parent.name or "world"
    for e in spec_elements(spec):
        sites = [spec.site(s) for s in (e.site_a, e.site_b)]
        if any(s is None for s in sites) or {s.parent.name or "world" for s in sites} != {body.name, parent}:
            continue
        raise ValueError(
            f"body {body.name!r} and its parent {parent!r} are already joined by flexure {e.name!r}: make_compliant "
            "would add a second element in parallel with it. To change that element, undo it first "
            "(mjflex.make_rigid(spec, compliance), or mjflex.remove_flexure) or edit it "
            "(mjflex.mjcf.elements.edit_flexure); to "
            f"add a second one on purpose, use mjflex.add_flexure(spec, name, {parent!r}, {body.name!r}, ...)"
        )


def _stop_kind(stops, replaced, body):
    """``(kind, Stops or None)``: what stops the motion (``"limits"``, ``"element"``, ``"given"`` or ``"none"``)."""
    if stops is None:
        return ("limits" if replaced else "none"), None
    if stops is False:
        return "none", None
    if isinstance(stops, Stops):
        return "given", stops
    if isinstance(stops, dict):
        allowed = {f.name for f in dataclasses.fields(Stops)} - {"lower", "upper"}  # the ranges give the limits
        unknown = sorted(set(stops) - allowed)
        if unknown:
            raise ValueError(
                f"stops={stops!r}: {unknown} are not arguments of mjflex.Stops that make_compliant lets you give (the "
                "ranges come from the replaced joints); give the others, or a mjflex.Stops"
            )
        if not replaced:
            raise ValueError(
                f"stops={stops!r} gives the replaced joints' ranges as element stops, but no joint of body {body!r} is "
                "replaced (replace_joints=...); give a mjflex.Stops(lower=..., upper=...)"
            )
        return "element", stops
    if isinstance(stops, str) and stops in STOP_KINDS:
        if not replaced:
            how = "as MuJoCo's joint limits" if stops == "limits" else "as the element's stops"
            raise ValueError(
                f"stops={stops!r} keeps the replaced joints' ranges {how}, but no joint of body {body!r} is replaced "
                "(replace_joints=...); give the element stops as mjflex.Stops(lower=..., upper=...), or stops=False"
            )
        return stops, None
    raise TypeError(f"stops must be 'limits', 'element', a dict of mjflex.Stops arguments, a mjflex.Stops, False "
                    f"(none) or None (with replace_joints: 'limits'); got {stops!r}")  # fmt: skip


def _element_matrices(rigid, body, kept, R_BE, directions, K, B, damping_ratio, strict):
    """``(directions, K, B, ratios)`` of the element, checked: the kept joints' directions are the element's none."""
    owned = coordinates.kept_directions(rigid, kept, R_BE) if kept else ()
    dirs = placement.directions_named(directions)
    if owned and isinstance(directions, str) and directions in placement.GROUPS:
        dirs = tuple(d for d in dirs if d not in owned)
        if not dirs:
            raise ValueError(f"the kept joints of body {body!r} move it in every direction of directions="
                             f"{directions!r}; the element would act on nothing")  # fmt: skip
    clash = [d for d in dirs if d in owned]
    if clash:
        raise ValueError(
            f"directions {clash} are moved by kept joint(s) {[n for n, _ in kept]} of body {body!r}: the element would "
            "act in parallel with them; leave them out, or replace those joints too"
        )
    K6 = placement.matrix6(K, dirs, "K")
    B6 = None if B is None else placement.matrix6(B, dirs, "B")
    idx = [DIRECTIONS.index(d) for d in owned]
    for what, M in (("K", K6), ("B", B6)):
        if M is not None and idx and (np.any(M[idx, :]) or np.any(M[:, idx])):
            raise ValueError(
                f"{what} is not zero in directions {list(owned)}, which the kept joint(s) {[n for n, _ in kept]} of "
                f"body {body!r} move: the element would act in parallel with them. Give {what} for the element's "
                f"directions {list(dirs)} only, or replace those joints too"
            )
    ratios = None
    if damping_ratio is not None:
        given = checked_ratios(damping_ratio, len(dirs) if np.ndim(damping_ratio) else 1, strict=strict, stacklevel=4)
        ratios = np.full(6, given.mean())
        ratios[[DIRECTIONS.index(d) for d in dirs]] = given if given.size == len(dirs) else given[0]
    return dirs, K6, B6, ratios


def _element_stops(kind, given, ranges, rest=None):
    """The element's :class:`Stops`: the user's, the replaced joints' ranges (``"element"``, with the arguments of
    ``given``, a dict, if any; counted from the rest pose ``rest``), or None."""
    if kind == "given":
        return given
    if kind != "element" or not (np.isfinite(ranges[0]).any() or np.isfinite(ranges[1]).any()):
        return None
    lower, upper = ranges[0].copy(), ranges[1].copy()
    if rest is not None:  # the ranges count from the compiled pose, the stops from the rest pose: where it is seen
        eye = np.eye(3)  # from there (exact along one axis, to second order across axes)
        z0 = stop_coordinates(eye, np.zeros(3), eye, np.zeros(3), rest=rest)
        lower, upper = lower + z0, upper + z0
    return Stops(lower=lower.tolist(), upper=upper.tolist(), **(given or {}))


def _rest_pose(rest, rigid, body, replaced, R_BE, p_BE, name):
    """The element's rest pose: given, none (False), or where the replaced joints' springs rest (None)."""
    if rest is False:
        return None
    if rest is None:
        found = coordinates.rest_from_springs(rigid, body, replaced, R_BE, p_BE) if replaced else None
        return None if found is None else (tuple(found[0].tolist()), tuple(found[1].tolist()))
    rest_pose(rest, f"rest of flexure {name!r}")  # here, not only by C in add_flexure: the stops count from it
    return tuple(float(v) for v in rest[0]), tuple(float(v) for v in rest[1])


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
    body poses and keyframes, array for array.

    Saving: MuJoCo's MjSpec cannot take back the declaration of the engine plugin
    ``mjflex.flexure`` that a plugin element brought, so ``spec.to_xml()`` still names it after
    the last element goes, and a MuJoCo without mjflex refuses that file ("plugin mjflex.flexure
    not found"). Write the rigid model with :func:`mjflex.spec_xml`, which leaves the unused
    declaration out. (The compiled model has no plugin either way.)

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
    if missing or not any(e.name == compliance.element for e in spec_elements(spec)):
        what = f"joint(s) {missing} of {compliance.element!r}" if missing else f"element {compliance.element!r}"
        raise ValueError(f"the spec has no {what}: is it compliant (the same spec make_compliant edited), or was "
                         "make_rigid called already?")  # fmt: skip
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
    added = {frozenset(p) for p in compliance.excludes}
    for e in list(spec.excludes):
        if frozenset((e.bodyname1, e.bodyname2)) in added:
            added.discard(frozenset((e.bodyname1, e.bodyname2)))
            spec.delete(e)
    placement.unpin_length_ranges(spec, compliance.lengthranges)

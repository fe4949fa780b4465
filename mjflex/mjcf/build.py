"""Adding flexure elements to a model with ``mujoco.MjSpec``, and removing them."""

import contextlib
from dataclasses import dataclass

import mujoco
import numpy as np

from ..core import stiffness_in_frame, validation
from ..core.identification import potential_in_frame
from ..core.polynomial import PolynomialTerms
from . import naming, schema
from .coordinates import DOFS
from .elements import add_plugin_element, detach_instance, find_element, require_native_library
from .notices import warn_likely_mistake
from .schema import PLUGIN
from .spec import (
    compile_spec,
    exclude_contacts,
    find_body,
    find_site,
    keep_joined_trees_awake,
    quaternion_from_rotation,
    reference_body_poses,
    rotation_from_quaternion,
    site_pose,
    unit_quaternion,
)
from .stops import Stops, coordinate_masses, resolved

SITE_SIZE = 0.002  # m, radius of the element's sites (visual only; round ellipsoids, see add_flexure)
#: Site groups (the one definition): ``add_flexure`` puts both sites of an element in
#: ``SITE_GROUP``, which MuJoCo's viewers hide by default; a model may draw an element as a shape
#: on one site in ``SHAPE_SITE_GROUP``, which they show by default (so does the engine plugin's
#: strain colouring, which follows site a's group), and hide the other in ``HIDDEN_SITE_GROUP``
#: (ARCADE does); mjflex's renderer shows ``SHOWN_SITE_GROUPS``.
SITE_GROUP = 4
SHAPE_SITE_GROUP = 2
HIDDEN_SITE_GROUP = 5
SHOWN_SITE_GROUPS = (SHAPE_SITE_GROUP, SITE_GROUP)


@dataclass
class FlexureHandle:
    """The spec elements that make up one flexure: its sites, and its text record or plugin instance.

    Returned by :func:`add_flexure`; edit the spec elements through it before compiling.

    Attributes
    ----------
    name : str
        The element's name.
    site_a, site_b : mujoco.MjsSite
        Its two sites, on body A and body B, at the element frame (``name/a``, ``name/b``).
    text : mujoco.MjsText or None
        Its text record ``mjflex:name`` (None for a plugin instance).
    plugin : mujoco.MjsPlugin or None
        Its instance of the engine plugin ``mjflex.flexure`` (None for a text record).

    Examples
    --------
    >>> import mujoco
    >>> import mjflex
    >>> spec = mujoco.MjSpec.from_string(mjflex.mjcf.elements.EXAMPLE_MODEL)  # bodies A and B
    >>> handle = mjflex.add_flexure(spec, "mount", "A", "B", pos=[0, 0, 0], K=[1, 1, 1, 1e4, 1e4, 1e4])
    >>> handle.name, handle.site_a.name, handle.site_b.name
    ('mount', 'mount/a', 'mount/b')
    """

    name: str
    site_a: "mujoco.MjsSite"
    site_b: "mujoco.MjsSite"
    text: "mujoco.MjsText | None"
    plugin: "mujoco.MjsPlugin | None" = None


def add_flexure(
    spec, name, body_a, body_b, *, pos=None, quat=None, site=None, frame="world", K, B=None, method="twist",
    terms=None, stiffness_frame=None, enabled=True, viscous=True, strain_per_radian=None, source=None, poses=None,
    exclude_contact=True, kind="plugin", stops=None, rest=None, **attributes,
):  # fmt: skip
    """Add a flexure element between two bodies of ``spec``.

    Parameters
    ----------
    spec : mujoco.MjSpec
        The model being built; it must compile (bodies with their geoms or inertias).
    name : str
        Element name (free text, unique): the sites are ``name/a``, ``name/b`` and the record
        ``mjflex:name``.
    body_a, body_b : str or mujoco.MjsBody
        The two bodies; ``"world"`` grounds the other one.
    pos : array_like, shape (3,)
        Origin of the element frame in the frame ``frame`` (the world by default) at the
        reference configuration [m].
    quat : array_like, shape (4,), optional
        Orientation of the element frame in the frame ``frame``, w-first (normalized like MJCF);
        default: that frame's axes.
    site : str or mujoco.MjsSite, optional
        Instead of ``pos`` and ``quat``: a site of body A or body B (e.g. a robot's
        ``"wrist_site"``) whose frame is the element frame; both element sites are placed at its
        pose, which holds at any configuration of a robot, not only at ``qpos0``. Its name is
        stored in the record (``"site"``), and :class:`mjflex.Flexures` reports an element whose
        frame no longer coincides with it.
    frame : str or mujoco.MjsBody
        The frame ``pos`` and ``quat`` are given in: ``"world"`` (default) or a body of the spec
        (its name or ``MjsBody``; its frame at the reference configuration ``qpos0``), e.g.
        ``frame=body_a`` for a frame fixed in body A. :func:`mjflex.make_compliant` takes the same.
    K : array_like, shape (6, 6) or (6,)
        Stiffness in the element frame about its origin, ``[rotation; translation]`` rows
        (``N m/rad``, ``N/rad``, ``N/m``); a 6-vector is the diagonal. 3x3 / 3-vector: planar
        element ``[theta_z; x; y]`` in the frame's x-y plane.
    B : array_like, optional
        Damping, same layout as ``K``.
    method : {"twist", "dualquat"}
        How the relative displacement is measured (:mod:`mjflex.core.elements`).
    terms : PolynomialTerms, optional
        Higher-order terms of the potential (e.g. ``fit.terms`` of :func:`mjflex.fit_potential`),
        in the coordinates of ``method``, given in the same frame as ``K``; stored with their
        order in the record.
    stiffness_frame : tuple (pos, quat), optional
        World pose (reference configuration) of the frame in which ``K``, ``B`` and ``terms`` are
        given, e.g. a centre of stiffness or a clamped end; they are moved to the element frame
        with the adjoint (eq. 54; the terms by :func:`mjflex.potential_in_frame`). Default: the
        element frame itself.
    enabled, viscous : bool
        Initial run-time switches stored in the model.
    strain_per_radian : float, optional
        Peak bending strain per radian about the frame's z axis, stored for reports and colours.
    source : dict, optional
        JSON-serializable description of where K and B come from, stored in the model file.
    poses : tuple, optional
        Output of :func:`reference_body_poses` to reuse when adding many flexures (the spec is
        compiled otherwise).
    exclude_contact : bool
        Exclude contacts between the two bodies (``<contact><exclude body1 body2/></contact>``;
        once per pair): the element holds them together where their geoms usually touch, and
        MuJoCo would push them apart. ``False`` keeps their contacts. A pair with the world is
        never excluded here (the world holds floors and obstacles; MuJoCo's parent-child filter
        exempts it likewise): :class:`mjflex.Flexures` warns if such geoms touch at rest.
    stops : Stops, optional
        End stops: one-sided limits on the element's coordinates (rotation vector and position of
        frame b in frame a, ``[rx, ry, rz, x, y, z]``, or ``[theta, x, y]`` planar), in the
        element frame, with a stated or derived stiffness and an optional damping
        (:class:`mjflex.Stops`). A damping ratio or time constant is turned here into numbers from
        the coordinates' effective masses at ``qpos0`` (the element not yet added), and those
        are stored in the record or plugin instance (:mod:`mjflex.mjcf.schema`). Default: none.
    rest : tuple (pos, quat), optional
        The rest pose: the pose of frame b in frame a at which the element's energy is zero,
        ``pos`` [x, y, z] [m] and ``quat`` [w, x, y, z] (a unit quaternion), in the element frame.
        Its energy, wrench and stop coordinates count from it; a rest pose away from the compiled
        one preloads the element (as MuJoCo's ``springref`` does a joint spring). Default: the
        compiled pose (the frames coincide). Stored as written; the C library checks it.
    kind : {"plugin", "record"}
        How the element is written (:mod:`mjflex.mjcf.schema`). ``"plugin"`` (default): an
        instance of the engine plugin ``mjflex.flexure`` named ``name``, whose forces belong to
        the model: any program that imports mujoco with mjflex installed runs it (the viewer,
        ``mujoco.rollout``, ``Batch``, a pickled copy), with no provider to install; the trees it
        joins get ``sleep="never"`` (a plugin cannot wake a sleeping tree). It needs mjflex's
        native library (built by ``pip install``; RuntimeError saying how otherwise).
        ``"record"``: a text record, whose forces :class:`mjflex.Flexures` adds through
        MuJoCo's process-wide ``mjcb_passive`` while installed (``with flex:``); it has run-time
        switches (``set_method`` & co.). Both carry the same parameters, and ``python -m mjflex
        convert`` turns one into the other losslessly. Either needs mjflex's native library (built
        by ``pip install``), which checks the element's parameters.
    **attributes
        Any other attribute of the record (:class:`mjflex.FlexureRecord`; the table of
        ``docs/reference/mjcf_schema.md``), e.g. the display-only ones, stored as given.

    Returns
    -------
    FlexureHandle
        The element's sites and its record or plugin instance in ``spec``.

    Examples
    --------
    A block hanging 5 cm below a leaf spring that grounds it, then the model's provider:

    >>> import mujoco
    >>> import mjflex
    >>> spec = mujoco.MjSpec.from_string(
    ...     '<mujoco><worldbody><body name="block" pos="0 0 -0.1"><freejoint/>'
    ...     '<geom type="box" size="0.02 0.02 0.02" mass="0.5"/></body></worldbody></mujoco>'
    ... )
    >>> K = [2, 2, 1, 1e4, 1e4, 1e4]  # diagonal: rotations [N m/rad], then translations [N/m]
    >>> handle = mjflex.add_flexure(spec, "leaf", "world", "block", pos=[0, 0, -0.05], K=K, B=[1e-3] * 6)
    >>> mjflex.Flexures(spec.compile())
    Flexures(1 elements: leaf)
    """
    _check_arguments(spec, name, enabled, viscous, source, exclude_contact)
    if kind not in ("plugin", "record"):
        raise ValueError(f'kind must be "plugin" or "record"; got {validation.shorten(kind)}')
    site_names = naming.site_names(name)
    if (
        spec.text(schema.PREFIX + name) is not None
        or any(spec.site(s) is not None for s in site_names)
        or any(p.name == name for p in spec.plugins)
    ):
        raise ValueError(
            f"flexure {name!r} already exists in the spec (its sites, text record or plugin instance); pick another "
            "name"
        )
    require_native_library(name)  # before anything is added: a refusal leaves the spec as it was
    K = schema.matrix_value(K, f"K of flexure {name!r}")
    B = None if B is None else schema.matrix_value(B, f"B of flexure {name!r}")
    bodies = find_body(spec, body_a, "body_a"), find_body(spec, body_b, "body_b")
    if bodies[0] is bodies[1]:
        raise ValueError(f"flexure {name!r}: body_a and body_b are the same body; an element joins two bodies")
    xpos, xmat, body_names = poses if poses is not None else reference_body_poses(spec)
    p_WE, R_WE, frame_site = _element_frame(spec, name, bodies, pos, quat, site, (xpos, xmat, body_names), frame)
    if _JOINTS_CHECKED["on"]:
        _warn_joined(spec, name, bodies)
    if stiffness_frame is not None:
        if K.shape != (6, 6):
            raise ValueError("stiffness_frame is supported for spatial (6x6) elements only")
        p_WF = validation.as_array(stiffness_frame[0], "stiffness_frame pos", (3,))
        R_WF = rotation_from_quaternion(unit_quaternion(stiffness_frame[1], "stiffness_frame quat"))
        R_FE, p_FE = R_WF.T @ R_WE, R_WF.T @ (p_WE - p_WF)
        B = None if B is None else stiffness_in_frame(B, R_FE, p_FE, check=False)  # checked once, below, by C
        if terms is not None and len(terms):
            K, terms = potential_in_frame(K, terms, R_FE, p_FE)
        else:
            K = stiffness_in_frame(K, R_FE, p_FE, check=False)
    if stops is not None and not isinstance(stops, Stops):
        raise TypeError(f"flexure {name!r}: stops must be a mjflex.Stops (or None); got {type(stops).__name__}")
    if stops and stops.needs_model:
        stops = _resolved_stops(spec, name, stops, K, bodies, p_WE, R_WE)
    try:
        record = schema.FlexureRecord(name, method, K, B, enabled, viscous, strain_per_radian, source,
                                      *_checked_terms(terms, method, name), site=frame_site, stops=stops or None,
                                      rest=_rest_pose(rest, name), **attributes)  # fmt: skip
    except TypeError as exc:
        raise TypeError(f"add_flexure: {exc}") from None
    text_data = _record_text(record)
    sites = []
    for b, site_name in zip(bodies, site_names, strict=True):
        i = 0 if b is spec.worldbody else body_names.index(b.name)
        R_WB, p_WB = xmat[i], xpos[i]
        # a round ellipsoid: MuJoCo writes all three of its sizes to a file (a sphere's one only, and a file read back
        # fills the others from the body's childclass), and the type is explicit (not the childclass's)
        sites.append(b.add_site(
            name=site_name, pos=R_WB.T @ (p_WE - p_WB), quat=quaternion_from_rotation(R_WB.T @ R_WE),
            size=[SITE_SIZE] * 3, type=mujoco.mjtGeom.mjGEOM_ELLIPSOID, group=SITE_GROUP,
        ))  # fmt: skip
    if exclude_contact and all(b is not spec.worldbody for b in bodies):
        exclude_contacts(spec, *bodies)
    if kind == "plugin":
        plugin = add_plugin_element(spec, record, *site_names)
        keep_joined_trees_awake(spec, [(name, *site_names)])
        return FlexureHandle(name, sites[0], sites[1], None, plugin)
    text = spec.add_text(name=schema.PREFIX + name, data=text_data)
    return FlexureHandle(name, sites[0], sites[1], text)


def _resolved_stops(spec, name, stops, K, bodies, p_WE, R_WE):
    """``stops`` with its damping ratio or time constant turned into numbers (:func:`mjflex.mjcf.stops.resolved`) from
    the effective masses of the element's coordinates in ``spec`` at ``qpos0``."""
    model = compile_spec(spec, f"find the effective masses of flexure {name!r}'s stop coordinates")
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    ids = [0 if b is spec.worldbody else mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, b.name) for b in bodies]
    return resolved(stops, K, coordinate_masses(model, data, *ids, p_WE, R_WE, K.shape[0]), name)


def _element_frame(spec, name, bodies, pos, quat, site, poses, frame="world"):
    """``(p_WE, R_WE, site name or None)``: the element frame at ``qpos0`` from ``pos``/``quat`` (in ``frame``)
    or ``site``."""
    if site is None:
        if pos is None:
            raise ValueError(f"flexure {name!r}: give the element frame, pos=... (and quat=...) or site=...")
        q = (1.0, 0.0, 0.0, 0.0) if quat is None else quat
        R_WF, p_WF = np.eye(3), np.zeros(3)  # the frame pos and quat are given in, at qpos0
        if not (isinstance(frame, str) and frame == "world"):
            body, (xpos, xmat, names) = find_body(spec, frame, f"flexure {name!r}: frame"), poses
            i = 0 if body is spec.worldbody or body.name == "world" else names.index(body.name)
            R_WF, p_WF = xmat[i], xpos[i]
        p, R = validation.as_array(pos, "pos", (3,)), rotation_from_quaternion(unit_quaternion(q, "quat"))
        return p_WF + R_WF @ p, R_WF @ R, None
    if pos is not None or quat is not None:
        raise ValueError(f"flexure {name!r}: give either site=... or pos=/quat=, not both")
    found = find_site(spec, site)
    owner = found.parent
    if all(owner is not b and owner.name != b.name for b in bodies):
        names = ["world" if b is spec.worldbody else b.name for b in bodies]
        raise ValueError(
            f"flexure {name!r}: site {found.name!r} is on body {owner.name or 'world'!r}, not on {names[0]!r} or "
            f"{names[1]!r}; use a site of one of the two bodies, or give the frame as pos=/quat="
        )
    p_WE, R_WE = site_pose(spec, found)
    return p_WE, R_WE, found.name


#: Whether add_flexure warns about bodies that joints already join (make_compliant adds its element as it replaces
#: a weld or the joints, and says so itself).
_JOINTS_CHECKED = {"on": True}


@contextlib.contextmanager
def joints_checked(on: bool):
    """Within the block, :func:`add_flexure` checks (``on``) or not the joints between the element's bodies."""
    before = _JOINTS_CHECKED["on"]
    _JOINTS_CHECKED["on"] = on
    try:
        yield
    finally:
        _JOINTS_CHECKED["on"] = before


def _warn_joined(spec, name, bodies):
    """A :class:`LikelyMistakeWarning` when one body is the other's parent and the child's joints leave it fewer
    than six degrees of freedom: the element then acts in parallel with the joints (or never deflects)."""
    a, b = bodies
    label = [("world" if x is spec.worldbody else x.name) for x in bodies]
    child = None
    for parent, kid in ((a, b), (b, a)):
        if kid is not spec.worldbody and kid.parent is not None and _named(kid.parent) == _named(parent):
            child = (parent, kid)
    if child is None:
        return
    parent, kid = child
    joints = list(kid.joints)
    dofs = sum(DOFS[int(j.type)] for j in joints)
    if dofs >= 6:
        return
    if not joints:
        message = (f"flexure {name!r}: body {kid.name!r} is welded to its parent {_named(parent)!r} (it has no joint): "
                   "the element never deflects and adds nothing. Give the body its degrees of freedom "
                   f"(mjflex.make_compliant(spec, {kid.name!r}, K) turns the weld into this element)")  # fmt: skip
    else:
        listed = ", ".join(f"{j.name or '(unnamed)'} ({mujoco.mjtJoint(int(j.type)).name[6:].lower()})" for j in joints)
        message = (
            f"flexure {name!r} joins {label[0]!r} and {label[1]!r}, which joint(s) {listed} already join: the element "
            f"acts in parallel with them, along the {dofs} degree(s) of freedom they allow (the others stay rigid). "
            f"To replace the joints by the element: mjflex.make_compliant(spec, {kid.name!r}, K, "
            "replace_joints=True); to keep both on purpose, silence mjflex.LikelyMistakeWarning"
        )
    warn_likely_mistake(message, stacklevel=3)


def _named(body) -> str:
    return body.name or "world"


def remove_flexure(spec, name) -> None:
    """Remove element ``name`` (its sites and its text record or plugin instance) from ``spec``.

    The ``<exclude>`` that ``add_flexure`` may have written, and the ``sleep`` policies it set,
    are left alone (other elements may join the same pair or trees). Raises ValueError when the
    spec holds no such element.

    Parameters
    ----------
    spec : mujoco.MjSpec
        The model, edited in place.
    name : str
        The element's name: its sites ``name/a``, ``name/b`` and its text record ``mjflex:name``
        or its ``mjflex.flexure`` plugin instance ``name`` are removed.

    Examples
    --------
    >>> import mujoco
    >>> import mjflex
    >>> spec = mujoco.MjSpec.from_string(mjflex.mjcf.elements.EXAMPLE_MODEL)  # one element, "hinge"
    >>> mjflex.remove_flexure(spec, "hinge")
    >>> spec.compile().nsite
    0
    """
    try:
        element = find_element(spec, name)
    except KeyError as exc:
        raise ValueError(exc.args[0]) from None
    sites = [spec.site(s) for s in (element.site_a, element.site_b)]
    if any(s is None for s in sites):
        raise ValueError(f"flexure {name!r} has no sites {element.site_a!r} and {element.site_b!r} in the spec; "
                         "remove its record or instance yourself")  # fmt: skip
    if element.kind == PLUGIN:
        detach_instance(spec, element.name)
    for part in [*sites, element.holder]:
        spec.delete(part)


def _check_arguments(spec, name, enabled, viscous, source, exclude_contact):
    """The types of :func:`add_flexure`'s Python arguments (the record's rules follow in :func:`_record_text`)."""
    if not isinstance(spec, mujoco.MjSpec):
        raise TypeError(f"spec must be a mujoco.MjSpec; got {type(spec).__name__}")
    if not isinstance(name, str) or not name:
        raise TypeError(f"name must be a non-empty str (the element's name); got {validation.shorten(name)}")
    validation.check_flag(enabled, "enabled")
    validation.check_flag(viscous, "viscous")
    validation.check_flag(exclude_contact, "exclude_contact")
    if source is not None and not isinstance(source, dict):
        raise TypeError(f"source must be a dict (JSON-serializable) or None; got {type(source).__name__}")


def _record_text(record):
    """The record's JSON text, its parameters checked once, by the C library (a record's rules and messages)."""
    try:
        text = record.to_text()
    except (TypeError, ValueError) as exc:  # json.dumps of a source holding other objects, or a cycle
        raise TypeError(f"flexure {record.name!r}: source must hold JSON values only: {exc}") from None
    schema.read_config(record.name, schema.config_of(record), schema.RECORD)
    return text


def _rest_pose(rest, name):
    """The ``rest`` argument as a record holds it, ``((x, y, z), (w, x, y, z))`` of floats, or None (its rules: the
    C library's, when the record is written)."""
    if rest is None:
        return None
    if isinstance(rest, str | bytes | dict) or not hasattr(rest, "__len__") or len(rest) != 2:
        raise ValueError(f"flexure {name!r}: rest must be a pose (pos, quat): ([x, y, z], [w, x, y, z]); got "
                         f"{validation.shorten(rest)}")  # fmt: skip
    parts = (validation.numeric_array(part, f"rest of flexure {name!r}").reshape(-1) for part in rest)
    return tuple(tuple(float(v) for v in part) for part in parts)


def _checked_terms(terms, method, name):
    """``(terms, order)`` for the record: None and 2 without terms; raises ValueError naming the element."""
    if terms is None:
        return None, 2
    if not isinstance(terms, PolynomialTerms):
        raise ValueError(f"flexure {name!r}: terms must be a mjflex.PolynomialTerms; got {type(terms).__name__}")
    if terms.method != method:
        raise ValueError(f"flexure {name!r}: the terms are in {terms.method} coordinates; pass method={terms.method!r}")
    return (terms, terms.order) if len(terms) else (None, 2)


def add_flexure_in_body_frame(spec, name, body_a, body_b, *, pos, quat=(1.0, 0.0, 0.0, 0.0), poses=None, **kwargs):
    """:func:`add_flexure` with the element frame given relative to body A's frame.

    Parameters
    ----------
    spec : mujoco.MjSpec
        The model being built; it must compile.
    name : str
        Element name, as in :func:`add_flexure`.
    body_a, body_b : str or mujoco.MjsBody
        The two bodies; ``"world"`` grounds the other one.
    pos : array_like, shape (3,)
        Origin of the element frame in body A's frame at the reference configuration [m].
    quat : array_like, shape (4,)
        Orientation of the element frame in body A's frame, w-first (default: A's axes).
    poses : tuple, optional
        Output of :func:`reference_body_poses`, to reuse when adding many flexures.
    **kwargs
        ``K``, ``B``, ``method`` and the other arguments of :func:`add_flexure`.

    Returns
    -------
    FlexureHandle

    Examples
    --------
    The element frame 5 cm below the world's origin, as seen from body A (here the world):

    >>> import mujoco
    >>> import mjflex
    >>> spec = mujoco.MjSpec.from_string(
    ...     '<mujoco><worldbody><body name="B" pos="0 0 -0.1"><freejoint/><geom size="0.01"/></body></worldbody>'
    ...     "</mujoco>"
    ... )
    >>> handle = mjflex.add_flexure_in_body_frame(spec, "leaf", "world", "B", pos=[0, 0, -0.05], K=[1] * 6)
    >>> handle.site_b.pos.tolist()  # in body B's frame: 5 cm above its origin
    [0.0, 0.0, 0.05]
    """
    if "frame" in kwargs:
        raise TypeError("add_flexure_in_body_frame gives the frame in body A's frame; for another, use add_flexure's "
                        "frame=")  # fmt: skip
    poses = poses if poses is not None else reference_body_poses(spec)
    return add_flexure(spec, name, body_a, body_b, pos=pos, quat=quat, frame=body_a, poses=poses, **kwargs)

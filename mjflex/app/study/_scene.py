"""The scene a study runs: the model, its initial state, what is tracked, and the variants.

Everything here is checked once, before any run, and a problem raises :class:`StudyError` with
the argument or element at fault and the fix.
"""

import os

import mujoco
import numpy as np

from ...core import validation
from ...mjcf.convert import copy_spec
from ...runtime.flexures import Flexures
from ...runtime.tables import ModelError
from ...variants import variant
from ...variants.variant import Variant
from ._metrics import TrackedItem, pose_matrix

#: An initial state whose velocities are all zero and whose accelerations are below this
#: [m/s^2 or rad/s^2] is at rest in equilibrium: nothing would move, and there is nothing to study.
EQUILIBRIUM_QACC = 1e-8


class StudyError(ValueError):
    """The study cannot go on; the message says why and how to fix it.

    ``partial`` holds the :class:`StudyResult` measured so far (None before the first run);
    ``paths`` the files it was written to, if any.
    """

    def __init__(self, message, partial=None):
        super().__init__(message)
        self.partial = partial
        self.paths = []


def load(model):
    """``(MjModel, name, source)`` from an MJCF path, an ``MjSpec`` or a model object.

    ``source`` is what variant builders receive: the path or a copy of the spec when given one
    (builders can rebuild the model from it), else the ``MjModel`` itself.
    """
    if isinstance(model, mujoco.MjModel):
        name = model.names[: model.names.index(b"\x00")].decode() or "model"
        return model, name, model
    if isinstance(model, mujoco.MjSpec):
        source = copy_spec(model)
        try:
            return copy_spec(model).compile(), model.modelname or "model", source
        except ValueError as exc:
            raise StudyError(f"the spec does not compile: {exc}") from None
    path = os.fspath(model)
    if not os.path.exists(path):
        raise StudyError(f"model file {path!r} not found")
    try:
        return mujoco.MjModel.from_xml_path(path), os.path.basename(path), path
    except ValueError as exc:
        raise StudyError(f"MuJoCo cannot load {path!r}: {exc}") from None


def source_spec_of(source, flex):
    """An ``MjSpec`` of the study's source when it holds plugin elements (their method is set there), else None.

    None too for an ``MjModel`` whose file MuJoCo no longer keeps (``mj_saveLastXML``).
    """
    if "plugin" not in flex.kinds:
        return None
    try:
        return variant.source_spec(source)
    except TypeError:  # an MjModel whose file MuJoCo no longer keeps
        return None


def flexures_of(model, name):
    try:
        flex = Flexures(model)
    except ModelError as exc:
        raise StudyError(f"{name}: {exc}") from None
    if not len(flex):
        raise StudyError(
            f'{name} has no mjflex elements (no mjflex.flexure plugin instances, no <text name="mjflex:..."> records '
            "with their sites), so there is nothing to study: the study compares ways of simulating flexures. Add "
            "elements as described in docs/reference/mjcf_schema.md or with mjflex.add_flexure, then run it again."
        )
    return flex


def _names(model, objtype, count):
    return [mujoco.mj_id2name(model, objtype, i) or "" for i in range(count)]


def initial_state(model, flex, name, *, keyframe=None, qpos=None, qvel=None):
    """The state every run starts from, and a description of it.

    ``keyframe`` (name or index; default: the model's first keyframe, if any), then ``qpos`` /
    ``qvel`` override. Returns ``(state, description, data)`` with ``state`` a dict of arrays.
    """
    data = mujoco.MjData(model)
    keys = _names(model, mujoco.mjtObj.mjOBJ_KEY, model.nkey)
    if keyframe is None and model.nkey:
        keyframe = 0
    if keyframe is not None:
        index = keyframe if isinstance(keyframe, int) else (keys.index(keyframe) if keyframe in keys else -1)
        if not 0 <= index < model.nkey:
            raise StudyError(f"{name}: no keyframe {keyframe!r}; its keyframes are {keys or 'none'}")
        mujoco.mj_resetDataKeyframe(model, data, index)
        what = f"keyframe '{keys[index] or index}'"
    else:
        what = "qpos0 at rest (the model has no keyframe)"
    for arg, value, size in (("qpos", qpos, model.nq), ("qvel", qvel, model.nv)):
        if value is not None:
            try:  # the core's number rules: no complex, booleans, text or None inside
                value = validation.numeric_array(value, arg)
            except (TypeError, ValueError) as exc:
                raise StudyError(f"{name}: {exc}") from None
            if value.shape != (size,):
                raise StudyError(f"{arg} must have {size} entries for {name}; got shape {value.shape}")
            getattr(data, arg)[:] = value
            what += f", {arg} given"
    for arg in ("qpos", "qvel", "act", "ctrl"):
        if not np.isfinite(getattr(data, arg)).all():
            raise StudyError(f"{name}: the initial {arg} ({what}) is not finite; fix the keyframe or the {arg} given")
    with flex:
        mujoco.mj_forward(model, data)
    if not np.isfinite(data.qacc).all():
        raise StudyError(f"{name}: the initial state ({what}) gives non-finite accelerations; check it")
    if not data.qvel.any() and np.max(np.abs(data.qacc), initial=0.0) < EQUILIBRIUM_QACC:
        raise StudyError(
            f"{name}: no initial state to study: {what} is at rest and in equilibrium, so nothing would move. Add a "
            '<keyframe><key name="run" qvel="..."/></keyframe> with the motion to study (ARCADE has "paper_run"), '
            "pick one with --keyframe, or pass qpos/qvel to mjflex.study."
        )
    state = {k: getattr(data, k).copy() for k in ("qpos", "qvel", "act", "ctrl", "mocap_pos", "mocap_quat")}
    return state, what, data


def default_frame(model, flex):
    """Heaviest top-level body if the mechanism floats freely, else the world (None).

    Floating: no element is attached to a static body (the world or a body welded to it) and
    every top-level moving body has one free joint. Errors then measure deformation rather than
    the rigid motion of the whole (ARCADE spins at 105 rad/s); for a grounded mechanism the
    world frame already does.
    """
    sites = [int(s) for pair in flex.site_ids for s in pair]
    if any(model.body_weldid[model.site_bodyid[s]] == 0 for s in sites):
        return None
    tops = [b for b in range(1, model.nbody) if model.body_parentid[b] == 0 and model.body_dofnum[b] > 0]
    free = all(
        model.body_jntnum[b] == 1 and model.jnt_type[model.body_jntadr[b]] == mujoco.mjtJoint.mjJNT_FREE for b in tops
    )
    if not tops or not free:
        return None
    return mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, max(tops, key=lambda b: model.body_mass[b]))


def tracked_items(model, flex, name, track=None, frame="auto"):
    """``(items, frame)``: bodies or sites to compare, and the body their poses are taken in.

    ``track``: names of bodies or sites (default: every named body but the world and the frame).
    ``frame``: a body name, ``"world"``, or ``"auto"`` (see :func:`default_frame`).
    """
    bodies = _names(model, mujoco.mjtObj.mjOBJ_BODY, model.nbody)
    if frame == "auto":
        frame = default_frame(model, flex)
    elif frame == "world":
        frame = None
    elif frame not in bodies[1:]:
        raise StudyError(f"{name}: no body {frame!r} to measure poses in; use a body name, 'world' or 'auto'")
    if track is None:
        track = [b for b in bodies[1:] if b and b != frame]
        if not track:
            raise StudyError(f"{name}: its bodies have no names, so nothing can be tracked; name them or pass track=")
    items = []
    for label in track:
        bid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, label)
        if bid > 0:
            items.append(TrackedItem(label, label, np.eye(4)))
            continue
        sid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, label)
        if sid < 0:
            raise StudyError(f"{name}: {label!r} is neither a body nor a site; track names one of its bodies or sites")
        body = bodies[model.site_bodyid[sid]]
        if not body:
            raise StudyError(f"{name}: site {label!r} is on an unnamed body; name the body to track the site")
        items.append(TrackedItem(label, body, pose_matrix(model.site_pos[sid], model.site_quat[sid])))
    return items, frame


def build_variant(entry, source):
    """A list of :class:`Variant` from an entry: a Variant, or a builder ``source -> Variant`` (or a
    list of them, or None), called with the study's source (see :func:`load`)."""
    if isinstance(entry, Variant):
        return [entry]
    built = entry(source)
    if built is None:
        return []
    built = list(built) if isinstance(built, list | tuple) else [built]
    for v in built:
        if not isinstance(v, Variant):
            raise TypeError(
                f"variant builder {entry!r} returned {type(v).__name__}, not mjflex.variants.variant.Variant"
            )
    return built


def variant_state(variant, model, data):
    """The variant's initial state from the source state; checked."""
    qpos, qvel = variant.state_from(model, data)
    qpos, qvel = np.asarray(qpos, dtype=float), np.asarray(qvel, dtype=float)
    m = variant.model
    if qpos.shape != (m.nq,) or qvel.shape != (m.nv,):
        raise ValueError(
            f"state_from returned shapes {qpos.shape}, {qvel.shape}; the variant needs ({m.nq},), ({m.nv},)"
        )
    if not (np.isfinite(qpos).all() and np.isfinite(qvel).all()):
        raise ValueError("state_from returned a non-finite state")
    return {"qpos": qpos, "qvel": qvel}

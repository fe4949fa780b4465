"""mjflex on MuJoCo Warp: the flexure forces of thousands of worlds per step, on a GPU or Warp's CPU device.

``pip install "mjflex[warp]"`` installs MuJoCo Warp (``mujoco-warp``) and NVIDIA Warp
(``warp-lang``); nothing else in mjflex imports them.

>>> import mujoco, mujoco_warp as mjw, mjflex.warp  # doctest: +SKIP
>>> mjmodel = mujoco.MjModel.from_xml_path("models/two_body.xml")  # doctest: +SKIP
>>> m = mjflex.warp.put_model(mjmodel)  # MuJoCo Warp's model, with mjflex's passive callback  # doctest: +SKIP
>>> d = mjw.make_data(mjmodel, nworld=1024)  # doctest: +SKIP
>>> mjw.step(m, d)  # doctest: +SKIP
>>> mjflex.warp.divergences(m, d)  # doctest: +SKIP
[]

What is there: both methods (finite twist, dual quaternion), damping, planar elements,
polynomial terms, end stops, rest offsets, elements on free bodies and on bodies moved by any chain of
joints, MuJoCo's spring/damper disable flags, both forms of elements in MJCF (text records and
``mjflex.flexure`` plugin instances), per-world K, B, switches and end stops (:func:`set_parameters`),
per-world divergence records naming the element and the step (:func:`divergences`), the element
math in float32 (MuJoCo Warp's precision) or float64. What is not: an element feature the kernels
do not implement is refused by :func:`put_model` naming the element and the feature; MuJoCo
Warp integrates in float32 only (no float64 simulation: use MuJoCo itself for that).
"""

import contextlib
import copy
import logging
import threading
import warnings

import mujoco
import mujoco_warp as mjw
import numpy as np

from . import _mjflex
from ._forces import WarpFlexures, WorldDivergence
from ._mjflex import ElementTable, UnsupportedElementError

__all__ = [
    "PRECISIONS",
    "ElementTable",
    "UnsupportedElementError",
    "WarpFlexures",
    "WorldDivergence",
    "displacements",
    "dissipation_powers",
    "diverged",
    "divergences",
    "element_table",
    "flexures",
    "generalized_forces",
    "potential_energies",
    "put_model",
    "set_parameters",
    "stop_coordinates",
    "wrenches",
]

#: Precisions of the element math: MuJoCo Warp's own float32, or float64 inside the kernels.
PRECISIONS = ("float32", "float64")
log = logging.getLogger("mjflex.warp")
_SLEEP = mujoco.mjtSleepPolicy
_AUTO_OF = {int(_SLEEP.mjSLEEP_NEVER): int(_SLEEP.mjSLEEP_AUTO_NEVER),
            int(_SLEEP.mjSLEEP_ALLOWED): int(_SLEEP.mjSLEEP_AUTO_ALLOWED),
            int(_SLEEP.mjSLEEP_INIT): int(_SLEEP.mjSLEEP_AUTO_ALLOWED)}  # fmt: skip


def put_model(mjmodel: mujoco.MjModel, *, precision: str = "float32", batch_sizes: dict | None = None):
    """MuJoCo Warp's model of ``mjmodel``, with the forces of mjflex's flexure elements as its passive callback.

    Parameters
    ----------
    mjmodel : mujoco.MjModel
        A model with mjflex elements in either form (text records, ``mjflex.flexure`` plugin
        instances); it is not changed: MuJoCo Warp is given an adapted copy.
    precision : {"float32", "float64"}
        Precision of the element math inside the kernels. MuJoCo Warp computes the kinematics
        and integrates in float32 either way; float64 removes the rounding of the element math
        itself (measured in the how-to page on MuJoCo Warp).
    batch_sizes : dict, optional
        Passed to ``mujoco_warp.put_model``: leading sizes of MuJoCo Warp's per-world model fields.

    Returns
    -------
    mujoco_warp.Model
        With ``callback.passive`` set to a :class:`WarpFlexures` (:func:`flexures` returns it);
        step it with ``mujoco_warp.step`` on data from ``mujoco_warp.make_data(mjmodel, nworld)``.
        The element parameters start as written in the model, shared by all worlds
        (:func:`set_parameters` batches them).

    Raises
    ------
    mjflex.ModelError
        A malformed element (as :class:`mjflex.Flexures`).
    UnsupportedElementError
        An element uses a feature the Warp kernels do not implement (named with the element).
    NotImplementedError
        The model holds something MuJoCo Warp cannot run (its own message, with a note), a plugin
        instance other than mjflex's that MuJoCo Warp would drop, or trees that start asleep.

    Notes
    -----
    What is adapted on the copy (listed in ``flexures(m).adaptations`` and logged at INFO level
    by the ``mjflex.warp`` logger): MuJoCo Warp accepts only the compiler's automatic sleep
    policies, so ``sleep="never"`` (which mjflex writes on bodies joined by an element) becomes
    the automatic "never" and ``"allowed"`` the automatic "allowed", which act the same; the
    ``mjflex.flexure`` plugin instances, which MuJoCo Warp ignores, are computed by the callback;
    the autoreset disable flag, which MuJoCo Warp refuses, is cleared (it never resets a world).
    """
    if not isinstance(mjmodel, mujoco.MjModel):
        raise TypeError(f"put_model expects a mujoco.MjModel; got {type(mjmodel).__name__}")
    if precision not in PRECISIONS:
        raise ValueError(f"precision must be one of {PRECISIONS}; got {precision!r}")
    model = copy.copy(mjmodel)
    flex = _mjflex.flexures(model)
    table = _mjflex.element_table(model, flex)
    adaptations = _check_plugins(model, table) + _adapt_sleep(model, table) + _adapt_flags(model)
    try:
        with _plugin_arrays_sized(model):
            m = mjw.put_model(model, batch_sizes=batch_sizes)
    except (NotImplementedError, ValueError) as exc:
        exc.add_note("mjflex.warp.put_model: MuJoCo Warp cannot run this model (see its message above)")
        raise
    m.callback.passive = WarpFlexures(table, model, precision, adaptations)
    for line in adaptations:
        log.info("mjflex.warp.put_model: %s", line)
    return m


_PATCH_LOCK = threading.Lock()


@contextlib.contextmanager
def _plugin_arrays_sized(model):
    """Work around MuJoCo Warp 4.0.0's ``put_model`` on models with non-geom plugin instances.

    It keeps only the geom plugins' instances in ``plugin`` / ``plugin_attr`` but sizes those
    arrays by the model's ``nplugin``, and fails ("cannot reshape array of size 0"). While it runs,
    the arrays of the ``nplugin`` dimension are sized by the instances it kept (``nplugin`` is read
    nowhere else in MuJoCo Warp 4.0.0). Only applied to models that have such instances;
    ``tests/test_warp.py`` checks that plain MuJoCo Warp still needs it.
    """
    if model.nplugin == int((model.geom_plugin >= 0).sum()):
        yield
        return
    from mujoco_warp._src import io

    original = io._create_array

    def create_array(data, spec, sizes, batch_size=1):
        if getattr(spec, "shape", ())[:1] == ("nplugin",):
            sizes = {**sizes, "nplugin": len(data)}
        return original(data, spec, sizes, batch_size)

    with _PATCH_LOCK:
        io._create_array = create_array
        try:
            yield
        finally:
            io._create_array = original


def _name(model, objtype, i, fallback):
    return mujoco.mj_id2name(model, objtype, int(i)) or f"{fallback} #{int(i)}"


def _check_plugins(model, table) -> list[str]:
    ours = set(_mjflex.mjflex_instances(model))
    # geom plugins MuJoCo Warp runs; those of bodies, actuators and sensors it refuses itself, with its own message
    attached = {int(p) for a in (model.geom_plugin, model.body_plugin, model.actuator_plugin, model.sensor_plugin)
                for p in a if p >= 0}  # fmt: skip
    others = [i for i in range(model.nplugin) if i not in ours and i not in attached]
    if others:
        names = ", ".join(repr(_name(model, mujoco.mjtObj.mjOBJ_PLUGIN, i, "instance")) for i in others[:5])
        raise NotImplementedError(
            f"mjflex.warp.put_model: plugin instance(s) {names} are neither mjflex.flexure elements nor attached to "
            "a geom, body, actuator or sensor; MuJoCo Warp would drop them silently (their forces or effects would be "
            "lost). Remove them for MuJoCo Warp, or simulate the model with MuJoCo"
        )
    if not ours:
        return []
    return [f"the {len(ours)} mjflex.flexure plugin instances, which MuJoCo Warp ignores, are computed by mjflex's "
            "passive callback (the same elements as the C plugin)"]  # fmt: skip


def _adapt_sleep(model, table) -> list[str]:
    policy = model.tree_sleep_policy
    sleep_on = bool(model.opt.enableflags & mujoco.mjtEnableBit.mjENBL_SLEEP)
    changed = {}
    for tree, value in enumerate(policy):
        value = int(value)
        if value not in _AUTO_OF:
            continue
        root = _name(model, mujoco.mjtObj.mjOBJ_BODY, model.tree_bodyadr[tree], "body")
        if value == int(_SLEEP.mjSLEEP_INIT) and sleep_on:
            raise NotImplementedError(
                f"mjflex.warp.put_model: the tree of body '{root}' starts asleep (sleep=\"init\"), which MuJoCo Warp "
                'does not support; use sleep="allowed" for MuJoCo Warp'
            )
        changed.setdefault(_SLEEP(value).name, []).append(root)
        policy[tree] = _AUTO_OF[value]
        if sleep_on and value != int(_SLEEP.mjSLEEP_NEVER) and tree in table.joined_trees:
            warnings.warn(
                f"mjflex.warp: flexure '{table.joined_trees[tree]}' joins the tree of body '{root}', which may sleep: "
                'a sleeping tree ignores forces, so the element\'s force is lost while it sleeps. Set sleep="never" '
                "on its root body, or disable sleeping",
                UserWarning,
                stacklevel=3,
            )
    out = []
    for name, roots in changed.items():
        more = f" and {len(roots) - 3} more" if len(roots) > 3 else ""
        new = _SLEEP(_AUTO_OF[int(getattr(_SLEEP, name))]).name
        why = "" if sleep_on else " (sleeping is off in this model: no effect)"
        out.append(f"sleep policy {name} of the trees of {', '.join(roots[:3])}{more} set to {new}, which MuJoCo "
                   f"Warp accepts and which acts the same{why}")  # fmt: skip
    return out


def element_table(mjmodel: mujoco.MjModel, flex=None) -> ElementTable:
    """The elements of ``mjmodel`` as the Warp kernels read them (``flex``: its :class:`mjflex.Flexures`, if made).

    Raises :class:`UnsupportedElementError` for an element feature the kernels lack. Note that
    :class:`mjflex.Flexures` sets the automatic sleep policy of trees joined by an element to
    "never" on the model it reads; pass a copy to leave a model as it is.
    """
    return _mjflex.element_table(mjmodel, flex if flex is not None else _mjflex.flexures(mjmodel))


def _adapt_flags(model) -> list[str]:
    autoreset = int(mujoco.mjtDisableBit.mjDSBL_AUTORESET)
    if not model.opt.disableflags & autoreset:
        return []
    model.opt.disableflags &= ~autoreset
    return ["the autoreset disable flag, which MuJoCo Warp refuses, cleared: MuJoCo Warp never resets a world "
            "(what the flag asks for); a diverged world is flagged by mjflex.warp.divergences"]  # fmt: skip


def flexures(m) -> WarpFlexures:
    """The :class:`WarpFlexures` of a model made by :func:`put_model` (its elements, switches and notes)."""
    forces = getattr(getattr(m, "callback", None), "passive", None)
    if not isinstance(forces, WarpFlexures):
        raise TypeError(
            "this MuJoCo Warp model has no mjflex callback: make it with mjflex.warp.put_model(mjmodel), not "
            "mujoco_warp.put_model"
        )
    return forces


def set_parameters(
    m, *, K=None, B=None, enabled=None, viscous=None, stop_lower=None, stop_upper=None, stop_stiffness=None
) -> None:
    """Set the elements' stiffness, damping, switches and end stops, shared by all worlds or one set per world.

    Parameters
    ----------
    m : mujoco_warp.Model
        A model made by :func:`put_model`.
    K, B : array_like, optional
        Shape ``(n, 6, 6)`` (all worlds) or ``(nworld, n, 6, 6)`` (one per world), or diagonals
        ``(..., n, 6)``: each element's stiffness / damping in its element frame, rows
        ``[rotation; translation]``, SI units (planar elements embedded at rows and columns
        ``[2, 3, 4]``, the only non-zero ones). Checked here: finite, symmetric, positive
        semi-definite (ValueError naming the element).
    enabled, viscous : array_like of bool, optional
        ``(n,)`` or ``(nworld, n)``: switch elements, or their damping, on and off per world.
    stop_lower, stop_upper : array_like, optional
        ``(n, 6)`` or ``(nworld, n, 6)``: the end stops' limits of each element on its stop
        coordinates ``[rx, ry, rz, x, y, z]`` [rad, m] (:mod:`mjflex.core.stops`; planar elements
        on ``theta, x, y`` at ``[2, 3, 4]``), ``-inf`` / ``+inf`` where a coordinate has no stop
        (the model's, ``parameters()["stop_lower"]``, are where to start). An element may get
        stops here that the model did not give it.
    stop_stiffness : array_like, optional
        ``(n, 6)`` or ``(nworld, n, 6)``: the stops' stiffness [N m/rad, N/m], read where a limit
        is finite (there it must be positive). Until it is set, the model's: a stiffness written
        in the model as it is, and a derived one (none written) derived from each world's ``K``,
        ``100 K_ii`` (:func:`mjflex.derived_stop_stiffness`), as editing ``K`` in the model
        would; once set, these values for every element.

    Raises
    ------
    ValueError
        A parameter of the wrong shape, not finite, a K or B not symmetric positive semi-definite,
        beyond float32 with ``precision="float32"``; stops that break the rules of
        :class:`mjflex.Stops` in some world (named with the element, the coordinate and the
        world). A refused call changes nothing.
    TypeError
        ``enabled`` or ``viscous`` not booleans.

    Notes
    -----
    The leading size of each parameter must be 1 or the data's ``nworld`` (checked at every
    step, ValueError otherwise; the stops' limits and stiffness must agree among themselves, and
    a derived stiffness has K's). Parameters not given keep their values. Takes effect at the
    next step. Which elements run the stops' code is set here: an element without a finite
    limit in any world skips it at one flag.

    Examples
    --------
    Four worlds of the two-body model, the hinge's rotation about z stopped at +-0.1, 0.2, 0.3
    and 0.4 rad (the stiffness derived from K)::

        forces = mjflex.warp.flexures(m)
        lower = np.full((4, len(forces), 6), -np.inf)
        upper = np.full((4, len(forces), 6), np.inf)
        lower[:, 0, 2], upper[:, 0, 2] = -np.arange(1, 5) / 10, np.arange(1, 5) / 10
        mjflex.warp.set_parameters(m, stop_lower=lower, stop_upper=upper)
    """
    flexures(m).set_parameters(K=K, B=B, enabled=enabled, viscous=viscous, stop_lower=stop_lower,
                               stop_upper=stop_upper, stop_stiffness=stop_stiffness)  # fmt: skip


def wrenches(m, d) -> np.ndarray:
    """Wrench of each element on its body B, ``(nworld, n, 6)``: moment about the origin of frame b and force,
    world axes [N m; N], from ``d``'s kinematics as they are (after ``mujoco_warp.forward`` or a step)."""
    return flexures(m).wrenches(m, d)


def generalized_forces(m, d) -> np.ndarray:
    """The generalized forces ``(nworld, nv)`` (float32) the elements add to ``qfrc_passive`` in ``d``'s state."""
    return flexures(m).generalized_forces(m, d)


def potential_energies(m, d) -> np.ndarray:
    """Elastic energy of each element, end stops included, ``(nworld, n)`` [J] (in the precision of the element
    math)."""
    return flexures(m).potentials_and_twists(m, d)[0]


def dissipation_powers(m, d) -> np.ndarray:
    """Power dissipated by each element's damping, ``(nworld, n)`` [W]."""
    return flexures(m).dissipation_powers(m, d)


def displacements(m, d) -> np.ndarray:
    """Finite twist ``[tau; t]`` of frame b relative to frame a of each element, ``(nworld, n, 6)`` [rad; m]."""
    return flexures(m).potentials_and_twists(m, d)[1]


def stop_coordinates(m, d) -> np.ndarray:
    """The coordinates end stops act on, ``(nworld, n, 6)``: ``[rx, ry, rz, x, y, z]`` of each element [rad; m].

    The rotation vector of frame b relative to frame a and the position of frame b's origin in
    frame a (:mod:`mjflex.core.stops`), for every element (with or without stops; planar ones in
    ``rz, x, y``), as :meth:`mjflex.Flexures.stop_coordinates`. Compare them with
    ``flexures(m).parameters()["stop_lower"]`` and ``["stop_upper"]`` to see which stops are
    engaged; their energy is part of :func:`potential_energies`.
    """
    return flexures(m).potentials_and_twists(m, d)[2]


def divergences(m, d) -> list[WorldDivergence]:
    """The worlds of ``d`` that diverged in their current run: world, element blamed, step index, message.

    Judged in every evaluation of the forces: a qpos or qvel that is not finite or beyond 1e10
    (MuJoCo's bound) is blamed on the element whose force alone accelerated a body beyond 1e8
    in that step or the one before (else on none); a non-finite wrench at a finite state on its
    element. From then on the world's forces are NaN, so its state is too: a diverged world never
    looks like a result. A world's run restarts when its time runs backwards (a reset).
    """
    return flexures(m).divergences(m, d)


def diverged(m, d) -> np.ndarray:
    """``(nworld,)`` bool: the worlds of ``d`` that diverged in their current run."""
    return flexures(m).diverged(d)

"""mjflex on MuJoCo Warp: the flexure forces of thousands of worlds per step, on a GPU or Warp's CPU device.

``pip install "mjflex[warp]"`` installs MuJoCo Warp (``mujoco-warp``) and NVIDIA Warp
(``warp-lang``); nothing else in mjflex imports them. :func:`put_model` gives MuJoCo Warp's
model with mjflex's passive callback; ``mujoco_warp.make_data`` and ``mujoco_warp.step`` do
the rest::

    mjmodel = mujoco.MjModel.from_xml_path("models/two_body.xml")
    m = mjflex.warp.put_model(mjmodel)
    d = mujoco_warp.make_data(mjmodel, nworld=1024)
    mujoco_warp.step(m, d)
    mjflex.warp.divergences(m, d)  # []: no world diverged

What is there: both methods (finite twist, dual quaternion), damping, planar elements,
polynomial terms, end stops, rest offsets, elements on free bodies and on bodies moved by any
chain of joints, MuJoCo's spring/damper disable flags, both forms of elements in MJCF (text
records and ``mjflex.flexure`` plugin instances), per-world K, B, switches and end stops
(:func:`set_parameters`), per-world divergence records naming the element and the step
(:func:`divergences`), the element math in float32 (MuJoCo Warp's precision) or float64. What
is not: an element feature the kernels do not implement is refused by :func:`put_model` naming
the element and the feature; MuJoCo Warp integrates in float32 only (no float64 simulation: use
MuJoCo itself for that).

Data of another model is refused by every function here (ValueError naming the sizes): make the
data from the MuJoCo model given to :func:`put_model`. The functions are the API; the
:class:`WarpFlexures` a model carries describes its elements (names, records, parameters).
"""

import copy
import logging

import mujoco
import mujoco_warp as mjw
import numpy as np

from ..core.docstrings import with_shared_docstring
from . import _adapt, _mjflex
from ._forces import WarpFlexures, WorldDivergence
from ._mjflex import ElementTable, UnsupportedElementError

__all__ = [
    "ElementTable",
    "UnsupportedElementError",
    "WarpFlexures",
    "WorldDivergence",
    "clear_divergences",
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
#: What the functions' docstrings share, filled in by _shared_doc for a line ``{name}``: the Parameters entries of
#: ``m`` and ``d``, and the examples' set-up (the two-body model; its body B turned by 0.1 rad; two worlds so).
_SHARED = {
    "m_and_d": """\
    Parameters
    ----------
    m : mujoco_warp.Model
        A model made by :func:`put_model`.
    d : mujoco_warp.Data
        Its data, read as it is (after ``mujoco_warp.forward`` or a step, or ``mujoco_warp.put_data``).
""",
    "model": """\
    >>> import mujoco, mujoco_warp as mjw, numpy as np
    >>> import mjflex.warp
    >>> from mjflex.mjcf.elements import EXAMPLE_MODEL  # two free bodies joined by the element "hinge"
    >>> mjmodel = mujoco.MjModel.from_xml_string(EXAMPLE_MODEL)
    >>> m = mjflex.warp.put_model(mjmodel)
""",
    "turned": """\
    {model}
    >>> mjdata = mujoco.MjData(mjmodel)
    >>> mjdata.qpos[10:14] = [np.cos(0.05), 0, 0, np.sin(0.05)]  # B turned by 0.1 rad about z
    >>> mujoco.mj_forward(mjmodel, mjdata)
""",
    "two_turned_worlds": """\
    {turned}
    >>> d = mjw.put_data(mjmodel, mjdata, nworld=2)  # two worlds in that state
""",
}


_shared_doc = with_shared_docstring(_SHARED)


@_shared_doc
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

    Examples
    --------
    {model}
    >>> mjflex.warp.flexures(m)
    WarpFlexures(1 elements: hinge; float32)
    >>> d = mjw.make_data(mjmodel, nworld=1024)  # mjw.step(m, d) steps 1024 worlds with the element's forces
    """
    if not isinstance(mjmodel, mujoco.MjModel):
        raise TypeError(f"put_model expects a mujoco.MjModel; got {type(mjmodel).__name__}")
    if precision not in PRECISIONS:
        raise ValueError(f"precision must be one of {PRECISIONS}; got {precision!r}")
    model = copy.copy(mjmodel)
    table = element_table(model)
    adaptations = _adapt.check_plugins(model) + _adapt.adapt_sleep(model, table) + _adapt.adapt_flags(model)
    try:
        with _adapt.plugin_arrays_sized(model):
            m = mjw.put_model(model, batch_sizes=batch_sizes)
    except (NotImplementedError, ValueError) as exc:
        exc.add_note("mjflex.warp.put_model: MuJoCo Warp cannot run this model (see its message above)")
        raise
    m.callback.passive = WarpFlexures(table, model, precision, adaptations)
    for line in adaptations:
        log.info("mjflex.warp.put_model: %s", line)
    return m


def element_table(mjmodel: mujoco.MjModel, flex=None) -> ElementTable:
    """The elements of ``mjmodel`` as the Warp kernels read them.

    Parameters
    ----------
    mjmodel : mujoco.MjModel
        A model with mjflex elements (either form). :class:`mjflex.Flexures` sets the automatic
        sleep policy of trees joined by an element to "never" on the model it reads: pass a copy
        to leave a model as it is.
    flex : mjflex.Flexures, optional
        Its provider, if made (else made here).

    Returns
    -------
    ElementTable
        The elements' arrays, parameters as written in the model.

    Raises
    ------
    UnsupportedElementError
        An element feature the kernels lack (named with the element).

    Examples
    --------
    >>> import copy, mujoco
    >>> import mjflex.warp
    >>> from mjflex.mjcf.elements import EXAMPLE_MODEL
    >>> table = mjflex.warp.element_table(copy.copy(mujoco.MjModel.from_xml_string(EXAMPLE_MODEL)))
    >>> table.names, table.K.shape, float(table.K[0, 2, 2])
    (('hinge',), (1, 6, 6), 0.25)
    """
    return _mjflex.element_table(mjmodel, flex)


def flexures(m) -> WarpFlexures:
    """The :class:`~mjflex.warp.WarpFlexures` of a model made by :func:`~mjflex.warp.put_model`: its elements,
    parameters and notes.

    Parameters
    ----------
    m : mujoco_warp.Model
        A model made by :func:`put_model` (TypeError otherwise).

    Returns
    -------
    WarpFlexures
        The model's passive callback.

    Examples
    --------
    >>> import mujoco
    >>> import mjflex.warp
    >>> from mjflex.mjcf.elements import EXAMPLE_MODEL
    >>> forces = mjflex.warp.flexures(mjflex.warp.put_model(mujoco.MjModel.from_xml_string(EXAMPLE_MODEL)))
    >>> forces.names, forces.precision, sorted(forces.parameters())
    (('hinge',), 'float32', ['B', 'K', 'enabled', 'stop_lower', 'stop_stiffness', 'stop_upper', 'viscous'])
    """
    forces = getattr(getattr(m, "callback", None), "passive", None)
    if not isinstance(forces, WarpFlexures):
        raise TypeError(
            "this MuJoCo Warp model has no mjflex callback: make it with mjflex.warp.put_model(mjmodel), not "
            "mujoco_warp.put_model"
        )
    return forces


@_shared_doc
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
    The leading size of each parameter must be 1 or the data's ``nworld`` (0 is refused here;
    the data's is checked at every step, ValueError otherwise; the stops' limits and stiffness
    must agree among themselves, and a derived stiffness has K's). Parameters not given keep
    their values. Takes effect at the next step. Which elements run the stops' code is set
    here: an element without a finite limit in any world skips it at one flag.

    Examples
    --------
    Four worlds, the hinge turned by 0.1 rad in each, its rotation about z stopped at 0.05, 0.08
    and 0.12 rad in the first three (the stops' stiffness derived from K: 100 K_zz = 25 N m/rad):

    {turned}
    >>> d = mjw.put_data(mjmodel, mjdata, nworld=4)
    >>> lower, upper = np.full((4, 1, 6), -np.inf), np.full((4, 1, 6), np.inf)  # (worlds, elements, 6)
    >>> upper[:3, 0, 2] = [0.05, 0.08, 0.12]
    >>> mjflex.warp.set_parameters(m, stop_lower=lower, stop_upper=upper)
    >>> print(mjflex.warp.potential_energies(m, d)[:, 0].round(5))  # [J]: K's 0.00125 and the stops'
    [0.0325  0.00625 0.00125 0.00125]
    """
    flexures(m)._set_parameters(K=K, B=B, enabled=enabled, viscous=viscous, stop_lower=stop_lower,
                               stop_upper=stop_upper, stop_stiffness=stop_stiffness)  # fmt: skip


@_shared_doc
def wrenches(m, d) -> np.ndarray:
    """Wrench of each element on its body B in each world.

    {m_and_d}

    Returns
    -------
    ndarray, shape (nworld, n, 6)
        Moment about the origin of frame b and force, world axes [N m; N], in the precision of
        the element math.

    Examples
    --------
    {two_turned_worlds}
    >>> print(mjflex.warp.wrenches(m, d)[0, 0].round(4) + 0.0)  # -K_zz 0.1 about z
    [ 0.     0.    -0.025  0.     0.     0.   ]
    """
    return flexures(m)._wrenches(m, d)


@_shared_doc
def generalized_forces(m, d) -> np.ndarray:
    """The generalized forces the elements add to ``qfrc_passive`` in each world.

    {m_and_d}

    Returns
    -------
    ndarray, shape (nworld, nv)
        float32, MuJoCo Warp's precision.

    Examples
    --------
    {two_turned_worlds}
    >>> print(mjflex.warp.generalized_forces(m, d)[0, [5, 11]].round(4) + 0.0)  # on A's and B's rotation about z
    [ 0.025 -0.025]
    """
    return flexures(m)._generalized_forces(m, d)


@_shared_doc
def potential_energies(m, d) -> np.ndarray:
    """Elastic energy of each element in each world, end stops included.

    {m_and_d}

    Returns
    -------
    ndarray, shape (nworld, n)
        [J], in the precision of the element math.

    Examples
    --------
    {two_turned_worlds}
    >>> print(mjflex.warp.potential_energies(m, d)[:, 0].round(6))  # K_zz 0.1^2 / 2
    [0.00125 0.00125]
    """
    return flexures(m)._potentials_and_twists(m, d)[0]


@_shared_doc
def dissipation_powers(m, d) -> np.ndarray:
    """Power dissipated by each element's damping in each world.

    {m_and_d}

    Returns
    -------
    ndarray, shape (nworld, n)
        [W], zero for an element without damping (or switched off).

    Examples
    --------
    {two_turned_worlds}
    >>> B = np.array([1e-3, 1e-3, 1e-3, 1.0, 1.0, 1.0])  # damping (diagonal) of the one element
    >>> mjflex.warp.set_parameters(m, B=[[B], [2 * B]], viscous=[True])  # world 1's twice world 0's
    >>> mjdata.qvel[11] = 2.0  # B turning about z at 2 rad/s
    >>> mujoco.mj_forward(mjmodel, mjdata)
    >>> d = mjw.put_data(mjmodel, mjdata, nworld=2)
    >>> print(mjflex.warp.dissipation_powers(m, d)[:, 0].round(6))  # B_zz omega^2
    [0.004 0.008]
    """
    return flexures(m)._dissipation_powers(m, d)


@_shared_doc
def displacements(m, d) -> np.ndarray:
    """Finite twist ``[tau; t]`` of frame b relative to frame a of each element in each world.

    {m_and_d}

    Returns
    -------
    ndarray, shape (nworld, n, 6)
        [rad; m] (zero for an element switched off, as :meth:`mjflex.Flexures.displacements`).

    Examples
    --------
    {two_turned_worlds}
    >>> print(mjflex.warp.displacements(m, d)[0, 0].round(6) + 0.0)
    [0.  0.  0.1 0.  0.  0. ]
    """
    return flexures(m)._potentials_and_twists(m, d)[1]


@_shared_doc
def stop_coordinates(m, d) -> np.ndarray:
    """The coordinates end stops act on, ``[rx, ry, rz, x, y, z]`` of each element in each world.

    The rotation vector of frame b relative to frame a and the position of frame b's origin in
    frame a (:mod:`mjflex.core.stops`), for every element (with or without stops; planar ones in
    ``rz, x, y``), as :meth:`mjflex.Flexures.stop_coordinates`. Compare them with
    ``flexures(m).parameters()["stop_lower"]`` and ``["stop_upper"]`` to see which stops are
    engaged; their energy is part of :func:`potential_energies`.

    {m_and_d}

    Returns
    -------
    ndarray, shape (nworld, n, 6)
        [rad; m].

    Examples
    --------
    {two_turned_worlds}
    >>> print(mjflex.warp.stop_coordinates(m, d)[0, 0].round(6) + 0.0)
    [0.  0.  0.1 0.  0.  0. ]
    """
    return flexures(m)._potentials_and_twists(m, d)[2]


@_shared_doc
def divergences(m, d) -> list[WorldDivergence]:
    """The worlds of ``d`` that diverged in their current run: world, element blamed, step index, message.

    Judged in every evaluation of the forces: a qpos or qvel that is not finite or beyond 1e10
    (MuJoCo's bound) is blamed on the element whose force alone accelerated a body beyond 1e8
    in that step or the one before (else on none); a non-finite wrench at a finite state on its
    element. From then on the world's forces are NaN, so its state is too: a diverged world never
    looks like a result. A world's run restarts when its time runs backwards (a reset).

    {m_and_d}

    Returns
    -------
    list of WorldDivergence
        In world order; empty when none diverged.

    Examples
    --------
    {two_turned_worlds}
    >>> qvel = d.qvel.numpy()
    >>> qvel[1, 0] = np.nan  # world 1 blew up
    >>> d.qvel.assign(qvel)
    >>> m.callback.passive(m, d)  # what mujoco_warp.forward and step call
    >>> [(v.world, v.element, v.step, v.reason) for v in mjflex.warp.divergences(m, d)]
    [(1, '', 0, "MuJoCo Warp's qvel became non-finite or beyond 1e10")]
    """
    return flexures(m)._divergences(m, d)


@_shared_doc
def diverged(m, d) -> np.ndarray:
    """Which worlds of ``d`` diverged in their current run (see :func:`~mjflex.warp.divergences`).

    {m_and_d}

    Returns
    -------
    ndarray of bool, shape (nworld,)

    Examples
    --------
    {two_turned_worlds}
    >>> qvel = d.qvel.numpy()
    >>> qvel[0, 0] = 1e12  # beyond MuJoCo's bound on a sane velocity
    >>> d.qvel.assign(qvel)
    >>> m.callback.passive(m, d)
    >>> mjflex.warp.diverged(m, d)
    array([ True, False])
    """
    forces = flexures(m)
    forces._state(m, d)  # checks d against the model
    return forces._diverged(d)


@_shared_doc
def clear_divergences(m, d) -> None:
    """Forget the divergence records of ``d``: every world starts a new run.

    A world's run also restarts by itself when its time runs backwards (a reset); this clears
    all of them at once, e.g. after setting a new state with ``d.qpos.assign``.

    Parameters
    ----------
    m : mujoco_warp.Model
        A model made by :func:`put_model`.
    d : mujoco_warp.Data
        Its data.

    Examples
    --------
    {model}
    >>> d = mjw.put_data(mjmodel, mujoco.MjData(mjmodel), nworld=2)
    >>> qvel = d.qvel.numpy()
    >>> qvel[0, 0] = np.nan
    >>> d.qvel.assign(qvel)
    >>> m.callback.passive(m, d)
    >>> mjflex.warp.diverged(m, d)
    array([ True, False])
    >>> mjflex.warp.clear_divergences(m, d)
    >>> mjflex.warp.diverged(m, d)
    array([False, False])
    """
    forces = flexures(m)
    forces._state(m, d)  # checks d against the model
    forces._clear_divergences(d)

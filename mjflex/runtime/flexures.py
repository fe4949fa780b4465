"""The passive-force provider: parse a model's flexures once, then add their forces every step."""

import warnings

import mujoco
import numpy as np

from ..core import validation
from ..core.stops import stop_coordinates
from ..mjcf import naming
from ..mjcf.notices import warn_likely_mistake
from ..mjcf.schema import PLUGIN
from ..native import library
from . import plausibility, registry, tables
from .divergence import Divergence, divergences_of, model_name, step_index
from .tables import ModelError

__all__ = ["Flexures"]

_SLEEP = mujoco.mjtSleepPolicy
_SLEEPY = {int(_SLEEP.mjSLEEP_ALLOWED), int(_SLEEP.mjSLEEP_INIT)}  # the user's explicit choices
_AUTO = {int(_SLEEP.mjSLEEP_AUTO), int(_SLEEP.mjSLEEP_AUTO_ALLOWED)}  # the compiler's

#: dtype of :meth:`Flexures.results`: one row per element.
RESULTS_DTYPE = np.dtype(
    [("name", object), ("wrench", np.float64, (6,)), ("displacement", np.float64, (6,)),
     ("energy", np.float64), ("power", np.float64), ("enabled", bool), ("method", "U8")]
)  # fmt: skip


_WARNED = set()  # the deprecated names used (each warns once)


def _snapshot(model) -> np.ndarray:
    """The bytes of the model fields the element reader uses (``mjflex/native/states.h``)."""
    native = library.lib()
    out = np.zeros(native.mjfx_snapshot_size(model._address) + 1, np.uint8)
    native.mjfx_snapshot_take(model._address, out.ctypes.data)
    return out


def _restore(model, copies, enabled, viscous, methods):
    """Unpickle a :class:`Flexures`: rebuilt from its model, with its switches and served copies."""
    flex = Flexures(model)
    for key, values in (("enabled", enabled), ("viscous", viscous), ("method", methods)):
        flex._elements[key][: len(values)] = values
    return flex.serve(copies) if copies else flex


class Flexures:
    """Visco-elastic flexure elements of a MuJoCo model and the passive forces they add.

    Parameters
    ----------
    model : mujoco.MjModel
        A model whose elements are written in its file as described in
        :mod:`mjflex.mjcf.schema`: text records (sites ``E/a``, ``E/b`` and a text record
        ``mjflex:E``), instances of the engine plugin ``mjflex.flexure``, or both (text records
        come first in the per-element arrays). All elements are parsed and validated here,
        once; a malformed one raises :class:`ModelError`.

    Attributes
    ----------
    model : mujoco.MjModel
        The model read (its elements are served on it; copies through :meth:`serve`).
    names : tuple of str
        The elements' names, in row order (text records first, then plugin instances):
        every per-element array follows it (:meth:`index` finds a row).
    records : list of mjflex.FlexureRecord
        Each element's parameters as written in the model, in row order: ``K``, ``B`` (element
        frame, SI), ``method``, ``stops``, polynomial ``terms``, ``site``, ``source``, ...

    Notes
    -----
    Engine-plugin elements: their forces belong to the model (every copy, ``Batch``,
    ``mujoco.rollout``, the viewer), so ``install()`` / ``with flex:`` / :meth:`serve` leave them
    alone: for them these are documented no-ops, so that code written for text-record models runs
    unchanged on plugin models (installing them again would add their forces twice). Their
    run-time switches are configuration attributes of the model: ``set_enabled`` & co. raise and
    say how to change them. Everything that reads a ``data`` works on both kinds alike, through
    the same C code as the forces.

    Text-record elements: ``install()`` (or ``with flex:``) adds the elements' generalized forces to
    ``data.qfrc_passive`` inside every ``mj_step`` / ``mj_forward`` of this model (and of the
    copies given to :meth:`serve`), for every integrator and any kinematic tree. The functions
    that read a ``data`` (``wrenches``, ``potential_energy``, ...) use its kinematics as they are
    (``site_xpos``, ``cvel``...), i.e. as of the last ``mj_forward`` or the start of the last
    ``mj_step``, like ``data.energy``. MuJoCo's ``spring`` / ``damper`` disable flags switch off
    the elastic / viscous parts.

    Installation nests: ``install`` / ``uninstall`` are counted per provider (an inner
    ``with flex:`` leaves the outer one installed), and when several providers of one model are
    installed, the innermost (last installed) serves it; uninstalling it hands the model back to
    the outer one. A provider is bound to its ``MjModel`` object; a copy of it (``copy.copy``,
    the models of a ``mujoco.batch.Batch``) gets the forces once given to :meth:`serve`.
    A ``Flexures`` pickles (for process pools, Dask, Ray): it is rebuilt from its model on
    unpickling, with its switches and served copies, and arrives uninstalled.

    Sleeping (``<flag sleep="enable"/>``): MuJoCo ignores forces on sleeping trees and wakes
    trees only in the position stage, so a passive callback cannot wake one. Trees joined by an
    element to another tree (or to a mocap body) therefore never sleep: their automatic policy
    is set to "never" here, as MuJoCo's compiler does for trees coupled by stiff tendons; an
    explicit ``sleep="allowed"`` or ``"init"`` on such a tree is kept, with a warning at install.

    Contacts: MuJoCo collides the bodies an element joins unless their pair is excluded
    (``<contact><exclude body1 body2/></contact>``, which :func:`mjflex.add_flexure` writes) or
    their geoms cannot collide. At construction a warning names the elements whose two bodies
    MuJoCo's own collision detection finds in contact at ``qpos0`` or a keyframe (every collision
    rule counts: contype/conaffinity, the parent filter, excludes, explicit pairs, margins). A
    second warning names the body pairs that touch there only because the joints under an element
    un-weld a body from its parent (MuJoCo's parent filter works on weld groups, so the body now
    meets its grandparent), with the ``<exclude>`` elements that restore the rigid model's
    filtering (:func:`mjflex.make_compliant` writes them).

    Integrators: the forces enter every integrator explicitly, as external smooth forces
    (MuJoCo takes no user derivatives into its implicit updates), so the time step must resolve
    the stiffest element mode: about ``h < 2 / omega_max`` (Euler, implicit, implicitfast,
    discrete) and ``h < 2 sqrt(2) / omega_max`` (RK4, 2.83 / omega_max); :func:`mjflex.step_advice` gives it.
    Convergence is first order for the single-step integrators and fourth order for RK4
    (tested). Under ``discrete`` the velocity-stepping solve treats them like any applied force:
    first order, no position-implicit stabilization of the flexures, and ``qacc`` is the step
    map ``(v+ - v)/h``.

    Divergence (:mod:`mjflex.runtime.divergence` has the rules): at any finite state the forces are
    finite and exact (``mj_forward``, ``mj_inverse`` at large deflections). A non-finite wrench
    sets ``qfrc_passive`` to NaN and is reported at once; a step that MuJoCo finds bad (NaN or
    beyond 1e10 in ``qpos``/``qvel``/``qacc``) is blamed on the element whose force alone
    accelerated a body the most. The report names the element and "the step from t = ... s (step
    index k, counting from 0)": a warning with MuJoCo's auto-reset on (its default; MuJoCo then
    resets), or in ``mujoco.rollout``'s worker threads, where an error would end the process;
    with auto-reset disabled ``mujoco.FatalError`` from ``mj_step`` (``mujoco.batch.SimulationError``
    from a ``Batch``). Each element is printed once per run of an ``MjData`` (until
    ``mj_resetData``); repeats are counted: :meth:`divergences`.

    Examples
    --------
    Two blocks joined by one element (the model file ``models/two_body.xml`` of the repository, built here), simulated
    for a millisecond with the provider installed, then read:

    >>> import mujoco
    >>> import mjflex
    >>> spec = mujoco.MjSpec.from_string(
    ...     '<mujoco><option timestep="2e-5" gravity="0 0 0"/><worldbody>'
    ...     '<body name="A"><freejoint/><geom type="box" size="0.045 0.01 0.01" density="2700"/></body>'
    ...     '<body name="B" pos="0.1 0 0"><freejoint/><geom type="box" size="0.045 0.01 0.01" density="2700"/></body>'
    ...     "</worldbody></mujoco>"
    ... )
    >>> _ = mjflex.add_flexure(spec, "hinge", "A", "B", pos=[0.05, 0, 0], K=[0.3, 40, 0.25, 5e6, 3e5, 1.5e6])
    >>> model = spec.compile()
    >>> flex = mjflex.Flexures(model)
    >>> data = mujoco.MjData(model)
    >>> data.qvel[9:12] = [0, 0, 20]  # B spins about the hinge axis z at 20 rad/s
    >>> with flex:  # the passive-force callback (a no-op for engine-plugin elements)
    ...     mujoco.mj_step(model, data, nstep=50)
    >>> mujoco.mj_forward(model, data)
    >>> flex.names, flex.wrenches(data).shape
    (('hinge',), (1, 6))
    >>> print(f"rotation about z {flex.displacements(data)[0, 2]:.3f} rad, energy {flex.potential_energy(data):.1e} J")
    rotation about z 0.020 rad, energy 3.8e-03 J
    """

    def __init__(self, model: mujoco.MjModel):
        if not isinstance(model, mujoco.MjModel):
            hint = " (pass data.model, or the model you made the data from)" if isinstance(model, mujoco.MjData) else ""
            raise TypeError(f"Flexures expects a mujoco.MjModel; got {type(model).__name__}{hint}")
        self.model = model
        self._copies = ()
        self._depth = 0
        self._tables = t = tables.derive(model)
        self.names, self.records = t.names, t.records
        self._index = {name: i for i, name in enumerate(self.names)}
        self._elements = t.elements  # the C loop's table (one row per element; switches live here)
        self._fingerprints = {model._address: tables.fingerprint(model)}
        for message in tables.contact_warnings(model, t):
            warnings.warn(message, UserWarning, stacklevel=2)
        for message in plausibility.implausible_stiffness(model, t.records, t.elements[: len(self.names)]):
            warn_likely_mistake(message, stacklevel=plausibility.outside_stacklevel())  # the user's line
        self._sleep_policy(model)
        self._snapshot = _snapshot(model)  # what the queries compare flex.model with (an in-place edit since)
        self._watches = {}  # model address -> the native per-mjData divergence watches of a served model (a buffer)

    def __reduce__(self):
        el = self._elements[: len(self)]
        switches = (el["enabled"].copy(), el["viscous"].copy(), el["method"].copy())
        return _restore, (self.model, tuple(self._copies), *switches)

    @property
    def kinds(self) -> tuple[str, ...]:
        """How each element is written in the model: ``"record"`` (text record) or ``"plugin"`` (engine plugin)."""
        return self._tables.kinds

    @property
    def element_table(self) -> tables.Tables:
        """The compiled model's element table, as the C library reads it (:class:`mjflex.runtime.tables.Tables`):
        for other engines (:mod:`mjflex.warp`). Its ``elements`` rows hold the run-time switches; change them
        through :meth:`set_enabled`, :meth:`set_viscous` and :meth:`set_method` only."""
        return self._tables

    def _registered(self) -> registry.Served:
        """What the registry serves for this provider (its text-record elements)."""
        return registry.Served(self.names, self._tables, self._watches_for)

    def _watches_for(self, model):
        """The native divergence watches of ``model``, one buffer (kept across installs: a run outlives them)."""
        watches = self._watches.get(model._address)
        if watches is None:
            native, n = library.lib(), self._served
            watches = self._watches[model._address] = np.zeros(native.mjfx_registry_watches_size(n), np.uint8)
            native.mjfx_registry_watches_init(watches.ctypes.data, n)
        return watches

    @property
    def _served(self) -> int:
        """Number of text-record elements (the first ones): the ones ``install`` adds."""
        return self._tables.served

    # ------------------------------------------------------------------ building

    def _sleep_policy(self, model):
        """Keep trees joined to another tree awake (see the class notes); returns what stays sleepy."""
        sleepy = {}
        for tree, element in self._tables.joined_trees.items():
            policy = int(model.tree_sleep_policy[tree])
            if policy in _AUTO:
                model.tree_sleep_policy[tree] = int(_SLEEP.mjSLEEP_AUTO_NEVER)
            elif policy in _SLEEPY:
                sleepy[tree] = element
        return sleepy

    def _warn_sleepy(self, model):
        sleepy = self._sleep_policy(model)
        if sleepy and model.opt.enableflags & mujoco.mjtEnableBit.mjENBL_SLEEP:
            tree, element = next(iter(sleepy.items()))
            root = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, model.tree_bodyadr[tree]) or f"#{tree}"
            warnings.warn(
                f"mjflex: flexure '{element}' joins tree '{root}' (and {len(sleepy) - 1} more), whose sleep policy "
                "allows sleeping: MuJoCo ignores forces on a sleeping tree and a passive callback cannot wake it "
                "(MuJoCo wakes trees in the position stage), so the element's force is lost while it sleeps. "
                'Set sleep="auto" or "never" on the tree\'s root body, or disable sleeping.',
                UserWarning,
                stacklevel=4,
            )

    def _check_model(self, model, what):
        """Raise unless ``model`` still holds this provider's elements where they were built."""
        digest = tables.fingerprint(model)
        if self._fingerprints.get(model._address) == digest or (
            model is not self.model and self._fingerprints.get(self.model._address) == digest
        ):  # unchanged, or a byte-identical copy of flex.model
            return
        fix = (
            "An element is unstressed at the pose its sites had when the Flexures was built (mjflex has no "
            "pre-stress), and a provider serves only copies of its model: build a new mjflex.Flexures(model) "
            "after editing site, body or record data"
        )
        try:
            other = tables.derive(model)
        except ModelError as exc:
            raise ModelError(f"{what} changed since this Flexures was built: {exc} {fix}") from None
        diff = tables.difference(self._tables, other, self.model, model)
        if diff is not None:
            raise ModelError(f"{what}: {diff} since this Flexures was built. {fix}")
        self._fingerprints[model._address] = digest

    # ------------------------------------------------------------------ installation

    @property
    def models(self) -> tuple:
        """The models this provider adds forces to: its own, then the copies given to :meth:`serve`."""
        return (self.model, *self._copies)

    def serve(self, models) -> "Flexures":
        """Also add the forces to these copies of the model; returns ``self``.

        Parameters
        ----------
        models : mujoco.MjModel, sequence of mujoco.MjModel, or mujoco.batch.Batch
            Copies of ``flex.model`` (``copy.copy``, a pickled and restored model, a model
            compiled again from the same spec) that may differ in anything mjflex does not read
            (masses, options, ...) but must hold the same elements, sites and dofs; each is
            checked (:class:`ModelError` names the first difference). They replace the copies
            served before. A ``Batch`` is served on the models it steps: ``batch.models`` if set,
            else ``batch.set_models(flex.model)`` is called first (a Batch's own copy of the
            model is invisible to callbacks; a Batch with expanded per-simulation fields needs
            per-simulation copies: make them, edit them, ``set_models`` them, then serve the batch).

        Notes
        -----
        Serving ``n`` copies takes ``n`` of the process's ``mjflex.runtime.registry.CAPACITY``
        (1024) model slots; identical copies are best served as one model
        (``batch.set_models(flex.model)``). The run-time switches (``set_enabled``, ...) act on
        all served models. The provider keeps the copies alive; ``serve(())`` drops them.
        """
        models = self._models_of(models)
        for i, model in enumerate(models):
            self._check_model(model, f"model {i} given to serve()")
            self._sleep_policy(model)
        copies = tuple(m for m in dict.fromkeys(models) if m is not self.model)
        with registry.LOCK:
            if self._depth and self._served:
                registry.unregister(self, [m for m in self._copies if m not in copies])
                registry.register(self, [m for m in copies if m not in self._copies], self._registered())
            self._copies = copies
        return self

    def _models_of(self, models):
        batch = getattr(models, "set_models", None)
        if batch is not None:
            if models.models is None:
                self._check_model(models.model, "the Batch's model")
                try:
                    models.set_models(self.model)
                except (ValueError, mujoco.FatalError) as exc:
                    raise ValueError(
                        f"this Batch has per-simulation fields ({exc}); mjflex cannot see the model copies a Batch "
                        "makes for them. Give each simulation a copy (copies = [copy.copy(model) ...], edit them), "
                        "call batch.set_models(copies), then flex.serve(batch)"
                    ) from None
            models = models.models
        models = [models] if isinstance(models, mujoco.MjModel) else list(models)
        for model in models:
            if not isinstance(model, mujoco.MjModel):
                raise TypeError(f"serve() expects mujoco.MjModel copies of flex.model; got {type(model).__name__}")
        return models

    def install(self) -> "Flexures":
        """Start adding the forces in ``mj_step`` / ``mj_forward`` of the served models (counted, see Notes).

        Checks first that the models still hold the elements as built (edited site or body
        poses raise :class:`ModelError`) and warns about trees that may sleep. Engine-plugin
        elements are left alone (their forces are the model's own); a model with only those
        installs nothing.
        """
        with registry.LOCK:
            if self._depth == 0 and self._served:
                for i, model in enumerate(self.models):
                    self._check_model(model, "flex.model" if i == 0 else f"served model {i - 1}")
                    self._warn_sleepy(model)
                registry.register(self, self.models, self._registered())
            self._depth += 1
        return self

    def uninstall(self) -> None:
        """Undo one ``install``; the last one stops the forces (an outer provider of the model takes over).

        When no model is served any more, the passive callback that was there before is restored.
        """
        with registry.LOCK:
            if self._depth == 0:
                return
            self._depth -= 1
            if self._depth == 0 and self._served:
                registry.unregister(self, self.models)

    @property
    def installed(self) -> bool:
        """Whether the elements' forces are added to the model now (False if another callback replaced ours).

        Always True for a model whose elements are all engine-plugin instances (the forces are the
        model's own); False for a model without elements.
        """
        if not self._served:
            return bool(self.names)
        return registry.serving(self.model) is self and registry.dispatcher_installed()

    def __enter__(self):
        return self.install()

    def __exit__(self, *exc):
        self.uninstall()

    def __len__(self):
        return len(self.names)

    def __repr__(self):
        return f"Flexures({len(self)} elements: {', '.join(self.names[:5])}{', ...' if len(self) > 5 else ''})"

    # ------------------------------------------------------------------ evaluation

    def _check_data(self, data):
        if not isinstance(data, mujoco.MjData):
            raise TypeError(f"expected a mujoco.MjData of flex.model; got {type(data).__name__}")
        m = self.model
        sizes = (data.qpos.size, data.qvel.size, data.xpos.shape[0], data.site_xpos.shape[0])
        expected = (m.nq, m.nv, m.nbody, m.nsite)
        if sizes != expected:
            raise ValueError(
                f"data belongs to another model: (nq, nv, nbody, nsite) = {sizes}, but flex.model has {expected}; "
                "pass mujoco.MjData(flex.model), or build a Flexures for the data's model"
            )
        if not library.lib().mjfx_snapshot_same(m._address, self._snapshot.ctypes.data, 1):
            self._check_model(m, "flex.model")  # ModelError where an in-place edit changed the elements
            self._snapshot = _snapshot(m)

    def _query(self, data, mode) -> np.ndarray:
        """What the C loop gives in ``mode`` on ``data``: ``(nv,)`` for APPLY, ``(n, 6)`` for WRENCH and COORDS, else
        ``(n,)``; FatalError naming the first element whose wrench is not finite."""
        self._check_data(data)
        n, t = len(self), self._tables
        slot = {library.APPLY: "qfrc", library.WRENCH: "out6", library.COORDS: "out6"}.get(mode, "out1")
        out = np.zeros(self.model.nv) if slot == "qfrc" else np.empty((n, 6) if slot == "out6" else n)
        status = library.evaluate(self.model, data, t.elements, t.chain, t.exps, t.coefs, mode, n=n, **{slot: out})
        if status >= 0:
            h = self.model.opt.timestep
            raise mujoco.FatalError(
                f"mjflex: flexure '{self.names[status]}' of model '{model_name(self.model)}': its wrench is not "
                f"finite at t = {data.time:.9g} s (step index {step_index(data.time, h)}, counting from 0): the state "
                "is NaN or infinite, or the forces overflow float64. Check the qpos/qvel you set, or reduce the time "
                "step (mjflex.step_advice(model) gives the largest stable one)."
            )
        return out

    def divergences(self, data) -> dict[str, Divergence]:
        """The divergences of each element in the current run of ``data`` (those that diverged at least once).

        A run is ``data`` from its creation or the last ``mj_resetData`` on (:mod:`mjflex.runtime.divergence`):
        the first divergence of an element is printed, the repeats (MuJoCo's auto-reset restarting
        a diverging model) are only counted here. For the ``mjcb_passive`` provider a bad step that
        MuJoCo found in the last ``mj_step`` is included (``pending``) before its next evaluation
        reports it. Elements not installed on ``data``'s model count nothing.
        """
        self._check_data(data)
        return divergences_of(self.model, data, self.names, self._served, self._watches.get(self.model._address))

    def index(self, name) -> int:
        """Row of element ``name`` (or the row ``name`` itself, an int) in the per-element arrays."""
        if isinstance(name, str):
            try:
                return self._index[name]
            except KeyError:
                raise KeyError(f"no flexure named {name!r}" + naming.suggestion(name, self.names, "flexures")) from None
        if isinstance(name, int | np.integer) and not isinstance(name, bool | np.bool_):
            if not 0 <= name < len(self):
                raise IndexError(
                    f"flexure index {int(name)} is out of range: there are {len(self)} (0 .. {len(self) - 1})"
                )
            return int(name)
        raise TypeError(
            f"an element is named by its name (str, one of flex.names) or its row (int); got "
            f"{validation.shorten(name)} ({type(name).__name__})"
        )

    def wrenches(self, data) -> np.ndarray:
        """Wrench of each element on its body B, ``(n, 6)``: ``[moment about site b; force]``, world axes [N m; N]."""
        return self._query(data, library.WRENCH)

    def generalized_forces(self, data) -> np.ndarray:
        """Generalized forces ``(nv,)`` the elements add to ``qfrc_passive`` in this state."""
        return self._query(data, library.APPLY)

    def potential_energies(self, data) -> np.ndarray:
        """Elastic energy of each element, ``(n,)`` [J]."""
        return self._query(data, library.ENERGY)

    def potential_energy(self, data) -> float:
        """Total elastic energy of the elements [J]."""
        return float(self.potential_energies(data).sum())

    def dissipation_powers(self, data) -> np.ndarray:
        """Power dissipated by each element's damping, ``(n,)`` [W] (non-negative)."""
        return self._query(data, library.POWER)

    def dissipation_power(self, data) -> float:
        """Total power dissipated by the elements [W]: the rate at which they remove energy."""
        return float(self.dissipation_powers(data).sum())

    def displacements(self, data) -> np.ndarray:
        """Finite twist ``[tau; t]`` of frame b relative to frame a for each element, ``(n, 6)`` [rad; m]."""
        return self._query(data, library.COORDS)

    def stop_coordinates(self, data) -> np.ndarray:
        """The coordinates end stops act on, ``(n, 6)``: ``[rx, ry, rz, x, y, z]`` of each element [rad; m].

        The rotation vector of frame b relative to frame a and the position of frame b's origin in
        frame a (:mod:`mjflex.core.stops`), for every element (with or without stops; planar ones
        in ``rz, x, y``), as of the last ``mj_kinematics``. Compare them with ``flex.records[i].stops``
        to see which stops are engaged; their energy is part of :meth:`potential_energies`.
        """
        self._check_data(data)
        el = self._elements[: len(self)]
        R_a, p_a = data.site_xmat[el["site_a"]].reshape(-1, 3, 3), data.site_xpos[el["site_a"]]
        R0 = el["R0"].reshape(-1, 3, 3)
        R_b = data.site_xmat[el["site_b"]].reshape(-1, 3, 3) @ np.swapaxes(R0, 1, 2)  # frame b* (rest offset removed)
        p_b = data.site_xpos[el["site_b"]] - np.einsum("nij,nj->ni", R_b, el["p0"])
        return stop_coordinates(R_a, p_a, R_b, p_b, check=False).reshape(len(self), 6)

    def results(self, data) -> np.ndarray:
        """Every per-element result at ``data``'s state in one labelled array, one row per element.

        (Its name was ``table`` until 1.0: "table" is the element table, :attr:`element_table`.)
        Fields (dtype ``RESULTS_DTYPE``): ``name``; ``wrench`` (6,) as :meth:`wrenches`;
        ``displacement`` (6,) as :meth:`displacements`; ``energy`` [J]; ``power`` [W];
        ``enabled``; ``method``. Select by name, e.g. ``t[t["name"] == "hinge"]["energy"]``;
        ``pandas.DataFrame({f: list(t[f]) for f in t.dtype.names})`` makes a data frame.
        """
        out = np.zeros(len(self), dtype=RESULTS_DTYPE)
        out["name"] = self.names
        out["wrench"] = self.wrenches(data)
        out["displacement"] = self.displacements(data)
        out["energy"] = self.potential_energies(data)
        out["power"] = self.dissipation_powers(data)
        out["enabled"], out["method"] = self.enabled, self.methods
        return out

    def table(self, data) -> np.ndarray:
        """Deprecated: :meth:`results` (a "table" is the element table, :attr:`element_table`)."""
        if "table" not in _WARNED:
            _WARNED.add("table")
            warnings.warn("Flexures.table is deprecated; use Flexures.results", DeprecationWarning, stacklevel=2)
        return self.results(data)

    # ------------------------------------------------------------------ element data

    @property
    def site_ids(self) -> np.ndarray:
        """Site ids ``(n, 2)`` of the frames a and b of each element."""
        el = self._elements[: len(self)]
        return np.stack([el["site_a"], el["site_b"]], axis=1).astype(np.int64).reshape(-1, 2)

    @property
    def body_ids(self) -> np.ndarray:
        """Body ids ``(n, 2)`` of the bodies A and B of each element."""
        el = self._elements[: len(self)]
        return np.stack([el["body_a"], el["body_b"]], axis=1).astype(np.int64).reshape(-1, 2)

    def _switchable(self, name):
        i = self.index(name)
        if self.kinds[i] == PLUGIN:
            raise ValueError(
                f"flexure {name!r} is an mjflex.flexure plugin instance: its switches and method are configuration "
                'attributes of the model (<config key="enabled" value="false"/>, "viscous", "method"); set them in '
                f"the spec before compiling, e.g. mjflex.edit_elements(spec, [{name!r}], viscous=False), or in the "
                "file"
            )
        return i

    # ------------------------------------------------------------------ run-time switches

    def set_enabled(self, name: str | int, enabled: bool) -> None:
        """Switch element ``name`` (or row ``name``) on or off (takes effect at the next step).

        ``enabled`` must be a bool (TypeError otherwise: ``bool("false")`` is True).
        """
        i, enabled = self._switchable(name), validation.check_flag(enabled, "enabled")
        self._elements[i]["enabled"] = enabled

    def set_viscous(self, name: str | int, viscous: bool) -> None:
        """Switch the damping of element ``name`` (or row ``name``) on or off; ``viscous`` a bool."""
        i, viscous = self._switchable(name), validation.check_flag(viscous, "viscous")
        if viscous and self.records[i].B is None:
            raise ValueError(
                f'flexure {self.names[i]!r} has no damping matrix B in the model; add "B" to its text record'
            )
        self._elements[i]["viscous"] = bool(viscous)

    def set_method(self, name: str | int, method: str) -> None:
        """Use ``"twist"`` or ``"dualquat"`` for element ``name`` (not for one with polynomial terms)."""
        i, code = self._switchable(name), validation.method_code(method)
        terms = self.records[i].terms
        if terms is not None and code != validation.METHOD_CODES[terms.method]:
            raise ValueError(
                f"flexure {self.names[i]!r} has polynomial terms in {terms.method} coordinates, which do not carry "
                f"over to {method}: fit (mjflex.fit_potential) or write terms for {method} in its record instead"
            )
        self._elements[i]["method"] = code

    @property
    def enabled(self) -> np.ndarray:
        """``(n,)`` bool: which elements act now (the record's ``enabled``, then :meth:`set_enabled`), in row order."""
        return self._elements["enabled"][: len(self)].astype(bool)

    @property
    def viscous(self) -> np.ndarray:
        """``(n,)`` bool: which elements add their damping ``B`` now (:meth:`set_viscous`), in row order."""
        return self._elements["viscous"][: len(self)].astype(bool)

    @property
    def methods(self) -> tuple[str, ...]:
        """Each element's method now, ``"twist"`` or ``"dualquat"`` (:meth:`set_method`), in row order."""
        return tuple(validation.METHOD_NAMES[int(c)] for c in self._elements["method"][: len(self)])

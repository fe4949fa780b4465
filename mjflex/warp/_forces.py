"""The passive callback of a MuJoCo Warp model: the elements' arrays on the device, their per-world
parameters, the launches, the queries and the per-world divergence records."""

import warnings
import weakref
from typing import NamedTuple

import mujoco
import numpy as np
import warp as wp

from ..core import validation
from ..mjcf import naming
from ..runtime.divergence import model_name
from . import _kernels as kn
from . import _stops, _watch
from ._mjflex import PLANAR_INDEX, ElementTable

_KIND_TEXT = {
    _watch.NONFINITE: "its wrench is not finite at a finite state",
    _watch.BAD_QPOS: "MuJoCo Warp's qpos became non-finite or beyond 1e10",
    _watch.BAD_QVEL: "MuJoCo Warp's qvel became non-finite or beyond 1e10",
}
_SPRING, _DAMPER = int(mujoco.mjtDisableBit.mjDSBL_SPRING), int(mujoco.mjtDisableBit.mjDSBL_DAMPER)
_FLOAT32_MAX = float(np.finfo(np.float32).max)
_OFF_PLANE = np.ones((6, 6), bool)
_OFF_PLANE[np.ix_(PLANAR_INDEX, PLANAR_INDEX)] = False


class WorldDivergence(NamedTuple):
    """The first divergence of one world in its current run (see :func:`mjflex.warp.divergences`).

    Attributes
    ----------
    world : int
        The world's index in the data.
    element : str
        The flexure blamed; ``''`` when no element's force alone was violent enough to blame.
    step : int
        Index of the step that diverged, counting from 0 (the step the C engine names).
    time : float
        The world's time when it was found [s] (MuJoCo Warp's float32 clock).
    reason : str
        What was found: a non-finite wrench at a finite state, or a qpos / qvel not finite or
        beyond MuJoCo's 1e10.
    message : str
        All of it in one sentence, with what to do.

    Examples
    --------
    >>> import mujoco, mujoco_warp as mjw, numpy as np
    >>> import mjflex.warp
    >>> from mjflex.mjcf.elements import EXAMPLE_MODEL
    >>> mjmodel = mujoco.MjModel.from_xml_string(EXAMPLE_MODEL)
    >>> m = mjflex.warp.put_model(mjmodel)
    >>> d = mjw.put_data(mjmodel, mujoco.MjData(mjmodel), nworld=3)
    >>> qpos = d.qpos.numpy()
    >>> qpos[2, 0] = np.inf  # world 2 is lost
    >>> d.qpos.assign(qpos)
    >>> m.callback.passive(m, d)  # what mujoco_warp.forward and step call
    >>> (found,) = mjflex.warp.divergences(m, d)
    >>> found.world, found.step, found.message[:62]
    (2, 0, 'mjflex.warp: world 2 diverged in the step from t = 0 s (step i')
    """

    world: int
    element: str  # the flexure blamed; '' when none was violent enough to blame
    step: int  # index of the step that diverged, counting from 0
    time: float  # the world's time when it was found [s] (MuJoCo Warp's float32 clock)
    reason: str
    message: str


class _DataState:
    """What one ``mujoco_warp.Data`` needs: the per-(world, element) results and the divergence watch."""

    def __init__(self, k, n, nworld, device):
        real = k["real"]
        shape = (nworld, max(n, 1))
        out = k["Out"]()
        out.mo, out.f = wp.zeros(shape, k["V3"], device=device), wp.zeros(shape, k["V3"], device=device)
        out.mom_a, out.mom_b = wp.zeros(shape, k["V3"], device=device), wp.zeros(shape, k["V3"], device=device)
        out.power = wp.zeros(shape, real, device=device)
        out.accel = wp.zeros(shape, wp.float32, device=device)
        out.finite = wp.ones(shape, wp.int32, device=device)
        self.out = out
        watch = _watch.Watch()
        for name, value, dtype in (("last_time", 0.0, wp.float32), ("step", 0, wp.int32), ("evals", -1, wp.int32),
                                   ("cand_element", -1, wp.int32), ("cand_accel", 0.0, wp.float32),
                                   ("cand_step", 0, wp.int32), ("element", -1, wp.int32), ("kind", 0, wp.int32),
                                   ("at_step", -1, wp.int32), ("time", 0.0, wp.float32),
                                   ("accel", 0.0, wp.float32)):  # fmt: skip
            setattr(watch, name, wp.full(nworld, value, dtype=dtype, device=device))
        self.watch = watch
        self.nworld = nworld


def _some_worlds(name, a):
    """``a`` ``(worlds, ...)``; ValueError if it has no world (the data's worlds could never match it)."""
    if a.shape[0] == 0:
        raise ValueError(
            f"{name} has 0 worlds (shape {a.shape}): give one set for all worlds (no leading axis) or one per world "
            "of the data (1 or nworld)"
        )
    return a


class WarpFlexures:
    """The flexure elements of a MuJoCo Warp model and the passive callback that adds their forces.

    Made by :func:`mjflex.warp.put_model`, which sets it as ``m.callback.passive``; reach it with
    :func:`mjflex.warp.flexures`. Called with ``(m, d)`` (by ``mujoco_warp.forward`` and
    ``step``), it adds the elements' generalized forces to ``d.qfrc_passive`` and watches every
    world for divergence. It describes the elements (``names``, ``records``, :meth:`parameters`);
    what is set or asked of the model and its data goes through :mod:`mjflex.warp`'s functions
    (``set_parameters(m, ...)``, ``wrenches(m, d)``, ...), one API: the methods of the same names
    that this class had are deprecated (each warns once, naming the function).

    Parameters
    ----------
    table : ElementTable
        The elements (:func:`mjflex.warp.element_table`).
    mjmodel : mujoco.MjModel
        The model MuJoCo Warp was given.
    precision : {"float32", "float64"}
        Precision of the element math.
    adaptations : sequence of str
        What :func:`~mjflex.warp.put_model` changed on ``mjmodel``.
    device : warp device or str, optional
        Where the element arrays live (default: Warp's current device).
    with_stops : bool
        False: kernels without the end stops' code, which refuse elements with stops (the
        baseline of ``scripts/bench_warp_stops.py``); mjflex runs the kernels with them.

    Attributes
    ----------
    names, kinds : tuple of str
        The elements' names, and their forms (``"record"`` or ``"plugin"``).
    records : list of mjflex.FlexureRecord
        Each element's parameters as written in the model.
    precision : str
        ``"float32"`` or ``"float64"``.
    mjmodel : mujoco.MjModel
        The adapted copy of the MuJoCo model that MuJoCo Warp was given.
    adaptations : tuple of str
        What :func:`~mjflex.warp.put_model` changed on it, and why.
    device : warp device
        Where the element arrays live.

    Examples
    --------
    >>> import mujoco
    >>> import mjflex.warp
    >>> from mjflex.mjcf.elements import EXAMPLE_MODEL
    >>> forces = mjflex.warp.flexures(mjflex.warp.put_model(mujoco.MjModel.from_xml_string(EXAMPLE_MODEL)))
    >>> forces.names, forces.kinds, forces.index("hinge"), forces.parameters()["K"].shape
    (('hinge',), ('record',), 0, (1, 1, 6, 6))
    """

    def __init__(self, table: ElementTable, mjmodel, precision: str, adaptations, device=None, with_stops=True):
        self.names, self.kinds, self.records = table.names, table.kinds, table.records
        self.mjmodel, self.precision, self.adaptations = mjmodel, precision, tuple(adaptations)
        self._index = {name: i for i, name in enumerate(self.names)}
        self._table = table
        self._with_stops = with_stops
        self._k = k = kn.kernels(precision, with_stops)
        self.device = wp.get_device(device)
        real = np.float64 if precision == "float64" else np.float32
        d = self.device
        el = k["Elements"]()
        n1 = max(len(self), 1)  # arrays are never empty (a valid address)

        def arr(a, dtype):
            a = np.asarray(a)
            if a.shape[0] == 0:
                a = np.zeros((n1, *a.shape[1:]), a.dtype)
            return wp.array(a.astype(real) if a.dtype.kind == "f" else a, dtype=dtype, device=d)

        el.ints = arr(table.ints, wp.int32)  # I_NCOL int32 columns
        el.qa, el.qb = arr(table.qa, k["Q4"]), arr(table.qb, k["Q4"])
        el.p0, el.lever_a, el.lever_b = arr(table.p0, k["V3"]), arr(table.lever_a, k["V3"]), arr(table.lever_b, k["V3"])
        el.inv_mass, el.inv_inertia = arr(table.inv_mass, k["real"]), arr(table.inv_inertia, k["real"])
        el.exps = wp.array(table.exps, dtype=wp.int32, device=d)
        el.coefs = arr(table.coefs, k["real"])
        el.series_c, el.series_g = arr(table.series_c, k["real"]), arr(table.series_g, k["real"])
        self._el = el
        self._start = wp.array(table.start, dtype=wp.int32, device=d)
        self._element = wp.array(table.element, dtype=wp.int32, device=d)
        self._code = wp.array(table.code, dtype=wp.int32, device=d)
        for e in range(len(self)):
            lo, hi = table.ints[e, kn.I_LO], table.ints[e, kn.I_HI]
            self._check_range(table.coefs[lo:hi], f"a polynomial term's coefficient of flexure '{self.names[e]}'")
        self._params = k["Params"]()
        self._real = real
        self._host = {}
        self._stop_k_given = None  # stop_stiffness as set (None: the model's, derived from K where it is)
        self._set_parameters(K=table.K, B=table.B, enabled=table.enabled, viscous=table.viscous,
                            stop_lower=table.stop_lower, stop_upper=table.stop_upper)  # fmt: skip
        _stops.set_damping(self._params, table, k["V6"], real, d)  # the model's, shared by the worlds
        self._states = {}
        self._no_watch = wp.zeros(0, dtype=wp.int32, device=d)

    def __len__(self):
        return len(self.names)

    def __repr__(self):
        more = ", ..." if len(self) > 5 else ""
        return f"WarpFlexures({len(self)} elements: {', '.join(self.names[:5])}{more}; {self.precision})"

    def index(self, name) -> int:
        """Row of element ``name`` in the per-element arrays."""
        try:
            return self._index[name]
        except KeyError:
            raise KeyError(f"no flexure named {name!r}" + naming.suggestion(name, self.names, "elements")) from None

    # ------------------------------------------------------------------ parameters

    def _set_parameters(
        self, *, K=None, B=None, enabled=None, viscous=None, stop_lower=None, stop_upper=None, stop_stiffness=None
    ) -> None:
        """Set the per-world parameters (see :func:`mjflex.warp.set_parameters`)."""
        n, fields = len(self), {}
        for name, value in (("K", K), ("B", B)):
            if value is not None:
                fields[name] = self._matrices(name, value)
        for name, value in (("enabled", enabled), ("viscous", viscous)):
            if value is not None:
                a = np.asarray(value)
                if a.dtype != bool:
                    raise TypeError(f"{name} must be booleans, (n,) or (worlds, n) with n = {n}; got {a.dtype}")
                if a.ndim == 1:
                    a = a[None]
                if a.ndim != 2 or a.shape[1] != n:
                    raise ValueError(f"{name} must have shape ({n},) or (worlds, {n}); got {np.shape(value)}")
                fields[name] = _some_worlds(name, a)
        given = self._stop_k_given
        if stop_stiffness is not None:
            given = _some_worlds("stop_stiffness", _stops.vectors("stop_stiffness", stop_stiffness, n))
        stops = {}
        if K is not None or stop_lower is not None or stop_upper is not None or stop_stiffness is not None:
            limits = [self._host.get(name) if value is None else _some_worlds(name, _stops.vectors(name, value, n))
                      for name, value in (("stop_lower", stop_lower), ("stop_upper", stop_upper))]  # fmt: skip
            k = _stops.stiffness(self._table, fields.get("K", self._host.get("K")), given)
            big = _FLOAT32_MAX if self.precision == "float32" else np.inf
            stops = dict(zip(_stops.NAMES, (*limits, _stops.effective(self.names, self._table.planar, *limits, k, big)),
                             strict=True))  # fmt: skip
        if stops and not self._with_stops and _stops.flags(stops["stop_lower"], stops["stop_upper"]).any():
            raise ValueError("these are kernels without the stops' code (a baseline for measuring their cost): they "
                             "cannot run elements with stops; use mjflex.warp.put_model")  # fmt: skip
        # everything checked: nothing below raises, so a refused call changes nothing
        self._stop_k_given = given
        fields.update(stops)
        k, p = self._k, self._params
        for name, a in fields.items():
            self._host[name] = a
            if len(self) == 0:
                a = np.zeros((1, 1, *a.shape[2:]))  # (worlds, 0, ...): one world, one element of zeros
            if name in ("K", "B"):
                setattr(p, name, wp.array(a.astype(self._real), dtype=k["M66"], device=self.device))
            elif name in stops:
                field = {"stop_lower": "stop_lo", "stop_upper": "stop_hi", "stop_stiffness": "stop_k"}[name]
                setattr(p, field, wp.array(np.ascontiguousarray(a, self._real), dtype=k["V6"], device=self.device))
            else:
                setattr(p, name, wp.array(a.astype(np.int32), dtype=wp.int32, device=self.device))
        if stops:
            flags = _stops.flags(stops["stop_lower"], stops["stop_upper"]) if len(self) else np.zeros(1, np.int32)
            p.stops = wp.array(flags, dtype=wp.int32, device=self.device)

    def _matrices(self, name, value):
        n = len(self)
        a = validation.numeric_array(value, name)
        if a.shape[-2:] != (6, 6) and a.shape[-1:] == (6,):
            a = a[..., :, None] * np.eye(6)  # diagonals
        if a.ndim == 3:
            a = a[None]
        if a.ndim != 4 or a.shape[1:] != (n, 6, 6):
            raise ValueError(
                f"{name} must have shape ({n}, 6, 6) or (worlds, {n}, 6, 6) (or diagonals (..., {n}, 6)), one 6x6 "
                f"matrix per element in the element frame (planar elements embedded at rows/columns "
                f"{list(PLANAR_INDEX)}); got {np.shape(value)}"
            )
        _some_worlds(name, a)
        what = "stiffness" if name == "K" else "damping"
        for e, element in enumerate(self.names):
            validation.check_psd_matrix(a[:, e], f"{name} of flexure '{element}' (per world)", 6, what=what)
            self._check_range(a[:, e], f"{name} of flexure '{element}'")
            if self._table.planar[e] and (a[:, e][:, _OFF_PLANE] != 0).any():
                raise ValueError(
                    f"{name} of flexure '{element}': the element is planar, so only rows/columns "
                    f"{list(PLANAR_INDEX)} ([theta_z; x; y]) may be non-zero; got out-of-plane entries"
                )
        return np.ascontiguousarray(a)

    def _check_range(self, a, what):
        big = float(np.abs(a).max(initial=0.0))
        if self.precision == "float32" and big > _FLOAT32_MAX:
            raise ValueError(
                f"{what} has an entry of {big:.3g}, beyond float32's range ({_FLOAT32_MAX:.3g}): the float32 kernels "
                'would see infinity. Use mjflex.warp.put_model(..., precision="float64"), or check the units'
            )

    def parameters(self) -> dict:
        """The per-world parameters as set: ``K``, ``B`` ``(worlds or 1, n, 6, 6)``, ``enabled``, ``viscous``
        ``(worlds or 1, n)``, ``stop_lower``, ``stop_upper`` and ``stop_stiffness`` ``(worlds or 1, n, 6)`` (the
        stiffness as the kernels read it: derived from K where the model derives it, 0 where there is no limit)."""
        return {name: a.copy() for name, a in self._host.items()}

    # ------------------------------------------------------------------ evaluation

    def _state(self, m, d):
        """The per-data state of ``d``; its sizes are checked against the model when it is first seen."""
        self._check_worlds(d)
        state = self._states.get(id(d))
        if state is None or state.nworld != d.nworld:
            self._check_sizes(m, d)
            state = self._states[id(d)] = _DataState(self._k, len(self), d.nworld, self.device)
            weakref.finalize(d, self._states.pop, id(d), None)
        return state

    def _check_sizes(self, m, d):
        """ValueError unless ``d`` (and ``m``) have this model's sizes: data of another model would be read and
        written out of bounds by the kernels (NaN results, or memory corrupted by the passive callback)."""
        mj = self.mjmodel
        want = {"nq": mj.nq, "nv": mj.nv, "nbody": mj.nbody, "nsite": mj.nsite}
        got = {}
        for field, size in (("qpos", "nq"), ("qvel", "nv"), ("qfrc_passive", "nv"), ("cdof", "nv"),
                            ("xquat", "nbody"), ("cvel", "nbody"), ("subtree_com", "nbody"),
                            ("site_xpos", "nsite")):  # fmt: skip
            shape = getattr(getattr(d, field, None), "shape", ())
            n = shape[1] if len(shape) > 1 else None
            if n != want[size]:
                got.setdefault(size, f"{field} {shape}")
        for size in ("nq", "nv", "nbody", "nsite"):
            if getattr(m, size, want[size]) != want[size]:
                got.setdefault(size, f"the MuJoCo Warp model's {size} = {getattr(m, size)}")
        if got:
            have = ", ".join(f"{size} = {n}" for size, n in want.items())
            raise ValueError(
                f"mjflex.warp: this data is not of the model '{model_name(mj)}' ({have}): its "
                f"{'; '.join(f'{size}: {text}' for size, text in got.items())}. Make the data from the MuJoCo model "
                "given to mjflex.warp.put_model: mujoco_warp.make_data(mjmodel, nworld=...) or "
                "mujoco_warp.put_data(mjmodel, mjdata, nworld=...)"
            )

    def _check_worlds(self, d):
        for name, a in self._host.items():
            if a.shape[0] not in (1, d.nworld):
                raise ValueError(
                    f"mjflex.warp: the per-world {name} has {a.shape[0]} worlds but the data has {d.nworld}; set "
                    f"parameters for 1 or {d.nworld} worlds (mjflex.warp.set_parameters)"
                )

    def _launch_gather(self, m, d, state, qfrc, watched):
        wp.launch(
            self._k["gather"], dim=(d.nworld, m.nv), device=self.device,
            inputs=[self._start, self._element, self._code, state.out, d.cdof,
                    state.watch.at_step if watched else self._no_watch],
            outputs=[qfrc],
        )  # fmt: skip

    def __call__(self, m, d) -> None:
        """The passive callback: add the elements' generalized forces to ``d.qfrc_passive`` and watch for divergence."""
        if not len(self):
            return
        state = self._evaluated(m, d)
        wp.launch(
            _watch.watch_kernel, dim=d.nworld, device=self.device,
            inputs=[d.time, m.opt.timestep, d.qpos, d.qvel, state.out.accel, state.out.finite], outputs=[state.watch],
        )  # fmt: skip
        self._launch_gather(m, d, state, d.qfrc_passive, True)

    # ------------------------------------------------------------------ queries

    def _evaluated(self, m, d):
        """The per-data state of ``d``, its ``out`` evaluated in ``d``'s state (the elements' wrenches and more)."""
        state = self._state(m, d)
        if len(self):
            flags = int(m.opt.disableflags)
            wp.launch(
                self._k["wrench"], dim=(d.nworld, len(self)), device=self.device,
                inputs=[self._el, self._params, int(not flags & _SPRING), int(not flags & _DAMPER), d.xquat,
                        d.site_xpos, d.cvel, d.subtree_com],
                outputs=[state.out],
            )  # fmt: skip
        return state

    def _wrenches(self, m, d) -> np.ndarray:
        """Wrench of each element on its body B, ``(nworld, n, 6)`` (see :func:`mjflex.warp.wrenches`)."""
        out = self._evaluated(m, d).out
        n = len(self)
        return np.concatenate([out.mo.numpy()[:, :n], out.f.numpy()[:, :n]], axis=-1)

    def _dissipation_powers(self, m, d) -> np.ndarray:
        """Power dissipated by each element, ``(nworld, n)`` [W] (see :func:`mjflex.warp.dissipation_powers`)."""
        return self._evaluated(m, d).out.power.numpy()[:, : len(self)]

    def _generalized_forces(self, m, d) -> np.ndarray:
        """The elements' generalized forces ``(nworld, nv)`` (see :func:`mjflex.warp.generalized_forces`)."""
        state = self._evaluated(m, d)
        qfrc = wp.zeros((d.nworld, m.nv), dtype=wp.float32, device=self.device)
        if len(self):
            self._launch_gather(m, d, state, qfrc, False)
        return qfrc.numpy()

    def _potentials_and_twists(self, m, d):
        """``(energy (nworld, n), twist (nworld, n, 6), stop coordinates (nworld, n, 6))`` in ``d``'s state."""
        self._state(m, d)  # checks d against the model
        k, n = self._k, len(self)
        shape = (d.nworld, max(n, 1))
        energy = wp.zeros(shape, k["real"], device=self.device)
        twist = wp.zeros(shape, k["V6"], device=self.device)
        stop_coords = wp.zeros(shape, k["V6"], device=self.device)
        if n:
            wp.launch(
                k["potential"], dim=(d.nworld, n), device=self.device,
                inputs=[self._el, self._params, int(not int(m.opt.disableflags) & _SPRING), d.xquat, d.site_xpos],
                outputs=[energy, twist, stop_coords],
            )  # fmt: skip
        return energy.numpy()[:, :n], twist.numpy()[:, :n], stop_coords.numpy()[:, :n]

    # ------------------------------------------------------------------ divergence

    def _divergences(self, m, d) -> list[WorldDivergence]:
        """The worlds that diverged in their current run, in world order."""
        state = self._state(m, d)
        w = state.watch
        at = w.at_step.numpy()
        worlds = np.flatnonzero(at >= 0)
        if not worlds.size:
            return []
        element, kind, time, accel = (a.numpy() for a in (w.element, w.kind, w.time, w.accel))
        h = m.opt.timestep.numpy().astype(float)
        exact = float(self.mjmodel.opt.timestep)
        h[h == np.float32(exact)] = exact  # the model's own step, not its float32 rounding, in messages
        out = []
        for i in worlds:
            e, step = int(element[i]), int(at[i])
            name = self.names[e] if 0 <= e < len(self) else ""
            t0 = step * h[i % h.shape[0]]
            reason = _KIND_TEXT[int(kind[i])]
            if kind[i] == _watch.NONFINITE:
                blame = f"flexure '{name}': {reason}"
            elif name:
                blame = (f"{reason}, and flexure '{name}''s force alone accelerated one of its bodies at "
                         f"{float(accel[i]):.3g} (m/s^2 or rad/s^2) in that step")  # fmt: skip
            else:
                blame = f"{reason}; no flexure's force alone exceeded {_watch.CANDIDATE_ACCEL:g} m/s^2 there"
            message = (
                f"mjflex.warp: world {int(i)} diverged in the step from t = {t0:.9g} s (step index {step}, counting "
                f"from 0): {blame}. Its forces are NaN from then on (until its time runs back: a reset). Reduce the "
                "time step (mjflex.step_advice(mjmodel) gives the largest stable one) or check the state you set."
            )
            out.append(WorldDivergence(int(i), name, step, float(time[i]), reason, message))
        return out

    def _diverged(self, d) -> np.ndarray:
        """``(nworld,)`` bool: which worlds diverged in their current run."""
        state = self._states.get(id(d))
        return np.zeros(d.nworld, bool) if state is None else state.watch.at_step.numpy() >= 0

    def _clear_divergences(self, d) -> None:
        """Forget the divergence records of ``d`` (every world starts a new run)."""
        self._states.pop(id(d), None)


def _deprecated(name, new):
    """A ``WarpFlexures`` method that was the same thing as ``mjflex.warp.<name>``: warns once, then calls it."""
    private = getattr(WarpFlexures, f"_{name}")

    def method(self, *args, **kwargs):
        if name not in _WARNED:
            _WARNED.add(name)
            warnings.warn(f"WarpFlexures.{name} is deprecated; use {new}", DeprecationWarning, stacklevel=2)
        return private(self, *args, **kwargs)

    method.__name__ = method.__qualname__ = name
    method.__doc__ = f"Deprecated: use :func:`{new.partition('(')[0]}` (one Warp API: the module's functions)."
    return method


_WARNED = set()
#: The methods that did what mjflex.warp's functions do (one Warp API): each warns once and names the function.
DEPRECATED_METHODS = {
    "set_parameters": "mjflex.warp.set_parameters(m, ...)",
    "wrenches": "mjflex.warp.wrenches(m, d)",
    "dissipation_powers": "mjflex.warp.dissipation_powers(m, d)",
    "generalized_forces": "mjflex.warp.generalized_forces(m, d)",
    "potentials_and_twists": "mjflex.warp.potential_energies(m, d), displacements(m, d) and stop_coordinates(m, d)",
    "divergences": "mjflex.warp.divergences(m, d)",
    "diverged": "mjflex.warp.diverged(m, d)",
    "clear_divergences": "mjflex.warp.clear_divergences(m, d)",
}
for _name, _new in DEPRECATED_METHODS.items():
    setattr(WarpFlexures, _name, _deprecated(_name, _new))

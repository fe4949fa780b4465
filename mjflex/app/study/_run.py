"""One model of the scene, run from the common initial state: samples, timing and divergence.

Divergence is detected, never left to look like a result: MuJoCo's automatic reset is switched
off on the study's model copies (so a blow-up cannot restart silently from ``qpos0``), and a run
stops at the first of

* a :class:`mujoco.FatalError` (mjflex raises one naming the element whose wrench is not finite),
* a MuJoCo bad-``qacc``/``qvel``/``qpos`` warning (NaN, inf or a huge value),
* a non-finite state, or an energy that left the reference's range by more than the limit.

Runs that would take longer than their wall-time budget stop early and are marked skipped, so
nothing hangs.
"""

import contextlib
import copy
import re
import time
from dataclasses import dataclass

import mujoco
import numpy as np

from ...mjcf.convert import copy_spec
from ...mjcf.elements import edit_elements
from ...runtime.divergence import step_phrase
from ...runtime.flexures import Flexures
from ..simulate import configure
from ._metrics import PoseReader, Trajectory

_BAD_STATE = (mujoco.mjtWarning.mjWARN_BADQACC, mujoco.mjtWarning.mjWARN_BADQVEL, mujoco.mjtWarning.mjWARN_BADQPOS)
_ELEMENT_IN_MESSAGE = re.compile(r"flexure '([^']+)'")


@contextlib.contextmanager
def quiet_mujoco_warnings():
    """Keep MuJoCo's warnings off the terminal while the study provokes divergence on purpose.

    The warnings are still counted in ``data.warning``, which is what the runs read.
    """
    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(lambda message: None)
    try:
        yield
    finally:
        mujoco.set_mju_user_warning(previous)


@dataclass
class Divergence:
    """Where and how a run stopped being a result."""

    time: float  # start of the diverging step [s] where mjflex named it, else the time at detection
    timestep: float  # [s]
    reason: str
    element: str | None  # the flexure mjflex named, or the one holding the most energy
    body: str | None
    exact: bool = False  # time is the start of the step that diverged (mjflex reported it)

    def text(self) -> str:
        where = f" at flexure '{self.element}'" if self.element else (f" at body '{self.body}'" if self.body else "")
        when = f"in {step_phrase(self.time, self.timestep)}" if self.exact else f"by t = {self.time:.4g} s"
        return f"diverged {when} with h = {self.timestep:.3g} s{where}: {self.reason}"


@dataclass
class Outcome:
    """What a sampled run produced: samples up to where it stopped, stepping time, why it stopped."""

    trajectory: Trajectory
    steps: int  # steps taken
    wall: float  # seconds spent in mj_step only
    cpu: float  # the same in this thread's CPU time
    divergence: Divergence | None = None
    skipped: str | None = None  # why the run was stopped before the end (budget), if it was

    @property
    def ok(self) -> bool:
        return self.divergence is None and self.skipped is None


class Sim:
    """One model of the scene (the source model or a variant), ready to run from the same start.

    Parameters
    ----------
    name : str
        Label of the variant (``"full"`` for the source model).
    model : mujoco.MjModel
        Copied; the study sets integrator and time step on its own copy.
    body_map : dict or None
        As in :class:`mjflex.variants.variant.Variant`; None for the source model.
    state : dict
        Initial ``qpos``, ``qvel`` and optionally ``act``, ``ctrl``, ``mocap_pos``, ``mocap_quat``.
    items, frame
        What to sample (see :class:`PoseReader`).
    """

    def __init__(self, name, model, body_map, state, items, frame, *, report="", spec=None):
        self.name, self.report = name, report
        self.body_map, self.items, self.frame_body = body_map, items, frame
        self.spec = spec  # what the model compiles from: plugin elements change method there (None: unknown)
        self.state = {k: np.asarray(v, dtype=float).copy() for k, v in state.items() if v is not None}
        self._models = {}  # method of the plugin elements (None: as in the file) -> (model, flex, reader, data)
        self._use(None, model)
        self.file_methods = tuple(r.method for r in self.flex.records)
        self.kinds = self.flex.kinds
        self._plugin_methods = [m for m, k in zip(self.file_methods, self.kinds, strict=True) if k == "plugin"]
        self._element_bodies = [{int(b) for b in bodies} for bodies in self.flex.body_ids]

    def _use(self, key, model=None):
        """Make the model whose plugin elements use method ``key`` (None: the file's) the current one."""
        if key not in self._models:
            model = copy.copy(model if model is not None else self._compiled(key))
            model.opt.enableflags |= mujoco.mjtEnableBit.mjENBL_ENERGY
            model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_AUTORESET
            flex = Flexures(model)
            self._models[key] = (model, flex, PoseReader(model, self.body_map, self.items, self.frame_body),
                                 mujoco.MjData(model))  # fmt: skip
        self.model, self.flex, self.reader, self.data = self._models[key]

    def _compiled(self, method):
        spec = copy_spec(self.spec)
        edit_elements(spec, [n for n, k in zip(self.flex.names, self.kinds, strict=True) if k == "plugin"],
                      method=method)  # fmt: skip
        return spec.compile()

    def method_switch_problem(self, methods) -> str | None:
        """Why this model cannot run ``methods`` (its plugin elements change method only in a spec), or None."""
        if self.spec is None and any(m != f for m in methods for f in self._plugin_methods):
            return (
                f"{self.name}: its elements are mjflex.flexure plugin instances, whose method is part of the model: "
                "the study compiles a copy per method from the MJCF file or MjSpec, which it was not given (an "
                "MjModel); pass the file's path or the MjSpec, or --methods/methods= the file's own method"
            )
        return None

    @property
    def has_flexures(self) -> bool:
        return len(self.flex) > 0

    def methods_label(self, method):
        if not self.has_flexures:
            return "-"
        if method is not None:
            return method
        return "/".join(sorted(set(self.file_methods)))

    def configure(self, integrator, method, h):
        """Set the integrator, every element's method (None: as in the file) and the time step.

        Text records switch at run time; plugin elements switch with a copy of the model compiled
        from the spec with that method (built once per method).
        """
        self._use(method if method is not None and any(f != method for f in self._plugin_methods) else None)
        configure(self.model, integrator=integrator, timestep=h)
        for name, file_method, kind in zip(self.flex.names, self.file_methods, self.kinds, strict=True):
            if kind == "record":
                self.flex.set_method(name, method or file_method)

    def reset(self, rest=False):
        """``self.data`` at the initial state, forwarded; ``rest``: at zero velocity, not forwarded."""
        d = self.data
        mujoco.mj_resetData(self.model, d)
        for key, value in self.state.items():
            getattr(d, key)[:] = value
        if rest:
            d.qvel[:] = 0.0
        else:
            mujoco.mj_forward(self.model, d)
        return d

    def sample(self, d):
        """Poses, total energy, kinetic and elastic energy of the current state (after mj_forward)."""
        p, R = self.reader.read(d)
        elastic = self.flex.potential_energy(d) if self.has_flexures else 0.0
        return p, R, float(d.energy[0] + d.energy[1] + elastic), float(d.energy[1]), elastic

    def culprit(self, d, message=None, dof=None):
        """``(element, body)`` to blame for a divergence.

        The element named in an mjflex error message; otherwise, among the elements attached to
        the body of the reported dof (or all of them), the one holding the most elastic energy
        in the last state whose energies are finite.
        """
        found = _ELEMENT_IN_MESSAGE.search(message or "")
        if found and found.group(1) in self.flex.names:
            return found.group(1), None
        body = int(self.model.dof_bodyid[dof]) if dof is not None and 0 <= dof < self.model.nv else None
        body_name = None if body is None else mujoco.mj_id2name(self.model, mujoco.mjtObj.mjOBJ_BODY, body)
        candidates = [i for i, b in enumerate(self._element_bodies) if body is None or body in b]
        if not candidates:
            return None, body_name
        energies = None
        with contextlib.suppress(mujoco.FatalError, ValueError):
            energies = self.flex.potential_energies(d)
        if energies is None or not np.isfinite(energies[candidates]).all():
            return self.flex.names[candidates[0]], body_name
        return self.flex.names[max(candidates, key=lambda i: energies[i])], body_name


def _bad_state(model, d):
    """``(reason, dof)`` if MuJoCo flagged a NaN/inf/huge state or the state is not finite."""
    for w in _BAD_STATE:
        stat = d.warning[w]
        if stat.number:
            return f"MuJoCo: {mujoco.mju_warningText(w, stat.lastinfo)}", int(stat.lastinfo)
    if not (np.isfinite(d.qpos).all() and np.isfinite(d.qvel).all()):
        return "the state became NaN or infinite", None
    return None


def run_sampled(sim, integrator, method, h, *, samples, every, energy_limit=None, max_wall=np.inf):
    """Run ``samples * every`` steps of ``h``, sampling every ``every`` steps (and at t = 0).

    ``energy_limit`` [J]: the run diverged when its energy leaves its start by more than this.
    ``max_wall`` [s]: stop (skipped) when the projected stepping time exceeds it. Only the
    ``mj_step`` calls are timed; sampling (an ``mj_forward`` per sample) is not.
    """
    sim.configure(integrator, method, h)
    m, d = sim.model, sim.reset()
    rows = [sim.sample(d)]
    times = [0.0]
    wall, cpu, steps, divergence, skipped = 0.0, 0.0, 0, None, None
    total = samples * every
    with sim.flex:
        for k in range(1, samples + 1):
            last_qpos, last_qvel = d.qpos.copy(), d.qvel.copy()
            message = None
            t0, c0 = time.perf_counter(), time.thread_time()
            try:
                for _ in range(every):
                    mujoco.mj_step(m, d)
            except mujoco.FatalError as exc:
                message = str(exc)
            wall, cpu = wall + time.perf_counter() - t0, cpu + time.thread_time() - c0
            steps = k * every
            bad = (message, None) if message else _bad_state(m, d)
            if bad is None:
                try:  # the sample's mj_forward meets the state the next step would: it may raise too
                    mujoco.mj_forward(m, d)
                    row = sim.sample(d)
                except mujoco.FatalError as exc:
                    message = str(exc)
                    bad = (message, None)
            if bad is None:
                if not np.isfinite(row[2]):
                    bad = ("the energy became NaN or infinite", None)
                elif energy_limit is not None and abs(row[2] - rows[0][2]) > energy_limit:
                    bad = (f"the energy left the reference's range (changed by {row[2] - rows[0][2]:.3g} J)", None)
            if bad is not None:
                reason, dof = bad
                if not (np.isfinite(d.qpos).all() and np.isfinite(d.qvel).all()):
                    d.qpos[:], d.qvel[:] = last_qpos, last_qvel
                    with contextlib.suppress(mujoco.FatalError):
                        mujoco.mj_forward(m, d)
                when = min(float(d.time), k * every * h) if np.isfinite(d.time) else k * every * h
                element, body = sim.culprit(d, message, dof)
                found = sorted(sim.flex.divergences(d).values(), key=lambda v: v.time) if sim.has_flexures else []
                if found:  # mjflex named the element and the step (mjflex.runtime.divergence)
                    divergence = Divergence(found[-1].time, h, found[-1].message, found[-1].element, body, exact=True)
                else:
                    divergence = Divergence(when, h, reason, element, body)
                break
            rows.append(row)
            times.append(k * every * h)
            if wall / steps * total > max_wall and k < samples:
                skipped = f"projected {wall / steps * total:.0f} s of stepping exceeds the run budget of {max_wall:g} s"
                break
    traj = Trajectory(np.array(times), *map(np.array, zip(*rows, strict=True)))  # p, R, energy, kinetic, elastic
    return Outcome(traj, steps, wall, cpu, divergence, skipped)

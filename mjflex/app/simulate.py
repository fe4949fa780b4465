"""Run a model with flexures and keep what the summary, the plots and the video need."""

import math
import sys
import time
from contextlib import contextmanager
from dataclasses import dataclass, field

import mujoco
import numpy as np

from ..analysis.advice import advise, integrator_name
from ..analysis.linearize import Options
from ..runtime.divergence import step_phrase
from ..runtime.flexures import Flexures

INTEGRATORS = {"euler": "mjINT_EULER", "rk4": "mjINT_RK4", "implicit": "mjINT_IMPLICIT",
               "implicitfast": "mjINT_IMPLICITFAST", "discrete": "mjINT_DISCRETE"}  # fmt: skip

_W = mujoco.mjtWarning
#: MuJoCo warnings that mean the state diverged (MuJoCo resets the data after them unless
#: auto-reset is disabled).
DIVERGENCE_WARNINGS = {_W.mjWARN_BADQPOS: "qpos", _W.mjWARN_BADQVEL: "qvel", _W.mjWARN_BADQACC: "qacc"}
#: Other MuJoCo warnings reported in the summary: the run went on, but something was lost.
OTHER_WARNINGS = {
    _W.mjWARN_INERTIA: "bad inertia", _W.mjWARN_CONTACTFULL: "contact buffer full",
    _W.mjWARN_CNSTRFULL: "constraint buffer full", _W.mjWARN_BADCTRL: "bad ctrl values",
}  # fmt: skip


class DivergenceError(RuntimeError):
    """The state of a run diverged; nothing after ``step`` is a result.

    ``run`` holds the samples taken before the diverging step; ``step`` (the number of steps
    taken, the failing one included) and ``time`` [s, at the start of that step] say where. The
    message names the step by the convention of :mod:`mjflex.runtime.divergence`.
    """

    def __init__(self, message, run, step, time):
        super().__init__(message)
        self.run, self.step, self.time = run, step, time


@dataclass
class Run:
    """Samples of a simulation: time, energies, element rotations, and optionally the states.

    Per-element arrays are ``(n,)`` in the order of ``flex.names``. ``peak_rotation`` and
    ``peak_bending`` are maxima over every step, not only over the samples.
    """

    time: list = field(default_factory=list)
    qpos: list = field(default_factory=list)  # empty unless the states were kept (rendering)
    kinetic: list = field(default_factory=list)  # MuJoCo's kinetic energy [J]
    mujoco_potential: list = field(default_factory=list)  # MuJoCo's own potential (gravity, springs) [J]
    flexure_potential: list = field(default_factory=list)  # [J]
    dissipated: list = field(default_factory=list)  # energy removed by the flexures' damping so far [J]
    rotation: list = field(default_factory=list)  # (n,) rotation angle |tau| of each element [rad]
    bending: list = field(default_factory=list)  # (n,) rotation about each element's z axis [rad]
    stroke: list = field(default_factory=list)  # axial position of the tracked body relative to the reference [m]
    peak_rotation: np.ndarray | None = None  # (n,) largest |tau| of each element over all steps [rad]
    peak_bending: np.ndarray | None = None  # (n,) largest |bending| of each element over all steps [rad]
    warnings: dict = field(default_factory=dict)  # MuJoCo warning -> times it was raised during the run

    def array(self, name):
        return np.asarray(getattr(self, name))


@dataclass
class Summary:
    model: str
    method: str
    integrator: str
    timestep: float
    duration: float
    steps: int
    wall_time: float  # [s] spent in mj_step (the run itself, flexure forces included)
    wall_per_simulated_second: float
    energy_start: float
    energy_end: float
    dissipated: float
    energy_balance_error: float  # (E_end + dissipated - E_start), J
    energy_balance_relative: float  # relative to the largest of the kinetic/elastic energy exchanged
    max_rotation: float
    max_rotation_element: str
    max_strain: float | None
    max_strain_element: str | None
    stroke_range: tuple | None
    mujoco_warnings: dict = field(default_factory=dict)

    def text(self) -> str:
        lines = [
            f"model {self.model}: {self.method}, {self.integrator}, dt = {self.timestep:g} s, "
            f"{self.steps} steps, {self.duration * 1e3:g} ms simulated",
            f"wall time of the run {self.wall_time:.3g} s ({self.wall_per_simulated_second:.3g} s per simulated "
            "second; mj_step with the flexures, without sampling or rendering)",
            f"energy: start {self.energy_start:.6g} J, end {self.energy_end:.6g} J, "
            f"dissipated {self.dissipated:.4g} J, balance error {self.energy_balance_error:.3g} J "
            f"({self.energy_balance_relative:.2e} of the energy exchanged)",
            f"max flexure rotation {self.max_rotation:.4g} rad ({np.degrees(self.max_rotation):.3g} deg) in "
            f"{self.max_rotation_element}",
        ]
        if self.max_strain is not None:
            lines.append(f"max bending strain {self.max_strain:.3%} in {self.max_strain_element}")
        if self.stroke_range is not None:
            lines.append(f"cylinder stroke {self.stroke_range[0] * 1e3:.3f} .. {self.stroke_range[1] * 1e3:.3f} mm")
        for name, count in self.mujoco_warnings.items():
            lines.append(f"MuJoCo warning during the run: {name} ({count} times)")
        return "\n".join(lines)


def integrator_label(model) -> str:
    """The model's integrator by its lowercase MJCF name (a key of :data:`INTEGRATORS`)."""
    return mujoco.mjtIntegrator(model.opt.integrator).name.replace("mjINT_", "").lower()


def configure(model, *, integrator=None, timestep=None):
    """Set the integrator (name as in MJCF, case-insensitive) and time step; validated."""
    if integrator is not None:
        key = integrator.lower()
        if key not in INTEGRATORS:
            raise ValueError(f"unknown integrator {integrator!r}; choose one of {sorted(INTEGRATORS)}")
        model.opt.integrator = getattr(mujoco.mjtIntegrator, INTEGRATORS[key])
    if timestep is not None:
        if not (timestep > 0 and math.isfinite(timestep)):
            raise ValueError(f"timestep must be a positive number of seconds; got {timestep!r}")
        model.opt.timestep = timestep
    model.opt.enableflags |= mujoco.mjtEnableBit.mjENBL_ENERGY


def timestep_warning(model, flex, data, name) -> str | None:
    """A warning when ``model``'s time step is above the largest stable step of its integrator at the configuration
    of ``data`` (the run's start; :func:`mjflex.step_advice`'s, with everything on), with the advised values; None
    when the step is stable there (one trial step: the bisection runs only for the warning)."""
    h, integrator = model.opt.timestep, integrator_name(None, model)
    everything = Options(True, "spring", True, True)
    _, _, first = advise(model, flex, data, integrator, everything, guess=h, expand=0, warn=False)
    if first == "stable":
        return None
    advice, last, _ = advise(model, flex, data, integrator, everything, guess=h, warn=False)
    if advice is None:
        return (f"warning: {name}: {integrator} is unstable at the initial state at every step down to {last:.3g} s "
                "(mjflex.step_advice): the state itself runs away; check it")  # fmt: skip
    return (
        f"warning: {name}: --timestep {h:g} s is above the largest stable step of {integrator} at the initial state, "
        f"{advice.limit:.3g} s (mjflex.step_advice; set by the {advice.frequency:.4g} Hz mode): the run will likely "
        f"diverge. Take --timestep {advice.recommended:.2g} (the advice's, half the limit) or less"
    )


def step_count(duration, timestep) -> int:
    """Steps of ``timestep`` [s] that make ``duration`` [s]; ValueError unless at least one."""
    if not (duration > 0 and math.isfinite(duration)):
        raise ValueError(f"duration must be a positive number of seconds; got {duration!r}")
    steps = round(duration / timestep)
    if steps < 1:
        raise ValueError(
            f"duration {duration:g} s is shorter than one time step ({timestep:g} s); ask for at least "
            f"{timestep:g} s or a smaller time step"
        )
    return steps


def element_strain_per_radian(flex) -> np.ndarray:
    """Peak bending strain per radian of each element, ``(n,)``; NaN where its record gives none."""
    return np.array([np.nan if r.strain_per_radian is None else r.strain_per_radian for r in flex.records])


class Progress:
    """A progress report of ``total`` steps on ``stream`` (stderr by default).

    On a terminal a bar is redrawn in place (at most every ``interval`` s); elsewhere (a log
    file, a pipe, CI) a plain line is written at most every ``log_interval`` s and once at the
    end, so that logs are not flooded. The time left is estimated from the rate of the steps
    after the first one (which carries one-off costs: caches, first contact with the data) and
    shown only once ``1 %`` of the steps or half a second of stepping is behind it.
    """

    def __init__(self, total, stream=None, *, clock=time.perf_counter, interval=0.25, log_interval=60.0):
        self.total, self.stream, self.clock = total, stream or sys.stderr, clock
        isatty = getattr(self.stream, "isatty", None)
        self.tty = bool(isatty and isatty())
        self.interval = interval if self.tty else log_interval
        self.start = self.clock()
        self.first = None  # (step, time) once the first step is done
        self.shown = -math.inf if self.tty else self.start  # a terminal shows the bar at once

    def eta(self, done, now):
        """Seconds left, or None while there is no sound estimate."""
        if self.first is None or done <= self.first[0]:
            return None
        steps, seconds = done - self.first[0], now - self.first[1]
        if steps < 0.01 * self.total and seconds < 0.5:
            return None
        return seconds / steps * (self.total - done)

    def update(self, done):
        now = self.clock()
        if self.first is None:
            self.first = (done, now)
        if done < self.total and now - self.shown < self.interval:
            return
        self.shown = now
        eta = self.eta(done, now)
        left = "estimating" if eta is None else f"~{eta:.1f} s left"
        fraction = done / self.total
        if self.tty:
            bar = "#" * int(30 * fraction)
            self.stream.write(f"\r[{bar:.<30}] {fraction:6.1%}  {now - self.start:6.1f} s, {left:>16}")
            if done == self.total:
                self.stream.write("\n")
        else:
            left = "done" if done == self.total else left
            self.stream.write(
                f"progress: {fraction:.1%} ({done}/{self.total} steps), {now - self.start:.1f} s, {left}\n"
            )
        self.stream.flush()


@contextmanager
def _divergence_stops_the_run(model):
    """MuJoCo's auto-reset off for the run (restored after): a diverging flexure raises ``mujoco.FatalError``
    naming the element, and MuJoCo's bad qpos/qvel/qacc checks count a warning, instead of a reset."""
    flags = model.opt.disableflags
    model.opt.disableflags = flags | mujoco.mjtDisableBit.mjDSBL_AUTORESET
    try:
        yield
    finally:
        model.opt.disableflags = flags


def _warning_counts(data):
    return {int(w): int(data.warning[w].number) for w in (*DIVERGENCE_WARNINGS, *OTHER_WARNINGS)}


def _divergence(data, before):
    """What MuJoCo's warnings say diverged since the counts ``before``, or None."""
    for w, what in DIVERGENCE_WARNINGS.items():
        if data.warning[w].number > before[int(w)]:
            index = int(data.warning[w].lastinfo)
            return (
                f"MuJoCo found a non-finite or huge {what}[{index}] (beyond 1e10, its mjMAXVAL); reduce the time "
                "step (mjflex.step_advice(model) gives the largest stable one) or check the initial state"
            )
    if not (np.isfinite(data.qpos).all() and np.isfinite(data.qvel).all()):
        return "the state is not finite"
    return None


def simulate(
    model, data, flex: Flexures, duration, *, sample_dt=None, track=("base", "cylinder"), progress=True,
    keep_qpos=True,
):  # fmt: skip
    """Step ``model`` for ``duration`` seconds with the flexures installed.

    Every ``sample_dt`` (default: every step) the time, energies and element rotations are
    recorded, and the state ``qpos`` if ``keep_qpos`` (rendering needs it; summaries do not).
    The dissipated energy is the trapezoidal integral of ``flex.dissipation_power`` over steps;
    the largest rotation and bending of each element are tracked over every step.
    ``track = (reference, body)`` names two bodies whose relative axial position is recorded
    (skipped if they do not exist). ``progress``: True (a :class:`Progress` on stderr), False, or
    a text stream to report on.

    The run stops at the first divergence: MuJoCo's auto-reset is off while it runs (restored
    after), a diverging flexure or a bad ``qpos``/``qvel``/``qacc`` raises :class:`DivergenceError`
    naming the step, the time and (for a flexure) the element.

    Returns
    -------
    run : Run
    wall_time : float
        Seconds spent in ``mj_step`` (the run, flexure forces included), not in the sampling.
    steps : int
    """
    h = model.opt.timestep
    steps = step_count(duration, h)
    every = max(1, round((sample_dt or h) / h))
    ids = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, n) for n in track]
    tracked = all(i >= 0 for i in ids)
    run = Run(peak_rotation=np.zeros(len(flex)), peak_bending=np.zeros(len(flex)))
    try:
        mujoco.mj_forward(model, data)
        dissipated, power, twist = 0.0, flex.dissipation_power(data), flex.displacements(data)
    except mujoco.FatalError as exc:  # a flexure's wrench is not finite in the initial state
        raise DivergenceError(
            f"the initial state (t = {data.time:g} s) is not valid: {exc}", run, 0, data.time
        ) from None

    def sample():
        run.time.append(data.time)
        if keep_qpos:
            run.qpos.append(data.qpos.copy())
        run.kinetic.append(float(data.energy[1]))
        run.mujoco_potential.append(float(data.energy[0]))
        run.flexure_potential.append(flex.potential_energy(data))
        run.dissipated.append(dissipated)
        run.rotation.append(np.linalg.norm(twist[:, :3], axis=1))
        run.bending.append(twist[:, 2].copy())
        if tracked:
            R = data.xmat[ids[0]].reshape(3, 3)
            run.stroke.append(float((R.T @ (data.xpos[ids[1]] - data.xpos[ids[0]]))[2]))

    def peaks():
        np.maximum(run.peak_rotation, np.linalg.norm(twist[:, :3], axis=1), out=run.peak_rotation)
        np.maximum(run.peak_bending, np.abs(twist[:, 2]), out=run.peak_bending)

    peaks()
    sample()
    t_start, wall, before = data.time, 0.0, _warning_counts(data)
    with _divergence_stops_the_run(model), flex:  # installed before the progress clock starts
        bar = Progress(steps, None if progress is True else progress) if progress else None
        for i in range(1, steps + 1):
            t = t_start + (i - 1) * h  # the start of this step
            try:
                t0 = time.perf_counter()
                mujoco.mj_step(model, data)
                wall += time.perf_counter() - t0  # stepping only; the bookkeeping below is not counted
                problem = _divergence(data, before)
                if problem is not None:  # mjflex may name the element that made the state bad
                    found = [v for v in flex.divergences(data).values() if abs(v.time - t) <= 1e-9 * max(h, t)]
                    problem = found[0].message if found else problem
                if problem is None:
                    mujoco.mj_forward(model, data)  # derived quantities (energy, kinematics) of the new state
                    new_power, twist = flex.dissipation_power(data), flex.displacements(data)
            except mujoco.FatalError as exc:  # a flexure diverged (auto-reset is off), named in the message
                problem = str(exc)
            if problem is not None:
                raise DivergenceError(
                    f"the run diverged in {step_phrase(t, h)} of its {steps} steps: {problem.rstrip('.')}. "
                    "Nothing from this step on is a result.",
                    run, i, t,
                )  # fmt: skip
            dissipated += 0.5 * h * (power + new_power)
            power = new_power
            peaks()
            if i % every == 0 or i == steps:
                sample()
            if bar is not None:
                bar.update(i)
    after = _warning_counts(data)
    run.warnings = {name: after[int(w)] - before[int(w)] for w, name in OTHER_WARNINGS.items()
                    if after[int(w)] > before[int(w)]}  # fmt: skip
    return run, wall, steps


def summarize(model_name, model, flex, run, wall, steps) -> Summary:
    """Energy balance, extreme rotations and strains of a run (strains where the elements' records state
    ``strain_per_radian``)."""
    E = run.array("kinetic") + run.array("mujoco_potential") + run.array("flexure_potential")
    exchanged = max(float(np.ptp(run.array("flexure_potential"))), float(np.ptp(run.array("kinetic"))), 1e-300)
    balance = float(E[-1] + run.dissipated[-1] - E[0])
    e_rot = int(np.argmax(run.peak_rotation))
    strain = run.peak_bending * element_strain_per_radian(flex)
    has_strain = bool(np.isfinite(strain).any())
    e_str = int(np.nanargmax(strain)) if has_strain else None
    duration = run.time[-1] - run.time[0]
    methods = sorted(set(flex.methods))
    return Summary(
        model=model_name, method="/".join(methods),
        integrator=integrator_label(model),
        timestep=float(model.opt.timestep), duration=float(duration), steps=steps, wall_time=wall,
        wall_per_simulated_second=wall / duration, energy_start=float(E[0]), energy_end=float(E[-1]),
        dissipated=float(run.dissipated[-1]), energy_balance_error=balance,
        energy_balance_relative=abs(balance) / exchanged,
        max_rotation=float(run.peak_rotation[e_rot]), max_rotation_element=flex.names[e_rot],
        max_strain=float(strain[e_str]) if has_strain else None,
        max_strain_element=flex.names[e_str] if has_strain else None,
        stroke_range=(float(min(run.stroke)), float(max(run.stroke))) if run.stroke else None,
        mujoco_warnings=dict(run.warnings),
    )  # fmt: skip

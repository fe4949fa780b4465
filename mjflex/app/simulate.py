"""Run a model with flexures and keep what the summary, the plots and the video need."""

import sys
import time
from dataclasses import asdict, dataclass, field

import mujoco
import numpy as np

from ..mj import Flexures

INTEGRATORS = {"euler": "mjINT_EULER", "rk4": "mjINT_RK4", "implicit": "mjINT_IMPLICIT",
               "implicitfast": "mjINT_IMPLICITFAST", "discrete": "mjINT_DISCRETE"}  # fmt: skip


@dataclass
class Run:
    """Samples of a simulation: time, state for rendering, energies and element rotations."""

    time: list = field(default_factory=list)
    qpos: list = field(default_factory=list)
    kinetic: list = field(default_factory=list)  # MuJoCo's kinetic energy [J]
    mujoco_potential: list = field(default_factory=list)  # MuJoCo's own potential (gravity, springs) [J]
    flexure_potential: list = field(default_factory=list)  # [J]
    dissipated: list = field(default_factory=list)  # energy removed by the flexures' damping so far [J]
    rotation: list = field(default_factory=list)  # (n,) rotation angle |tau| of each element [rad]
    bending: list = field(default_factory=list)  # (n,) rotation about each element's z axis [rad]
    stroke: list = field(default_factory=list)  # axial position of the tracked body relative to the reference [m]

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
    wall_time: float
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

    def to_dict(self):
        return asdict(self)

    def text(self) -> str:
        lines = [
            f"model {self.model}: {self.method}, {self.integrator}, dt = {self.timestep:g} s, "
            f"{self.steps} steps, {self.duration * 1e3:g} ms simulated",
            f"wall time {self.wall_time:.2f} s ({self.wall_per_simulated_second:.1f} s per simulated second)",
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
        return "\n".join(lines)


def configure(model, *, integrator=None, timestep=None):
    """Set the integrator (name as in MJCF, case-insensitive) and time step; validated."""
    if integrator is not None:
        key = integrator.lower()
        if key not in INTEGRATORS:
            raise ValueError(f"unknown integrator {integrator!r}; choose one of {sorted(INTEGRATORS)}")
        model.opt.integrator = getattr(mujoco.mjtIntegrator, INTEGRATORS[key])
    if timestep is not None:
        if not (timestep > 0 and np.isfinite(timestep)):
            raise ValueError(f"timestep must be a positive number of seconds; got {timestep!r}")
        model.opt.timestep = timestep
    model.opt.enableflags |= mujoco.mjtEnableBit.mjENBL_ENERGY


def _progress(fraction, start, width=30):
    filled = int(width * fraction)
    elapsed = time.perf_counter() - start
    eta = elapsed / fraction - elapsed if fraction > 0 else 0.0
    sys.stderr.write(
        f"\r[{'#' * filled}{'.' * (width - filled)}] {fraction:6.1%}  {elapsed:6.1f} s, ~{eta:5.1f} s left"
    )
    sys.stderr.flush()


def simulate(model, data, flex: Flexures, duration, *, sample_dt=None, track=("base", "cylinder"), progress=True):
    """Step ``model`` for ``duration`` seconds with the flexures installed.

    Every ``sample_dt`` (default: every step) the state and energies are recorded; the
    dissipated energy is the trapezoidal integral of ``flex.dissipation_power`` over steps.
    ``track = (reference, body)`` names two bodies whose relative axial position is recorded
    (skipped if they do not exist). Returns ``(Run, wall_time, steps)``; ``wall_time`` counts
    the ``mj_step`` calls only, not the bookkeeping.
    """
    if not duration > 0:
        raise ValueError(f"duration must be positive; got {duration!r}")
    h = model.opt.timestep
    steps = round(duration / h)
    every = max(1, round((sample_dt or h) / h))
    ids = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, n) for n in track]
    tracked = all(i >= 0 for i in ids)
    run = Run()
    mujoco.mj_forward(model, data)
    dissipated, power = 0.0, flex.dissipation_power(data)

    def sample():
        run.time.append(data.time)
        run.qpos.append(data.qpos.copy())
        run.kinetic.append(float(data.energy[1]))
        run.mujoco_potential.append(float(data.energy[0]))
        run.flexure_potential.append(flex.potential_energy(data))
        run.dissipated.append(dissipated)
        twist = flex.displacements(data)
        run.rotation.append(np.linalg.norm(twist[:, :3], axis=1))
        run.bending.append(twist[:, 2].copy())
        if tracked:
            R = data.xmat[ids[0]].reshape(3, 3)
            run.stroke.append(float((R.T @ (data.xpos[ids[1]] - data.xpos[ids[0]]))[2]))

    sample()
    start, wall = time.perf_counter(), 0.0
    with flex:
        for i in range(1, steps + 1):
            t0 = time.perf_counter()
            mujoco.mj_step(model, data)
            wall += time.perf_counter() - t0  # stepping only; the bookkeeping below is not counted
            mujoco.mj_forward(model, data)  # derived quantities (energy, kinematics) of the new state
            new_power = flex.dissipation_power(data)
            dissipated += 0.5 * h * (power + new_power)
            power = new_power
            if i % every == 0 or i == steps:
                sample()
            if progress and (i % max(1, steps // 200) == 0 or i == steps):
                _progress(i / steps, start)
    if progress:
        sys.stderr.write("\n")
    return run, wall, steps


def summarize(model_name, model, flex, run, wall, steps, *, strain_per_radian=None) -> Summary:
    """Energy balance, extreme rotations and strains of a run.

    ``strain_per_radian`` (n,) converts each element's bending rotation to a peak strain;
    by default it is taken from the elements' records when they carry ``strain_per_radian``.
    """
    E = run.array("kinetic") + run.array("mujoco_potential") + run.array("flexure_potential")
    exchanged = max(float(np.ptp(run.array("flexure_potential"))), float(np.ptp(run.array("kinetic"))), 1e-300)
    balance = float(E[-1] + run.dissipated[-1] - E[0])
    rot = run.array("rotation")
    e_rot = np.unravel_index(np.argmax(rot), rot.shape)[1]
    if strain_per_radian is None:
        strain_per_radian = np.array([r.strain_per_radian if r.strain_per_radian is not None else np.nan
                                      for r in flex.records])  # fmt: skip
    strain = np.abs(run.array("bending")) * strain_per_radian
    has_strain = np.isfinite(strain).any()
    e_str = np.unravel_index(np.nanargmax(strain), strain.shape)[1] if has_strain else None
    duration = run.time[-1] - run.time[0]
    methods = sorted(set(flex.methods))
    return Summary(
        model=model_name, method="/".join(methods),
        integrator=mujoco.mjtIntegrator(model.opt.integrator).name.replace("mjINT_", "").lower(),
        timestep=float(model.opt.timestep), duration=float(duration), steps=steps, wall_time=wall,
        wall_per_simulated_second=wall / duration, energy_start=float(E[0]), energy_end=float(E[-1]),
        dissipated=float(run.dissipated[-1]), energy_balance_error=balance,
        energy_balance_relative=abs(balance) / exchanged,
        max_rotation=float(rot.max()), max_rotation_element=flex.names[e_rot],
        max_strain=float(np.nanmax(strain)) if has_strain else None,
        max_strain_element=flex.names[e_str] if has_strain else None,
        stroke_range=(float(min(run.stroke)), float(max(run.stroke))) if run.stroke else None,
    )  # fmt: skip

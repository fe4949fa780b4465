"""Largest stable time step of a model with flexures, per integrator, and the energy error below it.

Usage::

    python scripts/timestep_study.py [MODEL.xml] [--duration 0.02] [--json out/timestep_study.json]

Runs the model's first keyframe (for ARCADE: the paper's run) with damping off, for each
integrator and time step, and records whether it stayed finite (no MuJoCo bad-acceleration
warning, energy error below 1 kJ) and the largest energy error. Compare with the explicit
limits from the highest normal mode (``scripts/step_limits.py``, which defines them): ``h < 2/w_max``
(Euler family), ``h < 2 sqrt(2)/w_max`` (RK4).
"""

import argparse
import os

import mujoco
import numpy as np
from _bench import write_json

import mjflex
from mjflex.analysis.linearize import normal_modes

HERE = os.path.dirname(os.path.abspath(__file__))
STEPS = (4e-5, 3e-5, 2e-5, 1e-5, 5e-6)
INTEGRATORS = ("RK4", "Euler", "implicitfast", "discrete")


def run(model, flex, integrator, dt, duration):
    model.opt.integrator = getattr(mujoco.mjtIntegrator, f"mjINT_{integrator.upper()}")
    model.opt.timestep = dt
    model.opt.enableflags |= mujoco.mjtEnableBit.mjENBL_ENERGY
    data = mujoco.MjData(model)
    if model.nkey:
        mujoco.mj_resetDataKeyframe(model, data, 0)
    mujoco.mj_forward(model, data)
    E0 = data.energy.sum() + flex.potential_energy(data)
    worst = 0.0
    with flex:
        for i in range(round(duration / dt)):
            mujoco.mj_step(model, data)
            if data.warning[mujoco.mjtWarning.mjWARN_BADQACC].number:
                return False, float("inf")
            if i % 25 == 0:
                mujoco.mj_forward(model, data)
                worst = max(worst, abs(data.energy.sum() + flex.potential_energy(data) - E0))
                if not worst < 1e3:
                    return False, worst
    return True, worst


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("model", nargs="?", default=os.path.join(HERE, "..", "models", "arcade.xml"))
    ap.add_argument("--duration", type=float, default=0.02)
    ap.add_argument("--json", default="out/timestep_study.json")
    args = ap.parse_args()
    spec = mujoco.MjSpec.from_file(args.model)
    mjflex.edit_elements(spec, viscous=False)  # plugin elements or text records alike
    model = spec.compile()
    flex = mjflex.Flexures(model)
    w_max = 2 * np.pi * normal_modes(model, flex)[0][-1]
    print(f"highest normal mode {w_max / 2 / np.pi:.0f} Hz: explicit limits 2/w = {2 / w_max:.2e} s, "
          f"2 sqrt(2)/w = {2 * np.sqrt(2) / w_max:.2e} s")  # fmt: skip
    print(
        f"{'integrator':<13} " + " ".join(f"{dt:>10.0e}" for dt in STEPS) + "   (max |energy error| [J], x = diverged)"
    )
    table = {}
    for integrator in INTEGRATORS:
        cells = []
        for dt in STEPS:
            ok, err = run(model, flex, integrator, dt, args.duration)
            table[f"{integrator}:{dt}"] = {"stable": ok, "max_energy_error_J": err}
            cells.append(f"{err:>10.2e}" if ok else f"{'x':>10}")
        print(f"{integrator:<13} " + " ".join(cells))
    write_json(args.json, {"model": os.path.basename(args.model), "duration": args.duration,
                           "omega_max": w_max, "runs": table})  # fmt: skip


if __name__ == "__main__":
    main()

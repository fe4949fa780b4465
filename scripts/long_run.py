"""Energy drift of long runs (1e6 steps) per integrator and element method.

Usage::

    python scripts/long_run.py [MODEL.xml] [--steps 1000000] [--timestep H] [--keep-damping]
                               [--integrators rk4 euler implicitfast discrete] [--methods twist dualquat]
                               [--json out/long_run.json]

Runs the model from its first keyframe (default ``models/two_body.xml``: block B spinning at
20 rad/s about the hinge axis, 1e6 steps of 2e-5 s = 20 s, ~1200 periods of the lowest mode)
with the elements' damping switched off, so that the exact motion conserves energy and every
change is the integrator's. The total energy (MuJoCo's kinetic and potential energy plus the
elements' elastic energy) is sampled every ``--every`` steps. Per run it prints

* ``max |dE|/E0``: the largest energy error over the run, relative to the initial energy: the
  bound the energy error stayed within;
* ``drift/1e6``: the least-squares slope of the energy error, per 1e6 steps, relative to E0
  (a secular trend; an oscillating, bounded error has a slope near 0);
* ``last/first``: the largest error in the last tenth of the run over the largest in the first
  tenth (about 1 for a bounded error, large for one that grows);
* ``us/step``: CPU time per step (this thread), for scale.

A run that diverges (NaN, MuJoCo's bad-state warnings with auto-reset off, mjflex's error) is
reported as such, with the step at which it happened. Writes the table as JSON.
"""

import argparse
import os
import time

import mujoco
import numpy as np
from _bench import write_json

import mjflex
from mjflex.app.simulate import INTEGRATORS
from mjflex.app.study._run import quiet_mujoco_warnings

HERE = os.path.dirname(os.path.abspath(__file__))


def energy(model, data, flex):
    mujoco.mj_forward(model, data)
    return float(data.energy[0] + data.energy[1] + flex.potential_energy(data))


def long_run(models, integrator, method, steps, every):
    """Energy error samples ``(k, E_k - E_0)`` of one run; returns a dict of the measures.

    ``models``: method -> ``(model, flex)``, each compiled with that method (plugin elements hold it).
    """
    model, flex = models[method]
    model.opt.integrator = getattr(mujoco.mjtIntegrator, INTEGRATORS[integrator])
    data = mujoco.MjData(model)
    if model.nkey:
        mujoco.mj_resetDataKeyframe(model, data, 0)
    E0 = energy(model, data, flex)
    k, dE, cpu, failure = [0], [0.0], 0.0, None
    with flex:
        for chunk in range(1, steps // every + 1):
            c0 = time.thread_time()
            try:
                for _ in range(every):
                    mujoco.mj_step(model, data)
            except mujoco.FatalError as exc:
                failure = str(exc)
            cpu += time.thread_time() - c0
            bad = data.warning[mujoco.mjtWarning.mjWARN_BADQACC].number or not np.isfinite(data.qvel).all()
            if failure or bad:
                failure = failure or "NaN, inf or huge acceleration (MuJoCo warning)"
                break
            k.append(chunk * every)
            dE.append(energy(model, data, flex) - E0)
    k, rel = np.array(k), np.array(dE) / abs(E0)
    tenth = max(1, len(k) // 10)
    return {
        "integrator": integrator, "method": method, "steps": int(k[-1]), "diverged": failure,
        "max_rel_error": float(np.max(np.abs(rel))),
        "drift_per_1e6_steps": float(np.polyfit(k, rel, 1)[0] * 1e6) if len(k) > 2 else float("nan"),
        "last_over_first": float(np.max(np.abs(rel[-tenth:])) / max(np.max(np.abs(rel[1 : tenth + 1])), 1e-300)),
        "final_rel_error": float(rel[-1]), "cpu_us_per_step": cpu / max(k[-1], 1) * 1e6, "E0": E0,
    }  # fmt: skip


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("model", nargs="?", default=os.path.join(HERE, "..", "models", "two_body.xml"))
    ap.add_argument("--steps", type=int, default=1_000_000)
    ap.add_argument("--every", type=int, default=1000, help="sample the energy every this many steps")
    ap.add_argument("--timestep", type=float, help="override the model's time step [s]")
    ap.add_argument("--integrators", nargs="+", default=["rk4", "euler", "implicitfast", "discrete"])
    ap.add_argument("--methods", nargs="+", default=["twist", "dualquat"])
    ap.add_argument("--keep-damping", action="store_true", help="keep the elements' damping (energy then decays)")
    ap.add_argument("--json", default="out/long_run.json")
    args = ap.parse_args()
    models = {}
    for method in args.methods:  # the method and damping written into the elements (plugin or text record)
        spec = mujoco.MjSpec.from_file(args.model)
        mjflex.edit_elements(spec, method=method, viscous=None if args.keep_damping else False)
        model = spec.compile()
        model.opt.enableflags |= mujoco.mjtEnableBit.mjENBL_ENERGY
        model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_AUTORESET  # a blow-up must not restart silently
        if args.timestep:
            model.opt.timestep = args.timestep
        models[method] = model, mjflex.Flexures(model)
    h = model.opt.timestep
    print(f"{os.path.basename(args.model)}: {args.steps} steps of {h:g} s ({args.steps * h:g} s simulated), "
          f"damping {'on' if args.keep_damping else 'off'}; energy sampled every {args.every} steps")  # fmt: skip
    print(f"{'integrator':<13}{'method':<10}{'max |dE|/E0':>13}{'drift/1e6':>12}{'last/first':>12}{'us/step':>9}")
    rows = []
    with quiet_mujoco_warnings():
        for integrator in args.integrators:
            for method in args.methods:
                r = long_run(models, integrator, method, args.steps, args.every)
                rows.append(r)
                tail = f"  DIVERGED at step {r['steps'] + args.every}: {r['diverged']}" if r["diverged"] else ""
                print(f"{integrator:<13}{method:<10}{r['max_rel_error']:>13.2e}{r['drift_per_1e6_steps']:>12.2e}"
                      f"{r['last_over_first']:>12.3g}{r['cpu_us_per_step']:>9.2f}{tail}", flush=True)  # fmt: skip
    write_json(args.json, {"model": os.path.basename(args.model), "timestep": h, "steps": args.steps,
                           "damping": args.keep_damping, "runs": rows})  # fmt: skip


if __name__ == "__main__":
    main()

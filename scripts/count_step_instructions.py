"""Instructions per simulation step of a model, counted by valgrind's callgrind (not timed).

Usage::

    python scripts/count_step_instructions.py [--model models/arcade.xml] [--steps 200] [--stops]
                                              [--baseline DIR] [--json out/count_step_instructions.json]

Timings on a shared machine are noisy; instruction counts are not: callgrind counts the
instructions executed inside ``mj_step`` (``--toggle-collect=mj_step``: the model's whole step,
MuJoCo's own work and the engine plugin's), ``--steps`` steps from the model's first keyframe
(or ``qpos0``), after one ``mj_forward`` that is not counted. The child process imports only
``mujoco`` (which loads the engine plugin ``mjflex.flexure`` through its entry point), so the
count is what any MuJoCo program pays. Rows:

* **model**: the model file as it is;
* **stops, free** (``--stops``): every element given end stops far outside its motion (a
  limit of 1 rad or 1 m on every coordinate), so they never engage: the cost of carrying stops;
* **stops, engaged** (``--stops``): every element given stops at zero on every coordinate
  (the two-sided range ``[0, 0]``), so every stop acts at every step, with a stiffness of 1e-9
  (N m/rad, N/m) so that the motion stays the model's (a hundred times ``K`` would need a step
  ten times smaller). The stop code has no branch on engagement: both rows should cost the same;
* **stops, engaged, damped** (``--stops``): the same stops with a damping of 1e-9 (N m s/rad, N s/m) on
  every coordinate: the cost of damped stops (the relative velocity and the stops' rates, their clamp).

A run that diverges (MuJoCo's bad-state warnings, or a velocity beyond 1e9) is refused: its count
would not be a step's cost.

``--baseline DIR``: also count the model's row with the mjflex source tree ``DIR`` (e.g. a
``git worktree`` of main) whose native library is built in ``DIR/mjflex/native``: the child
runs with ``DIR`` first on ``PYTHONPATH``, so ``import mujoco`` loads that library instead. The
ratio of the two counts is the change's cost for a model without stops. Needs ``valgrind``.

The JSON records the model's number of elements and its force evaluations per step (4 for RK4),
so that a difference of counts reads per element evaluation (docs/background/end_stops.md).
"""

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile

import mujoco
import numpy as np
from _bench import write_json

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

# the model is compiled outside valgrind (COMPILE) and loaded from MuJoCo's binary format inside it: under valgrind,
# MuJoCo 4.0.0's XML reader now and then refuses numbers it reads without ("unknown error in attribute 'qvel'")
COMPILE = """
import sys
import mujoco
mujoco.mj_saveModel(mujoco.MjModel.from_xml_path(sys.argv[1]), sys.argv[2], None)
"""
CHILD = """
import sys
import mujoco
model = mujoco.MjModel.from_binary_path(sys.argv[1])
data = mujoco.MjData(model)
if model.nkey:
    mujoco.mj_resetDataKeyframe(model, data, 0)
mujoco.mj_forward(model, data)
mujoco.mj_step(model, data, nstep=int(sys.argv[2]))
bad = sum(data.warning[w].number for w in (mujoco.mjtWarning.mjWARN_BADQPOS, mujoco.mjtWarning.mjWARN_BADQVEL,
                                           mujoco.mjtWarning.mjWARN_BADQACC))
print("diverged" if bad or not abs(data.qvel).max() < 1e9 else "finite")
"""


def _with_stops(path, lower, upper, out, stiffness=None, damping=None):
    """The model file at ``path`` with stops ``[lower, upper]`` on every coordinate of every plugin element."""
    spec = mujoco.MjSpec.from_file(path)
    for plugin in spec.plugins:
        if plugin.plugin_name != "mjflex.flexure":
            continue
        config = dict(plugin.config)
        n = len(config["K"].split())
        n = 3 if n in (3, 9) else 6
        config["stop_lower"], config["stop_upper"] = " ".join([repr(lower)] * n), " ".join([repr(upper)] * n)
        if stiffness is not None:
            config["stop_stiffness"] = repr(stiffness)
        if damping is not None:
            config["stop_damping"] = repr(damping)
        plugin.config = config
    with open(out, "w") as f:
        f.write(spec.to_xml())
    return out


def _elements(path):
    """Number of mjflex plugin elements in the model file at ``path``."""
    return sum(p.plugin_name == "mjflex.flexure" for p in mujoco.MjSpec.from_file(path).plugins)


def count(path, steps, pythonpath=None):
    """Instructions callgrind counts inside ``mj_step`` for ``steps`` steps of the model file ``path``."""
    with tempfile.TemporaryDirectory() as tmp:
        env = dict(os.environ)
        if pythonpath:
            env["PYTHONPATH"] = os.pathsep.join([pythonpath, env.get("PYTHONPATH", "")]).rstrip(os.pathsep)
        binary = os.path.join(tmp, "model.mjb")
        subprocess.run([sys.executable, "-c", COMPILE, os.path.abspath(path), binary], env=env, check=True, cwd=tmp)
        child = os.path.join(tmp, "child.py")
        with open(child, "w") as f:
            f.write(CHILD)
        out = os.path.join(tmp, "callgrind.out")
        cmd = ["valgrind", "--tool=callgrind", "--toggle-collect=mj_step", f"--callgrind-out-file={out}",
               sys.executable, child, binary, str(steps)]  # fmt: skip
        run = subprocess.run(cmd, env=env, capture_output=True, text=True, cwd=tmp)
        if run.returncode:
            raise RuntimeError(f"valgrind failed ({run.returncode}):\n{run.stderr[-3000:]}")
        if "finite" not in run.stdout.split():
            raise RuntimeError(f"the run of {path} diverged: its count would not be a step's cost")
        with open(out) as f:
            text = f.read()
        total = re.search(r"^summary:\s+(\d+)", text, re.M) or re.search(r"^totals:\s+(\d+)", text, re.M)
        return int(total.group(1))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--model", default=os.path.join(ROOT, "models", "arcade.xml"))
    ap.add_argument("--steps", type=int, default=200)
    ap.add_argument("--stops", action="store_true", help="also count the model with free and engaged stops")
    ap.add_argument("--baseline", help="an mjflex source tree with its native library built, to compare against")
    ap.add_argument("--json", default=os.path.join("out", "count_step_instructions.json"))
    args = ap.parse_args(argv)
    if shutil.which("valgrind") is None:
        sys.exit("valgrind is not installed (apt-get install valgrind)")
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        cases = [("model", args.model, None)]
        if args.baseline:
            cases.insert(0, ("model, baseline library", args.model, os.path.abspath(args.baseline)))
        if args.stops:
            cases.append(("stops, free", _with_stops(args.model, -1.0, 1.0, os.path.join(tmp, "free.xml")), None))
            on = _with_stops(args.model, 0.0, 0.0, os.path.join(tmp, "on.xml"), stiffness=1e-9)
            cases.append(("stops, engaged", on, None))
            damped = _with_stops(args.model, 0.0, 0.0, os.path.join(tmp, "damped.xml"), stiffness=1e-9, damping=1e-9)
            cases.append(("stops, engaged, damped", damped, None))
        for name, path, pythonpath in cases:
            total = count(path, args.steps, pythonpath)
            rows.append({"case": name, "instructions": total, "per_step": total / args.steps})
            print(f"{name:30s} {total / args.steps:14,.0f} instructions per step", flush=True)
    reference = next(r for r in rows if r["case"] == "model")["per_step"]
    for r in rows:
        r["ratio_to_model"] = r["per_step"] / reference
    print("\n" + "\n".join(f"{r['case']:30s} x {r['ratio_to_model']:.5f}" for r in rows))
    model = mujoco.MjModel.from_xml_path(args.model)
    payload = {"model": os.path.relpath(args.model, ROOT), "steps": args.steps, "rows": rows,
               "elements": _elements(args.model), "integrator": mujoco.mjtIntegrator(model.opt.integrator).name,
               "evaluations_per_step": 4 if model.opt.integrator == mujoco.mjtIntegrator.mjINT_RK4 else 1,
               "mujoco": mujoco.__version__, "numpy": np.__version__}  # fmt: skip
    write_json(args.json, payload)
    return payload


if __name__ == "__main__":
    main()

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
  (the two-sided range ``[0, 0]``), so every stop acts at every step.

``--baseline DIR``: also count the model's row with the mjflex source tree ``DIR`` (e.g. a
``git worktree`` of main) whose native library is built in ``DIR/mjflex/native``: the child
runs with ``DIR`` first on ``PYTHONPATH``, so ``import mujoco`` loads that library instead. The
ratio of the two counts is the change's cost for a model without stops. Needs ``valgrind``.
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

CHILD = """
import sys
import mujoco
model = mujoco.MjModel.from_xml_path(sys.argv[1])
data = mujoco.MjData(model)
if model.nkey:
    mujoco.mj_resetDataKeyframe(model, data, 0)
mujoco.mj_forward(model, data)
mujoco.mj_step(model, data, nstep=int(sys.argv[2]))
print("energy-check", float(data.qpos.sum()))
"""


def _with_stops(path, lower, upper, out):
    """The model file at ``path`` with stops ``[lower, upper]`` on every coordinate of every plugin element."""
    spec = mujoco.MjSpec.from_file(path)
    for plugin in spec.plugins:
        if plugin.plugin_name != "mjflex.flexure":
            continue
        config = dict(plugin.config)
        n = len(config["K"].split())
        n = 3 if n in (3, 9) else 6
        config["stop_lower"], config["stop_upper"] = " ".join([repr(lower)] * n), " ".join([repr(upper)] * n)
        plugin.config = config
    with open(out, "w") as f:
        f.write(spec.to_xml())
    return out


def count(path, steps, pythonpath=None):
    """Instructions callgrind counts inside ``mj_step`` for ``steps`` steps of the model file ``path``."""
    with tempfile.TemporaryDirectory() as tmp:
        child = os.path.join(tmp, "child.py")
        with open(child, "w") as f:
            f.write(CHILD)
        env = dict(os.environ)
        if pythonpath:
            env["PYTHONPATH"] = os.pathsep.join([pythonpath, env.get("PYTHONPATH", "")]).rstrip(os.pathsep)
        out = os.path.join(tmp, "callgrind.out")
        cmd = ["valgrind", "--tool=callgrind", "--toggle-collect=mj_step", f"--callgrind-out-file={out}",
               sys.executable, child, os.path.abspath(path), str(steps)]  # fmt: skip
        run = subprocess.run(cmd, env=env, capture_output=True, text=True, cwd=tmp)
        if run.returncode:
            raise RuntimeError(f"valgrind failed ({run.returncode}):\n{run.stderr[-3000:]}")
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
            cases.append(("stops, engaged", _with_stops(args.model, 0.0, 0.0, os.path.join(tmp, "on.xml")), None))
        for name, path, pythonpath in cases:
            total = count(path, args.steps, pythonpath)
            rows.append({"case": name, "instructions": total, "per_step": total / args.steps})
            print(f"{name:28s} {total / args.steps:14,.0f} instructions per step", flush=True)
    reference = next(r for r in rows if r["case"] == "model")["per_step"]
    for r in rows:
        r["ratio_to_model"] = r["per_step"] / reference
    print("\n" + "\n".join(f"{r['case']:28s} x {r['ratio_to_model']:.5f}" for r in rows))
    payload = {"model": os.path.relpath(args.model, ROOT), "steps": args.steps, "rows": rows,
               "mujoco": mujoco.__version__, "numpy": np.__version__}  # fmt: skip
    write_json(args.json, payload)
    return payload


if __name__ == "__main__":
    main()

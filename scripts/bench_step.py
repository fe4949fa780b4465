"""Cost of a simulation step with 48 flexures, against no elements and against 48 weld constraints.

Usage::

    python scripts/bench_step.py [--model models/arcade.xml | --random] [--json out/bench_step.json]
                                 [--integrator euler|rk4]

The same 35 free bodies are stepped with ``mj_step`` (Euler by default, the model's time step)
from the same state in these versions, measured interleaved in one process (medians of
same-repeat ratios, with their min-max spread):

* **plugin**: the 48 elements as instances of the engine plugin ``mjflex.flexure`` (twist and
  dual-quaternion methods): the forces belong to the model;
* **mjcb_passive**: the same elements as text records, their forces added by mjflex's C
  ``mjcb_passive`` dispatcher (twist and dual-quaternion methods);
* **bare**: the same model without elements (a separately loaded, unregistered copy);
* **weld**: the same bodies joined instead by 48 MuJoCo ``weld`` equality constraints at the
  element frames (site-to-site), the native way to make a rigid joint.

It also measures the start-up: a fresh process from ``import mujoco`` to its first step of the
plugin model (no mjflex import: ``import mujoco`` loads the plugin), and of the text-record model
through ``import mjflex`` and ``Flexures``, each the median of ``--startup-runs`` processes.

Goals: issue "MuJoCo layer": flexure step <= 0.5 x weld step and <= 3 x bare step; issue 16
(engine plugin): plugin step <= 1.5 x bare for both methods, start-up <= 0.5 s.
``--random`` uses 35 free bodies on a line (neighbours and random next-but-one pairs linked) with
48 notch-hinge stiffnesses in random orientations instead of the ARCADE model.
"""

import argparse
import os
import subprocess
import sys
import tempfile

import mujoco
import numpy as np
from _bench import compare, print_table, write_json

import mjflex

HERE = os.path.dirname(os.path.abspath(__file__))


def random_spec(seed=0, n_bodies=35, n_elements=48):
    """35 free boxes on a line, 34 neighbours linked plus 14 random next-but-one pairs.

    Each element is the paper's notch hinge (mjflex.geometry) in a random orientation, scaled by a
    random factor in [0.5, 2]: a full, coupled 6x6 K; B = 2e-6 s K.
    """
    from scipy.spatial.transform import Rotation

    from mjflex.app.arcade import ArcadeParams, notch_stiffness

    K_notch = notch_stiffness(ArcadeParams())
    rng = np.random.default_rng(seed)
    spec = mujoco.MjSpec()
    spec.option.gravity = [0, 0, 0]
    spec.option.timestep = 2e-6  # explicitly stable for these stiff, randomly oriented elements
    for i in range(n_bodies):
        body = spec.worldbody.add_body(name=f"b{i}", pos=[0.03 * i, 0, 0])
        body.add_freejoint()
        body.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.012, 0.0025, 0.00475], density=2700,
                      contype=0, conaffinity=0)  # fmt: skip
    pairs = [(i, i + 1) for i in range(n_bodies - 1)]
    second = [(i, i + 2) for i in range(n_bodies - 2)]
    pairs += [second[k] for k in sorted(rng.choice(len(second), n_elements - len(pairs), replace=False))]
    poses = mjflex.reference_body_poses(spec)
    for e, (i, j) in enumerate(pairs):
        R = Rotation.random(random_state=rng).as_matrix()
        K = rng.uniform(0.5, 2.0) * mjflex.stiffness_in_frame(K_notch, R, np.zeros(3))
        mjflex.add_flexure(spec, f"e{e}", f"b{i}", f"b{j}", pos=0.5 * (poses[0][i + 1] + poses[0][j + 1]), K=K,
                           B=2e-6 * K, poses=poses)  # fmt: skip
    return spec


def welded(spec, model):
    """A copy of the spec with each flexure replaced by a weld between its two sites."""
    weld = spec.copy()
    for name in mjflex.Flexures(model).names:
        weld.add_equality(type=mujoco.mjtEq.mjEQ_WELD, objtype=mujoco.mjtObj.mjOBJ_SITE, name1=f"{name}/a",
                          name2=f"{name}/b")  # fmt: skip
    return weld


def plugin_spec(spec, method):
    """A copy of the spec with every text record turned into an mjflex.flexure instance using ``method``."""
    from mjflex.mj.build import records_to_plugins

    copy = spec.copy()
    records_to_plugins(copy)
    for plugin in copy.plugins:
        config = dict(plugin.config)
        config["method"] = method
        plugin.config = config
    return copy


STARTUP = {
    "plugin": """
import time; t0 = time.perf_counter()
import mujoco
m = mujoco.MjModel.from_xml_path({path!r}); d = mujoco.MjData(m); mujoco.mj_step(m, d)
print(time.perf_counter() - t0)""",
    "mjcb_passive": """
import time; t0 = time.perf_counter()
import mujoco, mjflex
m = mujoco.MjModel.from_xml_path({path!r}); d = mujoco.MjData(m)
with mjflex.Flexures(m):
    mujoco.mj_step(m, d)
print(time.perf_counter() - t0)""",
}


def startup(paths, runs):
    """Median and range [s] over ``runs`` fresh processes: import to the first step of each model."""
    out = {}
    for kind, path in paths.items():
        times = []
        for _ in range(runs):
            code = STARTUP[kind].format(path=path)
            done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
            times.append(float(done.stdout.split()[-1]))
        out[kind] = {"median_s": float(np.median(times)), "min_s": min(times), "max_s": max(times), "runs": runs}
    return out


def stepper(model, qvel, steps=5):
    data = mujoco.MjData(model)
    data.qvel[:] = qvel
    mujoco.mj_forward(model, data)

    def run():
        for _ in range(steps):
            mujoco.mj_step(model, data)

    run.data = data
    return run


def check_stable(cases):
    """Timings only count if no run diverged (MuJoCo resets diverging data and counts a warning)."""
    for name, run in cases.items():
        bad = run.data.warning[mujoco.mjtWarning.mjWARN_BADQACC].number
        if bad or not np.all(np.isfinite(run.data.qpos)):
            raise SystemExit(f"error: case {name!r} diverged ({bad} bad-acceleration warnings); timings invalid")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--model", default=os.path.join(HERE, "..", "models", "arcade.xml"))
    ap.add_argument("--random", action="store_true", help="random 35-body, 48-element model instead")
    ap.add_argument("--repeat", type=int, default=21)
    ap.add_argument("--json", default="out/bench_step.json")
    ap.add_argument("--integrator", choices=["euler", "rk4"], default="euler")
    ap.add_argument("--startup-runs", type=int, default=5, help="fresh processes per start-up measurement (0: skip)")
    args = ap.parse_args()
    spec = random_spec() if args.random else mujoco.MjSpec.from_file(args.model)
    spec.option.integrator = getattr(mujoco.mjtIntegrator, f"mjINT_{args.integrator.upper()}")
    models = {k: spec.compile() for k in ("twist", "dualquat", "bare")}
    models["weld"] = welded(spec, models["bare"]).compile()
    plugin_specs = {m: plugin_spec(spec, m) for m in ("twist", "dualquat")}
    for method, s in plugin_specs.items():
        models[f"plugin_{method}"] = s.compile()
    if models["bare"].nkey:  # the paper's run if the model has it, else a random motion
        qvel = models["bare"].key_qvel[0].copy()
    else:
        qvel = 0.1 * np.random.default_rng(1).normal(size=models["bare"].nv)
    providers = [mjflex.Flexures(models[m]) for m in ("twist", "dualquat")]
    for name in providers[1].names:
        providers[1].set_method(name, "dualquat")
    for p in providers:
        p.install()
    steps = 5
    cases = {
        "bare: same bodies, no elements (baseline)": stepper(models["bare"], qvel, steps),
        "plugin, twist method": stepper(models["plugin_twist"], qvel, steps),
        "plugin, dual-quaternion method": stepper(models["plugin_dualquat"], qvel, steps),
        "flexures, twist method": stepper(models["twist"], qvel, steps),
        "flexures, dual-quaternion method": stepper(models["dualquat"], qvel, steps),
        "weld: 48 weld equality constraints": stepper(models["weld"], qvel, steps),
    }
    rows = compare(cases, "bare: same bodies, no elements (baseline)", repeat=args.repeat)
    check_stable(cases)
    for r in rows.values():  # per mj_step
        for key in ("median_s", "min_s", "max_s"):
            r[key] /= steps
    nb = models["bare"].nbody - 1
    print_table(
        rows,
        f"mj_step ({args.integrator}), {nb} free bodies, {len(providers[0])} elements ('flexures': mjcb_passive "
        "provider, C); ratios to bare in the same repeat",
    )
    weld = rows["weld: 48 weld equality constraints"]["median_s"]
    verdict = {}
    for name in ("flexures, twist method", "flexures, dual-quaternion method"):
        r = rows[name]
        verdict[name] = {"vs_bare": r["ratio_median"], "vs_weld": r["median_s"] / weld,
                         "goal_met": r["ratio_median"] <= 3.0 and r["median_s"] / weld <= 0.5}  # fmt: skip
        print(f"{name}: {r['ratio_median']:.2f}x bare, {r['median_s'] / weld:.2f}x weld -> goal "
              f"{'met' if verdict[name]['goal_met'] else 'NOT met'} (<= 3x bare, <= 0.5x weld)")  # fmt: skip
    for name in ("plugin, twist method", "plugin, dual-quaternion method"):
        r = rows[name]
        verdict[name] = {"vs_bare": r["ratio_median"], "goal_met": r["ratio_median"] <= 1.5}
        print(f"{name}: {r['ratio_median']:.2f}x bare ({r['ratio_min']:.2f}-{r['ratio_max']:.2f}) -> goal "
              f"{'met' if verdict[name]['goal_met'] else 'NOT met'} (<= 1.5x bare)")  # fmt: skip
    for p in providers:
        p.uninstall()
    start = {}
    if args.startup_runs:
        with tempfile.TemporaryDirectory() as tmp:
            paths = {"plugin": os.path.join(tmp, "plugin.xml"), "mjcb_passive": os.path.join(tmp, "record.xml")}
            for path, s in zip(paths.values(), (plugin_specs["twist"], spec), strict=True):
                with open(path, "w") as f:
                    f.write(s.to_xml())
            start = startup(paths, args.startup_runs)
        print("\nstart-up: a fresh process from its first import to its first step (median, min-max)")
        for kind, r in start.items():
            what = "import mujoco, load the plugin model" if kind == "plugin" else "import mujoco, mjflex; Flexures"
            print(f"  {kind:<14} {r['median_s']:.3f} s ({r['min_s']:.3f}-{r['max_s']:.3f}): {what}, mj_step")
        verdict["startup"] = {"plugin_s": start["plugin"]["median_s"], "goal_met": start["plugin"]["median_s"] <= 0.5}
    write_json(args.json, {"model": "random" if args.random else os.path.basename(args.model), "rows": rows,
                           "verdict": verdict, "steps_per_call": steps, "integrator": args.integrator,
                           "startup": start})  # fmt: skip


if __name__ == "__main__":
    main()

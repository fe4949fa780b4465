"""Cost of a simulation step with 48 flexures, against no elements and against 48 weld constraints.

Usage::

    python scripts/bench_step.py [--model models/arcade.xml | --random] [--json out/bench_step.json]
                                 [--integrator euler rk4] [--lanes auto|2|4] [--runs 5] [--repeat 21]
                                 [--startup-runs 5]

The same 35 free bodies are stepped with ``mj_step`` (the model's time step) from the same state in
these versions, measured interleaved (same-repeat ratios: median, quartiles, min-max) in each of
``--runs`` fresh processes, whose repeats are pooled (scripts/_bench.py), once per integrator
(Euler and RK4 by default; the rows of the first are ``rows`` in the JSON, the others'
``rows_<integrator>``):

* **plugin**: the 48 elements as instances of the engine plugin ``mjflex.flexure`` (twist and
  dual-quaternion methods): the forces belong to the model;
* **mjcb_passive**: the same elements as text records, their forces added by mjflex's C
  ``mjcb_passive`` dispatcher (twist and dual-quaternion methods);
* **bare**: the same model without elements (a separately loaded, unregistered copy);
* **weld**: the same bodies joined instead by 48 MuJoCo ``weld`` equality constraints at the
  element frames (site-to-site), the native way to make a rigid joint.

The native library evaluates the elements in vector lanes: 4 where the CPU has AVX, else 2
(``--lanes`` forces a build; the JSON records the lanes used). It also measures the start-up: a
fresh process from ``import mujoco`` to its first step of the plugin model (no mjflex import:
``import mujoco`` loads the plugin), and of the text-record model through ``import mjflex`` and
``Flexures``, each the median of ``--startup-runs`` processes.

Goals: issue "MuJoCo layer": flexure step <= 0.5 x weld step and <= 3 x bare step; issue 16
(engine plugin): plugin step <= 1.5 x bare for both methods and both integrators, start-up <= 0.5 s.
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
from _bench import (
    CHILD,
    add_timing_options,
    compare,
    measured_in_processes,
    print_table,
    ratio_between,
    scale_times,
    write_json,
)

import mjflex
from mjflex.mjcf.convert import copy_spec, plugins_to_records, records_to_plugins

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
                           B=2e-6 * K, poses=poses, kind="record")  # fmt: skip
    return spec


def welded(spec, model):
    """A copy of the spec with each flexure replaced by a weld between its two sites."""
    weld = copy_spec(spec)
    for name in mjflex.Flexures(model).names:
        weld.add_equality(type=mujoco.mjtEq.mjEQ_WELD, objtype=mujoco.mjtObj.mjOBJ_SITE, name1=f"{name}/a",
                          name2=f"{name}/b")  # fmt: skip
    return weld


def plugin_spec(spec, method):
    """A copy of the spec with every text record turned into an mjflex.flexure instance using ``method``."""
    copy = copy_spec(spec)
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


BARE = "bare: same bodies, no elements (baseline)"
WELD = "weld: 48 weld equality constraints"
PLUGIN = ("plugin, twist method", "plugin, dual-quaternion method")


def set_lanes(lanes):
    """Force the native library's lane count (2 or 4; 'auto': the widest the CPU has); returns the lanes used."""
    from mjflex.native import library as _native

    native = _native.lib()
    if native.mjfx_set_lanes(0 if lanes == "auto" else int(lanes)) < 0:
        raise SystemExit(f"error: --lanes {lanes}: this CPU or build has no {lanes}-lane evaluation (try --lanes 2)")
    return _native.lanes()


def measure_integrator(args, integrator):
    """Time the cases interleaved in this process with one integrator: ``rows`` (per ``mj_step``)."""
    spec = random_spec() if args.random else mujoco.MjSpec.from_file(args.model)
    plugins_to_records(spec)  # both forms are built from text records (models/arcade.xml holds plugin instances)
    spec.option.integrator = getattr(mujoco.mjtIntegrator, f"mjINT_{integrator.upper()}")
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
        BARE: stepper(models["bare"], qvel, steps),
        PLUGIN[0]: stepper(models["plugin_twist"], qvel, steps),
        PLUGIN[1]: stepper(models["plugin_dualquat"], qvel, steps),
        "flexures, twist method": stepper(models["twist"], qvel, steps),
        "flexures, dual-quaternion method": stepper(models["dualquat"], qvel, steps),
        WELD: stepper(models["weld"], qvel, steps),
    }
    try:
        rows = compare(cases, BARE, repeat=args.repeat)
    finally:
        for p in providers:
            p.uninstall()
    check_stable(cases)
    for r in rows.values():  # per mj_step
        scale_times(r, 1 / steps)
    return rows, models["bare"].nbody - 1, len(providers[0])


def rows_key(integrator, integrators):
    """Where an integrator's rows are in the JSON: ``rows`` for the first, ``rows_<integrator>`` for the others."""
    return "rows" if integrator == integrators[0] else f"rows_{integrator}"


def measure(args):
    """Time every integrator's cases in this process (the JSON's payload)."""
    payload = {"model": "random" if args.random else os.path.basename(args.model), "steps_per_call": 5,
               "integrators": list(args.integrator), "native_lanes": set_lanes(args.lanes)}  # fmt: skip
    for integrator in args.integrator:
        rows, payload["bodies"], payload["elements"] = measure_integrator(args, integrator)
        payload[rows_key(integrator, args.integrator)] = rows
    return payload


def verdicts(rows):
    """Goal of each row: mjcb_passive <= 3x the bare step and <= 0.5x the weld step; plugin <= 1.5x the bare step."""
    verdict = {}
    for name, r in rows.items():
        if name in (BARE, WELD):
            continue
        weld = ratio_between(r, rows[WELD], "vs_weld") or {"vs_weld_median": r["median_s"] / rows[WELD]["median_s"]}
        if name in PLUGIN:
            goal = r["ratio_median"] <= 1.5
        else:
            goal = r["ratio_median"] <= 3.0 and weld["vs_weld_median"] <= 0.5
        verdict[name] = {"vs_bare": r["ratio_median"], "vs_weld": weld["vs_weld_median"], "goal_met": goal}
        verdict[name].update({k: v for k, v in weld.items() if k != "vs_weld_median"})
    return verdict


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--model", default=os.path.join(HERE, "..", "models", "arcade.xml"))
    ap.add_argument("--random", action="store_true", help="random 35-body, 48-element model instead")
    ap.add_argument(
        "--integrator",
        nargs="+",
        choices=["euler", "rk4"],
        default=["euler", "rk4"],
        help="integrators to measure, each in its own table (default: euler rk4)",
    )
    ap.add_argument(
        "--lanes",
        choices=["auto", "2", "4"],
        default="auto",
        help="vector lanes of the native evaluation: auto (4 with AVX, else 2), or force 2 or 4",
    )
    ap.add_argument("--startup-runs", type=int, default=5, help="fresh processes per start-up measurement (0: skip)")
    add_timing_options(ap, "out/bench_step.json", runs=5)
    args = ap.parse_args()
    if len(set(args.integrator)) != len(args.integrator):
        raise SystemExit(f"error: --integrator lists one twice: {' '.join(args.integrator)}")
    payload = measured_in_processes(args) or measure(args)
    payload["verdict"] = {}
    for integrator in args.integrator:
        rows = payload[rows_key(integrator, args.integrator)]
        print_table(rows, f"mj_step ({integrator}), {payload['bodies']} free bodies, {payload['elements']} elements "
                    f"('flexures': the C mjcb_passive provider; native lanes {payload['native_lanes']}); ratios to "
                    "bare in the same repeat")  # fmt: skip
        payload["verdict"][integrator] = verdict = verdicts(rows)
        for name, v in verdict.items():
            goal = "<= 1.5x bare" if name in PLUGIN else "<= 3x bare, <= 0.5x weld"
            print(f"{name}: {v['vs_bare']:.2f}x bare, {v['vs_weld']:.2f}x weld -> goal "
                  f"{'met' if v['goal_met'] else 'NOT met'} ({goal})")  # fmt: skip
    payload["startup"] = {}
    if args.startup_runs and not os.environ.get(CHILD):  # once, in the process that pools the runs
        spec = random_spec() if args.random else mujoco.MjSpec.from_file(args.model)
        plugins_to_records(spec)  # both forms are built from text records (models/arcade.xml: plugin instances)
        plugin_xml, record_xml = plugin_spec(spec, "twist").to_xml(), spec.to_xml()
        with tempfile.TemporaryDirectory() as tmp:
            paths = {"plugin": os.path.join(tmp, "plugin.xml"), "mjcb_passive": os.path.join(tmp, "record.xml")}
            for path, xml in zip(paths.values(), (plugin_xml, record_xml), strict=True):
                with open(path, "w") as f:
                    f.write(xml)
            payload["startup"] = start = startup(paths, args.startup_runs)
        print("\nstart-up: a fresh process from its first import to its first step (median, min-max)")
        for kind, r in start.items():
            what = "import mujoco, load the plugin model" if kind == "plugin" else "import mujoco, mjflex; Flexures"
            print(f"  {kind:<14} {r['median_s']:.3f} s ({r['min_s']:.3f}-{r['max_s']:.3f}): {what}, mj_step")
        payload["verdict"]["startup"] = {"plugin_s": start["plugin"]["median_s"],
                                         "goal_met": start["plugin"]["median_s"] <= 0.5}  # fmt: skip
    write_json(args.json, payload)


if __name__ == "__main__":
    main()

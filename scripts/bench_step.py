"""Cost of a simulation step with 48 flexures, against no elements and against 48 weld constraints.

Usage::

    python scripts/bench_step.py [--model models/arcade.xml | --random] [--json out/bench_step.json]
                                 [--runs 5] [--repeat 21]

The same 35 free bodies are stepped with ``mj_step`` (Euler, the model's time step) from the
same state in three versions, measured interleaved (same-repeat ratios: median, quartiles,
min-max) in each of ``--runs`` fresh processes, whose repeats are pooled (scripts/_bench.py):

* **flexures**: the 48 elements installed (twist and dual-quaternion methods, native callback);
* **bare**: the same model without elements (a separately loaded, unregistered copy);
* **weld**: the same bodies joined instead by 48 MuJoCo ``weld`` equality constraints at the
  element frames (site-to-site), the native way to make a rigid joint.

Goals (issue "MuJoCo layer"): flexure step <= 0.5 x weld step and <= 3 x bare step.
``--random`` uses 35 free bodies on a line (neighbours and random next-but-one pairs linked) with
48 notch-hinge stiffnesses in random orientations instead of the ARCADE model.
"""

import argparse
import os

import mujoco
import numpy as np
from _bench import (
    add_timing_options,
    compare,
    measured_in_processes,
    print_table,
    ratio_between,
    scale_times,
    write_json,
)

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


def measure(args):
    """Time the cases interleaved in this process: the payload's ``rows`` (per ``mj_step``)."""
    spec = random_spec() if args.random else mujoco.MjSpec.from_file(args.model)
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_EULER
    models = {k: spec.compile() for k in ("twist", "dualquat", "bare")}
    models["weld"] = welded(spec, models["bare"]).compile()
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
        "flexures, twist method": stepper(models["twist"], qvel, steps),
        "flexures, dual-quaternion method": stepper(models["dualquat"], qvel, steps),
        WELD: stepper(models["weld"], qvel, steps),
    }
    rows = compare(cases, BARE, repeat=args.repeat)
    check_stable(cases)
    for r in rows.values():  # per mj_step
        scale_times(r, 1 / steps)
    for p in providers:
        p.uninstall()
    return {"model": "random" if args.random else os.path.basename(args.model), "rows": rows,
            "steps_per_call": steps, "bodies": models["bare"].nbody - 1, "elements": len(providers[0])}  # fmt: skip


def verdicts(rows):
    """Goal of each flexure row: <= 3x the bare step and <= 0.5x the weld step (same-repeat ratios)."""
    verdict = {}
    for name, r in rows.items():
        if name in (BARE, WELD):
            continue
        weld = ratio_between(r, rows[WELD], "vs_weld") or {"vs_weld_median": r["median_s"] / rows[WELD]["median_s"]}
        verdict[name] = {"vs_bare": r["ratio_median"], "vs_weld": weld["vs_weld_median"],
                         "goal_met": r["ratio_median"] <= 3.0 and weld["vs_weld_median"] <= 0.5}  # fmt: skip
        verdict[name].update({k: v for k, v in weld.items() if k != "vs_weld_median"})
    return verdict


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--model", default=os.path.join(HERE, "..", "models", "arcade.xml"))
    ap.add_argument("--random", action="store_true", help="random 35-body, 48-element model instead")
    add_timing_options(ap, "out/bench_step.json", runs=5)
    args = ap.parse_args()
    payload = measured_in_processes(args) or measure(args)
    payload["verdict"] = verdicts(payload["rows"])
    print_table(payload["rows"], f"mj_step (Euler), {payload['bodies']} free bodies, {payload['elements']} elements; "
                "ratios to bare in the same repeat")  # fmt: skip
    for name, v in payload["verdict"].items():
        print(f"{name}: {v['vs_bare']:.2f}x bare, {v['vs_weld']:.2f}x weld -> goal "
              f"{'met' if v['goal_met'] else 'NOT met'} (<= 3x bare, <= 0.5x weld)")  # fmt: skip
    write_json(args.json, payload)


if __name__ == "__main__":
    main()

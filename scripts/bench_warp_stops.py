"""What end stops cost the MuJoCo Warp element forces: elements without stops, and elements with stops not engaged.

mjflex's Warp kernels skip the end stops of an element at one per-element flag (read outside
the element math). This script measures what that flag costs elements *without* stops against
kernels built without the stops' code (``mjflex.warp._kernels.build(..., with_stops=False)``,
the same numbers to the bit: tests/test_warp_stops.py), and what stops cost when every element
has them but none is engaged. Per model and number of worlds, every repeat times each case once,
interleaved, and takes its ratio to ``bare`` within the repeat:

* ``bare``: the passive callback (element wrenches, divergence watch, gather into
  ``qfrc_passive``) with the kernels without the stops' code;
* ``stops``: the same with mjflex's kernels, on the same elements (no stops): the flag's cost;
* ``stops_present``: mjflex's kernels with stops on every coordinate of every element, set wide
  (+-3 rad, +-1 m: never engaged) by ``set_parameters``: the stops' math when present;
* ``wrench_bare``, ``wrench_stops``: the element-wrench kernel alone (the one that reads the flag),
  without and with the stops' code;
* ``step_bare``, ``step_stops``: ``mujoco_warp.step`` with the first two callbacks (the flag's
  cost against a whole step).

Each kind (callback, wrench kernel, step) has its own baseline: ``bare``, ``wrench_bare``,
``step_bare``. On Warp's CPU device every launch also pays Warp's Python launch overhead (tens
of microseconds), which dominates at a few worlds.

    python scripts/bench_warp_stops.py --out out/bench_warp_stops [--device cpu] [--worlds 1,8,64]
        [--models arcade,two_body] [--repeat 5] [--target 0.2]

Timings on a shared, loaded machine: read the same-repeat ratios, not the times.
"""

import argparse
import os
import sys
import time

import mujoco
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from _bench import timing_row, write_json

MODELS = {"arcade": "models/arcade.xml", "two_body": "models/two_body_plugin.xml"}
CASES = ("bare", "stops", "stops_present", "wrench_bare", "wrench_stops", "step_bare", "step_stops")
BASELINE = {case: "step_bare" if case.startswith("step") else "wrench_bare" if case.startswith("wrench") else "bare"
            for case in CASES}  # fmt: skip


def _callbacks(mw, model):
    """``{case: (MuJoCo Warp model, callback)}`` of the three callbacks on ``model`` (which has no stops)."""
    from mjflex.warp._forces import WarpFlexures

    out = {}
    for case in ("bare", "stops", "stops_present"):
        m = mw.put_model(model)
        forces = mw.flexures(m)
        if case == "bare":
            forces = WarpFlexures(forces._table, forces.mjmodel, forces.precision, forces.adaptations, with_stops=False)
            m.callback.passive = forces
        elif case == "stops_present":
            wide = np.tile([3.0] * 3 + [1.0] * 3, (len(forces), 1))
            wide[np.ix_(forces._table.planar, [0, 1, 5])] = np.inf  # planar elements: theta, x, y only
            mw.set_parameters(m, stop_lower=-wide, stop_upper=wide, stop_stiffness=np.ones_like(wide))
        out[case] = (m, forces)
    return out


def bench(name, wp, mjw, mw, args, log):
    model = mujoco.MjModel.from_xml_path(os.path.join(os.path.dirname(os.path.dirname(__file__)), MODELS[name]))
    key = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, key, 0)
    rows = {}
    for n in args.worlds:
        callbacks = _callbacks(mw, model)
        d = mjw.make_data(model, nworld=n)
        d.qpos.assign(np.tile(np.float32(key.qpos), (n, 1)))
        d.qvel.assign(np.tile(np.float32(key.qvel), (n, 1)))
        mjw.forward(callbacks["stops"][0], d)
        run = {case: (lambda m=m, f=f, d=d: f(m, d)) for case, (m, f) in callbacks.items()}
        for case, source in (("step_bare", "bare"), ("step_stops", "stops")):
            run[case] = lambda m=callbacks[source][0], d=d: mjw.step(m, d)
        for case, source in (("wrench_bare", "bare"), ("wrench_stops", "stops")):
            m, forces = callbacks[source]
            run[case] = lambda m=m, f=forces, d=d: f._evaluated(m, d)  # the wrench kernel alone
        calls = {}
        for case, fn in run.items():  # compile or load the kernels, then size the calls to the target time
            fn()
            t0 = time.perf_counter()
            fn()
            calls[case] = max(1, int(args.target / max(time.perf_counter() - t0, 1e-7)))
        times = {case: [] for case in CASES}
        for _ in range(args.repeat):
            for case in CASES:
                t0 = time.perf_counter()
                for _ in range(calls[case]):
                    run[case]()
                wp.synchronize_device(d.qpos.device)
                times[case].append((time.perf_counter() - t0) / calls[case])
        row = {case: timing_row(times[case], times[BASELINE[case]], calls=calls[case]) for case in CASES}
        rows[str(n)] = row
        log(f"{name:9s} {n:5d} worlds: callback bare {1e6 * row['bare']['median_s']:9.1f} us, with the flag x"
            f"{row['stops']['ratio_median']:.3f} ({row['stops']['ratio_min']:.3f}-{row['stops']['ratio_max']:.3f}), "
            f"stops present x{row['stops_present']['ratio_median']:.3f}; wrench kernel bare "
            f"{1e6 * row['wrench_bare']['median_s']:8.1f} us, with the flag x{row['wrench_stops']['ratio_median']:.3f} "
            f"({row['wrench_stops']['ratio_min']:.3f}-{row['wrench_stops']['ratio_max']:.3f}); step bare "
            f"{1e3 * row['step_bare']['median_s']:8.2f} ms, with the flag x{row['step_stops']['ratio_median']:.3f} "
            f"({row['step_stops']['ratio_min']:.3f}-{row['step_stops']['ratio_max']:.3f})")  # fmt: skip
    return {"elements": len(mw.flexures(callbacks["stops"][0])), "worlds": rows}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", required=True, help="folder for bench_warp_stops_<cpu|gpu>.json (created)")
    ap.add_argument("--device", default="cpu", help="Warp device: cpu (default) or cuda:0")
    ap.add_argument("--models", default="arcade,two_body", help=f"comma-separated, of {sorted(MODELS)}")
    ap.add_argument("--worlds", default="1,8,64", help="numbers of worlds, comma-separated")
    ap.add_argument("--repeat", type=int, default=5, help="interleaved repeats (default 5)")
    ap.add_argument("--target", type=float, default=0.2, help="seconds per timed case and repeat")
    args = ap.parse_args(argv)
    args.worlds = [int(x) for x in args.worlds.split(",")]
    models = args.models.split(",")
    if [m for m in models if m not in MODELS] or args.repeat < 1 or min(args.worlds) < 1:
        ap.error(f"--models of {sorted(MODELS)}, --repeat >= 1, --worlds >= 1")
    os.makedirs(args.out, exist_ok=True)
    import mujoco_warp as mjw
    import warp as wp

    import mjflex.warp as mw

    wp.init()
    device = wp.get_device(args.device)
    kind = "gpu" if device.is_cuda else "cpu"
    payload = {"device": {"name": device.name, "alias": device.alias, "warp": wp.__version__},
               "repeat": args.repeat, "target_s": args.target, "cases": list(CASES), "models": {}}  # fmt: skip
    print(f"end stops on MuJoCo Warp, device {device.alias}; load average {os.getloadavg()[0]:.1f}; time per call "
          "(median) and same-repeat ratios to the kernels without the stops' code (median, min-max)")  # fmt: skip
    with wp.ScopedDevice(device):
        for name in models:
            payload["models"][name] = bench(name, wp, mjw, mw, args, print)
            write_json(os.path.join(args.out, f"bench_warp_stops_{kind}.json"), payload)


if __name__ == "__main__":
    import warp

    warp.config.log_level = warp.LOG_WARNING  # no start-up banner and module-load lines between the table's rows
    main()

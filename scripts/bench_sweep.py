"""Wall time of an ARCADE sweep: serial loop vs mujoco.batch.Batch vs a spawn process pool vs Dask.

Every repeat runs each case once, interleaved, on the same variants (leaf-spring stiffness x
damping, the paper's initial condition); the ratio to the serial loop is taken within the
repeat. Reported: median wall time, median same-repeat ratio (quartiles, min-max), and the per-task
overhead: the wall time of the same sweep with duration 0 (build every variant, dispatch,
observe; no stepping) divided by the number of variants. Results of every case are checked to
be bit-identical to the serial loop. The machine is shared: read medians and ratios.

    python scripts/bench_sweep.py [--variants 16] [--duration 0.01] [--repeat 7] [--workers 2] [--runs 1]

``--runs N`` repeats the benchmark in N fresh processes and pools their repeats (scripts/_bench.py).
"""

import argparse
import multiprocessing
import os
import statistics
import sys
import time
from concurrent.futures import ProcessPoolExecutor

import mujoco
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from _bench import add_runs_option, measured_in_processes, timing_row, write_json

import mjflex
from mjflex.app.sweep.arcade import arcade_recipe, arcade_stroke


def serial(recipe, rows, duration):
    """The baseline: build, step and observe each variant in turn with mj_step in this thread."""
    out = []
    for params in rows:
        model = recipe.build(**params)
        flex = mjflex.Flexures(model)
        data = mujoco.MjData(model)
        mujoco.mj_resetDataKeyframe(model, data, recipe.keyframe_index(model))
        with flex:
            for _ in range(round(duration / model.opt.timestep)):
                mujoco.mj_step(model, data)
            mujoco.mj_forward(model, data)
            out.append(arcade_stroke(model, flex, data)["stroke"])
    return np.array(out)


def grid_rows(n):
    scales = np.geomspace(0.5, 4.0, max(1, n // 4))
    betas = [0.0, 2e-6, 5e-6, 1e-5][: max(1, min(4, n))]
    rows = [{"leaf_scale": float(s), "beta": b} for s in scales for b in betas]
    return rows[:n]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--variants", type=int, default=16)
    ap.add_argument("--duration", type=float, default=0.01, help="simulated time per variant [s]")
    ap.add_argument("--repeat", type=int, default=7, help="interleaved repeats per process (default 7)")
    ap.add_argument("--workers", type=int, default=2, help="threads (Batch) or processes (pool, Dask)")
    ap.add_argument("--json", default="out/bench_sweep.json")
    add_runs_option(ap)
    args = ap.parse_args(argv)
    if pooled(args) is not None:
        return
    recipe, rows = arcade_recipe(), grid_rows(args.variants)
    pool = ProcessPoolExecutor(args.workers, mp_context=multiprocessing.get_context("spawn"))
    executors = {"batch": None, "pool": pool}
    try:
        from distributed import Client, LocalCluster

        cluster = LocalCluster(n_workers=args.workers, threads_per_worker=1, processes=True, dashboard_address=None)
        executors["dask"] = Client(cluster)
    except ImportError:
        print('Dask not installed (pip install "mjflex[dask]"): no Dask case', file=sys.stderr)
        cluster = None

    def run(name, duration):
        if name == "serial":
            return serial(recipe, rows, duration)
        threads = args.workers if name == "batch" else 1
        ds = mjflex.sweep(recipe, rows, duration, arcade_stroke, executor=executors[name], threads=threads,
                          progress=False)  # fmt: skip
        assert (ds["status"] == "ok").all(), ds["error"].values
        return ds["stroke"].values

    cases = ["serial", *executors]
    load_before = os.getloadavg()[0]
    reference = run("serial", args.duration)
    for name in cases[1:]:  # warm up the workers (imports) and check the results
        np.testing.assert_array_equal(run(name, args.duration), reference, err_msg=name)
    wall = {name: [] for name in cases}
    overhead = {name: [] for name in cases}
    for _ in range(args.repeat):
        for name in cases:
            for duration, store in ((args.duration, wall), (0.0, overhead)):
                t0 = time.perf_counter()
                run(name, duration)
                store[name].append(time.perf_counter() - t0)
    pool.shutdown()
    if cluster is not None:
        executors["dask"].close()
        cluster.close()

    load = (load_before, os.getloadavg()[0])
    n, steps = len(rows), round(args.duration / 1e-5)
    print(f"\nARCADE sweep: {n} variants x {args.duration * 1e3:g} ms ({steps} RK4 steps each), {args.workers} "
          f"threads/processes, {args.repeat} interleaved repeats, {os.cpu_count()} CPUs (shared: noisy; 1-min load "
          f"average {load[0]:.1f} before, {load[1]:.1f} after)")  # fmt: skip
    print(f"{'case':<8} {'wall median':>12} {'vs serial (median, min-max)':>30} {'overhead/variant':>18}")
    result = {}
    for name in cases:
        per_variant = statistics.median(overhead[name]) / n
        result[name] = timing_row(
            wall[name], wall["serial"], overhead_per_variant_s=per_variant, overhead_s=overhead[name]
        )
        r = _named_for_readme(result[name])
        print(f"{name:<8} {r['wall_median_s']:>10.2f} s {r['ratio_to_serial_median']:>14.2f}x "
              f"({r['ratio_min']:.2f}-{r['ratio_max']:.2f}) {r['overhead_per_variant_s'] * 1e3:>14.1f} ms")  # fmt: skip
    print("all cases bit-identical to the serial loop: yes (checked)")
    write_json(args.json, {"variants": n, "duration_s": args.duration, "steps": steps, "workers": args.workers,
                           "repeat": args.repeat, "cases": result, "bit_identical": True,
                           "load_average_before_after": load})  # fmt: skip


def _named_for_readme(row):
    """The row's wall-time median and same-repeat ratio also under the names the sweep block's renderer reads."""
    row["wall_median_s"], row["ratio_to_serial_median"] = row["median_s"], row["ratio_median"]
    return row


def pooled(args):
    """``--runs N``: the benchmark in N fresh processes, repeats pooled (the overheads are the first run's)."""
    payload = measured_in_processes(args)
    if payload is not None:
        for row in payload["cases"].values():
            _named_for_readme(row)
        write_json(args.json, payload)
    return payload


if __name__ == "__main__":
    main()

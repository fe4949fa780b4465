"""Throughput of mjflex on MuJoCo Warp against MuJoCo's own batching, in world-steps per second.

For ARCADE (48 elements, 35 bodies) and the two-body model (one element), for each number of
worlds (default 1 ... 8192), every repeat times each case once, interleaved, and takes its ratio
to ``mujoco.rollout`` within the repeat:

* ``warp``: ``mujoco_warp.step`` with mjflex's passive callback (:func:`mjflex.warp.put_model`),
  float32, on ``--device`` (a step captured as a CUDA graph on a GPU, as MuJoCo Warp's own
  benchmark does; plain launches on the CPU device);
* ``warp_bare``: the same MuJoCo Warp model without the callback (what the elements cost);
* ``rollout``: ``mujoco.rollout`` on ``--threads`` threads, the C plugin in float64 (the baseline);
* ``batch``: ``mujoco.batch.Batch`` on ``--threads`` threads.

Before the timings it records a correctness check on the device: the element forces on random
states and short trajectories of both models against the C engine, within the float32 bounds
of tests/test_warp.py (so that the figures come with evidence that the device computed the
right thing). Worlds whose estimated time exceeds what is left of ``--budget`` are skipped and
listed. Everything (``bench_warp_<cpu|gpu>.json`` and a log) goes to ``--out``.

    python scripts/bench_warp.py --out out/bench_warp [--device cpu] [--worlds 1,8,64,512,4096,8192]
        [--models arcade,two_body] [--repeat 3] [--target 0.3] [--threads N] [--budget 540]

The machine is shared: read medians and same-repeat ratios. Needs no display and no mediapy.
"""

import argparse
import contextlib
import os
import sys
import time
import traceback

import mujoco
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
# tests/ (the check's bounds and models) from the checkout, after the installed packages: an installed mjflex wins
sys.path.append(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from _bench import spread_of, timing_row, write_json

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
MODELS = {"arcade": "models/arcade.xml", "two_body": "models/two_body_plugin.xml"}
CASES = ("rollout", "warp", "warp_bare", "batch")  # the first is the baseline of the ratios
MIN_LEFT_S = 20.0  # a size is not started with less of the budget left


class Log:
    """Print every line and append it to the log file at once (a run stopped by a time limit keeps its log)."""

    def __init__(self, path):
        self.path = path
        open(path, "w").close()

    def __call__(self, *parts):
        line = " ".join(str(p) for p in parts)
        print(line, flush=True)
        with open(self.path, "a") as f:
            f.write(line + "\n")


def device_info(wp, device):
    info = {"name": device.name, "alias": device.alias, "is_cuda": bool(device.is_cuda), "warp": wp.__version__}
    import mujoco_warp

    info["mujoco_warp"] = mujoco_warp.__version__
    if device.is_cuda:
        info["arch"] = getattr(device, "arch", None)
        info["total_memory_gib"] = round(getattr(device, "total_memory", 0) / 2**30, 1)
        for name in ("get_cuda_driver_version", "get_cuda_toolkit_version"):
            with contextlib.suppress(Exception):
                info[name[4:]] = ".".join(map(str, getattr(wp, name)()))
    return info


# ------------------------------------------------------------------------ correctness on the device


def correctness_check(log):
    """Forces of random states and trajectories against the C engine, within tests/test_warp.py's bounds."""
    try:
        from tests import warp_bounds as wb
        from tests.warp_models import features_model, random_state
    except ImportError as exc:
        log(f"correctness check skipped: {exc} (run from a checkout of the repository)")
        return {"skipped": str(exc)}
    import mujoco_warp as mjw

    import mjflex
    import mjflex.warp as mw

    out = {}
    model = features_model("plugin", stops=True)  # every element feature, end stops engaged in some states
    rng = np.random.default_rng(11)
    states = [random_state(model, rng, angle=2.5) for _ in range(12)]
    m = mw.put_model(model)
    d = mjw.make_data(model, nworld=len(states))
    d.qpos.assign(np.array([s[0] for s in states], np.float32))
    d.qvel.assign(np.array([s[1] for s in states], np.float32))
    mjw.forward(m, d)
    got = {
        "wrench": mw.wrenches(m, d),
        "energy": mw.potential_energies(m, d),
        "power": mw.dissipation_powers(m, d),
        "twist": mw.displacements(m, d),
        "qfrc": mw.generalized_forces(m, d),
        "stops": mw.stop_coordinates(m, d),
    }
    flex, worst = mjflex.Flexures(model), {}
    for i, (qpos, qvel) in enumerate(states):
        data = mujoco.MjData(model)
        data.qpos[:], data.qvel[:] = np.float32(qpos), np.float32(qvel)
        mujoco.mj_forward(model, data)
        ref, bound = wb.c_queries(flex, data), wb.bounds(model, data, flex)
        for key in ref:
            ratio = np.abs(got[key][i] - ref[key]) / np.maximum(bound[key], 1e-300)
            worst[key] = max(worst.get(key, 0.0), float(ratio.max()))
    out["forces"] = {"states": len(states), "elements": len(flex), "largest_error_over_bound": worst,
                     "passed": all(v <= 1.0 for v in worst.values())}  # fmt: skip
    log(f"forces of {len(states)} random states x {len(flex)} elements vs the C engine: largest error / derived bound "
        + ", ".join(f"{k} {v:.2g}" for k, v in worst.items()))  # fmt: skip
    for name, nstep in (("two_body", 200), ("arcade", 100)):
        model = mujoco.MjModel.from_xml_path(os.path.join(ROOT, MODELS[name]))
        key = mujoco.MjData(model)
        mujoco.mj_resetDataKeyframe(model, key, 0)
        m = mw.put_model(model)
        d = mjw.make_data(model, nworld=1)
        d.qpos.assign(np.float32(key.qpos)[None])
        d.qvel.assign(np.float32(key.qvel)[None])
        traj = np.empty((nstep, model.nq + model.nv))
        for k in range(nstep):
            mjw.step(m, d)
            traj[k] = np.concatenate([d.qpos.numpy()[0], d.qvel.numpy()[0]])
        ref, bound = wb.trajectory_bound(model, key.qpos, key.qvel, nstep)
        err = np.stack([np.abs(traj - ref)[:, g].max(1) for g in wb.state_groups(model)], 1)
        ratio = float((err / np.maximum(bound, 1e-300)).max())
        out[f"trajectory_{name}"] = {"steps": nstep, "largest_error_over_bound": ratio, "passed": ratio <= 1.0,
                                     "diverged_worlds": len(mw.divergences(m, d))}  # fmt: skip
        log(f"{name}: {nstep} steps from its keyframe vs the C plugin: largest error / derived bound {ratio:.2g}")
    out["passed"] = all(v["passed"] for v in out.values() if isinstance(v, dict))
    log("correctness check:", "PASSED" if out["passed"] else "FAILED (the timings below are of wrong results)")
    return out


# ------------------------------------------------------------------------ the cases


class Cases:
    """The four ways to step ``n`` worlds of one model, each a callable of a step count."""

    def __init__(self, wp, mjw, mw, model, n, threads, device):
        from mujoco import rollout
        from mujoco.batch import Batch

        self.wp, self.mjw, self.device, self.n = wp, mjw, device, n
        key = mujoco.MjData(model)
        mujoco.mj_resetDataKeyframe(model, key, 0)
        spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
        state = np.empty(mujoco.mj_stateSize(model, spec))
        mujoco.mj_getState(model, key, state, spec)
        self.state0 = np.tile(state, (n, 1))
        self.models, self.datas = [model] * n, [mujoco.MjData(model) for _ in range(threads)]
        self.rollout = rollout.Rollout(nthread=threads)
        self.batch = Batch(model, n, threads)
        self.batch.reset(keyframe=np.zeros(n, np.int32))
        self.warp = self._warp(mw, model, key, n, bare=False)
        self.warp_bare = self._warp(mw, model, key, n, bare=True)
        self.first_step_s = {}

    def _warp(self, mw, model, key, n, bare):
        m = mw.put_model(model)
        if bare:
            m.callback.passive = None
        d = self.mjw.make_data(model, nworld=n)
        d.qpos.assign(np.tile(np.float32(key.qpos), (n, 1)))
        d.qvel.assign(np.tile(np.float32(key.qvel), (n, 1)))
        return {"m": m, "d": d, "graph": None}

    def warm_up(self):
        """One step of each (compiles MuJoCo Warp's and mjflex's kernels, or loads them from Warp's cache)."""
        for name in CASES:
            t0 = time.perf_counter()
            self.run(name, 1, capture=True)
            self.first_step_s[name] = time.perf_counter() - t0

    def run(self, name, steps, capture=False):
        if name == "rollout":
            self.rollout.rollout(self.models, self.datas, self.state0, nstep=steps)
        elif name == "batch":
            self.batch.step(nstep=steps)
        else:
            w = getattr(self, name)
            if self.device.is_cuda and capture and w["graph"] is None:
                self.mjw.step(w["m"], w["d"])  # allocate what the first step allocates, outside the capture
                try:
                    with self.wp.ScopedCapture() as cap:
                        self.mjw.step(w["m"], w["d"])
                    w["graph"] = cap.graph
                except Exception as exc:  # e.g. no memory pool for allocations in a capture: plain launches
                    w["graph"], w["no_graph"] = None, f"{type(exc).__name__}: {exc}"
                    self.wp.synchronize_device(self.device)
            for _ in range(steps):
                if w["graph"] is not None:
                    self.wp.capture_launch(w["graph"])
                else:
                    self.mjw.step(w["m"], w["d"])
            self.wp.synchronize_device(self.device)

    def warp_graph(self, name):
        w = getattr(self, name)
        return True if w["graph"] is not None else w.get("no_graph", False)

    def diverged(self, mw):
        return {name: len(mw.divergences(getattr(self, name)["m"], getattr(self, name)["d"])) for name in ("warp",)}


def bench_model(name, wp, mjw, mw, args, device, log, deadline, save):
    model = mujoco.MjModel.from_xml_path(os.path.join(ROOT, MODELS[name]))
    rows, skipped, per_world_step = {}, {}, None
    out = {"path": MODELS[name], "nbody": model.nbody, "nv": model.nv, "timestep_s": float(model.opt.timestep),
           "integrator": "RK4", "worlds": rows, "skipped": skipped}  # fmt: skip
    for n in args.worlds:
        left = deadline - time.perf_counter()
        if left < MIN_LEFT_S:
            skipped[str(n)] = f"{left:.0f} s of the budget left"
            log(f"{name}, {n} worlds: skipped ({skipped[str(n)]})")
            continue
        if per_world_step is not None:
            estimate = args.repeat * sum(max(args.target, n * t) for t in per_world_step.values()) * 1.5 + 5
            if estimate > left:
                skipped[str(n)] = f"estimated {estimate:.0f} s, {left:.0f} s of the budget left"
                log(f"{name}, {n} worlds: skipped ({skipped[str(n)]})")
                continue
        try:
            cases = Cases(wp, mjw, mw, model, n, args.threads, device)
            cases.warm_up()
            steps = {}
            for case in CASES:
                t0 = time.perf_counter()
                cases.run(case, 1)
                one = max(time.perf_counter() - t0, 1e-6)
                steps[case] = int(np.clip(round(args.target / one), 1, 2000))
            times = {case: [] for case in CASES}
            for _ in range(args.repeat):
                for case in CASES:
                    t0 = time.perf_counter()
                    cases.run(case, steps[case])
                    times[case].append((time.perf_counter() - t0) / (steps[case] * n))
        except Exception as exc:  # out of memory at large sizes, a driver problem: say so, go on
            skipped[str(n)] = f"{type(exc).__name__}: {exc}"
            log(f"{name}, {n} worlds: failed: {skipped[str(n)]}")
            traceback.print_exc()
            continue
        per_world_step = {case: float(np.median(t)) for case, t in times.items()}
        row = {}
        for case in CASES:
            r = timing_row(times[case], times["rollout"], steps_per_call=steps[case],
                           first_step_s=round(cases.first_step_s[case], 3))  # fmt: skip
            r.update(spread_of(1.0 / np.asarray(times[case]), "world_steps_per_s"))
            row[case] = r
        row["diverged_worlds"] = cases.diverged(mw)
        row["cuda_graph"] = {c: cases.warp_graph(c) for c in ("warp", "warp_bare")} if device.is_cuda else None
        rows[str(n)] = row
        log(_table_line(name, n, row))
        save(name, out)
    return out


def _table_line(name, n, row):
    cells = []
    for case in CASES:
        r = row[case]
        rate = f"{r['world_steps_per_s_median']:.3g}"
        fast = (1 / r["ratio_median"], 1 / r["ratio_max"], 1 / r["ratio_min"])  # throughput relative to rollout
        vs = "" if case == "rollout" else f" ({fast[0]:.3g}x, {fast[1]:.3g}-{fast[2]:.3g})"
        cells.append(f"{case} {rate}/s{vs}")
    return f"{name:<9} {n:>6} worlds: " + "; ".join(cells)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", required=True, help="folder for bench_warp_<cpu|gpu>.json and .log (created)")
    ap.add_argument("--device", default="cpu", help="Warp device: cpu (default) or cuda:0")
    ap.add_argument("--models", default="arcade,two_body", help=f"comma-separated, of {sorted(MODELS)}")
    ap.add_argument("--worlds", default="1,8,64,512,4096,8192", help="numbers of worlds, comma-separated")
    ap.add_argument("--repeat", type=int, default=3, help="interleaved repeats (default 3)")
    ap.add_argument("--target", type=float, default=0.3, help="seconds per timed call (sets the steps per call)")
    ap.add_argument("--threads", type=int, default=os.cpu_count(), help="threads of rollout and Batch (default all)")
    ap.add_argument("--budget", type=float, default=540.0, help="seconds for everything; larger sizes are skipped")
    ap.add_argument("--no-check", action="store_true", help="skip the correctness check")
    args = ap.parse_args(argv)
    args.worlds = [int(x) for x in args.worlds.split(",")]
    models = args.models.split(",")
    unknown = [m for m in models if m not in MODELS]
    if unknown or args.repeat < 1 or min(args.worlds) < 1:
        ap.error(f"--models of {sorted(MODELS)}, --repeat >= 1, --worlds >= 1 (got {unknown or args})")
    deadline = time.perf_counter() + args.budget
    os.makedirs(args.out, exist_ok=True)
    import mujoco_warp as mjw
    import warp as wp

    import mjflex.warp as mw

    wp.init()
    device = wp.get_device(args.device)
    kind = "gpu" if device.is_cuda else "cpu"
    log = Log(os.path.join(args.out, f"bench_warp_{kind}.log"))
    payload = {"device": device_info(wp, device), "threads": args.threads, "repeat": args.repeat,
               "target_s": args.target, "budget_s": args.budget, "cases": list(CASES), "models": {}}  # fmt: skip
    log(f"mjflex on MuJoCo Warp, device {device.alias} ({device.name}); C baselines on {args.threads} threads of "
        f"{os.cpu_count()} CPUs; load average {os.getloadavg()[0]:.1f}")  # fmt: skip
    path = os.path.join(args.out, f"bench_warp_{kind}.json")

    def save(name, rows):  # after every size: a run stopped by a time limit keeps what it measured
        payload["models"][name] = rows
        write_json(path, payload)

    with wp.ScopedDevice(device):
        payload["check"] = {} if args.no_check else correctness_check(log)
        write_json(path, payload)
        log("world-steps per second, median of the repeats (throughput relative to rollout's in the same repeat: "
            "median, min-max):")  # fmt: skip
        for name in models:
            save(name, bench_model(name, wp, mjw, mw, args, device, log, deadline, save))


if __name__ == "__main__":
    main()

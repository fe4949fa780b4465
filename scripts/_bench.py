"""Timing and output helpers shared by the benchmark and measurement scripts.

These machines are shared and noisy, so cases are measured *interleaved*: every repeat
times each case once (``number`` calls), and each case's ratio to the baseline is taken
within the same repeat. Every timing row (:func:`timing_row`) records the median time per
call and the median of the same-repeat ratios with their spread (quartiles and min-max) and
the ratios themselves, so that any two rows give a same-repeat ratio too
(:func:`ratio_between`).

One process is not the whole story: the medians of fresh processes differ by more than the
repeats of one (code placement, caches, frequency scaling). ``--runs N``
(:func:`add_runs_option`, :func:`measured_in_processes`) runs a script N times in fresh
interpreters, one after another, and pools their repeats: the spread is then over all
repeats of all runs, and ``run_ratio_medians`` lists each run's median.

Every script writes its JSON with :func:`write_json`, which adds the command, the date, the
script's wall time and the machine (:func:`machine`: CPU model, logical cores, load average
before and after). Run a script with ``MJFLEX_RECORD=1`` in the environment to
also record the JSON in ``docs/results/`` under the JSON's own file name (by default
``<script>.json``; runs of one script with other arguments are recorded side by side when their
``--json`` names differ, e.g. ``long_run_arcade.json``), committed: the measured figures of the
README and the documentation pages are generated from those files by
``python scripts/results_blocks.py``.
"""

import copy
import datetime
import json
import os
import platform
import shlex
import subprocess
import sys
import tempfile
import time

import numpy as np

_START = time.perf_counter()  # the script's clock: scripts import this module before their work
_LOAD_BEFORE = os.getloadavg()[0]


def _calls_for(fn, target):
    t0 = time.perf_counter()
    fn()
    one = max(time.perf_counter() - t0, 1e-7)
    return max(1, int(target / one))


def spread_of(values, prefix):
    """``{prefix}_median, _q1, _q3, _min, _max`` of ``values``."""
    v = np.asarray(values, float)
    q1, median, q3 = np.percentile(v, [25, 50, 75])
    return {f"{prefix}_median": float(median), f"{prefix}_q1": float(q1), f"{prefix}_q3": float(q3),
            f"{prefix}_min": float(v.min()), f"{prefix}_max": float(v.max())}  # fmt: skip


def timing_row(times, base_times, **extra):
    """A timing row: seconds per call of each repeat (``times``) against the baseline's of the same repeats.

    Keys: ``median_s, min_s, max_s`` (time per call), ``ratio_median, ratio_q1, ratio_q3, ratio_min,
    ratio_max`` (same-repeat ratios to the baseline), ``times_s`` and ``ratios`` (every repeat, for
    :func:`ratio_between` and :func:`merge_runs`), ``repeats``, and ``extra``.
    """
    t, base = np.asarray(times, float), np.asarray(base_times, float)
    ratio = t / base
    row = {"median_s": float(np.median(t)), "min_s": float(t.min()), "max_s": float(t.max())}
    row.update(spread_of(ratio, "ratio"))
    row.update(extra)
    row.update({"repeats": len(t), "times_s": [float(f"{x:.6g}") for x in t],
                "ratios": [float(f"{x:.6g}") for x in ratio]})  # fmt: skip
    return row


def scale_times(row, factor):
    """Times of ``row`` per ``1 / factor`` of a call (e.g. per step of a call of several steps); ratios unchanged."""
    for key in ("median_s", "min_s", "max_s"):
        row[key] *= factor
    row["times_s"] = [float(f"{x * factor:.6g}") for x in row["times_s"]]


def ratio_between(row, other, prefix="ratio"):
    """Same-repeat ratio of two rows of one measurement (``row / other``): median and spread.

    From the per-repeat ratios to their common baseline; ``{}`` for rows recorded without them.
    """
    if "ratios" not in row or "ratios" not in other:
        return {}
    return spread_of(np.asarray(row["ratios"]) / np.asarray(other["ratios"]), prefix)


def compare(cases, baseline, *, repeat=21, target=0.01):
    """Time ``cases`` (name -> zero-argument callable) interleaved against ``cases[baseline]``.

    Returns name -> :func:`timing_row` (plus ``calls_per_run``, the calls timed together in a repeat).
    """
    for fn in cases.values():
        fn()  # warm up (JIT compilation, caches)
    number = {name: _calls_for(fn, target) for name, fn in cases.items()}
    times = {name: [] for name in cases}
    for _ in range(repeat):
        for name, fn in cases.items():
            n = number[name]
            t0 = time.perf_counter()
            for _ in range(n):
                fn()
            times[name].append((time.perf_counter() - t0) / n)
    return {name: timing_row(t, times[baseline], calls_per_run=number[name]) for name, t in times.items()}


# ------------------------------------------------------------------------ independent processes


def add_runs_option(ap, default=1):
    """``--runs N``: time in N fresh processes, one after another, and pool their repeats."""
    ap.add_argument("--runs", type=int, default=default,
                    help=f"independent processes to measure in, one after another; spreads pool all their repeats "
                         f"(default {default})")  # fmt: skip


def add_timing_options(ap, json_path, *, repeat=21, runs=1):
    """The options of a benchmark script: ``--json``, ``--repeat`` (per process) and ``--runs``."""
    ap.add_argument("--json", default=json_path)
    ap.add_argument("--repeat", type=int, default=repeat, help=f"interleaved repeats per process (default {repeat})")
    add_runs_option(ap, runs)


def _argv_without(argv, options):
    out, skip = [], False
    for arg in argv:
        if skip:
            skip = False
        elif arg in options:
            skip = True
        elif not any(arg.startswith(o + "=") for o in options):
            out.append(arg)
    return out


#: Environment variable set in the fresh processes of :func:`measured_in_processes`.
CHILD = "MJFLEX_BENCH_CHILD"


def measured_in_processes(args):
    """With ``args.runs > 1``: this script run ``args.runs`` times in fresh interpreters, payloads merged; else None.

    Each child runs with ``--runs 1`` and a temporary ``--json`` and records nothing; the caller derives
    what depends on the timings from the merged payload (:func:`merge_runs`), then writes it.
    """
    if args.runs < 1:
        raise SystemExit(f"error: --runs must be >= 1, got {args.runs}")
    if args.runs == 1:
        return None
    env = {k: v for k, v in os.environ.items() if k != "MJFLEX_RECORD"}
    env[CHILD] = "1"  # what a script measures once, not per run (e.g. start-up), it skips in the children
    payloads = []
    with tempfile.TemporaryDirectory() as folder:
        for i in range(args.runs):
            path = os.path.join(folder, f"run{i}.json")
            argv = _argv_without(sys.argv[1:], ("--runs", "--json"))
            print(f"\n--- run {i + 1} of {args.runs} (a fresh process) ---", flush=True)
            subprocess.run([sys.executable, sys.argv[0], *argv, "--runs", "1", "--json", path], env=env, check=True)
            with open(path) as f:
                payloads.append(json.load(f))
    merged = merge_runs(payloads)
    print(f"\n--- {args.runs} runs pooled ---")
    for where, row in timing_rows(merged):
        print(f"{where:<70} {row['ratio_median']:.2f}x ({row['ratio_min']:.2f}-{row['ratio_max']:.2f}); "
              f"run medians {min(row['run_ratio_medians']):.2f}-{max(row['run_ratio_medians']):.2f}")  # fmt: skip
    return merged


def timing_rows(payload, where=""):
    """``(path, row)`` of every timing row (a dict with ``ratios``) in a payload, depth first."""
    if isinstance(payload, dict):
        if "ratios" in payload and "times_s" in payload:
            yield where, payload
            return
        for key, value in payload.items():
            yield from timing_rows(value, f"{where}/{key}" if where else str(key))
    elif isinstance(payload, list):
        for i, value in enumerate(payload):
            yield from timing_rows(value, f"{where}[{i}]")


def merge_runs(payloads):
    """The first payload with each timing row pooled over all payloads (same structure, same rows).

    A pooled row has the statistics of all repeats of all runs, ``run_ratio_medians`` (each run's
    median) and ``processes``; everything else is the first run's (recompute what derives from timings).
    """
    merged = copy.deepcopy(payloads[0])
    rows = [dict(timing_rows(p)) for p in payloads]
    for where, row in timing_rows(merged):
        runs = [r[where] for r in rows]
        times = np.concatenate([r["times_s"] for r in runs])
        ratios = np.concatenate([r["ratios"] for r in runs])
        pooled = timing_row(times, times / ratios)
        keep = {k: v for k, v in row.items() if k not in pooled}
        row.clear()
        row.update(pooled)
        row.update(keep)
        row["repeats"] = runs[0]["repeats"]
        row["processes"] = len(runs)
        row["run_ratio_medians"] = [r["ratio_median"] for r in runs]
    merged["processes"] = len(payloads)
    return merged


def print_table(rows, title):
    """Print the rows of :func:`compare`: median time, and the same-repeat ratio's median, quartiles and min-max."""
    print(f"\n{title}")
    print(f"{'case':<56} {'median':>11} {'min':>11}   ratio: median (quartiles) [min-max]")
    for name, r in rows.items():
        quartiles, extremes = f"{r['ratio_q1']:.2f}-{r['ratio_q3']:.2f}", f"{r['ratio_min']:.2f}-{r['ratio_max']:.2f}"
        ratio = f"{r['ratio_median']:.2f}x ({quartiles}) [{extremes}]"
        print(f"{name:<56} {r['median_s'] * 1e6:>9.2f}us {r['min_s'] * 1e6:>9.2f}us   {ratio}")


RESULTS = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "docs", "results")


def write_json(path, payload):
    """Write ``payload`` with command, date, wall time and machine to ``path``; also to docs/results if recording.

    Recording (``MJFLEX_RECORD=1``) writes ``docs/results/<file name of path>``, which must be the
    running script's name, optionally with a suffix (``long_run_arcade.json`` from
    ``scripts/long_run.py``), so that every recorded file says which script made it.
    """
    payload = dict(payload)
    script = os.path.relpath(os.path.abspath(sys.argv[0]), os.path.join(RESULTS, "..", ".."))
    payload["command"] = shlex.join(["python", script.replace(os.sep, "/"), *sys.argv[1:]])
    payload["date"] = datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds")
    payload["script_wall_s"] = round(time.perf_counter() - _START, 1)
    payload["machine"] = machine()
    paths = [path]
    if os.environ.get("MJFLEX_RECORD") == "1":
        name, stem = os.path.basename(path), os.path.splitext(os.path.basename(sys.argv[0]))[0]
        if name == f"{stem}.json" or (name.startswith(f"{stem}_") and name.endswith(".json")):
            paths.append(os.path.join(RESULTS, name))
        else:
            print(f"\nnot recorded: name the JSON {stem}.json or {stem}_<what>.json to record it", file=sys.stderr)
    for target in paths:
        os.makedirs(os.path.dirname(os.path.abspath(target)), exist_ok=True)
        with open(target, "w") as f:
            json.dump(payload, f, indent=1)
            f.write("\n")
        print(f"\nwrote {os.path.normpath(target)}")


def cpu_model():
    """The CPU's model name (``/proc/cpuinfo``; elsewhere what ``platform`` knows)."""
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith(("model name", "Hardware", "Processor")) and ":" in line:
                    return " ".join(line.split(":", 1)[1].split())
    except OSError:
        pass
    return platform.processor() or platform.machine() or "unknown"


def machine():
    """What a reader needs to judge the timings: CPU model, cores, load average before and after, versions."""
    usable = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    versions = {name: getattr(sys.modules[name], "__version__", "?") for name in ("mujoco", "numpy", "numba", "scipy")
                if name in sys.modules}  # fmt: skip
    return {
        "cpu_model": cpu_model(),
        "logical_cores": os.cpu_count(),
        "usable_cores": usable,
        "load_average_1min_before": round(_LOAD_BEFORE, 2),  # when the script started
        "load_average_1min_after": round(os.getloadavg()[0], 2),  # when it wrote its JSON
        "platform": platform.platform(),
        "python": platform.python_version(),
        "versions": versions,
    }

"""Timing and output helpers shared by the benchmark and measurement scripts.

These machines are shared and noisy, so cases are measured *interleaved*: every repeat
times each case once (``number`` calls), and each case's ratio to the baseline is taken
within the same repeat. Reported: median time per call and median same-repeat ratio.

Every script writes its JSON with :func:`write_json`, which adds the command, the date, the
script's wall time and the machine. Run a script with ``MJFLEX_RECORD=1`` in the environment to
also record the JSON in ``docs/results/`` under the JSON's own file name (by default
``<script>.json``; runs of one script with other arguments are recorded side by side when their
``--json`` names differ, e.g. ``long_run_arcade.json``), committed: README.md's measured figures
are generated from those files by ``python scripts/readme_results.py``.
"""

import datetime
import json
import os
import platform
import shlex
import sys
import time

import numpy as np

_START = time.perf_counter()  # the script's clock: scripts import this module before their work


def _calls_for(fn, target):
    t0 = time.perf_counter()
    fn()
    one = max(time.perf_counter() - t0, 1e-7)
    return max(1, int(target / one))


def compare(cases, baseline, *, repeat=21, target=0.01):
    """Time ``cases`` (name -> zero-argument callable) interleaved against ``cases[baseline]``.

    Returns name -> {median_s, min_s, max_s, ratio_median, ratio_min, ratio_max, calls_per_run, runs}.
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
    base = np.array(times[baseline])
    out = {}
    for name, t in times.items():
        t = np.array(t)
        ratio = t / base
        out[name] = {
            "median_s": float(np.median(t)),
            "min_s": float(t.min()),
            "max_s": float(t.max()),
            "ratio_median": float(np.median(ratio)),
            "ratio_min": float(ratio.min()),
            "ratio_max": float(ratio.max()),
            "calls_per_run": number[name],
            "runs": repeat,
        }
    return out


def print_table(rows, title):
    """Print the rows of :func:`compare`."""
    print(f"\n{title}")
    print(f"{'case':<56} {'median':>11} {'min':>11} {'ratio (median, min-max)':>26}")
    for name, r in rows.items():
        ratio = f"{r['ratio_median']:.2f}x ({r['ratio_min']:.2f}-{r['ratio_max']:.2f})"
        print(f"{name:<56} {r['median_s'] * 1e6:>9.2f}us {r['min_s'] * 1e6:>9.2f}us {ratio:>26}")


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
    payload["machine"] = {
        "platform": platform.platform(),
        "python": platform.python_version(),
        "cpus": os.cpu_count(),
        "load_average_1min": round(os.getloadavg()[0], 2),
    }  # at the end of the run
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

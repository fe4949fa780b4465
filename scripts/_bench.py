"""Timing helpers shared by the benchmark scripts.

These machines are shared and noisy, so cases are measured *interleaved*: every repeat
times each case once (``number`` calls), and each case's ratio to the baseline is taken
within the same repeat. Reported: median time per call and median same-repeat ratio.
"""

import json
import os
import platform
import time

import numpy as np


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


def write_json(path, payload):
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    payload = dict(payload)
    payload["machine"] = {"platform": platform.platform(), "python": platform.python_version(), "cpus": os.cpu_count()}
    with open(path, "w") as f:
        json.dump(payload, f, indent=2)
    print(f"\nwrote {path}")

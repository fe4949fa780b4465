"""scripts/_bench.py: the statistics of timing rows, pooling fresh processes (--runs), the machine record."""

import json
import os
import subprocess
import sys

import numpy as np
import pytest

ROOT = os.path.join(os.path.dirname(__file__), "..")
sys.path.insert(0, os.path.join(ROOT, "scripts"))

import _bench  # noqa: E402


def test_timing_row_keeps_every_repeat_and_its_spread():
    base = [1.0, 2.0, 1.0, 1.0, 4.0]
    row = _bench.timing_row([2.0, 3.0, 2.5, 2.0, 6.0], base)
    assert row["ratios"] == [2.0, 1.5, 2.5, 2.0, 1.5]  # same-repeat ratios, not ratios of medians
    assert row["ratio_median"] == 2.0 and (row["ratio_min"], row["ratio_max"]) == (1.5, 2.5)
    assert (row["ratio_q1"], row["ratio_q3"]) == (1.5, 2.0) and row["repeats"] == 5
    assert row["median_s"] == 2.5 and row["times_s"][4] == 6.0
    other = _bench.timing_row([1.0, 2.0, 1.0, 1.0, 4.0], base)  # the baseline itself: ratios 1
    assert _bench.ratio_between(row, other)["ratio_median"] == 2.0
    assert _bench.ratio_between(row, {"ratio_median": 1.0}) == {}  # older rows carry no repeats


def test_runs_are_pooled_repeat_by_repeat():
    runs = [{"rows": {"a": _bench.timing_row([s * r for r in ratios], [s] * 3)}, "note": k}
            for k, (s, ratios) in enumerate([(1.0, [2.0, 2.1, 2.2]), (3.0, [2.6, 2.7, 2.8])])]  # fmt: skip
    merged = _bench.merge_runs(runs)
    row = merged["rows"]["a"]
    assert merged["processes"] == 2 and row["processes"] == 2 and row["repeats"] == 3 and merged["note"] == 0
    assert row["run_ratio_medians"] == pytest.approx([2.1, 2.7])
    assert row["ratio_min"] == 2.0 and row["ratio_max"] == pytest.approx(2.8) and len(row["ratios"]) == 6
    assert row["ratio_median"] == pytest.approx(np.median([2.0, 2.1, 2.2, 2.6, 2.7, 2.8]))


def test_machine_says_cpu_cores_and_load():
    m = _bench.machine()
    assert m["cpu_model"] and m["logical_cores"] >= 1 and m["usable_cores"] >= 1
    assert m["load_average_1min_before"] >= 0 and m["load_average_1min_after"] >= 0
    assert m["versions"]["numpy"] == np.__version__


SCRIPT = """
import argparse, sys
sys.path.insert(0, {scripts!r})
from _bench import add_runs_option, compare, measured_in_processes, write_json

ap = argparse.ArgumentParser()
ap.add_argument("--json")
ap.add_argument("--repeat", type=int, default=3)
add_runs_option(ap, default=3)
args = ap.parse_args()
payload = measured_in_processes(args) or {{"rows": compare({{"base": lambda: sum(range(50)),
    "double": lambda: (sum(range(50)), sum(range(50)))}}, "base", repeat=args.repeat, target=1e-4)}}
write_json(args.json, payload)
"""


def test_runs_option_times_in_fresh_processes(tmp_path):
    script = tmp_path / "bench_tiny.py"
    script.write_text(SCRIPT.format(scripts=os.path.join(ROOT, "scripts")))
    out = tmp_path / "tiny.json"
    env = {k: v for k, v in os.environ.items() if k != "MJFLEX_RECORD"}
    result = subprocess.run([sys.executable, str(script), "--json", str(out), "--repeat", "4"], env=env,
                            capture_output=True, text=True, timeout=300)  # fmt: skip
    assert result.returncode == 0, result.stderr
    assert result.stdout.count("(a fresh process)") == 3 and "3 runs pooled" in result.stdout
    payload = json.loads(out.read_text())
    row = payload["rows"]["double"]
    assert payload["processes"] == 3 and row["processes"] == 3 and row["repeats"] == 4 and len(row["ratios"]) == 12
    assert len(row["run_ratio_medians"]) == 3 and row["ratio_min"] <= min(row["run_ratio_medians"])
    assert payload["command"].endswith("--json " + str(out) + " --repeat 4")  # the command as given, not a child's
    assert "cpu_model" in payload["machine"]

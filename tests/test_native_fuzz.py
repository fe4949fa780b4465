"""A short derandomized slice of the native fuzzer (scripts/fuzz_native.py): no crash, no hang, no accepted
configuration with non-finite forces, no valid model refused (issue 22).

The full run (8,000 configurations and 3,000 states by default) is ``python scripts/fuzz_native.py``; this
slice is its first cases of a fixed seed, each in a forked child.
"""

import json
import os
import subprocess
import sys

import pytest

from tests.native_cases import ROOT

CONFIGS, STATES, SEED = 100, 60, 2026


@pytest.mark.skipif(not hasattr(os, "fork"), reason="the fuzzer forks a child per case (POSIX only)")
def test_a_fuzz_slice_finds_no_defect(tmp_path):
    out = tmp_path / "fuzz.json"
    result = subprocess.run(
        [sys.executable, os.path.join(ROOT, "scripts", "fuzz_native.py"), "--configs", str(CONFIGS), "--states",
         str(STATES), "--seed", str(SEED), "--json", str(out)],
        capture_output=True, text=True, timeout=600, cwd=ROOT,
    )  # fmt: skip
    assert result.returncode == 0, result.stdout + result.stderr
    report = json.loads(out.read_text())
    assert report["failures"] == [] and report["nan_configs"] == []
    config, state = report["counts"]["config"], report["counts"]["state"]
    assert sum(config.values()) == CONFIGS and sum(state.values()) == STATES
    # the slice reaches both sides of the checks: refused and accepted configurations, finite and NaN states
    assert config["compile error"] > CONFIGS // 2 and config["accepted finite"] > 0
    assert state["accepted finite"] > 0 and state["NaN"] > 0 and state["compile error"] == 0

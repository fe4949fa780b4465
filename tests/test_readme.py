"""The README's Python example runs as written, from the repository root."""

import datetime
import importlib.util
import os
import re

import numpy as np
import pytest

ROOT = os.path.join(os.path.dirname(__file__), "..")


def test_readme_python_blocks_run(monkeypatch, capsys):
    with open(os.path.join(ROOT, "README.md")) as f:
        blocks = re.findall(r"```python\n(.*?)```", f.read(), flags=re.S)
    assert blocks
    monkeypatch.chdir(ROOT)
    for code in blocks:
        exec(compile(code, "README.md", "exec"), {})
    out = capsys.readouterr().out
    assert "flexure energy" in out and "dissipating" in out


def test_readme_test_command_is_what_ci_runs():
    with open(os.path.join(ROOT, "README.md")) as f:
        readme = f.read()
    with open(os.path.join(ROOT, ".ci", "run")) as f:
        ci = f.read()
    command = 'python -m pip install -e ".[test]" && python -m pytest'
    assert command in readme and command in ci


def _generator():
    spec = importlib.util.spec_from_file_location("readme_results", os.path.join(ROOT, "scripts", "readme_results.py"))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_readme_figures_are_what_the_recorded_json_gives():
    """The generated blocks of README.md equal what scripts/readme_results.py makes of docs/results/*.json."""
    generator = _generator()
    with open(os.path.join(ROOT, "README.md")) as f:
        readme = f.read()
    names = {m["name"] for m in generator.BLOCK.finditer(readme)}
    assert names == set(generator.BLOCKS), "every renderer has its block in README.md and every block a renderer"
    results = generator.load_results()
    assert generator.generate(readme, results) == readme, "run: python scripts/readme_results.py"
    used = {name for needs, _ in generator.BLOCKS.values() for name in needs}
    assert used == set(results), "every recorded JSON is shown in the README, and only those"


def test_recorded_json_says_how_and_when_it_was_made():
    """docs/results/NAME.json: made by scripts/NAME.py (or NAME = <script>_<what>), with date and machine; the
    command-line reports (study, sweep) say their command and date; the FE tables (package data) their command."""
    generator = _generator()
    for name, result in generator.load_results().items():
        if name in generator.SOURCES:
            assert result["command"].startswith(("python -m mjflex ", "python scripts/")), name
            if generator.SOURCES[name].startswith("mjflex/"):
                continue  # package data: no date, so that rebuilding nothing changes nothing
        else:
            script = re.fullmatch(r"python scripts/(\w+)\.py( .*)?", result["command"])
            assert script and (name == script[1] or name.startswith(script[1] + "_")), name
            assert result["machine"]["cpus"] >= 1, name
        date = datetime.datetime.fromisoformat(result["date"])
        assert date.tzinfo is not None and date.year >= 2025, name


def test_generator_rewrites_a_stale_block():
    generator = _generator()
    stale = "x\n<!-- results:modes-table -->\nold\n<!-- /results -->\ny\n"
    generator.BLOCKS["modes-table"] = (["modes"], lambda results: f"{results['modes']['arcade.xml']['n_rigid']}\n")
    try:
        assert generator.generate(stale, {"modes": {"arcade.xml": {"n_rigid": 6}}}) == (
            "x\n<!-- results:modes-table -->\n6\n<!-- /results -->\ny\n"
        )
    finally:
        del generator.BLOCKS["modes-table"]


def test_a_recorded_accuracy_figure_is_what_the_code_computes_today(tmp_path):
    """scripts/modes.py, run again end to end on models/arcade.xml, gives the recorded ARCADE modes and README row.

    The other README tests compare the README with the JSON that was recorded; this one recomputes a recorded
    figure (not a timing) with today's code and model, so a change to either that moves it (a stale record) fails.
    Tolerance 1e-6 relative on the elastic frequencies: the stiffness comes from central differences of the forces
    (~1e-9 relative, mjflex.mj.linearize), and numpy/scipy/LAPACK versions and CPUs move well-separated eigenvalues
    at round-off (measured: 1e-10 between this record and a rerun); a change of the model or of the element math
    that matters moves them by 1e-4 or more. The rigid modes' frequencies are round-off (< 1e-3 Hz) and not compared.
    """
    import json
    import subprocess
    import sys

    out = tmp_path / "modes.json"
    subprocess.run([sys.executable, os.path.join("scripts", "modes.py"), os.path.join("models", "arcade.xml"),
                    "--json", str(out)], cwd=ROOT, check=True, capture_output=True, env={**os.environ,
                    "MJFLEX_RECORD": "0"})  # fmt: skip
    with open(out) as f:
        now = json.load(f)["arcade.xml"]
    with open(os.path.join(ROOT, "docs", "results", "modes.json")) as f:
        recorded = json.load(f)["arcade.xml"]
    for key in ("n_rigid", "guide_mode", "guide_is_axial"):
        assert now[key] == recorded[key], key
    for key in ("guide_frequency_hz", "separation", "highest_frequency_hz"):
        assert now[key] == pytest.approx(recorded[key], rel=1e-6), key
    elastic = [(a["frequency_hz"], b["frequency_hz"]) for a, b in zip(now["modes"], recorded["modes"], strict=True)
               if not b["rigid"]]  # fmt: skip
    assert len(elastic) >= 6
    np.testing.assert_allclose(*np.array(elastic).T, rtol=1e-6)
    generator = _generator()
    assert generator.row_modes({"arcade.xml": now}) == generator.row_modes({"arcade.xml": recorded})


def test_readme_says_what_has_no_command_and_what_a_pip_install_lacks():
    """README: reduce and fitting are Python-only, and scripts/ and models/ come with a clone only. Both stay true:
    the command line has no such command, and the package a pip install builds holds mjflex* alone."""
    import subprocess
    import sys
    import tomllib

    with open(os.path.join(ROOT, "README.md")) as f:
        readme = f.read()
    assert "Model reduction (`mjflex.reduce`), the\nMuJoCo-native variants and the fitting" in readme
    assert "are Python-only" in readme and "come with a clone of this repository" in readme
    usage = subprocess.run([sys.executable, "-m", "mjflex", "--help"], cwd=ROOT, capture_output=True, text=True).stdout
    commands = set(re.search(r"\{([a-z,]+)\}", usage).group(1).split(","))
    assert commands and not commands & {"reduce", "fit", "fit_potential", "variants"}, commands
    with open(os.path.join(ROOT, "pyproject.toml"), "rb") as f:
        setuptools = tomllib.load(f)["tool"]["setuptools"]
    assert setuptools["packages"]["find"]["include"] == ["mjflex*"]
    assert all(package.startswith("mjflex") for package in setuptools.get("package-data", {}))

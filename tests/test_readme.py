"""The README's Python example runs as written, from the repository root."""

import datetime
import importlib.util
import os
import re

import numpy as np

ROOT = os.path.join(os.path.dirname(__file__), "..")


#: Sections whose python blocks a test of their own runs and checks.
DEDICATED = ("### A compliant joint in your robot",)


def python_blocks(heading=None):
    """The README's fenced python blocks: all of them, or those of the section under ``heading``."""
    with open(os.path.join(ROOT, "README.md")) as f:
        readme = f.read()
    sections = re.split(r"^(?=#{2,4} )", readme, flags=re.M)  # level 2-4 headings (a code comment is "# ")
    out = []
    for section in sections:
        title = section.splitlines()[0] if section else ""
        if (title in DEDICATED) if heading is None else (title != heading):
            continue
        out += re.findall(r"```python\n(.*?)```", section, flags=re.S)
    return out


def test_readme_python_blocks_run(monkeypatch, capsys):
    blocks = python_blocks()
    assert blocks
    monkeypatch.chdir(ROOT)
    for code in blocks:
        exec(compile(code, "README.md", "exec"), {})
    out = capsys.readouterr().out
    assert "flexure energy" in out and "dissipating" in out


def test_readme_compliant_joint_example_runs(monkeypatch, capsys):
    """The 'compliant joint in your robot' example, on gymnasium's pusher file: compliant, simulated, rigid again."""
    (code,) = python_blocks("### A compliant joint in your robot")
    monkeypatch.chdir(ROOT)
    namespace = {}
    exec(compile(code, "README.md", "exec"), namespace)
    out = capsys.readouterr().out
    assert "Compliance(body='r_forearm_link' on 'r_forearm_roll_link'" in out and "forearm modes [" in out
    freq = namespace["freq"]
    assert (freq > 1).sum() == 6  # the forearm's six modes; the arm's other joints are free
    deflection = namespace["flex"].displacements(namespace["data"])[0]
    assert np.isfinite(deflection).all() and 1e-5 < np.abs(deflection).max() < 0.1  # loaded, bounded
    rigid = namespace["spec"].compile()
    assert rigid.nq == namespace["model"].nq - 7 and rigid.ntext == 0  # make_rigid took it all back


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

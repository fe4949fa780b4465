"""The README, the front door: its set-up commands are CI's, its versions table is pyproject's, its links lead
somewhere; and the measured figures of every page (README and docs/) are what the recorded JSON gives.

The README's code blocks run with the documentation's (tests/test_docs.py, tests/codeblocks.py).
"""

import copy
import datetime
import importlib.util
import os
import re
import sys

import numpy as np
import pytest

ROOT = os.path.join(os.path.dirname(__file__), "..")
#: The README stays a front door: what it is, a picture, set-up, an example, links into the documentation.
MAX_README_LINES = 150


def _readme():
    with open(os.path.join(ROOT, "README.md"), encoding="utf-8") as f:
        return f.read()


def test_readme_is_a_front_door_whose_links_lead_somewhere():
    """At most MAX_README_LINES lines; every relative link and image names a file or folder of the repository, and
    the documentation's sections are all linked."""
    readme = _readme()
    assert len(readme.splitlines()) <= MAX_README_LINES, "the README grew: move the detail to a page under docs/"
    targets = re.findall(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", readme)
    local = [t for t in targets if not re.match(r"[a-z]+://", t)]
    assert len(local) >= 10, local
    missing = [t for t in local if not os.path.exists(os.path.join(ROOT, t))]
    assert not missing, f"README links to files that do not exist: {missing}"
    for section in ("docs/tutorials/", "docs/howto/index.md", "docs/reference/index.md", "docs/background/index.md"):
        assert section in local, section
    assert "python -m mjflex docs" in readme, "the README says how to build the site"


def test_readme_test_command_is_what_ci_runs():
    readme = _readme()
    with open(os.path.join(ROOT, ".ci", "run")) as f:
        ci = f.read()
    command = 'python -m pip install -e ".[test]" && python -m pytest'
    assert command in readme and command in ci


def test_tested_with_table_states_each_python_with_its_oldest_and_newest_sets():
    """The README's table has an oldest and a newest row for each Python that pyproject.toml declares (and nox runs);
    no oldest row goes below pyproject's lower bounds, and one states them exactly (the bounds themselves passed)."""
    import tomllib

    sys.path.insert(0, os.path.join(ROOT, "scripts"))
    from tested_versions import SHOWN, oldest_constraints

    readme = _readme()
    head = f"| set | Python | {' | '.join(SHOWN)} |"
    assert head in readme, "the Tested-with table has the columns of scripts/tested_versions.py"
    rows = [[c.strip() for c in line.split("|")[1:-1]] for line in readme.splitlines()
            if line.startswith(("| oldest", "| newest"))]  # fmt: skip
    with open(os.path.join(ROOT, "pyproject.toml"), "rb") as f:
        classifiers = tomllib.load(f)["project"]["classifiers"]
    pythons = sorted(c.rsplit(" ", 1)[1] for c in classifiers if re.fullmatch(r".*Python :: 3\.\d+", c))
    assert pythons == ["3.11", "3.12", "3.13"]
    for kind in ("oldest", "newest"):
        stated = sorted(".".join(r[1].split(".")[:2]) for r in rows if r[0].startswith(kind))
        assert stated == pythons, f"{kind} rows for Pythons {stated}, pyproject declares {pythons}"
    bounds = dict(c.split("==") for c in oldest_constraints())

    def padded(version):
        return tuple(int(x) for x in version.split(".")) + (0,) * (3 - version.count(".") - 1)

    checked = [name for name in SHOWN if name in bounds]
    assert len(checked) >= 7
    exact = 0
    for row in (r for r in rows if r[0].startswith("oldest")):
        versions = dict(zip(SHOWN, row[2:], strict=True))
        for name in checked:
            assert padded(versions[name]) >= padded(bounds[name]), f"{name}: README {versions[name]} < {bounds[name]}"
        exact += all(padded(versions[name]) == padded(bounds[name]) for name in checked)
    assert exact >= 1, "no oldest row states pyproject's lower bounds: raise the bounds, or test them"


def _generator():
    spec = importlib.util.spec_from_file_location("results_blocks", os.path.join(ROOT, "scripts", "results_blocks.py"))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_every_block_has_one_place_and_every_page_is_what_the_recorded_json_gives():
    """The generated blocks of README.md and docs/**/*.md equal what scripts/results_blocks.py makes of the recorded
    JSON; each renderer's block is placed on exactly one page, and every recorded JSON is shown."""
    generator = _generator()
    pages = generator.pages()
    assert os.path.abspath(generator.README) in map(os.path.abspath, pages) and len(pages) >= 20
    placed = generator.placements()
    assert set(placed) == set(generator.BLOCKS), "every renderer has its block on a page and every block a renderer"
    twice = {name: where for name, where in placed.items() if len(where) != 1}
    assert not twice, f"blocks placed more than once: {twice}"
    results = generator.load_results()
    for page in pages:
        with open(page, encoding="utf-8") as f:
            text = f.read()
        assert generator.generate(text, results) == text, f"{page}: run python scripts/results_blocks.py"
    used = {name for needs, _ in generator.BLOCKS.values() for name in needs}
    assert used == set(results), "every recorded JSON is shown on a page, and only those"


def test_stable_step_scenes_are_stated_as_the_scripts_run_them():
    """The alternatives and reduce tables state which runs judged a "stable RK4 step" (the durations are the scripts'
    arguments, not recorded in their JSON): the rendered note must say what the scripts do."""
    generator = _generator()
    from _readme_speed import STABLE_STEP_RUNS  # scripts/ is on the path once the generator is loaded

    def durations(script):
        with open(os.path.join(ROOT, "scripts", script), encoding="utf-8") as f:
            return [
                float(x) for x in re.findall(r"costs_at_stable_steps\(cases, h, repeat, [^\n]*, ([\d.e-]+)\)", f.read())
            ]

    assert durations("_arcade_alternatives.py") == [STABLE_STEP_RUNS["arcade"]]
    assert sorted(durations("compare_alternatives.py")) == sorted(
        [STABLE_STEP_RUNS["bushing"], STABLE_STEP_RUNS["cantilever"]]
    )
    with open(os.path.join(ROOT, "scripts", "_variants.py"), encoding="utf-8") as f:
        assert "growth=2.0, bisections=4" in f.read()  # the 4.4 % of the note: 2 ** (1 / 2 ** 4) - 1
    assert generator.BLOCKS["reduce-arcade"][1](generator.load_results()).count("4.4 %") == 1


def test_block_places_are_found_on_any_page(tmp_path):
    """placements() sees blocks wherever they are, and counts a block placed twice twice (the test above then fails)."""
    generator = _generator()
    one, two = tmp_path / "a.md", tmp_path / "b.md"
    one.write_text("<!-- results:demo -->\nx\n<!-- /results -->\n<!-- results:modes-x -->\n<!-- /results -->\n")
    two.write_text("text\n<!-- results:demo -->\n<!-- /results -->\n")
    assert generator.placements([str(one), str(two)]) == {
        "demo": [os.path.relpath(one, generator.ROOT), os.path.relpath(two, generator.ROOT)],
        "modes-x": [os.path.relpath(one, generator.ROOT)],
    }
    pages = [os.path.relpath(p, generator.ROOT) for p in generator.pages()]
    assert "README.md" in pages and not any(p.startswith(os.path.join("docs", "auto_tutorials")) for p in pages)


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
            machine = result["machine"]  # older JSON: "cpus"; newer: CPU model, cores, load before and after
            assert machine.get("logical_cores", machine.get("cpus")) >= 1, name
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
        inline = "a sentence with <!-- results:modes-table -->5<!-- /results --> rigid modes\n"  # a number in prose
        generator.BLOCKS["modes-table"] = (["modes"], lambda results: f"{results['modes']['arcade.xml']['n_rigid']}")
        assert generator.generate(inline, {"modes": {"arcade.xml": {"n_rigid": 6}}}) == inline.replace("5", "6")
    finally:
        del generator.BLOCKS["modes-table"]


# ----------------------------------------------------------------------------------- timings: spread and machine

#: "×" that are not timings: a 6×6 matrix, the stable-step search's 100× limit, Dask's 2×1 workers.
NOT_TIMINGS = re.compile(r"\d×\d|100× the scene's step")
#: A timing figure "2.47×" (not the upper end of a range "1.6–3.8×") without its spread " (2.18–2.61)".
BARE_TIMING = re.compile(r"(?<![–\d.])\d+(?:\.\d+)?×(?! \()")
#: Blocks that hold a table or an account of timings: each names the machine once.
MACHINE_BLOCKS = ("measured", "polynomial-cost", "native", "reduce-arcade", "sweep-bench", "step-cost")


def _timing_rows(payload):
    if isinstance(payload, dict):
        if "ratio_median" in payload or "ratio_to_serial_median" in payload:
            yield payload
            return
        for value in payload.values():
            yield from _timing_rows(value)


def _cost_tables(payload, found=None):
    """The tables of scripts/_variants.py's step costs (every row has a stable step), as the scripts pool them."""
    found = [] if found is None else found
    if isinstance(payload, dict):
        values = list(payload.values())
        if values and all(isinstance(v, dict) and "stable_step_s" in v for v in values):
            found.append(payload)  # scripts/compare_alternatives.py: scene -> costs
        elif values and all(isinstance(v, dict) and "stable_step_s" in v.get("cost", {}) for v in values):
            found.append({k: v["cost"] for k, v in payload.items()})  # scripts/reduce_arcade.py: rows -> cost
        else:
            for value in values:
                _cost_tables(value, found)
    return found


def _as_recorded_now(results, timed):
    """The committed JSON as the benchmark scripts record it now, through scripts/_bench.py's own functions: each
    timing row with repeats made up around its median (3 processes of 3 repeats, pooled), the speed-ups derived
    from them, and this machine."""
    sys.path.insert(0, os.path.join(ROOT, "scripts"))
    import _bench
    from _variants import add_speedups

    out = copy.deepcopy(results)
    for name in timed:
        runs = []
        for k in range(3):
            payload = copy.deepcopy(results[name])
            for row in _timing_rows(payload):
                ratio = row.get("ratio_median", row.get("ratio_to_serial_median"))
                seconds = row.get("median_s", row.get("wall_median_s"))
                factors = [1.0] * 3 if ratio == 1.0 else [0.9 + 0.05 * k, 1.0, 1.3 - 0.1 * k]  # a baseline is 1
                row.update(_bench.timing_row([seconds * f for f in factors], [seconds / ratio] * 3))
            runs.append(payload)
        merged = _bench.merge_runs(runs)
        for row in _timing_rows(merged):
            if "ratio_to_serial_median" in row:  # scripts/bench_sweep.py's names of the README
                row.update(ratio_to_serial_median=row["ratio_median"], wall_median_s=row["median_s"])
        for costs in _cost_tables(merged):
            add_speedups(costs, next(iter(costs)))
        merged["machine"] = _bench.machine()
        out[name] = merged
    return out


def _timing_texts(generator, results):
    """``(block, rendered text, its timed JSON names)`` of every block showing timings (the measured table: only its
    timing rows and the note below it)."""
    timed = set(generator.TIMED)
    for block, (needs, renderer) in generator.BLOCKS.items():
        names = [n for n in needs if n in timed]
        if not names:
            continue
        text = renderer(results)
        if block == "measured":
            keep = [x for x in text.splitlines() if not x.startswith("|") or any(f"scripts/{n}.py" in x for n in names)]
            text = "\n".join(keep)
        yield block, text, names


def _check_timings(generator, results):
    """Every timing rendered from JSON that carries its spread shows it, and each table names the machine once."""
    from _readme_format import machine_of  # scripts/ is on the path once the generator is loaded

    checked = 0
    for block, text, names in _timing_texts(generator, results):
        machines = {machine_of(results[n]) for n in names} - {""}
        if not machines:
            continue  # recorded before the spread and the machine were: rendered as before (test above)
        if block in MACHINE_BLOCKS:
            for machine in machines:
                assert text.count(machine) == 1, f"block {block!r} names its machine {text.count(machine)} times"
        bare = BARE_TIMING.findall(NOT_TIMINGS.sub("", text))
        assert not bare, f"block {block!r} shows timings without their spread: {bare}"
        checked += 1
    return checked


def test_rendered_timings_have_their_spread_and_machine():
    """Where the recorded JSON carries them (scripts/_bench.py since the spread and machine were added), every
    timing ratio in the README has its min–max, and every table of timings names the CPU, cores and load."""
    generator = _generator()
    results = generator.load_results()
    _check_timings(generator, results)  # the committed JSON: binds once re-recorded
    now = _as_recorded_now(results, generator.TIMED)
    blocks = len(list(_timing_texts(generator, now)))
    assert blocks >= 6 and _check_timings(generator, now) == blocks  # every block showing timings, none skipped
    measured = generator.block_measured(now)
    assert measured.count("Timed on ") == 1 and "3 fresh processes × 3 interleaved repeats" in measured


def test_a_recorded_accuracy_figure_is_what_the_code_computes_today(tmp_path):
    """scripts/modes.py, run again end to end on models/arcade.xml, gives the recorded ARCADE modes and README row.

    The other tests here compare the pages with the JSON that was recorded; this one recomputes a recorded
    figure (not a timing) with today's code and model, so a change to either that moves it (a stale record) fails.
    Tolerance 1e-6 relative on the elastic frequencies: the stiffness comes from central differences of the forces
    (~1e-9 relative, mjflex.analysis.linearize), and numpy/scipy/LAPACK versions and CPUs move well-separated
    eigenvalues at round-off (measured: 1e-10 between this record and a rerun); a change of the model or of the element
    math that matters moves them by 1e-4 or more. The rigid modes' frequencies are round-off (< 1e-3 Hz) and not
    compared.
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


def test_pages_say_what_has_no_command_and_what_a_pip_install_lacks():
    """The command-line page: reduce and fitting are Python-only, and scripts/ and models/ come with a clone only (the
    README says the first too). Both stay true: the command line has no such command, and the package a pip install
    builds holds mjflex* alone."""
    import subprocess
    import tomllib

    with open(os.path.join(ROOT, "docs", "reference", "command_line.md"), encoding="utf-8") as f:
        page = f.read()
    assert "Model reduction (`mjflex.reduce`), the\nMuJoCo-native variants and the fitting" in page
    assert "are Python-only" in page and "come with a clone of this repository" in page
    assert "Python-only" in _readme()
    usage = subprocess.run([sys.executable, "-m", "mjflex", "--help"], cwd=ROOT, capture_output=True, text=True).stdout
    commands = set(re.search(r"\{([a-z,]+)\}", usage).group(1).split(","))
    assert commands and not commands & {"reduce", "fit", "fit_potential", "variants"}, commands
    with open(os.path.join(ROOT, "pyproject.toml"), "rb") as f:
        setuptools = tomllib.load(f)["tool"]["setuptools"]
    shipped = [*setuptools["packages"]["find"]["include"], *setuptools.get("py-modules", [])]
    assert shipped and all(name.startswith("mjflex") for name in shipped), shipped  # mjflex, mjflex_plugin
    assert all(package.startswith("mjflex") for package in setuptools.get("package-data", {}))

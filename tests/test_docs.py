"""The documentation site: it builds in strict mode, documents every public name, and its code runs.

``python -m mjflex docs`` builds ``docs/`` with Sphinx's ``-W --keep-going -n``: a warning, a
reference to nothing, or a tutorial that raises fails the build. The code blocks of the pages
are run by :mod:`tests.codeblocks` (marking and rules in its docstring). README.md's blocks are
run by ``tests/test_readme.py`` until the README moves into the site (stage B of issue 18).
"""

import doctest
import glob
import html as html_text
import importlib.util
import inspect
import os
import re
import subprocess
import sys

import pytest

from . import codeblocks

ROOT = codeblocks.ROOT
DOCS = os.path.join(ROOT, "docs")
GENERATED = ("auto_tutorials", "reference/api", "study", "_build")  # written by the build or by mjflex study


def _extension():
    spec = importlib.util.spec_from_file_location("mjflex_docs", os.path.join(DOCS, "_ext", "mjflex_docs.py"))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _pages():
    pages = sorted(glob.glob(os.path.join(DOCS, "**", "*.md"), recursive=True))
    return [p for p in pages if not os.path.relpath(p, DOCS).startswith(GENERATED)]


def _tutorials():
    return sorted(glob.glob(os.path.join(DOCS, "tutorials", "plot_*.py")))


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    """The site, built once by the documented command in strict mode."""
    out = tmp_path_factory.mktemp("docs")
    done = subprocess.run([sys.executable, "-m", "mjflex", "docs", "--out", str(out)], cwd=ROOT,
                          env=codeblocks.environment(), capture_output=True, text=True, timeout=900)  # fmt: skip
    assert done.returncode == 0, f"the strict build failed:\n{done.stdout[-6000:]}\n{done.stderr[-6000:]}"
    return os.path.join(out, "html")


def test_site_builds_without_warnings(site):
    assert os.path.exists(os.path.join(site, "index.html"))
    for section in ("auto_tutorials/index", "howto/index", "reference/index", "background/index"):
        assert os.path.exists(os.path.join(site, section + ".html")), section


def test_every_public_name_has_a_reference_entry(site):
    """Every name of mjflex.__all__ (and the lazy study, sweep, Recipe; geometry's names) has its page."""
    import mjflex

    names = _extension().public_names()
    expected = {f"mjflex.{n}" for n in mjflex.__all__ if n != "geometry"} | {"mjflex.study", "mjflex.sweep"}
    expected |= {"mjflex.Recipe"} | {f"mjflex.geometry.{n}" for n in mjflex.geometry.__all__}
    assert expected <= set(names)
    for name in names:
        path = os.path.join(site, "reference", "api", f"{name}.html")
        assert os.path.exists(path), f"no reference page for {name}"
        with open(path, encoding="utf-8") as f:
            html = f.read()
        assert f'id="{name}"' in html, f"{name}: the page does not document the object"
    with open(os.path.join(site, "reference", "api.html"), encoding="utf-8") as f:
        api = f.read()
    assert all(f"{name}.html" in api for name in names), "the API page links every entry"


def test_tutorials_ran_and_drew_their_figures(site):
    """Each tutorial was executed by the build and its figures are the build's (none is committed)."""
    tutorials = _tutorials()
    assert len(tutorials) >= 5
    for script in tutorials:
        stem = os.path.splitext(os.path.basename(script))[0]
        with open(os.path.join(site, "auto_tutorials", f"{stem}.html"), encoding="utf-8") as f:
            html = f.read()
        assert f"sphx_glr_{stem}_001.png" in html, f"{stem}: no figure drawn by the build"
        assert "Total running time of the script" in html, stem
    committed = subprocess.run(["git", "ls-files", "docs/auto_tutorials"], cwd=ROOT, capture_output=True, text=True)
    assert committed.stdout == "", "generated tutorial pages are committed"


def test_command_line_reference_lists_every_command(site):
    from mjflex.app.cli import build_parser

    with open(os.path.join(site, "reference", "command_line.html"), encoding="utf-8") as f:
        html = html_text.unescape(re.sub(r"<[^>]+>", "", f.read()))
    commands = build_parser()._subparsers._group_actions[0].choices
    assert set(commands) >= {"simulate", "demo", "study", "sweep", "docs"}
    for name, parser in commands.items():
        assert f"python -m mjflex {name}" in html, name
        for action in parser._actions:
            for option in action.option_strings:
                if option in ("-h", "--help"):
                    continue  # every parser has it; the page says so once per usage line ([-h])
                assert option in html, f"{name} {option}"


def test_error_bands_page_is_rendered_from_the_tables(site):
    from mjflex.geometry.tables import error_bands

    with open(os.path.join(site, "background", "stiffness_from_geometry.html"), encoding="utf-8") as f:
        html = f.read()
    for kind in ("notch", "leaf"):  # a table cell each, not text that happens to contain the number
        assert f"<td><p>{100 * error_bands(kind)['rot_z']['total']:.2g} %</p></td>" in html, kind


# ----------------------------------------------------------------------------- docstring examples

#: Public names whose docstring has no Examples section yet: the MuJoCo layer and the applications, which the
#: engine-plugin and robot issues (16, 17) are changing; issue 18's stage B writes them. Shrinks, never grows.
EXAMPLES_PENDING = {
    "mjflex.FlexureHandle", "mjflex.FlexureRecord", "mjflex.Flexures", "mjflex.Variant", "mjflex.add_flexure",
    "mjflex.add_flexure_in_body_frame", "mjflex.bushing_variant", "mjflex.pseudo_rigid_body_variant", "mjflex.reduce",
    "mjflex.reference_body_poses", "mjflex.weld_variant", "mjflex.Recipe", "mjflex.study", "mjflex.sweep",
    "mjflex.app.sweep.edit_flexure", "mjflex.app.sweep.flexure_matrices", "mjflex.PotentialFit",
    # issue 17 (merged into main after this branch started): not public here yet
    "mjflex.Compliance", "mjflex.damping_from_ratios", "mjflex.make_compliant", "mjflex.make_rigid",
    "mjflex.normal_modes", "mjflex.remove_flexure",
}  # fmt: skip


def _public_objects():
    extension = _extension()
    return {name: extension._resolve(name) for name in extension.public_names()}


def test_every_public_function_and_class_has_an_example():
    """numpydoc Examples in every public docstring (exceptions aside), but for the pending list above."""
    missing = set()
    for name, obj in _public_objects().items():
        if isinstance(obj, type) and issubclass(obj, BaseException):
            continue
        if "\nExamples\n--------\n" not in inspect.cleandoc(obj.__doc__ or ""):
            missing.add(name)
    assert missing <= EXAMPLES_PENDING, f"no Examples section: {sorted(missing - EXAMPLES_PENDING)}"
    assert not EXAMPLES_PENDING & (set(_public_objects()) - missing), "has examples now: drop it from the pending list"


def test_docstring_examples_run():
    """The Examples of the public docstrings run and print what they say (doctest)."""
    finder, runner = (
        doctest.DocTestFinder(recurse=False),
        doctest.DocTestRunner(optionflags=doctest.NORMALIZE_WHITESPACE),
    )
    ran = 0
    for name, obj in _public_objects().items():
        for test in finder.find(obj, name, globs={}):
            ran += len(test.examples)
            runner.run(test)
    assert ran >= 50
    assert runner.failures == 0, f"{runner.failures} docstring example(s) failed (see the output above)"


# ----------------------------------------------------------------------------- code blocks


def test_code_block_parser():
    text = (
        "# Page\n\n```python\nx = 1\n```\n\n<!-- not-run: needs a cluster -->\n```bash\nsbatch job.sh\n```\n\n"
        "```bash\npython -m mjflex simulate models/two_body.xml \\\n    --duration 0.01  # short\n```\n\n"
        "```xml\n<mujoco/>\n```\n\n<!-- not-run: -->\n```python\nimport nothing\n```\n\n```sh\npip install x\n```\n"
    )
    found = codeblocks.blocks("page.md", text)
    assert [(b.language, b.skip) for b in found] == [
        ("python", None), ("bash", "needs a cluster"), ("bash", None), ("xml", None), ("python", ""), ("bash", None)
    ]  # fmt: skip
    assert found[0].code == "x = 1\n"
    assert codeblocks.commands(found[2]) == ["python -m mjflex simulate models/two_body.xml --duration 0.01"]
    assert [bool(codeblocks.problems(b)) for b in found] == [False, False, False, False, True, True]


def test_code_blocks_of_the_pages_run_or_are_marked():
    """Every python and bash block of docs/ runs, or says in a marker why it does not; markers stay few."""
    found = [b for page in _pages() for b in codeblocks.blocks(page)]
    programs = [b for b in found if b.program]
    assert len(programs) >= 8
    assert [p for b in programs for p in codeblocks.problems(b)] == []
    marked = [b for b in programs if b.skip is not None]
    assert len(marked) <= len(programs) // 2, [b.where() for b in marked]


def _runnable_pages():
    return [
        os.path.relpath(p, DOCS) for p in _pages() if any(b.program and b.skip is None for b in codeblocks.blocks(p))
    ]


@pytest.mark.parametrize("page", _runnable_pages())
def test_page_code_runs(page, tmp_path):
    failures = codeblocks.run_page(codeblocks.blocks(os.path.join(DOCS, page)), codeblocks.workspace(tmp_path))
    assert not failures, "\n\n".join(failures)

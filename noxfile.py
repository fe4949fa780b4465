"""The Python matrix: the release wheel on Python 3.11, 3.12 and 3.13, each with its oldest and newest dependencies.

Usage (from the repository root, in a venv with ``pip install -e ".[release]"``; the Pythons from pyenv or PATH)::

    python scripts/build_release.py --no-suite       # once: dist/ gets the sdist and the wheel, both checked
    nox                                              # the six legs, one after the other (about 1 h on 2 cores)
    nox -s "tests(3.13, newest)"                     # one leg
    nox -l                                           # the legs

Each leg is ``scripts/build_release.py --skip-build`` for one Python: a fresh venv, the wheel from ``dist/`` installed
on a bare machine's PATH (no C compiler, no Xvfb), the smoke run and the whole test suite, from the sdist's tree
without the package sources. "newest" is what pip resolves today; "oldest" pins every dependency to the lowest
release that installs on that Python (``scripts/tested_versions.py --oldest --python X.Y``). Each leg writes
``out/matrix/<python>-<set>.json``: the pass count, the timings, and the row of the README's "Tested with" table.
"""

import datetime
import os

import nox

PYTHONS = ["3.11", "3.12", "3.13"]
OUT = os.path.join("out", "matrix")

nox.options.default_venv_backend = "none"  # each leg makes its own fresh venv (scripts/build_release.py)
nox.options.error_on_missing_interpreters = True


@nox.session
@nox.parametrize("deps", [nox.param("oldest", id="oldest"), nox.param("newest", id="newest")])
@nox.parametrize("python", [nox.param(v, id=v) for v in PYTHONS])
def tests(session, python, deps):
    """The wheel in a fresh venv of ``python`` with the ``deps`` set: smoke run and whole suite, no compiler."""
    os.makedirs(OUT, exist_ok=True)
    label = "oldest" if deps == "oldest" else f"newest (pip, {datetime.date.today().isoformat()})"
    command = ["python", "scripts/build_release.py", "--skip-build", "--no-sdist-check", "--python", python, "--label",
               label]  # fmt: skip
    if deps == "oldest":
        constraints = os.path.join(OUT, f"oldest-{python}.txt")
        with open(constraints, "w") as f:
            session.run("python", "scripts/tested_versions.py", "--oldest", "--python", python, stdout=f)
        command += ["--constraints", constraints]
    session.run(*command, "--json", os.path.join(OUT, f"{python}-{deps}.json"))

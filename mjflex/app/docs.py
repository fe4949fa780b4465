"""``python -m mjflex docs``: build the documentation site of a source checkout with Sphinx.

The sources are ``docs/`` of the repository (not installed with the package): the pages, the
tutorials (sphinx-gallery scripts executed by the build, which makes their figures) and
``docs/conf.py``. Strict by default: Sphinx's ``-W --keep-going -n``, so a warning, a broken
cross-reference or a failing tutorial fails the build, as in CI (``tests/test_docs.py``).
"""

import importlib.util
import os
import subprocess
import sys
import time

#: The repository root of a source checkout (``docs/`` beside the ``mjflex`` package); where mjflex is installed
#: from a wheel (no ``docs/`` beside it), the checkout in the working directory.
ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
if not os.path.exists(os.path.join(ROOT, "docs", "conf.py")) and os.path.exists(os.path.join("docs", "conf.py")):
    ROOT = os.path.abspath(os.curdir)
SOURCE = os.path.join(ROOT, "docs")
#: What the build imports, as module -> the PyPI name in the ``docs`` extra.
REQUIRED = {
    "sphinx": "sphinx",
    "sphinx_gallery": "sphinx-gallery",
    "numpydoc": "numpydoc",
    "myst_parser": "myst-parser",
    "furo": "furo",
    "sphinxarg": "sphinx-argparse",
    "sphinx_copybutton": "sphinx-copybutton",
    "skfem": "scikit-fem",  # mjflex.geometry.fe, documented and linked (the docs extra pulls in the fe extra)
}


def build_docs(out="out/docs", *, strict=True, tutorials=True) -> int:
    """Build the site into ``out/html``; returns Sphinx's exit status (0: built without warnings).

    Raises SystemExit with the fix when the sources or the docs extra are missing.
    """
    if not os.path.exists(os.path.join(SOURCE, "conf.py")):
        raise SystemExit(
            f"error: no documentation sources at {SOURCE!r}: the site is built from a source checkout "
            '(git clone, then pip install -e ".[docs]" and python -m mjflex docs)'
        )
    missing = [name for module, name in REQUIRED.items() if importlib.util.find_spec(module) is None]
    if missing:
        raise SystemExit(f'error: missing {", ".join(missing)}; install the docs extra: pip install -e ".[docs]"')
    out = os.path.abspath(out)
    os.makedirs(out, exist_ok=True)
    command = [sys.executable, "-m", "sphinx", "-b", "html", "-d", os.path.join(out, "doctrees")]
    if strict:
        command += ["-W", "--keep-going", "-n"]
    if not tutorials:
        command += ["-D", "plot_gallery=0"]
    started = time.perf_counter()
    status = subprocess.call([*command, SOURCE, os.path.join(out, "html")])
    wall = time.perf_counter() - started
    index = os.path.join(out, "html", "index.html")
    if status == 0:
        print(f"built {index} in {wall:.0f} s")
    else:
        print(f"error: the documentation build failed (Sphinx exit status {status}, {wall:.0f} s); see above")
    return status

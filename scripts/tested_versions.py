"""The versions this environment runs mjflex with, as the README's "Tested with" table states them.

Usage::

    python scripts/tested_versions.py                      # this venv's row of the table (after a passing test run)
    python scripts/tested_versions.py --oldest             # pip constraints: every dependency at its lower bound
    python scripts/tested_versions.py --oldest --python 3.13   # the oldest releases that install on Python 3.13

The lower bounds of ``pyproject.toml`` all install on Python 3.11, but not on every Python: numpy 1.26 and
numba 0.60 have no wheels for 3.13, whose oldest set is numpy 2.1 and numba 0.61. ``--python`` asks uv
(``pip install uv``) for the lowest versions of the direct dependencies that resolve together with binary
wheels for that Python on manylinux x86-64 (``uv pip compile --resolution lowest-direct``), and prints them
as pip constraints (transitive dependencies stay free, as pip resolves them).

The README's rows are made by ``nox`` (``noxfile.py``): for each Python, a fresh venv with the release wheel
and what pip resolves today ("newest"), or with ``--oldest --python`` constraints ("oldest"), the whole
suite, then this script's row of that venv (``out/matrix/*.json``).
"""

import argparse
import datetime
import importlib.metadata
import os
import platform
import re
import shutil
import subprocess
import sys
import tomllib

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
#: The table's columns: the dependencies whose numerics or APIs the suite exercises.
SHOWN = ["mujoco", "numpy", "scipy", "numba", "matplotlib", "xarray", "pandas", "scikit-fem", "dask"]


def requirements():
    """Every requirement of pyproject.toml (dependencies and the extras the test extra takes in), e.g. numpy>=1.26."""
    with open(os.path.join(ROOT, "pyproject.toml"), "rb") as f:
        project = tomllib.load(f)["project"]
    extras = project["optional-dependencies"]
    found = list(project["dependencies"])
    for extra in ("test", "fe", "dask", "docs"):
        found += [r for r in extras[extra] if not r.startswith("mjflex")]
    return found


def oldest_constraints():
    """``name==lower bound`` for every requirement with one."""
    lines = []
    for req in requirements():
        m = re.fullmatch(r"([A-Za-z0-9_.-]+)\s*>=\s*([\w.]+)", req.split(";")[0].strip())
        if m:
            lines.append(f"{m[1]}=={m[2]}")
    return lines


def oldest_installable(python):
    """``name==version`` for every requirement with a lower bound: the lowest that installs on ``python`` (X.Y)."""
    uv = shutil.which("uv") or os.path.join(os.path.dirname(sys.executable), "uv")
    if not os.path.exists(uv):
        raise SystemExit("--python needs uv: pip install uv")
    command = [uv, "pip", "compile", "-", "--resolution", "lowest-direct", "--python-version", python,
               "--python-platform", "x86_64-manylinux_2_28", "--only-binary", ":all:", "--no-header", "--no-annotate",
               "--native-tls", "--quiet"]  # fmt: skip
    direct = [r.split(";")[0].strip() for r in requirements()]
    done = subprocess.run(command, input="\n".join(direct), capture_output=True, text=True)
    if done.returncode != 0:
        raise SystemExit(f"uv could not resolve the oldest set for Python {python}:\n{done.stderr}")
    resolved = dict(line.split("==") for line in done.stdout.split() if "==" in line)
    lines = []
    for constraint in oldest_constraints():
        name = constraint.split("==")[0]
        key = re.sub(r"[-_.]+", "-", name).lower()
        lines.append(f"{name}=={resolved[key]}")
    return lines


def row(label):
    """A markdown row: label, Python, and the installed version of each shown package."""
    versions = []
    for name in SHOWN:
        try:
            versions.append(importlib.metadata.version(name))
        except importlib.metadata.PackageNotFoundError:
            versions.append("–")
    return f"| {label} | {platform.python_version()} | " + " | ".join(versions) + " |"


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--oldest", action="store_true", help="print pip constraints pinning every lower bound")
    ap.add_argument("--python", help="with --oldest: the oldest releases that install on this Python (X.Y; needs uv)")
    ap.add_argument("--label", help="the row's first cell (default: today's date)")
    args = ap.parse_args()
    if args.oldest:
        print("\n".join(oldest_installable(args.python) if args.python else oldest_constraints()))
        return
    print(f"| set | Python | {' | '.join(SHOWN)} |\n|{'---|' * (len(SHOWN) + 2)}")
    print(row(args.label or f"tested {datetime.date.today().isoformat()}"))


if __name__ == "__main__":
    main()

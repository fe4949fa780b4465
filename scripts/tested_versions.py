"""The versions this environment runs mjflex with, as the README's "Tested with" table states them.

Usage::

    python scripts/tested_versions.py                 # this venv's row of the table (after a passing test run)
    python scripts/tested_versions.py --oldest        # pip constraints: every dependency at its lower bound

How the two rows of the README were made (Python 3.11, the whole suite each time)::

    python scripts/tested_versions.py --oldest > /tmp/oldest.txt
    python3 -m venv /tmp/venv-oldest && /tmp/venv-oldest/bin/pip install -c /tmp/oldest.txt -e ".[test]"
    /tmp/venv-oldest/bin/python -m pytest && /tmp/venv-oldest/bin/python scripts/tested_versions.py
    python3 -m venv /tmp/venv-new && /tmp/venv-new/bin/pip install -e ".[test]"    # what pip resolves today
    /tmp/venv-new/bin/python -m pytest && /tmp/venv-new/bin/python scripts/tested_versions.py
"""

import argparse
import datetime
import importlib.metadata
import os
import platform
import re
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
    ap.add_argument("--label", help="the row's first cell (default: today's date)")
    args = ap.parse_args()
    if args.oldest:
        print("\n".join(oldest_constraints()))
        return
    print(f"| set | Python | {' | '.join(SHOWN)} |\n|{'---|' * (len(SHOWN) + 2)}")
    print(row(args.label or f"tested {datetime.date.today().isoformat()}"))


if __name__ == "__main__":
    main()

"""The code base stays ruff-clean (the style gate of the project)."""

import os
import subprocess
import sys

ROOT = os.path.join(os.path.dirname(__file__), "..")


def test_ruff_check_is_clean():
    # the package's sources, unless the suite runs against an installed wheel from a tree without them
    folders = [f for f in ("mjflex", "tests", "scripts") if os.path.isdir(os.path.join(ROOT, f))]
    result = subprocess.run([sys.executable, "-m", "ruff", "check", *folders], cwd=ROOT, capture_output=True, text=True)
    assert result.returncode == 0, result.stdout + result.stderr

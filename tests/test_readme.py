"""The README's Python example runs as written, from the repository root."""

import os
import re

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

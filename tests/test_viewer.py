"""MuJoCo's own viewer runs the committed plugin model, on a virtual X display.

Needs ``Xvfb`` (Debian's ``xvfb``). On a machine without it these tests skip, saying how to run
them; ``.ci/run`` installs it (as root) and sets ``MJFLEX_REQUIRE=xvfb``, so in CI a missing Xvfb
fails them instead. The viewer draws with GLFW on the display (Mesa's software GL here).
"""

import importlib.util
import json
import os
import shutil
import subprocess
import sys
import time

import numpy as np
import pytest

import mjflex
from tests.conftest import require

ROOT = os.path.join(os.path.dirname(__file__), "..")
MODELS = os.path.join(ROOT, "models")
SCRIPT = os.path.join(ROOT, "scripts", "viewer_screenshot.py")


@pytest.fixture(scope="module")
def screenshot():
    require(
        "xvfb",
        shutil.which("Xvfb") is not None,
        "MuJoCo's viewer needs a display: no Xvfb on PATH (install "
        "Debian's xvfb, e.g. apt-get install xvfb, then run pytest tests/test_viewer.py)",
    )
    spec = importlib.util.spec_from_file_location("viewer_screenshot", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _env():
    return {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "MUJOCO_GL")}


def _script(args, tmp_path):
    out = str(tmp_path / "shot.png")
    done = subprocess.run([sys.executable, SCRIPT, "--out", out, "--width", "480", "--height", "270", *args],
                          cwd=ROOT, env=_env(), capture_output=True, text=True, timeout=300)  # fmt: skip
    with open(os.path.join(tmp_path, "shot.json")) as f:
        return done, json.load(f), out


def test_the_viewer_shows_the_guide_intact_after_the_paper_run(screenshot, tmp_path):
    """scripts/viewer_screenshot.py: 20 ms of the paper run in mujoco.viewer (mujoco imported, mjflex not); the
    elements hold (sites within 2 mm); the text-record twin, which no mujoco-only program can simulate, falls apart."""
    done, summary, image = _script([], tmp_path)
    assert done.returncode == 0, done.stderr
    assert summary["plugin_instances"] == 48 and summary["elements"] == 48 and not summary["mjflex_imported"]
    assert summary["viewer_running"] and summary["max_site_separation_m"] < 2e-3 and summary["image_std"] > 5
    from PIL import Image

    pixels = np.asarray(Image.open(image))
    assert pixels.shape == (270, 480, 3)
    records = str(tmp_path / "arcade_records.xml")
    mjflex.convert_file(os.path.join(MODELS, "arcade.xml"), records, to="record")
    done, summary, _ = _script(["--model", records], tmp_path)
    assert done.returncode == 1 and summary["plugin_instances"] == 0 and summary["max_site_separation_m"] > 0.05
    assert "came apart" in done.stderr


def test_python_m_mujoco_viewer_loads_the_plugin_model(screenshot, tmp_path):
    """`python -m mujoco.viewer --mjcf=models/arcade.xml`: MuJoCo's managed viewer loads the model (the plugin is
    registered by `import mujoco`) and draws the elements in their zero-strain green; a misspelt plugin name is
    MuJoCo's load error instead, with nothing green drawn."""
    misspelt = str(tmp_path / "arcade_misspelt_plugin.xml")
    with open(os.path.join(MODELS, "arcade.xml")) as f, open(misspelt, "w") as g:
        g.write(f.read().replace('plugin="mjflex.flexure"', 'plugin="mjflex.flexur"'))
    display, server = screenshot.start_display(960, 540)
    try:
        seen = {}
        for name, path in (("good", os.path.join(MODELS, "arcade.xml")), ("bad", misspelt)):
            env = {**_env(), "DISPLAY": display}
            viewer = subprocess.Popen([sys.executable, "-m", "mujoco.viewer", f"--mjcf={path}"], cwd=ROOT, env=env,
                                      stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)  # fmt: skip
            try:
                green, started = 0, time.perf_counter()
                while time.perf_counter() - started < (60 if name == "good" else 8) and green < 200:
                    time.sleep(0.5)
                    image = screenshot.grab(display).astype(int)
                    r, g, b = image[..., 0], image[..., 1], image[..., 2]
                    green = int(((g > 60) & (g > 3 * r) & (g > 3 * b)).sum())
                seen[name] = (green, viewer.poll() is None)
            finally:
                viewer.kill()
                viewer.wait(timeout=30)
    finally:
        server.terminate()
        server.wait(timeout=30)
    assert seen["good"][0] >= 200 and seen["good"][1]  # drawn, and still running
    assert seen["bad"][0] < 20

"""Test configuration: offscreen rendering needs MUJOCO_GL before mujoco is first imported."""

import os
import platform

if platform.system() == "Linux" and not os.environ.get("DISPLAY"):
    os.environ.setdefault("MUJOCO_GL", "egl")  # set MUJOCO_GL=osmesa where EGL is unavailable

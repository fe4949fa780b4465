"""Test configuration: offscreen rendering needs MUJOCO_GL before mujoco is first imported."""

import os
import platform

if platform.system() == "Linux" and not os.environ.get("DISPLAY"):
    os.environ.setdefault("MUJOCO_GL", "egl")  # set MUJOCO_GL=osmesa where EGL is unavailable


import pytest


@pytest.fixture
def clean_callback():
    """The test starts and ends without a passive callback and with no mjflex provider installed."""
    import mujoco

    from mjflex.mj import _callback

    mujoco.set_mjcb_passive(None)
    yield
    _callback.uninstall_all()
    mujoco.set_mjcb_passive(None)

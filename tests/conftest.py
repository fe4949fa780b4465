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

    from mjflex.runtime import registry as _callback

    mujoco.set_mjcb_passive(None)
    yield
    _callback.uninstall_all()
    mujoco.set_mjcb_passive(None)


def require(name, available, reason):
    """Skip the calling test when a system service ``name`` is missing, unless CI requires it.

    A test that needs something beyond Python and the package (a display server, a C compiler, a
    sanitizer runtime) calls this with ``available`` (bool) and ``reason`` (what is missing and how to
    get it). Where the environment variable ``MJFLEX_REQUIRE`` lists ``name`` (comma-separated, or
    ``all``), a missing service fails the test instead: ``.ci/run`` sets it, so CI never skips silently.
    """
    if available:
        return
    required = {item.strip() for item in os.environ.get("MJFLEX_REQUIRE", "").split(",") if item.strip()}
    if name in required or "all" in required:
        pytest.fail(f"{reason} (MJFLEX_REQUIRE lists {name!r}, so this must run here)")
    pytest.skip(f"{reason}; set MJFLEX_REQUIRE={name} to make this a failure instead of a skip")


def c_compiler():
    """The C compiler that tests build copies of the native library with: ``$CC``, else Python's, else gcc.

    Skips the calling test where there is none (a machine that installed mjflex's wheel needs none),
    through :func:`require` (``MJFLEX_REQUIRE=compiler`` makes that a failure).
    """
    import shlex
    import shutil
    import sysconfig

    words = shlex.split(os.environ.get("CC") or sysconfig.get_config_var("CC") or "gcc")
    found = shutil.which(words[0]) if words else None
    require("compiler", found is not None, f"no C compiler ({words[0] if words else '$CC is empty'} is not on PATH; "
            "install gcc, e.g. apt-get install gcc) to build a test copy of the native library")  # fmt: skip
    return found

"""Registers mjflex's engine plugin ``mjflex.flexure`` with MuJoCo: the ``mujoco.plugins`` entry point.

``import mujoco`` calls :func:`register` (``[project.entry-points."mujoco.plugins"]`` in mjflex's
``pyproject.toml``), so every program that imports mujoco, ``python -m mujoco.viewer`` included,
can load models with ``<plugin plugin="mjflex.flexure">``. This module is deliberately tiny and
imports neither numpy nor mjflex (whose import pulls in numba): it only finds the compiled
library, checks that it was built for the MuJoCo that runs, and loads it, once, through
``mujoco.mj_loadPluginLibrary``. mjflex's Python layer finds the same library through
:func:`library` (a second copy from another path would collide with the first registration).

The library ``mjflex/native/libmjflex-mjNNNNNNN.so`` is built by ``pip install`` (``setup.py``);
``NNNNNNN`` is the ``mjVERSION_HEADER`` of the MuJoCo headers it was compiled against. The
environment variable ``MJFLEX_NATIVE_DIR`` names another folder to take it from (the sanitizer
builds of ``tests/test_native_sanitizers.py``); it must be set before ``import mujoco``.
"""

import ctypes
import importlib.util
import os
import re
import threading

__all__ = ["NativeLibraryError", "built", "library", "library_path", "register"]

_LOCK = threading.Lock()
_STATE = {}
_PATTERN = re.compile(r"libmjflex-mj(\d+)\.(so|dylib|dll)$")
REBUILD = (
    "rebuild mjflex against the installed mujoco: pip install --force-reinstall --no-deps --no-build-isolation "
    "<mjflex source folder or sdist> (a C compiler is needed)"
)


class NativeLibraryError(RuntimeError):
    """mjflex's native library is missing, or was built for another MuJoCo; the message says how to fix it."""


def _folder():
    if os.environ.get("MJFLEX_NATIVE_DIR"):
        return os.environ["MJFLEX_NATIVE_DIR"]
    spec = importlib.util.find_spec("mjflex")  # locates the package without importing it (no numba)
    if spec is None or not spec.submodule_search_locations:
        return None
    return os.path.join(next(iter(spec.submodule_search_locations)), "native")


def _candidates():
    folder = _folder()
    if folder is None or not os.path.isdir(folder):
        return []
    found = []
    for name in os.listdir(folder):
        match = _PATTERN.match(name)
        if match:
            found.append((int(match.group(1)), os.path.join(folder, name)))
    return sorted(found)


def library_path():
    """Path of the native library built for the running MuJoCo; raises :class:`NativeLibraryError`."""
    import mujoco

    running = mujoco.mj_version()
    found = _candidates()
    for version, path in found:
        if version == running:
            return path
    if not found:
        raise NativeLibraryError(
            "mjflex's native library (the engine plugin mjflex.flexure, which computes every flexure force) is not "
            f"built in {_folder()}, and mjflex does not work without it: this install is broken. Install mjflex's "
            "binary wheel, which needs no compiler (pip install --force-reinstall mjflex-<version>-py3-none-"
            "manylinux_*_x86_64.whl), or build from source: Install gcc, then "
            f"{REBUILD.split(': ', 1)[1]}"
        )
    built = ", ".join(str(v) for v, _ in found)
    raise NativeLibraryError(
        f"mjflex's native library was built against the headers of MuJoCo {built}, but MuJoCo {running} "
        f"({mujoco.__version__}) is running; mjModel and mjData change between releases, so it is not loaded: "
        f"{REBUILD}"
    )


def library():
    """The native library as a ``ctypes.CDLL``, loaded (and its plugin registered) once per process.

    Raises :class:`NativeLibraryError` when it is missing, built for another MuJoCo, or refused
    to register (the check of ``mjVERSION_HEADER`` against ``mj_version()`` inside it).
    """
    # mujoco is imported before the lock is taken: its import runs the entry point, register(), which calls this
    # function again in this thread (a lock held across the import would deadlock; tests/test_native_lifecycle.py)
    import mujoco

    with _LOCK:
        if "library" in _STATE:
            return _STATE["library"]
        if "error" in _STATE:
            raise NativeLibraryError(_STATE["error"])
        try:
            path = library_path()
            mujoco.mj_loadPluginLibrary(path)  # runs the library's constructor: mjp_registerPlugin
            lib = ctypes.CDLL(path)  # the same handle (same path): no second copy
            if lib.mjfx_status() == -2:
                raise NativeLibraryError(
                    f"another copy of mjflex's native library, loaded from another path, registered the plugin "
                    f"mjflex.flexure in this process before {path}: two installations of mjflex are on the path "
                    "(see sys.path and PYTHONPATH); keep one, so that the plugin's elements and mjflex's Python "
                    "layer use one library"
                )
            if lib.mjfx_status() != 1:
                raise NativeLibraryError(
                    f"mjflex's native library {path} refused to register: it was compiled against the headers of "
                    f"MuJoCo {lib.mjfx_header_version()} but runs in MuJoCo {mujoco.mj_version()}; {REBUILD}"
                )
        except (NativeLibraryError, OSError, mujoco.FatalError) as exc:
            _STATE["error"] = str(exc)
            raise NativeLibraryError(str(exc)) from None
        _STATE["library"] = lib
        return lib


def built() -> bool:
    """Whether any native library was built (for whichever MuJoCo)."""
    return bool(_candidates())


def register():
    """The ``mujoco.plugins`` entry point: load the library (registering ``mjflex.flexure``).

    A library built for another MuJoCo raises :class:`NativeLibraryError`, which ``import mujoco``
    turns into a ``RuntimeWarning`` naming the cause and the fix (mujoco itself still imports).
    Without any library (a broken install) it does nothing here: mjflex raises
    :class:`NativeLibraryError` when it is used, and a plugin model fails to compile with MuJoCo's
    "unrecognized plugin".
    """
    if built():
        library()

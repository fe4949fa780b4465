"""Build of mjflex's native library (the engine plugin and the per-step math, ``mjflex/native/*.c``).

Everything else is in ``pyproject.toml``. The library is a plain C shared library, not a Python
extension module: it is loaded by ``mujoco.mj_loadPluginLibrary`` and by ctypes, and does not
depend on Python's ABI. It is compiled against the headers of the ``mujoco`` wheel of the build
environment and linked to that wheel's ``libmujoco.so.X.Y.Z`` (rpath to the wheel's folder), so
the build requires the same ``mujoco`` as the runtime (both pinned in ``pyproject.toml``). Its
file name carries the header version (``libmjflex-mj4000000.so``): ``mjflex_plugin`` refuses a
library built for another MuJoCo before loading it.

mjflex does not work without the library (every flexure force comes from it); issue 23's packaging
makes a build without a compiler stop. Until then the build warns and goes on, and mjflex raises
``mjflex_plugin.NativeLibraryError`` saying how to install it when it is used.
"""

import importlib.util
import os
import re
import sys

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

NATIVE = os.path.join("mjflex", "native")
SOURCES = sorted(os.path.join(NATIVE, f) for f in os.listdir(NATIVE) if f.endswith(".c"))


def _mujoco_folder():
    spec = importlib.util.find_spec("mujoco")  # without importing it (no bindings, no entry points)
    if spec is None or not spec.submodule_search_locations:
        return None
    return next(iter(spec.submodule_search_locations))


def _header_version(folder):
    with open(os.path.join(folder, "include", "mujoco", "mujoco.h")) as f:
        return int(re.search(r"#define\s+mjVERSION_HEADER\s+(\d+)", f.read()).group(1))


class BuildNative(build_ext):
    """Compile ``mjflex/native`` into ``mjflex/native/libmjflex-mjNNNNNNN.so``, or warn and go on."""

    def get_ext_filename(self, fullname):
        folder = _mujoco_folder()
        version = _header_version(folder) if folder else 0
        suffix = ".dll" if sys.platform == "win32" else (".dylib" if sys.platform == "darwin" else ".so")
        return os.path.join(*fullname.split(".")[:-1], f"libmjflex-mj{version}{suffix}")

    def get_export_symbols(self, ext):
        return []  # a C library, not a module: no PyInit_ symbol

    def build_extension(self, ext):
        folder = _mujoco_folder()
        if folder is None:
            self._skip("the mujoco package is not installed in the build environment")
            return
        libs = sorted(f for f in os.listdir(folder) if re.fullmatch(r"libmujoco\.so\.\d+\.\d+\.\d+", f))
        if not libs and sys.platform.startswith("linux"):
            self._skip(f"no libmujoco.so.X.Y.Z in {folder}")
            return
        ext.include_dirs = [os.path.join(folder, "include")]
        ext.library_dirs = [folder]
        ext.extra_link_args = [f"-l:{libs[-1]}", "-Wl,-rpath,$ORIGIN/../../mujoco", "-lm"]
        try:
            super().build_extension(ext)
        except Exception as exc:  # no compiler, or it failed: mjflex says so when it is used
            self._skip(f"{type(exc).__name__}: {exc}")

    def _skip(self, why):
        bar = "=" * 78
        print(
            f"\n{bar}\nmjflex: the native library (engine plugin mjflex.flexure and the fast per-step path) was NOT "
            f"built:\n  {why}\nmjflex does not work without it. "
            "To build it, install a C compiler (e.g. apt-get install gcc) and reinstall mjflex:\n"
            f"  pip install --force-reinstall --no-deps <mjflex source>\n{bar}\n",
            file=sys.stderr,
        )


def _cflags():
    """-O3 (about 15 % fewer instructions per element than -O2, measured); -fexceptions so that a MuJoCo error
    raised from a callback (a C++ exception under the Python bindings) unwinds through these C frames;
    -fno-math-errno so that sqrt is one instruction. No -march: the library must run on any x86-64."""
    if sys.platform == "win32":
        return ["/O2"]
    return ["-O3", "-std=c11", "-fexceptions", "-fno-math-errno", "-ffp-contract=off", "-Wall"]


setup(
    ext_modules=[
        Extension(
            "mjflex.native.libmjflex",
            sources=SOURCES,
            depends=sorted(os.path.join(NATIVE, f) for f in os.listdir(NATIVE) if f.endswith(".h")),
            extra_compile_args=_cflags(),
            optional=True,
        )
    ],
    cmdclass={"build_ext": BuildNative},
)

"""Build of mjflex's native library (the engine plugin and the per-step math, ``mjflex/native/*.c``).

Everything else is in ``pyproject.toml``. The library is a plain C shared library, not a Python
extension module: it is loaded by ``mujoco.mj_loadPluginLibrary`` and by ctypes, and does not
depend on Python's ABI, so the wheel is tagged ``py3-none-<platform>``: one wheel for every
supported Python (``scripts/build_release.py`` builds it and makes it a manylinux wheel). It is
compiled against the headers of the ``mujoco`` wheel of the build environment and linked to that
wheel's ``libmujoco.so.X.Y.Z`` (which the ``mujoco-core`` wheel installs into the ``mujoco``
folder of site-packages; the rpath ``$ORIGIN/../../mujoco`` finds it from ``mjflex/native``), so
the build requires the same ``mujoco`` as the runtime (both pinned in ``pyproject.toml``). Its
file name carries the header version (``libmjflex-mj4000000.so``): ``mjflex_plugin`` refuses a
library built for another MuJoCo before loading it.

The library is required: plugin models (the default) do not load without it. A build from source
without a working C compiler stops with a message that says what to do (install a wheel, or
install gcc); it never installs half of mjflex.
"""

import importlib.util
import os
import re
import shutil
import sys

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

try:  # setuptools >= 70.1 (what pyproject's build-system asks for)
    from setuptools.command.bdist_wheel import bdist_wheel
except ImportError:  # an older setuptools in a --no-build-isolation environment
    try:
        from wheel.bdist_wheel import bdist_wheel
    except ImportError:
        bdist_wheel = None

NATIVE = os.path.join("mjflex", "native")
SOURCES = sorted(os.path.join(NATIVE, f) for f in os.listdir(NATIVE) if f.endswith(".c"))
HOW_TO_FIX = (
    "mjflex's native library (the engine plugin mjflex.flexure and the per-step math) is compiled from C when "
    "mjflex is installed from source, and mjflex does not work without it. Either\n"
    "  * install mjflex's binary wheel, which needs no compiler (Linux x86-64, Python 3.11-3.13): "
    "pip install mjflex-<version>-py3-none-manylinux_*_x86_64.whl (python scripts/build_release.py makes it "
    "where a compiler is), or\n"
    "  * install a C compiler (Debian/Ubuntu: apt-get install gcc; Fedora: dnf install gcc) and install mjflex "
    "again."
)


class NativeBuildError(SystemExit):
    """Stops the build with a message (pip shows it under 'error: subprocess-exited-with-error')."""


def _fail(why):
    bar = "=" * 78
    print(f"\n{bar}\nmjflex: cannot build the native library: {why}\n\n{HOW_TO_FIX}\n{bar}\n", file=sys.stderr)
    raise NativeBuildError(f"mjflex: cannot build the native library: {why}. {HOW_TO_FIX}")


def _mujoco_folder():
    spec = importlib.util.find_spec("mujoco")  # without importing it (no bindings, no entry points)
    if spec is None or not spec.submodule_search_locations:
        return None
    return next(iter(spec.submodule_search_locations))


def _header_version(folder):
    with open(os.path.join(folder, "include", "mujoco", "mujoco.h")) as f:
        return int(re.search(r"#define\s+mjVERSION_HEADER\s+(\d+)", f.read()).group(1))


def _not_searched_here(arg):
    """A link flag of the building Python (its -L and rpath, e.g. pyenv's lib folder), not of this library."""
    return arg.startswith(("-L", "-Wl,-rpath", "-Wl,-R", "-R"))


class BuildNative(build_ext):
    """Compile ``mjflex/native`` into ``mjflex/native/libmjflex-mjNNNNNNN.so``, or stop saying how to get it."""

    def get_ext_filename(self, fullname):
        folder = _mujoco_folder()
        version = _header_version(folder) if folder else 0
        return os.path.join(*fullname.split(".")[:-1], f"libmjflex-mj{version}.so")

    def get_export_symbols(self, ext):
        return []  # a C library, not a module: no PyInit_ symbol

    def build_extension(self, ext):
        folder = _mujoco_folder()
        if folder is None:
            _fail("the mujoco package is not installed in the build environment (pyproject.toml's build-system)")
        if not sys.platform.startswith("linux"):  # the link step below is GNU ld's, against libmujoco.so
            _fail(f"building on {sys.platform} is not supported yet: mjflex is built and tested on Linux only "
                  "(docs/install.md, supported platforms)")  # fmt: skip
        libs = sorted(f for f in os.listdir(folder) if re.fullmatch(r"libmujoco\.so\.\d+\.\d+\.\d+", f))
        if not libs:
            _fail(f"no libmujoco.so.X.Y.Z in {folder} (the mujoco-core wheel installs it there)")
        for tool in ("compiler_so", "linker_so"):
            command = getattr(self.compiler, tool, None) or []
            if not command or shutil.which(command[0]) is None:
                _fail(f"no C compiler: {command[0] if command else tool!r} is not an executable on PATH")
        self.compiler.linker_so = [a for a in self.compiler.linker_so if not _not_searched_here(a)]
        ext.include_dirs = [os.path.join(folder, "include")]
        ext.library_dirs = [folder]
        ext.extra_link_args = [f"-l:{libs[-1]}", "-Wl,-rpath,$ORIGIN/../../mujoco", "-lm"]
        try:
            super().build_extension(ext)
        except Exception as exc:  # the compiler failed: say why and what to do, and install nothing
            _fail(f"{type(exc).__name__}: {exc}")


def _cflags():
    """-O3 (about 15 % fewer instructions per element than -O2, measured); -fexceptions so that a MuJoCo error
    raised from a callback (a C++ exception under the Python bindings) unwinds through these C frames;
    -fno-math-errno so that sqrt is one instruction. No -march: the library must run on any x86-64."""
    return ["-O3", "-std=c11", "-fexceptions", "-fno-math-errno", "-ffp-contract=off", "-Wall"]


commands = {"build_ext": BuildNative}
if bdist_wheel is not None:

    class Wheel(bdist_wheel):
        """``py3-none-<platform>``: the library is tied to the platform and to MuJoCo, not to a Python."""

        def get_tag(self):
            _, _, platform = super().get_tag()
            return "py3", "none", platform

    commands["bdist_wheel"] = Wheel

setup(
    ext_modules=[
        Extension(
            "mjflex.native.libmjflex",
            sources=SOURCES,
            depends=sorted(os.path.join(NATIVE, f) for f in os.listdir(NATIVE) if f.endswith(".h")),
            extra_compile_args=_cflags(),
        )
    ],
    cmdclass=commands,
)

"""How the native library is built, found and registered: `import mujoco` alone, once, and never the wrong one."""

import ctypes
import os
import shutil
import subprocess
import sys

import mujoco
import pytest

import mjflex
import mjflex_plugin
from mjflex.native import library as _native
from tests.conftest import c_compiler

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), ".."))
NATIVE = os.path.join(os.path.dirname(mjflex.__file__), "native")  # the installed sources (the wheel has them)


def _run(code, **env):
    result = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=300,
                            env={**os.environ, **env})  # fmt: skip
    return result


def test_the_native_library_is_in_use():
    """The test environment builds it (pip install -e .)."""
    assert _native.lib(), "the native library did not build: pip install -v -e . shows why"
    assert os.path.basename(mjflex_plugin.library_path()) == f"libmjflex-mj{mujoco.mj_version()}.so"


def test_import_mujoco_alone_loads_the_plugin_and_stays_light(tmp_path):
    from tests.models import B_DEMO, two_body_spec

    path = tmp_path / "plugin.xml"
    path.write_text(two_body_spec(B=B_DEMO, kind="plugin").to_xml())
    code = f"""
import sys
import mujoco
model = mujoco.MjModel.from_xml_path({str(path)!r})
data = mujoco.MjData(model)
data.qpos[7] += 0.01
mujoco.mj_step(model, data)
print("force", data.qfrc_passive[0] != 0, "numba" in sys.modules, "mjflex" in sys.modules, "mjflex.core" in sys.modules)
"""
    result = _run(code)
    assert result.returncode == 0, result.stderr
    assert result.stdout.split() == ["force", "True", "False", "False", "False"]
    assert "Warning" not in result.stderr


def test_mjflex_uses_the_copy_that_mujoco_registered(tmp_path):
    """One library in the process: mjflex's ctypes handle is the one `import mujoco` loaded (a second copy
    from another path would collide with the registration)."""
    code = """
import mujoco, mjflex
from mjflex.native import library as _native
from tests.models import two_body_spec
assert _native.lib()
mjflex.Flexures(two_body_spec(kind="plugin").compile())
with mjflex.Flexures(two_body_spec().compile()):
    pass
maps = {line.split()[-1] for line in open("/proc/self/maps") if "libmjflex" in line}
print(len(maps))
"""
    result = _run(code)
    assert result.returncode == 0, result.stderr
    assert result.stdout.split()[-1] == "1"


def _compile_library(out, *flags):
    folder = os.path.dirname(mujoco.__file__)
    libs = [f for f in os.listdir(folder) if f.startswith("libmujoco.so.")]
    cc = c_compiler()
    sources = [os.path.join(NATIVE, f) for f in sorted(os.listdir(NATIVE)) if f.endswith(".c")]
    cmd = [cc, "-O1", "-shared", "-fPIC", "-std=c11", "-fexceptions", *flags,
           f"-I{os.path.join(folder, 'include')}", *sources, "-o", str(out), f"-L{folder}", f"-l:{libs[0]}",
           f"-Wl,-rpath,{folder}", "-lm"]  # fmt: skip
    done = subprocess.run(cmd, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr


def test_a_library_built_for_another_mujoco_refuses_to_register(tmp_path):
    """The check of mjVERSION_HEADER against mj_version() inside the library (any host: simulate, C programs)."""
    fake = tmp_path / "libmjflex-mj3999999.so"
    _compile_library(fake, "-DMJFX_HEADER_VERSION=3999999")
    code = f"""
import ctypes, mujoco
mujoco.mj_loadPluginLibrary({str(fake)!r})
lib = ctypes.CDLL({str(fake)!r})
print("status", lib.mjfx_status(), lib.mjfx_header_version())
"""
    result = _run(code)
    assert result.returncode == 0, result.stderr
    assert "status -1 3999999" in result.stdout
    out = result.stdout + result.stderr
    assert "compiled against the headers of MuJoCo 3999999 but is loaded by MuJoCo 4000000" in out
    assert "it is not registered. Rebuild it against the installed mujoco: pip install --force-reinstall" in out


def test_the_entry_point_refuses_a_library_built_for_another_mujoco(tmp_path, monkeypatch):
    """Before loading anything: the file name carries the header version (setup.py names it)."""
    (tmp_path / "libmjflex-mj3999999.so").write_bytes(b"not loaded")
    monkeypatch.setattr(mjflex_plugin, "_folder", lambda: str(tmp_path))
    with pytest.raises(
        mjflex_plugin.NativeLibraryError,
        match=r"built against the headers of MuJoCo 3999999, but "
        r"MuJoCo 4000000 \(4.0.0\) is running; .* rebuild mjflex against the installed mujoco: pip",
    ):
        mjflex_plugin.library_path()
    for key in ("error", "library"):  # forget this process's loaded library for the test (restored after)
        monkeypatch.delitem(mjflex_plugin._STATE, key, raising=False)
    with pytest.raises(mjflex_plugin.NativeLibraryError, match="3999999"):
        mjflex_plugin.register()  # what `import mujoco` turns into a RuntimeWarning


def test_register_is_quiet_without_any_library(tmp_path, monkeypatch):
    """No library in the package (a broken install): `import mujoco` says nothing; mjflex says why when used."""
    monkeypatch.setattr(mjflex_plugin, "_folder", lambda: str(tmp_path))
    assert not mjflex_plugin.built()
    mjflex_plugin.register()
    with pytest.raises(mjflex_plugin.NativeLibraryError, match=r"is not built .* Install gcc, then pip install"):
        mjflex_plugin.library_path()


@pytest.mark.parametrize("cc", ["/nonexistent/cc", "false"], ids=["no compiler", "compiler fails"])
def test_without_a_working_compiler_the_build_stops_and_says_what_to_do(tmp_path, cc):
    """The library is not optional (plugin models need it): setup.py's build_ext fails, naming the two ways out
    (a binary wheel, or gcc), and builds nothing. Run on a copy: setup.py and the native sources alone."""
    os.makedirs(tmp_path / "mjflex" / "native")
    for name in os.listdir(NATIVE):
        if name.endswith((".c", ".h")):
            shutil.copy(os.path.join(NATIVE, name), tmp_path / "mjflex" / "native")
    shutil.copy(os.path.join(ROOT, "setup.py"), tmp_path)
    env = {k: v for k, v in os.environ.items() if k not in ("LDSHARED", "CFLAGS", "LDFLAGS")}
    command = [sys.executable, "setup.py", "build_ext", "--build-lib", "lib", "--build-temp", "tmp"]
    result = subprocess.run(command, cwd=tmp_path, capture_output=True, text=True, env={**env, "CC": cc}, timeout=300)
    assert result.returncode != 0, result.stdout
    out = result.stderr
    assert "mjflex: cannot build the native library: " in out
    assert ("no C compiler: '/nonexistent/cc" in out) if cc.startswith("/") else ("CompileError" in out)
    assert "install mjflex's binary wheel, which needs no compiler" in out and "apt-get install gcc" in out
    built = [f for _, _, files in os.walk(tmp_path) for f in files if f.startswith("libmjflex")]
    assert built == []


def test_the_scalar_path_is_iso_c11(tmp_path):
    """The C compiles without GNU extensions in its one-lane path (what a compiler without GNU C builds,
    flexure_kernel.h): -std=c11 -pedantic-errors -DMJFX_SCALAR, and that library loads and runs one lane."""
    copy = tmp_path / "libmjflex-iso.so"
    # another header version: the copy does not register the plugin a second time (its functions still work)
    _compile_library(copy, "-pedantic-errors", "-Wall", "-DMJFX_SCALAR", "-DMJFX_HEADER_VERSION=3999999")
    lib = ctypes.CDLL(str(copy))
    assert lib.mjfx_header_version() == 3999999
    assert lib.mjfx_lanes() == 1 and lib.mjfx_set_lanes(2) == -1


def test_the_element_struct_is_mirrored_exactly():
    native = _native.lib()
    for name in _native.ELEMENT_DTYPE.names:
        assert native.mjfx_element_field(name.encode()) == _native.ELEMENT_DTYPE.fields[name][1]
    assert native.mjfx_element_field(b"no_such_field") == -1
    assert ctypes.sizeof(_native.Scan) == 16


def test_without_the_library_import_mjflex_works_and_the_first_use_says_how_to_install_it(tmp_path):
    """One runtime: no Python fallback. The core needs no library; an element's first use (add_flexure, which has
    the library check it, in either form) raises NativeLibraryError naming the element, the wheel and the compiler
    (MJFLEX_NATIVE_DIR points mjflex_plugin at an empty folder: a broken install)."""
    code = """
import mujoco, mjflex, mjflex_plugin
from tests.models import two_body_spec
import numpy as np
print("core", float(mjflex.potential(np.eye(3), np.zeros(3), np.eye(3), [0, 0, 0.1], K=np.eye(6))))
try:
    mjflex.Flexures(two_body_spec(kind="record").compile())
except mjflex_plugin.NativeLibraryError as exc:
    print("refused:", exc)
"""
    result = _run(code, MJFLEX_NATIVE_DIR=str(tmp_path))
    assert result.returncode == 0, result.stderr
    assert "core 0.005" in result.stdout  # K_z (0.1 m)^2 / 2
    assert "refused: flexure 'link': flexure elements need mjflex's native library" in result.stdout
    assert "Install mjflex's binary wheel, which needs no compiler" in result.stdout
    assert "Install gcc, then pip install" in result.stdout

"""The native library under AddressSanitizer + UndefinedBehaviorSanitizer and ThreadSanitizer (issue 22).

The library is built again from the same sources and flags as ``pip install`` builds it: ``setup.py
build_ext`` into a temporary folder, with the sanitizer flags added through ``CFLAGS`` and ``LDFLAGS``
(so setup.py stays the one place that names the sources and the optimization flags). The tests of the
native math, the plugin, the boundary checks, the lifecycle and the hardening, and the fuzzer's slice,
then run in a child interpreter that loads that build (``MJFLEX_NATIVE_DIR``, honoured by
``mjflex_plugin``) with libasan preloaded together with libstdc++ (ASan otherwise aborts at the first
C++ exception of another extension, e.g. MuJoCo's errors). UBSan stops at the first report
(``-fno-sanitize-recover=all``); any report of either fails the test, as does any failing test.
ThreadSanitizer runs the threaded paths: rollout with threads and model lists of other element
counts, datas made, stepped and freed in threads (the plugin's registry), models with muscles compiled
in threads (MuJoCo's length-range simulations on datas without instances), and the mjcb_passive
dispatcher with more datas than it has watch entries. Not ``mujoco.batch.Batch``: its thread pool, in
the uninstrumented libmujoco, hands work over through atomics ThreadSanitizer cannot see, so every
handover is reported as a race, inside MuJoCo (``mjb_makeBatch``) as much as in the plugin; Batch
runs in the ASan run (tests/test_plugin.py).

Without gcc or the sanitizer runtimes these tests skip (``require("sanitizers", ...)``); CI sets
``MJFLEX_REQUIRE`` so that they run there.
"""

import os
import re
import shutil
import subprocess
import sys
import time

import pytest

from tests.conftest import require
from tests.native_cases import ROOT, run_python, sanitizer_reports

SANITIZED_TESTS = [
    "tests/test_native.py",
    "tests/test_native_math.py",
    "tests/test_native_kernel.py",
    "tests/test_plugin.py",
    "tests/test_plugin_config.py",
    "tests/test_boundary.py",
    "tests/test_native_lifecycle.py",
    "tests/test_native_hardening.py",
    "tests/test_native_reference.py",
    "tests/test_native_fuzz.py",
    "tests/test_native_guards.py",  # the registry's guards, the dof-chain buffer at its fullest (issue 33 item 17)
    "tests/test_model_edits.py",  # the model snapshots compared after in-place edits (issue 33 item 14)
    "tests/test_stop_damping.py",
    "tests/test_rest_pose.py",
    "tests/test_lengthrange.py",  # the compiler's length-range data (no instances), in threads too
    "tests/test_schema.py",  # the one rulebook, and the sites an element binds (exact names, then one affix)
]

# builds and loads a copy of the library of its own, without the sanitizers: nothing to learn from it here
ONE_LANE_BUILD = "tests/test_native_kernel.py::test_a_one_lane_build_gives_the_same_bits"


def _runtime(compiler, name):
    """Absolute path of a runtime library of the compiler (``gcc -print-file-name``), or None."""
    try:
        out = subprocess.run([compiler, f"-print-file-name={name}"], capture_output=True, text=True, timeout=30)
    except OSError:
        return None
    path = out.stdout.strip()
    return os.path.realpath(path) if os.path.isabs(path) and os.path.exists(path) else None


def _toolchain(sanitizer):
    compiler = os.environ.get("CC", "gcc")
    runtimes = {"asan": ["libasan.so", "libstdc++.so"], "tsan": ["libtsan.so"]}[sanitizer]
    paths = [_runtime(compiler, name) for name in runtimes] if shutil.which(compiler) else [None]
    require(
        "sanitizers",
        all(paths),
        f"building the sanitizer tests needs {compiler} and its runtimes {runtimes} "
        "(Debian: apt-get install gcc, which brings libasan and libtsan)",
    )
    return paths


def _build(tmp_path_factory, flags):
    """setup.py build_ext with the sanitizer flags; returns the folder of the built library."""
    out = tmp_path_factory.mktemp("sanitized")
    env = {**os.environ, "CFLAGS": f"{flags} -fno-omit-frame-pointer -g", "LDFLAGS": flags}
    start = time.perf_counter()
    result = subprocess.run(
        [sys.executable, "setup.py", "build_ext", "--parallel", "2", "--build-lib", str(out / "lib"), "--build-temp",
         str(out / "tmp")],
        cwd=ROOT, env=env, capture_output=True, text=True, timeout=900,
    )  # fmt: skip
    folder = out / "lib" / "mjflex" / "native"
    built = [f for f in os.listdir(folder)] if folder.is_dir() else []
    assert result.returncode == 0 and built, f"the sanitizer build failed:\n{result.stdout}\n{result.stderr}"
    print(f"sanitizer build ({flags}): {time.perf_counter() - start:.1f} s")
    return str(folder)


@pytest.fixture(scope="module")
def asan(tmp_path_factory):
    libasan, libstdcxx = _toolchain("asan")
    folder = _build(tmp_path_factory, "-fsanitize=address,undefined -fno-sanitize-recover=all")
    return {
        "MJFLEX_NATIVE_DIR": folder,
        "LD_PRELOAD": f"{libasan} {libstdcxx}",
        # leaks: Python's own allocations at exit are not ours (the registry's counts are checked by the tests)
        "ASAN_OPTIONS": "detect_leaks=0:halt_on_error=1:abort_on_error=0:exitcode=86",
        "UBSAN_OPTIONS": "halt_on_error=1:print_stacktrace=1:exitcode=87",
        "PYTHONFAULTHANDLER": "1",
    }


@pytest.fixture(scope="module")
def tsan(tmp_path_factory):
    (libtsan,) = _toolchain("tsan")
    folder = _build(tmp_path_factory, "-fsanitize=thread")
    return {"MJFLEX_NATIVE_DIR": folder, "LD_PRELOAD": libtsan,
            "TSAN_OPTIONS": "halt_on_error=0:exitcode=66:report_signal_unsafe=0"}  # fmt: skip


def test_the_native_tests_are_clean_under_asan_and_ubsan(asan):
    """Every test of SANITIZED_TESTS passes with the ASan + UBSan build, and nothing is reported."""
    start = time.perf_counter()
    result = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-x", *SANITIZED_TESTS, "--deselect",
         ONE_LANE_BUILD],
        cwd=ROOT, env={**os.environ, **asan}, capture_output=True, text=True, timeout=1500,
    )  # fmt: skip
    out = result.stdout + result.stderr
    print(f"ASan + UBSan run of {len(SANITIZED_TESTS)} test files: {time.perf_counter() - start:.1f} s")
    reports = sanitizer_reports(out)
    assert result.returncode == 0 and not reports, out[-12000:]
    passed = re.search(r"(\d+) passed", out)
    assert passed and int(passed.group(1)) > 150 and " failed" not in out, out[-3000:]


def test_the_sanitized_build_is_the_one_loaded(asan):
    """The child really runs the sanitized library (not the installed one)."""
    result = run_python(
        """
import mjflex_plugin
print(mjflex_plugin.library_path())
""",
        env=asan,
    )
    assert result.stdout.strip().startswith(asan["MJFLEX_NATIVE_DIR"])


THREADED = """
import copy, threading
import numpy as np
import mujoco
from mujoco import rollout
import mjflex
from tests.native_cases import two_body_xml, chain_xml
from tests.models import two_body_spec, B_DEMO

# the mjcb_passive dispatcher: 160 datas of one text-record model, more than its 64 watch entries, 4 threads
m = two_body_spec(B=B_DEMO).compile()
flex = mjflex.Flexures(m)
datas = [mujoco.MjData(m) for _ in range(160)]

def run(k):
    for _ in range(15):
        for d in datas[k::4]:
            mujoco.mj_step(m, d)

with flex:
    threads = [threading.Thread(target=run, args=(k,)) for k in range(4)]
    [t.start() for t in threads]; [t.join() for t in threads]

# rollout: 4 threads, a model list of 1, 6 and 2 elements on datas made from the first
models = [mujoco.MjModel.from_xml_string(two_body_xml(n)) for n in (1, 6, 2)]
kind = mujoco.mjtState.mjSTATE_FULLPHYSICS
d = mujoco.MjData(models[0]); d.qvel[:] = 0.3
state = np.empty(mujoco.mj_stateSize(models[0], kind)); mujoco.mj_getState(models[0], d, state, kind)
out, _ = rollout.rollout(models * 4, [mujoco.MjData(models[0]) for _ in range(4)], np.tile(state, (12, 1)), nstep=30)
assert np.isfinite(out).all()

# a chain of hinge, slide and ball joints, each thread's data stepped with a copy of the model (read again)
chain = mujoco.MjModel.from_xml_string(chain_xml(4))
d = mujoco.MjData(chain); d.qvel[:] = 0.2
state = np.empty(mujoco.mj_stateSize(chain, kind)); mujoco.mj_getState(chain, d, state, kind)
copies = [copy.copy(chain) for _ in range(4)]
out, _ = rollout.rollout(copies, [mujoco.MjData(chain) for _ in range(2)], np.tile(state, (4, 1)), nstep=30)
assert np.isfinite(out).all()

# the registry: datas made, copied, stepped with other models and freed in 4 threads
def churn(k):
    for r in range(25):
        m = models[(k + r) % 3]
        d = mujoco.MjData(m); d.qvel[:] = 0.1
        mujoco.mj_step(m, d, 2)
        twin = copy.copy(d)
        mujoco.mj_step(models[(k + r + 1) % 3], twin, 2)

threads = [threading.Thread(target=churn, args=(k,)) for k in range(4)]
[t.start() for t in threads]; [t.join() for t in threads]

# compiles in 4 threads: MuJoCo's length-range simulations (on its datas without instances) side by side
from tests.native_cases import arm_xml

def compile_arm(k):
    for _ in range(3):
        mujoco.MjSpec.from_string(arm_xml("element")).compile()

threads = [threading.Thread(target=compile_arm, args=(k,)) for k in range(4)]
[t.start() for t in threads]; [t.join() for t in threads]

print("threaded paths done")
"""


def test_the_threaded_paths_are_clean_under_tsan(tsan):
    """Item 7 (two threads took and cleared the same watch record) and the registry, under ThreadSanitizer."""
    start = time.perf_counter()
    result = run_python(THREADED, env=tsan, timeout=900)
    print(f"ThreadSanitizer run: {time.perf_counter() - start:.1f} s")
    assert "threaded paths done" in result.stdout

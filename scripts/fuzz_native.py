"""Fuzz the native engine plugin: mutated plugin configurations and extreme states, each in a forked child.

Usage::

    python scripts/fuzz_native.py [--configs 8000] [--states 3000] [--seed 0] [--timeout 20] [--json out.json]
    python scripts/fuzz_native.py --replay config:123 --seed 0      # one case again, in this process, verbosely

Every case is derived from ``(seed, kind, index)`` alone (numpy's SeedSequence), so a slice is
derandomized and any case can be replayed. A case runs in a child forked from this process
(``import mujoco`` registered the plugin before the fork): a crash or a hang ends the child, not
the run. The child's stderr is kept, so that under a sanitizer build (tests/test_native_sanitizers.py)
a report counts as a crash.

Cases:

* ``config``: a valid element on two free bodies (or a chain), then one to three of its
  ``mjflex.flexure`` attributes replaced by a hostile value (NaN, inf, 1e300, wrong counts,
  non-symmetric or indefinite matrices, exponents out of range, repeated terms, junk JSON, unknown
  sites, unknown keys, ...). The model is compiled, an MjData made, and the forces evaluated at
  rest and at a small displacement (they must be finite), then stepped (a valid but very stiff
  element may diverge there: MuJoCo and the plugin report it; judged in the step, not the force).
* ``state``: a valid model (free bodies with 1 to 3 elements of either method, polynomial terms,
  a chain of hinge, slide and ball joints, a mocap body) and a state with NaN, inf, 1e300, 1e-300,
  zero quaternions, through ``mj_forward``, ``mj_step``, ``mj_inverse``, ``mj_resetData`` and
  ``mujoco.rollout`` (1 or 2 threads, and a model list of other element counts).

Classes: ``compile error`` (MuJoCo refused the model: the plugin's message), ``accepted finite``,
``NaN`` (a force or state not finite, no error raised), ``MuJoCo error`` (an exception while
stepping: MuJoCo's own checks), ``crash`` (a signal, a non-zero exit, or a sanitizer report) and
``hang`` (no result within ``--timeout`` seconds). A config that is accepted must give finite forces
(``NaN`` there is a defect); a state that holds NaN or inf gives NaN, as MuJoCo itself does.
The state cases' models are valid: a ``compile error`` there is a defect too. The table and JSON list
the counts per kind and class, a few examples of each, and every defect with its case id.
"""

import argparse
import json
import os
import signal
import sys
import tempfile
import time
import traceback

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))
sys.path.insert(0, HERE)

import mujoco  # noqa: E402  (registers the plugin before any fork)
from mujoco import rollout  # noqa: E402

from tests.native_cases import SANITIZER_REPORTS, chain_xml, two_body_xml  # noqa: E402

CLASSES = ("compile error", "accepted finite", "NaN", "MuJoCo error", "crash", "hang")
KINDS = ("config", "state")

# ------------------------------------------------------------------ hostile values

NUMBERS = ["0", "-0", "1", "-1", "0.5", "1e-320", "1e280", "-1e280", "1e300", "1e308", "nan", "NaN", "-nan", "inf",
           "-inf", "Infinity", "1e9999", "0x1p3", "1,2", "1e", "--1", "+", ".", "abc", "1.5.5", "\u0661",
           ""]  # fmt: skip


def _number(rng):
    if rng.random() < 0.5:
        return repr(float(rng.normal() * 10.0 ** rng.integers(-3, 4)))
    return NUMBERS[rng.integers(len(NUMBERS))]


def _numbers(rng, count=None):
    count = count if count is not None else int(rng.choice([0, 1, 3, 5, 6, 8, 9, 35, 36, 37, 100]))
    return " ".join(_number(rng) for _ in range(count))


def _matrix(rng):
    """A K or B: valid, non-symmetric, indefinite, huge, or junk."""
    choice = rng.integers(6)
    n = int(rng.choice([3, 6]))
    A = rng.normal(size=(n, n))
    if choice == 0:
        M = A @ A.T + n * np.eye(n)  # valid
    elif choice == 1:
        M = A @ A.T + n * np.eye(n)
        M[0, n - 1] += 1.0  # not symmetric
    elif choice == 2:
        M = A @ A.T
        M[n - 1, n - 1] = -abs(M[n - 1, n - 1]) - 1.0  # indefinite, the last direction
    elif choice == 3:
        M = (A @ A.T + n * np.eye(n)) * 10.0 ** rng.integers(250, 310)
    elif choice == 4:
        return _numbers(rng)
    else:
        M = np.diag(rng.normal(size=n))
        return " ".join(repr(float(v)) for v in np.diag(M))
    return " ".join(repr(float(v)) for v in M.ravel())


def _exponents(rng, method):
    nvar = 6 if method != "dualquat" else 8
    rows = int(rng.choice([0, 1, 2, 5, 50]))
    table = rng.integers(0, 5, size=(rows, nvar))
    choice = rng.integers(5)
    if choice == 0 and rows:
        table[rng.integers(rows), rng.integers(nvar)] = int(rng.choice([-1, 17, 99, 2**31 - 1]))
    elif choice == 1 and rows > 1:
        table[-1] = table[0]  # a repeated term
    elif choice == 2:
        return _numbers(rng)
    text = " ".join(str(int(v)) for v in table.ravel())
    return text if rng.random() < 0.8 else text + " 1"


def _json(rng):
    return str(rng.choice(['{"formula": "x"}', "{", '{"a": NaN}', '{"a": 1,}', "[" * 300 + "]" * 300,
                           '{"a": "\\u12"}', '{"a": "\\q"}', '"text"', "{}", '{"a": [1, {"b": null}]}',
                           '{"a":' * 250 + "1" + "}" * 250, "\x01", '{"\u00e9": 1e400}']))  # fmt: skip


def _site(rng):
    return str(rng.choice(["a", "b", "", "A", "no_such_site", "a" * 5000, "b/a", "world", " a", "\u00e9"]))


def hostile_value(rng, key, method):
    if key in ("K", "B"):
        return _matrix(rng)
    if key == "method":
        return str(rng.choice(["twist", "dualquat", "", "TWIST", " twist ", "planar", "\t", "twist dualquat"]))
    if key == "order":
        return str(rng.choice(["-1", "0", "1", "2", "3", "4", "5", "17", "99999999999", "2.0", "nan", "", "4 4"]))
    if key == "exponents":
        return _exponents(rng, method)
    if key == "coefficients":
        return _numbers(rng)
    if key in ("enabled", "viscous"):
        return str(rng.choice(["true", "false", "", "yes", "1", "True", " false ", "truee"]))
    if key in ("strain_per_radian", "strain_scale"):
        return _numbers(rng, int(rng.choice([0, 1, 1, 1, 2])))
    if key == "source":
        return _json(rng)
    if key in ("site_a", "site_b", "site"):
        return _site(rng)
    if key == "rest_pos":
        return _numbers(rng, int(rng.choice([3, 3, 3, 2, 4])))
    if key == "rest_quat":
        return _quaternion(rng)
    if key == "stop_damping":
        return _numbers(rng, int(rng.choice([0, 1, 1, 3, 6, 6, 7])))
    return _numbers(rng)


def _quaternion(rng):
    """A rest quaternion: a rotation (to the last bit, or within the tolerance 1e-6), just not one, or junk."""
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)
    choice = rng.integers(5)
    if choice == 1:
        q *= 1.0 + 5e-7 * rng.choice([-1, 1])  # within the tolerance
    elif choice == 2:
        q *= 1.0 + 2e-6 * rng.choice([-1, 1])  # not a rotation
    elif choice == 3:
        return _numbers(rng, int(rng.choice([0, 3, 4, 5])))
    return " ".join(repr(float(v)) for v in q)


# ------------------------------------------------------------------ cases


def _rng(seed, kind, index):
    return np.random.default_rng([seed, KINDS.index(kind), index])


def _valid_terms(rng, method):
    """Cubic and quartic twist terms, small: a valid polynomial element (dual quaternions: none)."""
    if method != "twist":
        return ""
    rows = [r for r in _monomials_3_4()]
    pick = rng.choice(len(rows), size=int(rng.integers(1, 6)), replace=False)
    exps = " ".join(" ".join(map(str, rows[i])) for i in pick)
    coefs = " ".join(repr(float(c)) for c in 0.1 * rng.normal(size=len(pick)))
    return (f'<config key="order" value="4"/><config key="exponents" value="{exps}"/>'
            f'<config key="coefficients" value="{coefs}"/>')  # fmt: skip


def _monomials_3_4():
    import itertools

    out = []
    for degree in (3, 4):
        for combo in itertools.combinations_with_replacement(range(6), degree):
            out.append([combo.count(k) for k in range(6)])
    return out


def config_case(seed, index):
    """(model text, mutated attributes): a valid base model, then hostile values."""
    rng = _rng(seed, "config", index)
    method = str(rng.choice(["twist", "dualquat"]))
    base = two_body_xml(int(rng.integers(1, 3)), method=method) if rng.random() < 0.8 else chain_xml(3, method=method)
    spec = mujoco.MjSpec.from_string(base)
    keys = list(attribute_names()) + ["no_such_key"]
    changes = {}
    for plugin in spec.plugins:
        config = dict(plugin.config)
        picked = [str(k) for k in rng.choice(keys, size=int(rng.integers(1, 4)), replace=False)]
        for key in picked:
            config[key] = changes.setdefault(f"{plugin.name}.{key}", hostile_value(rng, key, method))
        if "stop_damping" in picked and not {"stop_lower", "stop_upper"} & set(picked) and rng.random() < 0.7:
            for key, sign in (("stop_lower", -1), ("stop_upper", 1)):  # tight limits: the damped stops engage
                tight = " ".join(f"{sign * v:g}" for v in [1e-4] * 3 + [1e-5] * 3)
                config[key] = changes[f"{plugin.name}.{key}"] = tight
        plugin.config = config
        if rng.random() < 0.5:
            break
    return spec, changes


def state_case(seed, index):
    """(model, variant models for rollout, state edits, operations)."""
    rng = _rng(seed, "state", index)
    method = str(rng.choice(["twist", "dualquat"]))
    which = rng.integers(4)
    if which == 0:
        n = int(rng.integers(1, 4))
        # 12 elements: past the 64-byte padding of a data's plugin_data words (8 per 64 bytes)
        xml, variants = two_body_xml(n, method=method), [two_body_xml(k, method=method) for k in (1, 12)]
    elif which == 1:
        xml = two_body_xml(1, method="twist").replace("</instance>", _valid_terms(rng, "twist") + "</instance>")
        variants = [two_body_xml(2)]
    elif which == 2:
        xml, variants = chain_xml(4, method=method), [chain_xml(4, method="dualquat" if method == "twist" else "twist")]
    else:
        xml, variants = two_body_xml(2, method=method, mocap=True), [two_body_xml(12, method=method, mocap=True)]
    specials = [np.nan, np.inf, -np.inf, 1e300, -1e300, 1e-300, 0.0, 1e6, -1e6, 1e154]
    edits = []
    for field in ("qpos", "qvel", "mocap_pos", "mocap_quat", "qacc"):
        if rng.random() < 0.5:
            count = int(rng.integers(1, 4))
            edits.append((field, [(int(rng.integers(0, 10**6)), float(rng.choice(specials))) for _ in range(count)]))
    if rng.random() < 0.3:
        edits.append(("zero_quaternion", int(rng.integers(0, 10**6))))
    ops = [str(o) for o in rng.choice(["forward", "step", "inverse", "rollout", "reset", "copy"],
                                      size=int(rng.integers(1, 5)))]  # fmt: skip
    return xml, variants, edits, ops, int(rng.integers(1, 3))


def attribute_names():
    import ctypes

    import mjflex_plugin

    lib = mjflex_plugin.library()
    lib.mjfx_attribute.restype = ctypes.c_char_p
    names, i = [], 0
    while (name := lib.mjfx_attribute(i)) is not None:
        names.append(name.decode())
        i += 1
    return names


# ------------------------------------------------------------------ running a case (in the child)


def _finite(*arrays):
    return all(np.all(np.isfinite(a)) for a in arrays)


def run_config(seed, index):
    spec, _ = config_case(seed, index)
    try:
        model = spec.compile()
        data = mujoco.MjData(model)
    except ValueError as exc:
        return "compile error", str(exc).splitlines()[-1][:300]
    finite = True
    mujoco.mj_forward(model, data)
    finite &= _finite(data.qfrc_passive)
    data.qpos[:] += 1e-3 * np.random.default_rng(index).normal(size=model.nq)
    data.qvel[:] = 0.1
    mujoco.mj_forward(model, data)
    finite &= _finite(data.qfrc_passive)
    mujoco.mj_step(model, data, 5)  # for crashes only: a stiff element may diverge here, which MuJoCo reports
    return ("accepted finite" if finite else "NaN"), ""


def _apply_edits(model, data, edits):
    for field, values in edits:
        if field == "zero_quaternion":
            free = [j for j in range(model.njnt) if model.jnt_type[j] in (0, 1)]  # free, ball
            if free:
                j = free[values % len(free)]
                adr = model.jnt_qposadr[j] + (3 if model.jnt_type[j] == 0 else 0)
                data.qpos[adr : adr + 4] = 0.0
            continue
        array = getattr(data, field).reshape(-1)
        for position, value in values:
            if array.size:
                array[position % array.size] = value


def run_state(seed, index):
    xml, variants, edits, ops, nthread = state_case(seed, index)
    try:  # valid models: a refusal is a defect (the fuzz run lists it)
        model = mujoco.MjModel.from_xml_string(xml)
        others = [mujoco.MjModel.from_xml_string(v) for v in variants]
        data = mujoco.MjData(model)
    except ValueError as exc:
        return "compile error", str(exc).splitlines()[-1][:300]
    data.qvel[:] = 0.2
    _apply_edits(model, data, edits)
    finite = True
    for op in ops:
        if op == "forward":
            mujoco.mj_forward(model, data)
        elif op == "step":
            mujoco.mj_step(model, data, 3)
        elif op == "inverse":
            mujoco.mj_inverse(model, data)
        elif op == "reset":
            mujoco.mj_resetData(model, data)
            _apply_edits(model, data, edits)
        elif op == "copy":
            data = mujoco.MjData(model) if index % 2 else __import__("copy").copy(data)
        elif op == "rollout":
            kind = mujoco.mjtState.mjSTATE_FULLPHYSICS
            state = np.empty(mujoco.mj_stateSize(model, kind))
            mujoco.mj_getState(model, data, state, kind)
            models = [model, *others] if all(o.nv == model.nv for o in others) else [model]
            datas = [mujoco.MjData(model) for _ in range(nthread)]
            out, _ = rollout.rollout(models, datas, np.tile(state, (len(models), 1)), nstep=4)
            finite &= _finite(out)
            continue
        finite &= _finite(data.qfrc_passive)
    finite &= _finite(data.qpos, data.qvel)
    return ("accepted finite" if finite else "NaN"), ""


def run_case(kind, seed, index):
    try:
        return (run_config if kind == "config" else run_state)(seed, index)
    except Exception as exc:  # MuJoCo's errors (FatalError, ValueError of a step, ...): not a crash
        return "MuJoCo error", f"{type(exc).__name__}: {str(exc).splitlines()[0][:300] if str(exc) else ''}"


# ------------------------------------------------------------------ the parent


def in_child(kind, seed, index, timeout):
    """Run one case in a forked child; returns (class, detail)."""
    read, write = os.pipe()
    err = tempfile.TemporaryFile()
    pid = os.fork()
    if pid == 0:  # the child
        os.close(read)
        os.dup2(err.fileno(), 2)
        os.dup2(err.fileno(), 1)
        try:
            result = run_case(kind, seed, index)
        except BaseException:
            result = ("crash", traceback.format_exc()[-300:])
        os.write(write, json.dumps(result).encode())
        os.close(write)
        sys.stdout.flush()
        os._exit(0)
    os.close(write)
    deadline, status = time.monotonic() + timeout, None
    while time.monotonic() < deadline:
        done, status = os.waitpid(pid, os.WNOHANG)
        if done:
            break
        time.sleep(0.002)
    else:
        os.kill(pid, signal.SIGKILL)
        os.waitpid(pid, 0)
        os.close(read)
        return "hang", f"no result within {timeout} s"
    payload = b""
    while chunk := os.read(read, 65536):
        payload += chunk
    os.close(read)
    err.seek(0)
    output = err.read().decode(errors="replace")
    reports = [line for line in output.splitlines() if any(r in line for r in SANITIZER_REPORTS)]
    if reports:
        return "crash", reports[0][:300]
    if os.WIFSIGNALED(status):
        return "crash", f"signal {signal.Signals(os.WTERMSIG(status)).name}"
    if os.WEXITSTATUS(status) != 0 or not payload:
        return "crash", f"exit status {os.WEXITSTATUS(status)}: {output[-300:]}"
    return tuple(json.loads(payload))


def fuzz(counts, seed, timeout, progress=True):
    result = {"seed": seed, "timeout_s": timeout, "counts": {}, "failures": [], "nan_configs": [], "examples": {}}
    start = time.perf_counter()
    for kind, n in counts.items():
        tally = dict.fromkeys(CLASSES, 0)
        for index in range(n):
            cls, detail = in_child(kind, seed, index, timeout)
            tally[cls] += 1
            examples = result["examples"].setdefault(f"{kind}: {cls}", [])
            if len(examples) < 3 and detail:
                examples.append(f"{kind}:{index}: {detail}")
            if cls in ("crash", "hang") or (kind == "state" and cls == "compile error"):
                result["failures"].append({"case": f"{kind}:{index}", "class": cls, "detail": detail})
            if kind == "config" and cls == "NaN":
                result["nan_configs"].append(f"{kind}:{index}")
            if progress and (index + 1) % 500 == 0:
                print(f"  {kind}: {index + 1}/{n} ({time.perf_counter() - start:.0f} s)", file=sys.stderr)
        result["counts"][kind] = tally
    result["seconds"] = time.perf_counter() - start
    return result


def print_table(result):
    print(f"fuzzed with seed {result['seed']} in {result['seconds']:.1f} s (each case in a forked child)")
    print(f"{'kind':8} " + " ".join(f"{c:>16}" for c in CLASSES))
    for kind, tally in result["counts"].items():
        print(f"{kind:8} " + " ".join(f"{tally[c]:16d}" for c in CLASSES))
    for name, examples in result["examples"].items():
        for example in examples:
            print(f"  e.g. {name}: {example}")
    for failure in result["failures"]:
        print(f"{failure['class']}: {failure['case']}: {failure['detail']}")
    if result["nan_configs"]:
        print(f"accepted configurations with non-finite forces: {', '.join(result['nan_configs'])}")


def replay(case, seed):
    kind, index = case.split(":")
    if kind == "config":
        _, changes = config_case(seed, int(index))
        print("mutated:", json.dumps(changes, indent=1)[:4000])
    else:
        xml, variants, edits, ops, nthread = state_case(seed, int(index))
        print(xml, "\nvariants for rollout:", len(variants), "\nedits:", edits)
        print("operations:", ops, "threads:", nthread)
    print("result:", run_case(kind, seed, int(index)))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--configs", type=int, default=8000, help="mutated configurations")
    parser.add_argument("--states", type=int, default=3000, help="extreme states")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--timeout", type=float, default=20.0, help="seconds before a case counts as a hang")
    parser.add_argument("--json", help="write the counts and failures here")
    parser.add_argument("--replay", help="run one case (config:N or state:N) in this process and print it")
    args = parser.parse_args(argv)
    if args.replay:
        replay(args.replay, args.seed)
        return 0
    result = fuzz({"config": args.configs, "state": args.states}, args.seed, args.timeout)
    print_table(result)
    if args.json:
        os.makedirs(os.path.dirname(os.path.abspath(args.json)), exist_ok=True)
        with open(args.json, "w") as f:
            json.dump(result, f, indent=1)
    return 1 if result["failures"] or result["nan_configs"] else 0


if __name__ == "__main__":
    sys.exit(main())

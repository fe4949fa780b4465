"""Benchmark of the core: a batch of 48 element wrenches versus a Python loop and a bare mj_step.

Usage::

    python scripts/bench_core.py [--json out/bench_core.json] [--n 48] [--runs 5] [--repeat 21]

Times, interleaved, in each of ``--runs`` fresh processes (same-repeat ratios to the baseline:
median, quartiles, min-max over the pooled repeats; scripts/_bench.py):

* ``mjflex.wrench_on_b`` on a batch of ``n`` elements (elastic + viscous), both methods,
  with and without argument validation, and the compiled batch kernel alone;
* the same math written as a plain per-element numpy loop (explicit 6x6 Gamma / Lambda
  matrices, scipy rotation vectors), which also cross-checks the results;
* one ``mujoco.mj_step`` of a model of 35 free bodies without elements (the baseline).

Goal (issue "screw-theory core"): the 48-element batch costs at most 2x the bare mj_step.
"""

import argparse
import math

import mujoco
import numpy as np
from _bench import add_timing_options, compare, measured_in_processes, print_table, write_json
from scipy.spatial.transform import Rotation

import mjflex
from mjflex.core import _kernels


def free_bodies_model(n_bodies=35):
    spec = mujoco.MjSpec()
    for i in range(n_bodies):
        body = spec.worldbody.add_body(name=f"body{i}", pos=[0.03 * i, 0, 0])
        body.add_freejoint()
        body.add_geom(
            type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.012, 0.0025, 0.00475], density=2700, contype=0, conaffinity=0
        )
    return spec.compile()


def hat(v):
    return np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])


def reference_wrench(R_WA, p_WA, R_WB, p_WB, K, B, w_WA, v_WA, w_WB, v_WB, method):
    """Per-element numpy: the paper's matrices built explicitly (eqs 44-50, 58-66, 85-103)."""
    R = R_WA.T @ R_WB
    p = R_WA.T @ (p_WB - p_WA)
    Vb = np.r_[R_WB.T @ w_WB, R_WB.T @ v_WB]
    Va = np.r_[R_WA.T @ w_WA, R_WA.T @ v_WA]
    if method == "twist":
        tau = Rotation.from_matrix(R).as_rotvec()
        a = np.linalg.norm(tau)
        c = (1 - a / 2 / np.tan(a / 2)) / a**2 if a > 1e-3 else 1 / 12 + a**2 / 720
        g = _kernels.jl_inv_coefs(a, math.cos(a / 2), math.sin(a / 2))[1]
        P = np.eye(3) - 0.5 * hat(tau) + c * hat(tau) @ hat(tau)
        t = P @ p
        D = -0.5 * hat(t) + c * (hat(tau) @ hat(t) + hat(t) @ hat(tau)) + g * (tau @ t) * hat(tau) @ hat(tau)
        Gamma = np.block([[P, D], [np.zeros((3, 3)), P]])
        Jl_inv = np.block([[P, np.zeros((3, 3))], [D, P]])
        rate = Gamma.T @ Vb - Jl_inv @ Va
        Wb = Gamma @ (K @ np.r_[tau, t] + B @ rate)
    else:
        w, x, y, z = Rotation.from_matrix(R).as_quat(scalar_first=True, canonical=True)
        xi = np.array([x, y, z])
        s_d, x_d = -0.5 * xi @ p, 0.5 * (w * p - np.cross(xi, p))
        pr, du = w * np.eye(3) - hat(xi), s_d * np.eye(3) - hat(x_d)
        Lam = np.block([[pr, du], [np.zeros((3, 3)), pr]])
        Lam_ba = np.block([[pr.T, du.T], [np.zeros((3, 3)), pr.T]])
        rate = 0.5 * Lam.T @ Vb - 0.5 * Lam_ba.T @ Va
        Wb = 2 * Lam @ (K @ np.r_[xi, x_d] + B @ rate)
    return -np.r_[R_WB @ Wb[:3], R_WB @ Wb[3:]]


def random_batch(n, seed=0):
    rng = np.random.default_rng(seed)
    R_WA = Rotation.random(n, random_state=rng).as_matrix()
    R_WB = R_WA @ Rotation.from_rotvec(0.3 * rng.normal(size=(n, 3))).as_matrix()
    p_WA = rng.normal(size=(n, 3))
    p_WB = p_WA + 1e-3 * rng.normal(size=(n, 3))
    K = np.empty((n, 6, 6))
    for i in range(n):
        Q, _ = np.linalg.qr(rng.normal(size=(6, 6)))
        K[i] = Q @ np.diag(np.geomspace(1, 1e3, 6)) @ Q.T
    B = 1e-3 * K
    vel = {k: rng.normal(size=(n, 3)) for k in ("w_WA", "v_WA", "w_WB", "v_WB")}
    return (R_WA, p_WA, R_WB, p_WB, 0.5 * (K + K.transpose(0, 2, 1)), 0.5 * (B + B.transpose(0, 2, 1)), vel)


def method_cases(method, n, R_WA, p_WA, R_WB, p_WB, K, B, vel):
    """Timed cases for one method, and a check of the batch against the per-element loop."""
    names = ("w_WA", "v_WA", "w_WB", "v_WB")
    out, power = np.empty((n, 6)), np.empty(n)
    kargs = (0 if method == "twist" else 1, R_WA, p_WA, R_WB, p_WB, K, B, True, *(vel[k] for k in names), out, power)

    def batch(check):
        return lambda: mjflex.wrench_on_b(R_WA, p_WA, R_WB, p_WB, K, method=method, B=B, check=check, **vel)

    def loop():
        return [
            reference_wrench(R_WA[i], p_WA[i], R_WB[i], p_WB[i], K[i], B[i], *(vel[k][i] for k in names), method)
            for i in range(n)
        ]

    cases = {
        f"{method}: wrench_on_b x{n}, check=False": batch(False),
        f"{method}: wrench_on_b x{n}, check=True": batch(True),
        f"{method}: compiled batch kernel alone x{n}": lambda: _kernels.spatial_wrench_batch(*kargs),
    }
    ref, got = np.array(loop()), batch(True)()
    err = float(np.max(np.linalg.norm(got - ref, axis=-1) / np.linalg.norm(ref, axis=-1)))
    return cases, loop, err


def measure(args):
    """Time the cases interleaved in this process; check the batch against the per-element loop."""
    R_WA, p_WA, R_WB, p_WB, K, B, vel = random_batch(args.n)
    model = free_bodies_model(35)
    data = mujoco.MjData(model)
    base = "mj_step, 35 free bodies, no elements (baseline)"
    cases = {base: lambda: mujoco.mj_step(model, data)}
    slow = {base: cases[base]}
    max_err = {}
    for method in ("twist", "dualquat"):
        fast, loop, max_err[method] = method_cases(method, args.n, R_WA, p_WA, R_WB, p_WB, K, B, vel)
        cases.update(fast)
        slow[f"{method}: per-element numpy loop x{args.n}"] = loop
    rows = compare(cases, base, repeat=args.repeat)
    rows.update({k: v for k, v in compare(slow, base, repeat=5, target=0.05).items() if k != base})
    return {"n_elements": args.n, "rows": rows, "max_rel_diff_vs_loop": max_err}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=48, help="elements in the batch")
    add_timing_options(ap, "out/bench_core.json", runs=5)
    args = ap.parse_args()
    payload = measured_in_processes(args) or measure(args)
    rows, n = payload["rows"], payload["n_elements"]
    print_table(rows, f"Core benchmark: {n} elements (elastic + viscous); ratios to mj_step in the same repeat")
    print(f"\nmax relative difference batch vs per-element loop: {payload['max_rel_diff_vs_loop']}")
    payload["goal_met"] = {m: rows[f"{m}: wrench_on_b x{n}, check=False"]["ratio_median"] <= 2.0
                           for m in ("twist", "dualquat")}  # fmt: skip
    print(f"goal (median ratio of wrench_on_b, check=False, to bare mj_step <= 2): {payload['goal_met']}")
    write_json(args.json, payload)


if __name__ == "__main__":
    main()

"""Cost of polynomial potentials: element wrenches with terms of order 4 and 6 versus the quadratic one.

Usage::

    python scripts/bench_polynomial.py [--json out/bench_polynomial.json] [--n 48] [--runs 5] [--repeat 21]

Times, interleaved in each of ``--runs`` fresh processes (same-repeat ratios to the quadratic batch
kernel: median, quartiles, min-max over the pooled repeats; scripts/_bench.py), the compiled batch
kernels for ``n`` elements (elastic + viscous) of both methods: quadratic (``K`` only), and with the
general polynomial of order 4 and 6, in the plane (``variables=(2, 3, 4)``, what
``scripts/fit_flexure.py`` fits) and in all six coordinates. The terms cost ``O(M)`` per element for
``M`` terms (printed), against a fixed cost for the quadratic part.
"""

import argparse

import numpy as np
from _bench import add_timing_options, compare, measured_in_processes, print_table, write_json
from bench_core import random_batch

import mjflex
from mjflex.core import _kernels, _poly_kernels


def measure(args):
    """Time the quadratic and polynomial batch kernels interleaved in this process."""
    R_WA, p_WA, R_WB, p_WB, K, B, vel = random_batch(args.n)
    v = [vel[k] for k in ("w_WA", "v_WA", "w_WB", "v_WB")]
    out, power = np.empty((args.n, 6)), np.empty(args.n)
    rng = np.random.default_rng(1)
    cases, sizes = {}, {}
    for method, code in (("twist", 0), ("dualquat", 1)):
        base = f"{method}: quadratic"
        cases[base] = lambda code=code: _kernels.spatial_wrench_batch(code, R_WA, p_WA, R_WB, p_WB, K, B, True, *v,
                                                                      out, power)  # fmt: skip
        for order in (4, 6):
            for label, variables in (("plane", (2, 3, 4)), ("all 6", None)):
                e = mjflex.polynomial_basis(method, order, variables)
                c = 1e-3 * rng.normal(size=len(e))
                pw, grad = _poly_kernels.work_arrays(e)
                name = f"{method}: order {order}, {label} ({len(e)} terms)"
                sizes[name] = len(e)
                cases[name] = lambda code=code, e=e, c=c, pw=pw, grad=grad: _poly_kernels.spatial_wrench_terms_batch(
                    code, R_WA, p_WA, R_WB, p_WB, K, B, True, *v, e, c, pw, grad, out, power
                )
    rows = compare(cases, "twist: quadratic", repeat=args.repeat)
    return {"n_elements": args.n, "rows": rows, "terms": sizes}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=48, help="elements in the batch")
    add_timing_options(ap, "out/bench_polynomial.json", runs=5)
    args = ap.parse_args()
    payload = measured_in_processes(args) or measure(args)
    rows, n = payload["rows"], payload["n_elements"]
    print_table(rows, f"Polynomial terms: compiled batch kernel, {n} elements; ratios to the twist quadratic kernel")
    print("\ncost per term and element (median batch minus the quadratic batch of the same method, / n / terms):")
    per_term = {}
    for name, m in payload["terms"].items():
        base = rows[f"{name.split(':')[0]}: quadratic"]["median_s"]
        per_term[name] = (rows[name]["median_s"] - base) / n / m
        print(f"  {name:<45} {per_term[name] * 1e9:6.1f} ns")
    quad = {k: rows[f"{k}: quadratic"]["median_s"] / n for k in ("twist", "dualquat")}
    print(f"quadratic wrench per element: twist {quad['twist'] * 1e9:.0f} ns, dualquat {quad['dualquat'] * 1e9:.0f} ns")
    payload.update({"seconds_per_term": per_term, "quadratic_seconds_per_element": quad})
    write_json(args.json, payload)


if __name__ == "__main__":
    main()

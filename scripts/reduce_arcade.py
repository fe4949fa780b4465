"""Speed gained and accuracy lost by each fidelity reduction (mjflex.reduce) of the ARCADE guide.

Usage::

    python scripts/reduce_arcade.py [--json out/reduce_arcade.json] [--repeat 11] [--runs 1]

``--runs N`` repeats everything in N fresh processes and pools the timing repeats (scripts/_bench.py).

For each reduction (frequency band kept, with or without the paper run as the scene, how loops
are closed) prints what was reduced (elements turned into joints, merged, kept; nv; highest
mode), the error of the kept modes against the full model, the largest stable RK4 step, the
cost per step and per simulated second at that step (median of interleaved repeats, ratio to
the full model in the same repeat), and the accuracy on the paper run (105 rad/s spin, 5 m/s
axial kick, 40 ms) and on a 0.01 m/s stroke without spin: stroke, parasitic radial motion and
tilt of the cylinder, axial trajectory error as a fraction of the full model's stroke.
"""

import argparse
import collections

from _arcade_alternatives import ARCADE, DURATION, arcade_cases, costs_of, modes_of, run_guide
from _bench import add_runs_option, measured_in_processes, write_json
from _variants import add_speedups

import mjflex

SETTINGS = (
    ("50 Hz", dict(keep_below_hz=50.0)),
    ("50 Hz, loops by constraints", dict(keep_below_hz=50.0, loops="constraint")),
    ("200 Hz", dict(keep_below_hz=200.0)),
    ("50 Hz, paper run as scene", dict(keep_below_hz=50.0, scene=("paper_run", DURATION))),
    ("2000 Hz", dict(keep_below_hz=2000.0)),
)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=11, help="interleaved repeats per process (default 11)")
    ap.add_argument("--json", default="out/reduce_arcade.json")
    add_runs_option(ap)
    args = ap.parse_args()
    pooled = measured_in_processes(args)
    if pooled is not None:  # speed-ups from the pooled cost ratios
        costs = {name: row["cost"] for name, row in pooled["rows"].items()}
        add_speedups(costs, next(iter(costs)))
        write_json(args.json, pooled)
        return
    variants = []
    for label, kwargs in SETTINGS:
        v = mjflex.reduce(ARCADE, name=f"reduced({label})", **kwargs)
        variants.append(v)
        kinds = collections.Counter("+".join(e["soft"]) or "rigid" for e in v.details["elements"].values())
        print(f"\n{v.name}: nv {v.details['nv_source']} -> {v.details['nv']}, loops {v.details['loops']}, "
              f"modes below the band within {100 * v.details['modes']['max_relative_error']:.2f} %, highest mode "
              f"{v.details['modes']['highest_hz']:.0f} Hz (full {v.details['modes']['highest_full_hz']:.0f} Hz); "
              f"elements: {dict(kinds)}")  # fmt: skip
    cases, small = arcade_cases(variants)
    results = run_guide(cases, small)
    costs = costs_of(cases, args.repeat)
    modes = {c.name: modes_of(c, c.constraints) for c in cases}
    full = results[cases[0].name]["paper_run"]
    print(f"\n{'model':<40} {'nv':>4} {'stable h':>9} {'x cost':>7} {'speed-up':>9} | {'paper run: stroke':>17} "
          f"{'radial':>9} {'axial err':>9} | {'0.01 m/s err':>12}")  # fmt: skip
    rows = {}
    for c in cases:
        p, s, k = results[c.name]["paper_run"], results[c.name]["small_stroke"], costs[c.name]
        stroke = f"{p['stroke_mm']:>15.3f}mm {p['radial_um']:>7.3g}um" if "diverged" not in p else f"{'diverged':>27}"
        print(f"{c.name:<40} {c.model.nv:>4} {k['stable_step_s']:>9.2e} {k['ratio_median']:>7.2f} "
              f"{k['speedup_at_stable']:>9.2f} | {stroke} {100 * p.get('axial_error', float('nan')):>8.1f}% | "
              f"{100 * s.get('axial_error', float('nan')):>11.2f}%")  # fmt: skip
        rows[c.name] = {"nv": int(c.model.nv), "guide": results[c.name], "cost": k, "modes_hz": modes[c.name]}
    print(f"\nfull model: stroke {full['stroke_mm']:.3f} mm, radial {full['radial_um']:.3g} um on the paper run; "
          "speed-up = wall time per simulated second of the full model at its stable step over the variant's at "
          "its own")  # fmt: skip
    write_json(args.json, {"rows": rows, "reports": {v.name: v.report for v in variants},
                           "details": {v.name: v.details for v in variants}, "duration": DURATION})  # fmt: skip


if __name__ == "__main__":
    main()

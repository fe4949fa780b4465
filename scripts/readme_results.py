"""Write the measured figures of README.md from the recorded JSON in docs/results/.

Usage::

    python scripts/readme_results.py            # rewrite README.md's generated blocks
    python scripts/readme_results.py --check    # exit 1 if README.md is not what the JSON gives

README.md holds blocks ``<!-- results:NAME -->`` ... ``<!-- /results -->`` whose text
``BLOCKS[NAME]`` renders from the files of ``docs/results/`` (a test checks that README.md is
what this script makes of them, so the two cannot drift apart). The JSON files are written by
the measurement scripts themselves: run one with ``MJFLEX_RECORD=1`` in the environment
(``scripts/_bench.py``'s ``write_json`` then also writes ``docs/results/<script>.json``, with
the command line and the date), then run this script.

Adding a measurement: make the script write its JSON with ``_bench.write_json``, write a row
function below (its JSON -> ``(what, result)``) and list it in ``MEASURED`` (or a block of
its own in ``BLOCKS``), record, regenerate, commit the JSON and README.md.
"""

import argparse
import glob
import json
import os
import re
import sys

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
RESULTS = os.path.join(ROOT, "docs", "results")
README = os.path.join(ROOT, "README.md")
BLOCK = re.compile(r"(<!-- results:(?P<name>[\w-]+) -->\n)(?P<body>.*?)(<!-- /results -->)", re.S)


def _sci(x):
    """``3e-5``, ``3.2e-5``: a short scientific notation (two significant digits at most)."""
    mantissa, exponent = f"{x:.1e}".split("e")
    return f"{mantissa.rstrip('0').rstrip('.')}e{int(exponent)}"


def _spread(row, key="ratio"):
    """``median× (min–max)`` of a row of scripts/_bench.py's ``compare``."""
    return f"{row[key + '_median']:.2f}× ({row[key + '_min']:.2f}–{row[key + '_max']:.2f})"


def row_bench_core(r):
    rows = r["rows"]
    n = r["n_elements"]

    def cell(method):
        return (
            f"{_spread(rows[f'{method}: wrench_on_b x{n}, check=False'])}; compiled kernel alone "
            f"{_spread(rows[f'{method}: compiled batch kernel alone x{n}'])}"
        )

    what = f"{n} wrenches (`wrench_on_b`, elastic + viscous) vs a bare `mj_step` of 35 bodies"
    return what, f"twist {cell('twist')}; dual quaternion {cell('dualquat')}"


def row_bench_step(r):
    rows = r["rows"]
    weld = rows["weld: 48 weld equality constraints"]["median_s"]
    cells = []
    for name, label in (("flexures, twist method", "twist"), ("flexures, dual-quaternion method", "dual quaternion")):
        cells.append(f"{label} {_spread(rows[name])} the bare step, {rows[name]['median_s'] / weld:.2f}× the weld step")
    bare = rows["bare: same bodies, no elements (baseline)"]["median_s"]
    what = f"`mj_step` with 48 flexures vs no elements vs 48 welds ({r['model']}, Euler)"
    return what, "; ".join(cells) + f" (bare step {bare * 1e6:.1f} µs)"


def row_compare_native(r):
    res, cost = r["results"], r["step_cost"]
    twist = res["twist"]
    parts = [
        f"step cost vs one hinge joint: mjflex {_spread(cost['twist'])}, 6-joint bushing {_spread(cost['bushing'])}, "
        f"weld {_spread(cost['weld'])}",
        f"swing {twist['frequency_hz']:.1f} Hz, {twist['peak_rotation_rad']:.2f} rad; largest rotation off mjflex's: "
        f"bushing {res['bushing']['max_rotation_deviation_rad']:.2g} rad, hinge joint "
        f"{res['hinge']['max_rotation_deviation_rad']:.2g} rad (no parasitic translation: mjflex "
        f"{twist['parasitic_translation_um']:.0f} µm), weld swings {res['weld']['peak_rotation_rad']:.2g} rad",
    ]
    return "a notch hinge: mjflex vs native joint springs (6-joint bushing, hinge) and a weld", "; ".join(parts)


def row_hinge_fe_check(r):
    conv2, conv3, beam = r["convergence_2d"], r["convergence_3d"], r["beam_over_fe"]

    def worst(kind):
        return max(abs(v) for name, c in conv2.items() if name.startswith(kind) for v in c["level 1"])

    mesh3 = {name.split()[0]: max(abs(v) for v in c["tables' mesh"]) for name, c in conv3.items()}
    rot = {
        float(k.split("=")[1]): v[2] for k, v in beam.items() if k.startswith("notch") and float(k.split("=")[1]) <= 0.8
    }
    excess = {k: 100 * (v - 1) for k, v in rot.items()}
    return (
        "flexure stiffness: 3-D finite elements with blocks (mesh error of the tables' meshes), beam model vs FE",
        f"tables' meshes within {worst('notch'):.2f} % (notch) and {worst('leaf'):.2f} % (leaf) of the Richardson "
        f"limit in plane stress, {mesh3['notch']:.2f} % / {mesh3['leaf']:.2f} % in 3-D (the paper's flexures); "
        f"beam model {min(excess.values()):.0f}–{max(excess.values()):.0f} % too stiff in the compliant rotation for "
        f"t/R {min(rot):g}–{max(rot):g} ({excess[0.125]:.0f} % at the paper's 0.125)",
    )


def row_modes(r):
    a = r["arcade.xml"]
    return (
        "ARCADE normal modes",
        f"{a['n_rigid']} rigid modes, then the cylinder's axial translation at {a['guide_frequency_hz']:.1f} Hz, next "
        f"mode {a['separation']:.2f}× higher; highest mode {a['highest_frequency_hz'] / 1e3:.1f} kHz",
    )


def stable_steps(r):
    """Largest stable step [s] per integrator of scripts/timestep_study.py's runs."""
    best = {}
    for key, run in r["runs"].items():
        integrator, dt = key.split(":")
        if run["stable"]:
            best[integrator] = max(best.get(integrator, 0.0), float(dt))
    return best


def row_timestep_study(r):
    best = stable_steps(r)
    steps = ", ".join(f"{name} ≤ {_sci(dt)} s" for name, dt in best.items())
    w = r["omega_max"]
    return (
        f"stable time step of the ARCADE run ({r['duration'] * 1e3:g} ms, no damping)",
        f"{steps} (modal limits 2.8/ω_max = {_sci(2.8 / w)} s, 2/ω_max = {_sci(2 / w)} s)",
    )


#: Rows of the "measured" table, in order: (JSON name in docs/results, row function).
MEASURED = [
    ("bench_core", row_bench_core),
    ("bench_step", row_bench_step),
    ("compare_native", row_compare_native),
    ("hinge_fe_check", row_hinge_fe_check),
    ("modes", row_modes),
    ("timestep_study", row_timestep_study),
]


def _command(r):
    return f"`{r['command']}` ({r['date'][:10]})"


def block_measured(results):
    lines = ["| what | result | command (recorded) |", "|---|---|---|"]
    for name, row in MEASURED:
        what, result = row(results[name])
        lines.append(f"| {what} | {result} | {_command(results[name])} |")
    return "\n".join(lines) + "\n"


def block_integrators(results):
    modes, study = results["modes"]["arcade.xml"], results["timestep_study"]
    best = stable_steps(study)
    return (
        f"For the ARCADE model `{results['modes']['command']}` finds ω_max/2π = "
        f"{modes['highest_frequency_hz'] / 1e3:.1f} kHz, and `{study['command']}` finds RK4 stable up to "
        f"{_sci(best['RK4'])} s and Euler up to {_sci(best['Euler'])} s (runs of {study['duration'] * 1e3:g} ms, "
        f"recorded {study['date'][:10]}); the model uses RK4 with 1e-5 s.\n"
    )


#: Block name -> (JSON files it reads, renderer).
BLOCKS = {
    "measured": ([name for name, _ in MEASURED], block_measured),
    "integrators": (["modes", "timestep_study"], block_integrators),
}


def load_results(folder=RESULTS):
    """Every recorded JSON of ``folder``, by file name without ``.json``."""
    results = {}
    for path in sorted(glob.glob(os.path.join(folder, "*.json"))):
        with open(path) as f:
            results[os.path.splitext(os.path.basename(path))[0]] = json.load(f)
    return results


def generate(readme, results):
    """``readme`` with every generated block rewritten from ``results``; KeyError names a missing block or JSON."""

    def render(match):
        name = match["name"]
        if name not in BLOCKS:
            raise KeyError(f"README block 'results:{name}' has no renderer in scripts/readme_results.py BLOCKS")
        needs, renderer = BLOCKS[name]
        missing = [n for n in needs if n not in results]
        if missing:
            raise KeyError(f"block 'results:{name}' needs docs/results/{missing[0]}.json: record it (MJFLEX_RECORD=1)")
        return match.group(1) + renderer(results) + match.group(4)

    return BLOCK.sub(render, readme)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check", action="store_true", help="only check; exit 1 if README.md would change")
    args = ap.parse_args()
    with open(README) as f:
        readme = f.read()
    new = generate(readme, load_results())
    if args.check:
        if new != readme:
            sys.exit("README.md differs from what docs/results gives: run python scripts/readme_results.py")
        print("README.md is what docs/results gives")
        return
    with open(README, "w") as f:
        f.write(new)
    print(f"wrote {os.path.normpath(README)} ({len(BLOCK.findall(new))} generated blocks)")


if __name__ == "__main__":
    main()

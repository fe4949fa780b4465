"""Write the measured figures of the README and the documentation pages from the recorded JSON.

Usage::

    python scripts/results_blocks.py            # rewrite every page's generated blocks
    python scripts/results_blocks.py --check    # exit 1 if a page is not what the JSON gives

README.md and the Markdown pages under ``docs/`` hold blocks ``<!-- results:NAME -->`` ...
``<!-- /results -->`` whose text ``BLOCKS[NAME]`` renders from recorded JSON. Each block is
placed exactly once, on the page where its subject is explained (:func:`placements` finds
them; ``tests/test_readme.py`` checks that every page is what this script makes of it, and
that every renderer has its one place, so the pages and the JSON cannot drift apart). The
sources:

* ``docs/results/*.json``, written by the measurement scripts themselves: run one with
  ``MJFLEX_RECORD=1`` in the environment (``scripts/_bench.py``'s ``write_json`` then also
  writes ``docs/results/<json name>``, with the command line, the date and the wall time);
* ``SOURCES``: the reports of the command line (``python -m mjflex study ... --out docs/study``,
  ``python -m mjflex sweep`` copied to ``docs/``), which record their command line too, and the
  finite-element tables shipped as package data (``scripts/build_stiffness_tables.py``).

Then run this script. Adding a measurement: make the script write its JSON with
``_bench.write_json``, write a renderer below (JSON -> text), list it in ``BLOCKS`` (and a row
in ``MEASURED``), put an empty block ``<!-- results:NAME -->`` / ``<!-- /results -->`` on the
page it belongs to, record, regenerate, commit the JSON and the page. A measured number in a
sentence is an inline block (renderers in ``scripts/_readme_inline.py``): tests/test_docs.py
fails on a number with a unit in a page's prose outside the blocks, unless its allow-list of
constants (parameters, defaults, definitions, test bounds) names it.
"""

import argparse
import glob
import json
import os
import re
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))  # the renderers' modules, also when imported by path
from _readme_format import (
    command_note,
    duration,
    machines_note,
    pct,
    same_repeat,
    sci,
    sig,
    spread,
    table,
    timed_on,
    times,
)
from _readme_inline import (
    block_operating_pose,
    fit_reach,
    inline_encoder_quality,
    inline_fit_reach,
    inline_long_run_divergence,
    inline_method_difference,
    inline_operating_pose_blind,
    inline_operating_pose_muscles,
    inline_operating_pose_servo,
    inline_operating_pose_solref,
    inline_operating_pose_spine,
    inline_snapshot_cost,
    inline_stop_cost,
    inline_stop_instructions,
    row_count_step_instructions,
    row_encoder_quality,
    row_operating_pose,
)
from _readme_reduce import block_reduce_robots
from _readme_speed import (
    LONG_RUNS,
    block_long_run,
    block_long_run_verdict,
    block_native,
    block_native_verdict,
    block_reduce_arcade,
    block_study_arcade,
    block_sweep_arcade,
    block_sweep_bench,
    row_bench_sweep,
    row_compare_alternatives,
    row_long_run,
    row_reduce_arcade,
    row_study_arcade,
)
from _readme_stops import block_stop_bounces, block_stop_preload, inline_stop_damping_instructions
from _readme_warp import WARP_BENCH, block_warp_bench, block_warp_float32

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
RESULTS = os.path.join(ROOT, "docs", "results")
README = os.path.join(ROOT, "README.md")
DOCS = os.path.join(ROOT, "docs")
#: Folders under docs/ written by a build or by a command (no hand-written pages with blocks).
GENERATED = ("_build", "_generated", "auto_tutorials", os.path.join("reference", "api"))
#: A generated block: on lines of its own, or inline in a sentence (no line break after the opening marker; its
#: renderer then returns text without one), for a number in prose.
BLOCK = re.compile(r"(<!-- results:(?P<name>[\w-]+) -->\n?)(?P<body>.*?)(<!-- /results -->)", re.S)
#: Recorded JSON outside docs/results: name -> path relative to the repository root.
SOURCES = {
    "study_arcade": "docs/study/study_arcade.json",
    "sweep_arcade": "docs/sweep_arcade.json",
    "table_notch": "mjflex/geometry/data/notch_hinge.json",
    "table_leaf": "mjflex/geometry/data/leaf_spring.json",
}
ENTRIES = ("rot_x", "rot_y", "rot_z", "x", "y", "z")


# ------------------------------------------------------------------------ per-step and core cost


def row_bench_core(r):
    rows = r["rows"]
    n = r["n_elements"]

    def cell(method):
        return (
            f"{spread(rows[f'{method}: wrench_on_b x{n}, check=False'])}; compiled kernel alone "
            f"{spread(rows[f'{method}: compiled batch kernel alone x{n}'])}"
        )

    what = f"{n} wrenches (`wrench_on_b`, elastic + viscous) vs a bare `mj_step` of 35 bodies"
    return what, f"twist {cell('twist')}; dual quaternion {cell('dualquat')}"


STEP_CASES = (  # bench_step's rows: (row name, label)
    ("plugin, twist method", "plugin, twist"),
    ("plugin, dual-quaternion method", "plugin, dual quaternion"),
    ("flexures, twist method", "`mjcb_passive`, twist"),
    ("flexures, dual-quaternion method", "`mjcb_passive`, dual quaternion"),
)
STEP_BARE, STEP_WELD = "bare: same bodies, no elements (baseline)", "weld: 48 weld equality constraints"


def _vs_weld(rows, name):
    weld = rows[STEP_WELD]
    vs_weld = same_repeat(rows[name], weld, "weld")  # older JSON: the ratio of the medians, no spread
    return times(vs_weld.get("weld_median", rows[name]["median_s"] / weld["median_s"]), vs_weld, "weld")


def row_bench_step(r):
    rows = r["rows"]
    bare = rows[STEP_BARE]["median_s"]
    if "plugin, twist method" not in rows:  # recorded before the engine plugin: the provider's rows only
        cells = [f"{label} {spread(rows[name])} the bare step, {_vs_weld(rows, name)} the weld step"
                 for name, label in (("flexures, twist method", "twist"),
                                     ("flexures, dual-quaternion method", "dual quaternion"))]  # fmt: skip
        what = f"`mj_step` with 48 flexures vs no elements vs 48 welds ({r['model']}, Euler)"
        return what, "; ".join(cells) + f" (bare step {bare * 1e6:.1f} µs)"
    rk4 = r.get("rows_rk4", {})
    cells = []
    for name, label in STEP_CASES[:2]:
        cell = f"{label.removeprefix('plugin, ')} {spread(rows[name])} (Euler)"
        cells.append(cell + (f", {spread(rk4[name])} (RK4)" if name in rk4 else ""))
    start = r.get("startup", {}).get("plugin")
    started = f"; a fresh process from `import mujoco` to its first step {start['median_s']:.2f} s" if start else ""
    what = f"`mj_step` with 48 plugin elements vs no elements ({r['model']})"
    return what, "; ".join(cells) + f" the bare step ({bare * 1e6:.1f} µs Euler){started}"


def block_step_cost(results):
    """Per-step cost of each form of the elements against the bare step (Euler and RK4), start-up, machine."""
    r = results["bench_step"]
    integrators = [("rows", "Euler"), ("rows_rk4", "RK4")]
    integrators = [(key, label) for key, label in integrators if key in r]
    head = ["elements", *[f"{label}: vs bare" for _, label in integrators], "Euler: vs 48 welds"]
    body = [["none (bare step)", *[f"{r[key][STEP_BARE]['median_s'] * 1e6:.1f} µs" for key, _ in integrators], ""]]
    for name, label in STEP_CASES:
        body.append([label, *[spread(r[key][name]) for key, _ in integrators], _vs_weld(r["rows"], name)])
    narrow = results.get("bench_step_2lanes")  # the same run with 2 lanes: what a CPU without AVX gets
    if narrow:
        for name, label in STEP_CASES[:2]:
            cells = [spread(narrow[key][name]) if key in narrow else "" for key, _ in integrators]
            body.append([f"{label}, 2 lanes (`--lanes 2`: CPUs without AVX)", *cells, _vs_weld(narrow["rows"], name)])
    lanes = r.get("native_lanes")
    out = (
        f"`{r['command']}` ({r['date'][:10]}; {r['bodies']} free bodies, {r['elements']} elements of ARCADE"
        + (f", the native library evaluating {lanes} elements at a time" if lanes else "")
        + "): the cost of `mj_step`, median of same-repeat ratios (min–max) pooled over fresh processes; the goal is "
        "a plugin step of at most 1.5 times the bare step.\n\n" + table(head, body)
    )
    start = r.get("startup", {})
    if start:
        parts = [f"{kind} {v['median_s']:.2f} s ({v['min_s']:.2f}–{v['max_s']:.2f})" for kind, v in start.items()]
        runs = next(iter(start.values()))["runs"]
        out += (f"\nStart-up, a fresh process from its first import to its first step (median of {runs} processes, "
                f"min–max): {'; '.join(parts)} (plugin: `import mujoco` and the model file only; `mjcb_passive`: "
                "`import mjflex` and `Flexures` too).\n")  # fmt: skip
    note = machines_note(results, ["bench_step", "bench_step_2lanes"])
    return out + ("\n" + note + "\n" if note else "")


def inline_plugin_overhead(results):
    """Inline: what the plugin's own loop over its instances adds to a step, against the ``mjcb_passive`` provider
    (twist elements), as a fraction of the bare step: the median (min–max) of the same-repeat differences."""
    import numpy as np

    r, name = results["bench_step"], "twist method"
    parts = []
    for key, label in (("rows", "ARCADE's bare Euler step"), ("rows_rk4", "its RK4 step")):
        rows = r[key]
        diff = np.array(rows[f"plugin, {name}"]["ratios"]) - np.array(rows[f"flexures, {name}"]["ratios"])
        parts.append(f"{np.median(diff):.2f}× ({diff.min():.2f}–{diff.max():.2f}) of {label}")
    return ", ".join(parts)


def _poly(r):
    """Per-term costs [ns], quadratic cost per element [ns], and a function: ratio to the method's quadratic."""
    per_term = [v * 1e9 for v in r["seconds_per_term"].values()]
    quad = {m: r["quadratic_seconds_per_element"][m] * 1e9 for m in ("twist", "dualquat")}
    rows = r["rows"]

    def ratio(method, label):
        """``(text(digits), terms)``: the cost against the method's quadratic batch (same repeats: with its spread)."""
        name = next(k for k in rows if k.startswith(f"{method}: {label}"))
        row, quadratic = rows[name], rows[f"{method}: quadratic"]
        within = same_repeat(row, quadratic, "q")  # older JSON: the ratio of the medians, no spread
        median = within.get("q_median", row["ratio_median"] / quadratic["ratio_median"])
        return lambda digits: times(median, within, "q", lambda x: f"{x:.{digits}f}"), r["terms"][name]

    return per_term, quad, ratio


def row_bench_polynomial(r):
    per_term, quad, ratio = _poly(r)
    (p6, n6), (a6, m6) = ratio("twist", "order 6, plane"), ratio("twist", "order 6, all 6")
    return (
        f"polynomial terms: compiled batch of {r['n_elements']} elements vs the quadratic one",
        f"{min(per_term):.0f}–{max(per_term):.0f} ns per term and element (quadratic wrench {quad['dualquat']:.0f}–"
        f"{quad['twist']:.0f} ns); twist order 6: {p6(1)} in the plane ({n6} terms), {a6(0)} in all six "
        f"coordinates ({m6} terms)",
    )


def block_polynomial_cost(results):
    r = results["bench_polynomial"]
    per_term, quad, ratio = _poly(r)
    cells = []
    for label in ("order 4, plane", "order 6, plane", "order 6, all 6"):
        (t, n), (d, m) = ratio("twist", label), ratio("dualquat", label)
        cells.append(f"{label.replace('all 6', 'all six coordinates')} ({n} / {m} terms) {t(1)} / {d(1)}")
    machine = timed_on(r)
    return (
        f"Per element, each term costs {min(per_term):.0f}–{max(per_term):.0f} ns against {quad['dualquat']:.0f} "
        f"(dual quaternion) and {quad['twist']:.0f} ns (twist) for the whole quadratic wrench; against the quadratic "
        f"batch of the same method (twist / dual quaternion), {'; '.join(cells)} (`{r['command']}`, medians "
        f"{'(min–max) ' if machine else ''}of interleaved repeats, recorded {r['date'][:10]}"
        f"{' ' + machine if machine else ''}).\n"
    )


# ---------------------------------------------------------------------- stiffness from geometry


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


def block_fe_check(results):
    r = results["hinge_fe_check"]
    conv2, conv3, beam = r["convergence_2d"], r["convergence_3d"], r["beam_over_fe"]

    def worst(kind):
        return max(abs(v) for name, c in conv2.items() if name.startswith(kind) for v in c["level 1"])

    def orders(kind):
        o = [x for name, c in conv2.items() if name.startswith(kind) for x in c["order"] if x == x and x < 4.5]
        return f"{min(o):.1f}–{max(o):.1f}"

    mesh3 = {name.split()[0]: max(abs(v) for v in c["tables' mesh"]) for name, c in conv3.items()}
    notch, leaf = beam["notch t/R=0.125"], beam["leaf L/t=18"]  # K_beam / K_FE in the order of ENTRIES
    rot = {float(k.split("=")[1]): v[2] for k, v in beam.items() if k.startswith("notch")}
    short = beam["leaf L/t=2"]
    return (
        f"- **Mesh convergence** (`{r['command']}`, {duration(r['wall_s'])}, recorded {r['date'][:10]}): in plane "
        f"stress the tables' mesh is within {worst('notch'):.2f} % (notch) and {worst('leaf'):.2f} % (leaf, re-entrant "
        f"corners) of the Richardson limit of four levels, converging at order {orders('notch')} (notch) and "
        f"{orders('leaf')} (leaf); in 3-D it is within {mesh3['notch']:.2f} % (the paper's hinge) and "
        f"{mesh3['leaf']:.2f} % (the paper's leaf) of the refined limit in every entry.\n"
        f"- **What the beam model misses** (stiffness ratio beam / 3-D FE, the paper's `b` = 9.5 mm and material): the "
        "compliant rotation of the "
        f"paper's hinge (`t/R = 0.125`) is {pct(notch[2] - 1)} too stiff ({pct(rot[0.05] - 1)} at t/R = 0.05, "
        f"{pct(rot[0.8] - 1)} at 0.8), its torsion {1 / notch[0]:.0f}× too soft (the blocks restrain the short "
        f"neck's warping), axial and out-of-plane shear {pct(notch[3] - 1)} and "
        f"{pct(notch[5] - 1)} too stiff; the paper's leaf (`L/t = 18`) is {pct(min(leaf[1:]) - 1)}–"
        f"{pct(max(leaf[1:]) - 1)} too stiff in bending and shear, a short leaf (`L/t = 2`) "
        f"{min(short[1:]):.1f}–{max(short[1:]):.1f}× (the roots' compliance in the blocks).\n"
    )


def block_fe_tables(results):
    rows, notes = [], []
    for name, label in (("table_notch", "notch hinge"), ("table_leaf", "leaf spring")):
        t = results[name]
        band = t["error_band"]
        rows.append([label] + [pct(band[e]["total"]) if e != "rot_z" else f"**{pct(band[e]['total'])}**"
                               for e in ENTRIES])  # fmt: skip
        grid = 1
        for axis in t["axes"].values():
            grid *= len(axis)
        notes.append(
            f"`{t['command']}` ({label}: {grid} FE solutions, last build {duration(t['grid_wall_time_s'])}, "
            f"validation {duration(t['validation_wall_time_s'])})"
        )
    head = ["entry", "torsion `rot_x`", "out-of-plane bending `rot_y`", "compliant rotation `rot_z`", "axial `x`",
            "in-plane shear `y`", "out-of-plane shear `z`"]  # fmt: skip
    return (
        table(head, rows)
        + "\nFrom the tables' own records (package data, `mjflex/geometry/data/`): "
        + "; ".join(notes)
        + ", one core.\n"
    )


def block_beam_factors(results):
    """Range of the FE/beam factors the tables hold, per kind: what ``method="beam"`` gets wrong."""
    import numpy as np

    out = []
    for name, label in (("table_notch", "notch"), ("table_leaf", "leaf")):
        ratio = 1.0 / np.asarray(results[name]["factors"], float).reshape(-1, 6)  # K_beam / K_FE per entry
        rz, others = ratio[:, 2], ratio[:, [1, 3, 4, 5]]
        soft = f"{pct(1 - rz.min())} too soft to " if rz.min() < 1 else f"{pct(rz.min() - 1)} to "
        out.append(f"{label}: compliant rotation {soft}{pct(rz.max() - 1)} too stiff, other entries up to "
                   f"{others.max():.2g}× too stiff, torsion up to {1 / ratio[:, 0].min():.0f}× too soft")  # fmt: skip
    return "Over the tables' range the beam model's stiffness (`method=\"beam\"`) is, " + "; ".join(out) + ".\n"


# -------------------------------------------------------------------------------- the ARCADE model


def row_modes(r):
    a = r["arcade.xml"]
    return (
        "ARCADE normal modes",
        f"{a['n_rigid']} rigid modes, then the cylinder's axial translation at {a['guide_frequency_hz']:.1f} Hz, next "
        f"mode {a['separation']:.2f}× higher; highest mode {a['highest_frequency_hz'] / 1e3:.1f} kHz",
    )


def _grid(r):
    """scripts/timestep_study.py's runs: ``{integrator: {step: run}}`` and the steps, largest first."""
    grid = {}
    for key, run in r["runs"].items():
        integrator, dt = key.split(":")
        grid.setdefault(integrator, {})[float(dt)] = run
    return grid, sorted({dt for runs in grid.values() for dt in runs}, reverse=True)


def _grid_bracket(runs):
    """``stable at 3e-5 s, diverges at 4e-5 s``: the grid steps around an integrator's limit."""
    stable = max((dt for dt, run in runs.items() if run["stable"]), default=None)
    unstable = min((dt for dt, run in runs.items() if not run["stable"] and (stable is None or dt > stable)),
                   default=None)  # fmt: skip
    parts = [f"stable at {sci(stable)} s"] if stable else []
    return ", ".join(parts + ([f"diverges at {sci(unstable)} s"] if unstable else []))


def row_timestep_study(r):
    grid, steps = _grid(r)
    common = max(dt for dt in steps if all(runs[dt]["stable"] for runs in grid.values()))
    errors = ", ".join(f"{name} {sig(runs[common]['max_energy_error_J'])} J" for name, runs in grid.items())
    brackets = "; ".join(f"{name} {_grid_bracket(runs)}" for name, runs in grid.items())
    return (
        f"energy error of the undamped ARCADE run ({r['duration'] * 1e3:g} ms) on a grid of steps",
        f"at h = {sci(common)} s {errors}; {brackets}",
    )


def block_integrators(results):
    """Energy error of the undamped paper run on scripts/timestep_study.py's grid of steps (x: diverged)."""
    study, modal = results["timestep_study"], results["step_limits"]["modal"]
    grid, steps = _grid(study)
    rows = [[name, *(sig(runs[dt]["max_energy_error_J"]) if runs[dt]["stable"] else "diverged" for dt in steps)]
            for name, runs in grid.items()]  # fmt: skip
    limit = {name: modal["rk4" if name == "RK4" else "euler"] for name in grid}  # Euler's for the Euler family
    agree = all(run["stable"] == (dt < limit[name]) for name, runs in grid.items() for dt, run in runs.items())
    verdict = ("every step below its modal limit ran through and every step above it diverged" if agree else
               "the runs do not follow the modal limits: see the table")  # fmt: skip
    return (
        f"`{study['command']}` (recorded {study['date'][:10]}): the paper's run of ARCADE for "
        f"{study['duration'] * 1e3:g} ms with the elements' damping off, largest deviation of the total energy [J] "
        f"at each step; {verdict}:\n\n" + table(["integrator", *(f"h = {sci(dt)} s" for dt in steps)], rows)
    )


# ---------------------------------------------------------------------------- time-step limits, defined once


def _limits_sci(x):
    return f"{sci(x, 4)} s"


def row_step_limits(r):
    m, lin, meas = r["modal"], r["linear"], r["measured"]
    return (
        f"time-step limits of ARCADE, RK4 / Euler ({r['rtol'] * 100:g} %)",
        f"modal (undamped) {sci(m['rk4'], 4)} / {sci(m['euler'], 4)} s; linear, with the model's damping "
        f"{sci(lin['rk4'], 4)} / {sci(lin['euler'], 4)} s; measured on the paper's run "
        f"({r['scene']['duration'] * 1e3:.1f} ms) {sci(meas['rk4']['largest_stable'], 4)} / "
        f"{sci(meas['euler']['largest_stable'], 4)} s",
    )


def block_step_limits(results):
    """ARCADE's time-step limits, each defined once: modal, linear (the model's damping), measured on a scene."""
    r = results["step_limits"]
    m, lin, und, meas, scene = r["modal"], r["linear"], r["linear_undamped"], r["measured"], r["scene"]
    zeta = r["fastest_eigenvalue"]["damping_ratio"]

    def measured(key):
        x = meas[key]
        return (f"{_limits_sci(x['largest_stable'])}; diverges at {_limits_sci(x['smallest_unstable'])} "
                f"(t = {x['divergence']['time'] * 1e3:.1f} ms)")  # fmt: skip

    rows = [
        ["**modal** (undamped)", "`2√2 / ω_max` and `2 / ω_max`, from the highest natural frequency "
         f"ω_max/2π = {r['highest_frequency_hz'] / 1e3:.3f} kHz", _limits_sci(m["rk4"]), _limits_sci(m["euler"])],
        ["**linear** (any motion)", "the one-step map of the model linearized at its initial pose at rest, with its "
         f"damping (the fastest mode's damping ratio: {zeta:.3f})", _limits_sci(lin["rk4"]), _limits_sci(lin["euler"])],
        ["**measured** (one scene)", f"the paper's run (keyframe `{scene['keyframe']}`), {scene['duration'] * 1e3:.1f} "
         "ms (one period of the guide mode), damping on: the largest step that runs through", measured("rk4"),
         measured("euler")],
    ]  # fmt: skip
    deviation = max(abs(und[k] / m[k] - 1) for k in m)
    return (
        f"`{r['command']}` (recorded {r['date'][:10]}, {duration(r['script_wall_s'])}; every limit bisected to "
        f"{r['rtol'] * 100:g} %; nothing timed):\n\n"
        + table(["limit", "defined by", "RK4", "Euler, implicitfast, discrete"], rows)
        + "\nWhy they differ:\n\n"
        f"- **Damping moves the advised limit off the modal one.** RK4's stability region reaches left of the "
        f"imaginary axis, so damping raises its limit (by {pct(lin['rk4'] / m['rk4'] - 1)} here); semi-implicit "
        f"Euler takes the elements' damping explicitly, which lowers it (by {pct(1 - lin['euler'] / m['euler'])}). "
        f"With the damping removed, the same computation gives the modal limits (to {sig(deviation, 1)} "
        "relative).\n"
        "- **A scene can run a little past the advised limit.** The advised limit holds for any motion. A scene that "
        "leaves the mode that sets it unexcited starts that mode from round-off, which needs time to grow: the "
        f"paper's run goes {pct(meas['rk4']['largest_stable'] / lin['rk4'] - 1, 1)} past RK4's advised limit and "
        f"diverges after {meas['rk4']['divergence']['time'] * 1e3:.0f} ms at a step "
        f"{pct(meas['rk4']['smallest_unstable'] / lin['rk4'] - 1, 1)} past it. A shorter run goes further, a "
        "longer one less far: a measured limit belongs to its scene and its length.\n"
    )


# ------------------------------------------------------------------------------------- the demo

DEMO_DEFAULT, DEMO_BEFORE = "default", "before: full look, 1280x720"


def _median_range(stats, digits=2):
    """``7.9 s (7.5–8.3)``: median and min–max of scripts/demo.py's statistics."""
    m, lo, hi = (sig(stats[k], digits) for k in ("median", "min", "max"))
    return f"{m} s ({lo}–{hi})"


def _gl_kind(gl):
    return f"{gl['renderer']}, {'software' if gl['software'] else 'hardware'} GL"


def row_demo(r):
    d, b = r["commands"][DEMO_DEFAULT], r["commands"][DEMO_BEFORE]
    return (
        f"`python -m mjflex demo`, start to exit ({_cores(r)} cores, {_gl_kind(d['gl'])})",
        f"{_median_range(d['wall_s'])} with {d['frame_ms']['median']:.1f} ms a frame ({d['width']}×{d['height']}, "
        f"{d['look']['name']} look); {_median_range(b['wall_s'])} and {b['frame_ms']['median']:.0f} ms a frame with "
        "the full look at 1280×720",
    )


def _cores(r):
    m = r["machine"]
    return m.get("logical_cores", m.get("cpus"))  # scripts/_bench.py's machine record; an older one says "cpus"


def _cpu(r):
    model = r["machine"].get("cpu_model")
    return f"{model}, " if model else ""


def _load(r):
    m = r["machine"]
    return m.get("load_average_1min_after", m.get("load_average_1min"))


def block_demo(results):
    r = results["demo"]
    d, b = r["commands"][DEMO_DEFAULT], r["commands"][DEMO_BEFORE]
    names = {"start-up": "start-up (Python, imports)", "kernels": "provider set-up", "provider": "provider set-up",
             "model": "model", "run": "run", "rendering set-up": "GL set-up", "rendering": "rendering",
             "encoding": "waiting for the encoder", "panels": "panels", "plots": "plots"}  # fmt: skip
    phases = ", ".join(f"{names.get(k, k)} {sig(v['median'])} s" for k, v in d["phases_s"].items())
    f = r["frame_costs"]
    rows = []
    for w, h in dict.fromkeys((x["width"], x["height"]) for x in f["rows"]):
        cells = [f"{x['cpu_ms']:.1f}" for x in f["rows"] if (x["width"], x["height"]) == (w, h)]
        enc = [f"{x['cpu_ms']:.1f}" for x in f["encoders"] if (x["width"], x["height"]) == (w, h)]
        rows.append([f"{w}×{h}", *cells, " / ".join(enc)])
    looks = list(dict.fromkeys(x["look"] for x in f["rows"]))
    encoders = " / ".join(dict.fromkeys(x["encoder"] for x in f["encoders"]))
    return (
        f"Recorded by `{r['command']}` ({r['date'][:10]}, {_cpu(r)}{_cores(r)} cores, {_gl_kind(d['gl'])}, "
        f"1-minute load average {_load(r):g} at the end; {d['runs']} fresh runs of each, "
        f"median and min–max): the demo takes {_median_range(d['wall_s'])} from start "
        f"to exit ({sig(d['cpu_s']['median'])} s of CPU time); it reports {phases}. The video's {d['frames']} frames "
        f"({d['width']}×{d['height']}, {d['look']['name']} look) take {d['frame_ms']['median']:.1f} ms each, "
        f"rendered and encoded. With the look and size of before (`--quality full --width 1280 --height 720`) the "
        f"command takes {_median_range(b['wall_s'])} and a frame {b['frame_ms']['median']:.0f} ms.\n\n"
        f"CPU time of one frame [ms] (drawing and read-back, the GL's threads included; median of {f['repeats']} "
        f"rounds of {f['frames']} frames), and of the encoder ({encoders}):\n\n"
        + table(["size", *looks, "encoder"], rows)
    )


# ----------------------------------------------------------------------------- large deflections


def _fit_cell(e, limit):
    worst, fails = e[f"worst_tip_error_pct_L_upto_{limit}deg"], e[f"failures_upto_{limit}deg"]
    text = "–" if worst is None else sig(worst)
    return text + (f" ({fails} none)" if fails else "")


def block_fit_flexure(results):
    r = results["fit_flexure"]
    fits = r["table"]
    reach = fit_reach(r)
    loads = len(next(iter(next(iter(r["points"].values())).values())))
    bins = sorted({int(k.split("_")[-1][:-3]) for k in fits[0] if k.startswith("worst_")})
    top = bins[-1]
    e = {(x["slenderness"], x["model"], x["method"]): x for x in fits}
    sizes = sorted({x["slenderness"] for x in fits})
    labels = {"beam theory": "linear beam theory K (not fitted)", "N = 2": "fitted N = 2", "N = 4": "fitted N = 4",
              "N = 6": "fitted N = 6", "beam K + N = 6": "beam K + fitted N = 6 terms"}  # fmt: skip
    rows = [[f"{sizes[0]:g}", label, *(_fit_cell(e[(sizes[0], model, m)], b) for m in ("twist", "dualquat")
                                       for b in bins)] for model, label in labels.items()]  # fmt: skip
    for size in sizes[1:]:
        rows.append([f"{size:g}", "fitted N = 2 / 4 / 6", *(" / ".join(_fit_cell(e[(size, f"N = {n}", m)], b)
                     for n in (2, 4, 6)) for m in ("twist", "dualquat") for b in bins)])  # fmt: skip
    ranges = [f"≤ {b}°" if b < reach else f"≤ {reach:.0f}°" for b in bins]
    head = ["L/t", "potential", *(f"twist: {x}" for x in ranges), *(f"dual quaternion: {x}" for x in ranges)]

    def w(size, model, method="twist", limit=top):
        return e[(size, model, method)][f"worst_tip_error_pct_L_upto_{limit}deg"]

    order4 = [w(size, "N = 4", m) for size in sizes for m in ("twist", "dualquat")]
    fixed_fails = max(x["failures"] for x in fits if x["model"].startswith("beam K"))
    slender = sizes[-1]
    return (
        f"`{r['command']}` (recorded {r['date'][:10]}, {duration(r['script_wall_s'])}): worst tip-position error "
        f"in % of L over the held-out loads up to {reach:.0f}° of tip rotation, and the number of loads (of "
        f"{loads}) where the model has no stable equilibrium; all numbers, the other models and the fitted potentials "
        "are in the JSON:\n\n"
        + table(head, rows)
        + f"\nFor L/t = {sizes[0]:g} the fitted order-6 potential errs by at most {sig(w(sizes[0], 'N = 6'))} % of L "
        f"(twist; {sig(w(sizes[0], 'N = 6', 'dualquat'))} % dual quaternion) against {sig(w(sizes[0], 'N = 2'))} % "
        f"for the fitted quadratic and {sig(w(sizes[0], 'beam theory'))} % for the beam-theory K; order 4 gets "
        f"{sig(min(order4))}–{sig(max(order4))} % over all three leaves. Keeping the beam K and fitting only the "
        f"terms errs by {sig(w(sizes[0], 'beam K + N = 6', limit=bins[0]))} % near rest (≤ {bins[0]}°, against "
        f"{sig(w(sizes[0], 'N = 6', limit=bins[0]))} % for the full fit) but is fragile for slender leaves: up to "
        f"{fixed_fails} of {loads} loads without a stable equilibrium. For L/t = {slender:g} order 6 finds no "
        f"equilibrium for {e[(slender, 'N = 6', 'twist')]['failures']} (twist) and "
        f"{e[(slender, 'N = 6', 'dualquat')]['failures']} (dual quaternion) of the largest loads.\n"
    )


def row_fit_flexure(r):
    fits = r["table"]
    s = min(e["slenderness"] for e in fits)
    top = max(int(k.split("_")[-1][:-3]) for k in fits[0] if k.startswith("worst_"))
    w = {(e["model"], e["method"]): e[f"worst_tip_error_pct_L_upto_{top}deg"] for e in fits if e["slenderness"] == s}
    return (
        f"a leaf spring (L/t = {s:g}) fitted far beyond its linear range: worst tip error over held-out loads",
        f"order 6 {sig(w[('N = 6', 'twist')])} % / {sig(w[('N = 6', 'dualquat')])} % of L, fitted quadratic "
        f"{sig(w[('N = 2', 'twist')])} % / {sig(w[('N = 2', 'dualquat')])} % (twist / dual quaternion)",
    )


# ------------------------------------------------------------------------------------- the index


#: Rows of the "What was measured" table, in order: (JSON name, row function).
MEASURED = [
    ("bench_core", row_bench_core),
    ("bench_step", row_bench_step),
    ("bench_polynomial", row_bench_polynomial),
    ("hinge_fe_check", row_hinge_fe_check),
    ("modes", row_modes),
    ("step_limits", row_step_limits),
    ("timestep_study", row_timestep_study),
    ("operating_pose", row_operating_pose),
    ("study_arcade", row_study_arcade),
    ("compare_alternatives", row_compare_alternatives),
    ("reduce_arcade", row_reduce_arcade),
    ("long_run", row_long_run),
    ("bench_sweep", row_bench_sweep),
    ("fit_flexure", row_fit_flexure),
    ("demo", row_demo),
    ("encoder_quality", row_encoder_quality),
    ("count_step_instructions", row_count_step_instructions),
]


#: The recorded JSON whose figures are timings (ratios of interleaved repeats): their blocks state the machine.
TIMED = [
    "bench_core",
    "bench_step",
    "bench_step_2lanes",
    "bench_polynomial",
    "compare_alternatives",
    "reduce_arcade",
    "reduce_robots",
    "bench_sweep",
]


def block_measured(results):
    lines = ["| what | result | command (recorded, wall time) |", "|---|---|---|"]
    for name, row in MEASURED:
        what, result = row(results[name])
        lines.append(f"| {what} | {result} | {command_note(results[name])} |")
    note = machines_note(results, [name for name, _ in MEASURED if name in TIMED])
    return "\n".join(lines) + "\n" + ("\n" + note if note else "")


#: Block name -> (recorded JSON it reads, renderer).
BLOCKS = {
    "measured": ([name for name, _ in MEASURED], block_measured),
    "integrators": (["timestep_study", "step_limits"], block_integrators),
    "step-limits": (["step_limits"], block_step_limits),
    "fe-tables": (["table_notch", "table_leaf"], block_fe_tables),
    "beam-factors": (["table_notch", "table_leaf"], block_beam_factors),
    "fe-check": (["hinge_fe_check"], block_fe_check),
    "polynomial-cost": (["bench_polynomial"], block_polynomial_cost),
    "fit-flexure": (["fit_flexure"], block_fit_flexure),
    "study-arcade": (["study_arcade"], block_study_arcade),
    "native": (["compare_alternatives"], block_native),
    "native-verdict": (["compare_alternatives"], block_native_verdict),
    "reduce-arcade": (["reduce_arcade"], block_reduce_arcade),
    "reduce-robots": (["reduce_robots"], block_reduce_robots),
    "long-run": (LONG_RUNS, block_long_run),
    "long-run-verdict": (LONG_RUNS, block_long_run_verdict),
    "sweep-arcade": (["sweep_arcade"], block_sweep_arcade),
    "sweep-bench": (["bench_sweep"], block_sweep_bench),
    "demo": (["demo"], block_demo),
    "step-cost": (["bench_step", "bench_step_2lanes"], block_step_cost),
    "plugin-overhead": (["bench_step"], inline_plugin_overhead),
    "warp-float32": (["warp_float32"], block_warp_float32),
    "warp-bench": (WARP_BENCH, block_warp_bench),  # only the throughput JSON recorded so far (GPU: where measured)
    "encoder-quality": (["encoder_quality", "demo"], inline_encoder_quality),
    "stop-cost": (["count_step_instructions"], inline_stop_cost),
    "stop-instructions": (["count_step_instructions"], inline_stop_instructions),
    "stop-bounces": (["stops_and_preload"], block_stop_bounces),
    "stop-preload": (["stops_and_preload"], block_stop_preload),
    "stop-damping-instructions": (["count_step_instructions_damping"], inline_stop_damping_instructions),
    "snapshot-cost": (["count_step_instructions_edits"], inline_snapshot_cost),
    "fit-reach": (["fit_flexure"], inline_fit_reach),
    "long-run-divergence": (["long_run_arcade", "long_run_arcade_1e-5"], inline_long_run_divergence),
    "method-difference": (["study_arcade"], inline_method_difference),
    "operating-pose-servo": (["operating_pose"], inline_operating_pose_servo),
    "operating-pose": (["operating_pose"], block_operating_pose),
    "operating-pose-muscles": (["operating_pose"], inline_operating_pose_muscles),
    "operating-pose-blind": (["operating_pose"], inline_operating_pose_blind),
    "operating-pose-spine": (["operating_pose"], inline_operating_pose_spine),
    "operating-pose-solref": (["operating_pose"], inline_operating_pose_solref),
}


def load_results(folder=RESULTS, sources=None):
    """Every recorded JSON of ``folder`` and of ``SOURCES``, by name (file name without ``.json``)."""
    results = {}
    for path in sorted(glob.glob(os.path.join(folder, "*.json"))):
        with open(path) as f:
            results[os.path.splitext(os.path.basename(path))[0]] = json.load(f)
    for name, path in (SOURCES if sources is None else sources).items():
        with open(_source_file(path)) as f:
            results[name] = json.load(f)
    return results


def _source_file(path):
    """A recorded JSON in the checkout; package data (``mjflex/...``) from the installed mjflex if not (a wheel)."""
    if os.path.exists(os.path.join(ROOT, path)) or not path.startswith("mjflex/"):
        return os.path.join(ROOT, path)
    import mjflex

    return os.path.join(os.path.dirname(mjflex.__file__), *path.split("/")[1:])


def pages():
    """README.md and every hand-written Markdown page under docs/ (absolute paths, sorted)."""
    found = [README]
    for path in sorted(glob.glob(os.path.join(DOCS, "**", "*.md"), recursive=True)):
        if not os.path.relpath(path, DOCS).startswith(GENERATED):
            found.append(path)
    return found


def placements(paths=None):
    """Block name -> the pages (paths relative to the repository root) that hold a block of that name, in order."""
    out = {}
    for path in pages() if paths is None else paths:
        with open(path, encoding="utf-8") as f:
            for m in BLOCK.finditer(f.read()):
                out.setdefault(m["name"], []).append(os.path.relpath(path, ROOT))
    return out


def generate(text, results):
    """``text`` with every generated block rewritten from ``results``; KeyError names a missing block or JSON."""

    def render(match):
        name = match["name"]
        if name not in BLOCKS:
            raise KeyError(f"block 'results:{name}' has no renderer in scripts/results_blocks.py BLOCKS")
        needs, renderer = BLOCKS[name]
        missing = [n for n in needs if n not in results]
        if missing:
            raise KeyError(f"block 'results:{name}' needs recorded JSON {missing[0]!r}: record it (MJFLEX_RECORD=1)")
        return match.group(1) + renderer(results) + match.group(4)

    return BLOCK.sub(render, text)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check", action="store_true", help="only check; exit 1 if a page would change")
    args = ap.parse_args()
    results, stale, written = load_results(), [], 0
    for path in pages():
        with open(path, encoding="utf-8") as f:
            text = f.read()
        new = generate(text, results)
        written += len(BLOCK.findall(new))
        if new == text:
            continue
        stale.append(os.path.relpath(path, ROOT))
        if not args.check:
            with open(path, "w", encoding="utf-8") as f:
                f.write(new)
    misplaced = {name: where for name, where in placements().items() if len(where) != 1}
    unplaced = sorted(set(BLOCKS) - set(placements()))
    for name, where in misplaced.items():
        print(f"block 'results:{name}' is placed {len(where)} times ({', '.join(where)}): place it once")
    for name in unplaced:
        print(f"block 'results:{name}' is on no page: put an empty one where it belongs, then run this again")
    if args.check:
        if stale:
            sys.exit(f"not what the recorded JSON gives: {', '.join(stale)}: run python scripts/results_blocks.py")
        print(f"every page is what the recorded JSON gives ({written} generated blocks)")
    else:
        print(f"{len(stale)} page(s) rewritten: {', '.join(stale) or 'none'} ({written} generated blocks)")
    if misplaced or unplaced:
        sys.exit(1)


if __name__ == "__main__":
    main()

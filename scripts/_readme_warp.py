"""Renderers of the MuJoCo Warp page's generated blocks (scripts/results_blocks.py): float32 and throughput.

The throughput block shows only what was measured: each of ``bench_warp_cpu`` and
``bench_warp_gpu`` (scripts/bench_warp.py, recorded with ``MJFLEX_RECORD=1``) where it is recorded
in docs/results, and says which is missing and the command that records it.
"""

import os

from _readme_format import command_note, load_of, machine_of, sig, table

RESULTS = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "docs", "results")
#: The throughput JSON recorded so far (the block reads only these).
WARP_BENCH = [n for n in ("bench_warp_cpu", "bench_warp_gpu") if os.path.exists(os.path.join(RESULTS, f"{n}.json"))]
GPU_COMMAND = "python scripts/bench_warp.py --device cuda:0 --out out/bench_warp"
CPU_COMMAND = "python scripts/bench_warp.py --device cpu --out out/bench_warp --budget 3600"
_NAMES = {"warp": "MuJoCo Warp + mjflex", "warp_bare": "MuJoCo Warp, no elements", "rollout": "`mujoco.rollout`",
          "batch": "`Batch`"}  # fmt: skip


def _rate(row):
    return f"{sig(row['world_steps_per_s_median'], 3)} ({sig(row['world_steps_per_s_min'], 2)}–" \
           f"{sig(row['world_steps_per_s_max'], 2)})"  # fmt: skip


def _relative(row):
    """Throughput relative to rollout's in the same repeat: median (min–max)."""
    return f"{sig(1 / row['ratio_median'], 2)}× ({sig(1 / row['ratio_max'], 2)}–{sig(1 / row['ratio_min'], 2)})"


def _bench_table(r):
    rows = []
    for model, m in r["models"].items():
        for n, row in m["worlds"].items():
            cells = [f"{model}", n]
            for case in ("warp", "warp_bare", "rollout", "batch"):
                cells.append(_rate(row[case]) + ("" if case == "rollout" else f"; {_relative(row[case])}"))
            rows.append(cells)
        for n, why in m.get("skipped", {}).items():
            rows.append([model, n, f"not measured: {why}", "", "", ""])
    head = ["model", "worlds", *(f"{_NAMES[c]}: world-steps/s (min–max); vs rollout" if c != "rollout" else
                                 f"{_NAMES[c]}: world-steps/s (min–max)" for c in ("warp", "warp_bare", "rollout",
                                                                                     "batch"))]  # fmt: skip
    return table(head, rows)


def _check_note(r):
    c = r.get("check", {})
    if not c or "skipped" in c:
        return "no correctness check was recorded with these figures"
    parts = [f"forces {max(c['forces']['largest_error_over_bound'].values()):.2g}"]
    parts += [f"{k.removeprefix('trajectory_')} trajectory {v['largest_error_over_bound']:.2g}" for k, v in c.items()
              if k.startswith("trajectory_")]  # fmt: skip
    verdict = "passed" if c["passed"] else "FAILED"
    return f"correctness check on the device {verdict} (largest error / derived bound: {', '.join(parts)})"


def block_warp_bench(results):
    out = []
    for name, what in (("bench_warp_gpu", "GPU"), ("bench_warp_cpu", "Warp's CPU device")):
        if name not in results:
            command = GPU_COMMAND if what == "GPU" else CPU_COMMAND
            out.append(f"**{what}: not measured yet** (no `docs/results/{name}.json`; `MJFLEX_RECORD=1 {command}` "
                       "records it).\n")  # fmt: skip
            continue
        r = results[name]
        d = r["device"]
        device = f"{d['name']} ({d['alias']})" + (f", CUDA driver {d['cuda_driver_version']}" if d.get(
            "cuda_driver_version") else "")  # fmt: skip
        out.append(
            f"**{what}**: {device}, Warp {d['warp']}, MuJoCo Warp {d['mujoco_warp']}; C baselines on {r['threads']} "
            f"threads of {machine_of(r)}; {r['repeat']} interleaved repeats, 1-minute load average {load_of(r)}; "
            f"{_check_note(r)}. Recorded by {command_note(r)}.\n\n" + _bench_table(r)
        )
    return "\n".join(out)


def _drift_rows(drift, label):
    rows = []
    for name, what in (("c_engine_float64", "C engine, float64"), ("warp_float32", "MuJoCo Warp, float32 elements"),
                       ("warp_float64", "MuJoCo Warp, float64 elements")):  # fmt: skip
        d = drift[name]
        rows.append([label, what, f"{sig(d['largest_J'])} J", f"{sig(d['largest_J'] / drift['elastic_energy_max_J'])}",
                     f"{sig(d['relative_largest'])}"])  # fmt: skip
    return rows


def block_warp_float32(results):
    r = results["warp_float32"]
    f = r["force_error"]
    rows = []
    for amplitude, row in f.items():
        a, b = row["float32"], row["float64"]
        rows.append([f"{amplitude} rad, {sig(1e-3 * float(amplitude))} m", f"{sig(row['wrench_norm_median'])}",
                     f"{sig(a['relative_median'])} / {sig(a['relative_max'])}",
                     f"{sig(b['relative_median'])} / {sig(b['relative_max'])}",
                     f"{sig(a['absolute_force_median_N'])} N, {sig(a['absolute_moment_median_Nm'])} N m"])  # fmt: skip
    head = [
        "deflection of each body (up to)",
        "wrench norm (median)",
        "relative error, float32 (median / max)",
        "relative error, float64 elements (median / max)",
        "absolute error (median, float32)",
    ]
    forces = table(head, rows)
    e, ea = r["energy_drift"], r["energy_drift_axial"]
    drift = table(["run", "engine", "largest energy error", "of the largest elastic energy", "of the total energy"],
                  _drift_rows(e, "paper's run (spin + axial)") + _drift_rows(ea, "axial motion alone"))  # fmt: skip
    s = r["stable_step"]
    stable = ", ".join(f"{what} {sig(s[name]['largest_stable_s'] * 1e6, 3)} µs" for name, what in (
        ("c_engine_float64", "C engine"), ("warp_float32", "MuJoCo Warp (float32)"),
        ("warp_float64", "MuJoCo Warp with float64 elements")))  # fmt: skip
    lo, hi = r["elastic_frequencies_hz"]
    k0, k1 = r["stiffness_range"]
    return (
        f"ARCADE (elastic modes {sig(lo, 3)} Hz … {sig(hi, 3)} Hz, diagonal stiffness {sig(k0)} … {sig(k1, 3)} "
        f"in N m/rad and N/m), on Warp's CPU device against the C engine in float64; {command_note(r)}.\n\n"
        f"Element wrenches at states moved from rest ({len(f)} amplitudes, 8 states each, all 48 elements):\n\n"
        f"{forces}\n"
        f"Energy over {e['steps']} RK4 steps of {e['timestep_s'] * 1e6:g} µs, undamped (kinetic + elastic, "
        f"evaluated in float64 at the recorded states; total energy {sig(e['initial_energy_J'], 3)} J with the spin, "
        f"{sig(ea['initial_energy_J'], 3)} J without):\n\n{drift}\n"
        f"Largest stable RK4 step of {len(s['grid_s'])} between {sig(s['grid_s'][0] * 1e6, 3)} and "
        f"{sig(s['grid_s'][-1] * 1e6, 3)} µs over {s['steps']} steps of the paper's run: {stable}.\n"
    )


__all__ = ["WARP_BENCH", "block_warp_bench", "block_warp_float32"]

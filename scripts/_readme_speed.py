"""Generated blocks of the speed-accuracy measurements: study, reduce, MuJoCo-native alternatives, long runs, sweeps.

Renderers of scripts/results_blocks.py: each takes the recorded JSON (by name) and returns Markdown text.
"""

import re

from _readme_format import (
    command_note,
    cost_ratio,
    duration,
    join_and,
    machine_of,
    pct,
    sci,
    sig,
    table,
    timed_on,
    times,
)

#: The recorded runs of scripts/long_run.py, in the order of their block.
LONG_RUNS = ["long_run", "long_run_arcade", "long_run_arcade_1e-5", "long_run_arcade_damped"]


# ---------------------------------------------------------------------------- speed vs accuracy


def _study_limit(r, variant="full", method="twist"):
    return {lim["integrator"]: lim for lim in r["limits"] if lim["variant"] == variant and lim["method"] == method}


def _usable_step(lim):
    """The step a study recommends for a (variant, method, integrator): checked (advised limit and perturbed run) or,
    in a record made before those checks, the measured one."""
    return lim["recommended"] if lim.get("checked") else lim["largest_stable"]


def row_study_arcade(r):
    need = {n["need"].split(" (")[0]: n for n in r["needs"]}
    eng = need["engineering answers"]
    faster = eng["vs the model's setting"]
    rk4 = _study_limit(r)["rk4"]
    return (
        "speed against accuracy on the ARCADE run (`mjflex study`)",
        f"for ≤ 1 % pose error: {eng['choice']}, {eng['s per simulated s']} CPU s per simulated s, "
        f"{faster} than the model's own RK4 at 1e-5 s; the RK4 step it recommends {sci(_usable_step(rk4), 3)} s",
    )


def block_study_arcade(results):
    r = results["study_arcade"]
    ref, lim = r["reference"], _study_limit(r)
    full = [x for x in r["rows"] if x["variant"] == "full" and x["status"] == "ok"]
    dq = [x["pose_error"] for x in full if x["method"] == "dualquat" and x["pose_error"] is not None]
    best = {v: min(x["pose_error"] for x in r["rows"] if x["variant"] == v and x["pose_error"] is not None)
            for v in r["variants"]}  # fmt: skip
    notes = {}
    for v, report in r["variants"].items():
        lines = report.splitlines()[1:]
        kept = sum("kept as an element" in line for line in lines)
        dropped = sum("damping dropped" in line for line in lines)
        if v.startswith("reduced") and kept:
            notes[v] = f" (keeps {kept} elements" + (f", drops the damping of {dropped})" if dropped else ")")
    checked = lim["rk4"].get("checked")
    rows = []
    for name, x in lim.items():
        div = x["divergence"] or {}
        where = f"`{div['element']}`, t = {div['time'] * 1e3:.1f} ms" if div.get("element") else "-"
        rows.append([name, f"{sci(x['largest_stable'], 3)} s", f"{sci(x['smallest_unstable'], 3)} s ({where})",
                     f"{sci(_usable_step(x), 3)} s"])  # fmt: skip
    width = max(x["smallest_unstable"] / x["largest_stable"] - 1 for x in lim.values())
    use = "the step it recommends (no larger than its advised limit)" if checked else "the step to use"
    return (
        f"`{r['command']}` (recorded {r['date'][:10]}, {duration(r['wall_s'])} of wall time on 2 cores, the "
        f"{len(r['variants'])} default variants included):\n\n"
        f"- **Scene**: the paper's run for {r['duration'] * 1e3:.1f} ms, one period of the guide mode; "
        f"{len(r['tracked'])} bodies tracked relative to the {r['frame']}.\n"
        f"- **Reference**: RK4 at {sci(ref['timestep'], 3)} s; successive refinements agree to "
        f"{sci(ref['agreement'])} (estimated error {sci(ref['error_estimate'])}, observed order "
        f"{ref['observed_order']:.1f}).\n"
        f"- **Stability** (twist elements; brackets within {pct(width, 1)}): the implicit integrators gain nothing, "
        "as mjflex forces enter every MuJoCo integrator explicitly; each divergence names its element.\n\n"
        + table(["integrator", "ran through at", "diverged at (element, time)", use], rows)
        + "\n"
        f"- **Element methods**: the dual-quaternion runs differ from the (twist) reference by {pct(min(dq))}–"
        f"{pct(max(dq))}: the two element models differ at ARCADE's finite rotations; that is not integration "
        "error.\n"
        "- **Variants**, best pose error (any method, integrator and step): "
        + ", ".join(f"{v} {pct(e)}{notes.get(v, '')}" for v, e in best.items())
        + ".\n\nWhich choice for which need (CPU seconds of `mj_step` per simulated second):\n\n"
        + table(list(r["needs"][0]), [list(n.values()) for n in r["needs"]])
    )


# ------------------------------------------------------------ MuJoCo-native alternatives, reduce


#: How scripts/_variants.py's ``stable_step`` finds the "stable RK4 step" of the alternatives' and reduce's tables, and
#: the runs it judges (``costs_at_stable_steps(..., duration)`` in scripts/compare_alternatives.py and
#: _arcade_alternatives.py; a test reads them there): a measured limit of a short scene, a lower bound within
#: 2**(1/16) - 1 = 4.4 %.
STABLE_STEP_SEARCH = "doubling the step, then 4 bisections: a lower bound within 4.4 %"
STABLE_STEP_RUNS = {"bushing": 0.01, "cantilever": 0.002, "arcade": 0.005}  # [s] of each scene


def _stable(cost):
    bound = "≥ " if cost.get("stable_step_is_search_limit") else ""
    return f"{bound}{sci(cost['stable_step_s'], 3)} s", f"{bound}{_speedup(cost)}"


def _stable_step_note(others=True):
    runs = STABLE_STEP_RUNS
    also = f"; bushing {runs['bushing'] * 1e3:g} ms, cantilever {runs['cantilever'] * 1e3:g} ms" if others else ""
    return (
        f"stable RK4 step: the largest step at which the first {runs['arcade'] * 1e3:g} ms of ARCADE's paper run"
        f"{also} run through, found by {STABLE_STEP_SEARCH}; a short scene's measured limit, not the model's advised "
        "limit ({ref}`step-limits`)"
    )


def _speedup(cost):
    """Speed-up at the stable step, with its spread where the JSON carries it."""
    return times(cost["speedup_at_stable"], cost, "speedup", sig)


def _native_cost(cost, stable=True):
    if not stable:
        return f"{cost['ratio_median']:.2f}× ({cost['ratio_min']:.2f}–{cost['ratio_max']:.2f})"
    step, speed = _stable(cost)
    return f"{cost_ratio(cost)}; {step}; {speed}"


def _spread_intro(r, old):
    """How the cost ratios were measured: ``old`` for JSON without the machine, else medians (min–max) and where."""
    return f"cost ratios are medians (min–max) of interleaved repeats {timed_on(r)}" if machine_of(r) else old


def _native_bushing(s):
    rows = []
    for name, r in s["results"].items():
        dyn = f"{r['dynamic_rotation_error_deg']:.0f}° / {r['dynamic_position_error_mm']:.0f} mm in motion"
        if r.get("static_rotation_error_deg", float("nan")) == r.get("static_rotation_error_deg"):
            rest = f"{r['static_rotation_error_deg']:.1f}° / {r['static_position_error_mm']:.1f} mm at rest"
        else:
            rest = "no equilibrium under the static load"
        acc = "the reference (the 6×6 law on the finite twist)" if name == "mjflex twist" else f"{dyn}; {rest}"
        rows.append(["", name, _native_cost(s["costs"][name], stable=False), acc])
    twist = s["results"]["mjflex twist"]
    force, torque = (sum(x * x for x in part) ** 0.5 for part in (s["static_wrench"][:3], s["static_wrench"][3:]))
    rows[0][0] = (
        f"bushing: coupled 6×6, {twist['peak_rotation_deg']:.0f}° peak rotation in {s['duration']:g} s; static "
        f"{force / 1e3:.2g} kN + {torque:.2g} N m ({twist['static_rotation_deg']:.0f}° under the twist law)"
    )
    return rows


def _native_cantilever(s):
    rows = []
    for name, r in s["results"].items():
        acc = f"{100 * r['small_error']:.2f} %, {100 * r['large_error']:.2f} %, f1 {100 * r['f1_error']:+.2f} %"
        rows.append(["", name, _native_cost(s["costs"][name]), acc])
    rows[0][0] = (
        f"cantilever: {s['segments']} elements; tip under a small load (Timoshenko), a large one (elastica), "
        "first frequency (Euler-Bernoulli)"
    )
    return rows


def _native_arcade(s):
    rows, full = [], next(iter(s["results"]))
    for name, r in s["results"].items():
        p, q = r["paper_run"], r["small_stroke"]
        acc = (
            f"stroke {p['stroke_mm']:.2f} mm, radial {sig(p['radial_um'])} µm, axial error {pct(p['axial_error'])}; "
            f"small stroke {pct(q['axial_error'])}; second mode {s['modes_hz'][name][1]:.1f} Hz"
        )
        rows.append(["", name, _native_cost(s["costs"][name]), acc])
    rows[0][0] = f"ARCADE: paper run ({s['duration'] * 1e3:g} ms), and a 0.01 m/s stroke without spin"
    rows[0][3] = rows[0][3].replace(", axial error 0 %", "").replace("small stroke 0 %; ", "")
    assert full == rows[0][1]
    return rows


def block_native(results):
    r = results["compare_alternatives"]
    rows = _native_bushing(r["bushing"]) + _native_cantilever(r["cantilever"]) + _native_arcade(r["arcade"])
    head = ["scene", "model", "cost per step vs mjflex; stable RK4 step; speed at it", "accuracy"]
    capped = all(c.get("stable_step_is_search_limit") for c in r["bushing"]["costs"].values())
    why = " (all its models are stable at the stable-step search's upper limit)" if capped else ""
    how = _spread_intro(r, f"cost ratios are medians of interleaved repeats in one process, for the bushing with their "
                           f"min–max{why}")  # fmt: skip
    return (
        f"`{r['command']}` (recorded {r['date'][:10]}, {duration(r['script_wall_s'])}); per-step {how}; "
        f"{_stable_step_note()}; speed = wall time per simulated second at each model's own stable step, relative to "
        "mjflex (≥: still stable at the search's upper limit, 100× the scene's step):\n\n" + table(head, rows)
    )


def block_native_verdict(results):
    r = results["compare_alternatives"]
    b, c, a = r["bushing"], r["cantilever"], r["arcade"]
    ar, ac, cc = a["results"], a["costs"], c["costs"]
    full = next(iter(ar))
    red = next(k for k in ar if k.startswith("reduced(50 Hz)"))
    best = min(ar[k]["paper_run"]["axial_error"] for k in ar if k != full)
    welds = [s["costs"][k]["ratio_median"] for s in (b, c, a) for k in s["costs"] if k.startswith("weld")]
    bush = [s["costs"]["bushing"]["ratio_median"] for s in (c, a)]
    small = {k: pct(ar[k]["small_stroke"]["axial_error"]) for k in ar}
    prb = "pseudo-rigid-body"
    return (
        "Verdict:\n\n"
        "- **Small motions**: every alternative that keeps the compliant directions is accurate (ARCADE's "
        f"0.01 m/s stroke: weld {small['weld(compliant)']}, 6-joint bushing {small['bushing']}, `reduce(50 Hz)` "
        f"{small[red]}), and only a reduction is also cheaper on a closed-loop mechanism without locking it "
        f"(`reduce(50 Hz)`: {_speedup(ac[red])} mjflex's speed, each at its stable step).\n"
        f"- **Welds** cost {min(welds):.1f}–{max(welds):.1f}× mjflex per step and misstate anything anisotropic: a "
        "weld holds one "
        "isotropic rotational stiffness, so ARCADE's welded notches are as soft out of plane as about their axis, a "
        "spurious "
        f"{a['modes_hz']['weld(compliant)'][1]:.1f} Hz second mode (mjflex {a['modes_hz'][full][1]:.1f} Hz).\n"
        "- **The 6-joint bushing** is exact for small motion of a diagonal `K` but drops coupling, errs by "
        f"{b['results']['bushing']['dynamic_rotation_error_deg']:.0f}° in the bushing scene's large motion and costs "
        f"{min(bush):.1f}–{max(bush):.0f}× per step in chains.\n"
        "- **The pseudo-rigid-body model** is the cheapest for open "
        f"chains ({_speedup(cc[prb])} mjflex's speed at {pct(abs(c['results'][prb]['small_error']))} "
        f"tip error on the cantilever) and locks closed ones (ARCADE: small stroke {small[prb]} off, paper-run stroke "
        f"{ar[prb]['paper_run']['stroke_mm']:.2f} mm instead of {ar[full]['paper_run']['stroke_mm']:.2f} mm).\n"
        "- **Large motion**: on ARCADE's paper run (1000 rpm) no cheaper model in this comparison follows the full "
        "model's axial trajectory "
        f"within {pct(best)} of its stroke: the straight legs and over-constrained plates turn stroke into "
        "second-order stretch and shear of the flexures, which only the full 6×6 elements carry (the scene analysis "
        "of `reduce` above measures it).\n"
    )


def _scene_directions(report, details):
    """Directions the scene analysis keeps compliant (its report says); largest leaf-shear, notch-stretch shares."""
    n = int(re.search(r"scene '[^']*' for [\d.e-]+ s: (\d+) directions stay compliant", report)[1])
    leaf = max(e["scene_share"]["y"] for k, e in details["elements"].items() if k.startswith("leaf"))
    notch = max(e["scene_share"]["x"] for k, e in details["elements"].items() if k.startswith("notch"))
    return n, leaf, notch


def block_reduce_arcade(results):
    r = results["reduce_arcade"]
    rows = []
    for name, row in r["rows"].items():
        d = r["details"].get(name)
        p, q, cost = row["guide"]["paper_run"], row["guide"]["small_stroke"], row["cost"]
        step, speed = _stable(cost)
        highest = d["modes"]["highest_hz"] if d else next(iter(r["details"].values()))["modes"]["highest_full_hz"]
        rows.append([name, row["nv"], f"{highest / 1e3:.3g} kHz" if highest >= 1e3 else f"{highest:.0f} Hz", step,
                     speed, cost_ratio(cost), f"{p['stroke_mm']:.2f} mm / {pct(p['axial_error'])}",
                     pct(q["axial_error"])])  # fmt: skip
    head = ["model", "nv", "highest mode", "stable RK4 step", "speed-up at it", "cost per step",
            "paper run: stroke / axial error", "0.01 m/s stroke: axial error"]  # fmt: skip
    details = r["details"]
    name = max(details, key=lambda k: sum(sum(e["scene_share"].values()) for e in details[k]["elements"].values()))
    n, leaf_y, notch_x = _scene_directions(r["reports"][name], details[name])
    how = _spread_intro(r, "cost ratios are medians of interleaved repeats in one process")
    return (
        f"`{r['command']}` (recorded {r['date'][:10]}, {duration(r['script_wall_s'])}; {how}; "
        f"{_stable_step_note(others=False)}):\n\n"
        + table(head, rows)
        + f"\nThe scene analysis (`scene=`) keeps {n} directions compliant that the paper run strains beyond 2 % of "
        f"its peak strain energy: each leaf's shear holds up to {pct(leaf_y)}, each notch's axial stretch up to "
        f"{pct(notch_x)} of it.\n"
    )


def row_compare_alternatives(r):
    c, a = r["cantilever"]["costs"], r["arcade"]["costs"]
    reduced = next(k for k in a if k.startswith("reduced(50 Hz)"))
    weld = a["weld(compliant)"]
    welds = times(weld["ratio_median"], weld, "ratio", lambda x: f"{x:.1f}")
    return (
        "mjflex vs MuJoCo-native models (welds, joint springs, 6-joint bushing, flexcomp rod) and `reduce`",
        f"cantilever: pseudo-rigid-body {_stable(c['pseudo-rigid-body'])[1]} mjflex's speed, 6-joint bushing "
        f"{_stable(c['bushing'])[1]}, weld {_stable(c['weld(compliant)'])[1]}; ARCADE: `reduce(50 Hz)` "
        f"{_stable(a[reduced])[1]}, welds {welds} the cost per step",
    )


def row_reduce_arcade(r):
    rows = r["rows"]
    full = next(iter(rows.values()))
    return (
        "ARCADE reduced by `mjflex.reduce` (nv, speed-up, accuracy)",
        "; ".join(
            f"{name.removeprefix('reduced(').removesuffix(')')}: nv {row['nv']}, {_stable(row['cost'])[1]}, small "
            f"stroke {pct(row['guide']['small_stroke']['axial_error'])}"
            for name, row in rows.items()
            if row is not full
        ),
    )


# ------------------------------------------------------------------------------------- long runs


def _verdict(run):
    if run["diverged"]:
        step = re.search(r"\(step (\d+)\)", run["diverged"])
        return f"**diverged** at step {int(step[1]) if step else run['steps']:,}".replace(",", " ")
    trend = "bounded" if run["last_over_first"] <= 3 else "growing" if run["final_rel_error"] > 0 else "steady loss"
    return f"{trend} (last/first {sig(run['last_over_first'])})"


def _long_run_rows(r, methods):
    rows = []
    for run in r["runs"]:
        if run["method"] not in methods:
            continue
        err = "–" if run["diverged"] else sig(run["max_rel_error"])
        drift = "–" if run["diverged"] else sig(run["drift_per_1e6_steps"])
        rows.append([run["integrator"], run["method"], err, drift, _verdict(run), f"{run['cpu_us_per_step']:.1f}"])
    return rows


def block_long_run(results):
    head = ["integrator", "method", "max \\|ΔE\\|/E0", "drift / 1e6 steps", "verdict", "CPU µs / step"]
    out = []
    for name in LONG_RUNS:
        r = results[name]
        damping = "damping on (the model as given)" if r["damping"] else "damping off"
        out.append(
            f"{r['model']}, {sci(r['steps'])} steps of {sci(r['timestep'])} s = {r['steps'] * r['timestep']:g} s, "
            f"{damping}: {command_note(r)}\n\n" + table(head, _long_run_rows(r, ("twist", "dualquat")))
        )
    return "\n".join(out)


def _fates(r, method="twist"):
    """integrator -> its verdict (without the ratio) in one long run."""
    return {x["integrator"]: _verdict(x).split(" (")[0] for x in r["runs"] if x["method"] == method}


def _named(fates, kinds):
    return [k for k, v in fates.items() if v.split(" at ")[0].strip("*") in kinds]


def block_long_run_verdict(results):
    two, a2, a1, damped = (results[k] for k in LONG_RUNS)
    rk4 = next(x for x in two["runs"] if x["integrator"] == "rk4" and x["method"] == "twist")
    first = [x for x in two["runs"] if x["integrator"] != "rk4"]
    two_text = (
        f"On two_body RK4's energy error is a {_verdict(rk4).split(' (')[0]} ({sig(rk4['drift_per_1e6_steps'])} "
        "per 1e6 steps: RK4's numerical damping) and the first-order integrators' stays "
        f"{'bounded' if all(x['last_over_first'] <= 3 for x in first) else 'NOT bounded'} (at most "
        f"{sig(max(x['max_rel_error'] for x in first))}), both element methods alike."
    )
    parts = []
    for r in (a2, a1):
        fates = _fates(r)
        diverged = [k for k, v in fates.items() if v.startswith("**")]
        steps = ", ".join(fates[k].split("step ")[1] for k in diverged)
        text = f"at {sci(r['timestep'])} s " + (
            f"{join_and(diverged)} diverged (step{'s' * (len(diverged) > 1)} {steps})" if diverged else "none diverged"
        )
        for kinds, verb in ((("growing",), "grew to"), (("bounded", "steady loss"), "stayed within")):
            names = _named(fates, kinds)
            if names:
                worst = max(x["max_rel_error"] for x in r["runs"] if x["integrator"] in names)
                text += f"; {join_and(names)} {verb} {sig(worst)}"
        parts.append(text)
    d = _fates(damped)
    return (
        f"{two_text} Undamped and spinning at 1000 rpm, ARCADE is another matter: {'; '.join(parts)} (largest "
        f"energy error relative to E0). With the model's own damping, {join_and(list(d))} ran {sci(damped['steps'])} "
        f"steps of {sci(damped['timestep'])} s: " + ", ".join(f"{k} {v}" for k, v in d.items()) + ". So stable over "
        "a study's run is not stable for ever: MuJoCo's first-order integrators need a margin below their short-run "
        "limit on an undamped, fast-spinning mechanism (the cause, presumably the explicit treatment of the fast "
        "rotation, was not isolated). For long undamped runs, use RK4.\n"
    )


def row_long_run(r):
    runs = {(x["integrator"], x["method"]): x for x in r["runs"]}
    rk4 = runs[("rk4", "twist")]
    eu = runs[("euler", "twist")]
    return (
        f"energy over {sci(r['steps'])} steps ({r['model']}, {sci(r['timestep'])} s, no damping)",
        f"RK4 {sig(rk4['max_rel_error'])} (drift {sig(rk4['drift_per_1e6_steps'])} per 1e6 steps), Euler "
        f"{sig(eu['max_rel_error'])}, {_verdict(eu)}; ARCADE in the long-run tables",
    )


# ---------------------------------------------------------------------------------------- sweeps


def block_sweep_arcade(results):
    r = results["sweep_arcade"]
    freq = r["first_frequency_hz"]
    bad = [v for v in r["variants"] if v["status"] != "ok"]
    if bad:
        betas = ", ".join(f"{b:g}" for b in sorted({v["beta"] for v in bad}))
        scales = ", ".join(f"×{v['leaf_scale']:g}" for v in bad)
        message = bad[0]["error"].split(" (mjflex.mj")[0]
        outcome = (
            f"With `beta = {betas} s` the damping of the stiffest modes is too large for the explicit 1e-5 s RK4 step "
            f"at leaf stiffness {scales}: those variants diverge and are reported (`{message}`), drawn as crosses on "
            "the axis, and have no result."
        )
    else:
        outcome = (
            f"Every variant ran (`beta` up to {sci(max(v['beta'] for v in r['variants']))} s at the explicit 1e-5 s "
            "RK4 step); a variant that diverges is reported with the element, time and step, drawn as a cross on the "
            "axis, and has no result."
        )
    return (
        f"`{r['command']}` (recorded {r['date'][:10]}, {duration(r['command_wall_s'])}; the figure is "
        f"`out/sweep_arcade.png`, copied to `docs/` with its JSON) finds the guide's first natural frequency "
        f"{', '.join(f'{v:.2f} Hz at ×{k}' for k, v in freq.items())} (leaf stiffness scale). {outcome}\n"
    )


def block_sweep_bench(results):
    r = results["bench_sweep"]
    n = r["workers"]
    labels = {"serial": "serial `mj_step` loop", "batch": f"`Batch`, {n} threads (default path)",
              "pool": f"spawn process pool, {n} workers", "dask": f"Dask `LocalCluster` {n}×1"}  # fmt: skip
    rows = []
    for name, c in r["cases"].items():
        if "ratio_q1" in c:  # recorded with its repeats: the baseline's spread is 1–1 (shown like the others)
            ratio = times(c["ratio_to_serial_median"], c, "ratio")
        else:
            ratio = "1.00×" if name == "serial" else f"{c['ratio_to_serial_median']:.2f}× ({c['ratio_min']:.2f}–"
            ratio += "" if name == "serial" else f"{c['ratio_max']:.2f})"
        rows.append([labels[name], f"{c['wall_median_s']:.2f} s", ratio, f"{c['overhead_per_variant_s'] * 1e3:.0f} ms"])
    load = r["load_average_before_after"]
    where = f" on {machine_of(r)}" if machine_of(r) else ""
    runs = f"{r['processes']} fresh processes × " if r.get("processes", 1) > 1 else ""
    return (
        f"`{r['command']}` ({r['variants']} ARCADE variants × {r['duration_s'] * 1e3:g} ms = {r['steps']} RK4 steps "
        f"each, {runs}{r['repeat']} interleaved repeats; recorded {r['date'][:10]}{where}, "
        f"{duration(r['script_wall_s'])}, 1-minute load average {load[0]:.1f} before and {load[1]:.1f} after). All "
        "paths gave bit-identical strokes (the script checks):\n\n"
        + table(["path", "wall median", "vs serial loop, same repeat: median (min–max)", "overhead per variant"], rows)
    )


def row_bench_sweep(r):
    c = r["cases"]
    return (
        f"a sweep of {r['variants']} ARCADE variants: serial loop vs `Batch` vs process pool vs Dask "
        f"({r['workers']} workers)",
        ", ".join(f"{k} {times(v['ratio_to_serial_median'], v, 'ratio')}" for k, v in c.items() if k != "serial")
        + " the serial wall time (medians of same-repeat ratios); bit-identical",
    )

"""Inline blocks of scripts/results_blocks.py: measured figures inside sentences of the pages' prose.

Each renderer takes the recorded JSON (by name) and returns text without a line break, placed in a sentence as
``<!-- results:NAME -->...<!-- /results -->``; tests/test_docs.py checks that no other number with a unit stands in
a page's prose unless it is a stated constant.
"""

from _readme_format import pct, sig


def _count(n):
    """``727 544``: a whole number with spaces between thousands."""
    return f"{round(n):,}".replace(",", " ")


# ---------------------------------------------------------------- rendering (docs/howto/render_headless.md)

DEMO_ENCODER, MEDIAPY_ENCODER = "demo (ultrafast, qp 23)", "mediapy default (medium, qp 28)"


def _demo_size(results):
    """The size of the demo's video as recorded by scripts/demo.py (its default command, on a software GL)."""
    d = results["demo"]["commands"]["default"]
    return d["width"], d["height"]


def inline_encoder_quality(results):
    """Fidelity (PSNR) and size of the demo's x264 settings against mediapy's defaults: the demo's size first, then
    the others (scripts/encoder_quality.py)."""
    r, size = results["encoder_quality"], _demo_size(results)
    software = "a software" if results["demo"]["commands"]["default"]["gl"]["software"] else "this"
    by = {(x["width"], x["height"], x["encoder"]): x for x in r["encoders"]}
    sizes = list(dict.fromkeys((x["width"], x["height"]) for x in r["encoders"]))

    def pair(size):
        demo, default = by[(*size, DEMO_ENCODER)], by[(*size, MEDIAPY_ENCODER)]
        return demo, default, f"{demo['psnr_db']:.1f} dB against {default['psnr_db']:.1f} dB"

    demo, default, main = pair(size)
    others = ", ".join(f"{pair(s)[2]} at {s[0]}×{s[1]}" for s in sizes if s != size)
    better = "a higher" if demo["psnr_db"] > default["psnr_db"] else "a lower"
    return (
        f"{better} fidelity at {size[0]}×{size[1]}, the demo's size on {software} GL (PSNR {main}; "
        f"{others}), for files {demo['bytes_per_frame'] / default['bytes_per_frame']:.1f}× as large "
        f"({demo['bytes_per_frame'] / 1e3:.1f} kB against {default['bytes_per_frame'] / 1e3:.1f} kB a frame; "
        f"`{r['command']}`, {r['frames']} frames of the paper's run)"
    )


# ---------------------------------------------------------------------- end stops (docs/background/end_stops.md)


def _instructions(r):
    """Instructions per step by case, and the element evaluations per step (elements × force evaluations)."""
    rows = {x["case"]: x["per_step"] for x in r["rows"]}
    return rows, r["elements"] * r["evaluations_per_step"]


def inline_stop_cost(results):
    """What stops add per element evaluation, and what carrying the stop code adds without stops (the table cell)."""
    rows, evaluations = _instructions(results["count_step_instructions"])
    with_stops = (rows["stops, free"] - rows["model"]) / evaluations
    without = (rows["model"] - rows["model, baseline library"]) / evaluations
    return f"{with_stops:.0f} instructions per element evaluation with stops, engaged or not; {without:.0f} without"


def inline_stop_instructions(results):
    """The instruction counts of ARCADE's step before stops, after, and with stops, free and engaged."""
    r = results["count_step_instructions"]
    rows, _ = _instructions(r)
    base, model, free, engaged = (rows[k] for k in ("model, baseline library", "model", "stops, free",
                                                    "stops, engaged"))  # fmt: skip
    return (
        f"`{r['command']}` (recorded {r['date'][:10]}, {r['steps']} steps; the baseline is a source tree of the "
        f"code before stops): {_count(base)} instructions per step before stops existed, {_count(model)} after "
        f"(+{pct(model / base - 1)}), {_count(free)} with stops on every coordinate of every element "
        f"(+{pct(free / model - 1)}), {_count(engaged)} with all of them engaged"
    )


# ------------------------------------------------------------------- large deflections, long runs, the methods


def fit_reach(r):
    """Largest tip rotation [deg] of scripts/fit_flexure.py's held-out loads."""
    return max(abs(p["tip_rotation_deg"]) for pts in r["points"].values() for v in pts.values() for p in v)


def inline_fit_reach(results):
    return f"{fit_reach(results['fit_flexure']):.0f}°"


def inline_long_run_divergence(results):
    """The steps at which the undamped ARCADE long runs with a first-order integrator diverged (range)."""
    steps = []
    for name in ("long_run_arcade", "long_run_arcade_1e-5"):
        r = results[name]
        steps += [x["steps"] for x in r["runs"] if x["diverged"] and x["integrator"] != "rk4"]
    return f"{_count(min(steps))} to {_count(max(steps))} steps"


def inline_method_difference(results):
    """Pose error of the dual-quaternion runs against the (twist) reference in the recorded study of ARCADE."""
    r = results["study_arcade"]
    dq = [x["pose_error"] for x in r["rows"] if x["variant"] == "full" and x["status"] == "ok"
          and x["method"] == "dualquat" and x["pose_error"] is not None]  # fmt: skip
    return f"{pct(min(dq))}–{pct(max(dq))}"


# ----------------------------------------------------------------------------- rows of the "measured" table


def row_encoder_quality(r, size=(960, 540)):
    by = {(x["width"], x["height"], x["encoder"]): x for x in r["encoders"]}
    demo, default = by[(*size, DEMO_ENCODER)], by[(*size, MEDIAPY_ENCODER)]
    return (
        f"video encoding of ARCADE's frames ({size[0]}×{size[1]}): the demo's x264 settings vs mediapy's",
        f"PSNR {demo['psnr_db']:.1f} vs {default['psnr_db']:.1f} dB, {demo['bytes_per_frame'] / 1e3:.1f} vs "
        f"{default['bytes_per_frame'] / 1e3:.1f} kB a frame",
    )


def row_count_step_instructions(r):
    rows, evaluations = _instructions(r)
    return (
        f"instructions of ARCADE's {r['integrator'].removeprefix('mjINT_')} step (callgrind): with end stops, "
        "and before stops existed",
        f"{_count(rows['model'])} per step; stops on every coordinate +{pct(rows['stops, free'] / rows['model'] - 1)} "
        f"({sig((rows['stops, free'] - rows['model']) / evaluations)} per element evaluation); before stops "
        f"{pct(1 - rows['model, baseline library'] / rows['model'])} fewer",
    )


# --------------------------------------------- advice at the operating pose (docs/howto/add_flexures_to_a_robot.md)


def _ms(seconds):
    """``0.840 ms``: a time step to the microsecond (the bisections' 0.1 % at these steps)."""
    return f"{seconds * 1e3:.3f} ms"


def _arm(results):
    """scripts/operating_pose.py's arm: (Euler entry, RK4 entry)."""
    arm = results["operating_pose"]["arm"]
    return arm["Euler"], arm["RK4"]


def inline_operating_pose_servo(results):
    """The stiffness of the servo that holds the arm's replaced joint (one servo, the same in both runs)."""
    kp = {e["servo"]["kp"] for e in _arm(results)}
    (value,) = kp
    return f"{value:g} N m/rad"


def inline_operating_pose_arm(results):
    """The arm's advised limits and the longest steps whose runs do not diverge, with the command."""
    r = results["operating_pose"]
    parts = []
    for e in _arm(results):
        advised, ran = e["operating"]["limit_s"], e["measured"]["largest_stable_s"]
        if not 0.95 < ran / advised < 1.05:  # the sentence before the block says that runs agree with the advice
            raise ValueError(f"operating_pose: {e['operating']['integrator']} runs to {_ms(ran)}, advised "
                             f"{_ms(advised)}: the page's 'runs agree with it' no longer holds")  # fmt: skip
        parts.append(f"the advised {e['operating']['integrator']} limit is {_ms(advised)} and runs do not diverge up "
                     f"to {_ms(ran)}")  # fmt: skip
    return (
        f"{'; '.join(parts)} (`{r['command']}`, recorded {r['date'][:10]}: runs of {r['run_steps']} steps from the "
        f"operating pose, knocked on every degree of freedom, the step bisected to {pct(r['rtol'], 1)})"
    )


def inline_operating_pose_blind(results):
    """The advice without the servo's stiffness, and at the unloaded qpos0, against the steps that run."""
    euler, rk4 = _arm(results)
    ratios = [e["without_servo"]["limit_s"] / e["measured"]["largest_stable_s"] for e in (euler, rk4)]
    times = f"{ratios[0]:.1f} times" if f"{ratios[0]:.1f}" == f"{ratios[1]:.1f}" else "/".join(
        f"{x:.1f}" for x in ratios) + " times"  # fmt: skip
    diverged = [e["without_servo_recommended_diverges"] for e in (euler, rk4)]
    half = {(True, True): "and even half of it diverges", (False, False): "though half of it runs"}.get(
        tuple(diverged), "and half of it diverges with " + ("Euler" if diverged[0] else "RK4"))  # fmt: skip
    return (
        f"the advice says {_ms(euler['without_servo']['limit_s'])} with Euler and "
        f"{_ms(rk4['without_servo']['limit_s'])} with RK4 (at the unloaded `qpos0` "
        f"{_ms(euler['reference']['limit_s'])} and {_ms(rk4['reference']['limit_s'])}), {times} the longest step "
        f"that runs, {half}"
    )


def inline_operating_pose_spine(results):
    """The tutorial spine: the stop's frequency in the linearization, the advised limits, and the steps that run."""
    s = results["operating_pose"]["spine"]
    free, pushed = s["unloaded"], s["pushed"]
    ran, ran_free = s["measured"]["largest_stable_s"], s["measured_unloaded"]["largest_stable_s"]
    if not ran > 2 * pushed["limit_s"] or s["unloaded_recommended_diverges"]:
        raise ValueError("operating_pose: the spine's runs now see the engaged stop: rewrite this sentence")
    rise = pushed["stiffest_frequency_hz"] / free["stiffest_frequency_hz"]
    return (
        f"a {s['push_n']:g} N push engages the {s['element']}'s stop on "
        f"{' and '.join(f'`{c}`' for c in s['engaged_at_pushed_pose'])} "
        f"and raises the stiffest frequency of the linearization {rise:.1f} times "
        f"({free['stiffest_frequency_hz']:.0f} to {pushed['stiffest_frequency_hz']:.0f} Hz): the advised "
        f"{pushed['integrator']} limit falls from {_ms(free['limit_s'])} to {_ms(pushed['limit_s'])}. Runs do not see "
        f"that mode: they do not diverge up to {_ms(ran_free)} from `qpos0` and {_ms(ran)} from the pushed pose "
        f"({ran / pushed['limit_s']:.1f} times the advice there), where the step recommended at `qpos0`, "
        f"{_ms(free['recommended_s'])}, runs too"
    )


def inline_operating_pose_solref(results):
    """The time constant of the spine's equality constraints (MuJoCo's solref), one for all of them."""
    (solref,) = results["operating_pose"]["spine"]["equality_solref"]
    if solref[0] <= 0:
        raise ValueError("operating_pose: the spine's equalities give stiffness and damping directly: reword")
    return f"a {solref[0] * 1e3:g} ms time constant"


def row_operating_pose(r):
    euler, rk4 = (r["arm"][k] for k in ("Euler", "RK4"))
    s = r["spine"]

    def pair(key, sub):
        return f"{_ms(euler[key][sub])[:-3]} / {_ms(rk4[key][sub])}"

    return (
        "time-step advice at the operating pose against runs from it that do not diverge: the servo-held arm of the "
        "tests (Euler / RK4), the tutorial's spine with a stop engaged (RK4)",
        f"arm: advised {pair('operating', 'limit_s')}, runs to {pair('measured', 'largest_stable_s')}; without the "
        f"servo advised {pair('without_servo', 'limit_s')}; spine pushed by {s['push_n']:g} N: advised "
        f"{_ms(s['pushed']['limit_s'])} (equalities rigid), runs to {_ms(s['measured']['largest_stable_s'])} "
        f"({_ms(s['measured_unloaded']['largest_stable_s'])} from `qpos0`)",
    )

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


def inline_snapshot_cost(results):
    """What comparing the model with its snapshot once per step costs (docs/reference/provider.md)."""
    r = results["count_step_instructions_edits"]
    rows, _ = _instructions(r)
    base, model = rows["model, baseline library"], rows["model"]
    return (
        f"{_count(model)} instructions per ARCADE step against {_count(base)} without the comparison "
        f"(+{pct(model / base - 1)}; `{r['command']}`, recorded {r['date'][:10]}, {r['steps']} steps, the baseline "
        "the library before it)"
    )


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


#: scripts/operating_pose.py's cases, as the page names them.
OPERATING_POSES = {"servo": "servo-held arm", "muscles": "muscle-held elbow", "spine": "spine, stop engaged"}


def _pose(results, case):
    """scripts/operating_pose.py's entry of ``case``, checked: each advised limit within [0.8, 1.0] of the step that
    runs (the page says the runs agree with the advice)."""
    r = results["operating_pose"]
    for integrator in r["integrators"]:
        e = r[case][integrator]
        ratio = e["advice"]["limit_s"] / e["measured"]["largest_stable_s"]
        if not 0.8 <= ratio <= 1.0:
            raise ValueError(f"operating_pose: {case}, {integrator}: advised / measured {ratio:.3f}, outside "
                             "[0.8, 1.0]: the page's 'runs agree with the advice' no longer holds")  # fmt: skip
    return r[case]


def inline_operating_pose_servo(results):
    """The stiffness of the servo that holds the arm's replaced joint."""
    return f"{_pose(results, 'servo')['servo']['kp']:g} N m/rad"


def _ratio(zeta):
    """A damping ratio to two digits; 0 below 1e-3 (round-off of an undamped mode)."""
    return f"{zeta:.2g}" if abs(zeta) >= 1e-3 else "0"


def block_operating_pose(results):
    """The advised limits against the steps that run, per model and integrator, with the command."""
    r = results["operating_pose"]
    lines = ["| model | integrator | advised limit | runs hold up to | advised / held | limiting eigenvalue |",
             "|---|---|---|---|---|---|"]  # fmt: skip
    for case, label in OPERATING_POSES.items():
        entry = _pose(results, case)
        for integrator in r["integrators"]:
            e = entry[integrator]
            a, held = e["advice"], e["measured"]["largest_stable_s"]
            lines.append(f"| {label} | {integrator} | {_ms(a['limit_s'])} | {_ms(held)} | {a['limit_s'] / held:.3f} | "
                         f"{a['limiting_frequency_hz']:.0f} Hz, damping ratio {_ratio(a['limiting_damping_ratio'])} "
                         "|")  # fmt: skip
    return "\n".join(lines) + (
        f"\n\n`{r['command']}`, recorded {r['date'][:10]}: each model at its operating pose; a step holds when two "
        f"runs of {r['run_steps']} steps from the pose, one knocked by {r['knock']}, do not move apart "
        f"{r['growth']:g}-fold; bisected to {pct(r['rtol'], 1)}.\n"
    )


def inline_operating_pose_blind(results):
    """The arm's advice without the servo's stiffness, and at the unloaded qpos0, against the steps that hold."""
    servo = _pose(results, "servo")
    parts = []
    for integrator in ("Euler", "RK4"):
        e = servo[integrator]
        blind = e["blind"]["without_servo"]["limit_s"]
        if not e["blind_grows"]["without_servo"]:
            raise ValueError("operating_pose: a run at the advice without the servo holds: rewrite this sentence")
        held, unloaded = e["measured"]["largest_stable_s"], e["blind"]["reference"]["limit_s"]
        parts.append(f"{_ms(blind)} with {integrator} ({blind / held:.1f} times the step that holds; at the unloaded "
                     f"`qpos0` {_ms(unloaded)})")  # fmt: skip
    return f"the advice says {' and '.join(parts)}, and a knocked run grows there"


def inline_operating_pose_muscles(results):
    """The elbow: what the muscles' and the damper's damping does to Euler's limit, and implicitfast's."""
    m = _pose(results, "muscles")
    euler, fast = m["Euler"], m["implicitfast"]
    blind = euler["blind"]["without_actuators"]["limit_s"]
    if not euler["blind_grows"]["without_actuators"] or not fast["advice"]["limit_s"] > euler["advice"]["limit_s"]:
        raise ValueError("operating_pose: the elbow no longer shows what its actuators' damping does: rewrite")
    return (
        f"without them the Euler advice is {_ms(blind)}, {blind / euler['measured']['largest_stable_s']:.2f} times "
        f"the step that holds, and a knocked run grows there; with them it is {_ms(euler['advice']['limit_s'])} "
        f"(damping ratio {euler['advice']['limiting_damping_ratio']:.2f}). implicitfast integrates that damping "
        f"implicitly: its limit is {_ms(fast['advice']['limit_s'])}, set by the elbow's stiffness"
    )


def inline_operating_pose_spine(results):
    """The tutorial spine: the engaged stop, the top frequency with soft and with rigid equalities, the RK4 advice."""
    s = _pose(results, "spine")
    own = s[s["file_integrator"] if s["file_integrator"] in s else "RK4"]
    f = s["stiffest_frequency_hz"]
    return (
        f"a {s['push_n']:g} N push engages the {s['element']}'s stop on "
        f"{' and '.join(f'`{c}`' for c in s['engaged_at_pushed_pose'])}; with the equalities as MuJoCo applies them "
        f"the stiffest mode there is {f['soft']:.0f} Hz, and projected as rigid loop closures it would be "
        f"{f['rigid']:.0f} Hz ({f['rigid'] / f['soft']:.1f} times). The advice counts them soft: "
        f"{_ms(own['advice']['limit_s'])} with {own['advice']['integrator']}, where runs hold up to "
        f"{_ms(own['measured']['largest_stable_s'])}"
    )


def inline_operating_pose_solref(results):
    """The time constant of the spine's equality constraints (MuJoCo's solref), one for all of them."""
    (solref,) = results["operating_pose"]["spine"]["equality_solref"]
    if solref[0] <= 0:
        raise ValueError("operating_pose: the spine's equalities give stiffness and damping directly: reword")
    return f"a {solref[0] * 1e3:g} ms time constant"


def row_operating_pose(r):
    ratios = [r[case][i]["advice"]["limit_s"] / r[case][i]["measured"]["largest_stable_s"]
              for case in OPERATING_POSES for i in r["integrators"]]  # fmt: skip
    return (
        "time-step advice at the operating pose against knocked runs from it: a servo-held arm, a muscle-held elbow, "
        f"the tutorial's spine with a stop engaged on soft equalities ({', '.join(r['integrators'])})",
        f"advised / largest step that holds: {min(ratios):.3f} to {max(ratios):.3f}",
    )

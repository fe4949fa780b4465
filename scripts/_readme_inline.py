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

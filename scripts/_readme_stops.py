"""Renderers of docs/background/end_stops.md's damped stops and preload (scripts/stops_and_preload.py) and of their
cost (scripts/count_step_instructions.py --stops, recorded as count_step_instructions_damping.json)."""

from _readme_format import command_note, pct, sci, sig, table

LINK_LABELS = {  # variant -> what it is
    "rigid": "MuJoCo joint limit",
    "damped": "element stop, damped (`time_constant`, `damping_ratio`)",
    "derived": "element stop, conservative, derived (100 K_ii)",
    "stiff": "element stop, conservative, too stiff for the step",
}
FINGER_LABELS = {  # variant -> what it is
    "rigid": "rigid: joint spring with `springref`, coupler's joint limit",
    "rest": "element with a rest pose, coupler's joint limit",
    "no rest": "element without a rest pose, coupler's joint limit",
    "rest+stop": "element with a rest pose, coupler's element stop",
}


def _stop(r):
    s = r["stop"]
    if "solref" in s:
        return f"`solref` {s['solref'][0]:g} {s['solref'][1]:g}"
    damping = f", b {sig(s['damping'], 3)} N m s/rad" if s["damping"] else ""
    return f"k {sig(s['stiffness'], 3)} N m/rad{damping} (ω h {s['omega_h']:.2f})"


def block_stop_bounces(results):
    """The link dropped into its stop: each variant's bounces, their energy losses, and a nudge's growth."""
    r = results["stops_and_preload"]
    p = r["parameters"]
    body = []
    for variant, label in LINK_LABELS.items():
        x = r["link"][variant]
        depths = ", ".join(sig(d, 2) for d in x["rebounds_rad"][:5]) + (", …" if len(x["rebounds_rad"]) > 5 else "")
        losses = ", ".join(sci(v, 2) for v in x["bounce_losses_J"][:4])
        body.append([label, _stop(x), str(len(x["rebounds_rad"])), depths, losses, sci(x["energy_lost_J"], 3),
                     sci(x["nudge_after_1s_rad"], 1) if x["nudge_after_1s_rad"] else "0"])  # fmt: skip
    head = ["stop", "law", "bounces", "their depths [rad]", "energy lost by the first four [J]",
            "energy lost in 1 s [J]", "a 1e-9 rad nudge after 1 s [rad]"]  # fmt: skip
    return (
        f"{command_note(r)}: MuJoCo's Euler at a {p['step_s'] * 1e3:g} ms step, the link released "
        f"{p['upper_rad'] - p['release_rad']:g} rad from its stop; a bounce lifts the link's tip by more than 0.1 mm "
        f"({sig(p['bounce_rad'], 2)} rad).\n\n" + table(head, body)
    )


def block_stop_preload(results):
    """The finger closed by its driver: each variant's pad path from the rigid finger's, and its tilt."""
    r = results["stops_and_preload"]
    body = []
    for name, x in r["finger"].items():
        variant, step = name.split(" at ")
        body.append([FINGER_LABELS[variant], step, f"{x['solref_s'] * 1e3:g} ms", f"{x['path_from_rigid_m'] * 1e3:.2g}",
                     sig(x["largest_tilt_rad"], 2), f"{x['closed_m'] * 1e3:.1f}"])  # fmt: skip
    head = ["finger", "step", "`solref` / `time_constant`", "pad path from the rigid finger's, largest [mm]",
            "pad's largest tilt [rad]", "closed [mm]"]  # fmt: skip
    return f"{command_note(r)}:\n\n" + table(head, body)


def inline_stop_damping_instructions(results):
    """The instruction counts of ARCADE's step before damping and rest poses, after, and with damped stops engaged."""
    r = results["count_step_instructions_damping"]
    rows = {row["case"]: row["per_step"] for row in r["rows"]}
    evaluations = r["elements"] * r["evaluations_per_step"]
    base, model = rows["model, baseline library"], rows["model"]
    engaged, damped = rows["stops, engaged"], rows["stops, engaged, damped"]
    return (
        f"`{r['command']}` (recorded {r['date'][:10]}, {r['steps']} steps; the baseline is a source tree of the "
        f"code before stop damping and rest poses): {_count(base)} instructions per step before, {_count(model)} "
        f"after ({'+' if model >= base else ''}{pct(model / base - 1)}); with every stop engaged "
        f"{_count(engaged)}, and damped {_count(damped)} (+{pct(damped / engaged - 1)}, "
        f"{sig((damped - engaged) / evaluations, 2)} instructions per element evaluation)"
    )


def _count(n):
    return f"{round(n):,}".replace(",", " ")

"""Page text of scripts/results_blocks.py for the reduction of robots to the file's step (scripts/reduce_robots.py)."""

from _readme_format import machines_note, pct, sci, sig, table


def _cost(row):
    return f"{sig(row['ratio_median'], 3)}× ({sig(row['ratio_min'], 3)}–{sig(row['ratio_max'], 3)})"


def block_reduce_robots(results):
    r = results["reduce_robots"]
    head = ["scene", "step (integrator)", "nv rigid / full / reduced", "advised step (at rest): full / reduced",
            "modes below the band: error", "statics: error", "cost per simulated s, reduced / rigid",
            "full model at its step / rigid", "against the full model's run: reduced (rigid)", "10 s run"]  # fmt: skip
    rows = []
    for name, row in r["rows"].items():
        nv, ref = row["nv"], row["reference"]
        statics = max(s["relative"] for s in row["statics"])
        rows.append([name, f"{sig(row['step'] * 1e3, 3)} ms ({row['integrator']})",
                     f"{nv['rigid']} / {nv['full']} / {nv['reduced']}",
                     f"{sci(row['full_advised_step'])} s / {sci(row['reduced_advised_step'])} s",
                     pct(row["modes"]["max_relative_error"]), pct(statics), _cost(row["cost"]["reduced"]),
                     _cost(row["cost"]["full"]),
                     f"{pct(ref['relative_error'])} ({pct(ref['rigid_relative_error'])})",
                     "finite" if row["run"]["finite"] else "diverged"])  # fmt: skip
    notes = []
    for name, row in r["rows"].items():
        if row.get("needed"):
            n = row["needed"]
            notes.append(f"{name}: at the file's step the reduction holds rigid {n['element']} {n['direction']}, "
                         f"which the modes below the band need (a `ReductionWarning` says so); the largest step that "
                         f"keeps it is {sci(n['largest_step'], 3)} s, the next row.")  # fmt: skip
    reference = next(iter(r["rows"].values()))["reference"]["seconds"]
    return (
        f"`{r['command']}` (recorded {r['date'][:10]}, {r['script_wall_s']:.0f} s; cost ratios: medians (min–max) of "
        f"interleaved repeats, each an equal stretch of simulated time of the scene's actuated run; against the full "
        f"model's run: the largest distance of a part's centre over {reference:g} s of the actuated run, from the "
        f"same state, over the largest distance a part moved):\n\n"
        + table(head, rows)
        + "\n"
        + "\n".join(notes)
        + "\n"
        + "\n"
        + machines_note(results, ["reduce_robots"])
    )

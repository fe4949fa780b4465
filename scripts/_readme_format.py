"""Number and table formatting of scripts/results_blocks.py (page text from recorded JSON)."""

import statistics


def sci(x, digits=2):
    """``3e-5``, ``3.2e-5``: a short scientific notation (``digits`` significant digits at most)."""
    mantissa, exponent = f"{x:.{digits - 1}e}".split("e")
    return f"{mantissa.rstrip('0').rstrip('.')}e{int(exponent)}"


def sig(x, digits=2):
    """``x`` to ``digits`` significant digits (whole numbers from ``10**digits`` on; an exponent below 1e-3)."""
    if abs(x) >= 10**digits:
        return f"{x:.0f}"
    if x == 0 or abs(x) >= 1e-3:
        return f"{x:.{digits}g}"
    return sci(x)


def pct(x, digits=2):
    """A relative value as percent: ``0.0213`` -> ``2.1 %``."""
    return f"{sig(100 * x, digits)} %"


def spread(row, key="ratio"):
    """``median× (min–max)`` of a row of scripts/_bench.py's ``compare``."""
    return f"{row[key + '_median']:.2f}× ({row[key + '_min']:.2f}–{row[key + '_max']:.2f})"


def times(median, row=None, key=None, fmt=None):
    """``median×``, followed by `` (min–max)`` where ``row`` records the spread of ``key`` (``{key}_q1`` ...).

    For ratios that older JSON recorded without a spread (rendered as before) and newer JSON with one.
    ``fmt`` formats a number (default two decimals).
    """
    fmt = fmt or (lambda x: f"{x:.2f}")
    text = f"{fmt(median)}×"
    if row and f"{key}_q1" in row:  # recorded by scripts/_bench.py with its repeats (older JSON: min-max at most)
        text += f" ({fmt(row[key + '_min'])}–{fmt(row[key + '_max'])})"
    return text


def cost_ratio(row):
    """A timing row's median same-repeat ratio, with its min–max where the row carries its repeats' spread."""
    return times(row["ratio_median"], row, "ratio")


def machine_of(r):
    """``CPU model, N logical cores`` of a recorded JSON; '' where it was recorded without (older JSON)."""
    m = r.get("machine", {})
    return f"{m['cpu_model']}, {m['logical_cores']} logical cores" if "cpu_model" in m else ""


def load_of(r):
    """``a → b``: the 1-minute load average when the script started and when it wrote its JSON."""
    m = r["machine"]
    return f"{m['load_average_1min_before']:.1f} → {m['load_average_1min_after']:.1f}"


def timed_on(r):
    """``on CPU, N logical cores (R repeats, 1-minute load average a → b)``; '' for JSON without the machine."""
    if not machine_of(r):
        return ""
    how = repeats_note(r)
    return f"on {machine_of(r)} ({how + ', ' if how else ''}1-minute load average {load_of(r)})"


def repeats_note(r):
    """``N fresh processes × R interleaved repeats`` (or ``R interleaved repeats``) of a recorded JSON's timings."""
    rows = list(_timing_rows(r))
    if not rows or "repeats" not in rows[0]:
        return ""
    repeats, processes = rows[0]["repeats"], r.get("processes", 1)
    return f"{processes} fresh processes × {repeats} interleaved repeats" if processes > 1 else f"{repeats} repeats"


def machines_note(results, names):
    """One sentence naming the machine (once per machine) and, per JSON, its repeats and load; '' if none recorded."""
    by_machine = {}
    for name in names:
        if name in results and machine_of(results[name]):
            by_machine.setdefault(machine_of(results[name]), []).append(name)
    if not by_machine:
        return ""
    parts = []
    for machine, recorded in by_machine.items():
        each = ", ".join(f"`{n}` ({repeats_note(results[n])}, load {load_of(results[n])})" for n in recorded)
        parts.append(f"{machine}: {each}")
    missing = [f"`{n}`" for n in names if n in results and not machine_of(results[n])]
    rest = f"; not recorded for {join_and(missing)}" if missing else ""
    return (
        f"Timed on {'; '.join(parts)}{rest}. Each ratio is the median (min–max) of the same-repeat ratios of all "
        "repeats (1-minute load average: when the script started → when it wrote its JSON).\n"
    )


def same_repeat(row, other, key):
    """``{key}_median, _q1, _q3, _min, _max`` of ``row / other`` repeat by repeat (ratios to a common baseline).

    ``{}`` for rows recorded without their repeats (older JSON).
    """
    if "ratios" not in row or "ratios" not in other:
        return {}
    r = [a / b for a, b in zip(row["ratios"], other["ratios"], strict=True)]
    q1, median, q3 = statistics.quantiles(r, n=4, method="inclusive") if len(r) > 1 else (r[0],) * 3
    return {f"{key}_median": median, f"{key}_q1": q1, f"{key}_q3": q3, f"{key}_min": min(r), f"{key}_max": max(r)}


def _timing_rows(payload):
    if isinstance(payload, dict):
        if "ratio_median" in payload:
            yield payload
            return
        for value in payload.values():
            yield from _timing_rows(value)


def duration(seconds):
    return f"{seconds:.0f} s" if seconds < 120 else f"{seconds / 60:.0f} min"


def command_note(r):
    """```command``` (date, wall time): how and when a JSON was recorded."""
    wall = r.get("script_wall_s", r.get("wall_s", r.get("command_wall_s")))
    return f"`{r['command']}` ({r['date'][:10]}{', ' + duration(wall) if wall else ''})"


def table(head, rows):
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    return "\n".join(lines + ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]) + "\n"


def join_and(names):
    return " and ".join([", ".join(names[:-1]), names[-1]] if len(names) > 1 else names)

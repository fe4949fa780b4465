"""Number and table formatting of scripts/readme_results.py (README text from recorded JSON)."""


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

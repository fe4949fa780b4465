"""The Pareto plot of a study: cost against error, one marker per candidate, the front drawn."""

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

from ._options import who

MARKERS = {"rk4": "o", "euler": "s", "implicitfast": "^", "implicit": "v", "discrete": "D"}


def pareto_plot(result, path):
    """Write the plot of ``result`` (a :class:`StudyResult`) to ``path`` (PNG); returns ``path``.

    x: pose error against the reference (log); y: wall seconds per simulated second (log).
    Colour: variant and method; marker: integrator. Diverged and skipped candidates are drawn
    as crosses in a strip at the right, at their cost where it was measured. The grey band is
    the reference's own error, below which errors are not resolved.
    """
    fig, ax = plt.subplots(figsize=(11, 6), dpi=110)
    ok = result.ok_rows()
    groups = sorted({(r.variant, r.method) for r in result.rows})
    colors = {g: plt.cm.tab10(i % 10) for i, g in enumerate(groups)}
    floor = result.floor
    errors = [max(r.pose_error, floor * 0.5, 1e-16) for r in ok]
    seen = set()
    for r, e in zip(ok, errors, strict=True):
        key = (r.variant, r.method, r.integrator)
        label = None if key in seen else who(r.variant, r.integrator, r.method)
        seen.add(key)
        ax.scatter(e, r.cost, marker=MARKERS.get(r.integrator, "o"), color=colors[(r.variant, r.method)],
                   edgecolor="k" if r.model_setting else "none", s=70 if r.model_setting else 36, label=label,
                   zorder=3)  # fmt: skip
    front = sorted((r for r in ok if r.pareto), key=lambda r: r.cost)
    if front:
        xs = [max(r.pose_error, floor * 0.5, 1e-16) for r in front]
        ax.step(xs, [r.cost for r in front], where="pre", color="k", lw=1.2, label="Pareto front",
                zorder=2)  # fmt: skip
        for r, x in zip(front, xs, strict=True):
            ax.annotate(f"{r.integrator} {r.timestep:.2g}", (x, r.cost), textcoords="offset points",
                        xytext=(4, 4), fontsize=7)  # fmt: skip
    xmax = max(errors, default=1.0)
    xmin = min(errors, default=1e-6)
    bad = [r for r in result.rows if r.status != "ok"]
    if bad:
        strip = max(xmax, 1.0) * 10
        bad = [r for r in bad if r.cost]  # cost over the steps taken before it stopped
        ax.scatter(
            [strip] * len(bad), [r.cost for r in bad], marker="x", color="0.5", label="diverged / skipped", zorder=3
        )
        ax.axvline(strip / 3, color="0.8", lw=0.8)
        ax.annotate("diverged /\nskipped", (strip, 1.0), xycoords=("data", "axes fraction"), xytext=(0, -4),
                    textcoords="offset points", ha="center", va="top", fontsize=7, color="0.4")  # fmt: skip
        xmax = strip
    ref = result.reference
    if ref is not None and ref.cost:
        ax.scatter(max(ref.error_estimate or floor, 1e-16), ref.cost, marker="*", s=160, color="gold",
                   edgecolor="k", label=f"reference (RK4, h = {ref.timestep:.2g} s)", zorder=4)  # fmt: skip
        xmin = min(xmin, max(ref.error_estimate or floor, 1e-16))
    if floor > 0:
        ax.axvspan(min(xmin, floor) / 3, floor, color="0.9", zorder=0, label="within the reference's error")
    for target in result.targets:
        ax.axvline(target, color="tab:red", ls=":", lw=0.8)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlim(min(xmin, floor or xmin) / 3, xmax * 3)
    ax.set_xlabel("pose error against the reference (relative to the motion)")
    ax.set_ylabel(f"{'CPU' if result.clock == 'cpu' else 'wall'} seconds of mj_step per simulated second")
    ax.set_title(f"{result.model}: speed vs accuracy ({result.duration * 1e3:.3g} ms from {result.initial_state})",
                 fontsize=10)  # fmt: skip
    ax.grid(True, which="major", alpha=0.3)
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return path

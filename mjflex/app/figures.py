"""Figures of a run: rendered frames with a colour bar, energies and the stroke against time.

Drawn with matplotlib's object-oriented API (a ``Figure`` saved with ``savefig``), so the
user's pyplot backend is left as it is; matplotlib is imported on the first figure. Every
function returns the figure it saved, so that its content can be checked.
"""

import numpy as np

from .render import ColourScale, strain_colors

#: Units of an energy axis, by size: (factor from joules, name).
_ENERGY_UNITS = ((1.0, "J"), (1e3, "mJ"), (1e6, "µJ"), (1e9, "nJ"))


def _figure(**kwargs):
    """A matplotlib figure that needs no pyplot backend (saved with ``fig.savefig``)."""
    from matplotlib.figure import Figure  # late: matplotlib, only when a figure is drawn

    return Figure(**kwargs)


def strain_colormap():
    """The colours of :func:`mjflex.app.render.strain_colors` from 0 to 1 as a matplotlib colormap."""
    from matplotlib.colors import ListedColormap  # late: matplotlib, only when a figure is drawn

    return ListedColormap(strain_colors(np.linspace(0.0, 1.0, 256), 1.0)[:, :3], name="mjflex_strain")


def panel_figure(path, images, times, title, scale: ColourScale | None = None, caption=None):
    """Rendered frames in a grid of three columns (the paper's Fig. 4), each titled with its time.

    ``images``: ``(H, W, 3)`` uint8 frames; ``times`` [s]; ``scale``: the colours' meaning, drawn
    as a colour bar in its unit (none if None); ``caption``: a line under the frames.
    """
    from matplotlib.cm import ScalarMappable  # late: matplotlib, only when a figure is drawn
    from matplotlib.colors import Normalize  # late: matplotlib, only when a figure is drawn

    rows = -(-len(images) // 3)
    aspect = images[0].shape[0] / images[0].shape[1]
    fig = _figure(figsize=(12, rows * (3.6 * aspect + 0.35) + 0.6 + 0.25 * (caption or "").count("\n")),
                  layout="constrained")  # fmt: skip
    axes = fig.subplots(rows, 3, squeeze=False)
    for ax, image, t in zip(axes.ravel(), images, times, strict=False):
        ax.imshow(image)
        ax.set_title(f"t = {t * 1e3:.1f} ms", fontsize=10)
        ax.set_axis_off()
    for ax in axes.ravel()[len(images) :]:
        ax.set_visible(False)
    if scale is not None:
        mappable = ScalarMappable(Normalize(0.0, scale.vmax * scale.factor), strain_colormap())
        bar = fig.colorbar(mappable, ax=axes, shrink=0.85, fraction=0.04, pad=0.01)
        bar.set_label(f"{scale.short} [{scale.unit}]", fontsize=10)
    fig.suptitle(title)
    if caption:
        fig.supxlabel(caption, fontsize=9)
    fig.savefig(path, dpi=110)
    return fig


def _energy_unit(values):
    """(factor, name) that shows ``values`` [J] with a largest magnitude between 0.1 and 1000."""
    top = float(np.nanmax(np.abs(values))) if np.size(values) else 0.0
    return next((unit for unit in _ENERGY_UNITS if top * unit[0] >= 0.1), _ENERGY_UNITS[-1])


def energy_plot(path, run, title):
    """Potential, dissipated and kinetic energy (top) and the balance error (bottom) against time."""
    t = run.array("time") * 1e3
    kinetic, mujoco_potential = run.array("kinetic"), run.array("mujoco_potential")
    potential, dissipated = run.array("flexure_potential") + mujoco_potential, run.array("dissipated")
    total = kinetic + potential
    balance = total + dissipated - total[0]
    fig = _figure(figsize=(8, 6), layout="constrained")
    a, b = fig.subplots(2, 1, sharex=True)
    f, unit = _energy_unit(np.concatenate([potential, dissipated, kinetic - kinetic[0]]))
    mujoco_too = bool(np.any(mujoco_potential != 0))
    a.plot(t, f * potential, label="potential energy (flexures + MuJoCo)" if mujoco_too else "flexures' elastic energy")
    a.plot(t, f * dissipated, label="dissipated by the flexures' damping")
    a.plot(t, f * (kinetic - kinetic[0]), label=f"kinetic energy − its initial {kinetic[0]:.5g} J")
    a.set_ylabel(f"energy [{unit}]")
    a.legend(loc="upper left", fontsize=8)
    a.grid(alpha=0.3)
    a.set_title(title)
    g, unit = _energy_unit(balance)
    b.plot(t, g * balance, color="k")
    b.set_ylabel(f"balance error [{unit}]\n(E + dissipated − E(0))")
    b.set_xlabel("time [ms]")
    b.grid(alpha=0.3)
    fig.savefig(path, dpi=110)
    return fig


def stroke_plot(path, run, title):
    """Axial position of the tracked body (the cylinder) relative to the reference body (the base) against time."""
    fig = _figure(figsize=(8, 3.5), layout="constrained")
    ax = fig.subplots()
    ax.plot(run.array("time") * 1e3, run.array("stroke") * 1e3)
    ax.set_xlabel("time [ms]")
    ax.set_ylabel("cylinder stroke [mm]\n(along the base's axis)")
    ax.set_title(title)
    ax.grid(alpha=0.3)
    fig.savefig(path, dpi=110)
    return fig

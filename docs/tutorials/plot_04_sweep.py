"""
A parameter sweep
=================

Stiffness, damping and tolerance studies run many variants of one model. :func:`mjflex.sweep` builds each variant
from a :class:`mjflex.Recipe` — a model file plus an ``edit(spec, **params)`` — simulates it, calls your
``observe(model, flex, data)`` and returns an `xarray <https://xarray.dev>`_ ``Dataset`` over the grid. Here:
the two-body model's hinge stiffness and its Rayleigh damping ``B = beta K``, 3 × 3 variants.
"""

# %%
# The recipe
# ----------
# ``edit`` changes one variant's :class:`mujoco.MjSpec` before it is compiled; :func:`mjflex.app.sweep.flexure_matrices`
# and :func:`mjflex.app.sweep.edit_flexure` read and rewrite an element's ``K`` and ``B``. Define both functions at
# the top level of a module when the sweep runs in other processes (they are pickled).
import warnings
from pathlib import Path

import matplotlib.pyplot as plt
import mujoco

import mjflex
from mjflex.app.sweep import edit_flexure, flexure_matrices

MODELS = Path("models") if Path("models").is_dir() else Path("../../models")  # the checkout's (run in docs/tutorials)


def stiffness_and_damping(spec, k_scale, beta):
    K, _ = flexure_matrices(spec, "hinge")
    edit_flexure(spec, "hinge", K=k_scale * K, B=beta * k_scale * K)


def swing(model, flex, data):  # run on the worker at every sample
    return {"angle": flex.displacements(data)[0, 2], "energy": flex.potential_energy(data)}


recipe = mjflex.Recipe(str(MODELS / "two_body.xml"), stiffness_and_damping, keyframe="swing")

# %%
# The sweep
# ---------
# A dict of values runs every combination (one dimension per parameter). By default the variants are stepped
# together by MuJoCo's ``mujoco.batch.Batch`` in this process; ``executor=`` takes a process pool or Dask
# (:doc:`/howto/sweeps_on_a_cluster`), with bit-identical results.
#
# Two of these variants diverge, on purpose (below). MuJoCo prints a warning when a simulation diverges, and the
# sweep warns once with the count; here both are collected, to be shown as what they are.
grid = {"k_scale": [0.5, 1.0, 2.0], "beta": [0.0, 2e-4, 2e-3]}
mujoco_warnings = []
mujoco.set_mju_user_warning(mujoco_warnings.append)  # MuJoCo's warnings into a list instead of its log
try:
    with warnings.catch_warnings(record=True) as sweep_warnings:
        warnings.simplefilter("always")
        ds = mjflex.sweep(recipe, grid, 0.05, swing, samples=101, progress=False)
finally:
    mujoco.set_mju_user_warning(None)  # MuJoCo's default again: print, and append to MUJOCO_LOG.TXT
shown = ds[["angle", "status"]]
shown.attrs = {}  # ds.attrs records how it was made: the recipe (with the model file's full path), grid, options
print(shown)
print("mjflex warned:", *(str(w.message) for w in sweep_warnings))
print(f"MuJoCo warned {len(mujoco_warnings)} times, first: {mujoco_warnings[0]}")

# %%
# Every variant has a ``status`` (``ok``, ``diverged`` or ``failed``, with the element and time in ``error``,
# ``element`` and ``time_diverged``); a diverged variant never stops the sweep, and its values are NaN.
print(ds["status"].to_pandas())
failed = ds.where(ds["status"] == "diverged", drop=True)
if failed.sizes["k_scale"]:
    first = failed.isel(k_scale=0, beta=0)
    print(f"k_scale {float(first.k_scale):g}, beta {float(first.beta):g}:", str(first["error"].values)[:300])

# %%
# The largest damping diverged with the stiffer hinges: ``B = beta K`` damps the element's stiff translational
# directions too (rate ``beta omega^2``), and MuJoCo's integrators take the flexures' damping explicitly, so the
# step must resolve that rate as well (:doc:`/howto/choose_method_integrator_step`).

# %%
# The result
# ----------
# Labelled selection makes the plot short: block B spins about the hinge axis and swings back at the hinge's
# frequency, which grows with the square root of the stiffness.
fig, axes = plt.subplots(1, 3, figsize=(10, 3.2), layout="constrained", sharey=True)
for ax, beta in zip(axes, ds["beta"].values, strict=True):
    for k_scale in ds["k_scale"].values:
        angle = ds["angle"].sel(k_scale=k_scale, beta=beta)
        ok = str(ds["status"].sel(k_scale=k_scale, beta=beta).values) == "ok"
        ax.plot(ds["time"] * 1e3, angle, label=f"K × {k_scale:g}" + ("" if ok else " (diverged)"))
    ax.set(xlabel="time [ms]", title=f"beta = {beta:g} s")
axes[0].set_ylabel("hinge rotation [rad]")
for ax in axes:
    ax.legend(fontsize="small")

# %%
# ``ds.to_netcdf("sweep.nc")`` keeps it; the ARCADE sweep of the command line (``python -m mjflex sweep``) is the
# same machinery on 16 variants of the guide.

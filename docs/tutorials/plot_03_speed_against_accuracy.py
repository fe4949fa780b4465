"""
Speed against accuracy with ``mjflex study``
============================================

How large a step can you take, with which integrator and element method, for the accuracy you need? ``mjflex
study`` measures it on *your* scene: it builds a converged reference, runs every candidate, and reports each
one's cost, its error against the reference and the largest stable step. Here a small run on the two-body model
(seconds), then the recorded study of the ARCADE guide.

The same from the command line, with a Markdown report, JSON and the Pareto plot written to ``out/``::

    python -m mjflex study models/two_body.xml --integrators rk4 euler --steps 1.2e-4 6e-5
"""

# %%
# A small study
# -------------
# Two integrators, two steps, both element methods; one timing round and no stability bisection keep it short (the
# defaults are 3 rounds and a bisection per method and integrator). The model's own variants (reduced, welded,
# pseudo-rigid-body) are skipped here: two bodies and one element leave nothing to reduce.
from pathlib import Path

import matplotlib.pyplot as plt

import mjflex

MODELS = Path("models") if Path("models").is_dir() else Path("../../models")  # the checkout's (run in docs/tutorials)
result = mjflex.study(
    str(MODELS / "two_body.xml"), integrators=("rk4", "euler"), steps=(1.2e-4, 6e-5), variants=[], bisect=0,
    repeat=1, progress=False,
)  # fmt: skip
print("\n".join(result.summary_lines()))

# %%
# The recommendation: for each error target, the cheapest candidate that meets it (costs are CPU seconds of
# ``mj_step`` per simulated second, measured in this run, so they vary with the machine).
print("\n".join(result.recommendation()))

# %%
# Every candidate
# ---------------
# ``result.rows`` holds one row per candidate (``result.records()`` gives plain dicts, e.g. for pandas). Pose error
# is relative to the motion; a diverged candidate would carry its element and step in ``divergence`` and no error.
fig, ax = plt.subplots(figsize=(6.5, 3.6), layout="constrained")
for row in result.ok_rows():
    marker = "o" if row.integrator == "rk4" else "s"
    color = "C0" if row.method == "twist" else "C1"
    ax.loglog(row.cost, row.pose_error, marker, color=color)
    ax.annotate(f"{row.timestep:.2g} s", (row.cost, row.pose_error), textcoords="offset points", xytext=(5, 3))
ax.plot([], [], "ko", label="RK4")
ax.plot([], [], "ks", label="Euler")
ax.plot([], [], "s", color="C0", label="twist")
ax.plot([], [], "s", color="C1", label="dual quaternion")
ax.set(xlabel="CPU s per simulated s", ylabel="pose error (relative)", title="two_body.xml: cost against error")
ax.legend(fontsize="small")

# %%
# The dual-quaternion runs differ from the (twist) reference by the difference between the two element *models*
# at finite rotations, not by integration error: compare methods at equal error only when both model your part
# well (:doc:`/background/methods`).
#
# On the ARCADE guide
# -------------------
# ``python -m mjflex study models/arcade.xml --out docs/study`` takes a few minutes; its recorded report is
# :doc:`/study/study_arcade` and its Pareto plot is below. How to read it and choose for your own model:
# :doc:`/howto/choose_method_integrator_step`.
#
# .. image:: /study/study_arcade.png
#    :alt: Pareto plot of the ARCADE study: cost against pose error for every candidate

"""
Fitting a large-deflection potential
====================================

A quadratic potential ``U = x^T K x / 2`` is exact only for small deflections. mjflex adds polynomial terms to it
and identifies them from (pose, wrench) samples of a test rig or of a finer model, by linear least squares. Here
the finer model is a leaf spring bent far beyond its linear range, computed as a chain of short elements (a
geometrically exact rod); one element is fitted to it, of orders 2, 4 and 6, and checked on loads it was not fitted to.

The full study (three slenderness ratios, orders up to 6, both element methods, held-out equilibria) is
``python scripts/fit_flexure.py``; its results are in :doc:`/background/large_deflections`.
"""

# %%
# The reference: a leaf as a chain of elements
# --------------------------------------------
# A steel leaf, 40 mm long and 4 mm thick (L/t = 10), clamped at its left end. :class:`mjflex.geometry.LeafChain`
# cuts it into 16 segments joined by planar twist elements and solves its statics under a tip load ``(M_z, F_x,
# F_y)`` by Newton's method.
import matplotlib.pyplot as plt
import numpy as np

import mjflex
from mjflex.geometry import LeafChain, leaf_spring_stiffness

L, t, b, E, nu = 0.040, 0.004, 0.008, 200e9, 0.3
chain = LeafChain(L, t, b, E, nu, n=16)
scale = np.array([chain.EI / L, chain.EI / L**2, chain.EI / L**2])  # loads that bend the leaf by about 1 rad


def tip_pose(load):
    try:
        return chain.solve(load)[-1]  # (theta, x, y) of the tip
    except RuntimeError:  # Newton did not converge in the default 4 load increments
        return chain.solve(load, steps=16)[-1]


def tip_poses(loads):
    return np.array([tip_pose(load) for load in loads])


# %%
# Samples
# -------
# The element's frame ``a`` sits on the clamp at the leaf's centre (at rest), frame ``b`` on the tip body at the same
# point; a sample is the pose of ``b`` in ``a`` and the wrench the element exerts on the tip body, which in
# equilibrium balances the tip load (moment taken about ``b``'s origin, in ``a``'s axes).


def element_sample(tip, load):
    c, s = np.cos(tip[0]), np.sin(tip[0])
    R = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    p_b = np.array([tip[1], tip[2], 0]) - R @ [L / 2, 0, 0]  # frame b's origin in the clamp's frame
    force = np.array([load[1], load[2], 0])
    moment = load[0] + np.cross([tip[1], tip[2], 0] - p_b, force)[2]
    return R, p_b - [L / 2, 0, 0], -np.array([0, 0, moment, force[0], force[1], 0])


rng = np.random.default_rng(1)
train = rng.uniform([-1.2, -0.5, -2.4], [1.2, 1.5, 2.4], (48, 3)) * scale
tips = tip_poses(train)
R_ab, p_ab, W = (np.array(x) for x in zip(*map(element_sample, tips, train), strict=True))
print(f"{len(train)} samples, tip rotations up to {np.degrees(np.abs(tips[:, 0]).max()):.0f} deg")

# %%
# The fit
# -------
# :func:`mjflex.fit_potential` fits ``K`` and the polynomial terms of the given order in the planar coordinates
# ``(tau_3, t_1, t_2)`` (``variables=(2, 3, 4)``), keeps only terms that respect the leaf's mirror symmetry
# (``y -> -y``), and weights wrench errors by the deflections they cause (the beam model's compliance).
K_beam = leaf_spring_stiffness(L, t, b, E, nu, method="beam")
weights = np.linalg.inv(np.linalg.cholesky(K_beam))
fits = {}
for order in (2, 4, 6):
    fits[order] = mjflex.fit_potential(
        R_ab, p_ab, W, order=order, variables=(2, 3, 4), wrench_frame="a", weights=weights, symmetries=[(1, -1, 1)]
    )
print(fits[6].summary())

# %%
# Held out: a transverse tip force
# --------------------------------
# A sweep of the tip force ``F_y`` the fit has not seen. At each of the chain's tip poses, the fitted element's
# wrench should balance the load. Its error is measured as the fit weighs it, by the deflection it causes
# (``weights`` maps a wrench to a deflection of the beam model), relative to the load's.
sweep = np.outer(np.linspace(0.1, 1, 8), [0, 0, 2.4]) * scale
held_tips = tip_poses(sweep)
R_t, p_t, W_t = (np.array(x) for x in zip(*map(element_sample, held_tips, sweep), strict=True))
models = {"beam theory K (linear)": (K_beam, None)} | {f"fitted, order {n}": (f.K, f.terms) for n, f in fits.items()}
fig, ax = plt.subplots(figsize=(6.5, 3.4), layout="constrained")
for label, (K, terms) in models.items():
    W_model = mjflex.wrench_on_b(np.eye(3), np.zeros(3), R_t, p_t, K, terms=terms)
    error = np.linalg.norm((W_model - W_t) @ weights.T, axis=1) / np.linalg.norm(W_t @ weights.T, axis=1)
    ax.semilogy(np.degrees(held_tips[:, 0]), error, "o-", label=label)
    print(f"{label}: largest error {error.max():.1%} (tip rotations up to {np.degrees(held_tips[-1, 0]):.0f} deg)")
ax.set(xlabel="tip rotation [deg]", ylabel="weighted wrench error / load", title="Leaf L/t = 10, transverse tip force")
ax.legend()

# %%
# The higher orders follow the leaf to large rotations where the quadratic potentials — the beam model's and the
# fitted one — do not: a straight leaf shortens as it bends, which a quadratic potential in the element's
# coordinates reads as a stretch and answers with a large axial force.
#
# Into a model it goes with its terms: ``mjflex.add_flexure(spec, "leaf", "A", "B", pos=..., K=fit.K,
# terms=fit.terms)`` writes them into the element's record, and :class:`mjflex.Flexures` evaluates them at every
# step. Restrict ``variables=`` to what the part needs: each term costs time at every step.

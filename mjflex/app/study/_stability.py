"""Stability beyond the scene: the advised limit of a time step, the mode that sets it, and perturbed runs.

The bisection of :mod:`._sweep` finds the largest step at which *the study's scene* stays finite.
A mode the scene never excites cannot diverge there, however unstable the step is for it: the
planar swing of ``models/two_body.xml`` never moves its stiffest (out-of-plane, 1882 Hz) mode,
so its scene runs RK4 at 1.14x the step that mode allows, and a velocity perturbation of 1e-6
diverges within the study's run. Two checks make the recommended limit hold for any motion:

* the **advised limit**: :func:`mjflex.step_advice`'s, at the scene's initial pose at rest (MuJoCo's
  own step linearized there, with its implicit terms, whatever they are; stable while it grows by at
  most 2x over the study's duration), bisected as closely as the measured one (the study's
  ``limit_rtol``). The mode that sets it is named by :func:`limiting_mode`: its natural frequency,
  the element direction (or joint spring) storing most of its strain energy, and the share of the
  scene's initial energy it carries.
* **perturbed runs**: the scene with a random velocity perturbation whose kinetic energy is
  ``PERTURBATION**2`` of the scene's energy swing (a relative amplitude of 1e-6, which excites
  every mode) at the recommended step, the smaller of the two limits (halved until it runs
  through, at most ``MAX_HALVINGS`` times), and, where the advised limit is the smaller, at the
  measured limit, to show that it diverges there.
"""

import math
import warnings

import mujoco
import numpy as np

from ...analysis.advice import advise
from ...analysis.advice import integrator_name as advice_name
from ...analysis.directions import element_directions
from ...analysis.linearize import NotAtRestWarning, Options, linearize, mass_at, modes_of

#: Relative velocity amplitude of the perturbed runs (kinetic energy PERTURBATION**2 of the scene's).
PERTURBATION = 1e-6
#: Largest nv for which the advised limit is computed: each trial step costs 4 nv steps and the
#: eigenvalues of a (2 nv, 2 nv) matrix (ARCADE, nv 210: ~0.5 s on a 2-core machine).
MAX_NV = 1000
#: Most halvings of the recommended step when a perturbed run diverges there.
MAX_HALVINGS = 3
#: Everything MuJoCo's step counts (the advice's default).
EVERYTHING = Options(True, "spring", True, True)


def advised_limit(sim, integrator, method, guess, rtol, duration):
    """``(StepAdvice or None, last step tried, why none)``: :func:`mjflex.step_advice` for ``integrator`` at the
    scene's initial pose at rest (its controls, activations and mocap poses), the elements' ``method`` configured,
    bisected from ``guess`` to ``rtol``, stable meaning at most 2x growth over ``duration`` beyond the model's own
    physical growth. The scene's start need not be at rest: the advice's warning about it is not repeated here."""
    sim.configure(integrator, method, guess)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", NotAtRestWarning)
        return advise(sim.model, sim.flex, sim.reset(rest=True), advice_name(integrator, sim.model), EVERYTHING,
                      rtol=rtol, horizon=duration, guess=guess, expand=12, warn=False, margin=False)  # fmt: skip


def _scene_share(sim, k, w2, phi, M):
    """Share of the scene's initial energy (kinetic, and elastic from the initial forces) in mode ``k`` (``w2``,
    ``phi``: the undamped modes, ``M`` the inertia)."""
    d = sim.reset(rest=True)
    with sim.flex:
        mujoco.mj_forward(sim.model, d)
        force = M @ d.qacc  # generalized force at the initial pose at rest
    v0 = sim.state["qvel"]
    elastic = w2 > 1e-12 * w2.max(initial=0.0)
    modal_v, modal_f = phi.T @ M @ v0, phi.T @ force
    energy = 0.5 * modal_v**2
    energy[elastic] += 0.5 * modal_f[elastic] ** 2 / w2[elastic]
    total = float(energy.sum())
    return float(energy[k] / total) if total > 0 else 0.0


def limiting_mode(sim, advice):
    """What diverges first above the advised limit (``advice``, a :class:`mjflex.StepAdvice`).

    Returns a dict: ``frequency_hz`` (``|lambda| / 2 pi`` of the limiting eigenvalue) and ``oscillating``
    (``|Im lambda| >= |Re lambda|``; else a damping-limited motion); ``where``: the element
    principal direction (``"element 'hinge' z"``) or joint spring storing the largest part of
    its strain energy, ``share`` that part and ``kind`` ``"strain"``, or, where elements and
    joint springs hold less than half of it (equality constraints, e.g. welds), the body with
    the largest part of its kinetic energy (``kind`` ``"kinetic"``); ``scene_share``: the part
    of the scene's initial energy in the natural mode closest to it.
    """
    m = sim.model
    lam, mode = advice.eigenvalue, advice.mode
    lin = linearize(m, sim.flex, sim.reset(rest=True), EVERYTHING, dynamics=True)  # at the initial pose at rest
    M, K = lin.M, lin.K
    parts = {}
    if sim.has_flexures:
        for d in element_directions(m, sim.flex, qpos=sim.state["qpos"]):
            for i, label in enumerate(d.labels):
                parts[f"element '{d.element}' {label}"] = 0.5 * d.k[i] * abs(d.J[i] @ mode) ** 2
    for jnt in range(m.njnt):
        if m.jnt_type[jnt] in (mujoco.mjtJoint.mjJNT_HINGE, mujoco.mjtJoint.mjJNT_SLIDE) and m.jnt_stiffness[jnt] > 0:
            name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, jnt) or f"#{jnt}"
            parts[f"joint '{name}'"] = 0.5 * m.jnt_stiffness[jnt] * abs(mode[m.jnt_dofadr[jnt]]) ** 2
    strain = 0.5 * float(mode @ (0.5 * (K + K.T)) @ mode)
    if parts and strain > 0 and sum(parts.values()) > 0.5 * strain:
        where, kind = max(parts, key=parts.get), "strain"
        share = parts[where] / sum(parts.values())
    else:
        bodies = np.bincount(m.dof_bodyid, np.abs(mode * (M @ mode)), minlength=m.nbody)  # kinetic, per body
        b = int(np.argmax(bodies))
        where, kind = f"body '{mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b)}'", "kinetic"
        share = float(bodies[b] / max(bodies.sum(), 1e-300))
    w2, phi = modes_of(lin)
    k = int(np.argmax(np.abs(phi.T @ M @ mode)))
    return {"frequency_hz": float(abs(lam) / (2.0 * np.pi)), "oscillating": bool(abs(lam.imag) >= abs(lam.real)),
            "where": where, "share": float(share), "kind": kind,
            "scene_share": _scene_share(sim, k, w2, phi, M)}  # fmt: skip


def perturbation(sim, energy, seed=0):
    """A random velocity (nv,) with kinetic energy ``PERTURBATION**2 * energy`` at the initial pose."""
    M = mass_at(sim.model, sim.reset(rest=True))
    v = np.random.default_rng(seed).normal(size=sim.model.nv)
    kinetic = 0.5 * float(v @ M @ v)
    return v * math.sqrt(PERTURBATION**2 * energy / kinetic) if kinetic > 0 else v * 0.0

"""Stability beyond the scene: the linear limit of a time step, the mode that sets it, and perturbed runs.

The bisection of :mod:`._sweep` finds the largest step at which *the study's scene* stays finite.
A mode the scene never excites cannot diverge there, however unstable the step is for it: the
planar swing of ``models/two_body.xml`` never moves its stiffest (out-of-plane, 1882 Hz) mode,
so its scene runs RK4 at 1.14x the step that mode allows, and a velocity perturbation of 1e-6
diverges within the study's run. Two checks make the recommended limit hold for any motion:

* the **linear limit**: the one-step map of the model linearized at the scene's initial pose at
  rest (central differences of ``mj_step`` over positions and velocities, so it is MuJoCo's own
  integrator with its implicit terms, whatever they are) is stable while it grows by at most
  2x over the study's duration (``NOISE_TOL``); a bisection over the step brackets that limit as
  closely as the measured one (the study's ``limit_rtol``). The mode whose eigenvalue leaves
  the unit circle there is named by :func:`limiting_mode`: its natural frequency, the element
  direction (or joint spring) storing most of its strain energy, and the share of the scene's
  initial energy it carries.
* **perturbed runs**: the scene with a random velocity perturbation whose kinetic energy is
  ``PERTURBATION**2`` of the scene's energy swing (a relative amplitude of 1e-6, which excites
  every mode) at the recommended step, the smaller of the two limits (halved until it runs
  through, at most ``MAX_HALVINGS`` times), and, where the linear limit is the smaller, at the
  measured limit, to show that it diverges there.
"""

import math

import mujoco
import numpy as np
import scipy.linalg

from ...analysis.directions import element_directions
from ._metrics import jacobian

#: A one-step map whose spectral radius ``rho`` satisfies ``ln rho <= growth h + max(ln 2 h / duration,
#: NOISE_TOL)`` is stable: beyond the model's own physical growth rate ``growth`` (0 at a stable
#: equilibrium), the linearized model may grow by at most a factor 2 over the study's duration,
#: the horizon of the measured limit too. Past a sharp explicit limit the radius rises steeply
#: (RK4 by ~2.5 per unit of omega h, symplectic Euler by the square root of the excess), so the
#: threshold hardly moves it; it matters where a scheme grows weakly at every step (RK4 on
#: MuJoCo's soft weld constraints: ln rho ~ 2e4 h^2 for two_body's welded variant).
#: NOISE_TOL: the finite-difference noise of the map, ~1e-6 on models/two_body.xml (its six
#: rigid-body modes' double eigenvalue 1 splits by the square root of the noise).
NOISE_TOL = 2e-5
#: Relative velocity amplitude of the perturbed runs (kinetic energy PERTURBATION**2 of the scene's).
PERTURBATION = 1e-6
#: Largest nv for which the linear limit is computed: each trial step costs 4 nv steps and the
#: eigenvalues of a (2 nv, 2 nv) matrix (ARCADE, nv 210: ~0.5 s on a 2-core machine).
MAX_NV = 1000
#: Most halvings of the recommended step when a perturbed run diverges there.
MAX_HALVINGS = 3
_EPS = 1e-6  # finite-difference step of the one-step map [rad, m, rad/s, m/s]


def _rest(sim):
    d = sim.data
    mujoco.mj_resetData(sim.model, d)
    for key, value in sim.state.items():
        getattr(d, key)[:] = value
    d.qvel[:] = 0.0
    return d


def step_map(sim, integrator, method, h):
    """``(2 nv, 2 nv)`` Jacobian of one ``mj_step`` of ``h`` over ``(qpos tangent, qvel)``, initial pose at rest.

    Actuator activations, controls and mocap poses stay at their initial values (not part of the map).
    """
    sim.configure(integrator, method, h)
    m, nv = sim.model, sim.model.nv
    T = np.zeros((2 * nv, 2 * nv))
    with sim.flex:
        for col in range(2 * nv):
            out = []
            for sign in (1.0, -1.0):
                d = _rest(sim)
                dx = np.zeros(nv)
                dx[col % nv] = sign * _EPS
                if col < nv:
                    mujoco.mj_integratePos(m, d.qpos, dx, 1.0)
                else:
                    d.qvel[:] = dx
                mujoco.mj_step(m, d)
                out.append((d.qpos.copy(), d.qvel.copy()))
            dq = np.zeros(nv)
            mujoco.mj_differentiatePos(m, dq, 2.0 * _EPS, out[1][0], out[0][0])
            T[:nv, col], T[nv:, col] = dq, (out[0][1] - out[1][1]) / (2.0 * _EPS)
    return T


def _radius(T):
    return float(np.max(np.abs(np.linalg.eigvals(T)), initial=0.0)) if len(T) else 0.0


def _stable(T, h, growth, duration):
    """The one-step map ``T`` of step ``h`` grows at most 2x over ``duration`` beyond the rate ``growth`` [1/s]."""
    return math.log(max(_radius(T), 1e-300)) <= growth * h + max(math.log(2.0) * h / duration, NOISE_TOL)


def linear_limit(sim, integrator, method, guess, rtol, duration, growth=0.0, *, factor=1.25, expand=12):
    """``(largest stable step [s] or None, one-step map just above it or None, the last step tried)``.

    Stable means: over ``duration`` [s] the map grows at most 2x more than the linearized model
    itself does at its fastest physical rate ``growth`` [1/s] (0 at a stable equilibrium; an
    unstable one, such as an inverted pendulum, grows at any step, and that is not the
    integrator's doing). Starts at
    ``guess`` (the measured limit) and multiplies or divides it by ``factor`` (at most
    ``expand`` times) until the limit is bracketed, then bisects geometrically until the bracket
    is within ``rtol`` (relative; the study's ``limit_rtol``). The step is None when the map is
    stable at every step tried (the map is None: an integrator implicit in every stiff term) or
    unstable at every one (the map is the last one).
    """
    lo, hi, T_hi = None, None, None
    h = guess
    for _ in range(expand + 1):
        T = step_map(sim, integrator, method, h)
        if _stable(T, h, growth, duration):
            lo, h = h, h * factor
        else:
            hi, T_hi, h = h, T, h / factor
        if lo is not None and hi is not None:
            break
    if lo is None or hi is None:
        return None, T_hi, (hi if lo is None else lo)
    while hi / lo > 1.0 + rtol:
        h = math.sqrt(lo * hi)
        T = step_map(sim, integrator, method, h)
        if _stable(T, h, growth, duration):
            lo = h
        else:
            hi, T_hi = h, T
    return lo, T_hi, hi


def linearization(sim):
    """The model linearized at the initial pose at rest (the element methods as configured).

    A dict: ``freq`` [Hz] and M-orthonormal ``phi`` (nv, nv) of the symmetric part of the
    stiffness ``K = M A`` (``A = -d qacc / d q``, the study's central differences), ``M``,
    ``K``; ``lam`` and ``vec``, the eigenvalues and eigenvectors of the first-order system
    ``[[0, I], [-A, -D]]`` (``D = -d qacc / d qvel``), and ``growth``, the largest real part
    of ``lam`` [1/s] (positive only at an unstable equilibrium).
    """
    m = sim.model
    with sim.flex:
        A = jacobian(m, _rest(sim), sim.state["qpos"], "qpos", 1e-6)
        D = jacobian(m, _rest(sim), sim.state["qpos"], "qvel", 1e-6)
    d = _rest(sim)
    mujoco.mj_forward(m, d)
    M = np.zeros((m.nv, m.nv))
    mujoco.mj_fullM(m, d, M)
    K = M @ A
    K = 0.5 * (K + K.T)  # symmetric at an equilibrium; a preloaded initial pose adds a small skew part
    w2, phi = scipy.linalg.eigh(K, M)
    n = m.nv
    lam, vec = np.linalg.eig(np.block([[np.zeros((n, n)), np.eye(n)], [-A, -D]]))
    return {"freq": np.sqrt(np.maximum(w2, 0.0)) / (2.0 * np.pi), "phi": phi, "M": M, "K": K, "lam": lam,
            "vec": vec, "growth": max(0.0, float(np.max(lam.real, initial=0.0)))}  # fmt: skip


def _scene_share(sim, k, lin):
    """Share of the scene's initial energy (kinetic, and elastic from the initial forces) in mode ``k``."""
    freq, phi, M = lin["freq"], lin["phi"], lin["M"]
    d = _rest(sim)
    with sim.flex:
        mujoco.mj_forward(sim.model, d)
        force = M @ d.qacc  # generalized force at the initial pose at rest
    v0 = sim.state["qvel"]
    w2 = (2.0 * np.pi * freq) ** 2
    elastic = w2 > 1e-12 * w2.max(initial=0.0)
    modal_v, modal_f = phi.T @ M @ v0, phi.T @ force
    energy = 0.5 * modal_v**2
    energy[elastic] += 0.5 * modal_f[elastic] ** 2 / w2[elastic]
    total = float(energy.sum())
    return float(energy[k] / total) if total > 0 else 0.0


def limiting_mode(sim, T, lin):
    """What diverges first, for the one-step map ``T`` (``lin``: :func:`linearization` of ``sim``).

    The eigenvector of ``T`` with the largest ``|eigenvalue|`` is matched with the closest
    eigenvector of the first-order system (the same vectors for RK4, whose map is a polynomial
    of the system). Returns a dict: ``frequency_hz`` (``|lambda| / 2 pi``) and ``oscillating``
    (``|Im lambda| >= |Re lambda|``; else a damping-limited motion); ``where``: the element
    principal direction (``"element 'hinge' z"``) or joint spring storing the largest part of
    its strain energy, ``share`` that part and ``kind`` ``"strain"``, or, where elements and
    joint springs hold less than half of it (equality constraints, e.g. welds), the body with
    the largest part of its kinetic energy (``kind`` ``"kinetic"``); ``scene_share``: the part
    of the scene's initial energy in the natural mode closest to it.
    """
    m, nv = sim.model, sim.model.nv
    mu, vec = np.linalg.eig(T)
    x = vec[:, int(np.argmax(np.abs(mu)))]
    V = lin["vec"]
    j = int(np.argmax(np.abs(V.conj().T @ x) / np.linalg.norm(V, axis=0)))
    lam, mode = lin["lam"][j], V[:nv, j]
    M, K = lin["M"], lin["K"]
    parts = {}
    if sim.has_flexures:
        for d in element_directions(m, sim.flex, qpos=sim.state["qpos"]):
            for i, label in enumerate(d.labels):
                parts[f"element '{d.element}' {label}"] = 0.5 * d.k[i] * abs(d.J[i] @ mode) ** 2
    for jnt in range(m.njnt):
        if m.jnt_type[jnt] in (mujoco.mjtJoint.mjJNT_HINGE, mujoco.mjtJoint.mjJNT_SLIDE) and m.jnt_stiffness[jnt] > 0:
            name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, jnt) or f"#{jnt}"
            parts[f"joint '{name}'"] = 0.5 * m.jnt_stiffness[jnt] * abs(mode[m.jnt_dofadr[jnt]]) ** 2
    strain = 0.5 * float(np.real(mode.conj() @ K @ mode))
    if parts and strain > 0 and sum(parts.values()) > 0.5 * strain:
        where, kind = max(parts, key=parts.get), "strain"
        share = parts[where] / sum(parts.values())
    else:
        kinetic = np.abs(mode.conj() * (M @ mode))
        bodies = {}
        for dof in range(nv):
            b = int(m.dof_bodyid[dof])
            bodies[b] = bodies.get(b, 0.0) + float(kinetic[dof])
        b = max(bodies, key=bodies.get)
        where, kind = f"body '{mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b)}'", "kinetic"
        share = bodies[b] / max(sum(bodies.values()), 1e-300)
    k = int(np.argmax(np.abs(lin["phi"].T @ M @ mode)))
    return {"frequency_hz": float(abs(lam) / (2.0 * np.pi)), "oscillating": bool(abs(lam.imag) >= abs(lam.real)),
            "where": where, "share": float(share), "kind": kind,
            "scene_share": _scene_share(sim, k, lin)}  # fmt: skip


def perturbation(sim, energy, seed=0):
    """A random velocity (nv,) with kinetic energy ``PERTURBATION**2 * energy`` at the initial pose."""
    m = sim.model
    d = _rest(sim)
    mujoco.mj_forward(m, d)
    M = np.zeros((m.nv, m.nv))
    mujoco.mj_fullM(m, d, M)
    v = np.random.default_rng(seed).normal(size=m.nv)
    kinetic = 0.5 * float(v @ M @ v)
    return v * math.sqrt(PERTURBATION**2 * energy / kinetic) if kinetic > 0 else v * 0.0

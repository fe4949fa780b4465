"""The time-step limits of a model with flexures, each defined once: from its modes, and measured on a stated scene.

Usage::

    python scripts/step_limits.py [MODEL.xml] [--keyframe NAME] [--duration S] [--json out/step_limits.json]

For RK4 and Euler (MuJoCo's semi-implicit Euler; implicitfast and discrete add nothing for
mjflex forces, which every MuJoCo integrator takes explicitly), three numbers:

* **modal limit** (undamped): ``h = 2 sqrt(2) / omega_max`` (RK4) and ``h = 2 / omega_max`` (Euler),
  with ``omega_max`` the highest natural frequency of :func:`mjflex.normal_modes` at ``qpos0``;
* **advised limit** (any motion, the model's damping included): the largest step at which the
  model linearized at ``qpos0`` at rest stays stable. The linearization is MuJoCo's own: the
  Jacobians ``A = -d qacc / d qpos`` and ``D = -d qacc / d qvel`` from ``mujoco.mjd_transitionFD`` of
  one Euler step of 1e-6 s. RK4: every eigenvalue ``lambda`` of ``[[0, I], [-A, -D]]`` must keep
  ``|R(h lambda)| <= 1``, ``R`` RK4's stability polynomial; Euler: the spectral radius of its
  one-step map ``[[I - h^2 A, h (I - h D)], [-h A, I - h D]]`` must stay at most 1. Without damping
  it is the modal limit (checked here);
* **measured limit** of a stated scene: the largest step at which the model, as it is (damping
  included), runs from ``--keyframe`` for ``--duration`` (default one period of the lowest elastic
  mode) without MuJoCo reporting a bad state or the elements' energy exceeding twice the scene's
  initial kinetic and elastic energy (a damped mechanism moving freely cannot gain energy); bisected
  to 0.1 %.

The advised limit holds for any motion; a scene that leaves the mode that sets it unexcited (its
initial energy in that mode is round-off) can run a little above it, until round-off has grown
into a divergence: the measured limit depends on the scene and on how long it runs. Nothing is
timed: the JSON is the same on every run on one machine.
"""

import argparse
import math
import os

import mujoco
import numpy as np
from _bench import write_json

import mjflex

HERE = os.path.dirname(os.path.abspath(__file__))
RTOL = 1e-3  # relative width at which the bisections stop
LINEARIZATION_STEP = 1e-6  # [s]: the Euler step whose transition matrix gives A and D
#: Spectral radius above 1 still counted as stable: the rigid-body modes' eigenvalue 1 is a Jordan block that
#: round-off splits by ~1e-8; past a limit the radius grows by ~1e-3 for 0.1 % more step.
NOISE = 1e-6
BAD_STATES = (mujoco.mjtWarning.mjWARN_BADQACC, mujoco.mjtWarning.mjWARN_BADQVEL, mujoco.mjtWarning.mjWARN_BADQPOS)


def rk4_factor(z):
    """RK4's amplification of ``y' = lambda y`` over one step, ``z = h lambda``."""
    return 1 + z + z**2 / 2 + z**3 / 6 + z**4 / 24


def linearization(model):
    """``(A, D)``: ``-d qacc / d qpos`` and ``-d qacc / d qvel`` at ``qpos0`` at rest, (nv, nv), from MuJoCo."""
    m = model
    saved = m.opt.timestep, m.opt.integrator
    m.opt.timestep, m.opt.integrator = LINEARIZATION_STEP, mujoco.mjtIntegrator.mjINT_EULER
    data = mujoco.MjData(m)
    mujoco.mj_forward(m, data)
    n = 2 * m.nv + m.na
    T = np.zeros((n, n))
    mujoco.mjd_transitionFD(m, data, 1e-6, True, T, None, None, None)
    m.opt.timestep, m.opt.integrator = saved
    nv, h = m.nv, LINEARIZATION_STEP
    return -T[nv : 2 * nv, :nv] / h, (np.eye(nv) - T[nv : 2 * nv, nv : 2 * nv]) / h


def rk4_linear_limit(eigenvalues):
    """Largest ``h`` with ``|R(h lambda)| <= 1`` for every eigenvalue (rigid-body ones, ``|lambda| ~ 0``, aside)."""
    scale = np.abs(eigenvalues).max()
    limit = math.inf
    for lam in eigenvalues[np.abs(eigenvalues) > 1e-6 * scale]:
        lo, hi = 0.0, 4.0 / abs(lam)  # |R| > 1 beyond |z| = 2.8 on any ray of the left half-plane
        if abs(rk4_factor(hi * lam)) <= 1:
            continue
        while hi - lo > 1e-9 * hi:
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if abs(rk4_factor(mid * lam)) <= 1 else (lo, mid)
        limit = min(limit, lo)
    return limit


def euler_linear_limit(A, D, guess):
    """Largest ``h`` at which the semi-implicit Euler map of ``qacc = -A q - D v`` has spectral radius <= 1."""
    nv = len(A)
    eye = np.eye(nv)

    def stable(h):
        T = np.block([[eye - h * h * A, h * (eye - h * D)], [-h * A, eye - h * D]])
        return np.abs(np.linalg.eigvals(T)).max() <= 1.0 + NOISE

    return bisect(stable, guess)


def bisect(stable, guess, rtol=RTOL):
    """``(largest stable, smallest unstable)`` step: bracket from ``guess`` by factors of 1.25, then bisect."""
    lo = hi = None
    h = guess
    while lo is None or hi is None:
        if stable(h):
            lo, h = h, h * 1.25
        else:
            hi, h = h, h / 1.25
        if h < 1e-3 * guess or h > 1e3 * guess:
            raise SystemExit(f"no stability limit within 1000x of {guess:.3g} s")
    while hi / lo > 1 + rtol:
        mid = math.sqrt(lo * hi)
        lo, hi = (mid, hi) if stable(mid) else (lo, mid)
    return lo, hi


def scene_run(model, flex, integrator, h, keyframe, duration, energy):
    """None if the scene runs through at step ``h``, else how it diverged: ``{"time", "reason"}`` (``time``: the
    start of the step in which MuJoCo found a bad state, or the time at which the energy was found too large)."""
    model.opt.integrator, model.opt.timestep = integrator, h
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, keyframe)
    for i in range(math.ceil(duration / h - 1e-9)):
        start = data.time
        mujoco.mj_step(model, data)  # MuJoCo resets a bad state: its warning counter tells
        bad = [w for w in BAD_STATES if data.warning[w].number]
        if bad:
            return {"time": float(start), "reason": f"MuJoCo: {mujoco.mjtWarning(bad[0]).name}"}
        if i % 10 == 9 and not flex.potential_energy(data) <= 2.0 * energy:
            return {"time": float(data.time), "reason": "the elements' energy exceeded twice the initial energy"}
    return None


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("model", nargs="?", default=os.path.join(HERE, "..", "models", "arcade.xml"))
    ap.add_argument("--keyframe", default=None, help="the scene's initial state (default: the first keyframe)")
    ap.add_argument("--duration", type=float, default=None, help="the scene's length [s] (default: one period of "
                    "the lowest elastic mode)")  # fmt: skip
    ap.add_argument("--json", default="out/step_limits.json")
    args = ap.parse_args()
    warnings_seen = []
    mujoco.set_mju_user_warning(warnings_seen.append)  # the diverging runs' warnings: counted, not printed
    model = mujoco.MjModel.from_xml_path(args.model)
    flex = mjflex.Flexures(model)
    keyframe = 0 if args.keyframe is None else model.key(args.keyframe).id
    freq, _ = mjflex.normal_modes(model, flex)
    omega_max = 2 * np.pi * freq[-1]
    elastic = freq[freq > 1e-6 * freq[-1]]
    duration = args.duration or 1.0 / elastic[0]
    modal = {"rk4": 2 * math.sqrt(2) / omega_max, "euler": 2 / omega_max}

    A, D = linearization(model)
    nv = model.nv
    eigenvalues = np.linalg.eigvals(np.block([[np.zeros((nv, nv)), np.eye(nv)], [-A, -D]]))
    fastest = eigenvalues[np.argmax(np.abs(eigenvalues))]
    linear = {"rk4": rk4_linear_limit(eigenvalues), "euler": euler_linear_limit(A, D, modal["euler"])[0]}
    undamped = {"rk4": rk4_linear_limit(np.linalg.eigvals(np.block([[np.zeros((nv, nv)), np.eye(nv)],
                                                                    [-A, np.zeros((nv, nv))]]))),
                "euler": euler_linear_limit(A, 0 * D, modal["euler"])[0]}  # fmt: skip

    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, keyframe)
    flags = model.opt.enableflags
    model.opt.enableflags = flags | mujoco.mjtEnableBit.mjENBL_ENERGY
    mujoco.mj_forward(model, data)
    energy = float(data.energy[1] + flex.potential_energy(data))  # kinetic and elastic (gravity's has no zero)
    model.opt.enableflags = flags
    integrators = {"rk4": mujoco.mjtIntegrator.mjINT_RK4, "euler": mujoco.mjtIntegrator.mjINT_EULER}
    measured = {}
    for name, integrator in integrators.items():
        lo, hi = bisect(lambda h, i=integrator: scene_run(model, flex, i, h, keyframe, duration, energy) is None,
                        linear[name])  # fmt: skip
        how = scene_run(model, flex, integrator, hi, keyframe, duration, energy)
        measured[name] = {"largest_stable": lo, "smallest_unstable": hi, "divergence": how}

    name = os.path.basename(args.model)
    print(f"{name}: highest natural frequency {freq[-1]:.1f} Hz; fastest eigenvalue with damping "
          f"{abs(fastest):.4g} 1/s, damping ratio {-fastest.real / abs(fastest):.3g}")  # fmt: skip
    print(f"scene: keyframe {model.key(keyframe).name or keyframe}, {duration * 1e3:.1f} ms, the model's damping")
    print(f"{'':>6} {'modal':>10} {'linear':>10} {'(undamped)':>10} {'measured':>10} {'diverged':>10}")
    for key in integrators:
        m = measured[key]
        print(
            f"{key:>6} {modal[key]:>10.4g} {linear[key]:>10.4g} {undamped[key]:>10.4g} {m['largest_stable']:>10.4g} "
            f"{m['smallest_unstable']:>10.4g}  ({m['divergence']['reason']} at t = {m['divergence']['time']:.3g} s)"
        )
    write_json(args.json, {
        "model": name,
        "highest_frequency_hz": float(freq[-1]),
        "omega_max": float(omega_max),
        "modal": modal,
        "fastest_eigenvalue": {"rate_per_s": float(abs(fastest)), "damping_ratio": float(-fastest.real / abs(fastest)),
                               "frequency_hz": float(abs(fastest.imag) / (2 * np.pi))},
        "linear": linear,
        "linear_undamped": undamped,
        "scene": {"keyframe": model.key(keyframe).name, "duration": duration, "lowest_elastic_hz": float(elastic[0]),
                  "initial_energy_J": energy},
        "measured": measured,
        "rtol": RTOL,
        "mujoco_warnings": len(warnings_seen),
    })  # fmt: skip


if __name__ == "__main__":
    main()

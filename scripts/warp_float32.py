"""What float32 means for ARCADE's flexures on MuJoCo Warp: force error, energy drift, stable step, float64 elements.

ARCADE's flexures are stiff in five directions and compliant in one: its elastic modes run from
the guide's 10 Hz to 12.7 kHz, its stiffnesses from 0.2 N m/rad to 5e6 N/m. MuJoCo Warp keeps
positions, kinematics and the state in float32; mjflex's kernels compute the element math in
float32 or float64 (``put_model(precision=...)``). Measured on Warp's CPU device (the numbers are
the device's arithmetic, not its speed; a GPU computes the same IEEE operations up to the order
of MuJoCo Warp's own reductions), against the C engine in float64:

1. force error: element wrenches at states turned and shifted from rest by amplitudes from 1e-6
   to 0.3 rad (and 1e-3 times that in m): relative error of each element's wrench (norm of the
   difference over the norm of the wrench), median and largest over elements and states, and the
   absolute error floor;
2. energy drift: the paper's run (105 rad/s spin, 5 m/s axial), and its axial motion alone (no
   spin), undamped, total energy (kinetic + elastic, evaluated by the C engine in float64 at the
   recorded states) over ``--steps`` steps;
3. stable step: the largest RK4 step of a grid that runs ``--stable-steps`` steps of the paper's
   run without divergence, MuJoCo Warp (one world per step size) and the C engine.

    python scripts/warp_float32.py [--steps 1000] [--stable-steps 300] [--json out/warp_float32.json]
"""

import argparse
import copy
import os
import sys

import mujoco
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from _bench import write_json

import mjflex

MODEL = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "models", "arcade.xml")
AMPLITUDES = (1e-6, 1e-4, 1e-2, 0.3)


def undamped(model):
    """A copy of ARCADE with every element's damping off (a copy: compiled again from the file with viscous=False)."""
    spec = mujoco.MjSpec.from_file(MODEL)
    mjflex.edit_elements(spec, viscous=False)
    out = spec.compile()
    out.opt.timestep = model.opt.timestep
    return out


def moved_states(model, rng, amplitude, count):
    out = []
    for _ in range(count):
        qpos = model.qpos0.copy()
        for j in range(model.njnt):
            if int(model.jnt_type[j]) != int(mujoco.mjtJoint.mjJNT_FREE):
                continue
            a = int(model.jnt_qposadr[j])
            qpos[a : a + 3] += 1e-3 * amplitude * rng.uniform(-1, 1, 3)
            axis = rng.normal(size=3)
            axis *= amplitude * rng.uniform(0, 1) / np.linalg.norm(axis)
            dq = np.empty(4)
            mujoco.mju_axisAngle2Quat(dq, axis / max(np.linalg.norm(axis), 1e-300), np.linalg.norm(axis))
            q = np.empty(4)
            mujoco.mju_mulQuat(q, dq, qpos[a + 3 : a + 7])
            qpos[a + 3 : a + 7] = q
        out.append((qpos, 0.1 * rng.normal(size=model.nv)))
    return out


def force_errors(wp, mjw, mw, model, count=8):
    flex = mjflex.Flexures(model)
    rng = np.random.default_rng(1)
    out = {}
    for amplitude in AMPLITUDES:
        states = moved_states(model, rng, amplitude, count)
        ref = []
        for qpos, qvel in states:
            data = mujoco.MjData(model)
            data.qpos[:], data.qvel[:] = np.float32(qpos), np.float32(qvel)
            mujoco.mj_forward(model, data)
            ref.append(flex.wrenches(data))
        ref = np.array(ref)
        row = {}
        for precision in ("float32", "float64"):
            m = mw.put_model(model, precision=precision)
            d = mjw.make_data(model, nworld=count)
            d.qpos.assign(np.array([s[0] for s in states], np.float32))
            d.qvel.assign(np.array([s[1] for s in states], np.float32))
            mjw.forward(m, d)
            got = mw.wrenches(m, d)
            err = np.linalg.norm(got - ref, axis=-1)
            rel = err / np.maximum(np.linalg.norm(ref, axis=-1), 1e-300)
            moment = np.linalg.norm(got[..., :3] - ref[..., :3], axis=-1)
            row[precision] = {"relative_median": float(np.median(rel)), "relative_max": float(rel.max()),
                              "absolute_force_median_N": float(np.median(np.linalg.norm(got[..., 3:] - ref[..., 3:],
                                                                                          axis=-1))),
                              "absolute_moment_median_Nm": float(np.median(moment))}  # fmt: skip
        row["wrench_norm_median"] = float(np.median(np.linalg.norm(ref, axis=-1)))
        out[f"{amplitude:g}"] = row
        print(f"amplitude {amplitude:g} rad: relative wrench error median/max float32 "
              f"{row['float32']['relative_median']:.2g}/{row['float32']['relative_max']:.2g}, float64 elements "
              f"{row['float64']['relative_median']:.2g}/{row['float64']['relative_max']:.2g}")  # fmt: skip
    return out


def energy(model, flex, qpos, qvel):
    data = mujoco.MjData(model)
    data.qpos[:], data.qvel[:] = qpos, qvel
    mujoco.mj_forward(model, data)
    M = np.zeros((model.nv, model.nv))
    mujoco.mj_fullM(model, data, M)
    return 0.5 * qvel @ M @ qvel + flex.potential_energy(data)


def axial_only(model, key):
    """The paper's run without its spin: every body at rest but the cylinder, at the keyframe's axial 5 m/s."""
    qvel = np.zeros(model.nv)
    cyl = model.body("cylinder").id
    base = model.body("base").id
    adr = model.jnt_dofadr[model.body_jntadr[cyl]]
    data = copy.copy(key)
    mujoco.mj_forward(model, data)
    axis = data.xmat[base].reshape(3, 3)[:, 2]
    qvel[adr : adr + 3] = 5.0 * axis
    return qvel


def energy_drift(mjw, mw, model, steps, spin=True, every=50):
    flex = mjflex.Flexures(model)
    key = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, key, model.key("paper_run").id)
    qvel = key.qvel if spin else axial_only(model, key)
    qpos0, qvel0 = np.float32(key.qpos).astype(float), np.float32(qvel).astype(float)
    e0 = energy(model, flex, qpos0, qvel0)
    elastic_scale = []
    out = {"initial_energy_J": e0}
    data = mujoco.MjData(model)
    data.qpos[:], data.qvel[:] = qpos0, qvel0
    c = [0.0]
    for k in range(1, steps + 1):
        mujoco.mj_step(model, data)
        if k % every == 0:
            c.append(energy(model, flex, data.qpos, data.qvel) - e0)
            mujoco.mj_forward(model, data)
            elastic_scale.append(flex.potential_energy(data))
    out["c_engine_float64"] = _drift(c, e0)
    for precision in ("float32", "float64"):
        m = mw.put_model(model, precision=precision)
        d = mjw.make_data(model, nworld=1)
        d.qpos.assign(np.float32(qpos0)[None])
        d.qvel.assign(np.float32(qvel0)[None])
        w = [0.0]
        for k in range(1, steps + 1):
            mjw.step(m, d)
            if k % every == 0:
                w.append(energy(model, flex, d.qpos.numpy()[0].astype(float), d.qvel.numpy()[0].astype(float)) - e0)
        out[f"warp_{precision}"] = _drift(w, e0)
    out["elastic_energy_max_J"] = float(max(elastic_scale))
    out["steps"], out["every"], out["timestep_s"] = steps, every, float(model.opt.timestep)
    for name in ("c_engine_float64", "warp_float32", "warp_float64"):
        print(f"energy drift over {steps} steps, {name}: largest |E - E0| {out[name]['largest_J']:.3g} J "
              f"({out[name]['relative_largest']:.2g} of E0 = {e0:.3g} J; elastic energy up to "
              f"{out['elastic_energy_max_J']:.3g} J)")  # fmt: skip
    return out


def _drift(values, e0):
    v = np.abs(np.asarray(values, float))
    return {"largest_J": float(v.max()), "relative_largest": float(v.max() / e0), "final_J": float(values[-1])}


def stable_steps(wp, mjw, mw, model, steps, grid):
    key = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, key, model.key("paper_run").id)
    out = {"grid_s": list(grid), "steps": steps}
    c_ok = []
    for h in grid:
        m = copy.copy(model)
        m.opt.timestep = h
        m.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_AUTORESET)
        data = mujoco.MjData(m)
        data.qpos[:], data.qvel[:] = np.float32(key.qpos), np.float32(key.qvel)
        try:
            for _ in range(steps):
                mujoco.mj_step(m, data)
            ok = bool(np.isfinite(data.qvel).all() and not any(data.warning[w].number for w in range(3, 6)))
        except mujoco.FatalError:
            ok = False
        c_ok.append(ok)
    out["c_engine_float64"] = {"stable": c_ok, "largest_stable_s": _largest(grid, c_ok)}
    for precision in ("float32", "float64"):
        m = mw.put_model(model, precision=precision)
        m.opt.timestep = wp.array(np.float32(grid), dtype=wp.float32)  # one step size per world
        d = mjw.make_data(model, nworld=len(grid))
        d.qpos.assign(np.tile(np.float32(key.qpos), (len(grid), 1)))
        d.qvel.assign(np.tile(np.float32(key.qvel), (len(grid), 1)))
        for _ in range(steps):
            mjw.step(m, d)
        ok = (~mw.diverged(m, d) & np.isfinite(d.qvel.numpy()).all(1)).tolist()
        out[f"warp_{precision}"] = {"stable": ok, "largest_stable_s": _largest(grid, ok)}
    for name in ("c_engine_float64", "warp_float32", "warp_float64"):
        print(f"largest stable RK4 step of {len(grid)} ({grid[0]:.3g} ... {grid[-1]:.3g} s), {steps} steps, {name}: "
              f"{out[name]['largest_stable_s']:.3g} s")  # fmt: skip
    return out


def _largest(grid, ok):
    good = [h for h, s in zip(grid, ok, strict=True) if s]
    return float(max(good)) if good else 0.0


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--steps", type=int, default=1000, help="steps of the energy-drift runs (1e-5 s each)")
    ap.add_argument("--stable-steps", type=int, default=300, help="steps of each stable-step run")
    ap.add_argument("--json", default="out/warp_float32.json")
    args = ap.parse_args()
    import mujoco_warp as mjw
    import warp as wp

    import mjflex.warp as mw
    from mjflex.analysis.linearize import normal_modes

    model = mujoco.MjModel.from_xml_path(MODEL)
    freq, _ = normal_modes(model, mjflex.Flexures(model))
    elastic = freq[freq > 1.0]
    K = np.array([np.diag(r.K) for r in mjflex.Flexures(model).records])
    payload = {"model": "models/arcade.xml", "device": "cpu", "elastic_frequencies_hz": [float(elastic.min()),
               float(elastic.max())], "stiffness_range": [float(K[K > 0].min()), float(K.max())]}  # fmt: skip
    print(f"ARCADE: elastic modes {elastic.min():.3g} ... {elastic.max():.4g} Hz, diagonal stiffness "
          f"{K[K > 0].min():.3g} ... {K.max():.3g} (N m/rad, N/m)")  # fmt: skip
    with wp.ScopedDevice("cpu"):
        payload["force_error"] = force_errors(wp, mjw, mw, model)
        payload["energy_drift"] = energy_drift(mjw, mw, undamped(model), args.steps)
        payload["energy_drift_axial"] = energy_drift(mjw, mw, undamped(model), args.steps, spin=False)
        grid = [float(h) for h in np.round(np.geomspace(1e-5, 6e-5, 12), 8)]
        payload["stable_step"] = stable_steps(wp, mjw, mw, model, args.stable_steps, grid)
    write_json(args.json, payload)


if __name__ == "__main__":
    main()

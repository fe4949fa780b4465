"""mjflex against MuJoCo's native ways of modelling a flexure: joint springs and welds.

Usage::

    python scripts/compare_native.py [--json out/compare_native.json] [--duration 0.05]

Scene: a 2.5 cm aluminium link hangs (no gravity) from the world through the paper's notch
hinge (mjflex.geometry, t/R = 0.125, E = 3.5 GPa) and is set swinging about the hinge axis at
400 rad/s (a swing of about 0.8 rad, undamped) with a transverse kick. Modelled as

* **mjflex twist / dualquat**: a free body and one 6x6 element (full stiffness, exact at large
  rotation);
* **6-joint bushing**: three slide and three hinge joints in series at the hinge centre with
  MuJoCo ``stiffness``/``damping`` set to K's and B's diagonal (the usual native bushing);
* **hinge joint**: one ideal revolute joint with the compliant-rotation stiffness (all other
  directions rigid);
* **weld**: a free body welded to the world (MuJoCo's soft equality constraint, as stiff as
  recommended for the step: ``solref = (2 dt, 1)``): rigid in every direction up to the
  constraint softness, which is set by the solver, not by the flexure.

Printed: cost per step (interleaved medians), swing frequency, peak rotation, parasitic
translation of the hinge centre, deviation from the mjflex twist trajectory, energy drift.
RK4, dt = 1e-5 s.
"""

import argparse
import time

import mujoco
import numpy as np
from _bench import compare, print_table, write_json

import mjflex
from mjflex.app.arcade import ArcadeParams, notch_stiffness

LINK = 0.025  # m, link length; the hinge centre is at the link's end, x = 0
DT = 1e-5
SPIN = 400.0  # rad/s about the hinge axis z: a swing of ~0.8 rad
KICK = 0.2  # m/s along y


def _link(parent, p, **body):
    body = parent.add_body(name="link", **body)
    body.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, pos=[LINK / 2 + 0.004, 0, 0], size=[LINK / 2, 0.0025, 0.00475],
                  density=p.link_density, contype=0, conaffinity=0)  # fmt: skip
    body.add_site(name="centre", pos=[0, 0, 0])
    return body


def _spec():
    spec = mujoco.MjSpec()
    spec.option.gravity = [0, 0, 0]
    spec.option.timestep = DT
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_RK4
    spec.option.enableflags |= mujoco.mjtEnableBit.mjENBL_ENERGY
    return spec


def build(kind, K, B):
    p = ArcadeParams()
    spec = _spec()
    if kind in ("twist", "dualquat", "weld"):
        body = _link(spec.worldbody, p)
        body.add_freejoint()
        if kind == "weld":
            # as stiff as MuJoCo recommends for this step (time constant 2 dt, critical damping)
            spec.add_equality(type=mujoco.mjtEq.mjEQ_WELD, objtype=mujoco.mjtObj.mjOBJ_BODY, name1="link",
                              name2="world", solref=[2 * DT, 1.0])  # fmt: skip
        else:
            mjflex.add_flexure(spec, "hinge", "world", "link", pos=[0, 0, 0], K=K, B=B, method=kind)
    elif kind == "bushing":
        body = _link(spec.worldbody, p)
        axes = np.eye(3)
        for i in range(3):
            body.add_joint(name=f"slide{i}", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=axes[i],
                           stiffness=[K[3 + i, 3 + i], 0, 0], damping=[B[3 + i, 3 + i], 0, 0])  # fmt: skip
        for i in range(3):
            body.add_joint(name=f"hinge{i}", type=mujoco.mjtJoint.mjJNT_HINGE, axis=axes[i],
                           stiffness=[K[i, i], 0, 0], damping=[B[i, i], 0, 0])  # fmt: skip
    elif kind == "hinge":
        body = _link(spec.worldbody, p)
        body.add_joint(name="hinge2", type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0, 0, 1], stiffness=[K[2, 2], 0, 0],
                       damping=[B[2, 2], 0, 0])  # fmt: skip
    return spec.compile()


def initial_state(model):
    """Swing about z at SPIN rad/s with a transverse kick KICK m/s of the hinge centre."""
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    target = np.array([0, 0, SPIN, 0, KICK, 0])  # [omega; v of the link origin], world
    J = np.zeros((6, model.nv))
    mujoco.mj_jacBody(model, data, J[3:], J[:3], model.body("link").id)
    data.qvel[:] = np.linalg.lstsq(J, target, rcond=None)[0]
    mujoco.mj_forward(model, data)
    return data


def trajectory(model, flex, duration):
    data = initial_state(model)
    steps = round(duration / DT)
    pos, rot, energy = [], [], []
    context = flex if flex is not None else _Null()
    with context:
        for _ in range(steps):
            mujoco.mj_step(model, data)
            mujoco.mj_forward(model, data)
            R = data.xmat[model.body("link").id].reshape(3, 3)
            pos.append(data.site_xpos[model.site("centre").id].copy())
            rot.append(np.arctan2(R[1, 0], R[0, 0]))
            energy.append(data.energy.sum() + (flex.potential_energy(data) if flex is not None else 0.0))
    return np.array(pos), np.unwrap(np.array(rot)), np.array(energy)


class _Null:
    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False


def swing_frequency(rot, duration):
    """Frequency of the rotation from its zero crossings [Hz]."""
    s = np.sign(rot - rot.mean())
    crossings = np.nonzero(s[1:] != s[:-1])[0]
    if len(crossings) < 3:
        return float("nan")
    return (len(crossings) - 1) / 2 / ((crossings[-1] - crossings[0]) * DT)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=0.05)
    ap.add_argument("--json", default="out/compare_native.json")
    args = ap.parse_args()
    K = notch_stiffness(ArcadeParams())
    B = np.zeros((6, 6))  # undamped, so that energy drift measures the integration alone
    kinds = ["twist", "dualquat", "bushing", "hinge", "weld"]
    models = {k: build(k, K, B) for k in kinds}
    flexes = {k: mjflex.Flexures(models[k]) if k in ("twist", "dualquat") else None for k in kinds}
    results, traj = {}, {}
    for k in kinds:
        t0 = time.perf_counter()
        traj[k] = trajectory(models[k], flexes[k], args.duration)
        pos, rot, energy = traj[k]
        results[k] = {
            "frequency_hz": swing_frequency(rot, args.duration),
            "peak_rotation_rad": float(np.abs(rot).max()),
            "parasitic_translation_um": float(np.linalg.norm(pos, axis=1).max() * 1e6),
            "energy_drift_relative": float((energy.max() - energy.min()) / energy[0]),
            "simulation_wall_s": time.perf_counter() - t0,
        }
    ref_pos, ref_rot, _ = traj["twist"]
    for k in kinds:
        pos, rot, _ = traj[k]
        results[k]["max_rotation_deviation_rad"] = float(np.abs(rot - ref_rot).max())
        results[k]["max_centre_deviation_um"] = float(np.linalg.norm(pos - ref_pos, axis=1).max() * 1e6)
    for f in flexes.values():
        if f is not None:
            f.install()
    cases = {}
    for k in kinds:
        data = initial_state(models[k])
        cases[k] = (lambda m, d: lambda: [mujoco.mj_step(m, d) for _ in range(10)])(models[k], data)
    rows = compare(cases, "hinge", repeat=15)
    for f in flexes.values():
        if f is not None:
            f.uninstall()
    for r in rows.values():
        for key in ("median_s", "min_s", "max_s"):
            r[key] /= 10
    print_table(rows, "cost of one RK4 step (ratios to the single native hinge joint, same repeat)")
    print(f"\n{'model':<10} {'f [Hz]':>9} {'peak rot':>9} {'parasitic':>11} {'dev. rot':>10} {'dev. centre':>12} "
          f"{'energy drift':>13}")  # fmt: skip
    for k in kinds:
        r = results[k]
        cells = [f"{r['frequency_hz']:>9.2f}", f"{r['peak_rotation_rad']:>8.3f}r",
                 f"{r['parasitic_translation_um']:>9.2f}um", f"{r['max_rotation_deviation_rad']:>9.2e}r",
                 f"{r['max_centre_deviation_um']:>10.2f}um", f"{r['energy_drift_relative']:>13.2e}"]  # fmt: skip
        print(f"{k:<10} " + " ".join(cells))
    write_json(args.json, {"results": results, "step_cost": rows, "duration": args.duration, "dt": DT})


if __name__ == "__main__":
    main()

"""Robots with compliant parts, reduced to the file's own time step: ``mjflex.reduce(full)`` on three scenes.

Usage::

    python scripts/reduce_robots.py [--json out/reduce_robots.json] [--repeat 7] [--reference 1.0] [--run 10]

The scenes of ``tests/robot_scenes.py``: a four-bar gripper whose passive pivots are steel notch hinges, a lumbar
spine whose L3 hinges (tied by equalities, moved by muscles) are a disc, gymnasium's pusher arm with a compliant
wrist. For each: the rigid model (the file), the full element model and the reduced one (``mjflex.reduce(full)``,
at the file's step; for the spine also at the largest step that keeps the directions its band needs):

* nv, the full model's advised step (:func:`mjflex.step_advice`, where the scene rests) against the file's;
* the reduced model's modes below the band and statics under the scene's loads against the full model's (the
  variant's ``details``: relative errors);
* cost per simulated second (median of interleaved repeats, each a chunk of equal simulated time of the scene's
  actuated run): the reduced model at the file's step and the full model at its advised step, over the rigid
  model at the file's step;
* error against a reference: the full model at its advised step over ``--reference`` s of the actuated run, against
  the reduced model at its step from the same state: the largest distance of a part's centre (geom) over the
  largest distance one moved (and the same for the rigid model at the file's step);
* a ``--run`` s actuated run of the reduced model at its step: finite, no MuJoCo bad-state warning.
"""

import argparse
import contextlib
import os
import sys
import warnings

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))  # _bench
sys.path.append(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))  # tests/robot_scenes.py
import mujoco
import numpy as np
from _bench import compare, write_json

import mjflex
from mjflex.variants.variant import PoseFit, identity_body_map
from tests import robot_scenes

BAD = (mujoco.mjtWarning.mjWARN_BADQACC, mujoco.mjtWarning.mjWARN_BADQPOS, mujoco.mjtWarning.mjWARN_BADQVEL)


class Runner:
    """A model stepping through the scene's actuated run in chunks of ``chunk`` simulated seconds."""

    def __init__(self, model, info, timestep, chunk, state=None):
        self.model, self.info, self.chunk = model, info, chunk
        model.opt.timestep = timestep
        self.data = mujoco.MjData(model)
        if info["keyframe"] is not None:
            mujoco.mj_resetDataKeyframe(model, self.data, model.key(info["keyframe"]).id)
        if state is not None:
            self.data.qpos[:], self.data.qvel[:] = state
        self.flex = mjflex.Flexures(model) if _has_records(model) else None
        self.steps = max(1, round(chunk / timestep))

    def __call__(self):
        m, d = self.model, self.data
        with self.flex if self.flex is not None else contextlib.nullcontext():
            for _ in range(self.steps):
                d.ctrl[:] = self.info["ctrl"](d.time)
                mujoco.mj_step(m, d)

    def diverged(self):
        return any(self.data.warning[w].number for w in BAD) or not np.isfinite(self.data.qpos).all()


def _has_records(model):
    return any("mjflex:" in (mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_TEXT, i) or "") for i in range(model.ntext))


def reference_error(full, variant, info, h_full, seconds):
    """Largest distance of a part's centre between the reduced run and the full one, over the largest motion."""
    ref = Runner(full, info, h_full, variant.model.opt.timestep)
    start = mujoco.MjData(full)
    start.qpos[:], start.qvel[:] = ref.data.qpos, ref.data.qvel
    mujoco.mj_forward(full, start)
    red = Runner(variant.model, info, variant.model.opt.timestep, variant.model.opt.timestep,
                 state=variant.state_from(full, start))  # fmt: skip
    names = [mujoco.mj_id2name(full, mujoco.mjtObj.mjOBJ_BODY, full.geom_bodyid[g]) for g in range(full.ngeom)]
    pairs = [(g, variant.body_map[n]) for g, n in enumerate(names) if n in variant.body_map]
    mujoco.mj_forward(full, ref.data)
    p0 = ref.data.geom_xpos.copy()
    moved = err = 0.0
    while ref.data.time < seconds:
        ref()
        red()
        mujoco.mj_kinematics(full, ref.data)
        mujoco.mj_kinematics(variant.model, red.data)
        if ref.diverged() or red.diverged():
            return float("nan")
        for g, (vb, X_VS) in pairs:
            b, v = full.geom_bodyid[g], variant.model.body(vb).id
            r = ref.data.xmat[b].reshape(3, 3).T @ (ref.data.geom_xpos[g] - ref.data.xpos[b])
            point = red.data.xpos[v] + red.data.xmat[v].reshape(3, 3) @ (X_VS[:3, :3] @ r + X_VS[:3, 3])
            err = max(err, float(np.linalg.norm(point - ref.data.geom_xpos[g])))
            moved = max(moved, float(np.linalg.norm(ref.data.geom_xpos[g] - p0[g])))
    return err / max(moved, 1e-12), moved


def full_advised_step(full, info):
    """The full model's step advice where the scene rests (its keyframe's static equilibrium), as reduce asks it."""
    at_rest = mjflex.static_equilibrium(full, keyframe=info["keyframe"])
    return mjflex.step_advice(full, keyframe=info["keyframe"], qpos=at_rest).recommended


def measure(name, rigid, full, variant, info, args):
    h = rigid.opt.timestep
    h_full = full_advised_step(full, info)
    chunk = max(20 * h, 0.01)
    cases = {"rigid": Runner(rigid, info, h, chunk), "reduced": Runner(variant.model, info, variant.model.opt.timestep,
             chunk), "full": Runner(full, info, h_full, chunk)}  # fmt: skip
    cost = compare(cases, "rigid", repeat=args.repeat, target=0.05)
    run = Runner(variant.model, info, variant.model.opt.timestep, args.run)
    run()
    rel, moved = reference_error(full, variant, info, h_full, args.reference)
    body_map = identity_body_map(rigid)
    as_variant = mjflex.Variant("rigid", rigid, "", body_map, PoseFit(rigid, body_map))
    rigid_rel, _ = reference_error(full, as_variant, info, h_full, args.reference)
    row = {
        "nv": {"rigid": int(rigid.nv), "full": int(full.nv), "reduced": int(variant.model.nv)},
        "file_step": h, "step": variant.model.opt.timestep, "integrator": variant.details["step"]["integrator"],
        "full_advised_step": h_full, "reduced_advised_step": variant.details["step"]["advised_step"],
        "modes": variant.details["modes"], "statics": variant.details["statics"],
        "needed": variant.details["step"].get("needed"),
        "cost": {k: v for k, v in cost.items()},
        "reference": {"seconds": args.reference, "relative_error": rel, "rigid_relative_error": rigid_rel,
                      "largest_motion_m": moved},
        "run": {"seconds": args.run, "finite": not run.diverged()},
        "report": variant.report,
    }  # fmt: skip
    c = cost
    print(f"{name:<24} nv {rigid.nv}/{full.nv}/{variant.model.nv}  full step {h_full:.3g} s, file {h:g} s; modes "
          f"{100 * variant.details['modes']['max_relative_error']:.3g} %, statics "
          f"{100 * max(s['relative'] for s in variant.details['statics']):.3g} %; per simulated s: reduced "
          f"{c['reduced']['ratio_median']:.2f}x rigid, full {c['full']['ratio_median']:.3g}x; reference "
          f"{100 * rel:.3g} % (rigid {100 * rigid_rel:.3g} %); {args.run:g} s run "
          f"{'finite' if row['run']['finite'] else 'DIVERGED'}")  # fmt: skip
    return row


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", default="out/reduce_robots.json")
    ap.add_argument("--repeat", type=int, default=7, help="interleaved repeats (default 7)")
    ap.add_argument("--reference", type=float, default=1.0, help="seconds of the reference run (default 1)")
    ap.add_argument("--run", type=float, default=10.0, help="seconds of the reduced model's run (default 10)")
    args = ap.parse_args()
    rows = {}
    for name, scene in robot_scenes.SCENES.items():
        rigid_spec, full_spec, info = scene()
        rigid, full = rigid_spec.compile(), full_spec.compile()
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", mjflex.ReductionWarning)
            variant = mjflex.reduce(full_spec)
        rows[name] = measure(name, rigid, full, variant, info, args)
        rows[name]["warnings"] = [str(w.message) for w in caught if issubclass(w.category, mjflex.ReductionWarning)]
        needed = variant.details["step"].get("needed")
        if needed:  # the largest step that keeps what the band needs
            kept = mjflex.reduce(full_spec, timestep=needed["largest_step"])
            key = f"{name} at {needed['largest_step']:.3g} s"
            rows[key] = measure(key, rigid, full, kept, info, args)
    write_json(args.json, {"rows": rows})


if __name__ == "__main__":
    main()

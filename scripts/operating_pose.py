"""Step advice at the operating pose, checked by runs: the figures of the how-to's "Advice at the operating pose".

Usage::

    python scripts/operating_pose.py [--json out/operating_pose.json]

Two models, taken from where they are defined (not copied):

* **the servo-held arm** of ``tests/test_operating_pose.py`` (``tests/robots.py``: ``servo_held_arm``, its
  link3 on an element soft in bending and torsion, held by the position servo of the joint it replaced).
  For Euler and RK4, :func:`mjflex.step_advice` (``arm_advice``) at the operating pose (the static
  equilibrium of keyframe ``level``, with gravity, the servos' stiffness and the springs), without the
  servos' stiffness, and at the unloaded ``qpos0``; and the **measured stable step**: the largest step at
  which a run of ``STEPS`` steps from the operating pose, knocked on every dof, does not diverge
  (``tests/robots.py``'s ``diverges``, the test's own check: MuJoCo's bad-acceleration warning or a speed of
  1e3), bisected to 0.1 % (``scripts/step_limits.py``'s ``bisect``), and whether such a run at the step
  recommended without the servos diverges.
* **the spine** of ``docs/tutorials/plot_06_spine.py``, run here as it is: its model (L3 replaced by a disc
  with stops; MuJoCo's default, soft ``solref`` on its equality constraints), its push on the torso and its
  pushed equilibrium (a stop engaged). The advice at ``qpos0`` and at the pushed pose, as the tutorial asks
  for it (the equalities projected as rigid, the default); the measured stable steps from both poses, as for
  the arm (the push held); and whether a run from the pushed pose diverges at the step recommended at
  ``qpos0``.

Nothing is timed: the JSON is the same on every run (the advice to round-off; a measured step to its
bisection's 0.1 %). ``tests/test_operating_pose.py`` recomputes the advice (``figures(measure=False)``) and
compares it with the recorded JSON. Record with ``MJFLEX_RECORD=1`` (scripts/_bench.py), then render the
pages with ``python scripts/results_blocks.py``.
"""

import argparse
import contextlib
import io
import os
import runpy
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))  # _bench, step_limits: also imported by path
sys.path.append(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))  # tests/robots.py (the test's arm)
import mujoco
import numpy as np
from _bench import write_json
from step_limits import RTOL, bisect

import mjflex
from tests.robots import arm_advice, diverges, servo_held_arm

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
TUTORIAL = os.path.join(ROOT, "docs", "tutorials", "plot_06_spine.py")
STEPS = 3000  # steps of a run that checks a time step (tests/robots.py diverges' default)


def advice_record(advice):
    """The figures of a :class:`mjflex.StepAdvice`: limit and recommendation [s], the limiting mode [Hz] and its
    damping ratio, the stiffest mode [Hz]."""
    return {
        "integrator": advice.integrator,
        "limit_s": float(advice.limit),
        "recommended_s": float(advice.recommended),
        "safety": float(advice.safety),
        "limiting_frequency_hz": float(advice.frequency),
        "limiting_damping_ratio": float(advice.damping_ratio),
        "stiffest_frequency_hz": float(advice.freq.max()),
    }


def measured_stable_step(runs_away, guess):
    """``{"largest_stable_s", "smallest_unstable_s"}``: the bisection bracket of the steps at which ``runs_away(h)``
    is False, from ``guess`` (factors of 1.25, then to ``RTOL``)."""
    lo, hi = bisect(lambda h: not runs_away(h), guess)
    return {"largest_stable_s": float(lo), "smallest_unstable_s": float(hi)}


def arm(measure=True):
    """The servo-held arm's advice for Euler and RK4 and, with ``measure``, the runs that check it."""
    out = {}
    for integrator in ("Euler", "RK4"):
        model, flex, qpos = servo_held_arm(integrator)
        servo = model.actuator("a3")
        out[integrator] = entry = {name: advice_record(a) for name, a in arm_advice(model, flex, qpos).items()}
        entry["servo"] = {"actuator": servo.name, "joint": model.joint(servo.trnid[0]).name,
                          "kp": float(-servo.biasprm[1])}  # fmt: skip
        if measure:

            def runs_away(h, model=model, qpos=qpos):
                return diverges(model, qpos, h, steps=STEPS, keyframe="level")

            entry["measured"] = measured_stable_step(runs_away, entry["operating"]["limit_s"])
            entry["without_servo_recommended_diverges"] = runs_away(entry["without_servo"]["recommended_s"])
    return out


def tutorial_namespace(path=TUTORIAL):
    """The spine tutorial, run as a script (its printed output kept out of this one's): its global names."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    with contextlib.redirect_stdout(io.StringIO()):
        namespace = runpy.run_path(path, run_name="__main__")
    plt.close("all")
    missing = [n for n in ("model", "flex", "where", "push", "torso", "loaded") if n not in namespace]
    if missing:
        raise SystemExit(f"{os.path.relpath(path, ROOT)} no longer defines {missing}: update scripts/operating_pose.py")
    return namespace


def engaged_stops(model, flex, qpos, element=0):
    """The coordinates (``"rx"`` ... ``"z"``) whose stop the element is past at ``qpos``."""
    data = mujoco.MjData(model)
    data.qpos[:] = qpos
    mujoco.mj_kinematics(model, data)
    x, stops = flex.stop_coordinates(data)[element], flex.records[element].stops
    lower = np.full(6, -np.inf) if stops is None or stops.lower is None else np.array(stops.lower)
    upper = np.full(6, np.inf) if stops is None or stops.upper is None else np.array(stops.upper)
    return [name for name, v, lo, hi in zip(("rx", "ry", "rz", "x", "y", "z"), x, lower, upper, strict=True)
            if not lo <= v <= hi]  # fmt: skip


def spine(measure=True):
    """The tutorial spine's advice at qpos0 and at the pushed pose and, with ``measure``, the runs that check it."""
    ns = tutorial_namespace()
    model, flex, push, loaded = ns["model"], ns["flex"], ns["push"], ns["loaded"]
    unloaded, pushed = ns["where"].values()  # the tutorial's two states: {} and {qpos, xfrc_applied}
    out = {
        "element": flex.names[0],
        "push_n": float(np.linalg.norm(push[ns["torso"], :3])),
        "push_body": model.body(ns["torso"]).name,
        "engaged_at_pushed_pose": engaged_stops(model, flex, loaded),
        "equality_solref": sorted({tuple(map(float, r)) for r in model.eq_solref}),
        "unloaded": advice_record(mjflex.step_advice(model, flex, **unloaded)),
        "pushed": advice_record(mjflex.step_advice(model, flex, **pushed)),
    }
    if measure:

        def runs_away(h, qpos=loaded, load=push):
            return diverges(model, qpos, h, steps=STEPS, xfrc_applied=load)

        out["measured"] = measured_stable_step(runs_away, out["pushed"]["limit_s"])
        out["measured_unloaded"] = measured_stable_step(lambda h: runs_away(h, model.qpos0, None),
                                                        out["unloaded"]["limit_s"])  # fmt: skip
        out["unloaded_recommended_diverges"] = runs_away(out["unloaded"]["recommended_s"])
    return out


def figures(measure=True):
    """Everything the JSON records but its command, date and machine (``measure=False``: the advice alone)."""
    return {"arm": arm(measure), "spine": spine(measure), "run_steps": STEPS, "rtol": RTOL,
            "knock": "1e-2 times a standard normal velocity on every dof (seed 0)"}  # fmt: skip


def summary(result):
    """What the JSON says, in a few lines [ms]."""

    def ms(x):
        return f"{x * 1e3:.3f} ms"

    lines = []
    for integrator, e in result["arm"].items():
        m = e["measured"]
        lines.append(
            f"arm, {integrator}: advised limit {ms(e['operating']['limit_s'])}; runs do not diverge up to "
            f"{ms(m['largest_stable_s'])} (diverge at {ms(m['smallest_unstable_s'])}); advised without the "
            f"servo {ms(e['without_servo']['limit_s'])}, at qpos0 {ms(e['reference']['limit_s'])}"
        )
    s = result["spine"]
    lines.append(f"spine, {s['pushed']['integrator']}: stiffest mode {s['unloaded']['stiffest_frequency_hz']:.0f} Hz "
                 f"at qpos0, {s['pushed']['stiffest_frequency_hz']:.0f} Hz pushed by {s['push_n']:g} N; advised "
                 f"limits {ms(s['unloaded']['limit_s'])} and {ms(s['pushed']['limit_s'])}; runs do not diverge up to "
                 f"{ms(s['measured_unloaded']['largest_stable_s'])} from qpos0, "
                 f"{ms(s['measured']['largest_stable_s'])} pushed")  # fmt: skip
    return "\n".join(lines)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", default="out/operating_pose.json")
    args = ap.parse_args()
    seen = []
    mujoco.set_mju_user_warning(seen.append)  # the diverging runs' warnings: counted, not printed
    result = figures()
    result["mujoco_warnings"] = len(seen)
    print(summary(result))
    write_json(args.json, result)


if __name__ == "__main__":
    main()

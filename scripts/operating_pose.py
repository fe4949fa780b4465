"""Step advice at the operating pose, checked by runs: the figures of the how-to's "Advice at the operating pose".

Usage::

    python scripts/operating_pose.py [--json out/operating_pose.json]

Three models, taken from where they are defined (not copied), each at its operating pose (its static equilibrium
under its load and actuator commands), for Euler, RK4 and implicitfast:

* **servo**: the servo-held arm of the tests (``tests/robots.py``: ``servo_held_arm``, its link3 on an element soft
  in bending and torsion, held by the position servo of the joint it replaced), keyframe ``level``; the advice
  also without the servos' stiffness and at the unloaded ``qpos0`` (``arm_advice``);
* **muscles**: a forearm on a compliant elbow held by two co-contracting muscles and a damper (``muscle_elbow``,
  ``ctrl = ELBOW_CTRL``); the advice also without the actuators (their force-velocity damping left out);
* **spine**: the spine of ``docs/tutorials/plot_06_spine.py``, run as it is: L3 replaced by a disc with stops,
  MuJoCo's default, soft ``solref`` on its equality constraints, pushed on the torso so that a stop is engaged; the
  top frequency with the equalities as MuJoCo applies them and projected as rigid (what the advice took before).

:func:`mjflex.step_advice` at the pose, and the **measured stable step**: the largest step at which two runs of
``STEPS`` steps from the pose, one knocked by 1e-6 on every dof, do not move apart 1000-fold (``tests/robots.py``'s
``knock_grows``, the test's own check), bisected to 0.1 % (``scripts/step_limits.py``'s ``bisect``); and whether a
knocked run grows at the advice that leaves something out.

Nothing is timed: the JSON is the same on every run (the advice to its bisection's 0.1 %; a measured step to its
bisection's 0.1 %). ``tests/test_operating_pose.py`` recomputes the advice (``figures(measure=False)``) and compares it
with the recorded JSON. Record with ``MJFLEX_RECORD=1`` (scripts/_bench.py), then render the pages with
``python scripts/results_blocks.py``.
"""

import argparse
import contextlib
import io
import os
import runpy
import sys
import warnings

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))  # _bench, step_limits: also imported by path
sys.path.append(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))  # tests/robots.py (the test's models)
import mujoco
import numpy as np
from _bench import write_json
from step_limits import RTOL, bisect

import mjflex
from mjflex.analysis.linearize import NotAtRestWarning
from tests.robots import ELBOW_CTRL, GROWTH, arm_advice, knock_grows, muscle_elbow, servo_held_arm

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
TUTORIAL = os.path.join(ROOT, "docs", "tutorials", "plot_06_spine.py")
STEPS = 3000  # steps of a run that checks a time step (tests/robots.py knock_grows' default)
INTEGRATORS = ("Euler", "RK4", "implicitfast")


def advice_record(advice):
    """The figures of a :class:`mjflex.StepAdvice`: limit and recommendation [s], the limiting eigenvalue's
    frequency [Hz] and damping ratio, the stiffest mode [Hz]."""
    return {
        "integrator": advice.integrator,
        "limit_s": float(advice.limit),
        "recommended_s": float(advice.recommended),
        "safety": float(advice.safety),
        "limiting_frequency_hz": float(advice.frequency),
        "limiting_damping_ratio": float(advice.damping_ratio),
        "stiffest_frequency_hz": float(advice.freq.max()),
    }


def measured_stable_step(grows, guess):
    """``{"largest_stable_s", "smallest_unstable_s"}``: the bisection bracket of the steps at which ``grows(h)`` is
    False, from ``guess`` (factors of 1.25, then to ``RTOL``)."""
    lo, hi = bisect(lambda h: not grows(h), guess)
    return {"largest_stable_s": float(lo), "smallest_unstable_s": float(hi)}


def _quiet_advice(*args, **kwargs):
    """step_advice of a state that is not at rest on purpose (a "without" what-if): its warning is not repeated."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", NotAtRestWarning)
        return mjflex.step_advice(*args, **kwargs)


def _entry(advice, blind, grows, measure):
    """One integrator's entry: the advice, the advice without something, and the runs that check both."""
    entry = {"advice": advice_record(advice), "blind": {k: advice_record(a) for k, a in blind.items()}}
    if measure:
        entry["measured"] = measured_stable_step(grows, advice.limit)
        entry["blind_grows"] = {k: bool(grows(a.limit)) for k, a in blind.items()}
    return entry


def servo(measure=True):
    """The servo-held arm, per integrator."""
    out = {}
    for integrator in INTEGRATORS:
        model, flex, qpos = servo_held_arm(integrator)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", NotAtRestWarning)
            advice = arm_advice(model, flex, qpos)

        def grows(h, model=model, qpos=qpos):
            return knock_grows(model, qpos, h, STEPS, keyframe="level")

        out[integrator] = _entry(advice.pop("operating"), advice, grows, measure)
    a3 = model.actuator("a3")
    out["servo"] = {"actuator": a3.name, "joint": model.joint(a3.trnid[0]).name, "kp": float(-a3.biasprm[1])}
    return out


def muscles(measure=True):
    """The muscle-held elbow, per integrator."""
    out = {}
    for integrator in INTEGRATORS:
        model, flex, qpos = muscle_elbow(integrator)
        advice = mjflex.step_advice(model, flex, qpos=qpos, ctrl=ELBOW_CTRL)
        blind = {"without_actuators": _quiet_advice(model, flex, qpos=qpos, ctrl=ELBOW_CTRL, actuator_stiffness=False)}

        def grows(h, model=model, qpos=qpos):
            return knock_grows(model, qpos, h, STEPS, ctrl=ELBOW_CTRL)

        out[integrator] = _entry(advice, blind, grows, measure)
    out["actuators"] = {mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_ACTUATOR, i): float(c)
                        for i, c in enumerate(ELBOW_CTRL)}  # fmt: skip
    return out


def tutorial_namespace(path=TUTORIAL):
    """The spine tutorial, run as a script (its printed output kept out of this one's): its global names."""
    import matplotlib  # late: the plotting backend is chosen before pyplot loads, only when the spine is run

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # late: after the backend

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
    """The tutorial spine at its pushed pose, per integrator (its own is RK4), and its top frequencies."""
    ns = tutorial_namespace()
    model, flex, push, loaded = ns["model"], ns["flex"], ns["push"], ns["loaded"]
    pushed = {"qpos": loaded, "xfrc_applied": push}
    with warnings.catch_warnings():  # rigid equalities leave the joint limits' forces out: not at rest, said
        warnings.simplefilter("ignore", NotAtRestWarning)
        modes = {c: float(mjflex.normal_modes(model, flex, constraints=c, joint_springs=True, gravity=True,
                                              **pushed)[0].max()) for c in ("spring", "project")}  # fmt: skip
    out = {
        "element": flex.names[0],
        "push_n": float(np.linalg.norm(push[ns["torso"], :3])),
        "push_body": model.body(ns["torso"]).name,
        "engaged_at_pushed_pose": engaged_stops(model, flex, loaded),
        "equality_solref": sorted({tuple(map(float, r)) for r in model.eq_solref}),
        "file_integrator": mujoco.mjtIntegrator(model.opt.integrator).name[6:],
        "stiffest_frequency_hz": {"soft": modes["spring"], "rigid": modes["project"]},
    }
    own = model.opt.integrator
    try:
        for integrator in INTEGRATORS:
            model.opt.integrator = getattr(mujoco.mjtIntegrator, f"mjINT_{integrator.upper()}")
            advice = mjflex.step_advice(model, flex, **pushed)

            def grows(h):
                return knock_grows(model, loaded, h, STEPS, xfrc_applied=push)

            out[integrator] = _entry(advice, {}, grows, measure)
    finally:
        model.opt.integrator = own
    return out


def figures(measure=True):
    """Everything the JSON records but its command, date and machine (``measure=False``: the advice alone)."""
    return {"servo": servo(measure), "muscles": muscles(measure), "spine": spine(measure), "run_steps": STEPS,
            "rtol": RTOL, "growth": GROWTH, "knock": "1e-6 times a standard normal velocity on every dof (seed 0)",
            "integrators": list(INTEGRATORS)}  # fmt: skip


def ratios(result):
    """``{(case, integrator): advised limit / largest stable step measured}``."""
    return {(case, i): result[case][i]["advice"]["limit_s"] / result[case][i]["measured"]["largest_stable_s"]
            for case in ("servo", "muscles", "spine") for i in result["integrators"]}  # fmt: skip


def summary(result):
    """What the JSON says, in a few lines [ms]."""
    lines = []
    for (case, integrator), r in ratios(result).items():
        e = result[case][integrator]
        lines.append(f"{case}, {integrator}: advised {e['advice']['limit_s'] * 1e3:.3f} ms, runs hold up to "
                     f"{e['measured']['largest_stable_s'] * 1e3:.3f} ms (advised / measured {r:.3f})")  # fmt: skip
    return "\n".join(lines)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", default="out/operating_pose.json")
    args = ap.parse_args()
    seen = []
    mujoco.set_mju_user_warning(seen.append)  # the growing runs' warnings: counted, not printed
    result = figures()
    result["mujoco_warnings"] = len(seen)
    print(summary(result))
    write_json(args.json, result)


if __name__ == "__main__":
    main()

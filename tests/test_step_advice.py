"""Step advice that counts what MuJoCo's step counts (issue 31 "Advice"), statics at the operating pose, and the study's
limit from the same advice (issue 30 "one answer for the step").

The references are runs: the largest stable step is measured by two runs from the operating pose, one knocked by
1e-6 on every dof, whose difference must not grow 1000-fold in 3000 steps (tests/robots.py ``knock_grows``; a bounded
chatter on a stop grows too). The advised limit must be within [0.8, 1.0] of it: a run at the limit holds, a run 5 %
above it grows. Damping ratios are measured by the logarithmic decrement of a free vibration.
"""

import math
import warnings

import mujoco
import numpy as np
import pytest

import mjflex
from mjflex.analysis.linearize import NotAtRestWarning, state
from tests.models import slide_oscillator_spec
from tests.robots import ELBOW_CTRL, K_WRIST, arm_spec, decay_ratio, knock_grows, muscle_elbow, servo_held_arm
from tests.spine import spine_on_its_stop

INTEGRATORS = ("Euler", "RK4", "implicitfast")


def _case(name, integrator):
    """``(model, flex, qpos, what the advice and the runs take)`` of one operating pose."""
    if name == "servo":
        model, flex, qpos = servo_held_arm(integrator)
        return model, flex, qpos, {"keyframe": "level"}
    if name == "muscles":
        model, flex, qpos = muscle_elbow(integrator)
        return model, flex, qpos, {"ctrl": ELBOW_CTRL}
    model, flex, qpos, xfrc = spine_on_its_stop(integrator)
    return model, flex, qpos, {"xfrc_applied": xfrc}


@pytest.mark.parametrize("integrator", INTEGRATORS)
@pytest.mark.parametrize("name", ["servo", "muscles", "stop_on_soft_equalities"])
def test_the_advised_limit_is_within_the_measured_stable_step(name, integrator):
    """At operating poses with a position servo holding a compliant joint, with muscles and a damper active (their
    force-velocity relation damps: explicitly under Euler and RK4, implicitly under implicitfast), and with a disc on
    its stop in a spine whose equalities are MuJoCo's default soft ones: a knocked run at the advised limit holds, one
    5 % above it grows."""
    model, flex, qpos, at = _case(name, integrator)
    advice = mjflex.step_advice(model, flex, qpos=qpos, **at)
    assert advice.integrator == integrator and advice.residual < 1e-6
    assert not knock_grows(model, qpos, advice.limit, **at)
    assert knock_grows(model, qpos, 1.05 * advice.limit, **at)


def test_the_muscles_damping_and_the_integrators_implicit_treatment_count():
    """The muscles' force-velocity slope and the damper are damping: under Euler they shorten the limit by a fifth
    (the advice without the actuators is optimistic, and a run there grows); implicitfast integrates them implicitly,
    so there they do not limit the step, which is then longer than Euler's."""
    model, flex, qpos = muscle_elbow("Euler")
    advice = mjflex.step_advice(model, flex, qpos=qpos, ctrl=ELBOW_CTRL)
    with pytest.warns(NotAtRestWarning):  # without the muscles the pose is not held
        blind = mjflex.step_advice(model, flex, qpos=qpos, ctrl=ELBOW_CTRL, actuator_stiffness=False)
    assert blind.limit > 1.2 * advice.limit and advice.damping_ratio > 0.1
    assert knock_grows(model, qpos, blind.limit, ctrl=ELBOW_CTRL)
    fast = mjflex.step_advice(model, flex, qpos=qpos, ctrl=ELBOW_CTRL, integrator="implicitfast")
    assert fast.limit > 1.2 * advice.limit


def test_ctrl_sets_the_commands_and_the_steady_activations():
    """``ctrl=`` is the keyframe's controls without a keyframe: the servo-held arm's advice from ctrl equals its
    advice from the keyframe; for muscles, the activations are at their steady state (act = ctrl)."""
    model, flex, qpos = servo_held_arm("Euler")
    by_key = mjflex.step_advice(model, flex, keyframe="level", qpos=qpos)
    by_ctrl = mjflex.step_advice(model, flex, qpos=qpos, ctrl=model.key("level").ctrl)
    assert by_ctrl.limit == pytest.approx(by_key.limit, rel=1e-9)
    model, _, qpos = muscle_elbow("Euler")
    data = state(model, qpos=qpos, ctrl=ELBOW_CTRL)
    np.testing.assert_array_equal(data.act, ELBOW_CTRL[:2])


@pytest.mark.parametrize(
    "ctrl, match",
    [([0.5, 0.5], r"ctrl must be 3 numbers, one per actuator \['flexor', 'extensor', 'damper'\]"),
     ([0.5, np.nan, 1.0], r"ctrl must be finite; it is \[nan\] for actuator\(s\) \['extensor'\]")],
)  # fmt: skip
def test_a_bad_ctrl_is_refused_naming_the_actuators(ctrl, match):
    model, flex, qpos = muscle_elbow("Euler")
    for call in (mjflex.step_advice, mjflex.normal_modes, mjflex.static_equilibrium):
        with pytest.raises(ValueError, match=match):
            call(model, flex, qpos=qpos, ctrl=ctrl)


def test_a_state_that_is_not_at_rest_is_said_with_its_residual():
    """The arm at its keyframe, not at its equilibrium: the advice says the state is not at rest, with the residual
    force and the dof it acts on (the largest: the shoulder's j2 carries the arm's weight), not a negative stiffness.
    The residual is MuJoCo's, without dry friction (which the advice leaves out: at rest it would hold 0.1 N m)."""
    model, flex, _ = servo_held_arm("Euler")
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        advice = mjflex.step_advice(model, flex, keyframe="level")
    said = [str(w.message) for w in seen if issubclass(w.category, NotAtRestWarning)]
    assert len(said) == 1 and not any("modes have negative stiffness" in str(w.message) for w in seen)
    assert "the state is not at rest" in said[0] and "on joint 'j2' (hinge of body 'link2'; N m)" in said[0]
    data = state(model, keyframe="level")
    model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_FRICTIONLOSS
    mujoco.mj_forward(model, data)
    residual = data.qfrc_smooth + data.qfrc_constraint
    assert f"leave {residual[1]:.3g} on" in said[0] and advice.residual == pytest.approx(np.abs(residual).max(), 1e-6)


def test_the_advised_damping_ratio_is_the_measured_logarithmic_decrement():
    """A block on a damped element (issue 33 item 17): the advice's damping ratio of its limiting mode against the
    logarithmic decrement of a free vibration along that mode, at a step far below the limit."""
    k, m, zeta = 4e4, 0.5, 0.03
    B = [1e-3, 1e-3, 1e-3, 2 * zeta * math.sqrt(k * m), 2 * zeta * math.sqrt(k * m), 2 * zeta * math.sqrt(k * m)]
    spec = slide_oscillator_spec(k=k, mass=m, B=B)
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_RK4
    model = spec.compile()
    flex = mjflex.Flexures(model)
    advice = mjflex.step_advice(model, flex)
    assert advice.frequency == pytest.approx(math.sqrt(k / m) / (2 * math.pi), rel=1e-6)
    model.opt.timestep = advice.limit / 100
    data = mujoco.MjData(model)
    data.qvel[:] = 1e-3 * advice.mode
    y = np.empty(int(6 / advice.frequency / model.opt.timestep))
    for i in range(len(y)):
        mujoco.mj_step(model, data)
        y[i] = data.qpos @ advice.mode
    measured, periods = decay_ratio(y)
    assert periods >= 5 and advice.damping_ratio == pytest.approx(measured, rel=0.01)
    assert advice.damping_ratio == pytest.approx(zeta, rel=1e-6)  # and the closed form: c / (2 sqrt(k m))


def test_an_undamped_mode_has_a_damping_ratio_of_zero_not_the_eigensolvers_round_off():
    """Without damping, ``Re lambda`` of the limiting mode is the eigensolver's round-off (3.8e-18 of ``|lambda|`` on
    one CPU, 0 on another): the advice says 0, so that its text reads the same on every machine; a small real damping
    (3e-6 on the limiting rocking mode) is still seen."""
    for c in (0.0, 2e-6 * math.sqrt(1e4 * 0.5)):
        spec = mujoco.MjSpec.from_string(
            '<mujoco><option integrator="RK4" gravity="0 0 0"/><worldbody><body name="block" pos="0 0 -0.1">'
            '<freejoint/><geom type="box" size="0.02 0.02 0.02" mass="0.5"/></body></worldbody></mujoco>'
        )
        mjflex.add_flexure(
            spec, "leaf", "world", "block", pos=[0, 0, -0.05], K=[2, 2, 1, 1e4, 1e4, 1e4], B=[0, 0, 0, c, c, c]
        )
        model = spec.compile()
        advice = mjflex.step_advice(model)
        assert ("damping ratio 0)" in str(advice)) == (c == 0), str(advice)
        assert (advice.damping_ratio == 0.0) if c == 0 else (1e-6 < advice.damping_ratio < 1e-5)


GRIPPER = """<mujoco model="gripper">
  <option timestep="2e-3" solver="{solver}"/>
  <worldbody>
    <body name="palm" pos="0 0 0.5">
      <geom type="box" size="0.04 0.02 0.01" mass="0.3"/>
      <body name="left" pos="-0.03 0 -0.01">
        <joint name="left" axis="0 1 0" range="-0.6 0.6" limited="true" damping="0.01"/>
        <geom type="capsule" fromto="0 0 0 0 0 -0.06" size="0.006" mass="0.03"/>
      </body>
      <body name="right" pos="0.03 0 -0.01">
        <joint name="right" axis="0 1 0" range="-0.6 0.6" limited="true" damping="0.01"/>
        <geom type="capsule" fromto="0 0 0 0 0 -0.06" size="0.006" mass="0.03"/>
      </body>
    </body>
  </worldbody>
  <contact><exclude body1="palm" body2="left"/><exclude body1="palm" body2="right"/></contact>
  <equality><joint joint1="right" joint2="left" polycoef="0 -1 0 0 0"/></equality>
  <actuator><position name="close" joint="left" kp="5" ctrlrange="-0.6 0.6"/></actuator>
</mujoco>"""


def _gripper(solver):
    spec = mujoco.MjSpec.from_string(GRIPPER.format(solver=solver))
    mjflex.make_compliant(spec, "left", [0.5, 2, 0.5, 1e4, 1e4, 1e4], replace_joints=True)
    model = spec.compile()
    return model, mjflex.Flexures(model)


def test_static_equilibrium_converges_to_the_constraint_solvers_noise():
    """A parallel gripper whose right finger follows the compliant left one by a joint equality, solved by MuJoCo's
    iterative CG solver: at two of five commands its residual stops near 1e-9 N m, above a tolerance of 1e-10 of the
    force scale but at the solver's noise. The poses are the equilibria: those of the exact Newton solver, to 1e-6 rad
    on the right finger (held by the soft equality alone, ~0.1 N m/rad: the solver's ~1e-8 N m moves it ~1e-7 rad)
    and 1e-9 elsewhere."""
    model, flex = _gripper("CG")
    exact, exact_flex = _gripper("Newton")
    for c in (-0.1, -0.2, -0.3, -0.4, -0.5):
        q = mjflex.static_equilibrium(model, flex, ctrl=[c])
        reference = mjflex.static_equilibrium(exact, exact_flex, ctrl=[c])
        np.testing.assert_allclose(q[:-1], reference[:-1], rtol=0, atol=1e-9)
        np.testing.assert_allclose(q[-1], reference[-1], rtol=0, atol=1e-6)


def test_static_equilibrium_converges_to_the_forces_round_off():
    """The compliant gripper's notch hinges (tests.robot_scenes), stiff in translation in a 0.4 m model: Newton's
    residual stops near 3e-9 N, above 1e-10 of the 13 N force scale but at the forces' round-off (statics'
    docstring). Converged at the default tolerance, where the residual is within 10 times its spread under shifts
    of the configuration by a rounding error (eps times the model's extent, eps rad), measured here."""
    from mjflex.analysis import statics
    from tests import robot_scenes

    _, full, info = robot_scenes.SCENES["gripper"]()
    model = full.compile()
    q = mjflex.static_equilibrium(model, keyframe=info["keyframe"])
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, info["keyframe"]))
    data.qpos[:] = q
    moving = np.arange(model.nv)
    r = statics._residual(model, data, moving)
    kind = model.jnt_type[model.dof_jntid]
    first = model.jnt_dofadr[model.dof_jntid]
    rotation = (kind != mujoco.mjtJoint.mjJNT_SLIDE) & ~(
        (kind == mujoco.mjtJoint.mjJNT_FREE) & (np.arange(model.nv) < first + 3)
    )
    rng, spread = np.random.default_rng(0), np.zeros(model.nv)
    for _ in range(20):
        shift = np.finfo(float).eps * np.where(rotation, 1.0, model.stat.extent) * rng.choice([-1.0, 1.0], model.nv)
        data.qpos[:] = q
        mujoco.mj_integratePos(model, data.qpos, shift, 1.0)
        spread = np.maximum(spread, np.abs(statics._residual(model, data, moving) - r))
    assert np.abs(r).max() > 1e-10 * 12.0  # above the plain tolerance: the case this is about
    assert np.all(np.abs(r) <= 10 * spread + 1e-10 * 12.9)


def test_static_equilibrium_that_fails_says_by_how_much_and_where():
    """A block on a slide that nothing holds, under gravity along it: the message gives the residual, its dof (in
    words, with its unit) and how far above the tolerance it is."""
    spec = mujoco.MjSpec.from_string(
        '<mujoco><worldbody><body name="carriage"><joint name="rail" type="slide" axis="0 0 1"/>'
        '<geom type="box" size="0.02 0.02 0.02" mass="0.5"/></body><body name="tool" pos="0.2 0 0"><freejoint/>'
        '<geom type="box" size="0.02 0.02 0.02" mass="0.1"/></body></worldbody></mujoco>'
    )
    mjflex.add_flexure(spec, "mount", "world", "tool", pos=[0.2, 0, 0], K=[2, 2, 1, 1e4, 1e4, 1e4])
    model = spec.compile()
    with pytest.raises(RuntimeError) as error:
        mjflex.static_equilibrium(model, max_iterations=5)
    said = str(error.value)
    weight = 0.5 * 9.81
    where = "on joint 'rail' (slide of body 'carriage'; N)"
    assert f"the residual force farthest above its tolerance is {-weight:.3g} {where}" in said
    assert f"{weight / (1e-10 * weight):.3g} times the tolerance" in said and "nothing holds that dof" in said


def test_the_studys_limit_is_step_advices():
    """The study's advised limit of each integrator (the bracket it reports beside the measured one) is
    mjflex.step_advice's at the scene's start, asked with the study's horizon (its duration)."""
    from mjflex.app.study import study

    spec = arm_spec()
    with pytest.warns(mjflex.LikelyMistakeWarning, match="replaces hinge 'j3'"):  # stiffer about j3, on purpose
        mjflex.make_compliant(spec, "link3", K_WRIST, replace_joints=True)
    model = spec.compile()
    result = study(spec, keyframe="up", duration=0.05, samples=20, methods=("twist",), integrators=("euler", "rk4"),
                   steps=(2e-3, 1e-3, 5e-4), bisect=4, variants=[], repeat=1, progress=False)  # fmt: skip
    for limit in result.limits:
        assert limit.linear_step is not None and limit.largest_stable is not None, limit.text()
        with pytest.warns(NotAtRestWarning):  # the scene starts from a keyframe that moves
            advice = mjflex.step_advice(model, integrator=limit.integrator, keyframe="up", horizon=result.duration)
        assert limit.linear_step <= advice.unstable and advice.limit <= limit.linear_unstable, limit.text()
        assert f"{limit.linear_step:.3g}" in limit.text() and f"{limit.largest_stable:.3g}" in limit.text()

"""mjflex.reduce on robots: elements inside kinematic trees, at the file's own time step (issue 32).

The scenes (tests/robot_scenes.py): a four-bar gripper whose passive pivots are notch hinges, a lumbar spine whose L3
hinges (tied by equalities, moved by muscles, motors and a servo) are a disc, and gymnasium's pusher arm with a
compliant wrist. The full models need steps of microseconds (the notches' stiff directions); ``mjflex.reduce(full)``
must give models that run at the file's step, keep the names a controller, a sensor reader or a keyframe uses, and
agree with the full model in statics and in the modes the step resolves.
"""

import contextlib
import re
import warnings

import mujoco
import numpy as np
import pytest

import mjflex
from tests import robot_scenes
from tests.plugin_models import assert_not_diverged


def _names(model, kind, count):
    return [mujoco.mj_id2name(model, kind, i) for i in range(count)]


def actuated_run(model, ctrl, seconds, keyframe=None):
    """A run of ``seconds`` at the model's own step with the controls ``ctrl(t)``; the final data."""
    data = mujoco.MjData(model)
    if keyframe is not None:
        mujoco.mj_resetDataKeyframe(model, data, model.key(keyframe).id)
    flex = mjflex.Flexures(model) if mjflex.Variant.has_flexures.fget(_Shim(model)) else None
    with flex if flex is not None else contextlib.nullcontext():
        while data.time < seconds:
            data.ctrl[:] = ctrl(data.time)
            mujoco.mj_step(model, data)
    return data


class _Shim:  # Variant.has_flexures for a bare model
    def __init__(self, model):
        self.model = model


@pytest.fixture(scope="module", params=["gripper", "pusher_wrist"])
def reached(request):
    rigid, full, info = robot_scenes.SCENES[request.param]()
    with warnings.catch_warnings():
        warnings.simplefilter("error", mjflex.ReductionWarning)
        variant = mjflex.reduce(full)
    return request.param, rigid.compile(), full.compile(), variant, info


def test_the_reduced_robot_runs_at_the_file_step_and_matches_the_full_model(reached):
    name, rigid, full, variant, info = reached
    step = variant.details["step"]
    assert step["timestep"] == full.opt.timestep == rigid.opt.timestep  # the file's own step, by default
    assert variant.model.opt.timestep == full.opt.timestep and variant.model.opt.integrator == full.opt.integrator
    assert step["reached"] and step["advised_step"] >= full.opt.timestep
    at_rest = mjflex.static_equilibrium(full, keyframe=info["keyframe"])
    full_advice = mjflex.step_advice(full, keyframe=info["keyframe"], qpos=at_rest)
    assert full_advice.recommended < full.opt.timestep / 10  # the full model cannot run there
    assert variant.details["modes"]["max_relative_error"] < 0.01
    assert len(variant.details["modes"]["reduced_hz"]) == len(variant.details["modes"]["full_hz"]) >= 1
    assert max(s["relative"] for s in variant.details["statics"]) < 0.01
    assert variant.model.nv == rigid.nv  # the notch hinges and the wrist are their hinges again
    if name == "pusher_wrist":  # its hinge's range became the element's stops: not a spring, the element in 1 direction
        assert variant.has_flexures and "wrist: in place on r_wrist_flex_link's joints: compliant rz" in variant.report
        assert "it becomes the element in 1 of 6 directions (rz)" in variant.report
    else:  # the notches: MuJoCo's own springs, nothing of mjflex left
        assert not variant.has_flexures
    data = actuated_run(variant.model, info["ctrl"], 10.0, info["keyframe"])
    assert_not_diverged(data, f"{name} reduced, 10 s at {full.opt.timestep} s")
    assert np.isfinite(data.qpos).all() and data.time >= 10.0


def test_the_reduced_robot_keeps_the_source_names(reached):
    _, _, full, variant, _ = reached
    m = variant.model
    O = mujoco.mjtObj
    for kind, count in ((O.mjOBJ_ACTUATOR, "nu"), (O.mjOBJ_TENDON, "ntendon"), (O.mjOBJ_EQUALITY, "neq"),
                        (O.mjOBJ_SENSOR, "nsensor"), (O.mjOBJ_KEY, "nkey")):  # fmt: skip
        assert _names(m, kind, getattr(m, count)) == _names(full, kind, getattr(full, count))
    assert np.array_equal(m.key_ctrl, full.key_ctrl)  # a keyframe's controls carry over
    for j in range(full.njnt):  # every joint the reduction kept is the source's, with its armature
        name = mujoco.mj_id2name(full, O.mjOBJ_JOINT, j)
        v = mujoco.mj_name2id(m, O.mjOBJ_JOINT, name)
        if v >= 0:
            assert m.dof_armature[m.jnt_dofadr[v]] == full.dof_armature[full.jnt_dofadr[j]]
            assert np.allclose(m.jnt_axis[v], full.jnt_axis[j]) and m.jnt_type[v] == full.jnt_type[j]


def test_state_from_maps_a_full_state_to_the_reduced_one(reached):
    """A state of the full model that moves only the kept joints maps to the same joint values, exactly."""
    _, _, full, variant, _ = reached
    data = mujoco.MjData(full)
    rng = np.random.default_rng(1)
    kept = [j for j in range(full.njnt) if mujoco.mj_name2id(variant.model, mujoco.mjtObj.mjOBJ_JOINT,
                                                               full.joint(j).name) >= 0]  # fmt: skip
    for j in kept:
        if full.jnt_type[j] in (mujoco.mjtJoint.mjJNT_HINGE, mujoco.mjtJoint.mjJNT_SLIDE):
            data.qpos[full.jnt_qposadr[j]] += 0.01 * rng.normal()
            data.qvel[full.jnt_dofadr[j]] = 0.1 * rng.normal()
    mujoco.mj_forward(full, data)
    qpos, _ = variant.state_from(full, data)
    for j in kept:
        v = variant.model.joint(full.joint(j).name)
        n = {0: 7, 1: 4}.get(int(full.jnt_type[j]), 1)
        assert np.allclose(qpos[v.qposadr[0] : v.qposadr[0] + n], data.qpos[full.jnt_qposadr[j] :][:n], atol=1e-9)


def test_a_notch_pivot_becomes_a_mujoco_spring_with_its_compliant_stiffness():
    """The gripper's pivots: hinges about element z, whose element coordinate is the joint angle, become MuJoCo
    springs of exactly K_zz (1/2 K_zz theta^2 at any angle): checked against the full model's element energy."""
    _, full_spec, _ = robot_scenes.gripper()
    full = full_spec.compile()
    variant = mjflex.reduce(full_spec)
    K = mjflex.geometry.notch_hinge_stiffness(**robot_scenes.NOTCH)
    flex = mjflex.Flexures(full)
    data = mujoco.MjData(full)
    for s in ("left", "right"):
        for part in ("follower", "coupler"):
            joint = f"{s}_{part}_pivot"
            v = variant.model.joint(joint)
            assert v.stiffness[0] == pytest.approx(K[2, 2], rel=1e-12)
            qposadr = variant.model.jnt_qposadr[v.id]
            rest = full.qpos0[full.joint(joint).qposadr[0]]
            assert variant.model.qpos_spring[qposadr] == pytest.approx(rest, abs=1e-15)
            for theta in (0.05, 0.4):
                data.qpos[:] = full.qpos0
                data.qpos[full.joint(joint).qposadr[0]] += theta
                mujoco.mj_kinematics(full, data)
                energy = flex.potential_energies(data)[flex.index(f"{s}_{part}_notch")]
                assert energy == pytest.approx(0.5 * v.stiffness[0] * theta**2, rel=1e-9)
    assert not variant.has_flexures  # every notch is a spring now: nothing of mjflex left to evaluate


def test_the_spine_says_which_direction_its_band_needs_and_the_step_that_keeps_it():
    """At the file's 2 ms the disc's shear must go rigid to resolve the step, but a band mode stores a few percent
    in it: a ReductionWarning names it and the largest step that keeps it; at that step the band is within 1 %."""
    _, full_spec, info = robot_scenes.spine()
    with pytest.warns(mjflex.ReductionWarning, match=r"holding rigid disc [xy], which the modes"):
        at_file = mjflex.reduce(full_spec)
    needed = at_file.details["step"]["needed"]
    assert needed["element"] == "disc" and needed["direction"] in ("x", "y")
    assert at_file.details["modes"]["max_relative_error"] > 0.01  # the price, reported
    largest = needed["largest_step"]
    assert 0.5e-3 < largest < 2e-3
    with warnings.catch_warnings():
        warnings.simplefilter("error", mjflex.ReductionWarning)
        kept = mjflex.reduce(full_spec, timestep=largest)
    assert kept.details["modes"]["max_relative_error"] < 0.01
    assert max(s["relative"] for s in kept.details["statics"]) < 0.01
    assert {"L3_flex", "L3_bend", "L3_rot"} <= {kept.model.joint(j).name for j in range(kept.model.njnt)}
    assert kept.has_flexures and "disc: in place on L3's joints" in kept.report  # three hinges in series: not springs
    assert "it becomes the element in" in kept.report
    assert kept.details["elements"]["disc"]["needed"]["ry"] == ["actuator L3_flexor", "tendon erector"]
    kept.model.opt.timestep = largest
    data = actuated_run(kept.model, info["ctrl"], 2.0, info["keyframe"])
    assert_not_diverged(data, "spine reduced at its largest step")


def test_a_band_reduction_of_a_tree_model_gives_the_same_model():
    """keep_below_hz on the gripper: the band's modes need the pivots' rotations only, as the step did."""
    _, full_spec, _ = robot_scenes.gripper()
    by_band = mjflex.reduce(full_spec, keep_below_hz=100.0)
    by_step = mjflex.reduce(full_spec)
    assert by_band.model.nv == by_step.model.nv
    assert {e: d["soft"] for e, d in by_band.details["elements"].items()} == {
        e: d["soft"] for e, d in by_step.details["elements"].items()
    }


@pytest.mark.parametrize("timestep", [0.0, -1e-3, float("nan"), float("inf")])
def test_a_step_that_is_not_a_step_is_refused(timestep):
    with pytest.raises(ValueError, match="timestep"):
        mjflex.reduce(robot_scenes.spine()[1], timestep=timestep)


def test_a_step_no_reduction_reaches_names_the_element_and_direction():
    """The pusher's wrist flexion is driven by a motor (needed) and rings at 1.9 Hz where the scene rests: 0.2 s cannot
    resolve it. The largest step the error gives is the step advice's, and a reduction for it resolves it."""
    _, full_spec, _ = robot_scenes.pusher_wrist()
    with pytest.raises(ValueError, match=r"element 'wrist', direction rz \(needed by actuator #5\).*largest step") as e:
        mjflex.reduce(full_spec, timestep=0.2)
    largest = float(re.search(r"the largest step with it is ([0-9.e-]+) s \(the step advice", str(e.value)).group(1))
    assert 0.01 < largest < 0.2
    with warnings.catch_warnings():
        warnings.simplefilter("error", mjflex.ReductionWarning)
        at_largest = mjflex.reduce(full_spec, timestep=largest * (1 - 1e-3))  # the message rounds to 3 digits
    assert at_largest.details["step"]["advised_step"] >= at_largest.model.opt.timestep


def test_the_step_advice_is_asked_where_the_scene_rests():
    """The gripper under gravity is not at rest at qpos0: reduce asks the reduced model's step advice at its static
    equilibrium under the keyframe's controls (no NotAtRestWarning), the same advice mjflex.step_advice gives there."""
    _, full_spec, info = robot_scenes.gripper()
    with warnings.catch_warnings():
        warnings.simplefilter("error", mjflex.analysis.linearize.NotAtRestWarning)
        variant = mjflex.reduce(full_spec)
    m = variant.model
    at_rest = mjflex.static_equilibrium(m, keyframe=info["keyframe"])
    advice = mjflex.step_advice(m, keyframe=info["keyframe"], qpos=at_rest)
    step = variant.details["step"]
    assert step["advised_step"] == pytest.approx(advice.recommended, rel=1e-3)  # two Newton solves to 1e-8 and 1e-10
    assert step["advice_state"] == "keyframe 'open'" and step["advice_states"][0]["at_rest"]
    assert step["advised_step"] >= m.opt.timestep
    assert "linearized where the scene rests" in variant.report and "'open', its rest" in variant.report


@pytest.mark.filterwarnings("ignore:invalid value encountered in divide:RuntimeWarning")  # a planar K's zero rows
def test_an_element_that_cannot_be_reduced_is_named_and_the_rest_is_reduced():
    """A planar element (its out-of-plane directions are free) in a 3-D scene stays whole: a ReductionWarning and the
    report name it; the gripper's notches are reduced all the same."""
    _, full_spec, _ = robot_scenes.gripper()
    tag = full_spec.worldbody.add_body(name="tag", pos=[0.3, 0.0, 0.1])
    tag.add_freejoint()
    tag.add_geom(size=[0.05, 0.0, 0.0], mass=1.0)
    mjflex.add_flexure(full_spec, "tag_leaf", "world", "tag", pos=[0.3, 0.0, 0.1], K=np.diag([0.01, 1.0, 1.0]))
    with pytest.warns(mjflex.ReductionWarning, match=r"1 element\(s\) stay whole: tag_leaf \(planar element"):
        variant = mjflex.reduce(full_spec)
    assert variant.details["elements"]["tag_leaf"]["kept"]
    assert "tag_leaf: kept as an element (planar element in a non-planar scene" in variant.report
    assert not any(variant.details["elements"][f"{s}_{p}_notch"]["kept"] for s in ("left", "right")
                   for p in ("follower", "coupler"))  # fmt: skip


def test_mocap_bodies_and_keyframes_with_mocap_poses_are_kept():
    """A mocap target beside the gripper: the reduced model keeps it and the keyframes' mocap poses."""
    _, full_spec, _ = robot_scenes.gripper()
    target = full_spec.worldbody.add_body(name="target", mocap=True, pos=[0.1, 0.2, 0.3])
    target.add_geom(size=[0.01, 0.0, 0.0], contype=0, conaffinity=0)
    full = full_spec.compile()
    key = mujoco.MjData(full)
    full_spec.keys[0].mpos = [0.2, 0.1, 0.4]
    full = full_spec.compile()
    variant = mjflex.reduce(full_spec)
    m = variant.model
    assert m.nmocap == 1 and m.body("target").mocapid[0] == 0
    assert np.allclose(m.key_mpos, full.key_mpos) and np.allclose(m.key_mquat, full.key_mquat)
    del key


def test_the_study_compares_the_reduction_at_the_file_step():
    """The study's default variants include the reduction at the file's step, and its step grid the file's step (so
    every model is run there, side by side); a model the file's step holds nothing rigid in gets no such variant."""
    from mjflex.app.study import _sweep
    from mjflex.app.study.variants import DEFAULT_VARIANTS, reduced_at_file_step

    assert reduced_at_file_step in DEFAULT_VARIANTS
    variant = reduced_at_file_step(robot_scenes.gripper()[1])
    assert variant.name == "reduced(file step)" and variant.model.opt.timestep == 0.002
    spec = mujoco.MjSpec.from_string(
        '<mujoco><option timestep="1e-5"/><worldbody><body name="block" pos="0 0 -0.1"><freejoint/>'
        '<geom type="box" size="0.02 0.02 0.02" mass="0.5"/></body></worldbody></mujoco>'
    )
    mjflex.add_flexure(spec, "leaf", "world", "block", pos=[0, 0, -0.05], K=[2, 2, 1, 1e5, 1e5, 1e5])
    with pytest.raises(mjflex.VariantNotApplicableError, match="holds nothing rigid"):
        reduced_at_file_step(spec)
    plan = _sweep._plan(0.002, np.array([10.0]), 1e3, duration=0.1, samples=10, steps=None, step_count=4,
                        max_step=7e-3, min_step=None)  # fmt: skip
    assert any(abs(plan.h(n) - 0.002) < 1e-12 for n in plan.grid)  # the file's step is a candidate


def test_arcade_reduces_as_recorded():
    """Free bodies coupled by elements (ARCADE) take the path they took before trees were reduced: the 50 Hz
    reduction keeps the directions, degrees of freedom and modes of docs/results/reduce_arcade.json."""
    import json
    import os

    root = os.path.join(os.path.dirname(__file__), "..")
    with open(os.path.join(root, "docs", "results", "reduce_arcade.json")) as f:
        recorded = json.load(f)["details"]["reduced(50 Hz)"]
    variant = mjflex.reduce(os.path.join(root, "models", "arcade.xml"), 50.0)
    assert variant.model.nv == recorded["nv"]
    assert {e: d["soft"] for e, d in variant.details["elements"].items()} == {
        e: d["soft"] for e, d in recorded["elements"].items()
    }
    assert variant.details["modes"]["reduced_hz"] == pytest.approx(recorded["modes"]["reduced_hz"], rel=1e-6)


@pytest.mark.parametrize("scene", ["gripper", "spine", "pusher_wrist"])
def test_the_robots_reduce_as_recorded(scene):
    """docs/results/reduce_robots.json is the scenes' reduction with today's code and defaults: the same degrees of
    freedom, modes and advised step (at the scene's rest), and for the spine the same largest step that keeps what
    its band needs."""
    import json
    import os

    with open(os.path.join(os.path.dirname(__file__), "..", "docs", "results", "reduce_robots.json")) as f:
        recorded = json.load(f)["rows"][scene]
    _, full_spec, _ = robot_scenes.SCENES[scene]()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", mjflex.ReductionWarning)  # the spine's, recorded in the JSON too
        variant = mjflex.reduce(full_spec)
    assert variant.model.nv == recorded["nv"]["reduced"]
    assert variant.details["modes"]["reduced_hz"] == pytest.approx(recorded["modes"]["reduced_hz"], rel=1e-6)
    assert variant.details["step"]["advised_step"] == pytest.approx(recorded["reduced_advised_step"], rel=1e-3)
    needed = variant.details["step"].get("needed")
    assert (needed is None) == (recorded["needed"] is None)
    if needed:
        assert needed["largest_step"] == pytest.approx(recorded["needed"]["largest_step"], rel=1e-3)


def test_a_plugin_other_than_mjflex_is_kept():
    """The gripper's lifter as MuJoCo's own PID actuator plugin: the reduced model keeps the plugin, its actuator and
    its activation, and runs."""
    xml = robot_scenes.gripper_xml().replace(
        '<position name="lifter" joint="lift" kp="2000" ctrlrange="-0.2 0.2"/>',
        '<plugin name="lifter" plugin="mujoco.pid" joint="lift" actdim="1"><config key="kp" value="2000"/>'
        '<config key="ki" value="10"/></plugin>',
    )
    xml = xml.replace("<worldbody>", '<extension><plugin plugin="mujoco.pid"/></extension><worldbody>', 1)
    xml = xml.replace('ctrl="0 0.01"', 'ctrl="0 0.01" act="0.001"')
    _, full_spec, info = robot_scenes.gripper(xml)
    full = full_spec.compile()
    variant = mjflex.reduce(full_spec)
    m = variant.model
    assert not variant.has_flexures and m.nplugin == 1 and m.na == full.na == 1
    assert mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_ACTUATOR, int(m.actuator_plugin.argmax())) == "lifter"
    assert np.array_equal(m.key_act, full.key_act)
    data = actuated_run(m, info["ctrl"], 2.0, info["keyframe"])
    assert_not_diverged(data, "the gripper with a PID lifter, reduced")

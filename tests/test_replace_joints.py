"""Joints replaced by an element in one call (mjflex.make_compliant(..., replace_joints=True)), and put back.

Two models go through it: a hand-built lumbar spine (tests/spine.py: hinge triplets tied level to level by joint
equalities, actuators and sensors on a level, a fixed tendon, a moving keyframe) and robot arms with an elastic
joint (gymnasium's pusher, unmodified, and tests/robots.py's servo-held arm). Every check is against a value
computed here from the model: the equalities' joints and coefficients from the spine's couplings, the stops from
the ranges in radians, the keyframe poses and velocities from the original model's kinematics, the actuators' and
sensors' readings from the original model's at the same state, the stiffness of a loaded elastic joint from its
symmetry (a conservative model), and the undo against the original compiled model, array by array, and its XML.
"""

import math
import os
import subprocess
import sys
import warnings

import mujoco
import numpy as np
import pytest

import mjflex
from tests.robots import arm_spec, pusher_path
from tests.spine import HINGES, LEVELS, key_values, radians, spine_spec

K_DISC = np.array([50.0, 50.0, 30.0, 2e5, 2e5, 5e5])  # N m/rad x 3 (bend x, flex y, rot z), N/m x 3


def _undone(spec, c):
    """``make_rigid``; ``spec.to_xml()`` then still declares the plugin (MjSpec cannot take it back)."""
    mjflex.make_rigid(spec, c)
    assert 'plugin="mjflex.flexure"' in spec.to_xml()


def assert_same_model(a, b):
    """Every array of two compiled models equal (names, ids, sizes, parameters), and their sizes."""
    for name in dir(a):
        if name.startswith("_"):
            continue
        x = getattr(a, name)
        if isinstance(x, np.ndarray):
            np.testing.assert_array_equal(x, getattr(b, name), err_msg=name)
        elif isinstance(x, int) and not isinstance(x, bool):
            assert x == getattr(b, name), name


def _poses(model, key):
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, key)
    mujoco.mj_forward(model, data)
    vel = np.zeros((model.nbody, 6))
    for b in range(model.nbody):
        mujoco.mj_objectVelocity(model, data, mujoco.mjtObj.mjOBJ_BODY, b, vel[b], 0)
    return data.xpos.copy(), data.xquat.copy(), vel


def _state(model, key=0, extra=None):
    """``mj_forward`` at a keyframe (``extra`` (qpos address, value) pairs added)."""
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, key)
    for address, value in extra or ():
        data.qpos[address] += value
    mujoco.mj_forward(model, data)
    return data


def _sensor(model, data, name):
    i = model.sensor(name).id
    return data.sensordata[model.sensor_adr[i] : model.sensor_adr[i] + model.sensor_dim[i]]


def _replace(spec, body="L3", **kwargs):
    kwargs.setdefault("K", K_DISC)
    return mjflex.make_compliant(spec, body, replace_joints=True, **kwargs)


# ----------------------------------------------------------------------------- the spine


@pytest.mark.parametrize("stops", ["limits", "element"])
def test_a_driven_level_is_replaced_and_its_couplings_removed(stops):
    """The default (``stops="limits"``) keeps the hinges' ranges as MuJoCo's joint limits, with their solref and
    solimp; ``stops="element"`` makes them the element's stops. Either way the hinges keep their armature (rotor
    inertia, there whatever the stiffness) and lose their springs and dampers."""
    spec = spine_spec()
    rigid = spec.compile()
    c = _replace(spec, stops=None if stops == "limits" else stops)
    model = spec.compile()
    r = c.replaced
    assert r.joints == ("L3_flex", "L3_bend", "L3_rot") and r.stops == stops and r.kept == ()
    # the hinges stay as the element's coordinates, without springs and dampers; three slides are added
    assert c.joints == tuple(f"L3_compliance/{j}" for j in "xyz")
    assert (model.nq, model.nv) == (rigid.nq + 3, rigid.nv + 3)
    for name in r.joints:
        j, i = model.joint(name).id, rigid.joint(name).id
        assert model.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE
        assert model.jnt_stiffness[j] == model.dof_damping[j] == 0
        assert model.dof_armature[model.jnt_dofadr[j]] == rigid.dof_armature[rigid.jnt_dofadr[i]] == 1e-4
        np.testing.assert_array_equal(model.jnt_axis[j], rigid.jnt_axis[i])
        assert model.jnt_limited[j] == (stops == "limits")
        for field in ("jnt_range", "jnt_solref", "jnt_solimp", "jnt_margin"):
            same = np.array_equal(getattr(model, field)[j], getattr(rigid, field)[i])
            assert same or (stops == "element" and field == "jnt_range"), field
    for j in c.joints:  # the added joints have MuJoCo's built-in settings
        assert model.dof_armature[model.jnt_dofadr[model.joint(j).id]] == 0
    # saved and read back, the joints keep what they have, whatever the class says
    again = mujoco.MjModel.from_xml_string(spec.to_xml())
    for name in ("jnt_limited", "jnt_range", "jnt_stiffness", "dof_damping", "dof_armature", "dof_frictionloss"):
        # rtol: MuJoCo writes the other levels' ranges (degrees made radians) with 6 digits
        np.testing.assert_allclose(getattr(again, name), getattr(model, name), rtol=1e-5, err_msg=name)
    # the element frame is the hinges': their anchor (L3's origin, 35 mm above L4's), L3's axes (the hinges')
    np.testing.assert_allclose(c.frame[0], [0, 0, 0.035], atol=1e-15)
    assert c.frame[1] == (1.0, 0.0, 0.0, 0.0)
    # the three equalities that drove L3 are gone; the six others keep their joints and coefficients
    removed = {e.name for e in r.edits if e.kind == "equality" and e.action == "removed"}
    assert removed == {f"L3_{h}_follows" for h, _, _ in HINGES}
    assert model.neq == rigid.neq - 3
    for k in range(model.neq):
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_EQUALITY, k)
        old = mujoco.mj_name2id(rigid, mujoco.mjtObj.mjOBJ_EQUALITY, name)
        np.testing.assert_array_equal(model.eq_data[k], rigid.eq_data[old])
        for field in ("eq_obj1id", "eq_obj2id"):
            joint = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, getattr(model, field)[k])
            assert joint == mujoco.mj_id2name(rigid, mujoco.mjtObj.mjOBJ_JOINT, getattr(rigid, field)[old])
    # ranges in element coordinates: bend (x) on rx, flex (y) on ry, rot (z) on rz, in radians; no translation
    ranges = {h: radians(lohi) for h, _, lohi in HINGES}
    np.testing.assert_allclose(r.lower[:3], [ranges["bend"][0], ranges["flex"][0], ranges["rot"][0]], rtol=1e-15)
    np.testing.assert_allclose(r.upper[:3], [ranges["bend"][1], ranges["flex"][1], ranges["rot"][1]], rtol=1e-15)
    assert np.all(np.isinf(r.lower[3:])) and np.all(np.isinf(r.upper[3:]))
    element_stops = mjflex.Flexures(model).records[0].stops
    if stops == "limits":
        assert element_stops is None  # MuJoCo's limits stop the motion, not the element
    else:
        np.testing.assert_array_equal(element_stops.lower, r.lower)  # the element has them
        np.testing.assert_array_equal(element_stops.upper, r.upper)
    # what the element does not carry is said: the joints' springs and dampers (the armature stays)
    assert len(r.notes) == 3 and all("stiffness 20 (give it in K)" in n and "damping 0.2" in n for n in r.notes)
    assert not any("armature" in n for n in r.notes)


@pytest.mark.parametrize("stops", ["limits", "element"])
def test_what_named_the_joints_reads_and_acts_as_before(stops):
    """Actuators, sensors and the tendon at the bent, moving keyframe, with the motor and servo driven: the same
    values in both models. With the limits kept the limit sensor reads the same value and the servo still inherits
    its control range; with element stops the limit sensor, which has no limit left to read, is removed, and the
    inherited control range becomes explicit."""
    spec = spine_spec()
    rigid = spec.compile()
    c = _replace(spec, stops=stops)
    model = spec.compile()
    edits = {(e.kind, e.name): e.action for e in c.replaced.edits}
    np.testing.assert_allclose(model.actuator_ctrlrange[model.actuator("L3_bender").id], radians((-6, 6)),
                               rtol=1e-15)  # fmt: skip
    readings = ["L3_flex_angle", "L5_orientation", "L3_rot_rate", "L4_flex_angle", "flex45_length"]
    if stops == "limits":
        assert ("sensor", "L3_flex_limit") not in edits and ("actuator", "L3_bender") not in edits
        assert spec.actuator("L3_bender").inheritrange == 1
        readings.insert(4, "L3_flex_limit")
    else:
        assert edits[("sensor", "L3_flex_limit")] == "removed" and edits[("actuator", "L3_bender")] == "changed"
    old, new = _state(rigid), _state(model)
    np.testing.assert_array_equal(new.ctrl, old.ctrl)
    for name in ("L3_flexor", "L3_bender", "L4_flexor"):
        i, j = rigid.actuator(name).id, model.actuator(name).id
        assert model.actuator_trntype[j] == rigid.actuator_trntype[i] == mujoco.mjtTrn.mjTRN_JOINT
        assert math.isclose(new.actuator_length[j], old.actuator_length[i], rel_tol=1e-14)
        assert math.isclose(new.actuator_force[j], old.actuator_force[i], rel_tol=1e-14, abs_tol=1e-15)
    for name in readings:
        np.testing.assert_allclose(_sensor(model, new, name), _sensor(rigid, old, name), rtol=1e-14, atol=1e-15)
    names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_SENSOR, i) for i in range(model.nsensor)]
    assert names == readings


def test_keyframes_put_every_body_where_it_was_with_its_velocity():
    spec = spine_spec()
    rigid = spec.compile()
    c = _replace(spec)
    model = spec.compile()
    assert [e.key for e in c.keyframes] == ["bent"]
    before, after = _poses(rigid, 0), _poses(model, 0)
    np.testing.assert_allclose(after[0], before[0], atol=1e-15)
    np.testing.assert_allclose(after[1], before[1], atol=1e-15)
    np.testing.assert_allclose(after[2], before[2], atol=1e-15)  # the same angular and linear velocities
    qpos, qvel = key_values()  # every hinge keeps its value (by name); the slides rest
    for k, level in enumerate(LEVELS):
        for i, (h, _, _) in enumerate(HINGES):
            jid = model.joint(f"{level}_{h}").id
            assert model.key_qpos[0][model.jnt_qposadr[jid]] == qpos[3 * k + i]
            assert model.key_qvel[0][model.jnt_dofadr[jid]] == qvel[3 * k + i]
    for j in c.joints:
        assert model.key_qpos[0][model.jnt_qposadr[model.joint(j).id]] == 0.0
    np.testing.assert_array_equal(model.key_ctrl[0], rigid.key_ctrl[0])


def test_the_driver_level_replaced_keeps_driving_its_followers():
    """L5 drives L4, L3 and L2: replaced, its hinges are the disc's coordinates and the nine equalities still tie the
    other levels to them, unchanged; they hold at the keyframe."""
    spec = spine_spec()
    rigid = spec.compile()
    c = _replace(spec, "L5")
    model = spec.compile()
    assert {e.action for e in c.replaced.edits if e.kind == "equality"} == {"kept"}
    assert model.neq == rigid.neq == 9
    np.testing.assert_array_equal(model.eq_data, rigid.eq_data)
    data = _state(model)
    rows = data.efc_type == mujoco.mjtConstraint.mjCNSTR_EQUALITY
    assert rows.sum() == 9 and np.abs(data.efc_pos[rows]).max() < 1e-15


def test_equalities_remove_and_refuse_are_the_users_choices():
    spec = spine_spec(quadratic=True)
    before = spec.to_xml()
    with pytest.raises(ValueError, match=r"L2_rot_follows \(L2_rot = f\(L5_rot\)\).*equalities='remove' removes"):
        _replace(spec, "L5", equalities="refuse")
    assert spec.to_xml() == before  # refused before anything changed
    c = _replace(spec, "L5", equalities="remove")
    assert sum(e.action == "removed" for e in c.replaced.edits if e.kind == "equality") == 9
    assert spec.compile().neq == 0
    with pytest.raises(ValueError, match=r"equalities='sometimes'"):
        _replace(spine_spec(), equalities="sometimes")


@pytest.mark.parametrize("body", ["L3", "L5"])
def test_make_rigid_restores_the_original_model_exactly(body):
    spec = spine_spec()
    original, xml = spec.compile(), spec.to_xml()
    c = _replace(spec, body, damping_ratio=0.05)
    assert spec.compile().nq == original.nq + 3
    _undone(spec, c)
    assert_same_model(spec.compile(), original)
    assert mjflex.spec_xml(spec) == xml
    with pytest.raises(ValueError, match="make_rigid called already"):
        mjflex.make_rigid(spec, c)


#: Loads each model file given on the command line in a process that imports mujoco alone; prints its sizes or
#: MuJoCo's error, one line each.
PLAIN_MUJOCO = """import sys, warnings
warnings.simplefilter("ignore")  # mjflex's entry point cannot register the plugin here, and says so
import mujoco
for path in sys.argv[1:]:
    try:
        m = mujoco.MjModel.from_xml_path(path)
        print("loaded", m.nq, m.nv, m.nbody, m.njnt, m.nplugin)
    except ValueError as exc:
        print("refused", str(exc).splitlines()[0])
"""


def test_the_rigid_file_loads_in_a_mujoco_without_mjflex(tmp_path):
    """Issue 33 item 3: after make_rigid, spec.to_xml() still declares mjflex.flexure (MjSpec cannot take a plugin
    declaration back), and a MuJoCo without mjflex refuses that file; mjflex.spec_xml writes
    the rigid model without it, which loads there with the original sizes. The subprocess imports mujoco with
    MJFLEX_NATIVE_DIR at an empty folder, so mjflex's entry point registers no plugin."""
    spec = _pusher()
    original = spec.compile()
    c = mjflex.make_compliant(spec, "r_elbow_flex_link", K_ELBOW, replace_joints=True)
    _undone(spec, c)
    (tmp_path / "rigid.xml").write_text(mjflex.spec_xml(spec))
    (tmp_path / "declared.xml").write_text(spec.to_xml())
    (tmp_path / "empty").mkdir()
    env = {**os.environ, "MJFLEX_NATIVE_DIR": str(tmp_path / "empty")}
    files = [str(tmp_path / "rigid.xml"), str(tmp_path / "declared.xml")]
    out = subprocess.run([sys.executable, "-c", PLAIN_MUJOCO, *files], env=env, capture_output=True, text=True,
                         check=True, cwd=tmp_path).stdout.splitlines()  # fmt: skip
    assert out[0] == f"loaded {original.nq} {original.nv} {original.nbody} {original.njnt} 0", out
    assert out[1] == "refused XML Error: plugin mjflex.flexure not found", out  # the plugin is truly absent there
    assert mjflex.spec_xml(spec) == spec.to_xml().replace(
        '  <extension>\n    <plugin plugin="mjflex.flexure"/>\n  </extension>\n\n', ""
    )


def test_make_rigid_keeps_later_edits_of_other_elements():
    """An equality edited and a sensor added after the replacement survive the undo, in their places."""
    spec = spine_spec()
    original = spec.compile()
    c = _replace(spec)
    spec.equality("L4_flex_follows").data = [0, 0.5, 0, 0, 0, *spec.equality("L4_flex_follows").data[5:]]
    spec.add_sensor(name="late", type=mujoco.mjtSensor.mjSENS_JOINTPOS, objtype=mujoco.mjtObj.mjOBJ_JOINT,
                    objname="L4_rot")  # fmt: skip
    mjflex.make_rigid(spec, c)
    model = spec.compile()
    assert model.eq_data[model.equality("L4_flex_follows").id][1] == 0.5
    assert model.equality("L3_flex_follows").id == original.equality("L3_flex_follows").id
    names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_SENSOR, i) for i in range(model.nsensor)]
    assert names == [*(mujoco.mj_id2name(original, mujoco.mjtObj.mjOBJ_SENSOR, i) for i in range(original.nsensor)),
                     "late"]  # fmt: skip


def test_replace_joints_is_needed_for_a_body_with_joints_and_unknown_names_get_suggestions():
    spec = spine_spec()
    with pytest.raises(ValueError, match="Pass replace_joints=True"):
        mjflex.make_compliant(spec, "L3", K_DISC)
    with pytest.raises(ValueError, match=r"body 'L33' is not in the spec; did you mean \['L3'"):
        mjflex.make_compliant(spec, "L33", K_DISC, replace_joints=True)


# ----------------------------------------------------------------------------- robot arms with an elastic joint

K_ELBOW = np.array([2e3, 2e3, 80.0, 1e6, 1e6, 1e6])  # stiff bearings; 80 N m/rad about the elbow axis (element z)


def _pusher():
    spec = mujoco.MjSpec.from_file(pusher_path())
    spec.add_key(name="reach", qpos=[0.3, 0.4, -0.2, -1.2, 0.5, -0.4, 0.3, 0.1, 0.0, 0.0, 0.0],
                 qvel=[0.1, -0.2, 0.3, 0.5, -0.1, 0.2, 0.0, 0.0, 0.0, 0.0, 0.0])  # fmt: skip
    return spec


def test_the_pusher_elbow_becomes_an_elastic_joint_and_comes_back():
    spec = _pusher()
    original, xml = spec.compile(), spec.to_xml()
    c = mjflex.make_compliant(spec, "r_elbow_flex_link", K_ELBOW, replace_joints=True, damping_ratio=0.05)
    model = spec.compile()
    r = c.replaced
    assert r.joints == ("r_elbow_flex_joint",)
    # the element frame is the joint's: origin at its anchor, z along the hinge (the link's y), x the link's x; the
    # link gets the other two rotations and the three translations
    assert c.frame[0] == (0.4, 0.0, 0.0)  # in the parent's frame
    np.testing.assert_allclose(c.frame[1], [math.sqrt(0.5), -math.sqrt(0.5), 0, 0], rtol=1e-15)  # -90 deg about x
    assert c.joints == tuple(f"r_elbow_flex_link_compliance/{d}" for d in ("x", "y", "z", "rx", "ry"))
    np.testing.assert_allclose(r.lower, [-np.inf, -np.inf, -2.3213, -np.inf, -np.inf, -np.inf], rtol=1e-15)
    np.testing.assert_allclose(r.upper, [np.inf, np.inf, 0.0, np.inf, np.inf, np.inf])
    assert r.stops == "limits" and model.jnt_limited[model.joint("r_elbow_flex_joint").id]
    assert [n.split(":")[0] for n in r.notes] == ["hinge r_elbow_flex_joint"]  # damping 0.1 (the armature stays)
    old, new = _state(original), _state(model)
    new.ctrl[:] = old.ctrl[:] = [0.5, -0.3, 0.2, 1.5, 0.1, -0.2, 0.3]
    for m, d in ((original, old), (model, new)):
        mujoco.mj_forward(m, d)
    np.testing.assert_allclose(new.actuator_force, old.actuator_force, rtol=1e-14)  # the elbow's motor: 1.5 N m
    before, after = _poses(original, 0), _poses(model, 0)
    np.testing.assert_allclose(after[0], before[0], atol=1e-15)
    np.testing.assert_allclose(after[2], before[2], atol=1e-15)
    _undone(spec, c)
    assert_same_model(spec.compile(), original)
    assert mjflex.spec_xml(spec) == xml


def test_a_loaded_elastic_joint_under_its_servo_is_conservative_and_runs():
    """The small arm's j3 (position servo a3, kp 5000, at keyframe "home": 0.8 rad) replaced by an element soft about
    the hinge: the servo bends the element 0.75 rad against 226 N m. Its transmission is still the joint's, so the
    model is conservative: the tangent stiffness at the loaded equilibrium is symmetric (a site transmission with
    refsite measured 226 N m/rad of asymmetry here, a flutter that diverged at every step), and a run from there,
    knocked on every dof, at the advised step stays bounded. (Softer in bending, 100 N m/rad, the element buckles
    under this load: test_operating_pose.)"""
    spec = arm_spec()
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_EULER
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # nothing but what the Compliance reports
        c = mjflex.make_compliant(spec, "link3", [2e3, 2e3, 300.0, 2e4, 2e4, 2e4], replace_joints=True)
    model = spec.compile()
    assert "stiffness 2" in c.replaced.notes[0] and "friction loss 0.1" in c.replaced.notes[0]
    np.testing.assert_allclose([c.replaced.lower[2], c.replaced.upper[2]], [-3, 3], rtol=1e-15)
    flex = mjflex.Flexures(model)
    q = mjflex.static_equilibrium(model, flex, keyframe="home")
    K = mjflex.analysis.linearize.stiffness_matrix(model, flex, q, keyframe="home", joint_springs=True,
                                             actuator_stiffness=True, gravity=True)  # fmt: skip
    assert np.abs(K - K.T).max() < 1e-6 * np.abs(K).max()  # 1e-6: central differences of forces of 1e4 N m/rad
    data = _state(model)
    data.qpos[:] = q
    mujoco.mj_forward(model, data)
    bent = q[model.jnt_qposadr[model.joint("j3").id]]
    assert math.isclose(data.actuator_force[2], 5000 * (0.8 - bent), rel_tol=1e-12) and data.actuator_force[2] > 200
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a DivergenceWarning, or a state said unstable, fails the test
        advice = mjflex.step_advice(model, flex, keyframe="home", qpos=q)
        model.opt.timestep = advice.recommended
        data.qpos[:], data.qvel[:] = q, 0.1 * np.random.default_rng(1).normal(size=model.nv)  # knocked
        mujoco.mj_step(model, data, nstep=int(0.3 / advice.recommended))
    assert np.isfinite(data.qpos).all() and np.abs(data.qvel).max() < 10


REF = """<mujoco><compiler angle="radian"/><worldbody><body name="base" pos="0 0 0.3"><geom size="0.05"/>
  <body name="arm" pos="0 0 0.1"><joint name="j" axis="0 0 1" ref="0.2" range="-0.5 1.0"/>
    <geom type="capsule" fromto="0 0 0 0.2 0 0" size="0.02"/></body></body></worldbody>
  <actuator><position name="servo" joint="j" kp="30"/></actuator>
  <keyframe><key name="turned" qpos="0.5" qvel="0.3" ctrl="0.4"/></keyframe></mujoco>"""


def test_a_joint_reference_shifts_the_stops_as_the_element_rests_there():
    """MuJoCo's ``ref`` is the joint's value at qpos0, where the element is unstressed: the range [-0.5, 1] becomes
    stops [-0.7, 0.8], and the joint keeps its ref (the body keeps its pose at every value)."""
    spec = mujoco.MjSpec.from_string(REF)
    rigid = spec.compile()
    c = mjflex.make_compliant(spec, "arm", [5, 5, 2, 1e5, 1e5, 1e5], replace_joints=True)
    model = spec.compile()
    np.testing.assert_allclose([c.replaced.lower[2], c.replaced.upper[2]], [-0.7, 0.8], rtol=1e-15)
    assert model.qpos0[model.jnt_qposadr[model.joint("j").id]] == 0.2
    old, new = _state(rigid), _state(model)
    assert math.isclose(new.actuator_force[0], old.actuator_force[0], rel_tol=1e-14)  # 30 (0.4 - 0.5) = -3 N m
    flex = mjflex.Flexures(model)
    np.testing.assert_allclose(flex.displacements(new)[0][:3], [0, 0, 0.3], atol=1e-15)  # 0.5 - ref about z
    np.testing.assert_allclose(_poses(model, 0)[2], _poses(rigid, 0)[2], atol=1e-15)  # turning at 0.3 rad/s
    mjflex.make_rigid(spec, c)
    assert_same_model(spec.compile(), rigid)


BALL = """<mujoco><worldbody><body name="base" pos="0 0 0.3"><geom size="0.05"/>
  <body name="head" pos="0 0 0.1"><joint name="neck" type="ball" range="0 40"/>
    <joint name="shift" type="slide" axis="1 1 0" range="-0.01 0.01"/><geom type="box" size="0.03 0.02 0.05"/>
  </body></body></worldbody></mujoco>"""


def test_a_ball_joint_keeps_its_ball_and_its_cone_becomes_the_circumscribed_box():
    """A ball (cone of 40 deg) and a slide off the element axes (the element frame given: the body's): the body
    gets the two slides that complete the translations (never more than six dofs); as element stops
    (``stops="element"``) the cone gives +-40 deg on each rotation, and the slide's range is said not to be
    carried."""
    spec = mujoco.MjSpec.from_string(BALL)
    K = [5, 5, 5, 1e5, 1e5, 1e5]  # the element frame given: the body's axes, not the joints'
    c = mjflex.make_compliant(spec, "head", K, replace_joints=True, stops="element", pos=[0, 0, 0], frame="body")
    model = spec.compile()
    assert c.joints == ("head_compliance/x", "head_compliance/z")
    assert model.nv == 3 + 1 + 2
    np.testing.assert_allclose(c.replaced.upper[:3], [math.radians(40)] * 3, rtol=1e-15)
    assert any("circumscribed box" in n for n in c.replaced.notes)
    assert any(n.startswith("the range of slide shift was not carried") for n in c.replaced.notes)
    stops = mjflex.Flexures(model).records[0].stops
    np.testing.assert_array_equal(stops.upper, c.replaced.upper)
    assert not model.jnt_limited.any()  # the ranges went to the element


def test_a_loaded_disc_stays_within_the_range_of_the_hinges_it_replaced():
    """40 N forward on the torso extends L3's disc past the hinges' 4.8 deg: without stops it rests at 12.6 deg; with
    the ranges carried as element stops (``stops="element"``) it rests 0.09 deg past the limit (the stop's own
    compliance, 100 times the disc's stiffness), and a run from rest at the step advised for that loaded, engaged
    state peaks 0.2 deg past it, without diverging (the advice against measured stable steps at such states:
    tests/test_operating_pose.py)."""
    static, runs = {}, {}
    for stops in ("element", False):
        spec = spine_spec()
        c = _replace(spec, K=[30, 30, 20, 2e5, 2e5, 5e5], damping_ratio=0.05, stops=stops)
        model = spec.compile()
        flex = mjflex.Flexures(model)
        xfrc = np.zeros((model.nbody, 6))
        xfrc[model.body("torso").id, 0] = 40.0
        qpos = mjflex.static_equilibrium(model, flex, xfrc_applied=xfrc)
        data = mujoco.MjData(model)
        data.qpos[:] = qpos
        mujoco.mj_kinematics(model, data)
        static[stops] = flex.displacements(data)[0][1]
        if stops is False:
            continue
        advice = mjflex.step_advice(model, flex, qpos=qpos, xfrc_applied=xfrc)
        model.opt.timestep = advice.recommended
        data = mujoco.MjData(model)
        data.xfrc_applied[:] = xfrc
        peak = -np.inf
        with warnings.catch_warnings():
            warnings.simplefilter("error", mjflex.DivergenceWarning)
            for _ in range(int(1.0 / advice.recommended)):
                mujoco.mj_step(model, data)
                peak = max(peak, flex.displacements(data)[0][1])
        runs[stops] = peak, flex.displacements(data)[0][1]
    upper = c.replaced.upper[1]
    assert math.isclose(upper, math.radians(4.8), rel_tol=1e-15)
    assert static[False] > upper + 0.1  # the load the range held
    overshoot = static["element"] - upper
    assert 0 < overshoot < 0.003
    peak, final = runs["element"]
    # the impact on the stop adds to the static overshoot (2.3x measured): 0.2 deg past the limit, against 12.6 deg
    assert peak < upper + 3 * overshoot and abs(final - static["element"]) < 0.25 * overshoot  # settling after 1 s

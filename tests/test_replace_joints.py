"""Joints replaced by an element in one call (mjflex.make_compliant(..., replace_joints=True)), and put back.

Two models go through it: a hand-built lumbar spine (tests/spine.py: hinge triplets tied level to level by joint
equalities, actuators and sensors on a level, a fixed tendon, a moving keyframe) and robot arms with an elastic
joint (gymnasium's pusher, unmodified, and tests/robots.py's servo-held arm). Every check is against a value
computed here from the model: the equalities' coefficients from the spine's couplings, the stops from the ranges
in radians, the keyframe poses and velocities from the original model's kinematics, the actuators' wrench and
length from the joint's, and the undo against the original compiled model, array by array, and its XML.
"""

import math
import warnings

import mujoco
import numpy as np
import pytest

import mjflex
from tests.robots import arm_spec, pusher_path
from tests.spine import FOLLOW, HINGES, LEVELS, key_values, radians, spine_spec

K_DISC = np.array([50.0, 50.0, 30.0, 2e5, 2e5, 5e5])  # N m/rad x 3 (bend x, flex y, rot z), N/m x 3


def _xml_without_extension(spec):
    """The spec's XML without the <extension> block: MjSpec cannot take back a plugin activation (no instance
    is left, and the compiled model has no plugin)."""
    text = spec.to_xml()
    start = text.find("  <extension>")
    return text if start < 0 else text[:start] + text[text.index("</extension>", start) + len("</extension>\n\n") :]


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


def _replace(spec, body="L3", **kwargs):
    kwargs.setdefault("K", K_DISC)
    return mjflex.make_compliant(spec, body, replace_joints=True, **kwargs)


# ----------------------------------------------------------------------------- the spine


def test_a_driven_level_is_replaced_and_its_couplings_removed():
    spec = spine_spec()
    rigid = spec.compile()
    c = _replace(spec)
    model = spec.compile()
    r = c.replaced
    assert r.joints == ("L3_flex", "L3_bend", "L3_rot")
    # the element frame is the hinges': their anchor (L3's origin, 35 mm above L4's), L3's axes (the hinges')
    np.testing.assert_allclose(c.frame[0], [0, 0, 0.035], atol=1e-15)
    assert c.frame[1] == (1.0, 0.0, 0.0, 0.0)
    assert c.joints == tuple(f"L3_compliance/{j}" for j in ("x", "y", "z", "ball"))
    assert (model.nq, model.nv) == (rigid.nq - 3 + 7, rigid.nv - 3 + 6)
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
    # ranges -> stops: bend (x) on rx, flex (y) on ry, rot (z) on rz, in radians; no translation stop
    ranges = {h: radians(lohi) for h, _, lohi in HINGES}
    np.testing.assert_allclose(r.lower[:3], [ranges["bend"][0], ranges["flex"][0], ranges["rot"][0]], rtol=1e-15)
    np.testing.assert_allclose(r.upper[:3], [ranges["bend"][1], ranges["flex"][1], ranges["rot"][1]], rtol=1e-15)
    assert np.all(np.isinf(r.lower[3:])) and np.all(np.isinf(r.upper[3:]))
    # what the element does not carry is said: the joints' springs, dampers and armature
    assert len(r.notes) == 3 and all("stiffness 20 (give it in K)" in n and "damping 0.2" in n for n in r.notes)


def test_actuators_become_site_transmissions_with_the_joints_wrench_and_length():
    spec = spine_spec()
    rigid = spec.compile()
    c = _replace(spec)
    model = spec.compile()
    a, b = (model.site(f"L3_compliance/{s}").id for s in "ab")
    for name, gear in (("L3_flexor", [0, 0, 0, 0, 2, 0]), ("L3_bender", [0, 0, 0, 1, 0, 0])):
        i = model.actuator(name).id
        assert model.actuator_trntype[i] == mujoco.mjtTrn.mjTRN_SITE
        assert (model.actuator_trnid[i].tolist(), model.actuator_gear[i].tolist()) == ([b, a], gear)
    assert model.actuator_trntype[model.actuator("L4_flexor").id] == mujoco.mjtTrn.mjTRN_JOINT
    assert [e.name for e in c.replaced.edits if e.kind == "actuator"] == ["L3_flexor", "L3_bender"]
    # the same torque on L3: u = 0.7 on the motor (gear 2) is 1.4 N m about L3's y axis (the ball's dofs are in
    # the body frame); nothing on the slides
    data = mujoco.MjData(model)
    data.ctrl[model.actuator("L3_flexor").id] = 0.7
    mujoco.mj_forward(model, data)
    j = model.joint("L3_compliance/ball").id
    np.testing.assert_allclose(data.qfrc_actuator[model.jnt_dofadr[j] : model.jnt_dofadr[j] + 3], [0, 1.4, 0],
                               atol=1e-12)  # fmt: skip
    for slide in "xyz":
        assert abs(data.qfrc_actuator[model.jnt_dofadr[model.joint(f"L3_compliance/{slide}").id]]) < 1e-12
    # the servo's length is the element's rotation about x: the hinge angle, exactly for a rotation about x alone
    for angle in (0.05, -0.1):
        old, new = mujoco.MjData(rigid), mujoco.MjData(model)
        old.qpos[rigid.jnt_qposadr[rigid.joint("L3_bend").id]] = angle
        q, _, _ = mjflex.mj.keyframes.map_state(rigid, model, model.body("L3").id, old.qpos, old.qvel)
        new.qpos[:] = q
        for m, d in ((rigid, old), (model, new)):
            mujoco.mj_forward(m, d)
        i_old, i_new = rigid.actuator("L3_bender").id, model.actuator("L3_bender").id
        assert math.isclose(new.actuator_length[i_new], old.actuator_length[i_old], rel_tol=1e-12)
        assert math.isclose(new.actuator_force[i_new], old.actuator_force[i_old], rel_tol=1e-10)


def test_joint_sensors_are_removed_and_the_others_keep_their_order():
    spec = spine_spec()
    rigid = spec.compile()
    c = _replace(spec)
    model = spec.compile()
    removed = [e.name for e in c.replaced.edits if e.kind == "sensor"]
    assert removed == ["L3_flex_angle", "L3_rot_rate"]
    names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_SENSOR, i) for i in range(model.nsensor)]
    assert names == ["L5_orientation", "L4_flex_angle"]
    assert model.nsensordata == rigid.nsensordata - 2


def test_keyframes_put_every_body_where_it_was_with_its_velocity():
    spec = spine_spec()
    rigid = spec.compile()
    c = _replace(spec)
    model = spec.compile()
    assert [e.key for e in c.keyframes] == ["bent"]
    before, after = _poses(rigid, 0), _poses(model, 0)
    np.testing.assert_allclose(after[0], before[0], atol=1e-14)
    np.testing.assert_allclose(np.abs((after[1] * before[1]).sum(axis=1)), 1.0, atol=1e-14)  # same orientations
    np.testing.assert_allclose(after[2], before[2], atol=1e-13)  # same angular and linear velocities
    # the other levels keep their values (by joint name), the new joints hold the pose: slides ~0, the ball turned
    qpos, qvel = key_values()
    for k, level in enumerate(LEVELS):
        if level == "L3":
            continue
        for i, (h, _, _) in enumerate(HINGES):
            jid = model.joint(f"{level}_{h}").id
            assert model.key_qpos[0][model.jnt_qposadr[jid]] == qpos[3 * k + i]
            assert model.key_qvel[0][model.jnt_dofadr[jid]] == qvel[3 * k + i]
    ctrl = model.key_ctrl[0]
    np.testing.assert_array_equal(ctrl, rigid.key_ctrl[0])


def test_the_driver_level_replaced_re_roots_its_followers():
    """L5 drives L4, L3 and L2; replaced, L4 becomes the driver: q_k = (c_k / c_4) q_L4, the equalities hold."""
    spec = spine_spec(tendon=False)
    c = _replace(spec, "L5")
    model = spec.compile()
    edits = {e.name: e for e in c.replaced.edits if e.kind == "equality"}
    for i, (h, _, _) in enumerate(HINGES):
        assert edits[f"L4_{h}_follows"].action == "removed"
        for level in ("L3", "L2"):
            assert edits[f"{level}_{h}_follows"].action == "rewritten"
            k = model.equality(f"{level}_{h}_follows").id
            assert model.joint(model.eq_obj2id[k]).name == f"L4_{h}"
            np.testing.assert_allclose(model.eq_data[k][:5], [0, FOLLOW[level][i] / FOLLOW["L4"][i], 0, 0, 0],
                                       rtol=1e-15)  # fmt: skip
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, 0)  # consistent with the original couplings, so with the new ones
    mujoco.mj_forward(model, data)
    rows = data.efc_type == mujoco.mjtConstraint.mjCNSTR_EQUALITY
    assert rows.sum() == 6 and np.abs(data.efc_pos[rows]).max() < 1e-15


def test_a_coupling_that_cannot_be_rewritten_is_refused_by_name_and_the_choice_given():
    spec = spine_spec(tendon=False, quadratic=True)
    before = spec.to_xml()
    with pytest.raises(ValueError, match=r"L2_rot_follows \(L2_rot = poly\(L5_rot\).*equalities='remove'"):
        _replace(spec, "L5")
    assert spec.to_xml() == before  # refused before anything changed
    c = _replace(spec, "L5", equalities="remove")
    assert sum(e.action == "removed" for e in c.replaced.edits if e.kind == "equality") == 9
    assert spec.compile().neq == 0


def test_refuse_keeps_every_equality_for_the_user_to_edit():
    spec = spine_spec()
    with pytest.raises(ValueError, match=r"L3_flex_follows .*L3_bend_follows .*\(equalities='refuse'\)"):
        _replace(spec, equalities="refuse")


def test_a_fixed_tendon_over_a_replaced_joint_is_refused_by_name():
    spec = spine_spec()
    before = spec.to_xml()
    with pytest.raises(ValueError, match=r"fixed tendon\(s\) flex45 \(sums L5_flex\)"):
        _replace(spec, "L5")
    assert spec.to_xml() == before


@pytest.mark.parametrize("body", ["L3", "L5"])
def test_make_rigid_restores_the_original_model_exactly(body):
    spec = spine_spec(tendon=body != "L5")
    original, xml = spec.compile(), spec.to_xml()
    c = _replace(spec, body, damping_ratio=0.05)
    assert spec.compile().nq == original.nq + 4
    mjflex.make_rigid(spec, c)
    assert_same_model(spec.compile(), original)
    assert _xml_without_extension(spec) == xml
    with pytest.raises(ValueError, match="make_rigid called already"):
        mjflex.make_rigid(spec, c)


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
    assert names == ["L3_flex_angle", "L5_orientation", "L3_rot_rate", "L4_flex_angle", "late"]


def test_replace_joints_is_needed_for_a_body_with_joints_and_unknown_names_get_suggestions():
    spec = spine_spec()
    with pytest.raises(ValueError, match="Pass replace_joints=True"):
        mjflex.make_compliant(spec, "L3", K_DISC)
    with pytest.raises(ValueError, match=r"body 'L33' is not in the spec; did you mean \['L3'"):
        mjflex.make_compliant(spec, "L33", K_DISC, replace_joints=True)
    with pytest.raises(ValueError, match=r"equalities='sometimes'"):
        mjflex.make_compliant(spec, "L3", K_DISC, replace_joints=True, equalities="sometimes")


# ----------------------------------------------------------------------------- robot arms with an elastic joint

K_ELBOW = np.array([2e3, 80.0, 2e3, 1e6, 1e6, 1e6])  # stiff bearings; 80 N m/rad about the elbow axis (y)


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
    # the element frame is the joint's: origin at its anchor, axes the link's (the hinge is along y)
    assert c.frame == ((0.4, 0.0, 0.0), (1.0, 0.0, 0.0, 0.0))  # in the parent's frame
    np.testing.assert_allclose(r.lower, [-np.inf, -2.3213, -np.inf, -np.inf, -np.inf, -np.inf], rtol=1e-15)
    np.testing.assert_allclose(r.upper, [np.inf, 0.0, np.inf, np.inf, np.inf, np.inf])
    motor = model.actuator(3).id  # the elbow's motor: unnamed, by its place
    assert model.actuator_trntype[motor] == mujoco.mjtTrn.mjTRN_SITE
    assert model.actuator_gear[motor].tolist() == [0, 0, 0, 0, 1, 0]
    assert [n.split(":")[0] for n in r.notes] == ["hinge r_elbow_flex_joint"]  # damping 0.1, armature 0.04
    before, after = _poses(original, 0), _poses(model, 0)
    np.testing.assert_allclose(after[0], before[0], atol=1e-14)
    np.testing.assert_allclose(after[2], before[2], atol=1e-13)
    mjflex.make_rigid(spec, c)
    assert_same_model(spec.compile(), original)
    assert _xml_without_extension(spec) == xml


def test_the_servo_held_arm_keeps_its_servo_on_the_elastic_joint():
    """The small arm's j3 (position servo a3, kp 5000) replaced: at every pose the servo's length and force are
    the joint's, so the arm holds the same posture; the class's spring, damper, armature and friction are said."""
    spec = arm_spec()
    rigid = spec.compile()
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # nothing but what the Compliance reports
        c = mjflex.make_compliant(spec, "link3", [2e3, 300.0, 2e3, 1e6, 1e6, 1e6], replace_joints=True)
    model = spec.compile()
    assert "stiffness 2" in c.replaced.notes[0] and "friction loss 0.1" in c.replaced.notes[0]
    np.testing.assert_allclose([c.replaced.lower[1], c.replaced.upper[1]], [-3, 3], rtol=1e-15)
    body = model.body("link3").id
    for k in range(rigid.nkey):
        old = mujoco.MjData(rigid)
        mujoco.mj_resetDataKeyframe(rigid, old, k)
        new = mujoco.MjData(model)
        mujoco.mj_resetDataKeyframe(model, new, k)
        old.qpos[2] += 0.05  # the link turned 0.05 rad past the servo's target
        new.qpos[:], _, residual = mjflex.mj.keyframes.map_state(rigid, model, body, old.qpos, old.qvel)
        assert residual < 1e-14
        for m, d in ((rigid, old), (model, new)):
            mujoco.mj_forward(m, d)
        i = rigid.actuator("a3").id
        assert math.isclose(new.actuator_length[i], old.actuator_length[i], rel_tol=1e-12)
        assert math.isclose(new.actuator_force[i], old.actuator_force[i], rel_tol=1e-9)
        assert math.isclose(new.actuator_force[i], -5000 * 0.05, rel_tol=1e-9)


REF = """<mujoco><compiler angle="radian"/><worldbody><body name="base" pos="0 0 0.3"><geom size="0.05"/>
  <body name="arm" pos="0 0 0.1"><joint name="j" axis="0 0 1" ref="0.2" range="-0.5 1.0"/>
    <geom type="capsule" fromto="0 0 0 0.2 0 0" size="0.02"/></body></body></worldbody>
  <actuator><position name="servo" joint="j" kp="30"/></actuator>
  <keyframe><key name="turned" qpos="0.5" qvel="0.3" ctrl="0.4"/></keyframe></mujoco>"""


def test_a_joint_reference_shifts_the_stops_and_the_servo_as_the_element_rests_there():
    """MuJoCo's ``ref`` is the joint's value at qpos0, where the element is unstressed: the range [-0.5, 1] becomes
    stops [-0.7, 0.8], and the servo's affine bias takes the shift, so it pulls with the same force."""
    spec = mujoco.MjSpec.from_string(REF)
    rigid = spec.compile()
    c = mjflex.make_compliant(spec, "arm", [5, 5, 2, 1e5, 1e5, 1e5], replace_joints=True)
    model = spec.compile()
    np.testing.assert_allclose([c.replaced.lower[2], c.replaced.upper[2]], [-0.7, 0.8], rtol=1e-15)
    old, new = mujoco.MjData(rigid), mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(rigid, old, 0)
    mujoco.mj_resetDataKeyframe(model, new, 0)
    for m, d in ((rigid, old), (model, new)):
        mujoco.mj_forward(m, d)
    assert math.isclose(new.actuator_length[0], 0.5 - 0.2, rel_tol=1e-12)  # the element's rotation about z
    assert math.isclose(new.actuator_force[0], old.actuator_force[0], rel_tol=1e-12)  # 30 (0.4 - 0.5) = -3 N m
    np.testing.assert_allclose(_poses(model, 0)[2], _poses(rigid, 0)[2], atol=1e-14)  # turning at 0.3 rad/s
    mjflex.make_rigid(spec, c)
    assert_same_model(spec.compile(), rigid)

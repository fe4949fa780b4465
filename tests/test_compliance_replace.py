"""What ``make_compliant(..., replace_joints=...)`` does since issues 31, 32 and 33: the stops it keeps, the element
frame it chooses, the subsets, redundant joints and second calls it refuses, and the closures it reports.

Models: gymnasium's pusher (unmodified, tests/robots.py), the hand-built spine (tests/spine.py), and small models
built here where a property needs one (three hinges on springs, a lone slide, a four-bar closed by a connect).
Every figure is checked against something computed here: the rigid model run with MuJoCo's own joint limit and
spring, torques and deflections from K, the closure from the sites' distance at rest.
"""

import math
import warnings

import mujoco
import numpy as np
import pytest

import mjflex
from tests.robots import arm_spec, decay_ratio, pusher_path
from tests.spine import spine_spec

ELBOW, ELBOW_JOINT = "r_elbow_flex_link", "r_elbow_flex_joint"
#: Steel notch hinge (R 5 mm, t 1 mm, b 10 mm): compliant about its z, torsion 5.5 times, bending 44 times stiffer.
NOTCH = mjflex.geometry.notch_hinge_stiffness(5e-3, 1e-3, 10e-3, 200e9, 0.3)


def _pusher(timestep=None, elbow_spring=None):
    spec = mujoco.MjSpec.from_file(pusher_path())
    if timestep is not None:
        spec.option.timestep = timestep
    if elbow_spring is not None:
        spec.joint(ELBOW_JOINT).stiffness = [elbow_spring, 0.0, 0.0]
    return spec


def _rest_angle(model, joint, torque, moving):
    """The angle of ``joint`` at rest under ``torque`` on its dof, only the joints ``moving`` free."""
    qfrc = np.zeros(model.nv)
    qfrc[model.joint(joint).dofadr[0]] = torque
    ball = int(mujoco.mjtJoint.mjJNT_BALL)
    dofs = [model.joint(j).dofadr[0] + k for j in moving for k in range(3 if model.joint(j).type[0] == ball else 1)]
    q = mjflex.static_equilibrium(model, qfrc_applied=qfrc, dofs=dofs)
    return q[model.joint(joint).qposadr[0]] - model.qpos0[model.joint(joint).qposadr[0]]


# ----------------------------------------------------------------------------- the element frame (issue 32, item 3)


def test_a_notch_hinge_from_geometry_turns_the_replaced_hinge_about_its_compliant_axis():
    """One rule: a replaced hinge's axis is the element's z, the compliant axis of mjflex.geometry's hinges. The
    pusher's elbow with a steel notch hinge then turns by tau / K_zz under a torque tau about it (1.0.0 put the
    hinge on the element axis it lay along, y here, and gave it the bending stiffness, 44 times too stiff, without a
    word); a frame that puts the hinge elsewhere is warned about, naming the ratio."""
    tau = -1e-3  # N m about the elbow, away from its limit at 0: 16 urad, linear
    spec = _pusher()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        c = mjflex.make_compliant(spec, ELBOW, NOTCH, replace_joints=True)
    model = spec.compile()
    R = np.empty(9)
    mujoco.mju_quat2Mat(R, np.array(c.frame[1]))
    np.testing.assert_allclose(R.reshape(3, 3)[:, 2], model.jnt_axis[model.joint(ELBOW_JOINT).id], atol=1e-15)
    moving = [ELBOW_JOINT, *c.joints]
    assert math.isclose(_rest_angle(model, ELBOW_JOINT, tau, moving), tau / NOTCH[2, 2], rel_tol=1e-6)

    spec = _pusher()
    with pytest.warns(mjflex.LikelyMistakeWarning, match=r"r_elbow_flex_joint.*element's ry.*43.7 times K's softest"):
        c = mjflex.make_compliant(spec, ELBOW, NOTCH, replace_joints=True, pos=[0, 0, 0], frame="body")
    model = spec.compile()
    assert math.isclose(_rest_angle(model, ELBOW_JOINT, tau, [ELBOW_JOINT, *c.joints]), tau / NOTCH[1, 1],
                        rel_tol=1e-6)  # fmt: skip


SLIDE = """<mujoco><worldbody><body name="base"><geom size="0.05"/>
  <body name="carriage" pos="0 0 0.1"><joint name="guide" type="slide" axis="1 0 0" range="-0.01 0.02"/>
    <geom type="box" size="0.03 0.02 0.01"/></body></body></worldbody></mujoco>"""


def test_a_lone_slide_is_the_element_z_and_its_range_maps_onto_it():
    """A lone replaced slide is along the element's z too (x the body axis most nearly perpendicular to it); its
    range is the element's z coordinate's (informative with the limits kept); K soft along another axis is warned
    about."""
    spec = mujoco.MjSpec.from_string(SLIDE)
    K = [1e3, 1e3, 1e3, 1e5, 1e5, 50.0]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        c = mjflex.make_compliant(spec, "carriage", K, replace_joints=True)
    R = np.empty(9)
    mujoco.mju_quat2Mat(R, np.array(c.frame[1]))
    np.testing.assert_allclose(R.reshape(3, 3), [[0, 0, 1], [1, 0, 0], [0, 1, 0]], atol=1e-15)  # x_E = y, z_E = x
    np.testing.assert_allclose([c.replaced.lower[5], c.replaced.upper[5]], [-0.01, 0.02], rtol=1e-15)
    assert c.joints == ("carriage_compliance/x", "carriage_compliance/y", "carriage_compliance/ball")
    with pytest.warns(mjflex.LikelyMistakeWarning, match=r"slide 'guide'.*element's z.*2e\+03 times"):
        mjflex.make_compliant(mujoco.MjSpec.from_string(SLIDE), "carriage", [1e3, 1e3, 1e3, 50, 1e5, 1e5],
                              replace_joints=True)  # fmt: skip


# ----------------------------------------------------------------------------- stops (issue 31)


def _pressed(model, nudge=0.0, seconds=1.0, push=30.0):
    """The elbow's angle over a run that presses it into its upper stop (0 rad) with ``push`` N m from -0.5 rad at
    3 rad/s, its start nudged by ``nudge`` rad."""
    data = mujoco.MjData(model)
    j = model.joint(ELBOW_JOINT)
    data.qpos[j.qposadr[0]], data.qvel[j.dofadr[0]] = -0.5 + nudge, 3.0
    data.qfrc_applied[j.dofadr[0]] = push
    out = np.empty(round(seconds / model.opt.timestep))
    for i in range(len(out)):
        mujoco.mj_step(model, data)
        out[i] = data.qpos[j.qposadr[0]]
    return out


K_BEARINGS = [2e3, 2e3, 80.0, 1e5, 1e5, 1e5]  # 80 N m/rad about the elbow; bearings that run at the file's step
B_ELBOW = [0, 0, 0.1, 0, 0, 0]  # the elbow's own damper, 0.1 N m s/rad


def _elastic_elbow(stops=None):
    spec = _pusher(timestep=2e-3)
    mjflex.make_compliant(spec, ELBOW, K_BEARINGS, B=B_ELBOW, replace_joints=True, stops=stops)
    return spec.compile()


@pytest.mark.parametrize("stops", [None, "element"])
def test_the_joint_limits_kept_do_not_chatter_at_the_files_step(stops):
    """Issue 31, "No chatter": pressed into its stop by 30 N m at a 2 ms step (Euler, the pusher's integrator), the
    elbow with MuJoCo's limit kept (the default) carries a 1e-9 rad nudge for 1 s without growth, like the rigid
    arm; the same range as undamped element stops (a spring 100 times the elbow's stiffness) amplifies it past
    1e-6 rad: why the limits are the default."""
    model = _elastic_elbow(stops)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", mjflex.DivergenceWarning)
        drift = np.abs(_pressed(model) - _pressed(model, nudge=1e-9)).max()
    if stops is None:
        assert drift < 1e-6
        rigid = _pusher(timestep=2e-3, elbow_spring=K_BEARINGS[2]).compile()
        assert np.abs(_pressed(rigid) - _pressed(rigid, nudge=1e-9)).max() < 1e-6
    else:
        assert drift > 1e-6


def _bounces(model, seconds=1.5):
    """``(rebounds, losses)`` of the elbow thrown at its upper stop (0 rad) from -0.5 rad at 3 rad/s: how far it swings
    back after each impact [rad], and the share of the mechanical energy (the elements' included) each impact
    takes."""
    model.opt.enableflags |= mujoco.mjtEnableBit.mjENBL_ENERGY
    flex = mjflex.Flexures(model)
    data = mujoco.MjData(model)
    j = model.joint(ELBOW_JOINT)
    data.qpos[j.qposadr[0]], data.qvel[j.dofadr[0]] = -0.5, 3.0
    q, E = [], []
    while data.time < seconds:
        mujoco.mj_step(model, data)
        mujoco.mj_energyPos(model, data)
        mujoco.mj_energyVel(model, data)
        q.append(data.qpos[j.qposadr[0]])
        E.append(data.energy.sum() + flex.potential_energy(data))
    q, E = np.array(q), np.array(E)
    inside = q > 0
    enter = np.flatnonzero(inside[1:] & ~inside[:-1]) + 1
    leave = np.flatnonzero(~inside[1:] & inside[:-1]) + 1
    rebounds = np.array([-q[b:a].min() for b, a in zip(leave, enter[1:], strict=False)])
    losses = np.array([(E[a - 1] - E[b]) / E[a - 1] for a, b in zip(enter, leave, strict=False)])
    return rebounds[rebounds > 1e-3], losses


def test_the_joint_limits_kept_bounce_and_lose_energy_as_the_rigid_arm():
    """Issue 31: thrown at its stop, the elastic elbow with the limit kept (the file's solref and solimp) bounces
    as often as the rigid arm whose elbow has the same spring (joint stiffness 80 N m/rad, the same limit), its
    rebounds within 20 % of the rigid arm's, and each of the first two impacts takes the same share of the energy
    within 20 %. (The elements' bearings, which the rigid arm lacks, store some of it.)"""
    rigid_rebounds, rigid_losses = _bounces(_pusher(timestep=2e-3, elbow_spring=K_BEARINGS[2]).compile())
    rebounds, losses = _bounces(_elastic_elbow())
    assert len(rigid_rebounds) == len(rebounds) >= 3
    np.testing.assert_allclose(rebounds, rigid_rebounds, rtol=0.2)
    np.testing.assert_allclose(losses[:2], rigid_losses[:2], rtol=0.2)
    assert rigid_losses[0] > 0.5  # an impact that matters: the limit's solref takes most of the energy


def test_element_stops_damped_by_the_files_solref_bounce_like_its_limit():
    """Issue 31: the elbow's range as element stops with a damping mapped from the file's solref (0.02 s, ratio 1:
    ``stops={"time_constant": 0.02, "damping_ratio": 1.0}``, mjflex.Stops' arguments) carries the 1e-9 rad nudge for
    1 s at 2 ms without growth, where undamped element stops chatter, and its first two bounces rebound and lose
    energy as the rigid arm's MuJoCo limit within 20 %."""
    solref = _pusher().compile().jnt_solref[0]
    model = _elastic_elbow({"time_constant": float(solref[0]), "damping_ratio": float(solref[1])})
    assert mjflex.Flexures(model).records[0].stops.damping is not None
    assert np.abs(_pressed(model) - _pressed(model, nudge=1e-9)).max() < 1e-6
    rigid_rebounds, rigid_losses = _bounces(_pusher(timestep=2e-3, elbow_spring=K_BEARINGS[2]).compile())
    rebounds, losses = _bounces(model)
    np.testing.assert_allclose(rebounds[:2], rigid_rebounds[:2], rtol=0.2)
    np.testing.assert_allclose(losses[:2], rigid_losses[:2], rtol=0.2)


def test_element_stops_take_the_ranges_with_the_stops_arguments_given():
    """``stops={"stiffness": 500}``: the elbow's range on the element's rz, with that stiffness; the joint's MuJoCo
    limit goes (one kind of stop, not two). A limit among the arguments is refused: the ranges give them."""
    spec = _pusher()
    c = mjflex.make_compliant(spec, ELBOW, K_BEARINGS, replace_joints=True, stops={"stiffness": 500.0})
    model = spec.compile()
    stops = mjflex.Flexures(model).records[0].stops
    assert c.replaced.stops == "element" and not model.jnt_limited[model.joint(ELBOW_JOINT).id]
    np.testing.assert_array_equal(stops.lower, [-np.inf, -np.inf, -2.3213, -np.inf, -np.inf, -np.inf])
    np.testing.assert_array_equal(stops.upper, [np.inf, np.inf, 0.0, np.inf, np.inf, np.inf])
    assert stops.stiffness == 500.0
    with pytest.raises(ValueError, match=r"\['upper'\] are not arguments of mjflex.Stops that make_compliant lets"):
        mjflex.make_compliant(_pusher(), ELBOW, K_BEARINGS, replace_joints=True, stops={"upper": [0.1] * 6})


def test_a_stop_kind_without_replaced_joints_is_refused():
    """MuJoCo's limits, or the ranges as element stops, need replaced joints: on a welded body they are a clear
    error, as is an unknown kind; the spec is untouched."""
    spec = arm_spec()
    before = spec.to_xml()
    for kind in ("limits", "element"):
        with pytest.raises(ValueError, match=rf"stops='{kind}' keeps the replaced joints' ranges.*mjflex.Stops"):
            mjflex.make_compliant(spec, "hand", [5, 5, 5, 1e4, 1e4, 1e4], stops=kind)
    with pytest.raises(TypeError, match=r"stops must be 'limits', 'element', a dict of mjflex.Stops arguments"):
        mjflex.make_compliant(spec, "hand", [5, 5, 5, 1e4, 1e4, 1e4], stops="soft")
    assert spec.to_xml() == before


# ----------------------------------------------------------------------------- a second call, redundant joints


def test_a_second_element_on_one_body_is_refused():
    """Issue 33 item 4: make_compliant(..., replace_joints=True) on a body it already made compliant would hand the
    first element's coordinates to a second one, in parallel. It is refused, naming the element and the ways out,
    before anything changes; after make_rigid the body takes one again. (add_flexure still adds one in parallel on
    purpose, with its warning.)"""
    spec = spine_spec()
    first = mjflex.make_compliant(spec, "L3", [50, 50, 30, 2e5, 2e5, 5e5], replace_joints=True)
    before = spec.to_xml()
    with pytest.raises(ValueError, match=r"'L3' and its parent 'L4' are already joined by flexure 'L3_compliance'.*"
                                         r"make_rigid.*mjflex.add_flexure\(spec, name, 'L4', 'L3'"):  # fmt: skip
        mjflex.make_compliant(spec, "L3", [50, 50, 30, 2e5, 2e5, 5e5], replace_joints=True, name="again")
    assert spec.to_xml() == before
    mjflex.make_rigid(spec, first)
    again = mjflex.make_compliant(spec, "L3", [50, 50, 30, 2e5, 2e5, 5e5], replace_joints=True)
    assert again.replaced.joints == first.replaced.joints
    hand = arm_spec()  # a welded body with an element on its weld already (add_flexure warned that it never deflects)
    with pytest.warns(mjflex.LikelyMistakeWarning, match="never deflects"):
        mjflex.add_flexure(hand, "mount", "link3", "hand", pos=[0.36, 0, 0.4], K=[5, 5, 5, 1e4, 1e4, 1e4])
    with pytest.raises(ValueError, match=r"already joined by flexure 'mount'"):
        mjflex.make_compliant(hand, "hand", [5, 5, 5, 1e4, 1e4, 1e4])


REDUNDANT = """<mujoco><worldbody><body name="base"><geom size="0.05"/>
  <body name="arm" pos="0 0 0.1"><joint name="a" axis="0 1 0" armature="1e-3"/>
    <joint name="b" axis="0 1 0" pos="0.01 0 0" armature="1e-3"/><joint name="c" type="ball" armature="1e-3"/>
    <geom type="capsule" fromto="0 0 0 0.2 0 0" size="0.02"/></body>
  </body></worldbody></mujoco>"""


def test_redundant_joints_are_refused_up_front_by_name():
    """Issue 33 item 16: two parallel hinges and a ball turn the body about y three times: with the
    element's translations added it would have 8 dofs, which MuJoCo refuses ("more than 6 dofs"). make_compliant
    says so first, naming each redundant joint and the ones it repeats; the spec is untouched. Fewer directions (the
    rotations only) fit in six and are accepted."""
    spec = mujoco.MjSpec.from_string(REDUNDANT)
    before = spec.to_xml()
    said = r"'arm' would get 8 degrees of freedom .*3 added.* at most 6.*hinge b \(1 of its dofs already given by a\); "
    with pytest.raises(ValueError, match=said + r"ball c \(1 of its dofs already given by a, b\)"):
        mjflex.make_compliant(spec, "arm", [5, 5, 5, 1e4, 1e4, 1e4], replace_joints=True)
    assert spec.to_xml() == before
    c = mjflex.make_compliant(spec, "arm", [5, 5, 5], replace_joints=True, directions="rotations", stops=False)
    assert c.joints == () and spec.compile().nv == 5


# ----------------------------------------------------------------------------- some of a body's joints (item 5)

THREE = """<mujoco><compiler angle="radian"/><option gravity="0 0 0"/><worldbody><body name="base"><geom size="0.05"/>
  <body name="head" pos="0 0 0.1">
    <joint name="nod" axis="0 1 0" stiffness="20" damping="0.3" armature="1e-3" range="-0.4 0.3"/>
    <joint name="tilt" axis="1 0 0" stiffness="20" damping="0.3" armature="1e-3" range="-0.2 0.2"/>
    <joint name="turn" axis="0 0 1" stiffness="20" damping="0.3" armature="1e-3" range="-1 1"/>
    <geom type="box" size="0.03 0.02 0.05" pos="0 0 0.05"/></body></body></worldbody>
  <actuator><motor name="nodder" joint="nod"/></actuator></mujoco>"""


def test_one_hinge_of_three_is_replaced_and_the_others_stay_joints():
    """Issue 33 item 5: replace_joints=["nod"] hands one hinge to the element (its axis the element's z; the
    translations added as slides), and the two others stay joints with their springs, dampers, armature and
    limits; the element leaves their directions alone. Statics: a torque about the nod axis turns it by tau / K_rz
    (the element), one about the tilt axis by tau / 20 (its own spring), whatever K says elsewhere."""
    spec = mujoco.MjSpec.from_string(THREE)
    rigid = spec.compile()
    c = mjflex.make_compliant(spec, "head", [0, 0, 7.0, 1e5, 1e5, 1e5], replace_joints=["nod"])
    model = spec.compile()
    assert c.replaced.joints == ("nod",) and c.replaced.kept == ("tilt", "turn")
    assert c.directions == ("rz", "x", "y", "z") and c.joints == tuple(f"head_compliance/{d}" for d in "xyz")
    assert model.nv == rigid.nv + 3 and np.all(c.K[:2] == 0) and np.all(c.K[:, :2] == 0)
    for name in ("tilt", "turn"):  # untouched
        j, i = model.joint(name).id, rigid.joint(name).id
        for field in ("jnt_stiffness", "jnt_range", "jnt_limited", "jnt_solref"):
            assert np.array_equal(getattr(model, field)[j], getattr(rigid, field)[i]), (name, field)
        assert model.dof_damping[model.jnt_dofadr[j]] == 0.3 and model.dof_armature[model.jnt_dofadr[j]] == 1e-3
    nod = model.joint("nod").id
    assert model.jnt_stiffness[nod] == model.dof_damping[model.jnt_dofadr[nod]] == 0
    assert model.dof_armature[model.jnt_dofadr[nod]] == 1e-3 and model.jnt_limited[nod]
    free = ["nod", "tilt", "turn", *c.joints]
    assert math.isclose(_rest_angle(model, "nod", 1e-3, free), 1e-3 / 7.0, rel_tol=1e-6)
    assert math.isclose(_rest_angle(model, "tilt", 1e-3, free), 1e-3 / 20.0, rel_tol=1e-6)
    mjflex.make_rigid(spec, c)
    back = spec.compile()
    for field in ("jnt_stiffness", "dof_damping", "dof_armature", "jnt_range", "qpos0", "body_pos"):
        np.testing.assert_array_equal(getattr(back, field), getattr(rigid, field), err_msg=field)


def test_a_damping_ratio_with_kept_joints_damps_the_element_alone():
    """With kept joints, damping_ratio gives the element's own modes their ratio and leaves the kept joints'
    directions undamped by the element (their own dampers stay): B is zero there, and a free nod measures 5 %."""
    spec = mujoco.MjSpec.from_string(THREE.replace('damping="0.3"', 'damping="0"'))
    c = mjflex.make_compliant(spec, "head", [0, 0, 7.0, 1e5, 1e5, 1e5], replace_joints=["nod"], damping_ratio=0.05)
    assert np.all(c.B[:2] == 0) and np.all(c.B[:, :2] == 0) and c.B[2, 2] > 0
    model = spec.compile()
    model.opt.timestep = 1e-4
    data = mujoco.MjData(model)
    data.qvel[model.joint("nod").dofadr[0]] = 1e-3
    nod = np.empty(20000)
    for i in range(len(nod)):
        mujoco.mj_step(model, data)
        nod[i] = data.qpos[model.joint("nod").qposadr[0]]
    ratio, periods = decay_ratio(nod)
    assert periods >= 4 and math.isclose(ratio, 0.05, rel_tol=0.05)


def test_replace_joints_names_are_checked():
    """A joint of another body, an unknown name, an empty list, a number; stiffness or directions where a kept
    joint moves the body: each a clear error before anything changes."""
    spec = spine_spec()
    before = spec.to_xml()
    K = [50, 50, 30, 2e5, 2e5, 5e5]
    cases = [
        (dict(replace_joints=["L4_flex"]), ValueError, r"'L4_flex' is not a joint of body 'L3'.*of body 'L4'"),
        (dict(replace_joints=["L3_flx"]), ValueError, r"'L3_flx' is not a joint of body 'L3'.*mean \['L3_flex'"),
        (dict(replace_joints=[]), ValueError, r"replace_joints=\[\] names no joint of body 'L3'"),
        (dict(replace_joints=1), TypeError, r"replace_joints must be True.*or the names of the joints"),
        (dict(replace_joints=["L3_flex"]), ValueError, r"K is not zero in directions \['rx', 'ry'\], which the kept "
                                                        r"joint\(s\) \['L3_bend', 'L3_rot'\]"),
        (dict(replace_joints=["L3_flex"], K=[30, 2e5, 2e5, 5e5], directions=("rx", "rz", "x", "y", "z")), ValueError,
         r"directions \['rx'\] are moved by kept joint\(s\)"),
    ]  # fmt: skip
    for kwargs, error, match in cases:
        with pytest.raises(error, match=match):
            mjflex.make_compliant(spec, "L3", **{"K": K, **kwargs})
    assert spec.to_xml() == before
    c = mjflex.make_compliant(spec, "L3", [30, 2e5, 2e5, 5e5], replace_joints="L3_flex")  # one name, as a str
    assert c.replaced.joints == ("L3_flex",) and c.directions == ("rz", "x", "y", "z")


# ----------------------------------------------------------------------------- closures (item 6)

FOURBAR = """<mujoco model="fourbar">
  <compiler angle="radian"/>
  <option timestep="2e-3" gravity="0 0 -9.81"/>
  <default><joint type="hinge" axis="0 1 0" armature="1e-3" damping="0.01"/>
    <geom type="capsule" size="0.004" density="2700"/></default>
  <worldbody>
    <body name="crank"><joint name="j_crank"/><geom fromto="0 0 0 0 0 0.03"/>
      <body name="coupler" pos="0 0 0.03"><joint name="j_coupler"/><geom fromto="0 0 0 0.06 0 0"/>
        <site name="coupler_end" pos="0.06 0 0"/></body></body>
    <body name="rocker" pos="0.06 0 0"><joint name="j_rocker" stiffness="0.5"/><geom fromto="0 0 0 0 0 0.03"/>
      <site name="rocker_end" pos="0 0 0.03"/></body>
  </worldbody>
  <equality><connect name="loop" site1="coupler_end" site2="rocker_end" solref="0.006 1"/></equality>
  <actuator><motor name="drive" joint="j_crank"/></actuator>
  <keyframe><key name="grip" ctrl="0.05"/></keyframe>
</mujoco>"""


def _opening(model, keyframe):
    """The distance between the loop's two sites at the model's rest from ``keyframe`` [m], from their positions."""
    qpos = mjflex.static_equilibrium(model, keyframe=keyframe)
    data = mujoco.MjData(model)
    data.qpos[:] = qpos
    mujoco.mj_kinematics(model, data)
    return float(np.linalg.norm(data.site("coupler_end").xpos - data.site("rocker_end").xpos))


def test_a_closure_that_opens_after_the_replacement_is_reported_and_warned_about():
    """Issue 33 item 6: a four-bar of light links on pivots with armature, closed by a connect whose solref holds it
    to micrometres under the motor's load. Its coupler pivot replaced, the coupler gets light slides beside it, and
    the same solref (its stiffness scales with the effective mass at the constraint) lets the loop open a hundred
    times further. Compliance.closures gives both openings at rest at the keyframe, which are the sites' distance
    computed here from the two models' equilibria, and the growth past 10 times is warned about."""
    spec = mujoco.MjSpec.from_string(FOURBAR)
    rigid = spec.compile()
    with pytest.warns(mjflex.LikelyMistakeWarning, match=r"equality 'loop' \(connect\) is open 0.000\d+ m at the "
                                                         r"operating pose, \d+ times the rigid model's"):  # fmt: skip
        c = mjflex.make_compliant(spec, "coupler", [5, 5, 0.05, 1e5, 1e5, 1e5], replace_joints=True, keyframe="grip")
    (closure,) = c.closures
    assert (closure.equality, closure.type, closure.unit, closure.opened) == ("loop", "connect", "m", True)
    assert math.isclose(closure.rigid, _opening(rigid, "grip"), rel_tol=1e-6)
    assert math.isclose(closure.compliant, _opening(spec.compile(), "grip"), rel_tol=1e-6)
    assert closure.growth > 10 and closure.rigid < 1e-5  # it held to micrometres
    assert "closures: 1 (opened: loop)" in repr(c)


def test_the_spine_closures_hold_after_its_disc_replaces_the_hinges():
    """The spine's joint equalities (stiff solref) at rest under gravity at the bent keyframe: the disc, stiffer than
    the hinges' springs, carries more of the load, and every closure that stays holds at least as well as in the rigid
    model; nothing is warned about."""
    spec = spine_spec(solref=(2e-3, 1.0))
    with warnings.catch_warnings():
        warnings.simplefilter("error", mjflex.LikelyMistakeWarning)
        c = mjflex.make_compliant(spec, "L3", [50, 50, 30, 2e5, 2e5, 5e5], replace_joints=True, keyframe="bent")
    assert {x.equality for x in c.closures} == {
        f"{lvl}_{h}_follows" for lvl in ("L4", "L2") for h in ("flex", "bend", "rot")
    }
    assert c.closure_note is None and all(x.unit == "rad" and x.type == "joint" for x in c.closures)
    assert all(0 < x.compliant <= x.rigid for x in c.closures) and not any(x.opened for x in c.closures)


# ----------------------------------------------------------------------------- a spring's reference (issue 31)

PRELOADED = """<mujoco><compiler angle="radian"/><option gravity="0 0 0"/><worldbody>
  <body name="base"><geom size="0.05"/><body name="finger" pos="0 0 0.1">
    <joint name="pivot" axis="0 1 0" stiffness="20" springref="0.3" range="-0.4 0.6" armature="1e-3"/>
    <geom type="box" size="0.04 0.01 0.01" pos="0.04 0 0"/></body></body></worldbody></mujoco>"""
K_PIVOT = [2e3, 2e3, 20.0, 1e6, 1e6, 1e6]  # the pivot's spring, 20 N m/rad, about the element's z


def _pivot_at_rest(spec, torque=0.0):
    model = spec.compile()
    qfrc = np.zeros(model.nv)
    qfrc[model.joint("pivot").dofadr[0]] = torque
    return mjflex.static_equilibrium(model, qfrc_applied=qfrc)[model.joint("pivot").qposadr[0]]


def test_a_replaced_spring_keeps_its_preload_as_the_elements_rest_pose():
    """A pivot's spring rests at its springref (0.3 rad), away from the compiled pose (0): the element that replaces
    it rests there too (its rest pose, 0.3 rad about its z), as in the rigid model; rest=False rests at the compiled
    pose. Element stops made from the range [-0.4, 0.6] count from the rest pose, so they still stop the pivot at
    0.6 rad: pushed by 50 N m it rests where the spring and the stop (100 times the spring) balance it."""
    rigid = mujoco.MjSpec.from_string(PRELOADED)
    assert math.isclose(_pivot_at_rest(rigid), 0.3, abs_tol=1e-9)
    spec = mujoco.MjSpec.from_string(PRELOADED)
    c = mjflex.make_compliant(spec, "finger", K_PIVOT, replace_joints=True)
    np.testing.assert_allclose(c.rest[1], [math.cos(0.15), 0, 0, math.sin(0.15)], atol=1e-15)
    np.testing.assert_allclose(c.rest[0], [0, 0, 0], atol=1e-15)
    assert "spring reference 0.3 != ref 0 (carried over: the element rests there)" in c.replaced.notes[0]
    assert math.isclose(_pivot_at_rest(spec), 0.3, abs_tol=1e-9)
    relaxed = mujoco.MjSpec.from_string(PRELOADED)
    assert mjflex.make_compliant(relaxed, "finger", K_PIVOT, replace_joints=True, rest=False).rest is None
    assert abs(_pivot_at_rest(relaxed)) < 1e-9

    stopped = mujoco.MjSpec.from_string(PRELOADED)
    c = mjflex.make_compliant(stopped, "finger", K_PIVOT, replace_joints=True, stops="element")
    np.testing.assert_allclose([c.replaced.lower[2], c.replaced.upper[2]], [-0.4, 0.6], rtol=1e-15)  # from ref
    stops = mjflex.Flexures(stopped.compile()).records[0].stops
    np.testing.assert_allclose([stops.lower[2], stops.upper[2]], [-0.7, 0.3], rtol=1e-12)  # from the rest pose
    k_stop = 100 * K_PIVOT[2]
    expected = (50.0 + K_PIVOT[2] * 0.3 + k_stop * 0.6) / (K_PIVOT[2] + k_stop)
    assert math.isclose(_pivot_at_rest(stopped, 50.0), expected, rel_tol=1e-6)

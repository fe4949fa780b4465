"""A compliant hand on a small arm in one call (mjflex.make_compliant), and back (mjflex.make_rigid).

The arm (tests/robots.py) reproduces the trap of a real gripper: the hand's cuff overlaps the
link before its parent, a contact MuJoCo filters while the hand is welded and not once it has
joints. Statics are solved by Newton's method on MuJoCo's forces; damping ratios are measured by
the logarithmic decrement of free vibrations.
"""

import warnings

import mujoco
import numpy as np
import pytest
import scipy.linalg

import mjflex
from mjflex.analysis.damping import displacement_jacobian, element_dofs
from mjflex.analysis.linearize import mass_matrix, state, stiffness_matrix
from tests.robots import (
    ARM_JOINTS,
    K_HAND,
    arm_spec,
    body_id,
    decay_ratio,
    free_vibration,
    solve_statics,
    subtree_wrench,
)

NEIGHBOUR = r"bodies 'hand' and 'link2' touch in the reference configuration \(geoms 'cuff' and 'g2'\)"


def _quiet(model):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        return mjflex.Flexures(model)


def _compliant(**kwargs):
    spec = arm_spec()
    kwargs.setdefault("K", K_HAND)
    return spec, mjflex.make_compliant(spec, "hand", site="wrist", **kwargs)


def test_one_call_gives_the_hand_six_clean_dofs_and_valid_keyframes():
    rigid = arm_spec().compile()
    spec, c = _compliant()
    model = spec.compile()
    assert (model.nq, model.nv) == (rigid.nq + 7, rigid.nv + 6)
    assert c.parent == "link3" and c.element == "hand_compliance" and c.frame == "wrist"
    assert c.joints == tuple(f"hand_compliance/{j}" for j in ("x", "y", "z", "ball"))
    for j in c.joints:  # the arm's childclass gives armature, range, damping, stiffness, friction: none inherited
        jid = model.joint(j).id
        dofs = slice(model.jnt_dofadr[jid], model.jnt_dofadr[jid] + (3 if j.endswith("ball") else 1))
        assert not model.jnt_limited[jid] and model.jnt_stiffness[jid] == 0
        assert not (
            model.dof_armature[dofs].any() or model.dof_damping[dofs].any() or model.dof_frictionloss[dofs].any()
        )
    arm = [model.joint(j).id for j in ARM_JOINTS]
    assert model.dof_armature[arm].tolist() == [0.01] * 3  # the arm's own joints keep theirs
    # keyframes: the arm's values where they were, the hand at rest; every body where the rigid model had it
    assert [e.key for e in c.keyframes] == ["home", "up"]
    for k in range(rigid.nkey):
        assert np.array_equal(model.key_qpos[k][model.jnt_qposadr[arm]], rigid.key_qpos[k])
        d0, d1 = mujoco.MjData(rigid), mujoco.MjData(model)
        mujoco.mj_resetDataKeyframe(rigid, d0, k)
        mujoco.mj_resetDataKeyframe(model, d1, k)
        mujoco.mj_kinematics(rigid, d0)
        mujoco.mj_kinematics(model, d1)
        np.testing.assert_allclose(d1.xpos, d0.xpos, atol=1e-15)
        np.testing.assert_allclose(d1.xmat, d0.xmat, atol=1e-15)
    # the element frame is the site's, and the model saved as XML reads back with the same settings
    flex = _quiet(model)
    again = mujoco.MjModel.from_xml_string(spec.to_xml())
    for name in ("jnt_limited", "dof_armature", "dof_damping", "jnt_stiffness", "key_qpos", "site_pos", "site_quat"):
        np.testing.assert_allclose(getattr(again, name), getattr(model, name), atol=1e-6)
    d = mujoco.MjData(model)
    mujoco.mj_kinematics(model, d)
    for s in flex.site_ids[0]:
        np.testing.assert_allclose(d.site_xpos[s], d.site_xpos[model.site("wrist").id], atol=1e-15)
        np.testing.assert_allclose(d.site_xmat[s], d.site_xmat[model.site("wrist").id], atol=1e-15)


def test_the_neighbour_contact_the_weld_filtered_is_excluded_by_name():
    spec, c = _compliant()
    assert c.excludes == (("link2", "hand"),) and c.kept == ()
    model = spec.compile()
    _quiet(model)
    for k in range(model.nkey):
        d = mujoco.MjData(model)
        mujoco.mj_resetDataKeyframe(model, d, k)
        mujoco.mj_forward(model, d)
        assert d.ncon == 0


def test_kept_neighbour_contact_is_reported_once_by_name():
    with pytest.warns(UserWarning, match=NEIGHBOUR) as record:
        _, c = _compliant(collide=[("hand", "link2")])
    assert c.excludes == () and c.kept == (("link2", "hand"),)
    assert sum("touch" in str(w.message) for w in record) == 1
    assert 'Restore the filtering: <contact><exclude body1="hand" body2="link2"/></contact>' in str(record[0].message)


def test_hand_made_unweld_is_reported_by_flexures():
    """The issue's route: joints added by hand and an element: Flexures names the resting neighbour contact."""
    spec = arm_spec()
    hand = spec.body("hand")
    for axis in np.eye(3):
        hand.add_joint(type=mujoco.mjtJoint.mjJNT_SLIDE, axis=axis, limited=mujoco.mjtLimited.mjLIMITED_FALSE)
    hand.add_joint(type=mujoco.mjtJoint.mjJNT_BALL, limited=mujoco.mjtLimited.mjLIMITED_FALSE)
    for key in spec.keys:
        key.qpos = [*key.qpos, 0, 0, 0, 1, 0, 0, 0]
    mjflex.add_flexure(spec, "wrist", "link3", "hand", site="wrist", K=K_HAND)
    model = spec.compile()
    with pytest.warns(UserWarning, match=NEIGHBOUR) as record:
        mjflex.Flexures(model)
    message = str(record[0].message)
    assert "flexure 'wrist'" in message and '<exclude body1="hand" body2="link2"/>' in message
    spec.add_exclude(bodyname1="hand", bodyname2="link2")
    _quiet(spec.compile())  # the exclude the warning names restores the filtering


@pytest.mark.parametrize("keyframe", [0, 1])
def test_statics_under_gravity_and_a_wrench_agree_with_the_compliance(keyframe):
    """At a keyframe, gravity and a wrench applied to the hand: Newton on the hand's dofs (the arm held)
    gives K^-1 times the load, computed from masses and positions alone.

    K is stiff so that the second-order terms stay below the 1e-5 asked of the agreement: the
    rotation (~1e-6 rad) turns the load (relative O(|x|)), and the translation t ~ F/K_t shifts the
    point the moment is taken about between frames a and b (F t / M ~ 1e-6 with K_t ~ 1e8 N/m).
    """
    K = np.array([3e3, 5e3, 2e3, 1e8, 2e8, 3e8])
    spec, c = _compliant(K=K)
    model = spec.compile()
    flex = _quiet(model)
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, keyframe)
    force, torque = np.array([0.3, 0.5, -0.2]), np.array([0.002, -0.003, 0.001])
    data.xfrc_applied[body_id(model, "hand")] = [*force, *torque]
    solve_statics(model, flex, data, element_dofs(model, flex, c.element))
    x = flex.displacements(data)[0]
    site_b = f"{c.element}/b"  # the element's frame on the hand, where its wrench acts
    expected = np.linalg.solve(np.diag(K), subtree_wrench(model, data, "hand", site_b, force, torque))
    assert np.abs(x[:3]).min() > 5e-8 and np.abs(x[3:]).min() > 1e-10  # every direction loaded
    np.testing.assert_allclose(x[:3], expected[:3], rtol=1e-5, atol=1e-5 * np.abs(expected[:3]).max())
    np.testing.assert_allclose(x[3:], expected[3:], rtol=1e-5, atol=1e-5 * np.abs(expected[3:]).max())


def _element_modes(model, flex, element, dofs, keyframe=None, actuators=False):
    K = stiffness_matrix(model, flex, keyframe=keyframe, joint_springs=True, actuator_stiffness=actuators)
    M = mass_matrix(model, keyframe=keyframe)
    lam, phi = scipy.linalg.eigh(0.5 * (K + K.T)[np.ix_(dofs, dofs)], M[np.ix_(dofs, dofs)])
    psi = displacement_jacobian(model, flex, element, state(model, keyframe))[:, dofs] @ phi
    share = np.einsum("ik,ij,jk->k", psi, flex.records[flex.index(element)].K, psi) / np.maximum(lam, 1e-300)
    return np.sqrt(np.maximum(lam, 0.0)), phi, psi, share


@pytest.mark.parametrize("direction", [0, 2, 5], ids=["bending", "torsion", "axial"])
def test_damping_ratio_on_a_servo_held_arm_is_measured(direction):
    """1 % asked, for the modes of the hand on the arm held by its position servos (others='free' with the
    servos' kp): the log decrement of a free vibration in the mode gives 1 % within 10 %."""
    spec, c = _compliant(damping_ratio=0.01, keyframe="home", others="free", actuator_stiffness=True)
    model = spec.compile()
    flex = _quiet(model)
    model.opt.gravity[:] = 0  # the free vibration about the keyframe, where the servos hold the arm
    arm = [model.joint(j).id for j in ARM_JOINTS]
    model.dof_damping[arm] = model.dof_frictionloss[arm] = 0  # the arm's own losses are not the element's ratio
    model.jnt_stiffness[arm] = 0  # nor its springs, whose preload would move it off the keyframe (2 vs kp 5e3+)
    dofs = np.arange(model.nv)
    omega, phi, psi, share = _element_modes(model, flex, c.element, dofs, "home", actuators=True)
    element_modes = np.nonzero(share > 0.5)[0]
    assert len(element_modes) == 6
    k = element_modes[np.argmax(np.abs(psi[direction, element_modes]) / np.abs(psi[:, element_modes]).max(axis=0))]
    y = free_vibration(model, flex, c.element, dofs, phi[:, k], "home", omega=omega[k])
    ratio, periods = decay_ratio(y)
    assert periods >= 6
    assert ratio == pytest.approx(0.01, rel=0.1)


def _welded_arm():
    """The arm with its joints removed: welded to the world at qpos0 (the arm 'locked' there)."""
    spec = arm_spec()
    for a in list(spec.actuators):
        spec.delete(a)
    for j in ARM_JOINTS:
        spec.delete(spec.joint(j))
    for key in list(spec.keys):
        spec.delete(key)
    return spec


def test_locked_damping_is_that_of_the_hand_on_a_rigid_arm():
    """others='locked' (the default): the inertia of the hand alone about the element frame, the arm
    held. Equal to the damping computed with every dof free on the arm welded at qpos0, and measured
    there."""
    ratios = [0.01, 0.01, 0.02, 0.01, 0.01, 0.01]
    _, locked = _compliant(damping_ratio=ratios)
    spec = _welded_arm()
    c = mjflex.make_compliant(spec, "hand", K=K_HAND, site="wrist", damping_ratio=ratios, others="free")
    # welded to the world, link3 is no longer the hand's parent weld group (MuJoCo exempts the world): excluded
    assert ("link3", "hand") in c.excludes
    np.testing.assert_allclose(c.B, locked.B, rtol=1e-6, atol=1e-9 * np.abs(c.B).max())
    welded = spec.compile()
    flex = _quiet(welded)
    welded.opt.gravity[:] = 0
    dofs = np.arange(welded.nv)
    omega, phi, psi, _ = _element_modes(welded, flex, c.element, dofs)
    for direction, wanted in ((0, 0.01), (2, 0.02)):  # bending, torsion
        k = int(np.argmax(np.abs(psi[direction]) / np.abs(psi).max(axis=0)))
        ratio, _ = decay_ratio(free_vibration(welded, flex, c.element, dofs, phi[:, k], omega=omega[k]))
        assert ratio == pytest.approx(wanted, rel=0.1)


def test_damping_is_what_the_element_applies():
    """B from ratios acts on the generalized velocities as J^T B J (J from the element's finite twist):
    the provider's damping forces differentiated by velocity agree, and the modes' damping is diagonal."""
    spec, c = _compliant(damping_ratio=0.01, keyframe="home")
    model = spec.compile()
    flex = _quiet(model)
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, 0)
    C = np.zeros((model.nv, model.nv))
    for i in range(model.nv):
        out = []
        for sign in (1.0, -1.0):
            data.qvel[:] = 0
            data.qvel[i] = sign * 1e-6
            mujoco.mj_forward(model, data)
            out.append(flex.generalized_forces(data))
        C[:, i] = -(out[0] - out[1]) / 2e-6
    J = displacement_jacobian(model, flex, c.element, state(model, "home"))
    np.testing.assert_allclose(C, J.T @ c.B @ J, atol=1e-8 * np.abs(C).max())
    dofs = element_dofs(model, flex, c.element)
    omega, phi, _, _ = _element_modes(model, flex, c.element, dofs, "home")
    modal = phi.T @ C[np.ix_(dofs, dofs)] @ phi
    np.testing.assert_allclose(modal, np.diag(0.02 * omega), atol=1e-9 * modal.max())


def test_make_rigid_restores_the_model():
    original = arm_spec()
    before = original.compile()
    spec, c = _compliant(damping_ratio=0.01)
    mjflex.make_rigid(spec, c)
    after = spec.compile()
    for name in ("nq", "nv", "njnt", "nsite", "ntext", "nexclude", "nkey"):
        assert getattr(after, name) == getattr(before, name), name
    np.testing.assert_array_equal(after.key_qpos, before.key_qpos)
    np.testing.assert_array_equal(after.key_qvel, before.key_qvel)
    poses = []
    for model in (before, after):
        data = mujoco.MjData(model)
        mujoco.mj_resetDataKeyframe(model, data, 0)
        mujoco.mj_kinematics(model, data)
        poses.append((data.xpos.copy(), data.xmat.copy()))
    np.testing.assert_array_equal(poses[1][0], poses[0][0])
    np.testing.assert_array_equal(poses[1][1], poses[0][1])
    with pytest.raises(ValueError, match="make_rigid called already"):
        mjflex.make_rigid(spec, c)


@pytest.mark.parametrize(
    "directions, K, joints",
    [
        ("rotations", [5.0, 5.0, 3.0], ["ball"]),
        (("rx", "rz"), [5.0, 3.0], ["hinge", "hinge"]),
        (("z",), [2e4], ["slide"]),
        (("ry", "x", "y"), np.diag([5.0, 2e4, 2e4]), ["slide", "slide", "hinge"]),
    ],
)
def test_fewer_directions_give_fewer_dofs_along_the_element_axes(directions, K, joints):
    spec, c = _compliant(directions=directions, K=K)
    model = spec.compile()
    kinds = {0: "free", 1: "ball", 2: "slide", 3: "hinge"}
    assert [kinds[int(model.jnt_type[model.joint(j).id])] for j in c.joints] == joints
    flex = _quiet(model)
    d = mujoco.MjData(model)
    mujoco.mj_kinematics(model, d)
    R_WE = d.site_xmat[model.site("wrist").id].reshape(3, 3)
    for name in c.joints:  # hinge and slide axes are the element frame's axes
        j = model.joint(name).id
        if model.jnt_type[j] in (2, 3):
            axis = d.xaxis[j]
            letter = name.rsplit("/", 1)[1][-1]
            np.testing.assert_allclose(axis, R_WE[:, "xyz".index(letter)], atol=1e-12)
    assert c.directions == tuple(x for x in ("rx", "ry", "rz", "x", "y", "z") if x in c.directions)
    K6 = np.asarray(c.K)
    idx = [("rx", "ry", "rz", "x", "y", "z").index(x) for x in c.directions]
    assert np.all(np.delete(np.delete(K6, idx, 0), idx, 1) == 0)
    assert flex.records[0].K.shape == (6, 6)


def _spec_with_site_on_link1():
    spec = arm_spec()
    spec.body("link1").add_site(name="elsewhere")
    return spec


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"body": "world"}, "world body has no parent"),
        ({"body": "hnd"}, r"body 'hnd' is not in the spec; did you mean \['hand'\]"),
        ({"body": "link3"}, r"body 'link3' already has joints \(j3\)"),
        ({"site": "elsewhere"}, "site 'elsewhere' belongs to body 'link1', not to 'hand' or its parent 'link3'"),
        ({"site": "wrst"}, "site 'wrst' is not in the spec; did you mean"),
        ({"directions": ()}, "the body would keep no degree of freedom"),
        ({"directions": ["rx", "twist"]}, r"directions \['twist'\] unknown"),
        ({"damping_ratio": 0.0}, "every ratio must be a finite number > 0"),
        ({"damping_ratio": -0.01}, "every ratio must be a finite number > 0"),
        ({"damping_ratio": float("nan")}, "every ratio must be a finite number > 0"),
        ({"damping_ratio": [0.01, 0.02]}, "one per direction"),
        ({"damping_ratio": 0.01, "B": 0.001 * K_HAND}, "give B or damping_ratio, not both"),
        ({"K": [1.0, 2.0]}, "K must be 6 numbers or 6x6"),
        ({"K": [5, 5, 3, 2e4, 2e4, -1]}, "not positive semi-definite"),
        ({"site": "wrist", "pos": [0, 0, 0]}, "not both"),
        ({"collide": ["hand", "nobody"]}, "collide: 'nobody' is not a body"),
        ({"joint_attributes": {"colour": 1}}, "'colour' is not a joint attribute"),
    ],
    ids=lambda v: str(v)[:40] if isinstance(v, dict) else None,
)
def test_bad_input_gets_one_clear_error_and_leaves_the_spec(kwargs, match):
    spec = _spec_with_site_on_link1()
    before = spec.to_xml()
    args = {"body": "hand", "K": K_HAND, "site": "wrist", **kwargs}
    body = args.pop("body")
    with pytest.raises(ValueError, match=match):
        mjflex.make_compliant(spec, body, **args)
    assert spec.to_xml() == before


def test_a_mocap_body_is_refused():
    spec = arm_spec()
    spec.worldbody.add_body(name="target", mocap=True).add_geom(size=[0.01, 0, 0])
    with pytest.raises(ValueError, match="mocap body, which cannot have joints"):
        mjflex.make_compliant(spec, "target", K=K_HAND)


def test_damping_from_ratios_checks_its_ratios():
    spec, c = _compliant()
    model = spec.compile()
    for bad in (0.0, float("nan"), [0.01] * 5, "x"):
        with pytest.raises(ValueError, match="damping_ratio"):
            mjflex.damping_from_ratios(model, c.element, bad)
    with pytest.raises(ValueError, match="others="):
        mjflex.damping_from_ratios(model, c.element, 0.01, others="held")


def _scene():
    """An empty scene with the arm's options (so that attaching it raises no conflict)."""
    scene = mujoco.MjSpec()
    scene.compiler.degree = False
    scene.option.timestep, scene.option.integrator = 1e-4, mujoco.mjtIntegrator.mjINT_RK4
    return scene


def test_an_attached_arm_is_made_compliant_under_its_prefix():
    scene = _scene()
    scene.worldbody.add_geom(name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[2, 2, 0.1])
    arm = arm_spec()
    frame = scene.worldbody.add_frame(pos=[0.5, 0, 0])
    frame.attach_body(arm.body("link1"), "left/", "")
    c = mjflex.make_compliant(scene, "left/hand", K=K_HAND, site="left/wrist", damping_ratio=0.01)
    assert c.parent == "left/link3" and c.excludes == (("left/link2", "left/hand"),)
    model = scene.compile()
    flex = _quiet(model)
    assert flex.names == ("left/hand_compliance",) and flex.records[0].site == "left/wrist"
    assert body_id(model, "left/hand") > 0


def test_add_flexure_at_a_site_and_the_record_checks_it():
    spec = arm_spec()
    hand = spec.body("hand")
    hand.add_joint(type=mujoco.mjtJoint.mjJNT_BALL, limited=mujoco.mjtLimited.mjLIMITED_FALSE, range=[0, 0])
    for key in spec.keys:
        key.qpos = [*key.qpos, 1, 0, 0, 0]
    mjflex.add_flexure(spec, "wrist", "link3", "hand", site="wrist", K=K_HAND, kind="record")
    spec.add_exclude(bodyname1="hand", bodyname2="link2")
    model = spec.compile()
    flex = _quiet(model)
    assert flex.records[0].site == "wrist"
    # the same record under an attach prefix still finds its site (plugin elements: tests/test_plugin_models.py)
    scene = _scene()
    scene.worldbody.add_frame().attach_body(spec.copy().body("link1"), "r-", "-1")
    assert _quiet(scene.compile()).names == ("r-wrist-1",)
    # the site moved in the file without its element: reported, naming the site
    spec.site("wrist").pos = [0.05, 0, 0]
    with pytest.raises(mjflex.ModelError, match="away from the site 'wrist' its record names"):
        mjflex.Flexures(spec.compile())
    with pytest.raises(ValueError, match="site 'link1' is not a site"):
        mjflex.add_flexure(spec, "other", "link3", "hand", site="link1", K=K_HAND)

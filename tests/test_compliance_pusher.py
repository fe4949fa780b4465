"""A compliant forearm on a real robot file from PyPI: gymnasium's 7-dof pusher arm, unmodified.

The pusher's ``<default>`` gives every joint armature 0.04, damping 1 and ``limited="true"``
without a range (which does not even compile for a new joint): the joints make_compliant adds
must not inherit any of it. ``r_forearm_link`` is welded to ``r_forearm_roll_link`` and carries
the jointed wrist and the fingertips: the element carries a subtree.
"""

import warnings

import mujoco
import numpy as np
import pytest
import scipy.linalg

import mjflex
from mjflex.analysis.damping import displacement_jacobian, element_dofs
from mjflex.analysis.linearize import mass_matrix, stiffness_matrix
from tests.robots import body_id, decay_ratio, free_vibration, pusher_path, solve_statics, subtree_wrench

BODY, PARENT = "r_forearm_link", "r_forearm_roll_link"
K = np.array([400.0, 500.0, 300.0, 2e5, 3e5, 4e5])
FRAME = dict(pos=[0.02, 0.0, 0.0], quat=[0.7071068, 0.0, 0.7071068, 0.0], frame="parent")  # z along the forearm


def _pusher():
    spec = mujoco.MjSpec.from_file(pusher_path())
    return spec


def _quiet(model):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        return mjflex.Flexures(model)


def test_the_file_is_the_package_one_and_the_new_joints_are_clean():
    with open(pusher_path()) as f:
        text = f.read()
    assert "armature='0.04'" in text and 'limited="true"' in text  # the defaults the new joints must not take
    spec = _pusher()
    rigid = spec.compile()
    c = mjflex.make_compliant(spec, BODY, K=K, damping_ratio=0.02, **FRAME)
    model = spec.compile()
    assert c.parent == PARENT and (model.nq, model.nv) == (rigid.nq + 7, rigid.nv + 6)
    new = [model.joint(j).id for j in c.joints]
    dofs = element_dofs(model, _quiet(model), c.element)
    assert not model.jnt_limited[new].any() and not model.dof_armature[dofs].any() and not model.dof_damping[dofs].any()
    assert model.dof_armature[model.joint("r_wrist_flex_joint").dofadr[0]] == pytest.approx(
        0.04
    )  # the arm keeps its own


def test_statics_of_the_forearm_agree_with_the_compliance():
    """Gravity (the file has none; set on the compiled model) and a wrench on the forearm: Newton on the
    element's dofs, every other joint held, gives K^-1 times the load of the forearm's subtree."""
    Ks = np.array([4e5, 5e5, 3e5, 2e8, 3e8, 4e8])  # stiff: second-order terms below 1e-6 (see test_compliance)
    spec = _pusher()
    c = mjflex.make_compliant(spec, BODY, K=Ks, **FRAME)
    model = spec.compile()
    model.opt.gravity[:] = [0.0, 0.0, -9.81]
    flex = _quiet(model)
    data = mujoco.MjData(model)
    data.qpos[:] = model.qpos0
    data.qpos[model.joint("r_elbow_flex_joint").qposadr[0]] = -0.7  # a bent arm
    force, torque = np.array([0.4, -0.3, 0.2]), np.array([0.01, 0.02, -0.015])
    data.xfrc_applied[body_id(model, BODY)] = [*force, *torque]
    solve_statics(model, flex, data, element_dofs(model, flex, c.element))
    x = flex.displacements(data)[0]
    expected = np.linalg.solve(np.diag(Ks), subtree_wrench(model, data, BODY, f"{c.element}/b", force, torque))
    assert np.abs(x[:3]).min() > 1e-9  # every direction loaded
    np.testing.assert_allclose(x[:3], expected[:3], rtol=1e-5, atol=1e-5 * np.abs(expected[:3]).max())
    np.testing.assert_allclose(x[3:], expected[3:], rtol=1e-5, atol=1e-5 * np.abs(expected[3:]).max())


def test_damping_ratio_of_the_forearm_is_measured_with_the_arm_locked():
    """2 % asked (others='locked', the default): measured on the arm with its other joints removed,
    i.e. held at qpos0, by the log decrement of the bending and torsion modes."""
    spec = _pusher()
    c = mjflex.make_compliant(spec, BODY, K=K, damping_ratio=0.02, **FRAME)
    mine = set(c.joints)
    for a in list(spec.actuators):
        spec.delete(a)
    for j in [j for j in spec.joints if j.name not in mine]:
        spec.delete(j)
    model = spec.compile()
    model.opt.timestep, model.opt.integrator = 2e-4, mujoco.mjtIntegrator.mjINT_RK4
    flex = _quiet(model)
    B = mjflex.damping_from_ratios(model, c.element, 0.02, others="free")  # nothing else moves: the same B
    np.testing.assert_allclose(B, c.B, rtol=1e-6, atol=1e-9 * np.abs(B).max())
    dofs = np.arange(model.nv)
    Ks = stiffness_matrix(model, flex, joint_springs=True)
    lam, phi = scipy.linalg.eigh(Ks, mass_matrix(model))
    psi = displacement_jacobian(model, flex, c.element, mujoco.MjData(model)) @ phi
    for direction in (0, 2):  # bending about x, torsion about the forearm
        k = int(np.argmax(np.abs(psi[direction]) / np.abs(psi).max(axis=0)))
        ratio, periods = decay_ratio(free_vibration(model, flex, c.element, dofs, phi[:, k], omega=np.sqrt(lam[k])))
        assert periods >= 6 and ratio == pytest.approx(0.02, rel=0.1)


def test_attached_pusher_round_trip():
    """Two pushers attached with prefixes; one forearm made compliant, then rigid again: the model is back."""
    scene = mujoco.MjSpec()
    scene.compiler.degree = False
    scene.option.timestep, scene.option.integrator = 0.01, mujoco.mjtIntegrator.mjINT_EULER
    scene.option.iterations, scene.option.gravity = 20, [0.0, 0.0, 0.0]  # the pusher's: no attach conflict
    for prefix, y in (("left/", -0.5), ("right/", 0.5)):
        frame = scene.worldbody.add_frame(pos=[0, y, 0])
        frame.attach_body(_pusher().body("r_shoulder_pan_link"), prefix, "")
    before = scene.compile()
    c = mjflex.make_compliant(scene, "left/" + BODY, K=K, **FRAME)
    model = scene.compile()
    assert _quiet(model).names == (f"left/{BODY}_compliance",) and model.nq == before.nq + 7
    mjflex.make_rigid(scene, c)
    after = scene.compile()
    assert (after.nq, after.nv, after.nbody, after.nsite, after.ntext, after.nexclude) == (
        before.nq, before.nv, before.nbody, before.nsite, before.ntext, before.nexclude,
    )  # fmt: skip
    d0, d1 = mujoco.MjData(before), mujoco.MjData(after)
    mujoco.mj_kinematics(before, d0)
    mujoco.mj_kinematics(after, d1)
    np.testing.assert_array_equal(d1.xpos, d0.xpos)

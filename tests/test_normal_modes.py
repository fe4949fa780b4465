"""mjflex.normal_modes at the top level: at a keyframe or a given state, with the actuators' and gravity's stiffness."""

import mujoco
import numpy as np
import pytest
import scipy.linalg

import mjflex
from tests.robots import ARM_JOINTS, arm_spec


def _full_inertia(model, keyframe):
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, keyframe)
    mujoco.mj_fwdPosition(model, data)
    M = np.zeros((model.nv, model.nv))
    mujoco.mj_fullM(model, data, M)
    return M


@pytest.mark.parametrize("keyframe", ["home", "up"])
def test_servo_held_arm_modes_at_a_keyframe(keyframe):
    """The rigid arm held by its position servos: K = diag(kp) (plus the joint springs if asked), M at the keyframe."""
    model = arm_spec().compile()
    kp = model.actuator_gainprm[:, 0]
    M = _full_inertia(model, mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, keyframe))
    freq, modes = mjflex.normal_modes(model, None, keyframe=keyframe, actuator_stiffness=True)
    lam = scipy.linalg.eigh(np.diag(kp), M, eigvals_only=True)
    np.testing.assert_allclose(freq, np.sqrt(lam) / (2 * np.pi), rtol=1e-6)
    np.testing.assert_allclose(modes.T @ M @ modes, np.eye(model.nv), atol=1e-9)
    springs, _ = mjflex.normal_modes(model, None, keyframe=keyframe, actuator_stiffness=True, joint_springs=True)
    lam = scipy.linalg.eigh(np.diag(kp + model.jnt_stiffness), M, eigvals_only=True)
    np.testing.assert_allclose(springs, np.sqrt(lam) / (2 * np.pi), rtol=1e-6)
    idle, _ = mjflex.normal_modes(model, None, keyframe=keyframe)  # nothing holds the joints: free modes
    np.testing.assert_allclose(idle, 0.0, atol=1e-6)


def test_keyframe_and_qpos_agree_and_differ_from_qpos0():
    model = arm_spec().compile()
    at_key, _ = mjflex.normal_modes(model, None, keyframe=0, actuator_stiffness=True)
    at_qpos, _ = mjflex.normal_modes(model, None, qpos=model.key_qpos[0], keyframe=0, actuator_stiffness=True)
    at_zero, _ = mjflex.normal_modes(model, None, actuator_stiffness=True)
    np.testing.assert_array_equal(at_key, at_qpos)
    assert np.abs(at_key - at_zero).max() > 1e-2 * at_key.max()  # the arm's inertia changes with its pose


def test_gravity_stiffness_gives_a_pendulum_its_frequency():
    spec = mujoco.MjSpec()
    body = spec.worldbody.add_body(name="bob", pos=[0, 0, -0.5])
    body.add_joint(name="swing", axis=[0, 1, 0], pos=[0, 0, 0.5])
    body.add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[0.05, 0, 0], mass=2.0)
    model = spec.compile()
    freq, _ = mjflex.normal_modes(model, None, gravity=True)
    m, r, L, g = 2.0, 0.05, 0.5, 9.81
    expected = np.sqrt(m * g * L / (m * L**2 + 0.4 * m * r**2)) / (2 * np.pi)
    assert freq[0] == pytest.approx(expected, rel=1e-6)
    assert mjflex.normal_modes(model, None)[0][0] == pytest.approx(0.0, abs=1e-6)


def test_the_old_import_path_and_bad_keyframes():
    from mjflex.analysis.linearize import normal_modes

    assert normal_modes is mjflex.normal_modes
    model = arm_spec().compile()
    with pytest.raises(ValueError, match=r"keyframe 'hom' is not in the model \(its keyframes: \['home', 'up'\]\)"):
        mjflex.normal_modes(model, None, keyframe="hom")
    with pytest.raises(ValueError, match="qpos must be 3 finite numbers"):
        mjflex.normal_modes(model, None, qpos=[0.0, np.nan, 0.0])
    assert len(ARM_JOINTS) == model.nv

"""Model building with MjSpec: placement helpers, stiffness given elsewhere, free-text names."""

import mujoco
import numpy as np
import pytest

import mjflex
from tests.helpers import random_rotation, random_spd


def _two_bodies():
    spec = mujoco.MjSpec()
    spec.option.gravity = [0, 0, 0]
    for name, pos, quat in (("A", [0.1, 0.2, 0.3], [0.9, 0.1, 0.3, -0.2]), ("B", [0.3, 0.1, 0.2], [1, 0, 0, 0])):
        body = spec.worldbody.add_body(name=name, pos=pos, quat=quat)
        body.add_freejoint()
        body.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.05, 0.02, 0.01], density=1000)
    return spec


def _site_pose(model, data, name):
    i = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, name)
    return data.site_xpos[i].copy(), data.site_xmat[i].reshape(3, 3).copy()


def test_sites_are_placed_at_the_world_pose():
    spec = _two_bodies()
    q = np.array([0.7, 0.2, -0.5, 0.3])
    mjflex.add_flexure(spec, "e", "A", "B", pos=[0.2, 0.15, 0.25], quat=q, K=np.ones(6))
    model = spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    R = np.empty(9)
    mujoco.mju_quat2Mat(R, q / np.linalg.norm(q))
    for s in ("e/a", "e/b"):
        p, Rs = _site_pose(model, data, s)
        assert np.allclose(p, [0.2, 0.15, 0.25], atol=1e-15) and np.allclose(Rs, R.reshape(3, 3), atol=1e-15)


def test_flexure_given_in_body_a_frame():
    spec = _two_bodies()
    mjflex.add_flexure_in_body_frame(spec, "e", "A", "B", pos=[0.05, 0.0, 0.0], quat=[0, 0, 0, 1], K=np.ones(6))
    model = spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    R_WA = data.xmat[1].reshape(3, 3)
    p, R = _site_pose(model, data, "e/a")
    assert np.allclose(p, data.xpos[1] + R_WA @ [0.05, 0, 0], atol=1e-15)
    assert np.allclose(R, R_WA @ np.diag([-1.0, -1.0, 1.0]), atol=1e-15)  # quat (0,0,0,1): half turn about z
    assert np.allclose(_site_pose(model, data, "e/b")[0], p, atol=1e-15)


def test_stiffness_given_at_another_frame_is_moved_by_the_adjoint():
    rng = np.random.default_rng(0)
    K_F, B_F = random_spd(rng), random_spd(rng)
    R_WF = random_rotation(rng)
    q_F = np.empty(4)
    mujoco.mju_mat2Quat(q_F, R_WF.ravel())
    p_WF, p_WE = np.array([0.25, 0.1, 0.2]), np.array([0.2, 0.15, 0.25])
    spec = _two_bodies()
    mjflex.add_flexure(spec, "e", "A", "B", pos=p_WE, K=K_F, B=B_F, stiffness_frame=(p_WF, q_F))
    record = mjflex.Flexures(spec.compile()).records[0]
    expected = mjflex.stiffness_in_frame(K_F, R_WF.T, R_WF.T @ (p_WE - p_WF))  # element frame: R_WE = I
    assert np.allclose(record.K, expected, rtol=1e-12, atol=1e-12 * np.abs(K_F).max())
    # the same elastic energy for the same small displacement seen from either frame
    d_E = 1e-3 * rng.normal(size=6)
    Ad = mjflex.adjoint_from_transform(R_WF.T, R_WF.T @ (p_WE - p_WF))
    assert np.isclose(d_E @ record.K @ d_E, (Ad @ d_E) @ K_F @ (Ad @ d_E), rtol=1e-12)


@pytest.mark.parametrize("name", ["leg 1/hinge «A»", "50% notch", 'quote"d', "a/b/c"])
def test_element_names_are_free_text(tmp_path, name):
    spec = _two_bodies()
    mjflex.add_flexure(spec, name, "A", "B", pos=[0.2, 0.15, 0.25], K=np.ones(6), B=0.01 * np.ones(6))
    path = tmp_path / "m.xml"
    path.write_text(spec.to_xml())
    model = mujoco.MjModel.from_xml_path(str(path))
    flex = mjflex.Flexures(model)
    assert flex.names == (name,)
    model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_AUTORESET
    data = mujoco.MjData(model)
    data.qvel[0] = np.nan
    with flex, pytest.raises(mujoco.FatalError) as err:
        mujoco.mj_forward(model, data)
    assert f"flexure '{name}'" in str(err.value)  # '%' reaches the message unharmed


def test_builders_compile_while_a_python_passive_callback_is_installed():
    """MuJoCo refuses to compile while a Python mjcb_passive is installed: the builders take it off for the
    compilation (add_flexure through build.compile_spec, the variants through variant.compile_spec) and put it back."""

    def user_callback(m, d):
        pass

    spec = _two_bodies()
    mujoco.set_mjcb_passive(user_callback)
    try:
        mjflex.add_flexure(spec, "e", "A", "B", pos=[0.2, 0.15, 0.25], K=np.ones(6))
        variant = mjflex.weld_variant(spec)
        assert mujoco.get_mjcb_passive() is user_callback
    finally:
        mujoco.set_mjcb_passive(None)
    assert variant.model.neq == 1

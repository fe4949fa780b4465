"""Generalized forces on jointed bodies: MuJoCo's native joint springs and mj_applyFT as references.

Tolerances: identities that hold exactly in exact arithmetic (invariances, planar = spatial,
adjoint symmetries, native = mjflex) are checked to 1e-11 ... 1e-14 relative, while 1e-15 ... 1e-17
is achieved (measured). The margin covers round-off on other platforms (fused multiply-add,
numba's ``fastmath={"contract"}``, other libm/BLAS) and stays far below any modelling error,
which shows at 1e-6 and above. Tolerances that bound a truncation error say so where they are used.
"""

import mujoco
import numpy as np
import pytest

import mjflex
from tests.models import B_DEMO, K_DEMO, applied_wrenches_reference, hinge_chain_spec, perturb_joints

AXIS = np.array([0.36, 0.48, 0.8])  # unit hinge / slide axis


def _joint_model(jtype, with_flexure, k=2.5, c=0.04, method="twist"):
    """One body on a hinge or slide joint: native stiffness/damping, or an aligned diagonal flexure."""
    spec = mujoco.MjSpec()
    spec.option.gravity = [0, 0, 0]
    body = spec.worldbody.add_body(name="body", pos=[0.1, -0.2, 0.3], quat=[0.9, 0.2, 0.1, -0.3])
    joint = body.add_joint(type=jtype, axis=AXIS, pos=[0.02, 0.01, -0.03])
    body.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.05, 0.02, 0.01], density=1000)
    if not with_flexure:
        joint.stiffness, joint.damping = [k, 0, 0], [c, 0, 0]
        return spec.compile()
    # element frame at the joint anchor, its x axis along the joint axis (in world coordinates)
    m0 = spec.compile()
    d0 = mujoco.MjData(m0)
    mujoco.mj_kinematics(m0, d0)
    anchor, axis = d0.xanchor[0], d0.xaxis[0]
    x = axis / np.linalg.norm(axis)
    y = np.cross(x, [0.0, 0.0, 1.0])
    y /= np.linalg.norm(y)
    R = np.column_stack([x, y, np.cross(x, y)])
    q = np.empty(4)
    mujoco.mju_mat2Quat(q, R.ravel())
    i = 0 if jtype == mujoco.mjtJoint.mjJNT_HINGE else 3
    K, B = np.zeros(6), np.zeros(6)
    K[i], B[i] = k, c
    mjflex.add_flexure(spec, "spring", "world", "body", pos=anchor, quat=q, K=K, B=B, method=method)
    return spec.compile()


@pytest.mark.parametrize("jtype", [mujoco.mjtJoint.mjJNT_HINGE, mujoco.mjtJoint.mjJNT_SLIDE])
@pytest.mark.parametrize("q", [1e-3, 0.3, 2.5])
def test_aligned_twist_flexure_reproduces_native_joint_spring(jtype, q):
    """Rotation about (translation along) a fixed axis: the twist element is exactly -k q - c qdot."""
    native = _joint_model(jtype, False)
    ours = _joint_model(jtype, True)
    flex = mjflex.Flexures(ours)
    dn, do = mujoco.MjData(native), mujoco.MjData(ours)
    for d in (dn, do):
        d.qpos[0], d.qvel[0] = q, -0.7
    with flex:
        mujoco.mj_forward(ours, do)
    mujoco.mj_forward(native, dn)
    assert do.qfrc_passive[0] == pytest.approx(dn.qfrc_passive[0], rel=1e-12)


@pytest.mark.parametrize("jtype", [mujoco.mjtJoint.mjJNT_HINGE, mujoco.mjtJoint.mjJNT_SLIDE])
def test_aligned_dualquat_flexure_matches_native_for_small_motion(jtype):
    native = _joint_model(jtype, False)
    ours = _joint_model(jtype, True, method="dualquat")
    flex = mjflex.Flexures(ours)
    for q in (1e-2, 1e-3):
        dn, do = mujoco.MjData(native), mujoco.MjData(ours)
        for d in (dn, do):
            d.qpos[0], d.qvel[0] = q, -0.7 * q
        mujoco.mj_forward(native, dn)
        do.qfrc_passive[:] = 0
        mujoco.mj_forward(ours, do)
        got = flex.generalized_forces(do)[0]
        # rotation: -k sin(q) vs -k q (relative q^2/6); translation is exact
        assert got == pytest.approx(dn.qfrc_passive[0], rel=q**2)


@pytest.mark.parametrize("method", ["twist", "dualquat"])
def test_chain_generalized_forces_equal_mj_applyFT(method):
    model = hinge_chain_spec(n=5, B=B_DEMO, method=method).compile()
    data = mujoco.MjData(model)
    perturb_joints(model, data, np.random.default_rng(0))
    flex = mjflex.Flexures(model)
    expected = applied_wrenches_reference(model, data, flex)
    got = flex.generalized_forces(data)
    assert np.abs(expected).max() > 0
    assert np.linalg.norm(got - expected) <= 1e-12 * np.linalg.norm(expected)
    # and the callback adds exactly these to qfrc_passive
    mujoco.mj_forward(model, data)
    before = data.qfrc_passive.copy()
    with flex:
        mujoco.mj_forward(model, data)
    assert np.linalg.norm(data.qfrc_passive - before - got) <= 1e-12 * np.linalg.norm(got)


def test_free_body_fast_path_equals_mj_applyFT():
    spec = mujoco.MjSpec()
    spec.option.gravity = [0, 0, 0]
    for name, pos in (("A", [0, 0, 1]), ("B", [0.1, 0, 1])):
        b = spec.worldbody.add_body(name=name, pos=pos, quat=[0.7, 0.1, 0.7, 0.1])
        b.add_freejoint()
        b.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.05, 0.02, 0.01], pos=[0.01, 0.02, 0.0], density=1000)
    mjflex.add_flexure(spec, "e", "A", "B", pos=[0.05, 0.01, 1.0], K=K_DEMO, B=B_DEMO)
    model = spec.compile()
    data = mujoco.MjData(model)
    rng = np.random.default_rng(3)
    data.qpos[0:3] += 0.05 * rng.normal(size=3)
    data.qvel[:] = rng.normal(size=12)
    mujoco.mj_forward(model, data)
    flex = mjflex.Flexures(model)
    free = flex._elements[0][["free_a", "free_b"]].tolist()
    assert list(free) == [0, 6]  # both bodies take the free-joint fast path
    W = flex.wrenches(data)[0]
    expected = np.zeros(model.nv)
    point = data.site_xpos[1]
    mujoco.mj_applyFT(model, data, W[3:], W[:3], point, 2, expected)
    mujoco.mj_applyFT(model, data, -W[3:], -W[:3], point, 1, expected)
    got = flex.generalized_forces(data)
    assert np.linalg.norm(got - expected) <= 1e-12 * np.linalg.norm(expected)


@pytest.mark.parametrize("method", ["twist", "dualquat"])
def test_planar_element_in_planar_scene(method):
    """A 3x3 element between bodies on (slide x, slide y, hinge z) equals the core planar wrench."""
    spec = mujoco.MjSpec()
    spec.option.gravity = [0, 0, 0]
    for name, x in (("A", 0.0), ("B", 0.2)):
        b = spec.worldbody.add_body(name=name, pos=[x, 0.0, 0.0])
        for jtype, axis in ((mujoco.mjtJoint.mjJNT_SLIDE, [1, 0, 0]), (mujoco.mjtJoint.mjJNT_SLIDE, [0, 1, 0]),
                            (mujoco.mjtJoint.mjJNT_HINGE, [0, 0, 1])):  # fmt: skip
            b.add_joint(type=jtype, axis=axis)
        b.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.08, 0.02, 0.01], density=1000)
    K3 = np.array([[0.8, 0.1, -0.2], [0.1, 300.0, 20.0], [-0.2, 20.0, 500.0]])
    B3 = 0.01 * K3
    mjflex.add_flexure(spec, "p", "A", "B", pos=[0.1, 0.0, 0.0], K=K3, B=B3, method=method)
    model = spec.compile()
    data = mujoco.MjData(model)
    data.qpos[:] = [0.01, -0.02, 0.3, 0.05, 0.03, 2.0]
    data.qvel[:] = [0.1, 0.2, -1.0, 0.3, -0.1, 2.0]
    mujoco.mj_forward(model, data)
    flex = mjflex.Flexures(model)
    W6 = flex.wrenches(data)[0]
    th_a, th_b = data.qpos[2], data.qpos[5]
    p_a = data.site_xpos[0, :2]
    p_b = data.site_xpos[1, :2]
    v_a = data.qvel[0:2] + data.qvel[2] * np.array([-(p_a[1] - data.qpos[1]), p_a[0] - 0.0 - data.qpos[0]])
    v_b = data.qvel[3:5] + data.qvel[5] * np.array([-(p_b[1] - data.qpos[4]), p_b[0] - 0.2 - data.qpos[3]])
    W3 = mjflex.planar_wrench_on_b(th_a, p_a, th_b, p_b, K3, method=method, B=B3,
                                   w_WA=data.qvel[2], v_WA=v_a, w_WB=data.qvel[5], v_WB=v_b)  # fmt: skip
    assert np.linalg.norm(W6[[2, 3, 4]] - W3) <= 1e-12 * np.linalg.norm(W3)
    assert np.abs(W6[[0, 1, 5]]).max() <= 1e-12 * np.linalg.norm(W3)

"""mjflex.reduce: cheaper models that keep the low modes, their state maps and their dynamics."""

import itertools

import mujoco
import numpy as np
import pytest

import mjflex
from mjflex.app.scenes import cantilever_spec, parallelogram_spec
from mjflex.mj._planar import in_plane_modes
from mjflex.mj.linearize import normal_modes
from mjflex.mj.variant import equality_rows
from tests.models import two_body_spec


def _elastic(freq):
    return freq[freq > 1e-2]


@pytest.fixture(scope="module")
def parallelogram():
    spec = parallelogram_spec()
    return spec, spec.compile(), mjflex.reduce(spec, 100.0)


def test_parallelogram_becomes_one_hinge_mechanism_with_the_same_guide_frequency(parallelogram):
    _, full, variant = parallelogram
    f_full, _ = normal_modes(full, mjflex.Flexures(full))
    f_red, _ = normal_modes(variant.model, mjflex.Flexures(variant.model), joint_springs=True, constraints="project")
    # The notches' five stiff directions, held rigid, raise the guide mode by their compliance in series
    # (~0.1 % here); reduce() promises freq_tol = 1 %.
    assert _elastic(f_red)[0] == pytest.approx(_elastic(f_full)[0], rel=0.01)
    assert variant.model.nv == 3  # three hinges (rod1, platform, rod2); the fourth closes the loop
    assert variant.details["loops"] == "constraint" and variant.details["loop_closers"] == ["notch2_top"]
    assert all(e["soft"] == ["rz"] for e in variant.details["elements"].values())
    assert variant.details["modes"]["max_relative_error"] < 0.01
    assert "two connect constraints" in variant.report


def test_parallelogram_dynamics_follow_the_full_model(parallelogram):
    _, full, variant = parallelogram
    traj = []
    for model in (full, variant.model):
        data = mujoco.MjData(model)
        mujoco.mj_resetDataKeyframe(model, data, 0)
        x = []
        with mjflex.Flexures(model):
            for _ in range(3000):  # 30 ms, about one period of the 36.5 Hz guide mode
                mujoco.mj_step(model, data)
                x.append(data.xpos[model.body("platform").id, 0])
        traj.append(np.array(x) - x[0])
    amplitude = np.abs(traj[0]).max()
    # The kick also rings the full model's stiff directions (kHz, a few % of the amplitude); the reduced
    # model has none of them, so the trajectories agree to a few % of the stroke, not to round-off.
    assert np.abs(traj[1] - traj[0]).max() < 0.05 * amplitude


def test_state_from_recovers_a_state_the_variant_can_represent(parallelogram):
    _, full, variant = parallelogram
    m = variant.model
    rng = np.random.default_rng(3)
    dv = mujoco.MjData(m)
    # a state of the mechanism (loop closed): move the hinges along the null space of the loop constraint
    dv.qpos[:] = m.qpos0
    _, G = equality_rows(m, dv)
    null = np.linalg.svd(G)[2][np.linalg.matrix_rank(G) :].T
    mujoco.mj_integratePos(m, dv.qpos, null @ (0.02 * rng.normal(size=null.shape[1])), 1.0)
    for _ in range(20):  # close the loop exactly (Gauss-Newton on the constraint residual)
        e, G = equality_rows(m, dv)
        mujoco.mj_integratePos(m, dv.qpos, np.linalg.lstsq(G, -e, rcond=None)[0], 1.0)
    _, G = equality_rows(m, dv)
    null = np.linalg.svd(G)[2][np.linalg.matrix_rank(G) :].T
    dv.qvel[:] = null @ rng.normal(size=null.shape[1])
    mujoco.mj_forward(m, dv)
    # the same poses and velocities written into the source's free joints
    ds = mujoco.MjData(full)
    for name in ("rod1", "rod2", "platform"):
        j = full.body(name).jntadr[0]
        qa, va = full.jnt_qposadr[j], full.jnt_dofadr[j]
        b = m.body(name).id
        ds.qpos[qa : qa + 3], ds.qpos[qa + 3 : qa + 7] = dv.xpos[b], dv.xquat[b]
        vel = np.zeros(6)
        mujoco.mj_objectVelocity(m, dv, mujoco.mjtObj.mjOBJ_BODY, b, vel, 1)  # local frame, at the body origin
        ds.qvel[va : va + 3] = dv.xmat[b].reshape(3, 3) @ vel[3:]
        ds.qvel[va + 3 : va + 6] = vel[:3]
    mujoco.mj_forward(full, ds)
    qpos, qvel = variant.state_from(full, ds)
    assert variant.state_from.last_residual < 1e-10
    np.testing.assert_allclose(qpos, dv.qpos, atol=1e-10)
    np.testing.assert_allclose(qvel, dv.qvel, rtol=1e-8, atol=1e-10 * np.abs(dv.qvel).max())


def test_body_map_covers_every_source_body_and_keyframes_carry_over(parallelogram):
    _, full, variant = parallelogram
    names = {full.body(i).name for i in range(1, full.nbody)}
    assert set(variant.body_map) == names
    assert all(np.array_equal(X, np.eye(4)) for _, X in variant.body_map.values())
    assert variant.model.nkey == 1 and variant.model.key("push").id == 0
    d = mujoco.MjData(variant.model)
    mujoco.mj_resetDataKeyframe(variant.model, d, 0)
    mujoco.mj_forward(variant.model, d)
    vel = np.zeros(6)
    mujoco.mj_objectVelocity(variant.model, d, mujoco.mjtObj.mjOBJ_XBODY, variant.model.body("platform").id, vel, 0)
    # The push moves the platform at 0.05 m/s; the reduced state carries the momentum its one mode can take
    assert 0.02 < vel[3] < 0.05


def test_cantilever_keeps_its_first_modes_and_drops_the_stiff_ones():
    spec = cantilever_spec(n=4)
    full = spec.compile()
    variant = mjflex.reduce(spec, 3000.0)
    f_full = _elastic(normal_modes(full, mjflex.Flexures(full))[0])
    f_red = _elastic(normal_modes(variant.model, mjflex.Flexures(variant.model) if variant.has_flexures else None,
                                  joint_springs=True)[0])  # fmt: skip
    kept = f_full[f_full < 3000.0]
    assert len(kept) >= 3
    np.testing.assert_allclose(f_red[: len(kept)], kept, rtol=0.01)  # the promised freq_tol
    assert f_red.max() < f_full.max()  # stiff directions held rigid: the highest mode drops
    assert variant.model.nv < full.nv


def test_planar_scene_becomes_a_planar_model():
    spec = cantilever_spec(n=4)
    full = spec.compile()
    variant = mjflex.reduce(spec, 3000.0, plane="auto", scene=("kick", 1e-3))
    m = variant.model
    assert variant.details["plane"] == pytest.approx([0.0, 0.0, 1.0])
    joints = [m.jnt_type[j] for j in range(m.njnt)]
    assert mujoco.mjtJoint.mjJNT_FREE not in joints and mujoco.mjtJoint.mjJNT_BALL not in joints
    d = mujoco.MjData(m)
    mujoco.mj_kinematics(m, d)
    mujoco.mj_comPos(m, d)
    for b in range(1, m.nbody):  # every joint moves the bodies in the x-y plane only
        jacp, jacr = np.zeros((3, m.nv)), np.zeros((3, m.nv))
        mujoco.mj_jacBody(m, d, jacp, jacr, b)
        assert np.abs(jacp[2]).max() < 1e-12 and np.abs(jacr[:2]).max() < 1e-12
    f_full, modes = normal_modes(full, mjflex.Flexures(full))
    in_plane = f_full[(f_full > 1e-2) & (f_full < 3000.0) & in_plane_modes(full, modes, np.array([0, 0, 1.0]))]
    f_red = _elastic(normal_modes(m, None, joint_springs=True)[0])
    assert len(in_plane) == 3 and len(in_plane) < len(_elastic(f_full[f_full < 3000.0]))  # out-of-plane ones go
    np.testing.assert_allclose(f_red[:3], in_plane, rtol=0.01)


def test_plane_checks_say_what_is_not_planar():
    with pytest.raises(ValueError, match="couples in-plane and out-of-plane"):
        mjflex.reduce(two_body_spec(), 100.0, plane=[0.0, 0.0, 1.0])
    spec = parallelogram_spec()
    with pytest.raises(ValueError, match="gravity"):
        tilted = spec.copy()
        tilted.option.gravity = [0.0, 0.0, -9.81]
        mjflex.reduce(tilted, 100.0, plane=[0.0, 0.0, 1.0])
    kick = (_out_of_plane_kick(), 1e-4)
    variant = mjflex.reduce(cantilever_spec(n=3), 3000.0, plane="auto", verify=False, scene=kick)
    assert "not planar (the scene's initial velocities leave the plane)" in variant.report
    assert variant.details["plane"] is None


def _out_of_plane_kick():
    model = cantilever_spec(n=3).compile()
    qvel = np.zeros(model.nv)
    qvel[model.jnt_dofadr[model.body("link3").jntadr[0]] + 2] = 0.1  # the tip moves along z
    return model.qpos0.copy(), qvel


def test_rigid_band_merges_everything_and_damping_goes_where_negligible():
    spec = two_body_spec(B=1e-7 * np.eye(6))
    variant = mjflex.reduce(spec, 1e-3)  # below every elastic mode: nothing to resolve
    assert variant.model.nv == 6  # one free rigid body left (B nested in A without joints)
    assert variant.details["elements"]["link"]["soft"] == []
    assert "rigid, bodies merged" in variant.report
    assert variant.body_map["B"][0] == "B" and variant.model.body("B").jntnum[0] == 0
    damped = mjflex.reduce(two_body_spec(B=np.diag([1e-3, 1e-3, 1e-3, 1.0, 1.0, 1.0])), 1e4, verify=False)
    light = mjflex.reduce(two_body_spec(B=1e-9 * np.eye(6)), 1e4, verify=False)
    assert not damped.details["elements"]["link"]["damping_dropped"]
    assert light.details["elements"]["link"]["damping_dropped"]


def test_bad_input_is_named():
    spec = parallelogram_spec()
    with pytest.raises(ValueError, match="keep_below_hz"):
        mjflex.reduce(spec, 0.0)
    with pytest.raises(ValueError, match="loops"):
        mjflex.reduce(spec, 100.0, loops="weld")
    bare = mujoco.MjSpec()
    bare.worldbody.add_body(name="b").add_geom(size=[0.1, 0, 0])
    with pytest.raises(ValueError, match="no mjflex elements"):
        mjflex.reduce(bare, 100.0)
    with pytest.raises(ValueError, match="keyframe"):
        mjflex.reduce(spec, 100.0, scene=("nope", 0.01))
    other = two_body_spec().compile()  # compiled from a spec, not the XML MuJoCo loaded last
    mujoco.MjModel.from_xml_path("models/two_body.xml")
    with pytest.raises(TypeError, match="MJCF path or the MjSpec"):
        mjflex.reduce(other, 100.0)


def test_a_looser_frequency_tolerance_never_keeps_more_on_arcade():
    # ARCADE at 200 Hz kept nv 85 with freq_tol = 5 % but nv 63 with 1 %: its leaf springs, three joints each at 5 %
    # (kept whole at 1 %), went into the trees and pushed one-joint hinges out to close loops. A looser tolerance
    # must hold at least the directions a tighter one holds, keep at most its elements, and leave at most its dofs.
    tolerances = (0.005, 0.01, 0.02, 0.05, 0.1)
    runs = [mjflex.reduce("models/arcade.xml", 200.0, freq_tol=tol, verify=False).details for tol in tolerances]
    nv = [d["nv"] for d in runs]
    assert all(a >= b for a, b in itertools.pairwise(nv)), dict(zip(tolerances, nv, strict=True))
    assert nv[0] > nv[-1]  # the tolerance matters here: otherwise the check above would be empty
    for tight, loose in itertools.pairwise(runs):
        for name, e in loose["elements"].items():
            assert set(e["soft"]) <= set(tight["elements"][name]["soft"]), name
            assert not e["kept"] or tight["elements"][name]["kept"], name
    for d, tol in zip(runs, tolerances, strict=True):
        assert d["predicted_error"] <= tol

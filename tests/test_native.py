"""MuJoCo-native alternatives of a flexure model: matched welds, pseudo-rigid-body joints, 6-joint bushings."""

import mujoco
import numpy as np
import pytest

import mjflex
from mjflex.analysis.linearize import normal_modes, stiffness_matrix
from mjflex.app.scenes import BUSHING_K, Beam, bushing_spec, cantilever_spec, parallelogram_spec
from mjflex.variants.alternatives import weld_targets
from tests.models import hinge_chain_spec

# free-joint qvel is [v (world); omega (body)]; the element twist is [omega; v]
SWAP = np.r_[3, 4, 5, 0, 1, 2]


def _elastic(freq):
    return freq[freq > 1e-2]


@pytest.mark.parametrize("match", ["compliant", "mean", "stiff"])
def test_matched_weld_has_the_stiffness_it_claims(match):
    """The weld's generalized stiffness at rest is k_r I (rotation) and k_t I (translation) about the element.

    The block's frame is the element frame, so the free joint's coordinates are the element's
    twist up to the order of its blocks. Tolerance 1e-3: the spring law is exact up to the
    impedance d = 1e-4 (the solver absorbs that fraction of the unconstrained acceleration) and
    the 1e-6 finite-difference step.
    """
    spec = bushing_spec()
    variant = mjflex.weld_variant(spec, match=match)
    K = stiffness_matrix(variant.model, None, constraints="spring")[np.ix_(SWAP, SWAP)]
    rec = mjflex.Flexures(spec.compile()).records[0]
    k_t, k_r, _ = weld_targets(rec, match)
    np.testing.assert_allclose(np.diag(K), [k_r] * 3 + [k_t] * 3, rtol=1e-3)
    off = K - np.diag(np.diag(K))
    assert np.abs(off).max() < 1e-3 * k_r
    eig_r, eig_t = np.linalg.eigvalsh(BUSHING_K[:3, :3]), np.linalg.eigvalsh(BUSHING_K[3:, 3:])
    pick = {"compliant": 0, "stiff": -1}
    expected = (eig_t.mean(), eig_r.mean()) if match == "mean" else (eig_t[pick[match]], eig_r[pick[match]])
    assert (k_t, k_r) == pytest.approx(expected, rel=1e-12)
    assert "anisotropy and coupling are lost" in variant.report


def test_rigid_weld_uses_the_step_dependent_time_constant_and_keeps_every_body():
    spec = parallelogram_spec()
    variant = mjflex.weld_variant(spec, match="rigid")
    m = variant.model
    assert m.neq == 4 and not variant.has_flexures
    np.testing.assert_allclose(m.eq_solref, [[2 * m.opt.timestep, 1.0]] * 4)
    assert set(variant.body_map) == {"rod1", "rod2", "platform"}


def test_pseudo_rigid_body_parallelogram_closes_its_loop_with_an_exact_tendon_spring():
    spec = parallelogram_spec()
    full = spec.compile()
    variant = mjflex.pseudo_rigid_body_variant(spec)
    m = variant.model
    assert m.nv == 3 and m.ntendon == 1 and m.neq == 2 and not variant.has_flexures
    # a planar loop's closing rotation is the signed sum of the other hinge angles: coefficients +-1
    np.testing.assert_allclose(np.abs(m.wrap_prm[m.tendon_adr[0] : m.tendon_adr[0] + m.tendon_num[0]]), 1.0, atol=1e-12)
    assert m.tendon_stiffness[0] == pytest.approx(mjflex.Flexures(full).records[0].K[2, 2], rel=1e-12)
    f_full = _elastic(normal_modes(full, mjflex.Flexures(full))[0])
    f_prb = _elastic(normal_modes(m, None, joint_springs=True, constraints="project")[0])
    assert len(f_prb) == 1
    assert f_prb[0] == pytest.approx(f_full[0], rel=0.01)  # the notches' stiff directions add ~0.1 % in series


def test_pseudo_rigid_body_cantilever_matches_the_midpoint_rule_of_beam_theory():
    """Hinges of stiffness EI/l at the segment centres: tip compliance l sum (L - x_k)^2 / EI exactly."""
    beam, n = Beam(), 4
    variant = mjflex.pseudo_rigid_body_variant(cantilever_spec(beam, n))
    m = variant.model
    K = stiffness_matrix(m, None, joint_springs=True)
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    jacp = np.zeros((3, m.nv))
    mujoco.mj_jacSite(m, d, jacp, None, m.site("tip").id)
    compliance = jacp[1] @ np.linalg.solve(K, jacp[1])
    seg = beam.L / n
    x = (np.arange(n) + 0.5) * seg
    K_rot = mjflex.geometry.leaf_spring_stiffness(seg, beam.t, beam.b, beam.E, beam.nu, method="beam", wide=False)[2, 2]
    assert compliance == pytest.approx(np.sum((beam.L - x) ** 2) / K_rot, rel=1e-6)
    # and, as the midpoint rule misses l^3/12 per segment and the shear, it is stiffer than the beam
    assert compliance < beam.tip_deflection(1.0)


def test_bushing_variant_is_exact_for_small_motion_when_k_is_diagonal():
    spec = cantilever_spec(n=3)
    full = spec.compile()
    variant = mjflex.bushing_variant(spec)
    assert variant.model.nv == full.nv and not variant.has_flexures
    f_full = normal_modes(full, mjflex.Flexures(full))[0]
    f_bush = normal_modes(variant.model, None, joint_springs=True)[0]
    np.testing.assert_allclose(f_bush, f_full, rtol=1e-6)  # finite-difference linearization of both


def test_bushing_variant_drops_coupling_and_says_so():
    variant = mjflex.bushing_variant(bushing_spec())
    assert "couplings dropped (largest normalized off-diagonal stiffness): bushing" in variant.report
    K = stiffness_matrix(variant.model, None, joint_springs=True)
    assert np.abs(K - np.diag(np.diag(K))).max() < 1e-6 * np.abs(K).max()  # six independent joint springs


def test_state_from_maps_the_launch_of_the_bushing_block_onto_the_joints():
    spec = bushing_spec()
    full = spec.compile()
    d = mujoco.MjData(full)
    mujoco.mj_resetDataKeyframe(full, d, 0)
    mujoco.mj_forward(full, d)
    for builder in (mjflex.bushing_variant, mjflex.weld_variant):
        variant = builder(spec)
        qpos, qvel = variant.state_from(full, d)
        dv = mujoco.MjData(variant.model)
        dv.qpos[:], dv.qvel[:] = qpos, qvel
        mujoco.mj_forward(variant.model, dv)
        a, b = np.zeros(6), np.zeros(6)
        mujoco.mj_objectVelocity(full, d, mujoco.mjtObj.mjOBJ_BODY, full.body("block").id, a, 0)
        mujoco.mj_objectVelocity(variant.model, dv, mujoco.mjtObj.mjOBJ_BODY, variant.model.body("block").id, b, 0)
        # both can move the block freely at qpos0; 1e-7: the fit's regularization (1e-12 of the largest inertia)
        np.testing.assert_allclose(b, a, rtol=1e-7)


def test_bad_input_is_named():
    with pytest.raises(ValueError, match="match"):
        mjflex.weld_variant(bushing_spec(), match="glue")
    with pytest.raises(ValueError, match="not a free body"):
        mjflex.pseudo_rigid_body_variant(hinge_chain_spec())
    bare = mujoco.MjSpec()
    bare.worldbody.add_body(name="b").add_geom(size=[0.1, 0, 0])
    with pytest.raises(ValueError, match="no mjflex elements"):
        mjflex.bushing_variant(bare)
    with pytest.raises(FileNotFoundError, match="MJCF"):
        mjflex.weld_variant("models/nope.xml")

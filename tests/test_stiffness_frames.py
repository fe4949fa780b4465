"""Adjoint transformation of stiffness (eq. 54) and the centre of stiffness.

Tolerances: identities that hold exactly in exact arithmetic (invariances, planar = spatial,
adjoint symmetries, native = mjflex) are checked to 1e-11 ... 1e-14 relative, while 1e-15 ... 1e-17
is achieved (measured). The margin covers round-off on other platforms (fused multiply-add,
numba's ``fastmath={"contract"}``, other libm/BLAS) and stays far below any modelling error,
which shows at 1e-6 and above. Tolerances that bound a truncation error say so where they are used.
"""

import numpy as np
import pytest

import mjflex
from tests.helpers import hat, random_rotation, random_spd


def test_adjoint_maps_twists_like_rigid_body_velocities():
    rng = np.random.default_rng(0)
    R, p = random_rotation(rng), rng.normal(size=3)
    Ad = mjflex.adjoint_from_transform(R, p)
    w_B, v_B = rng.normal(size=3), rng.normal(size=3)  # velocity of B's origin, B coords
    V_A = Ad @ np.r_[w_B, v_B]
    # independently: angular velocity rotates; velocity of the point at A's origin
    w_A = R @ w_B
    v_A = R @ v_B + np.cross(p, w_A)  # v(o_A) = v(o_B) + w x (o_A - o_B)
    assert np.allclose(V_A, np.r_[w_A, v_A], rtol=1e-14, atol=1e-14)


def test_stiffness_in_frame_preserves_energy_and_composes():
    rng = np.random.default_rng(1)
    K = random_spd(rng)
    R1, p1, R2, p2 = random_rotation(rng), rng.normal(size=3), random_rotation(rng), rng.normal(size=3)
    K1 = mjflex.stiffness_in_frame(K, R1, p1)
    K12 = mjflex.stiffness_in_frame(K1, R2, p2)
    K_direct = mjflex.stiffness_in_frame(K, R1 @ R2, p1 + R1 @ p2)
    assert np.allclose(K12, K_direct, rtol=1e-12, atol=1e-12 * np.abs(K).max())
    d = rng.normal(size=6)
    Ad = mjflex.adjoint_from_transform(R1, p1)
    assert np.isclose(d @ K1 @ d, (Ad @ d) @ K @ (Ad @ d), rtol=1e-13)
    # and back
    back = mjflex.stiffness_in_frame(K1, R1.T, -R1.T @ p1)
    assert np.allclose(back, K, rtol=1e-12, atol=1e-12 * np.abs(K).max())


def test_centre_of_stiffness_makes_coupling_symmetric():
    rng = np.random.default_rng(2)
    for _ in range(20):
        K = random_spd(rng, cond=1e3)
        r = mjflex.centre_of_stiffness(K)
        Kc = mjflex.stiffness_in_frame(K, np.eye(3), r)[:3, 3:]
        # round-off amplified by the condition (up to 1e3 here) of (tr K_t) I - K_t; achieved 2e-16
        assert np.abs(Kc - Kc.T).max() <= 1e-12 * np.abs(K).max()


def test_centre_of_leaf_spring_is_its_midpoint():
    """A cantilever K given at its clamped end has its centre of stiffness at the beam's midpoint."""
    L, kb = 0.01, 2.0
    # stiffness at the midpoint: decoupled (symmetric beam); move it to the end x = -L/2
    K_mid = np.diag([0.5, kb * L**2 / 12 * 10, kb * L**2 / 12, 1e4, 12 * kb, 12 * kb * 10])
    K_end = mjflex.stiffness_in_frame(K_mid, np.eye(3), [L / 2, 0.0, 0.0])
    assert np.abs(K_end[:3, 3:]).max() > 0  # coupled at the end
    r = mjflex.centre_of_stiffness(K_end)
    assert np.allclose(r, [-L / 2, 0, 0], rtol=0, atol=1e-14)


def test_batched_centre():
    """Each centre of a (2, 3) batch, checked with the adjoint written out here: about r, K's coupling is symmetric."""
    rng = np.random.default_rng(3)
    K = np.stack([random_spd(rng, scales=[1, 1, 1, 30, 30, 30]) for _ in range(6)]).reshape(2, 3, 6, 6)
    r = mjflex.centre_of_stiffness(K)
    assert r.shape == (2, 3, 3)
    for idx in np.ndindex(2, 3):
        Ad = np.block([[np.eye(3), np.zeros((3, 3))], [hat(r[idx]), np.eye(3)]])  # twist at r -> twist at origin
        Kc = (Ad.T @ K[idx] @ Ad)[:3, 3:]
        assert np.abs(Kc - Kc.T).max() <= 1e-12 * np.abs(K[idx]).max()
        assert np.abs(K[idx][:3, 3:] - K[idx][3:, :3].T).max() == 0 and np.abs(r[idx]).max() > 1e-3  # not trivial


def test_no_centre_when_translation_is_free_in_a_plane():
    K = np.zeros((6, 6))
    K[:3, :3] = np.eye(3)
    K[5, 5] = 1.0  # only z translation is stiff: K_t has two zero eigenvalues
    K[0, 5] = K[5, 0] = 0.5
    with pytest.raises(ValueError, match=r"no unique centre of stiffness.*two or more zero"):
        mjflex.centre_of_stiffness(K)

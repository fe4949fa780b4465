"""The elastic wrench is minus the gradient of the potential, at every angle (issue: core).

The reference gradient is Ridders' extrapolated central difference of ``mjflex.potential``
under world-frame displacements of body B (``tests.helpers.gradient_wrt_b``), an independent
computation that shares nothing with the wrench code path but the potential itself.

Relative rotations below 1e-6 rad are built on frames A whose rotation is a signed
permutation, so that ``R_WA^T R_WB`` is exact in floating point: with a generic ``R_WA`` the
product itself carries an absolute error of ~1e-16 in each entry, i.e. a relative error of
1e-16/alpha in the relative rotation, which is a property of the input representation, not of
the method (the wrench is then exact for the rotation the inputs actually encode).
"""

import numpy as np
import pytest

import mjflex
from tests.helpers import exact_rotation, gradient_wrt_b, random_rotation, random_spd

RTOL = 1e-7


def _case(seed, angle, trans, huge=False):
    rng = np.random.default_rng(seed)
    K = random_spd(rng, cond=50.0)
    R_ab = random_rotation(rng, angle)
    p_ab = trans * rng.normal(size=3)
    if angle >= 1e-6 and not huge:
        R_WA = random_rotation(rng)
        p_WA = rng.normal(size=3)
    else:
        R_WA = exact_rotation(rng)
        p_WA = rng.integers(-64, 64, size=3) / 64.0
    return R_WA, p_WA, R_WA @ R_ab, p_WA + R_WA @ p_ab, K


def _check(method, R_WA, p_WA, R_WB, p_WB, K, h_rot, h_lin):
    W = mjflex.wrench_on_b(R_WA, p_WA, R_WB, p_WB, K, method=method)
    # the step follows the scale of the displacement: central differences of a function that
    # is ~quadratic in a displacement of size s lose ~eps * s / h relative digits
    size = np.linalg.norm(mjflex.twist_from_transform(R_WA.T @ R_WB, R_WA.T @ (p_WB - p_WA)))
    h_rot, h_lin = min(h_rot, 0.1 * size), min(h_lin, 0.1 * size)

    def energy(R, p):
        return mjflex.potential(R_WA, p_WA, R, p, K, method=method)

    g = gradient_wrt_b(energy, R_WB, p_WB, h_rot, h_lin)
    scale = np.linalg.norm(W)
    assert scale > 0
    err = np.linalg.norm(W + g) / scale
    assert err <= RTOL, f"relative error {err:.3g}: wrench {W} vs -grad {-g}"


ANGLES = np.geomspace(1e-12, np.pi - 1e-6, 41)


@pytest.mark.parametrize("method", ["twist", "dualquat"])
@pytest.mark.parametrize("k", range(len(ANGLES)))
def test_wrench_is_minus_gradient_over_angles(method, k):
    angle = ANGLES[k]
    trans = 0.0 if k % 3 == 0 else 0.3  # every third case is a pure rotation
    R_WA, p_WA, R_WB, p_WB, K = _case(k, angle, trans)
    h_rot = min(1e-3, 0.1 * (np.pi - angle))  # stay on one branch of the twist log
    _check(method, R_WA, p_WA, R_WB, p_WB, K, h_rot, 1e-3)


@pytest.mark.parametrize("angle", [np.pi - 1e-9, np.pi - 1e-12, np.pi])
def test_dualquat_gradient_up_to_half_turn(angle):
    R_WA, p_WA, R_WB, p_WB, K = _case(7, angle, 0.3)
    _check("dualquat", R_WA, p_WA, R_WB, p_WB, K, 1e-3, 1e-3)


@pytest.mark.parametrize("method", ["twist", "dualquat"])
def test_exact_zero_rotation_pure_translation(method):
    rng = np.random.default_rng(3)
    K = random_spd(rng)
    R = random_rotation(rng)
    p_WA = rng.normal(size=3)
    p_WB = p_WA + 0.2 * rng.normal(size=3)
    _check(method, R, p_WA, R, p_WB, K, 1e-3, 1e-3)


@pytest.mark.parametrize("method", ["twist", "dualquat"])
def test_coincident_frames_give_exactly_zero(method):
    rng = np.random.default_rng(4)
    R, p = random_rotation(rng), rng.normal(size=3)
    K = random_spd(rng)
    assert np.all(mjflex.wrench_on_b(R, p, R, p, K, method=method) == 0.0)
    assert mjflex.potential(R, p, R, p, K, method=method) == 0.0


@pytest.mark.parametrize("method", ["twist", "dualquat"])
@pytest.mark.parametrize("angle", [1e-9, 0.0])
def test_huge_translation_tiny_rotation(method, angle):
    R_WA, p_WA, R_WB, p_WB, K = _case(5, max(angle, 1e-300), 0.0, huge=True)
    R_WB = R_WA @ random_rotation(np.random.default_rng(6), angle) if angle else R_WA
    p_WB = p_WA + np.array([1e3, -7e2, 4e2])
    _check(method, R_WA, p_WA, R_WB, p_WB, K, 1e-3, 1e-3)


@pytest.mark.parametrize("method", ["twist", "dualquat"])
def test_physical_units_stiffness(method):
    """Realistic notch-hinge scales: 1 N m/rad in rotation, 1e6 N/m in translation."""
    rng = np.random.default_rng(8)
    K = random_spd(rng, cond=10.0, scales=[1.0, 30.0, 30.0, 1e3, 1e3, 3e3])
    R_WA, p_WA = random_rotation(rng), rng.normal(size=3)
    R_WB = R_WA @ random_rotation(rng, 0.4)
    p_WB = p_WA + R_WA @ (1e-4 * rng.normal(size=3))
    _check(method, R_WA, p_WA, R_WB, p_WB, K, 1e-4, 1e-7)

"""End stops in the core (mjflex.core.stops): coordinates, energy, and the wrench as minus its gradient.

The reference gradient is Ridders' extrapolated central difference of ``stop_potential`` under
world-frame displacements of body B (``tests.helpers.gradient_wrt_b``); the coordinates are
checked against scipy's rotation vector. Poses are chosen with every engaged coordinate well past
its limit (and every free one well inside), so that no difference step crosses a limit, where the
energy's second derivative jumps.
"""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import mjflex
from tests.helpers import gradient_wrt_b, random_rotation

INF = np.inf


def _pose(rng, angle, trans=0.01):
    R_WA, p_WA = random_rotation(rng), rng.normal(size=3)
    R_ab, p_ab = random_rotation(rng, angle), trans * rng.normal(size=3)
    return R_WA, p_WA, R_WA @ R_ab, p_WA + R_WA @ p_ab


def _limits_around(z, rng, margin):
    """Limits that put each coordinate of ``z`` past a stop (below or above, by ``margin`` of its size or more)
    or inside a range, at random; each with a stiffness."""
    lower, upper = np.full(6, -INF), np.full(6, INF)
    for i in range(6):
        size = max(abs(z[i]), 1e-3)
        which = rng.integers(3)
        if which == 0:  # past the upper stop
            upper[i] = z[i] - margin * size
        elif which == 1:  # past the lower stop
            lower[i] = z[i] + margin * size
        else:  # inside a two-sided range
            lower[i], upper[i] = z[i] - size, z[i] + size
    return lower, upper, rng.uniform(0.5, 2.0, size=6) * np.array([10, 10, 10, 1e4, 1e4, 1e4])


def test_coordinates_are_the_rotation_vector_and_the_position_of_b_in_a():
    rng = np.random.default_rng(0)
    for angle in (1e-9, 0.3, 2.0, np.pi - 1e-3):
        R_WA, p_WA, R_WB, p_WB = _pose(rng, angle)
        z = mjflex.stop_coordinates(R_WA, p_WA, R_WB, p_WB)
        assert np.allclose(z[:3], Rotation.from_matrix(R_WA.T @ R_WB).as_rotvec(), rtol=1e-12, atol=1e-15)
        assert np.allclose(z[3:], R_WA.T @ (p_WB - p_WA), rtol=1e-12, atol=1e-17)
    # the same for both methods by construction, and not the twist's t under rotation
    R_WB, _ = mjflex.transform_from_twist([0, 0, 0.5, 0, 0, 0])
    z = mjflex.stop_coordinates(np.eye(3), np.zeros(3), R_WB, [0.1, 0, 0])
    t = mjflex.twist_from_transform(R_WB, [0.1, 0, 0])
    assert np.allclose(z, [0, 0, 0.5, 0.1, 0, 0]) and abs(t[4]) > 0.01


@pytest.mark.parametrize("angle", [1e-6, 1e-2, 0.5, 1.5, 2.5, 3.0])
@pytest.mark.parametrize("seed", range(4))
def test_stop_wrench_is_minus_the_gradient_of_the_stop_energy(angle, seed):
    rng = np.random.default_rng(100 + seed)
    R_WA, p_WA, R_WB, p_WB = _pose(rng, angle)
    z = mjflex.stop_coordinates(R_WA, p_WA, R_WB, p_WB)
    lower, upper, k = _limits_around(z, rng, 0.5)
    W = mjflex.stop_wrench_on_b(R_WA, p_WA, R_WB, p_WB, lower, upper, k)

    def energy(R, p):
        return mjflex.stop_potential(R_WA, p_WA, R, p, lower, upper, k, check=False)

    assert energy(R_WB, p_WB) > 0
    step = 0.05 * min(angle, 0.01)  # well within the margin of every engaged or free coordinate
    g = gradient_wrt_b(energy, R_WB, p_WB, step, 0.05 * 0.01 * 0.5)
    err = np.linalg.norm(W + g) / np.linalg.norm(W)
    assert err <= 1e-7, (err, W, -g)


def test_stops_are_exactly_zero_inside_their_range_and_one_sided():
    rng = np.random.default_rng(3)
    R_WA, p_WA, R_WB, p_WB = _pose(rng, 0.4)
    z = mjflex.stop_coordinates(R_WA, p_WA, R_WB, p_WB)
    k = np.full(6, 1e3)
    inside = mjflex.stop_wrench_on_b(R_WA, p_WA, R_WB, p_WB, z - 1e-9, z + 1e-9, k)
    assert np.array_equal(inside, np.zeros(6))
    assert mjflex.stop_potential(R_WA, p_WA, R_WB, p_WB, z - 1e-9, z + 1e-9, k) == 0.0
    # past an upper stop on x only: the force pushes b back along -x of frame a, and the energy is k d^2 / 2
    upper = np.full(6, INF)
    upper[3] = z[3] - 0.002
    W = mjflex.stop_wrench_on_b(R_WA, p_WA, R_WB, p_WB, None, upper, k)
    assert np.allclose(W[3:], -1e3 * 0.002 * R_WA[:, 0], rtol=1e-9) and np.allclose(W[:3], 0, atol=1e-15)
    U = mjflex.stop_potential(R_WA, p_WA, R_WB, p_WB, None, upper, k)
    assert np.isclose(U, 0.5 * 1e3 * 0.002**2, rtol=1e-9)
    # a lower stop on the same coordinate, far below it, does nothing
    lower = np.full(6, -INF)
    lower[3] = z[3] - 1.0
    assert mjflex.stop_potential(R_WA, p_WA, R_WB, p_WB, lower, None, k) == 0.0


def test_about_one_axis_the_moment_is_k_times_the_overshoot_at_any_angle():
    for angle in (0.1, 1.0, 3.0):
        R_WB, _ = mjflex.transform_from_twist([0, 0, angle, 0, 0, 0])
        upper = [INF, INF, angle - 0.05, INF, INF, INF]
        W = mjflex.stop_wrench_on_b(np.eye(3), np.zeros(3), R_WB, np.zeros(3), None, upper, [7.0] * 6)
        assert np.allclose(W, [0, 0, -7.0 * 0.05, 0, 0, 0], atol=1e-13)


def test_planar_stops_are_the_spatial_stops_of_the_motion_in_the_plane():
    rng = np.random.default_rng(4)
    for _ in range(20):
        ta, tb = rng.uniform(-4, 4, size=2)
        pa, pb = rng.normal(size=2), rng.normal(size=2)
        lower, upper = rng.uniform(-1, 0, size=3), rng.uniform(0, 1, size=3)
        k = rng.uniform(1, 10, size=3)
        lo6, hi6, k6 = np.full(6, -INF), np.full(6, INF), np.zeros(6)
        lo6[[2, 3, 4]], hi6[[2, 3, 4]], k6[[2, 3, 4]] = lower, upper, k
        R = [Rotation.from_rotvec([0, 0, t]).as_matrix() for t in (ta, tb)]
        P = [np.r_[p, 0.0] for p in (pa, pb)]
        U3 = mjflex.planar_stop_potential(ta, pa, tb, pb, lower, upper, k)
        U6 = mjflex.stop_potential(R[0], P[0], R[1], P[1], lo6, hi6, k6)
        W3 = mjflex.planar_stop_wrench_on_b(ta, pa, tb, pb, lower, upper, k)
        W6 = mjflex.stop_wrench_on_b(R[0], P[0], R[1], P[1], lo6, hi6, k6)
        assert np.isclose(U3, U6, rtol=1e-12, atol=1e-300)
        assert np.allclose(W3, W6[[2, 3, 4]], rtol=1e-12, atol=1e-12 * (1 + np.abs(W6).max()))
        assert np.allclose(W6[[0, 1, 5]], 0, atol=1e-12 * (1 + np.abs(W6).max()))


def test_batches_broadcast_like_the_element_functions():
    rng = np.random.default_rng(5)
    poses = [_pose(rng, a) for a in (0.1, 0.2, 0.3)]
    R_WA, p_WA, R_WB, p_WB = (np.stack(x) for x in zip(*poses, strict=True))
    lower, upper, k = np.full(6, -0.05), np.full(6, 0.05), np.full(6, 100.0)
    W = mjflex.stop_wrench_on_b(R_WA, p_WA, R_WB, p_WB, lower, upper, k)
    U = mjflex.stop_potential(R_WA, p_WA, R_WB, p_WB, lower, upper, k)
    assert W.shape == (3, 6) and U.shape == (3,)
    for i in range(3):
        assert np.array_equal(W[i], mjflex.stop_wrench_on_b(*poses[i], lower, upper, k))
        assert U[i] == mjflex.stop_potential(*poses[i], lower, upper, k)


def test_derived_stiffness_is_the_factor_times_the_diagonal():
    K = np.diag([2.0, 3.0, 4.0, 1e4, 2e4, 3e4])
    K[0, 3] = K[3, 0] = 1.0
    assert np.array_equal(mjflex.derived_stop_stiffness(K), 100.0 * np.diagonal(K))
    with pytest.raises(ValueError, match="6x6 or 3x3"):
        mjflex.derived_stop_stiffness(np.eye(4))


@pytest.mark.parametrize(
    ("lower", "upper", "k", "match"),
    [
        ([np.nan] * 6, None, [1.0] * 6, "NaN"),
        ([0.1] * 6, [0.0] * 6, [1.0] * 6, "lower > upper"),
        ([INF] * 6, None, [1.0] * 6, r"\+inf"),
        (None, [0.0] * 6, [-1.0] * 6, ">= 0"),
        (None, [0.0] * 5, [1.0] * 6, r"shape \(\.\.\., 6\)"),
    ],
)
def test_bad_limits_are_refused(lower, upper, k, match):
    with pytest.raises(ValueError, match=match):
        mjflex.stop_potential(np.eye(3), np.zeros(3), np.eye(3), np.zeros(3), lower, upper, k)

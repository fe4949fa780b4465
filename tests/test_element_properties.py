"""Physical properties of the element wrenches: rest behaviour, invariance, dissipation, methods, planar, batching.

Tolerances: identities that hold exactly in exact arithmetic (invariances, planar = spatial,
adjoint symmetries, native = mjflex) are checked to 1e-11 ... 1e-14 relative, while 1e-15 ... 1e-17
is achieved (measured). The margin covers round-off on other platforms (fused multiply-add,
numba's ``fastmath={"contract"}``, other libm/BLAS) and stays far below any modelling error,
which shows at 1e-6 and above. Tolerances that bound a truncation error say so where they are used.
"""

import numpy as np
import pytest

import mjflex
from tests.helpers import random_rotation, random_spd, rot_exp

METHODS = ["twist", "dualquat"]


def _blockdiag(R):
    T = np.zeros((6, 6))
    T[:3, :3] = T[3:, 3:] = R
    return T


def _random_state(rng, angle=None, trans=0.3):
    R_WA, p_WA = random_rotation(rng), rng.normal(size=3)
    R_WB = R_WA @ random_rotation(rng, angle if angle is not None else rng.uniform(0, 3.0))
    p_WB = p_WA + trans * rng.normal(size=3)
    vel = {k: rng.normal(size=3) for k in ("w_WA", "v_WA", "w_WB", "v_WB")}
    return R_WA, p_WA, R_WB, p_WB, vel


def _shift(W, r):
    """Wrench about point q -> about q + r (same world axes)."""
    return np.concatenate([W[:3] - np.cross(r, W[3:]), W[3:]])


# --------------------------------------------------------------------------- at rest


@pytest.mark.parametrize("method", METHODS)
def test_small_displacement_gives_minus_K_delta(method):
    rng = np.random.default_rng(0)
    K = random_spd(rng)
    R_WA, p_WA = random_rotation(rng), rng.normal(size=3)
    for eps in [1e-4, 1e-6]:
        delta = eps * rng.normal(size=6)  # body-frame displacement of b from a
        R_WB = R_WA @ rot_exp(delta[:3])
        p_WB = p_WA + R_WA @ delta[3:]
        W = mjflex.wrench_on_b(R_WA, p_WA, R_WB, p_WB, K, method=method)
        ref = _blockdiag(R_WB) @ (-K @ delta)
        assert np.linalg.norm(W - ref) <= 10 * eps * np.linalg.norm(ref)


@pytest.mark.parametrize("method", METHODS)
def test_viscous_wrench_at_coincident_frames_is_minus_B_relative_velocity(method):
    rng = np.random.default_rng(1)
    K, B = random_spd(rng), random_spd(rng, cond=1e3)
    R, p = random_rotation(rng), rng.normal(size=3)
    _, _, _, _, vel = _random_state(rng)
    W = mjflex.wrench_on_b(R, p, R, p, K, method=method, B=B, **vel)
    V_rel = np.concatenate([vel["w_WB"] - vel["w_WA"], vel["v_WB"] - vel["v_WA"]])
    ref = _blockdiag(R) @ (-B @ (_blockdiag(R).T @ V_rel))
    assert np.linalg.norm(W - ref) <= 1e-14 * np.linalg.norm(ref)


# --------------------------------------------------------------------------- invariance


@pytest.mark.parametrize("method", METHODS)
def test_swapping_bodies_gives_same_energy_and_opposite_wrench(method):
    rng = np.random.default_rng(2)
    for _ in range(20):
        K, B = random_spd(rng), random_spd(rng)
        R_WA, p_WA, R_WB, p_WB, vel = _random_state(rng)
        U_ab = mjflex.potential(R_WA, p_WA, R_WB, p_WB, K, method=method)
        U_ba = mjflex.potential(R_WB, p_WB, R_WA, p_WA, K, method=method)
        assert abs(U_ab - U_ba) <= 1e-13 * U_ab
        W_b = mjflex.wrench_on_b(R_WA, p_WA, R_WB, p_WB, K, method=method, B=B, **vel)
        swapped = {"w_WA": vel["w_WB"], "v_WA": vel["v_WB"], "w_WB": vel["w_WA"], "v_WB": vel["v_WA"]}
        W_a = mjflex.wrench_on_b(R_WB, p_WB, R_WA, p_WA, K, method=method, B=B, **swapped)
        # the wrench on A, moved to p_WB, is the negative of the wrench on B
        assert np.linalg.norm(_shift(W_a, p_WB - p_WA) + W_b) <= 1e-12 * np.linalg.norm(W_b)


@pytest.mark.parametrize("method", METHODS)
def test_moving_both_element_frames_with_adjoint_stiffness(method):
    """Same bodies, frames a' = a X and b' = b X, K' = Ad_X^T K Ad_X: same energy and wrench (eqs 54-57, 91-95)."""
    rng = np.random.default_rng(3)
    for _ in range(20):
        K, B = random_spd(rng), random_spd(rng)
        R_WA, p_WA, R_WB, p_WB, vel = _random_state(rng, angle=rng.uniform(0, 2.5))
        R_X, p_X = random_rotation(rng), 0.5 * rng.normal(size=3)
        K2 = mjflex.stiffness_in_frame(K, R_X, p_X)
        B2 = mjflex.stiffness_in_frame(B, R_X, p_X)
        R_WA2, p_WA2 = R_WA @ R_X, p_WA + R_WA @ p_X
        R_WB2, p_WB2 = R_WB @ R_X, p_WB + R_WB @ p_X
        # velocities of the new origins (same rigid bodies)
        vel2 = dict(vel)
        vel2["v_WA"] = vel["v_WA"] + np.cross(vel["w_WA"], p_WA2 - p_WA)
        vel2["v_WB"] = vel["v_WB"] + np.cross(vel["w_WB"], p_WB2 - p_WB)
        U = mjflex.potential(R_WA, p_WA, R_WB, p_WB, K, method=method)
        U2 = mjflex.potential(R_WA2, p_WA2, R_WB2, p_WB2, K2, method=method)
        assert abs(U - U2) <= 1e-12 * U
        W = mjflex.wrench_on_b(R_WA, p_WA, R_WB, p_WB, K, method=method, B=B, **vel)
        W2 = mjflex.wrench_on_b(R_WA2, p_WA2, R_WB2, p_WB2, K2, method=method, B=B2, **vel2)
        assert np.linalg.norm(_shift(W, p_WB2 - p_WB) - W2) <= 1e-11 * np.linalg.norm(W)


@pytest.mark.parametrize("method", METHODS)
def test_global_rigid_motion(method):
    rng = np.random.default_rng(4)
    K = random_spd(rng)
    R_WA, p_WA, R_WB, p_WB, _ = _random_state(rng)
    R_G, p_G = random_rotation(rng), rng.normal(size=3)
    U = mjflex.potential(R_WA, p_WA, R_WB, p_WB, K, method=method)
    U2 = mjflex.potential(R_G @ R_WA, R_G @ p_WA + p_G, R_G @ R_WB, R_G @ p_WB + p_G, K, method=method)
    assert abs(U - U2) <= 1e-13 * U
    W = mjflex.wrench_on_b(R_WA, p_WA, R_WB, p_WB, K, method=method)
    W2 = mjflex.wrench_on_b(R_G @ R_WA, R_G @ p_WA + p_G, R_G @ R_WB, R_G @ p_WB + p_G, K, method=method)
    assert np.linalg.norm(_blockdiag(R_G) @ W - W2) <= 1e-13 * np.linalg.norm(W)


# --------------------------------------------------------------------------- dissipation


@pytest.mark.parametrize("method", METHODS)
def test_viscous_power_is_never_positive(method):
    rng = np.random.default_rng(5)
    zero = np.zeros((6, 6))
    for i in range(200):
        B = random_spd(rng, cond=1e4)
        if i % 4 == 0:  # singular damping: only some directions damped
            Q, _ = np.linalg.qr(rng.normal(size=(6, 6)))
            B = Q[:, :2] @ np.diag(rng.uniform(0.1, 2, 2)) @ Q[:, :2].T
        angle = np.pi if i % 10 == 0 else None
        R_WA, p_WA, R_WB, p_WB, vel = _random_state(rng, angle=angle)
        W = mjflex.wrench_on_b(R_WA, p_WA, R_WB, p_WB, zero, method=method, B=B, **vel)
        v_A_at_b = vel["v_WA"] + np.cross(vel["w_WA"], p_WB - p_WA)
        power = W[:3] @ (vel["w_WB"] - vel["w_WA"]) + W[3:] @ (vel["v_WB"] - v_A_at_b)
        diss = mjflex.dissipation_power(R_WA, p_WA, R_WB, p_WB, B, method=method, **vel)
        assert diss >= 0
        assert abs(power + diss) <= 1e-12 * max(diss, np.linalg.norm(W) * 1e-3)


def test_rigid_common_motion_dissipates_nothing():
    rng = np.random.default_rng(6)
    B = random_spd(rng)
    R_WA, p_WA, R_WB, p_WB, _ = _random_state(rng)
    w, v0 = rng.normal(size=3), rng.normal(size=3)
    vel = {"w_WA": w, "w_WB": w, "v_WA": v0 + np.cross(w, p_WA), "v_WB": v0 + np.cross(w, p_WB)}
    for method in METHODS:
        W = mjflex.wrench_on_b(R_WA, p_WA, R_WB, p_WB, np.zeros((6, 6)), method=method, B=B, **vel)
        assert np.linalg.norm(W) <= 1e-13 * np.linalg.norm(B) * (1 + np.linalg.norm(w) + np.linalg.norm(v0))


# --------------------------------------------------------------------------- twist vs dual quaternion


def test_methods_agree_to_first_order():
    rng = np.random.default_rng(7)
    K = random_spd(rng)
    R_WA, p_WA = random_rotation(rng), rng.normal(size=3)
    d = rng.normal(size=6)
    errs = []
    for eps in [1e-2, 1e-3, 1e-4]:
        R_WB, p_WB = R_WA @ rot_exp(eps * d[:3]), p_WA + R_WA @ (eps * d[3:])
        Wt = mjflex.wrench_on_b(R_WA, p_WA, R_WB, p_WB, K, method="twist")
        Wq = mjflex.wrench_on_b(R_WA, p_WA, R_WB, p_WB, K, method="dualquat")
        errs.append(np.linalg.norm(Wt - Wq) / np.linalg.norm(Wt))
    assert errs[-1] <= 5e-8  # achieved 7e-9 at eps = 1e-4: the O(eps^2) difference of the cubic terms
    # the relative difference shrinks with the displacement: O(eps^2) (cubic wrench terms)
    assert errs[1] <= 0.02 * errs[0] and errs[2] <= 0.02 * errs[1]


def test_principal_axis_moments_are_k_alpha_and_k_sin_alpha():
    K = np.diag([2.0, 3.0, 5.0, 10.0, 20.0, 30.0])
    I3 = np.eye(3)
    for alpha in [0.3, 1.5, 2.9, np.pi]:
        R = rot_exp([0.0, 0.0, alpha]) if alpha < np.pi else np.diag([-1.0, -1.0, 1.0])
        Wt = mjflex.wrench_on_b(I3, np.zeros(3), R, np.zeros(3), K, method="twist")
        Wq = mjflex.wrench_on_b(I3, np.zeros(3), R, np.zeros(3), K, method="dualquat")
        assert abs(Wt[2] + 5.0 * alpha) <= 1e-12 * 5 * alpha
        assert abs(Wq[2] + 5.0 * np.sin(alpha)) <= 1e-12 * 5
        assert np.abs(Wt[[0, 1, 3, 4, 5]]).max() <= 1e-12 and np.abs(Wq[[0, 1, 3, 4, 5]]).max() <= 1e-12
    # at the half turn the dual-quaternion restoring moment vanishes
    assert abs(Wq[2]) <= 1e-12


def test_half_turn_twist_energy_is_continuous_with_a_kink():
    """Rotating through pi: energy continuous, slope flips sign; the dual-quaternion energy is smooth."""
    K = np.diag([2.0, 3.0, 5.0, 10.0, 20.0, 30.0])
    I3, z = np.eye(3), np.zeros(3)

    def energy(phi, method):
        return mjflex.potential(I3, z, rot_exp([0.0, 0.0, phi]), z, K, method=method)

    h = 1e-6
    below, at, above = (energy(np.pi + s, "twist") for s in (-h, 0.0, h))
    assert abs(below - at) <= 5 * 5 * np.pi * h and abs(above - at) <= 5 * 5 * np.pi * h
    assert below < at and above < at  # a peak with a kink, slope +5 pi -> -5 pi
    dq = [energy(np.pi + s, "dualquat") for s in (-h, 0.0, h)]
    # smooth maximum: zero slope (exactly 0 here by symmetry; 1e-9 is the round-off of U ~ 10 J over h = 1e-6)
    assert abs((dq[2] - dq[0]) / (2 * h)) <= 1e-9
    # exactly pi: the twist wrench is one of its two one-sided limits, the dual-quaternion wrench is continuous
    p_b = np.array([0.1, 0.2, 0.0])
    for method in METHODS:
        W = mjflex.wrench_on_b(I3, z, np.diag([-1.0, -1.0, 1.0]), p_b, K, method=method)
        sides = [mjflex.wrench_on_b(I3, z, rot_exp([0.0, 0.0, np.pi + s]), p_b, K, method=method) for s in (-h, h)]
        gaps = [np.linalg.norm(W - side) / np.linalg.norm(side) for side in sides]
        assert min(gaps) <= 1e-4  # O(h) away from one side
        if method == "twist":
            assert max(gaps) >= 0.1  # and the sides differ: the kink
        else:
            assert max(gaps) <= 1e-4


# --------------------------------------------------------------------------- planar


def _embed(M3):
    M = np.zeros((6, 6))
    idx = [2, 3, 4]
    M[np.ix_(idx, idx)] = M3
    return M


def _rz(th):
    return rot_exp([0.0, 0.0, th])


@pytest.mark.parametrize("method", METHODS)
def test_planar_equals_spatial_restricted_to_plane(method):
    rng = np.random.default_rng(8)
    for i in range(100):
        K3, B3 = random_spd(rng, 3), random_spd(rng, 3)
        th_a, th_b = rng.uniform(-4, 4, 2)
        if i % 10 == 0:
            th_b = th_a + np.pi  # exactly a half turn
        p_a, p_b = rng.normal(size=2), rng.normal(size=2)
        wa, wb = rng.normal(size=2)
        va, vb = rng.normal(size=2), rng.normal(size=2)
        W3 = mjflex.planar_wrench_on_b(
            th_a, p_a, th_b, p_b, K3, method=method, B=B3, w_WA=wa, v_WA=va, w_WB=wb, v_WB=vb
        )
        U3 = mjflex.planar_potential(th_a, p_a, th_b, p_b, K3, method=method)
        e = np.zeros(1)
        W6 = mjflex.wrench_on_b(
            _rz(th_a), np.r_[p_a, e], _rz(th_b), np.r_[p_b, e], _embed(K3), method=method, B=_embed(B3),
            w_WA=[0, 0, wa], v_WA=np.r_[va, e], w_WB=[0, 0, wb], v_WB=np.r_[vb, e],
        )  # fmt: skip
        U6 = mjflex.potential(_rz(th_a), np.r_[p_a, e], _rz(th_b), np.r_[p_b, e], _embed(K3), method=method)
        if abs(abs(mjflex.core._planar_kernels.wrap_angle(th_b - th_a)) - np.pi) < 1e-9 and method == "twist":
            continue  # at a half turn the spatial branch comes from a rounded R; see the exact test below
        assert abs(U3 - U6) <= 1e-12 * max(U6, 1e-300)
        assert np.linalg.norm(W3 - W6[[2, 3, 4]]) <= 1e-12 * np.linalg.norm(W6)
        assert np.abs(W6[[0, 1, 5]]).max() <= 1e-12 * np.linalg.norm(W6)
        d3 = mjflex.planar_dissipation_power(
            th_a, p_a, th_b, p_b, B3, method=method, w_WA=wa, v_WA=va, w_WB=wb, v_WB=vb
        )
        assert d3 >= 0


@pytest.mark.parametrize("method", METHODS)
def test_planar_half_turn_matches_exact_spatial_half_turn(method):
    K3 = random_spd(np.random.default_rng(9), 3)
    p_b = np.array([0.3, -0.2])
    W3 = mjflex.planar_wrench_on_b(0.0, [0, 0], np.pi, p_b, K3, method=method)
    W6 = mjflex.wrench_on_b(
        np.eye(3), np.zeros(3), np.diag([-1.0, -1.0, 1.0]), np.r_[p_b, 0], _embed(K3), method=method
    )
    assert np.linalg.norm(W3 - W6[[2, 3, 4]]) <= 1e-12 * np.linalg.norm(W6)


# --------------------------------------------------------------------------- batching


@pytest.mark.parametrize("shape", [(), (48,), (4, 5)])
@pytest.mark.parametrize("method", METHODS)
def test_batched_calls_equal_loop(shape, method):
    rng = np.random.default_rng(10)
    n = int(np.prod(shape))
    states = [_random_state(rng) for _ in range(n)]
    stack = [np.array(x).reshape(shape + np.shape(x[0])) for x in zip(*[s[:4] for s in states], strict=True)]
    vel = {k: np.array([s[4][k] for s in states]).reshape(shape + (3,)) for k in states[0][4]}
    K = np.array([random_spd(rng) for _ in range(n)]).reshape(shape + (6, 6))
    B = random_spd(rng)  # one damping shared by all: broadcast
    W = mjflex.wrench_on_b(*stack, K, method=method, B=B, **vel)
    U = mjflex.potential(*stack, K, method=method)
    D = mjflex.dissipation_power(*stack, B, method=method, **vel)
    assert W.shape == shape + (6,) and U.shape == shape and D.shape == shape
    flat = [x.reshape((n,) + x.shape[len(shape) :]) for x in stack]
    fk = K.reshape(n, 6, 6)
    fv = {k: v.reshape(n, 3) for k, v in vel.items()}
    for i in range(n):
        one = [x[i] for x in flat]
        vi = {k: v[i] for k, v in fv.items()}
        assert np.array_equal(W.reshape(n, 6)[i], mjflex.wrench_on_b(*one, fk[i], method=method, B=B, **vi))
        assert U.reshape(n)[i] == mjflex.potential(*one, fk[i], method=method)
        assert D.reshape(n)[i] == mjflex.dissipation_power(*one, B, method=method, **vi)


@pytest.mark.parametrize("shape", [(), (48,), (4, 5)])
def test_planar_batched_calls_equal_loop(shape):
    rng = np.random.default_rng(11)
    th_a, th_b = rng.uniform(-3, 3, shape), rng.uniform(-3, 3, shape)
    p_a, p_b = rng.normal(size=shape + (2,)), rng.normal(size=shape + (2,))
    K = random_spd(rng, 3)
    W = mjflex.planar_wrench_on_b(th_a, p_a, th_b, p_b, K, method="dualquat")
    U = mjflex.planar_potential(th_a, p_a, th_b, p_b, K)
    assert W.shape == shape + (3,) and np.shape(U) == shape
    for idx in np.ndindex(shape):
        assert np.array_equal(
            W[idx], mjflex.planar_wrench_on_b(th_a[idx], p_a[idx], th_b[idx], p_b[idx], K, method="dualquat")
        )
        assert U[idx] == mjflex.planar_potential(th_a[idx], p_a[idx], th_b[idx], p_b[idx], K)


def test_broadcasting_partial_shapes():
    rng = np.random.default_rng(12)
    R_WA = np.stack([random_rotation(rng) for _ in range(4)])[:, None]  # (4, 1, 3, 3)
    R_WB = np.stack([random_rotation(rng) for _ in range(5)])  # (5, 3, 3)
    p = rng.normal(size=(4, 5, 3))
    K = random_spd(rng)
    W = mjflex.wrench_on_b(R_WA, np.zeros(3), R_WB, p, K)
    assert W.shape == (4, 5, 6)
    assert np.array_equal(W[2, 3], mjflex.wrench_on_b(R_WA[2, 0], np.zeros(3), R_WB[3], p[2, 3], K))
    with pytest.raises(ValueError, match="batch shapes do not broadcast"):
        mjflex.wrench_on_b(R_WA[:3], np.zeros(3), R_WB, p, K)

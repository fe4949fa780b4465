"""Twists and dual quaternions against scipy.spatial.transform (an independent implementation).

Tolerances: identities that hold exactly in exact arithmetic (invariances, planar = spatial,
adjoint symmetries, native = mjflex) are checked to 1e-11 ... 1e-14 relative, while 1e-15 ... 1e-17
is achieved (measured). The margin covers round-off on other platforms (fused multiply-add,
numba's ``fastmath={"contract"}``, other libm/BLAS) and stays far below any modelling error,
which shows at 1e-6 and above. Tolerances that bound a truncation error say so where they are used.
"""

import numpy as np
import pytest
from scipy.spatial.transform import RigidTransform, Rotation

import mjflex
from tests.helpers import random_rotation

TOL = 1e-12


def _poses(n, seed, max_angle=np.pi):
    rng = np.random.default_rng(seed)
    angles = np.concatenate([[0.0, 1e-12, 1e-8, 1e-4, 0.5, 1.0, 3.0, np.pi - 1e-7], rng.uniform(0, max_angle, n)])
    R = np.stack([random_rotation(rng, a) for a in angles])
    p = rng.normal(size=(len(angles), 3)) * np.geomspace(1e-6, 1e3, len(angles))[:, None]
    return R, p


def test_twist_matches_scipy_exp_coords():
    R, p = _poses(200, 0, max_angle=np.pi - 1e-3)
    xi = mjflex.twist_from_transform(R, p)
    T = np.zeros((len(R), 4, 4))
    T[:, :3, :3], T[:, :3, 3], T[:, 3, 3] = R, p, 1.0
    ref = RigidTransform.from_matrix(T).as_exp_coords()
    scale = np.maximum(np.linalg.norm(ref, axis=-1, keepdims=True), 1.0)
    assert np.abs(xi - ref).max(axis=-1).max() / 1.0 <= 1e-12 * scale.max()
    # rotation part against scipy's rotation vectors, relative to the angle (small angles too)
    rv = Rotation.from_matrix(R).as_rotvec()
    rel = np.linalg.norm(xi[:, :3] - rv, axis=-1) / np.maximum(np.linalg.norm(rv, axis=-1), 1e-300)
    assert rel[np.linalg.norm(rv, axis=-1) > 0].max() <= 1e-12


def test_transform_twist_round_trip():
    R, p = _poses(200, 1)
    R2, p2 = mjflex.transform_from_twist(mjflex.twist_from_transform(R, p))
    assert np.abs(R2 - R).max() <= TOL
    assert (np.linalg.norm(p2 - p, axis=-1) / np.maximum(np.linalg.norm(p, axis=-1), 1.0)).max() <= TOL


def test_twist_transform_round_trip_and_scipy_exp():
    rng = np.random.default_rng(2)
    axis = rng.normal(size=(300, 3))
    axis /= np.linalg.norm(axis, axis=-1, keepdims=True)
    angle = np.concatenate([[0.0, 1e-12, 1e-6], rng.uniform(0, np.pi - 1e-6, 297)])
    xi = np.concatenate([angle[:, None] * axis, rng.normal(size=(300, 3))], axis=-1)
    R, p = mjflex.transform_from_twist(xi)
    ref = RigidTransform.from_exp_coords(xi).as_matrix()
    assert np.abs(R - ref[:, :3, :3]).max() <= TOL
    assert np.abs(p - ref[:, :3, 3]).max() <= TOL * 10  # |p| up to ~5 m
    back = mjflex.twist_from_transform(R, p)
    assert np.abs(back - xi).max() <= 2e-14  # achieved 1e-15 (|xi| up to ~5)


def test_small_rotation_vector_keeps_relative_precision():
    for a in [1e-15, 1e-12, 1e-9]:
        w = a * np.array([0.36, -0.48, 0.8])
        R = Rotation.from_rotvec(w).as_matrix()
        xi = mjflex.twist_from_transform(R, np.zeros(3))
        assert np.linalg.norm(xi[:3] - w) <= 1e-15 * a


def test_dual_quaternion_matches_scipy():
    R, p = _poses(200, 3)
    q = mjflex.dual_quaternion_from_transform(R, p)
    T = np.zeros((len(R), 4, 4))
    T[:, :3, :3], T[:, :3, 3], T[:, 3, 3] = R, p, 1.0
    ref = RigidTransform.from_matrix(T).as_dual_quat(scalar_first=True)
    ref *= np.where(ref[:, :1] < 0, -1.0, 1.0)  # scipy does not fix the double cover
    assert np.all(q[:, 0] >= 0)
    scale = np.maximum(np.linalg.norm(p, axis=-1), 1.0)
    assert (np.abs(q - ref).max(axis=-1) / scale).max() <= TOL
    # the unit conditions
    assert np.abs(np.linalg.norm(q[:, :4], axis=-1) - 1).max() <= 1e-15
    assert (np.abs(np.sum(q[:, :4] * q[:, 4:], axis=-1)) / scale).max() <= 1e-15


def test_dual_quaternion_round_trips():
    R, p = _poses(200, 4)
    q = mjflex.dual_quaternion_from_transform(R, p)
    R2, p2 = mjflex.transform_from_dual_quaternion(q)
    R3, p3 = mjflex.transform_from_dual_quaternion(-q)  # double cover
    scale = np.maximum(np.linalg.norm(p, axis=-1), 1.0)
    for Rx, px in [(R2, p2), (R3, p3)]:
        assert np.abs(Rx - R).max() <= TOL
        assert (np.linalg.norm(px - p, axis=-1) / scale).max() <= TOL
    q2 = mjflex.dual_quaternion_from_transform(R2, p2)
    assert (np.abs(q2 - q).max(axis=-1) / scale).max() <= TOL


def test_half_turn_is_defined_and_deterministic():
    """At exactly pi the log is two-valued; the result is a valid log with a fixed sign rule."""
    for axis in [np.array([1.0, 0, 0]), np.array([0, -1.0, 0]), np.array([0, 0, 1.0]), np.array([1.0, -2, 2]) / 3]:
        R = 2.0 * np.outer(axis, axis) - np.eye(3)  # exactly symmetric: a half turn
        xi = mjflex.twist_from_transform(R, np.array([0.1, 0.2, 0.3]))
        tau = xi[:3]
        assert abs(np.linalg.norm(tau) - np.pi) <= 1e-12
        assert tau[np.argmax(np.abs(tau))] > 0
        R2, p2 = mjflex.transform_from_twist(xi)
        assert np.abs(R2 - R).max() <= 1e-12 and np.abs(p2 - [0.1, 0.2, 0.3]).max() <= 1e-12
        q = mjflex.dual_quaternion_from_transform(R, np.zeros(3))
        assert abs(q[0]) <= 1e-16


@pytest.mark.parametrize("shape", [(), (7,), (2, 3)])
def test_transform_functions_broadcast(shape):
    rng = np.random.default_rng(5)
    n = int(np.prod(shape))
    R = np.stack([random_rotation(rng) for _ in range(n)]).reshape(shape + (3, 3))
    p = rng.normal(size=shape + (3,))
    xi = mjflex.twist_from_transform(R, p)
    q = mjflex.dual_quaternion_from_transform(R, p)
    assert xi.shape == shape + (6,) and q.shape == shape + (8,)
    flat_xi = [mjflex.twist_from_transform(r, pp) for r, pp in zip(R.reshape(-1, 3, 3), p.reshape(-1, 3), strict=True)]
    assert np.array_equal(xi.reshape(-1, 6), np.array(flat_xi).reshape(-1, 6))
    # one rotation broadcast against many positions
    xi2 = mjflex.twist_from_transform(np.eye(3), p)
    assert np.allclose(xi2[..., 3:], p, rtol=0, atol=0)

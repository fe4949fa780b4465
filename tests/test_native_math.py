"""The C element math (mjflex/native/flexure_math.c) against the independent reference, mjflex.core.

Per element: wrench (elastic + viscous), energy and power of both methods, with polynomial terms and
planar elements, over random poses including rotations near 0 and near a half turn. Tolerance: 1e-12
of the wrench's norm (the core and the C code evaluate the same formulas in a different order; achieved
~1e-15).
"""

import ctypes

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import mjflex
from mjflex.core.series import JL_INV_COEFFS, JL_INV_RATE_COEFFS
from mjflex.mjcf import schema
from mjflex.native import library as _native
from tests.helpers import exact_rotation, random_spd

# relative rotation angles: generic, tiny (series branch), the series threshold, near a half turn
ANGLES = [None, 0.0, 1e-12, 1e-7, 1e-3, 0.999, 1.0, 1.001, 2.5, np.pi - 1e-3, np.pi - 1e-7]
RTOL = 1e-12


def _c(a):
    return np.ascontiguousarray(a, dtype=np.float64)


def _poses(rng, n):
    """World poses of frames a and b (n, ...) whose relative rotation angles sweep ANGLES.

    Frame a is a signed permutation (``exact_rotation``) and, for tiny displacements, at the origin: the
    relative pose is then exact in floating point, so the comparison measures the two implementations, not
    the round-off of recovering a 1e-12 rad displacement from world poses (which either would amplify).
    """
    R_WA = np.array([exact_rotation(rng) for _ in range(n)])
    rotvecs = []
    for i in range(n):
        angle = ANGLES[i % len(ANGLES)]
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        rotvecs.append(axis * (rng.uniform(0, np.pi) if angle is None else angle))
    R_ab = Rotation.from_rotvec(rotvecs).as_matrix()
    tiny = rng.choice([True, False], size=(n, 1))
    p_ab = 0.05 * rng.normal(size=(n, 3)) * np.where(tiny, 1e-9, 1.0)
    p_WA = np.where(tiny, 0.0, rng.normal(size=(n, 3)))
    R_WB = R_WA @ R_ab
    p_WB = p_WA + np.einsum("nij,nj->ni", R_WA, p_ab)
    return R_WA, p_WA, R_WB, p_WB


def native_wrench(method, R_WA, p_WA, R_WB, p_WB, K, B=None, vel=None, terms=None):
    n = len(R_WA)
    K = _c(np.broadcast_to(K, (n, 6, 6)))
    B = None if B is None else _c(np.broadcast_to(B, (n, 6, 6)))
    exps, coefs, top = _terms(terms)
    vel = [None] * 4 if vel is None else [_c(v) for v in vel]
    out, power = np.empty((n, 6)), np.empty(n)
    args = [_c(R_WA), _c(p_WA), _c(R_WB), _c(p_WB), K, B]
    ptr = [None if a is None else a.ctypes.data for a in args]
    vptr = [None if v is None else v.ctypes.data for v in vel]
    _native.lib().mjfx_wrench_batch(n, _native_method(method), *ptr, int(B is not None), *vptr,
                                    exps.ctypes.data, coefs.ctypes.data, len(coefs) if terms else 0, top,
                                    out.ctypes.data, power.ctypes.data)  # fmt: skip
    return out, power


def native_potential(method, R_WA, p_WA, R_WB, p_WB, K, terms=None):
    n = len(R_WA)
    exps, coefs, top = _terms(terms)
    out = np.empty(n)
    args = [_c(R_WA), _c(p_WA), _c(R_WB), _c(p_WB), _c(np.broadcast_to(K, (n, 6, 6)))]
    _native.lib().mjfx_potential_batch(n, _native_method(method), *(a.ctypes.data for a in args), exps.ctypes.data,
                                       coefs.ctypes.data, len(coefs) if terms else 0, top, out.ctypes.data)  # fmt: skip
    return out


def _native_method(method):
    return {"twist": 0, "dualquat": 1}[method]


def _terms(terms):
    if terms is None or len(terms) == 0:
        return np.zeros((1, 8), np.int32), np.zeros(1), 0
    exps = np.zeros((len(terms), 8), np.int32)
    exps[:, : terms.exponents.shape[1]] = terms.exponents
    return exps, _c(terms.coefficients), int(terms.exponents.max())


def _random_terms(rng, method, order=4):
    basis = mjflex.polynomial_basis(method, order)
    return mjflex.PolynomialTerms(method, basis, rng.normal(size=len(basis)) * 10.0)


def _check(got, expected, rtol=RTOL):
    scale = np.linalg.norm(expected, axis=-1, keepdims=True)
    err = np.linalg.norm(got - expected, axis=-1, keepdims=True)
    assert (err <= rtol * scale + 1e-300).all(), f"worst relative error {np.max(err / np.maximum(scale, 1e-300)):.3g}"


def test_series_coefficients_are_the_cores():
    """The first 12 are the core's; the C code has 8 more (exact too: tests/test_native_kernel.py) for its series
    up to 2.2 rad."""
    c, g = np.zeros(20), np.zeros(20)
    assert _native.lib().mjfx_series_coefficients(c.ctypes.data, g.ctypes.data, 20) == 20
    assert np.array_equal(c[:12], JL_INV_COEFFS) and np.array_equal(g[:12], JL_INV_RATE_COEFFS)


@pytest.mark.parametrize("method", ["twist", "dualquat"])
@pytest.mark.parametrize("with_terms", [False, True], ids=["quadratic", "terms"])
def test_wrench_energy_power_match_the_core(method, with_terms):
    rng = np.random.default_rng(11 if with_terms else 7)
    n = 400
    R_WA, p_WA, R_WB, p_WB = _poses(rng, n)
    K = random_spd(rng, cond=1e3, scales=[1, 1, 1, 30, 30, 30])
    B = 0.01 * random_spd(rng)
    vel = [rng.normal(size=(n, 3)) for _ in range(4)]
    terms = _random_terms(rng, method) if with_terms else None
    w_WA, v_WA, w_WB, v_WB = vel
    expected = mjflex.wrench_on_b(R_WA, p_WA, R_WB, p_WB, K, method=method, B=B, w_WA=w_WA, v_WA=v_WA, w_WB=w_WB,
                                  v_WB=v_WB, terms=terms)  # fmt: skip
    got, power = native_wrench(method, R_WA, p_WA, R_WB, p_WB, K, B, vel, terms)
    _check(got, expected)
    elastic = mjflex.wrench_on_b(R_WA, p_WA, R_WB, p_WB, K, method=method, terms=terms)
    _check(native_wrench(method, R_WA, p_WA, R_WB, p_WB, K, terms=terms)[0], elastic)
    expected_power = mjflex.dissipation_power(R_WA, p_WA, R_WB, p_WB, B, method=method, w_WA=w_WA, v_WA=v_WA,
                                              w_WB=w_WB, v_WB=v_WB)  # fmt: skip
    assert np.allclose(power, expected_power, rtol=RTOL, atol=0)
    energy = mjflex.potential(R_WA, p_WA, R_WB, p_WB, K, method=method, terms=terms)
    got_energy = native_potential(method, R_WA, p_WA, R_WB, p_WB, K, terms)
    assert np.all(np.abs(got_energy - energy) <= RTOL * np.abs(energy) + 1e-300)


@pytest.mark.parametrize("method", ["twist", "dualquat"])
def test_diagonal_stiffness_fast_path_is_bit_identical_to_the_full_product(method):
    """ARCADE's K are diagonal: the C loop skips the zero products, which must not change a bit."""
    rng = np.random.default_rng(3)
    R_WA, p_WA, R_WB, p_WB = _poses(rng, 200)
    K = np.diag(rng.uniform(0.5, 5.0, 6) * [1, 1, 1, 1e4, 1e4, 1e4])
    dense = K.copy()
    dense[0, 5] = dense[5, 0] = 1e-300  # not diagonal any more, numerically the same
    diagonal, _ = native_wrench(method, R_WA, p_WA, R_WB, p_WB, K)
    full, _ = native_wrench(method, R_WA, p_WA, R_WB, p_WB, dense)
    assert np.array_equal(diagonal, full)
    _check(diagonal, mjflex.wrench_on_b(R_WA, p_WA, R_WB, p_WB, K, method=method))


@pytest.mark.parametrize("method", ["twist", "dualquat"])
def test_planar_element_matches_the_core_planar_functions(method):
    """A planar element (3x3 K embedded in [theta_z; x; y]) moving in the plane: the core's planar functions."""
    rng = np.random.default_rng(5)
    n = 200
    theta_a, theta_b = rng.uniform(-np.pi, np.pi, n), rng.uniform(-np.pi, np.pi, n)
    theta_b[::7] = theta_a[::7] + 1e-9  # nearly aligned
    p_a, p_b = np.zeros((n, 3)), np.zeros((n, 3))
    p_a[:, :2], p_b[:, :2] = rng.normal(size=(n, 2)), rng.normal(size=(n, 2))
    R_WA = Rotation.from_euler("z", theta_a[:, None]).as_matrix()
    R_WB = Rotation.from_euler("z", theta_b[:, None]).as_matrix()
    K3 = random_spd(rng, n=3, scales=[1, 20, 20])
    B3 = 0.01 * random_spd(rng, n=3)
    K6, B6 = schema.embed_planar(K3), schema.embed_planar(B3)
    w_a, w_b = np.zeros((n, 3)), np.zeros((n, 3))
    w_a[:, 2], w_b[:, 2] = rng.normal(size=n), rng.normal(size=n)
    v_a, v_b = np.zeros((n, 3)), np.zeros((n, 3))
    v_a[:, :2], v_b[:, :2] = rng.normal(size=(n, 2)), rng.normal(size=(n, 2))
    got, power = native_wrench(method, R_WA, p_a, R_WB, p_b, K6, B6, [w_a, v_a, w_b, v_b])
    planar = mjflex.planar_wrench_on_b(theta_a, p_a[:, :2], theta_b, p_b[:, :2], K3, method=method, B=B3,
                                       w_WA=w_a[:, 2], v_WA=v_a[:, :2], w_WB=w_b[:, 2], v_WB=v_b[:, :2])  # fmt: skip
    assert np.allclose(got[:, [0, 1, 5]], 0.0, atol=1e-13 * np.abs(planar).max())  # nothing out of the plane
    _check(got[:, [2, 3, 4]], planar)
    expected_power = mjflex.planar_dissipation_power(theta_a, p_a[:, :2], theta_b, p_b[:, :2], B3, method=method,
                                                     w_WA=w_a[:, 2], v_WA=v_a[:, :2], w_WB=w_b[:, 2],
                                                     v_WB=v_b[:, :2])  # fmt: skip
    assert np.allclose(power, expected_power, rtol=RTOL, atol=1e-14 * np.abs(expected_power).max())


def test_twist_of_the_loop_matches_the_core():
    rng = np.random.default_rng(9)
    R_WA, p_WA, R_WB, p_WB = _poses(rng, 300)
    out = np.empty((300, 6))
    args = [_c(a) for a in (R_WA, p_WA, R_WB, p_WB)]
    _native.lib().mjfx_twist_batch(300, *(a.ctypes.data for a in args), out.ctypes.data)
    R_ab = np.swapaxes(R_WA, -1, -2) @ R_WB
    p_ab = np.einsum("nji,nj->ni", R_WA, p_WB - p_WA)
    _check(out, mjflex.twist_from_transform(R_ab, p_ab))


def test_element_struct_matches_numpy_and_the_plugin_attributes_match_the_schema():
    native = _native.lib()
    assert native.mjfx_element_field(None) == _native.ELEMENT_DTYPE.itemsize
    assert _native.plugin_attributes() == tuple(a.key for a in schema.attributes())
    assert ctypes.sizeof(_native.Verdict) == 40


@pytest.mark.parametrize("method", ["twist", "dualquat"])
def test_the_mujoco_loop_matches_the_core_at_any_rotation(method, tmp_path):
    """The loop's own pose path (MuJoCo's body quaternions, the rest offset of a saved file) against the core fed
    with the sites' world poses and velocities; relative rotations from 1e-9 rad to near a half turn."""
    import mujoco

    from tests.models import B_DEMO, two_body_spec

    path = tmp_path / "two_body.xml"
    path.write_text(two_body_spec(B=B_DEMO, method=method).to_xml())  # 6-digit site poses: a rest offset
    model = mujoco.MjModel.from_xml_path(str(path))
    flex = mjflex.Flexures(model)
    row = flex.element_table.elements[0]
    assert row["offset"]
    R0, p0 = row["R0"].reshape(3, 3), row["p0"]
    rng = np.random.default_rng(2)
    data = mujoco.MjData(model)
    for angle in (1e-9, 1e-4, 0.3, 1.0, 2.0, 3.0, np.pi - 1e-6):
        data.qpos[:] = model.qpos0
        rotation = Rotation.from_rotvec(angle * rng.normal(size=3) / np.sqrt(3))  # about B's centre
        q = Rotation.from_quat(data.qpos[10:14], scalar_first=True)
        data.qpos[10:14] = (rotation * q).as_quat(scalar_first=True)
        data.qpos[7:10] += 0.01 * rng.normal(size=3)
        data.qvel[:] = rng.normal(size=model.nv)
        mujoco.mj_forward(model, data)
        sa, sb = flex.site_ids[0]
        R_a, p_a = data.site_xmat[sa].reshape(3, 3), data.site_xpos[sa]
        R_b = data.site_xmat[sb].reshape(3, 3) @ R0.T
        p_b = data.site_xpos[sb] - R_b @ p0
        vel = []
        for site, point in ((sa, p_a), (sb, p_b)):
            v = np.empty(6)
            mujoco.mj_objectVelocity(model, data, mujoco.mjtObj.mjOBJ_SITE, int(site), v, 0)
            vel += [v[:3], v[3:] + np.cross(v[:3], point - data.site_xpos[site])]
        expected = mjflex.wrench_on_b(R_a, p_a, R_b, p_b, flex.records[0].K, method=method, B=B_DEMO, w_WA=vel[0],
                                      v_WA=vel[1], w_WB=vel[2], v_WB=vel[3])  # fmt: skip
        _check(flex.wrenches(data)[0][None], expected[None])
        energy = mjflex.potential(R_a, p_a, R_b, p_b, flex.records[0].K, method=method)
        assert abs(flex.potential_energies(data)[0] - energy) <= RTOL * energy

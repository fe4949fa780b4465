"""Polynomial (higher-order) potentials: quadratic special case, energy consistency, invariance, footnote 4.

References independent of the code under test: Ridders' finite differences of the energy
(``tests.helpers``), the 6x8 map of eq. 116 and the paper's inverse maps (eqs 78, 117) written
out here in numpy, scipy rotations, and the algebraic identities of unit dual quaternions.
"""

import numpy as np
import pytest

import mjflex
from mjflex.core.identification import design_matrix
from mjflex.core.polynomial import VARIABLES, coordinate_indices, no_terms, polynomial_basis
from tests.helpers import gradient_wrt_b, hat, lambda_tilde, random_rotation, random_spd, rot_exp

METHODS = ["twist", "dualquat"]


def _terms(method, rng, order=4, scale=1.0):
    e = polynomial_basis(method, order)
    return mjflex.PolynomialTerms(method, e, scale * rng.normal(size=len(e)))


def _state(rng, angle, trans=0.3):
    R_WA, p_WA = random_rotation(rng), rng.normal(size=3)
    return R_WA, p_WA, R_WA @ random_rotation(rng, angle), p_WA + trans * rng.normal(size=3)


def _shift(W, r):
    """Wrench about point q -> about q + r (same axes)."""
    return np.concatenate([W[..., :3] - np.cross(r, W[..., 3:]), W[..., 3:]], axis=-1)


# --------------------------------------------------------------------------- the quadratic case


@pytest.mark.parametrize("method", METHODS)
def test_without_terms_is_the_quadratic_potential_bit_for_bit(method):
    """N = 2 (no terms) runs the quadratic kernels themselves: identical bits.

    All-zero terms take the polynomial path (the same products, but the compiler may fuse
    multiply-adds differently around the added zeros): equal to round-off.
    """
    rng = np.random.default_rng(0)
    n = 64
    R_WA = np.stack([random_rotation(rng) for _ in range(n)])
    R_WB = np.stack([R @ random_rotation(rng, a) for R, a in zip(R_WA, np.linspace(0, 3.1, n), strict=True)])
    p_WA, p_WB = rng.normal(size=(n, 3)), rng.normal(size=(n, 3))
    vel = {k: rng.normal(size=(n, 3)) for k in ("w_WA", "v_WA", "w_WB", "v_WB")}
    K, B = random_spd(rng), random_spd(rng)
    ref_W = mjflex.wrench_on_b(R_WA, p_WA, R_WB, p_WB, K, method=method, B=B, **vel)
    ref_U = mjflex.potential(R_WA, p_WA, R_WB, p_WB, K, method=method)
    W = mjflex.wrench_on_b(R_WA, p_WA, R_WB, p_WB, K, method=method, B=B, **vel, terms=no_terms(method))
    U = mjflex.potential(R_WA, p_WA, R_WB, p_WB, K, method=method, terms=no_terms(method))
    np.testing.assert_array_equal(W, ref_W)
    np.testing.assert_array_equal(U, ref_U)
    basis = polynomial_basis(method, 4)
    zero = mjflex.PolynomialTerms(method, basis, np.zeros(len(basis)))
    W = mjflex.wrench_on_b(R_WA, p_WA, R_WB, p_WB, K, method=method, B=B, **vel, terms=zero)
    U = mjflex.potential(R_WA, p_WA, R_WB, p_WB, K, method=method, terms=zero)
    eps = np.finfo(float).eps
    assert np.all(np.linalg.norm(W - ref_W, axis=1) <= 8 * eps * np.linalg.norm(ref_W, axis=1))
    assert np.all(np.abs(U - ref_U) <= 8 * eps * ref_U)


def _quadratic_as_terms(K, method):
    """The quadratic potential written as degree-2 monomials (an independent route to eq. 39/80)."""
    nvar = len(VARIABLES[method])
    zi = list(range(6)) if method == "twist" else [1, 2, 3, 5, 6, 7]
    diag, off = (0.5, 1.0) if method == "twist" else (2.0, 4.0)
    rows, coefs = [], []
    for i in range(6):
        for j in range(i, 6):
            e = np.zeros(nvar, dtype=int)
            e[zi[i]] += 1
            e[zi[j]] += 1
            rows.append(e)
            coefs.append((diag if i == j else off) * K[i, j])
    return mjflex.PolynomialTerms(method, np.array(rows), np.array(coefs))


@pytest.mark.parametrize("method", METHODS)
def test_quadratic_written_as_monomials_matches_K_to_round_off(method):
    """N = 2 through the general monomial code equals the quadratic kernels to round-off."""
    rng = np.random.default_rng(1)
    K = random_spd(rng)
    terms = _quadratic_as_terms(K, method)
    np.testing.assert_allclose(terms.rest_stiffness(), K, rtol=0, atol=1e-14 * np.abs(K).max())
    for angle in [1e-6, 0.4, 1.5, 3.0]:
        R_WA, p_WA, R_WB, p_WB = _state(rng, angle)
        W_ref = mjflex.wrench_on_b(R_WA, p_WA, R_WB, p_WB, K, method=method)
        W = mjflex.wrench_on_b(R_WA, p_WA, R_WB, p_WB, np.zeros((6, 6)), method=method, terms=terms)
        # different summation order of the same products: a few ulps of the largest entry
        assert np.linalg.norm(W - W_ref) <= 1e-13 * np.linalg.norm(W_ref)
        U_ref = mjflex.potential(R_WA, p_WA, R_WB, p_WB, K, method=method)
        U = mjflex.potential(R_WA, p_WA, R_WB, p_WB, np.zeros((6, 6)), method=method, terms=terms)
        assert abs(U - U_ref) <= 1e-13 * U_ref


# --------------------------------------------------------------------------- energy consistency


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("angle", [1e-4, 0.3, 1.2, 2.5, 3.1])
def test_wrench_is_minus_gradient_of_polynomial_energy(method, angle):
    """Ridders differences of the energy under world-frame displacements of B (as for eq. 39/80)."""
    rng = np.random.default_rng(int(angle * 1e4))
    K, terms = random_spd(rng), _terms(method, rng, order=6 if method == "twist" else 4)
    R_WA, p_WA, R_WB, p_WB = _state(rng, angle)
    W = mjflex.wrench_on_b(R_WA, p_WA, R_WB, p_WB, K, method=method, terms=terms)

    def energy(R, p):
        return mjflex.potential(R_WA, p_WA, R, p, K, method=method, terms=terms)

    g = gradient_wrt_b(energy, R_WB, p_WB, min(1e-3, 0.1 * (np.pi - angle), 0.1 * max(angle, 0.3)), 1e-3)
    # Ridders' error estimate is ~1e-10 here; the wrench itself is exact to round-off
    assert np.linalg.norm(W + g) <= 1e-8 * np.linalg.norm(W)


@pytest.mark.parametrize("method", METHODS)
def test_terms_leave_rest_and_stiffness_at_rest_unchanged(method):
    """Basis terms are at least cubic: zero wrench at rest and W ~ -K delta for small delta."""
    rng = np.random.default_rng(2)
    K, terms = random_spd(rng), _terms(method, rng)
    np.testing.assert_array_equal(terms.rest_stiffness(), 0.0)
    R, p = random_rotation(rng), rng.normal(size=3)
    assert np.all(mjflex.wrench_on_b(R, p, R, p, K, method=method, terms=terms) == 0.0)
    for eps in [1e-3, 1e-5]:
        delta = eps * rng.normal(size=6)
        R_WB, p_WB = R @ rot_exp(delta[:3]), p + R @ delta[3:]
        W = mjflex.wrench_on_b(R, p, R_WB, p_WB, K, method=method, terms=terms)
        ref = np.kron(np.eye(2), R_WB) @ (-K @ delta)
        assert np.linalg.norm(W - ref) <= 30 * eps * np.linalg.norm(ref)


@pytest.mark.parametrize("method", METHODS)
def test_rest_stiffness_of_quadratic_like_terms(method):
    """Terms with a quadratic part at rest (sigma^2, sigma s', z_i z_j) add rest_stiffness() to K."""
    rng = np.random.default_rng(3)
    if method == "twist":
        e = np.array([[2, 0, 0, 0, 0, 0], [0, 1, 0, 0, 1, 0], [0, 0, 0, 0, 0, 3]])
    else:  # sigma^2, sigma s', sigma^2 xi_1 xi_2 (= xi_1 xi_2 (1 - |xi|^2)), xi_3 x'_3
        e = np.array(
            [[2, 0, 0, 0, 0, 0, 0, 0], [1, 0, 0, 0, 1, 0, 0, 0], [2, 1, 1, 0, 0, 0, 0, 0], [0, 0, 0, 1, 0, 0, 0, 1]]
        )
    terms = mjflex.PolynomialTerms(method, e, rng.uniform(0.5, 1.0, size=len(e)))
    K = random_spd(rng, cond=5.0) * 10
    K_rest = K + terms.rest_stiffness()
    R, p = random_rotation(rng), rng.normal(size=3)
    eps = 1e-6
    delta = eps * rng.normal(size=6)
    R_WB, p_WB = R @ rot_exp(delta[:3]), p + R @ delta[3:]
    W = mjflex.wrench_on_b(R, p, R_WB, p_WB, K, method=method, terms=terms)
    ref = np.kron(np.eye(2), R_WB) @ (-K_rest @ delta)
    assert np.linalg.norm(W - ref) <= 30 * eps * np.linalg.norm(ref)
    assert np.linalg.norm(terms.rest_stiffness()) > 0.1


# --------------------------------------------------------------------------- invariance


@pytest.mark.parametrize("method", METHODS)
def test_common_motion_of_both_bodies(method):
    """Global invariance: energy unchanged, wrench rotates with the motion."""
    rng = np.random.default_rng(4)
    K, terms = random_spd(rng), _terms(method, rng)
    for _ in range(10):
        R_WA, p_WA, R_WB, p_WB = _state(rng, rng.uniform(0, 3.0))
        Q, d = random_rotation(rng), rng.normal(size=3)
        U = mjflex.potential(R_WA, p_WA, R_WB, p_WB, K, method=method, terms=terms)
        U2 = mjflex.potential(Q @ R_WA, Q @ p_WA + d, Q @ R_WB, Q @ p_WB + d, K, method=method, terms=terms)
        assert abs(U2 - U) <= 1e-12 * abs(U)
        W = mjflex.wrench_on_b(R_WA, p_WA, R_WB, p_WB, K, method=method, terms=terms)
        W2 = mjflex.wrench_on_b(Q @ R_WA, Q @ p_WA + d, Q @ R_WB, Q @ p_WB + d, K, method=method, terms=terms)
        assert np.linalg.norm(W2 - np.kron(np.eye(2), Q) @ W) <= 1e-12 * np.linalg.norm(W)


@pytest.mark.parametrize("method", METHODS)
def test_exchanging_the_bodies_with_reversed_terms(method):
    """Which body is the reference does not matter: reversed() gives the same energy and wrench pair."""
    rng = np.random.default_rng(5)
    K, terms = random_spd(rng), _terms(method, rng)
    back = terms.reversed()
    assert np.any(back.coefficients != terms.coefficients)  # odd terms change sign
    np.testing.assert_array_equal(back.reversed().coefficients, terms.coefficients)
    for _ in range(10):
        R_WA, p_WA, R_WB, p_WB = _state(rng, rng.uniform(0, 3.0))
        U_ab = mjflex.potential(R_WA, p_WA, R_WB, p_WB, K, method=method, terms=terms)
        U_ba = mjflex.potential(R_WB, p_WB, R_WA, p_WA, K, method=method, terms=back)
        assert abs(U_ab - U_ba) <= 1e-12 * abs(U_ab)
        W_b = mjflex.wrench_on_b(R_WA, p_WA, R_WB, p_WB, K, method=method, terms=terms)
        W_a = mjflex.wrench_on_b(R_WB, p_WB, R_WA, p_WA, K, method=method, terms=back)
        assert np.linalg.norm(_shift(W_a, p_WB - p_WA) + W_b) <= 1e-12 * np.linalg.norm(W_b)


@pytest.mark.parametrize("method", METHODS)
def test_other_element_frames_give_a_polynomial_of_the_same_order(method):
    """Eq. 69: frames a F, b F see a polynomial of the same order; energy and wrench agree at new points."""
    rng = np.random.default_rng(6)
    K, terms = random_spd(rng), _terms(method, rng)
    R_F, p_F = random_rotation(rng), 0.2 * rng.normal(size=3)
    K2, terms2 = mjflex.potential_in_frame(K, terms, R_F, p_F)
    assert terms2.order == terms.order
    for _ in range(10):
        R_WA, p_WA, R_WB, p_WB = _state(rng, rng.uniform(0, 2.0))
        new = (R_WA @ R_F, p_WA + R_WA @ p_F, R_WB @ R_F, p_WB + R_WB @ p_F)
        U = mjflex.potential(R_WA, p_WA, R_WB, p_WB, K, method=method, terms=terms)
        U2 = mjflex.potential(*new, K2, method=method, terms=terms2)
        assert abs(U2 - U) <= 1e-9 * abs(U)
        W = mjflex.wrench_on_b(R_WA, p_WA, R_WB, p_WB, K, method=method, terms=terms)
        W2 = mjflex.wrench_on_b(*new, K2, method=method, terms=terms2)
        assert np.linalg.norm(_shift(W2, p_WB - new[3]) - W) <= 1e-9 * np.linalg.norm(W)


# --------------------------------------------------------------------------- the wrench maps of the paper


def _random_poses(rng, n, angle_max=3.1, trans=0.5):
    R = np.stack([random_rotation(rng, a) for a in rng.uniform(0, angle_max, n)])
    return R, trans * rng.normal(size=(n, 3))


def test_dualquat_wrench_map_is_eq_116_with_a_two_dimensional_workless_null_space():
    rng = np.random.default_rng(7)
    R, p = _random_poses(rng, 20)
    R[0] = rot_exp(np.pi * np.array([0.0, 0.6, 0.8]))  # sigma = 0: the footnote's other case
    q = mjflex.dual_quaternion_from_transform(R, p)
    # a linear monomial z_k is a unit generalized force along z_k: its wrench is -1/2 Lambda~ e_k
    W, _ = design_matrix(R, p, "dualquat", np.eye(8, dtype=int))
    Nw = mjflex.workless_generalized_forces(q)
    for i in range(len(q)):
        L = lambda_tilde(q[i])
        np.testing.assert_allclose(W[i], -0.5 * L, rtol=0, atol=1e-15)
        assert np.linalg.matrix_rank(L) == 6
        np.testing.assert_allclose(L @ Nw[i].T, 0.0, atol=1e-15)
        assert np.linalg.matrix_rank(Nw[i]) == 2
        # eq. 117 is a right inverse of the map: the paper's generalized forces reproduce the wrench
        A, C = L[:3, :4], L[:3, 4:]
        P = 2.0 * np.block([[A.T, C.T], [np.zeros((4, 3)), A.T]])
        np.testing.assert_allclose(0.5 * L @ P, np.eye(6), atol=1e-14)


def _jl(tau):
    """Left Jacobian of SO(3) = S of eq. 19 (complex-step safe)."""
    a2 = tau @ tau
    a = np.sqrt(a2)
    T = hat(tau)
    return np.eye(3) + (1 - np.cos(a)) / a2 * T + (a - np.sin(a)) / (a2 * a) * (T @ T)


def test_twist_wrench_map_inverts_eq_78():
    """-Gamma of the kernel times Gamma^-1 = [[pr S, du S], [0, pr S]] (eqs 78-79) is -I."""
    rng = np.random.default_rng(8)
    R, p = _random_poses(rng, 20, angle_max=3.0)
    W, _ = design_matrix(R, p, "twist", np.eye(6, dtype=int))
    xi = mjflex.twist_from_transform(R, p)
    for i in range(len(xi)):
        tau, t = xi[i, :3], xi[i, 3:]
        h = 1e-30  # complex step: du S = d/deps S(tau + eps t), exact to round-off
        S_du = _jl(tau.astype(complex) + 1j * h * t).imag / h
        G_inv = np.block([[_jl(tau), S_du], [np.zeros((3, 3)), _jl(tau)]])
        np.testing.assert_allclose(W[i] @ G_inv, -np.eye(6), atol=1e-13)


def test_polynomials_constant_on_unit_dual_quaternions_exert_nothing():
    """Footnote 4 at the level of coefficients: multiples of the two constraints give no energy or wrench."""
    rng = np.random.default_rng(9)
    # xi_1^2 (sigma^2 + |xi|^2 - 1) + 3 x'_2 xi_3 (sigma s' + xi . x')
    e = np.zeros((9, 8), dtype=int)
    e[0, [0, 1]] = [2, 2]
    e[1, 1] = 4
    e[2, [1, 2]] = 2
    e[3, [1, 3]] = 2
    e[4, 1] = 2
    for r, (a, b) in enumerate([(0, 4), (1, 5), (2, 6), (3, 7)]):
        e[5 + r, [a, b]] += 1
        e[5 + r, [6, 3]] += 1
    c = np.array([1.0, 1.0, 1.0, 1.0, -1.0, 3.0, 3.0, 3.0, 3.0])
    terms = mjflex.PolynomialTerms("dualquat", e, c)
    R, p = _random_poses(rng, 50)
    W, V = design_matrix(R, p, "dualquat", terms.exponents, terms.coefficients)
    assert np.abs(W.sum(axis=2)).max() <= 1e-13 * np.abs(W).max()
    assert np.abs(V.sum(axis=1)).max() <= 1e-13 * np.abs(V).max()


def _manifold_rank(method, exps, R, p):
    _, V = design_matrix(R, p, method, exps)
    assert np.all(np.linalg.norm(V, axis=0) > 0)
    s = np.linalg.svd(V / np.linalg.norm(V, axis=0), compute_uv=False)
    return int(np.sum(s > 1e-9 * s[0])), s


@pytest.mark.parametrize("variables", [None, (2, 3, 4), (0, 1, 2), (0, 3, 4, 5)])
def test_dualquat_basis_is_independent_and_complete(variables):
    """Standard monomials (+ the K quadratics) are independent functions; non-standard ones are not new."""
    rng = np.random.default_rng(10)
    basis = polynomial_basis("dualquat", 4, variables)
    v = list(range(6)) if variables is None else list(variables)
    quad = [np.bincount([a, b], minlength=8) for i, a in enumerate([[1, 2, 3, 5, 6, 7][k] for k in v])
            for b in [[1, 2, 3, 5, 6, 7][k] for k in v][i:]]  # fmt: skip
    exps = np.concatenate([np.array(quad), basis])
    # poses that move only along the variables: exp of a twist with the others zero
    n = 3 * len(exps)
    xi = np.zeros((n, 6))
    xi[:, v] = rng.uniform(-1.2, 1.2, size=(n, len(v)))
    R, p = mjflex.transform_from_twist(xi)
    rank, s = _manifold_rank("dualquat", exps, R, p)
    assert rank == len(exps), f"standard monomials dependent: singular values {s[-3:]}"
    # sigma^2 z_j z_k and sigma s' z_j z_k reduce to standard monomials: adding them adds nothing
    j, k = [[1, 2, 3, 5, 6, 7][i] for i in v][:2]
    extras = [[0, 0, j, k]] + ([[0, 4, j, k]] if 4 in coordinate_indices("dualquat", variables) else [])
    for extra in extras:
        rank2, _ = _manifold_rank("dualquat", np.concatenate([exps, [np.bincount(extra, minlength=8)]]), R, p)
        assert rank2 == len(exps)


def test_basis_sizes():
    """Twist: all monomials of degree 3..N in 6 variables; dual quaternion: counted by hand for N = 4."""
    from math import comb

    for N in (3, 4, 6):
        assert len(polynomial_basis("twist", N)) == sum(comb(d + 5, 5) for d in range(3, N + 1))
    assert len(polynomial_basis("twist", 4, (2, 3, 4))) == comb(5, 2) + comb(6, 2)
    assert len(polynomial_basis("dualquat", 2)) == 0
    # planar (sigma, xi_3, x'_1, x'_2; s' = 0): degree 4 in (xi_3, x'_1, x'_2) times 1 or sigma (degree 3);
    # degree 2 has none (the quadratics are K, sigma xi_3 and sigma x'_j stress the element)
    assert len(polynomial_basis("dualquat", 4, (2, 3, 4))) == comb(6, 2) + comb(5, 2)


# --------------------------------------------------------------------------- validation


@pytest.mark.parametrize(
    ("method", "exponents", "coefficients", "match"),
    [
        ("twist", [[1, 0, 0, 0, 0, 0]], [1.0], "linear term"),
        ("twist", [[0, 0, 0, 0, 0, 0]], [1.0], "constant"),
        ("dualquat", [[0, 1, 1, 1, 0, 0, 0, 0]], [1.0], "odd degree"),
        ("dualquat", [[1, 1, 0, 0, 0, 0, 0, 0]], [1.0], "stressed at rest"),
        ("twist", [[3, 0, 0, 0, 0, 0], [3, 0, 0, 0, 0, 0]], [1.0, 2.0], "repeats"),
        ("twist", [[3, 0, 0, 0, 0]], [1.0], "shape"),
        ("twist", [[1.5, 1.5, 0, 0, 0, 0]], [1.0], "integer"),
        ("twist", [[3, 0, 0, 0, 0, 0]], [np.nan], "non-finite"),
        ("twist", [[3, 0, 0, 0, 0, 0]], [1.0, 2.0], "one per row"),
        ("twist", [[-1, 4, 0, 0, 0, 0]], [1.0], "integers in"),
        ("quat", [[3, 0, 0, 0, 0, 0]], [1.0], "method"),
    ],
)
def test_bad_terms_are_rejected(method, exponents, coefficients, match):
    with pytest.raises(ValueError, match=match):
        mjflex.PolynomialTerms(method, exponents, coefficients)


def test_sigma_terms_that_cancel_at_rest_are_accepted():
    """sigma^3 xi_1 - sigma xi_1 = -|xi|^2 sigma xi_1 on unit quaternions: no stress at rest."""
    t = mjflex.PolynomialTerms("dualquat", [[3, 1, 0, 0, 0, 0, 0, 0], [1, 1, 0, 0, 0, 0, 0, 0]], [2.0, -2.0])
    R = np.eye(3)
    assert np.all(mjflex.wrench_on_b(R, np.zeros(3), R, np.zeros(3), np.eye(6), method="dualquat", terms=t) == 0)


def test_terms_must_match_the_method_and_keep_the_rest_stiffness_psd():
    rng = np.random.default_rng(11)
    R, p = random_rotation(rng), rng.normal(size=3)
    terms = _terms("twist", rng)
    with pytest.raises(ValueError, match="method='twist'"):
        mjflex.wrench_on_b(R, p, R, p, np.eye(6), method="dualquat", terms=terms)
    with pytest.raises(ValueError, match="PolynomialTerms"):
        mjflex.potential(R, p, R, p, np.eye(6), terms={"exponents": [[3, 0, 0, 0, 0, 0]]})
    soft = mjflex.PolynomialTerms("twist", [[2, 0, 0, 0, 0, 0]], [-1.0])  # -tau_1^2 beats K_11 = 1
    with pytest.raises(ValueError, match=r"K \+ terms.rest_stiffness\(\).* is not positive semi-definite"):
        mjflex.wrench_on_b(R, p, R, p, np.eye(6), terms=soft)


@pytest.mark.parametrize("method", METHODS)
def test_terms_round_trip_through_json(method):
    import json

    rng = np.random.default_rng(12)
    t = _terms(method, rng)
    back = mjflex.PolynomialTerms.from_dict(json.loads(json.dumps(t.to_dict())))
    np.testing.assert_array_equal(back.exponents, t.exponents)
    np.testing.assert_array_equal(back.coefficients, t.coefficients)
    assert back.method == method and back.order == 4
    assert mjflex.PolynomialTerms.from_dict(no_terms(method).to_dict()).order == 2


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("m", [(1, -1, 1), (1, -1, -1)])
def test_symmetric_basis_keeps_exactly_the_invariant_terms(method, m):
    """A mirror plane or half turn diag(m) maps X_ab to M X_ab M: kept terms are invariant, dropped ones odd."""
    rng = np.random.default_rng(13)
    R, p = _random_poses(rng, 30, angle_max=2.5)
    M = np.diag(np.asarray(m, dtype=float))
    R_m, p_m = M @ R @ M, p @ M
    full = polynomial_basis(method, 4)
    kept = polynomial_basis(method, 4, symmetries=[m])
    assert 0 < len(kept) < len(full)
    _, V = design_matrix(R, p, method, full)
    _, V_m = design_matrix(R_m, p_m, method, full)
    invariant = {tuple(e) for e in kept}
    for k, e in enumerate(full):
        expected = V[:, k] if tuple(e) in invariant else -V[:, k]
        np.testing.assert_allclose(V_m[:, k], expected, rtol=1e-12, atol=1e-14 * np.abs(V[:, k]).max())


def test_symmetries_are_checked():
    with pytest.raises(ValueError, match=r"3 signs \(\+1 or -1\)"):
        polynomial_basis("twist", 4, symmetries=[(1, 0, 1)])

"""Identification of polynomial potentials: round trips, statistics, the paper's route, degenerate data.

Independent references: the model wrenches are generated with ``mjflex.wrench_on_b`` (the per-step
code path, not the design kernel the fit uses); the expected covariance is assembled here from
single-term potentials; the paper's generalized-force route (eq. 117 plus the workless directions
of footnote 4) and the ridge solution are solved here with ``numpy.linalg.lstsq``.
"""

import warnings

import numpy as np
import pytest

import mjflex
from mjflex.core.polynomial import coordinate_indices, polynomial_basis
from tests.helpers import lambda_tilde, random_spd

SCALES = np.array([0.4, 0.4, 0.4, 1e-3, 1e-3, 1e-3])  # rad, m: a flexure's working range
K_SCALES = [1.0, 1.0, 1.0, 3e2, 3e2, 3e2]  # sqrt of N m/rad and N/m


def _model(method, order, rng, variables=None):
    """K in physical units and terms that change the wrench by tens of % at the edge of the range."""
    K = random_spd(rng, cond=10.0, scales=K_SCALES)
    if variables is not None:
        v = list(variables)
        Kv = np.zeros((6, 6))
        Kv[np.ix_(v, v)] = K[np.ix_(v, v)]
        K = Kv
    e = polynomial_basis(method, order, variables)
    # range of each coordinate z: twist as SCALES; dual quaternion sigma ~ 1, s' ~ xi x', xi, x' halved
    zr = SCALES if method == "twist" else np.array([1.0, *SCALES[:3] / 2, 0.1 * 2e-4, *SCALES[3:] / 2])
    U0 = 0.5 * np.sum(np.diag(K) * SCALES**2) / 6
    mag = rng.uniform(0.1, 0.5, len(e)) * rng.choice([-1.0, 1.0], len(e))
    return K, mjflex.PolynomialTerms(method, e, mag * U0 / np.prod(zr**e, axis=1))


def _samples(rng, n, variables=None):
    xi = rng.uniform(-1, 1, size=(n, 6)) * SCALES
    if variables is not None:
        mask = np.zeros(6, dtype=bool)
        mask[list(variables)] = True
        xi[:, ~mask] = 0.0
    return mjflex.transform_from_twist(xi)


def _wrench_b(R, p, K, method, terms, check=True):
    """Wrench on B in b axes, through the element API (A at the origin); ``check=False`` for indefinite K."""
    W = mjflex.wrench_on_b(np.eye(3), np.zeros(3), R, p, K, method=method, terms=terms, check=check)
    Rt = np.swapaxes(R, -1, -2)
    return np.concatenate([(Rt @ W[:, :3, None])[..., 0], (Rt @ W[:, 3:, None])[..., 0]], axis=1)


def _true_parameters(K, terms, variables=None):
    v = list(range(6)) if variables is None else list(variables)
    return np.concatenate([[K[i, j] for a, i in enumerate(v) for j in v[a:]], terms.coefficients])


@pytest.mark.parametrize(
    ("method", "order", "variables"),
    [("twist", 4, None), ("dualquat", 4, None), ("twist", 6, (2, 3, 4)), ("dualquat", 6, (2, 3, 4))],
)
def test_noiseless_round_trip_recovers_every_coefficient(method, order, variables):
    rng = np.random.default_rng(order)
    K, terms = _model(method, order, rng, variables)
    R, p = _samples(rng, 150, variables)
    W = _wrench_b(R, p, K, method, terms)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        fit = mjflex.fit_potential(R, p, W, method=method, order=order, variables=variables)
    truth = _true_parameters(K, terms, variables)
    err = np.abs(fit.parameters - truth) / np.abs(truth)
    assert err.max() <= 1e-9, f"worst {fit.parameter_names[err.argmax()]}: {err.max():.3g}"
    assert fit.rank == len(truth) and fit.condition < 1e6
    np.testing.assert_allclose(fit.K, K, rtol=0, atol=1e-9 * np.abs(K).max())
    assert fit.relative_residual <= 1e-12
    # the same data given in a axes
    W_a = mjflex.wrench_on_b(np.eye(3), np.zeros(3), R, p, K, method=method, terms=terms)
    fit_a = mjflex.fit_potential(R, p, W_a, method=method, order=order, variables=variables, wrench_frame="a")
    assert np.abs(fit_a.parameters - truth).max() <= 1e-9 * np.abs(truth).max()
    np.testing.assert_allclose(fit_a.predict(R, p, wrench_frame="a"), W_a, rtol=0, atol=1e-10 * np.abs(W_a).max())


def _expected_covariance(R, p, method, K, terms, variables, w):
    """(A^T W^2 A)^-1 with the columns of A from single-parameter potentials via wrench_on_b."""
    cols = []
    v = list(range(6)) if variables is None else list(variables)
    zero_terms = mjflex.PolynomialTerms(method, terms.exponents[:0], np.zeros(0))
    for a, i in enumerate(v):
        for j in v[a:]:
            E = np.zeros((6, 6))
            E[i, j] = E[j, i] = 1.0
            cols.append(_wrench_b(R, p, E, method, zero_terms, check=False))
    for e in terms.exponents:
        cols.append(_wrench_b(R, p, np.zeros((6, 6)), method, mjflex.PolynomialTerms(method, [e], [1.0])))
    A = np.stack([c.reshape(-1) for c in cols], axis=1) * np.tile(w, len(R))[:, None]
    return np.linalg.inv(A.T @ A)


@pytest.mark.parametrize(("method", "order", "variables"), [("twist", 4, (2, 3, 4)), ("dualquat", 4, (0, 2, 3, 4))])
def test_noisy_fits_scatter_as_the_expected_covariance(method, order, variables):
    """Gaussian wrench noise: estimates scatter with (A^T W^2 A)^-1, and the fit reports that covariance."""
    rng = np.random.default_rng(20)
    K, terms = _model(method, order, rng, variables)
    R, p = _samples(rng, 120, variables)
    W = _wrench_b(R, p, K, method, terms)
    sd = 0.01 * np.sqrt(np.mean(W**2, axis=0)).clip(1e-6)  # 1 % of each component's RMS
    truth = _true_parameters(K, terms, variables)
    C = _expected_covariance(R, p, method, K, terms, variables, 1 / sd)
    Ci = np.linalg.inv(C)
    reps, chi2, s2 = 25, [], []
    for _ in range(reps):
        noisy = W + sd * rng.normal(size=W.shape)
        fit = mjflex.fit_potential(R, p, noisy, method=method, order=order, variables=variables, weights=1 / sd)
        d = fit.parameters - truth
        chi2.append(d @ Ci @ d)
        s2.append(np.sum((fit.residuals / sd) ** 2) / fit.dof)
    n_par = len(truth)
    # mean of chi^2/p over reps is 1 with standard deviation sqrt(2 / (p reps)); 4 sigma
    assert abs(np.mean(chi2) / n_par - 1) <= 4 * np.sqrt(2 / (n_par * reps))
    # the residual variance estimates the noise variance: 1 within 4 sigma of its mean
    assert abs(np.mean(s2) - 1) <= 4 * np.sqrt(2 / (fit.dof * reps))
    # reported covariance: s^2 C (estimated scale) or exactly C with absolute weights
    np.testing.assert_allclose(fit.covariance, s2[-1] * C, rtol=1e-7, atol=0)
    abs_fit = mjflex.fit_potential(R, p, noisy, method=method, order=order, variables=variables,
                                   weights=1 / sd, absolute_weights=True)  # fmt: skip
    np.testing.assert_allclose(abs_fit.covariance, C, rtol=1e-7, atol=0)


def _monomial_gradients(q, exps):
    """d(z^e)/dz for each sample and monomial, shape (n, 8, M) (numpy, independent of the kernels)."""
    G = np.zeros((len(q), q.shape[1], len(exps)))
    for k in range(q.shape[1]):
        lowered = exps.copy()
        lowered[:, k] -= 1
        ok = exps[:, k] > 0
        G[:, k, ok] = exps[ok, k] * np.prod(q[:, None, :] ** lowered[None, ok].clip(0), axis=2)
    return G


def test_papers_generalized_force_route_needs_the_workless_multipliers():
    """Eq. 117 then fit grad U: only with two free workless multipliers per sample (footnote 4) is it exact."""
    rng = np.random.default_rng(21)
    method, order = "dualquat", 4
    K, terms = _model(method, order, rng, (0, 1, 2, 3, 4))
    R, p = _samples(rng, 80, (0, 1, 2, 3, 4))
    W = _wrench_b(R, p, K, method, terms)
    q = mjflex.dual_quaternion_from_transform(R, p)
    zi = [1, 2, 3, 5, 6]
    k_rows = [np.bincount([zi[a], b], minlength=8) for a in range(5) for b in zi[a:]]
    k_fac = [2.0 if zi[a] == b else 4.0 for a in range(5) for b in zi[a:]]
    exps = np.concatenate([np.array(k_rows), terms.exponents])
    G = _monomial_gradients(q, exps) * np.concatenate([k_fac, np.ones(len(terms))])
    g = np.stack([-_eq117(qi) @ Wi for qi, Wi in zip(q, W, strict=True)])  # our sign: W = -1/2 L g
    Nw = mjflex.workless_generalized_forces(q)
    n, P = len(q), exps.shape[0]
    A = np.zeros((8 * n, P + 2 * n))
    A[:, :P] = G.transpose(0, 1, 2).reshape(8 * n, P)
    for i in range(n):
        A[8 * i : 8 * i + 8, P + 2 * i : P + 2 * i + 2] = -Nw[i].T
    D = np.linalg.norm(A, axis=0)  # equilibrate: coefficients span many decades
    x, *_ = np.linalg.lstsq(A / D, g.reshape(-1), rcond=None)
    x = x / D
    truth = _true_parameters(K, terms, (0, 1, 2, 3, 4))
    assert np.abs(x[:P] - truth).max() <= 1e-8 * np.abs(truth).max()
    fit = mjflex.fit_potential(R, p, W, method=method, order=order, variables=(0, 1, 2, 3, 4))
    assert np.abs(fit.parameters - x[:P]).max() <= 1e-8 * np.abs(truth).max()
    # without the multipliers the eq. 117 forces are not gradients of any polynomial of the basis
    y, *_ = np.linalg.lstsq(A[:, :P] / D[:P], g.reshape(-1), rcond=None)
    assert np.linalg.norm(A[:, :P] @ (y / D[:P]) - g.reshape(-1)) > 1e-3 * np.linalg.norm(g)


def _eq117(q):
    """The paper's map from wrench to generalized forces (a right inverse of 1/2 Lambda~)."""
    L = lambda_tilde(q)
    A, C = L[:3, :4], L[:3, 4:]
    return 2.0 * np.block([[A.T, C.T], [np.zeros((4, 3)), A.T]])


def test_known_stiffness_fits_only_the_terms_and_ridge_matches_the_augmented_system():
    rng = np.random.default_rng(22)
    K, terms = _model("twist", 4, rng, (2, 3, 4))
    R, p = _samples(rng, 60, (2, 3, 4))
    W = _wrench_b(R, p, K, "twist", terms)
    fit = mjflex.fit_potential(R, p, W, order=4, variables=(2, 3, 4), K=K)
    assert len(fit.parameters) == len(terms)
    assert np.abs(fit.parameters - terms.coefficients).max() <= 1e-9 * np.abs(terms.coefficients).max()
    # ridge: the solution of [A D^-1; lambda I] x = [y; 0], theta = D^-1 x
    noisy = W + 0.05 * np.sqrt(np.mean(W**2, axis=0)) * rng.normal(size=W.shape)
    lam = 0.3
    fit_r = mjflex.fit_potential(R, p, noisy, order=4, variables=(2, 3, 4), ridge=lam)
    plain = mjflex.fit_potential(R, p, noisy, order=4, variables=(2, 3, 4))
    A = np.kron(np.eye(len(R)), plain.weights) @ _design(R, p, plain)
    D = np.linalg.norm(A, axis=0)
    aug = np.vstack([A / D, lam * np.eye(len(D))])
    x, *_ = np.linalg.lstsq(aug, np.concatenate([(noisy @ plain.weights.T).reshape(-1), np.zeros(len(D))]), rcond=None)
    np.testing.assert_allclose(fit_r.parameters, x / D, rtol=1e-8, atol=1e-12 * np.abs(x / D).max())
    assert np.linalg.norm(fit_r.parameters * D) < np.linalg.norm(plain.parameters * D)
    assert fit_r.relative_residual > plain.relative_residual


def test_matrix_weights_whiten_each_sample():
    """A (6, 6) weight matrix (here compliance weighting by a coupled K0) solves the whitened problem."""
    rng = np.random.default_rng(25)
    K, terms = _model("dualquat", 4, rng, (2, 3, 4))
    R, p = _samples(rng, 50, (2, 3, 4))
    W = _wrench_b(R, p, K, "dualquat", terms)
    noisy = W + 0.02 * np.sqrt(np.mean(W**2, axis=0)) * rng.normal(size=W.shape)
    Wm = np.linalg.inv(np.linalg.cholesky(random_spd(rng, cond=30.0, scales=K_SCALES)))
    fit = mjflex.fit_potential(R, p, noisy, method="dualquat", order=4, variables=(2, 3, 4), weights=Wm)
    A = np.kron(np.eye(len(R)), Wm) @ _design(R, p, fit)
    x, *_ = np.linalg.lstsq(A / np.linalg.norm(A, axis=0), (noisy @ Wm.T).reshape(-1), rcond=None)
    np.testing.assert_allclose(fit.parameters, x / np.linalg.norm(A, axis=0), rtol=1e-8)
    np.testing.assert_array_equal(fit.weights, Wm)
    diag = mjflex.fit_potential(R, p, noisy, method="dualquat", order=4, variables=(2, 3, 4), weights=np.ones(6))
    np.testing.assert_array_equal(diag.weights, np.eye(6))


def _design(R, p, fit):
    """Columns of the fit's unknowns via single-parameter potentials (wrench_on_b)."""
    cols = []
    for name in fit.parameter_names[: len(fit.parameters) - len(fit.terms)]:
        i, j = (int(c) for c in name[2:-1].split(","))
        E = np.zeros((6, 6))
        E[i, j] = E[j, i] = 1.0
        cols.append(_wrench_b(R, p, E, fit.method, None, check=False))
    for e in fit.terms.exponents:
        cols.append(_wrench_b(R, p, np.zeros((6, 6)), fit.method, mjflex.PolynomialTerms(fit.method, [e], [1.0])))
    return np.stack([c.reshape(-1) for c in cols], axis=1)


# --------------------------------------------------------------------------- bad and degenerate data


def _data(n=40, variables=None):
    rng = np.random.default_rng(23)
    K, terms = _model("twist", 4, rng, variables)
    R, p = _samples(rng, n, variables)
    return R, p, _wrench_b(R, p, K, "twist", terms)


@pytest.mark.parametrize(
    ("change", "kwargs", "match"),
    [
        ("nan_wrench", {}, r"wrench contains a non-finite value \(nan at index \[3, 2\]\)"),
        ("nan_p", {}, r"p_ab contains a non-finite value"),
        ("few", {}, r"too few samples: 5 samples give 30 equations for 203 unknowns; pass at least 34"),
        ("line", {}, r"single direction"),
        ("mismatch", {}, r"same number n of samples"),
        ("zero", {}, r"wrench is zero in every sample"),
        (None, {"order": None}, r"pass order="),
        (None, {"ridge": -1.0}, r"ridge must be a finite number >= 0"),
        (None, {"weights": [1, 1, 1, 0, 1, 1]}, r"weights must be 6 positive numbers"),
        (None, {"wrench_frame": "world"}, r"wrench_frame must be 'a' or 'b'"),
        (None, {"variables": (2, 7)}, r"variables must be distinct indices 0..5"),
        (None, {"order": 3, "method": "dualquat"}, r"even"),
    ],
)
def test_degenerate_data_raise_clear_errors(change, kwargs, match):
    R, p, W = _data()
    if change == "nan_wrench":
        W[3, 2] = np.nan
    elif change == "nan_p":
        p[7, 0] = np.inf
    elif change == "few":
        R, p, W = R[:5], p[:5], W[:5]
    elif change == "line":
        xi = np.linspace(-1, 1, 40)[:, None] * SCALES * np.array([0.3, -1, 0.5, 1, 2, -1])
        R, p = mjflex.transform_from_twist(xi)
    elif change == "mismatch":
        W = W[:-1]
    elif change == "zero":
        W = np.zeros_like(W)
    args = {"order": 4} | kwargs
    with pytest.raises(ValueError, match=match):
        mjflex.fit_potential(R, p, W, **args)


def _fit_warnings(*args, **kwargs):
    """The fit and the messages of the FitWarnings it raised."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        fit = mjflex.fit_potential(*args, **kwargs)
    return fit, [str(w.message) for w in caught if issubclass(w.category, mjflex.FitWarning)]


def test_unexcited_directions_warn_and_restricting_variables_fixes_it():
    R, p, W = _data(60, variables=(2, 3, 4))
    fit, messages = _fit_warnings(R, p, W, order=4)
    assert any("do not excite tau_1, tau_2, t_3" in m for m in messages)
    # the couplings of the idle coordinates to the moving ones (e.g. K[0,2]) do act on the samples
    assert any("determine only 88 of 203 unknowns (K[0,0], K[0,1], K[0,5]," in m for m in messages)
    assert fit.rank < len(fit.parameters) and np.isinf(fit.condition)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        fit = mjflex.fit_potential(R, p, W, order=4, variables=(2, 3, 4))
    assert fit.rank == len(fit.parameters)


def test_nearly_collinear_samples_warn_about_conditioning():
    rng = np.random.default_rng(24)
    s = np.linspace(-1, 1, 80)[:, None]
    xi = (s * np.array([0, 0, 1, 1, 0.5, 0]) + 1e-6 * rng.normal(size=(80, 6)) * [0, 0, 1, 1, 1, 0]) * SCALES
    R, p = mjflex.transform_from_twist(xi)
    K = random_spd(rng, cond=10.0, scales=K_SCALES)
    W = _wrench_b(R, p, K, "twist", None)
    _, messages = _fit_warnings(R, p, W, order=4, variables=(2, 3, 4))
    assert any("ill-conditioned" in m or "determine only" in m for m in messages), messages


def test_unstable_data_warn_that_K_is_indefinite():
    R, p, W = _data(60, variables=(2, 3, 4))
    with pytest.warns(mjflex.FitWarning, match=r"not positive semi-definite"):
        fit = mjflex.fit_potential(R, p, -W, order=2, variables=(2, 3, 4))
    with pytest.raises(ValueError, match="not positive semi-definite"):
        mjflex.wrench_on_b(np.eye(3), np.zeros(3), R[0], p[0], fit.K)


def test_basis_coordinates_of_planar_dual_quaternions():
    assert coordinate_indices("dualquat", (2, 3, 4)) == (0, 3, 5, 6)
    assert coordinate_indices("dualquat", (0, 3)) == (0, 1, 4, 5)  # xi_1 and x'_1: s' moves
    assert coordinate_indices("twist", (5, 1)) == (1, 5)


@pytest.mark.parametrize("method", ["twist", "dualquat"])
def test_symmetric_fit_has_fewer_unknowns_and_recovers_a_symmetric_potential(method):
    """Mirror plane x-z: K couples only coordinates of equal parity; the symmetric model is recovered."""
    rng = np.random.default_rng(26)
    sym = [(1, -1, 1)]
    K = random_spd(rng, cond=10.0, scales=K_SCALES)
    signs = np.array([-1, 1, -1, 1, -1, 1])
    K = K * (np.outer(signs, signs) > 0)  # the invariant part (still positive definite: block diagonal)
    e = polynomial_basis(method, 4, symmetries=sym)
    zr = SCALES if method == "twist" else np.array([1.0, *SCALES[:3] / 2, 2e-5, *SCALES[3:] / 2])
    U0 = 0.5 * np.sum(np.diag(K) * SCALES**2) / 6
    terms = mjflex.PolynomialTerms(method, e, rng.uniform(0.1, 0.5, len(e)) * U0 / np.prod(zr**e, axis=1))
    R, p = _samples(rng, 150)
    W = _wrench_b(R, p, K, method, terms)
    fit = mjflex.fit_potential(R, p, W, method=method, order=4, symmetries=sym)
    full = mjflex.fit_potential(R, p, W, method=method, order=4)
    assert len(fit.parameters) < 0.6 * len(full.parameters)
    assert "K[0,3]" in full.parameter_names and "K[0,3]" not in fit.parameter_names
    np.testing.assert_allclose(fit.K, K, rtol=0, atol=1e-9 * np.abs(K).max())
    assert np.abs(fit.terms.coefficients - terms.coefficients).max() <= 1e-9 * np.abs(terms.coefficients).max()

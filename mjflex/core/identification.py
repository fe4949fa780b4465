r"""Identification of polynomial potentials from measured or finite-element data (eqs 77-79, 117).

Data: ``n`` relative poses ``X_ab = (R_ab, p_ab)`` (pose of frame b in frame a, the element
frames that coincide at rest) and the wrench the element exerts on body B at each of them
(a test rig that holds B measures the negative of it). The unknowns are the stiffness at rest
``K`` (symmetric: its upper triangle) and the coefficients of the terms of
:mod:`mjflex.core.polynomial`; the model wrench is linear in them,

    ``W_b = -Gamma_ab grad U(xi)``  (twist)   or   ``W_b = -1/2 Lambda~_ab grad U(q)``  (dual quaternion),

so each sample gives six linear equations ``A_i theta = W_i`` and :func:`fit_potential` solves
them by weighted linear least squares.

The paper maps each wrench to generalized forces first (eq. 77 with ``Gamma^-1`` of eq. 78, or
eq. 117) and then fits ``grad U``. For the twist this is the same fit with other weights. For the
dual quaternion eq. 117 picks one of many generalized forces: any multiple of the two workless
directions of :func:`mjflex.core.polynomial.workless_generalized_forces` may be added per sample
(footnote 4). Fitting wrenches eliminates those two multipliers exactly, and the matching freedom
in the coefficients (polynomials constant on the unit dual quaternions) is removed by fitting only
standard monomials (:func:`mjflex.core.polynomial.polynomial_basis`). The fit is therefore unique
whenever the samples excite every direction.

Scaling: moments and forces have different units, so each sample's six equations are multiplied
by a weight matrix (``weights``; default diagonal, the inverse RMS of the measured moments and of
the measured forces), and the columns of the weighted design matrix are scaled to unit norm before
the SVD; ``condition`` is the condition number of that equilibrated matrix, and ``ridge`` acts on it
(dimensionless). Two choices of ``weights`` have a meaning of their own:

* ``1 / noise standard deviation`` per component, or the inverse Cholesky factor ``C^-1`` of the
  noise covariance ``C C^T``: the fit is then the maximum-likelihood estimate, and with
  ``absolute_weights=True`` its covariance is exact;
* compliance weighting, the inverse Cholesky factor of a stiffness estimate ``K0 = C C^T`` (e.g.
  from :mod:`mjflex.geometry`): the residual norm ``r^T K0^-1 r`` measures each wrench error by
  the displacement it would cause. Fit this way when some directions are much stiffer than others
  (a leaf spring's axial direction), where small pose errors mean large forces but small
  deflection errors.
"""

import warnings
from dataclasses import dataclass

import numpy as np

from . import _poly_kernels as _polyk
from .elements import wrench_on_b
from .polynomial import (
    DQ_DISPLACEMENT,
    VARIABLES,
    PolynomialTerms,
    monomial_names,
    polynomial_basis,
    symmetry_signs,
    variable_indices,
)
from .stiffness import stiffness_in_frame
from .transforms import dual_quaternion_from_transform, transform_from_twist, twist_from_transform
from .validation import as_array, check_psd_matrix, check_rotation, method_code

#: Condition number (of the equilibrated design matrix) above which the fit warns.
CONDITION_WARN = 1e8
#: A displacement coordinate whose RMS is below this fraction of the largest RMS of its kind
#: (rotations, translations) counts as not excited.
EXCITATION_RTOL = 1e-3


class FitWarning(UserWarning):
    """The samples do not determine every coefficient well (see the message)."""


@dataclass(frozen=True, eq=False)
class PotentialFit:
    """A fitted polynomial potential and the quality of the fit.

    Attributes
    ----------
    method : str
        ``"twist"`` or ``"dualquat"``.
    K : ndarray, shape (6, 6)
        Stiffness at rest, element frame, rows ``[rotation; translation]`` (as everywhere).
    terms : PolynomialTerms
        Higher-order terms. Evaluate with ``wrench_on_b(..., fit.K, method=fit.method, terms=fit.terms)``.
    parameter_names : tuple of str
        ``"K[i,j]"`` (``i <= j``) and the term names, in the order of ``parameters``.
    parameters : ndarray, shape (p,)
        The fitted unknowns.
    covariance : ndarray, shape (p, p)
        Their covariance: ``s^2 (A^T A)^-1`` with the weighted design matrix ``A`` and
        ``s^2`` the weighted residual variance, or ``s^2 = 1`` with ``absolute_weights``
        (weights = 1 / noise standard deviation); with ridge, the covariance of the biased
        estimate.
    residuals : ndarray, shape (n, 6)
        Measured minus fitted wrench, in the axes of the input wrench [N m; N].
    rms_residual : ndarray, shape (6,)
        RMS of ``residuals`` per component.
    relative_residual : float
        ``|weighted residual| / |weighted data|``.
    condition : float
        Condition number of the equilibrated weighted design matrix (``inf`` if rank deficient).
    rank : int
        Its numerical rank (``p`` when every unknown is determined).
    singular_values : ndarray
        Its singular values, descending.
    dof : float
        Degrees of freedom of the residual (``6 n`` minus the effective number of parameters).
    weights : ndarray, shape (6, 6)
        The weight matrix applied to each sample's wrench residual (diagonal unless a matrix was given).
    coordinate_range : ndarray, shape (2, 6) or (2, 8)
        Smallest and largest value of each coordinate ``z`` over the samples: the range where
        the potential was fitted.

    Examples
    --------
    :func:`mjflex.fit_potential` returns one. Samples of a quadratic element give its ``K`` back:

    >>> import numpy as np
    >>> import mjflex
    >>> K = np.diag([2.0, 2.0, 1.0, 4e4, 4e4, 1e5])
    >>> rng = np.random.default_rng(0)
    >>> R_ab, p_ab = mjflex.transform_from_twist(rng.uniform(-0.3, 0.3, (50, 6)) * [1, 1, 1, 1e-3, 1e-3, 1e-3])
    >>> W = mjflex.wrench_on_b(np.eye(3), np.zeros(3), R_ab, p_ab, K)  # wrench on B, a axes, about b
    >>> fit = mjflex.fit_potential(R_ab, p_ab, W, order=2, wrench_frame="a")
    >>> fit.method, fit.rank, len(fit.parameters), len(fit.terms)  # the 21 entries of K's upper triangle
    ('twist', 21, 21, 0)
    >>> bool(np.allclose(fit.K, K, rtol=1e-8, atol=1e-8 * K.max())), bool(fit.relative_residual < 1e-10)
    (True, True)
    """

    method: str
    K: np.ndarray
    terms: PolynomialTerms
    parameter_names: tuple
    parameters: np.ndarray
    covariance: np.ndarray
    residuals: np.ndarray
    rms_residual: np.ndarray
    relative_residual: float
    condition: float
    rank: int
    singular_values: np.ndarray
    dof: float
    weights: np.ndarray
    coordinate_range: np.ndarray

    @property
    def order(self) -> int:
        """Order of the fitted potential."""
        return self.terms.order

    def predict(self, R_ab, p_ab, *, wrench_frame="b"):
        """Wrench of the fitted potential on B at relative poses, as in the input data.

        Parameters
        ----------
        R_ab : array_like, shape (..., 3, 3)
            Orientation of frame b in frame a.
        p_ab : array_like, shape (..., 3)
            Origin of b in a coordinates [m].
        wrench_frame : {"b", "a"}
            Axes of the result; the moment is about b's origin in both cases.

        Returns
        -------
        wrench : ndarray, shape (..., 6)
            ``[moment; force]`` on B [N m; N].
        """
        return model_wrench(R_ab, p_ab, self.K, self.method, self.terms, wrench_frame=wrench_frame)

    def summary(self) -> str:
        """A few lines: order, size, residuals and conditioning."""
        return (
            f"{self.method} potential of order {self.order}: {len(self.parameters)} parameters, "
            f"rank {self.rank}, condition {self.condition:.3g}, dof {self.dof:.0f}\n"
            f"relative residual {self.relative_residual:.3g}; RMS residual moment "
            f"{np.array2string(self.rms_residual[:3], precision=3)} N m, force "
            f"{np.array2string(self.rms_residual[3:], precision=3)} N"
        )


def model_wrench(R_ab, p_ab, K, method, terms=None, *, wrench_frame="b"):
    """Wrench on B of the potential ``(K, terms)`` at relative poses (a fixed at the origin).

    Arguments as in :meth:`PotentialFit.predict`; ``K`` shape (6, 6). Returns ``(..., 6)``.
    """
    R_ab = check_rotation(R_ab, "R_ab")
    W = wrench_on_b(np.eye(3), np.zeros(3), R_ab, p_ab, K, method=method, terms=terms)
    return W if wrench_frame == "a" else _rotate(W, R_ab, transpose=True)


def _rotate(W, R, transpose=False):
    Rt = np.swapaxes(R, -1, -2) if transpose else R
    return np.concatenate([(Rt @ W[..., :3, None])[..., 0], (Rt @ W[..., 3:, None])[..., 0]], axis=-1)


# --------------------------------------------------------------------------- the fit


def _samples(R_ab, p_ab, wrench):
    R = check_rotation(R_ab, "R_ab")
    p = as_array(p_ab, "p_ab", (3,))
    W = as_array(wrench, "wrench", (6,))
    if R.ndim != 3 or p.ndim != 2 or W.ndim != 2 or not (len(R) == len(p) == len(W)):
        raise ValueError(
            f"R_ab, p_ab and wrench must hold the same number n of samples, shapes (n, 3, 3), (n, 3), (n, 6); "
            f"got {R.shape}, {p.shape}, {W.shape}"
        )
    return np.ascontiguousarray(R), np.ascontiguousarray(p), np.ascontiguousarray(W)


def _stiffness_monomials(method, variables, symmetries=None):
    """Exponent rows, factors and names of the upper-triangle entries of ``K`` over ``variables``.

    With ``symmetries``, only the entries that couple coordinates of equal sign under each of them.
    """
    nvar = len(VARIABLES[method])
    zi = variables if method == "twist" else [DQ_DISPLACEMENT[i] for i in variables]
    signs = symmetry_signs("twist", symmetries)
    rows, factors, names = [], [], []
    for a, i in enumerate(variables):
        for j in variables[a:]:
            if np.any(signs[:, i] != signs[:, j]):
                continue
            e = np.zeros(nvar, dtype=np.int64)
            e[zi[a]] += 1
            e[zi[variables.index(j)]] += 1
            diag = i == j
            rows.append(e)
            factors.append((0.5 if diag else 1.0) if method == "twist" else (2.0 if diag else 4.0))
            names.append(f"K[{i},{j}]")
    return np.array(rows, dtype=np.int64).reshape(-1, nvar), np.array(factors), names


def design_matrix(R_ab, p_ab, method, exponents, factors=None):
    """Wrench on B (b axes, about b's origin) and value of each monomial at each pose.

    Parameters
    ----------
    R_ab : ndarray, shape (n, 3, 3)
        Orientations of b in a (validated by the caller).
    p_ab : ndarray, shape (n, 3)
        Origins of b in a [m].
    method : {"twist", "dualquat"}
        Coordinates of the monomials.
    exponents : ndarray of int, shape (p, 6) or (p, 8)
        The monomials (any degree; a linear monomial ``z_k`` gives the wrench of a unit
        generalized force along ``z_k``).
    factors : ndarray, shape (p,), optional
        Coefficient of each monomial (default 1).

    Returns
    -------
    wrench : ndarray, shape (n, 6, p)
        ``[moment; force]`` on B of each monomial (as a potential) [N m; N].
    value : ndarray, shape (n, p)
        Its value [J].
    """
    code = method_code(method)
    exps = np.ascontiguousarray(exponents, dtype=np.int64)
    f = np.ones(len(exps)) if factors is None else np.ascontiguousarray(factors, dtype=np.float64)
    W = np.empty((len(R_ab), 6, len(exps)))
    V = np.empty((len(R_ab), len(exps)))
    pw, grad = _polyk.work_arrays(exps)
    _polyk.design_batch(code, np.ascontiguousarray(R_ab), np.ascontiguousarray(p_ab), exps, f, pw, grad, W, V)
    return W, V


def _check_excitation(z, method, variables, n_params):
    """Raise for a single direction, warn for coordinates that the samples do not move."""
    disp = z if method == "twist" else z[:, list(DQ_DISPLACEMENT)]
    disp = disp[:, list(variables)]
    rms = np.sqrt(np.mean(disp**2, axis=0))
    names = [VARIABLES[method][i if method == "twist" else DQ_DISPLACEMENT[i]] for i in variables]
    kind = np.array([i < 3 for i in variables])
    excited = np.zeros(len(variables), dtype=bool)
    for k in (True, False):
        sel = kind == k
        if sel.any() and rms[sel].max() > 0:
            excited[sel] = rms[sel] > EXCITATION_RTOL * rms[sel].max()
    if excited.sum() > 0:
        normalized = disp[:, excited] / rms[excited]
        s = np.linalg.svd(normalized, compute_uv=False)
        directions = int(np.sum(s > 1e-9 * s[0]))
    else:
        directions = 0
    if directions <= 1 and len(variables) > 1:
        raise ValueError(
            f"the samples move along {'no' if directions == 0 else 'a single'} direction of the displacement "
            f"coordinates ({', '.join(names)}): they cannot separate the {n_params} unknowns. Add samples that "
            "move in other directions, or fit a potential of one coordinate with variables=(i,)."
        )
    if not excited.all():
        idle = [n for n, e in zip(names, excited, strict=True) if not e]
        warnings.warn(
            f"the samples do not excite {', '.join(idle)} (RMS below {EXCITATION_RTOL:g} of the largest of "
            "its kind): the stiffness and terms that involve only them are not determined. Pass variables= "
            "with only the excited coordinates (indices 0..5 of [rotation; translation]) and add the missing "
            "stiffness separately, or add samples that move along them.",
            FitWarning,
            stacklevel=3,
        )


def _default_weights(W):
    """Inverse RMS of the measured moments and forces (pooled over components)."""
    rm, rf = np.sqrt(np.mean(W[:, :3] ** 2)), np.sqrt(np.mean(W[:, 3:] ** 2))
    fallback = np.sqrt(np.mean(W**2))
    rm, rf = (rm if rm > 0 else fallback), (rf if rf > 0 else fallback)
    if not fallback > 0:
        raise ValueError("wrench is zero in every sample: the data contain no information about the stiffness.")
    return np.array([1 / rm] * 3 + [1 / rf] * 3)


def _solve(A, y, ridge, absolute):
    """Equilibrated, optionally ridge-regularized least squares; returns the solution and diagnostics."""
    d = np.linalg.norm(A, axis=0)
    d[d == 0] = 1.0
    U, s, Vt = np.linalg.svd(A / d, full_matrices=False)
    tol = s[0] * max(A.shape) * np.finfo(float).eps if s.size else 0.0
    rank = int(np.sum(s > tol))
    filt = s**2 / (s**2 + ridge**2) if ridge > 0 else (s > tol).astype(float)
    inv = np.divide(filt, s, out=np.zeros_like(s), where=s > tol)
    x = Vt.T @ (inv * (U.T @ y))
    theta = x / d
    r = y - A @ theta
    dof = A.shape[0] - filt.sum()
    s2 = 1.0 if absolute else float(r @ r) / max(dof, 1e-300)
    cov = s2 * (Vt.T * inv**2) @ Vt / np.outer(d, d)
    cond = s[0] / s[-1] if s.size and s[-1] > tol else np.inf
    return theta, cov, r, rank, s, cond, dof


def fit_potential(
    R_ab, p_ab, wrench, *, method="twist", order=None, variables=None, symmetries=None, exponents=None,
    K=None, weights=None, absolute_weights=False, ridge=0.0, wrench_frame="b",
):  # fmt: skip
    """Fit a polynomial potential to measured (pose, wrench) samples by linear least squares.

    Parameters
    ----------
    R_ab : array_like, shape (n, 3, 3)
        Orientation of the element frame b (on body B) in frame a (on body A) per sample.
    p_ab : array_like, shape (n, 3)
        Origin of b in a coordinates [m].
    wrench : array_like, shape (n, 6)
        Wrench the element exerts on B, ``[moment about b's origin; force]`` [N m; N], in b axes
        (``wrench_frame="b"``) or a axes (``"a"``).
    method : {"twist", "dualquat"}
        Coordinates of the potential.
    order : int, optional
        Order ``N`` of the general polynomial (:func:`~mjflex.core.polynomial.polynomial_basis`);
        ``2`` fits ``K`` only. Required unless ``exponents`` is given.
    variables : sequence of int, optional
        Displacement coordinates (indices 0..5 of ``[rotation; translation]``) that ``K`` and the
        terms may involve (default all), e.g. ``(2, 3, 4)`` for samples in the x-y plane.
    symmetries : sequence of 3-sequences of +-1, optional
        Symmetries of the flexure in the element frame (mirror planes, half turns; see
        :func:`~mjflex.core.polynomial.symmetry_signs`): ``K`` and the terms are restricted to the
        invariant ones, e.g. ``[(1, -1, 1)]`` for a leaf along x that bends in the x-y plane.
    exponents : array_like of int, shape (M, 6) or (M, 8), optional
        Fit these terms instead of the general polynomial (e.g. a sparse model); used as given
        (``symmetries`` then only restrict ``K``).
    K : array_like, shape (6, 6), optional
        Known stiffness at rest (e.g. from :mod:`mjflex.geometry`): then only the terms are fitted.
    weights : array_like, shape (6,) or (6, 6), optional
        Weight of each wrench component [1/(N m), 1/N], ideally ``1 / noise standard deviation``,
        or a matrix applied to each residual (a whitening matrix, or compliance weighting: module
        docstring). Default: inverse RMS of the measured moments and of the measured forces.
    absolute_weights : bool
        The weights are exactly ``1 / noise standard deviation``: the covariance then uses
        ``s^2 = 1`` instead of the residual variance.
    ridge : float
        Tikhonov parameter of the equilibrated problem (``>= 0``): minimizes
        ``|weighted residual|^2 + ridge^2 |D theta|^2``, ``D`` the column norms.
    wrench_frame : {"b", "a"}
        Axes of ``wrench`` (the moment is about b's origin either way).

    Returns
    -------
    PotentialFit
        Fitted ``K`` and terms with residuals, covariance and conditioning.

    Raises
    ------
    ValueError
        Non-finite or misshapen data (naming the argument and sample), fewer equations than
        unknowns, samples along a single direction, bad options.

    Warns
    -----
    FitWarning
        Coordinates not excited by the samples, a rank-deficient or ill-conditioned design
        (condition above ``CONDITION_WARN``), or a fitted ``K`` that is not positive
        semi-definite.

    Examples
    --------
    >>> import numpy as np
    >>> import mjflex
    >>> rng = np.random.default_rng(0)
    >>> K = np.diag([2.0, 2.0, 1.0, 4e4, 4e4, 1e5])
    >>> true = mjflex.PolynomialTerms("twist", [[0, 0, 4, 0, 0, 0], [0, 0, 2, 2, 0, 0]], [30.0, -2e3])
    >>> R_ab, p_ab = mjflex.transform_from_twist(rng.uniform(-1, 1, (100, 6)) * [0.3, 0.3, 0.8, 2e-3, 2e-3, 1e-3])
    >>> W = mjflex.wrench_on_b(np.eye(3), np.zeros(3), R_ab, p_ab, K, terms=true)  # samples: poses and wrenches
    >>> fit = mjflex.fit_potential(R_ab, p_ab, W, order=4, wrench_frame="a")
    >>> print(np.allclose(fit.K, K, rtol=1e-8), fit.rank == len(fit.parameters))
    True True
    >>> print(f"{fit.terms.coefficients[np.all(fit.terms.exponents == [0, 0, 4, 0, 0, 0], axis=1)][0]:.6f}")
    30.000000
    """
    method_code(method)
    R, p, W = _samples(R_ab, p_ab, wrench)
    if wrench_frame not in ("a", "b"):
        raise ValueError(f"wrench_frame must be 'a' or 'b'; got {wrench_frame!r}")
    if not (np.isscalar(ridge) and np.isfinite(ridge) and ridge >= 0):
        raise ValueError(f"ridge must be a finite number >= 0; got {ridge!r}")
    variables = variable_indices(variables, method)
    exponents, k_rows, k_factors, k_names = _unknowns(method, order, variables, symmetries, exponents, K is None)
    Wb = _rotate(W, R, transpose=True) if wrench_frame == "a" else W
    w = np.diag(_default_weights(Wb)) if weights is None else _weights(weights)
    if K is not None:
        K = check_psd_matrix(K, "K", 6, what="stiffness")
        Wb = Wb - model_wrench(R, p, K, method)
    rows = np.concatenate([k_rows, exponents])
    n_params = len(rows)
    if 6 * len(R) < n_params:
        raise ValueError(
            f"too few samples: {len(R)} samples give {6 * len(R)} equations for {n_params} unknowns; pass at least "
            f"{-(-n_params // 6)} samples (several times that for a reliable fit), or lower the order or restrict "
            "variables."
        )
    z = (twist_from_transform if method == "twist" else dual_quaternion_from_transform)(R, p)  # (n, 6) or (n, 8)
    _check_excitation(z, method, variables, n_params)

    A, _ = design_matrix(R, p, method, rows, np.concatenate([k_factors, np.ones(len(exponents))]))
    Aw = np.einsum("ij,njp->nip", w, A).reshape(-1, n_params)
    yw = (Wb @ w.T).reshape(-1)
    theta, cov, r, rank, s, cond, dof = _solve(Aw, yw, ridge, absolute_weights)
    _warn_conditioning(rank, cond, n_params, k_names + list(monomial_names(exponents, method)), Aw)

    nk = len(k_names)
    K_fit = K if K is not None else _symmetric(theta[:nk], k_names)
    terms = PolynomialTerms(method, exponents, theta[nk:])
    _warn_indefinite(K_fit)
    res = Wb - A @ theta
    if wrench_frame == "a":
        res = _rotate(res, R)
    return PotentialFit(
        method=method, K=K_fit, terms=terms,
        parameter_names=tuple(k_names) + terms.names, parameters=theta, covariance=cov,
        residuals=res, rms_residual=np.sqrt(np.mean(res**2, axis=0)),
        relative_residual=float(np.linalg.norm(r) / max(np.linalg.norm(yw), 1e-300)),
        condition=float(cond), rank=rank, singular_values=s, dof=float(dof), weights=w,
        coordinate_range=np.stack([z.min(axis=0), z.max(axis=0)]),
    )  # fmt: skip


def _unknowns(method, order, variables, symmetries, exponents, fit_K):
    """The terms' exponents and the K entries to fit: ``(exponents, k_rows, k_factors, k_names)``."""
    if exponents is None:
        if order is None:
            raise ValueError("pass order= (the order N of the polynomial) or exponents= (the terms to fit)")
        exponents = polynomial_basis(method, order, variables, symmetries)
    else:
        exponents = PolynomialTerms(method, exponents, np.zeros(len(np.asarray(exponents)))).exponents
    k_rows, k_factors, k_names = _stiffness_monomials(method, list(variables), symmetries)
    if not fit_K:
        k_rows, k_factors, k_names = k_rows[:0], k_factors[:0], []
    if len(k_rows) + len(exponents) == 0:
        raise ValueError("nothing to fit: K is given and the basis has no terms (order 2); pass a higher order.")
    return exponents, k_rows, k_factors, k_names


def _weights(weights):
    """The (6, 6) weight matrix of a vector of 6 positive weights or an invertible matrix."""
    w = as_array(weights, "weights", ())
    if w.shape == (6,) and np.all(w > 0):
        return np.diag(w)
    if w.shape == (6, 6) and np.linalg.matrix_rank(w) == 6:
        return np.array(w, dtype=float)
    raise ValueError(
        "weights must be 6 positive numbers (one per wrench component, ideally 1 / noise std) or an invertible "
        f"(6, 6) matrix (a whitening or compliance weighting, e.g. inv(cholesky(K0))); got shape {w.shape}: {weights!r}"
    )


def _symmetric(values, names):
    """K from its upper-triangle entries named ``"K[i,j]"``."""
    K = np.zeros((6, 6))
    for v, name in zip(values, names, strict=True):
        i, j = (int(c) for c in name[2:-1].split(","))
        K[i, j] = K[j, i] = v
    return K


def _warn_conditioning(rank, cond, n_params, names, A):
    if rank < n_params:
        zero = [n for n, c in zip(names, np.linalg.norm(A, axis=0) == 0, strict=True) if c]
        detail = f" ({', '.join(zero[:8])}{'...' if len(zero) > 8 else ''} act on no sample)" if zero else ""
        warnings.warn(
            f"the samples determine only {rank} of {n_params} unknowns{detail}: the minimum-norm solution is "
            "returned (undetermined combinations set to zero). Add samples along more directions, restrict "
            "variables=, lower the order, or pass ridge=.",
            FitWarning,
            stacklevel=3,
        )
    elif cond > CONDITION_WARN:
        warnings.warn(
            f"the fit is ill-conditioned (condition number {cond:.3g} > {CONDITION_WARN:g}): some coefficients are "
            "poorly determined (see covariance). Spread the samples over a wider range, lower the order, or pass "
            "ridge=.",
            FitWarning,
            stacklevel=3,
        )


def _warn_indefinite(K):
    lam = np.linalg.eigvalsh(K)
    if lam[0] < -1e-10 * max(abs(lam[-1]), 1e-300):
        warnings.warn(
            f"the fitted stiffness at rest K is not positive semi-definite (smallest eigenvalue {lam[0]:.6g}): "
            "the samples do not pin down the behaviour near rest. Add samples at small deflections, pass the "
            "known K=, or lower the order; the element functions reject this K.",
            FitWarning,
            stacklevel=3,
        )


# --------------------------------------------------------------------------- change of frames


def potential_in_frame(K, terms, R_F, p_F, *, seed=0):
    """The same polynomial potential seen from other element frames (the paper's equation 69).

    New frames ``a' = a F`` and ``b' = b F`` (both moved by the same ``F``, so that they still
    coincide at rest) see the displacement ``X_a'b' = F^-1 X_ab F``, whose coordinates are linear
    maps of the old ones, so the potential is a polynomial of the same order in them.

    Parameters
    ----------
    K : array_like, shape (6, 6)
        Stiffness at rest in the old frames.
    terms : PolynomialTerms
        Terms in the old frames.
    R_F : array_like, shape (3, 3)
        Orientation of the new frames relative to the old ones (``R_aa'``).
    p_F : array_like, shape (3,)
        Origin of the new frames in old coordinates (``p_aa'``) [m].
    seed : int
        Seed of the interpolation points (the result does not depend on it beyond round-off).

    Returns
    -------
    K_new : ndarray, shape (6, 6)
        ``Ad_F^T K Ad_F`` (eq. 54) plus whatever quadratic part the terms gain.
    terms_new : PolynomialTerms
        The terms in the general basis of the same order: found by interpolating the energy at
        generic displacements, exact to round-off (a residual above 1e-9 relative raises).

    Examples
    --------
    >>> import numpy as np
    >>> import mjflex
    >>> K = np.diag([2.0, 2.0, 1.0, 4e4, 4e4, 1e5])
    >>> terms = mjflex.PolynomialTerms("twist", [[0, 0, 4, 0, 0, 0]], [30.0])
    >>> K_new, terms_new = mjflex.potential_in_frame(K, terms, np.eye(3), [0.01, 0.0, 0.0])  # frames 1 cm along x
    >>> R_ab, p_ab = mjflex.transform_from_twist([0.0, 0.0, 0.3, 0.001, 0.0, 0.0])
    >>> F = (np.eye(3), np.array([0.01, 0.0, 0.0]))
    >>> U_old = mjflex.potential(np.eye(3), np.zeros(3), R_ab, p_ab, K, terms=terms)
    >>> U_new = mjflex.potential(F[0], F[1], R_ab, p_ab + R_ab @ F[1], K_new, terms=terms_new)
    >>> print(np.isclose(U_new, U_old, rtol=1e-9))  # one potential, two descriptions
    True
    """
    R_F, p_F = check_rotation(R_F, "R_F"), as_array(p_F, "p_F", (3,))
    K_new = stiffness_in_frame(K, R_F, p_F)
    method, order = terms.method, terms.order
    basis = polynomial_basis(method, order)
    k_rows, k_factors, k_names = _stiffness_monomials(method, list(range(6)))
    rows = np.concatenate([k_rows, basis])
    rng = np.random.default_rng(seed)
    xi_new = rng.uniform(-0.8, 0.8, size=(3 * len(rows) + 20, 6))
    R_new, p_new = transform_from_twist(xi_new)
    # the same displacement in the old frames: X_ab = F X_a'b' F^-1
    R_old = R_F @ R_new @ R_F.T
    p_old = (R_F @ p_new[..., None])[..., 0] + p_F - (R_old @ p_F[:, None])[..., 0]
    _, V_old = design_matrix(R_old, p_old, method, terms.exponents, terms.coefficients)
    _, V_new = design_matrix(R_new, p_new, method, rows, np.concatenate([k_factors, np.ones(len(basis))]))
    _, V_rest = design_matrix(np.eye(3)[None], np.zeros((1, 3)), method, terms.exponents, terms.coefficients)
    target = V_old.sum(axis=1) - V_rest.sum()  # U is defined up to a constant (e.g. sigma^2 terms)
    theta, *_ = np.linalg.lstsq(V_new, target, rcond=None)
    err = np.linalg.norm(V_new @ theta - target) / max(np.linalg.norm(target), 1e-300)
    if err > 1e-9:
        raise RuntimeError(f"interpolation of the transformed terms left a relative residual {err:.3g}")
    nk = len(k_rows)
    return K_new + _symmetric(theta[:nk], k_names), PolynomialTerms(method, basis, theta[nk:])

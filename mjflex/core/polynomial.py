r"""Higher-order (polynomial) elastic potentials of an element (paper secs 4.8 and 5.8).

The quadratic potential of :mod:`mjflex.core.elements` is exact only for small deflections.
A polynomial potential of order ``N`` adds terms to it,

    ``U = U_K + sum_m c_m z^e_m``,   ``z^e = prod_k z_k^(e_k)``,

where ``U_K`` is the quadratic potential of the stiffness ``K`` (eq. 39 or eq. 80) and ``z``
are the displacement coordinates of the element (eqs 68, 105):

* ``method="twist"``: ``z = (tau_1, tau_2, tau_3, t_1, t_2, t_3)``, the finite twist;
* ``method="dualquat"``: ``z = (sigma, xi_1, xi_2, xi_3, s', x'_1, x'_2, x'_3)``, the unit dual
  quaternion in the order of :func:`~mjflex.core.transforms.dual_quaternion_from_transform`.

Wrench
------
The generalized forces are ``g = dU/dz`` (eqs 70-75, 107-114). The wrench the element exerts on
B, in b coordinates about b's origin, is ``-Gamma_ab g`` (eq. 76) or ``-1/2 Lambda~_ab g``
(eq. 115) with the 6x8 map (eq. 116)

    ``Lambda~_ab = [[-xi, sigma I - xi^, -x', s' I - x'^], [0, 0, -xi, sigma I - xi^]]``

(columns ``sigma, xi, s', x'``): a body-frame virtual displacement ``delta`` of B changes ``q``
by ``1/2 Lambda~^T delta``, which extends eq. 84 to the scalar parts. With
``g = [0; 4 K [xi; x']]`` this is eq. 87, so the quadratic potential is the case without terms.
(The paper writes the wrench of B on the element, the negative of ours; see
:mod:`mjflex.core.elements`.) The viscous part stays quadratic (``B``).

Workless generalized forces (the paper's footnote 4)
----------------------------------------------------
``Lambda~_ab`` has rank 6 at every displacement; its null space is spanned by
``n_1 = (sigma, xi, 0, 0)`` and ``n_2 = (s', x', sigma, xi)`` (:func:`workless_generalized_forces`),
the gradients of the constraints ``|q_r|^2 = 1`` and ``q_r . q_d = 0`` that make ``q`` a unit
dual quaternion: forces along them do no work on any motion. Hence (i) a measured wrench fixes
the generalized forces only up to such components (eq. 117 picks one; the identification in
:mod:`mjflex.core.identification` fits wrenches, which is the same fit with the two multipliers
of every sample eliminated), and (ii) a polynomial that is constant on the unit dual quaternions,
such as ``sigma^2 + |xi|^2``, exerts no wrench, so coefficients are only unique modulo the ideal
that the two constraints generate. We remove that freedom with the normal form of a Groebner
basis of the ideal in graded reverse lexicographic order ``sigma > s' > xi_1 > xi_2 > xi_3 >
x'_1 > x'_2 > x'_3``: the basis is ``{sigma^2 + |xi|^2 - 1, sigma s' + xi . x',
s' (|xi|^2 - 1) - sigma xi . x'}`` with leading monomials ``sigma^2``, ``sigma s'`` and
``s' xi_f^2`` (``xi_f`` the first rotation coordinate in use), so the *standard* monomials, those
divisible by none of these, are linearly independent functions of the displacement and span all
polynomials of the same degree. :func:`polynomial_basis` returns only standard monomials.

Constraints
-----------
The constant term is arbitrary (zero) and the element must be unstressed at rest: twist terms
have degree >= 2; dual-quaternion terms have even degree (``q`` and ``-q`` are the same
displacement) and the coefficients of ``sigma^k xi_j`` (and of ``sigma^k x'_j``) add up to zero.
Symmetry is built in: each monomial appears once, so the coefficient tensors are symmetric.

Invariance (paper, after eqs 68 and 105)
----------------------------------------
The energy depends only on the relative displacement, so it is unchanged by a common motion of
both bodies. Exchanging the bodies maps the twist to ``-xi`` and the dual quaternion to its
conjugate: :meth:`PolynomialTerms.reversed` gives the terms of the exchanged element (``K`` is
unchanged). Other element frames see coordinates that are linear maps of these, hence a
polynomial of the same order (eq. 69; :func:`mjflex.core.identification.potential_in_frame`).

Validity
--------
A polynomial is fitted over a range of deflections and can do anything outside it; the twist
log changes branch at a half turn, where odd terms jump (like ``K_c``, see
:mod:`mjflex.core.elements`).
"""

import itertools
from dataclasses import dataclass

import numpy as np

from .validation import as_array, method_code, numeric_array

#: Names of the coordinates ``z`` of each method, in order.
VARIABLES = {
    "twist": ("tau_1", "tau_2", "tau_3", "t_1", "t_2", "t_3"),
    "dualquat": ("sigma", "xi_1", "xi_2", "xi_3", "s'", "x'_1", "x'_2", "x'_3"),
}
#: Largest exponent of one coordinate in a term (bounds the kernels' work buffers).
MAX_EXPONENT = 16
#: Relative tolerance of the rest-stress check of dual-quaternion terms.
REST_STRESS_RTOL = 1e-12

_SIGMA, _SDUAL = 0, 4
DQ_DISPLACEMENT = (1, 2, 3, 5, 6, 7)  # z index of xi_1..3, x'_1..3 (the 6 coordinates of K)


@dataclass(frozen=True, eq=False)
class PolynomialTerms:
    """The terms of a polynomial potential beyond its quadratic part ``K``.

    Parameters
    ----------
    method : {"twist", "dualquat"}
        Coordinates of the terms (module docstring).
    exponents : array_like of int, shape (M, 6) or (M, 8)
        Row ``m`` holds the exponents of ``z`` in term ``m`` (6 columns for twist coordinates,
        8 for dual-quaternion coordinates). Rows must be distinct.
    coefficients : array_like, shape (M,)
        Coefficient of each term [J per unit of the coordinates: rad, m].

    Raises
    ------
    ValueError
        Naming the offending row when a term is constant or linear, odd (dual quaternion), a
        duplicate, has an exponent above ``MAX_EXPONENT``, a coefficient is not finite, or the
        terms stress the element at rest.

    Examples
    --------
    >>> import numpy as np
    >>> import mjflex
    >>> terms = mjflex.PolynomialTerms("twist", [[0, 0, 4, 0, 0, 0]], [50.0])  # U += 50 tau_3^4
    >>> K = np.diag([2.0, 2.0, 2.0, 1e4, 1e4, 1e4])
    >>> R_WB, p_WB = mjflex.transform_from_twist([0.0, 0.0, 0.2, 0.0, 0.0, 0.0])
    >>> W = mjflex.wrench_on_b(np.eye(3), np.zeros(3), R_WB, p_WB, K, terms=terms)
    >>> print(f"{W[2]:.4f} N m")  # -(2 * 0.2 + 4 * 50 * 0.2^3)
    -2.0000 N m
    """

    method: str
    exponents: np.ndarray
    coefficients: np.ndarray

    def __post_init__(self):
        method_code(self.method)
        nvar = len(VARIABLES[self.method])
        e = _exponents(self.exponents, nvar, "exponents")
        c = as_array(self.coefficients, "coefficients", ())
        if c.shape != (len(e),):
            raise ValueError(f"coefficients must have shape ({len(e)},), one per row of exponents; got {c.shape}")
        _check_degrees(e, self.method)
        c = np.array(c, dtype=np.float64)
        e.flags.writeable = c.flags.writeable = False
        object.__setattr__(self, "exponents", e)
        object.__setattr__(self, "coefficients", c)
        if self.method == "dualquat":
            _check_rest_stress(e, c)

    @classmethod
    def checked(cls, method, exponents, coefficients) -> "PolynomialTerms":
        """Terms whose rules were checked elsewhere (an element's, by the C library): not checked again."""
        terms = object.__new__(cls)
        e, c = np.array(exponents, dtype=np.int64), np.array(coefficients, dtype=np.float64)
        e.flags.writeable = c.flags.writeable = False
        for name, value in (("method", method), ("exponents", e), ("coefficients", c)):
            object.__setattr__(terms, name, value)
        return terms

    def __len__(self):
        return len(self.coefficients)

    @property
    def order(self) -> int:
        """Highest degree of the potential (2 without terms: the quadratic potential)."""
        return max(2, int(self.exponents.sum(axis=1).max(initial=0)))

    @property
    def names(self) -> tuple[str, ...]:
        """The terms as text, e.g. ``"tau_3^2 t_1"``."""
        return monomial_names(self.exponents, self.method)

    def rest_stiffness(self) -> np.ndarray:
        """Contribution of the terms to the stiffness at rest, shape (6, 6).

        The Hessian of the terms with respect to a body-frame displacement of B at rest, in the
        layout of ``K``; the element's stiffness at rest is ``K + rest_stiffness()``. It is zero
        for the terms of :func:`polynomial_basis` (all at least cubic in the displacement).
        """
        H = np.zeros((6, 6))
        for e, c in zip(self.exponents, self.coefficients, strict=True):
            if self.method == "twist":
                H += c * _quadratic_hessian(e)
                continue
            # at rest q = (1, 0, 0, 0, 0, 0, 0, 0); to second order in delta = [w; v]:
            # xi = w/2, x' = v/2, sigma = 1 - |w|^2/8, s' = -w.v/4
            rest = e[list(DQ_DISPLACEMENT)]
            if e[_SDUAL] == 0 and rest.sum() == 2:
                H += 0.25 * c * _quadratic_hessian(rest)
            elif e[_SDUAL] == 0 and rest.sum() == 0:
                H[:3, :3] -= 0.25 * c * e[_SIGMA] * np.eye(3)
            elif e[_SDUAL] == 1 and rest.sum() == 0:
                H[:3, 3:] -= 0.25 * c * np.eye(3)
                H[3:, :3] -= 0.25 * c * np.eye(3)
        return H

    def reversed(self) -> "PolynomialTerms":
        """The terms of the same element with bodies A and B exchanged.

        ``xi_ba = -xi_ab`` (twist) and ``q_ba = conj(q_ab)`` (dual quaternion), so each
        coefficient changes sign with the parity of the degree in the odd coordinates.
        """
        odd = self.exponents if self.method == "twist" else self.exponents[:, list(DQ_DISPLACEMENT)]
        sign = 1.0 - 2.0 * (odd.sum(axis=1) % 2)
        return PolynomialTerms(self.method, self.exponents, sign * self.coefficients)

    def to_dict(self) -> dict:
        """JSON-ready ``{"method", "exponents", "coefficients"}`` (coefficients round-trip exactly)."""
        return {
            "method": self.method,
            "exponents": self.exponents.tolist(),
            "coefficients": [float(c) for c in self.coefficients],
        }

    @classmethod
    def from_dict(cls, data: dict) -> "PolynomialTerms":
        """Inverse of :meth:`to_dict`."""
        missing = {"method", "exponents", "coefficients"} - set(data)
        if missing:
            raise ValueError(f"polynomial terms need the keys {sorted(missing)}; got {sorted(data)}")
        exps = np.asarray(data["exponents"], dtype=object)
        if exps.size == 0:
            exps = np.zeros((0, len(VARIABLES.get(data["method"], ()))), dtype=np.int64)
        return cls(data["method"], exps, data["coefficients"])


def no_terms(method: str) -> PolynomialTerms:
    """Terms of the quadratic potential (none)."""
    method_code(method)
    return PolynomialTerms(method, np.zeros((0, len(VARIABLES[method])), dtype=np.int64), np.zeros(0))


def _exponents(exponents, nvar: int, name: str) -> np.ndarray:
    shape_fix = (
        f"{name} must be an integer array of shape (M, {nvar}), one row of exponents of "
        f"{', '.join(VARIABLES['twist' if nvar == 6 else 'dualquat'])} per term"
    )
    try:  # the core's number rules: no booleans, text, None, complex or integers beyond float64
        f = numeric_array(exponents, name)
    except ValueError as exc:
        raise ValueError(f"{shape_fix}: {exc}") from None
    if f.size == 0:
        f = f.reshape(0, nvar)
    if f.ndim != 2 or f.shape[1] != nvar:
        raise ValueError(f"{shape_fix}; got shape {np.shape(exponents)}")
    bad = ~((f >= 0) & (f <= MAX_EXPONENT) & (np.mod(f, 1.0) == 0.0))  # NaN fails every comparison
    if bad.any():
        r = int(np.argwhere(bad)[0, 0])
        raise ValueError(f"{name}[{r}] = {f[r].tolist()}: exponents must be integers in [0, {MAX_EXPONENT}]")
    e = np.ascontiguousarray(f, dtype=np.int64)
    rows, first = np.unique(e, axis=0, return_index=True)
    if len(rows) != len(e):
        dup = sorted(set(range(len(e))) - set(first.tolist()))[0]
        same = int(np.flatnonzero((e == e[dup]).all(axis=1))[0])
        raise ValueError(
            f"{name}[{dup}] repeats {name}[{same}] = {e[dup].tolist()}: list each term once (add the coefficients)."
        )
    return e


def _check_degrees(e: np.ndarray, method: str) -> None:
    deg = e.sum(axis=1)
    low = np.flatnonzero(deg < 2)
    if low.size:
        r = int(low[0])
        raise ValueError(
            f"exponents[{r}] = {e[r].tolist()} is a {'constant' if deg[r] == 0 else 'linear'} term: "
            "the constant is arbitrary and linear terms stress the element at rest; drop it "
            "(terms start at degree 2)."
        )
    if method == "dualquat":
        odd = np.flatnonzero(deg % 2)
        if odd.size:
            r = int(odd[0])
            raise ValueError(
                f"exponents[{r}] = {e[r].tolist()} has odd degree {deg[r]}: q and -q are the same "
                "displacement, so dual-quaternion potentials are even; use terms of even degree."
            )


def _check_rest_stress(e: np.ndarray, c: np.ndarray) -> None:
    """The generalized force at rest along xi and x' must vanish (sigma^k z_j terms cancel)."""
    scale = np.abs(c).sum()
    for j in DQ_DISPLACEMENT:
        others = np.delete(np.arange(8), [_SIGMA, j])
        rows = (e[:, j] == 1) & (e[:, others].sum(axis=1) == 0)
        stress = c[rows].sum()
        if abs(stress) > REST_STRESS_RTOL * scale:
            name = VARIABLES["dualquat"][j]
            raise ValueError(
                f"the terms sigma^k {name} (rows {np.flatnonzero(rows).tolist()}) exert a generalized force "
                f"{stress:.6g} along {name} at rest: the element would be stressed at rest. Their "
                "coefficients must add up to zero (polynomial_basis never contains them)."
            )


def _quadratic_hessian(e: np.ndarray) -> np.ndarray:
    """Hessian of the monomial ``z^e`` at ``z = 0`` (non-zero only for degree 2)."""
    n = len(e)
    H = np.zeros((n, n))
    if e.sum() == 2:
        idx = np.flatnonzero(e)
        i, j = (idx[0], idx[0]) if len(idx) == 1 else idx
        H[i, j] += 1.0
        H[j, i] += 1.0
    return H


def monomial_names(exponents, method: str) -> tuple[str, ...]:
    """Text of each row of ``exponents``, e.g. ``"sigma xi_3 x'_1^2"``; ``"1"`` for a constant."""
    names = VARIABLES[method]
    out = []
    for row in np.asarray(exponents):
        parts = [n if k == 1 else f"{n}^{k}" for n, k in zip(names, row, strict=True) if k]
        out.append(" ".join(parts) or "1")
    return tuple(out)


def variable_indices(variables, method: str) -> tuple[int, ...]:
    if variables is None:
        return tuple(range(6))
    try:
        v = tuple(int(i) for i in variables)
    except (TypeError, ValueError):
        v = ()
    if not v or len(set(v)) != len(v) or any(i < 0 or i > 5 for i in v) or any(int(i) != i for i in variables):
        names = VARIABLES["twist" if method == "twist" else "dualquat"]
        raise ValueError(
            f"variables must be distinct indices 0..5 of the displacement coordinates [rotation; translation] "
            f"({', '.join(names if method == 'twist' else (names[i] for i in DQ_DISPLACEMENT))}); got {variables!r}"
        )
    return tuple(sorted(v))


def coordinate_indices(method: str, variables=None) -> tuple[int, ...]:
    """Indices into ``z`` of the coordinates that the displacement ``variables`` allow.

    ``variables`` are indices ``0..5`` of ``[rotation; translation]`` (default all). For dual
    quaternions ``sigma`` is always allowed and ``s' = -xi . x' / sigma`` only when a rotation
    and a translation coordinate along the same axis both are (it vanishes otherwise).
    """
    v = variable_indices(variables, method)
    if method_code(method) == 0:
        return v
    z = [_SIGMA] + [DQ_DISPLACEMENT[i] for i in v]
    if any(i < 3 and i + 3 in v for i in v):
        z.append(_SDUAL)
    return tuple(sorted(z))


def symmetry_signs(method: str, symmetries) -> np.ndarray:
    """Signs that the coordinates ``z`` take under each symmetry of the flexure, shape (S, 6) or (S, 8).

    A symmetry ``m = (m_x, m_y, m_z)`` (entries +-1) says that the flexure is unchanged by the map
    ``x -> diag(m) x`` of the element frame: a reflection (``det = -1``; ``(1, -1, 1)`` is the
    mirror plane x-z) or a half turn (``det = +1``; ``(1, -1, -1)`` turns about x). It maps a
    displacement ``X_ab`` to ``M X_ab M`` (``M = diag(m)``), so rotation coordinates (``tau``,
    ``xi``) change by ``det(M) m``, translation coordinates (``t``, ``x'``) by ``m``, ``sigma``
    not at all and ``s' = -xi . x' / sigma`` by ``det(M)``.
    """
    rows = []
    for m in [] if symmetries is None else symmetries:
        m = np.asarray(m, dtype=float)
        if m.shape != (3,) or not np.all(np.abs(m) == 1.0):
            raise ValueError(
                f"each symmetry must be 3 signs (+1 or -1) of the element frame's axes, e.g. (1, -1, 1) for the "
                f"mirror plane x-z or (1, -1, -1) for a half turn about x; got {m.tolist()!r}"
            )
        det = float(np.prod(m))
        rows.append(np.concatenate([det * m, m]) if method == "twist" else np.array([1.0, *(det * m), det, *m]))
    return np.array(rows).reshape(len(rows), len(VARIABLES[method]))


def polynomial_basis(method: str, order: int, variables=None, symmetries=None) -> np.ndarray:
    """Exponents of the terms of a general polynomial potential of order ``N``.

    Parameters
    ----------
    method : {"twist", "dualquat"}
        Coordinates (module docstring).
    order : int
        ``N >= 2``; even for dual quaternions. ``N = 2`` gives no terms (the quadratic potential).
    variables : sequence of int, optional
        Indices ``0..5`` of the displacement coordinates ``[rotation; translation]`` the potential
        depends on (default all six), e.g. ``(2, 3, 4)`` for motion in the x-y plane.
    symmetries : sequence of 3-sequences of +-1, optional
        Symmetries of the flexure (:func:`symmetry_signs`): only terms invariant under all of them
        are returned, e.g. ``[(1, -1, 1)]`` for a leaf spring along x bending in the x-y plane.

    Returns
    -------
    exponents : ndarray of int, shape (M, 6) or (M, 8)
        Twist: every monomial of degree ``3..N`` in the allowed coordinates. Dual quaternion:
        every *standard* monomial (module docstring) of even degree ``2..N`` in the allowed
        coordinates except those already in ``K`` (``[xi; x']`` quadratics) and those that
        stress the element at rest (``sigma xi_j``, ``sigma x'_j``); its degree-2 members
        (``s' xi_j``, ``s' x'_j``, ``s'^2``) are cubic and quartic in the displacement, so they
        join from ``N = 4``. Every term is at least cubic in the displacement, so ``K`` is
        exactly the stiffness at rest.

    Examples
    --------
    >>> import mjflex
    >>> exps = mjflex.polynomial_basis("twist", 4, variables=(2, 3, 4))  # up to order 4 in (tau_3, t_1, t_2)
    >>> print(exps.shape)
    (25, 6)
    >>> print(exps[:3])
    [[0 0 3 0 0 0]
     [0 0 2 1 0 0]
     [0 0 2 0 1 0]]
    """
    code = method_code(method)
    if not isinstance(order, int | np.integer) or order < 2 or (code == 1 and order % 2):
        raise ValueError(
            f"order must be an integer >= 2{' and even (dual-quaternion potentials are even in q)' if code else ''}; "
            f"got {order!r}"
        )
    nvar = len(VARIABLES[method])
    allowed = coordinate_indices(method, variables)
    first_xi = next((k for k in allowed if 1 <= k <= 3), None)
    signs = symmetry_signs(method, symmetries)
    rows = []
    for degree in range(3, order + 1) if code == 0 else range(2, order + 1, 2) if order > 2 else ():
        for combo in itertools.combinations_with_replacement(allowed, degree):
            e = np.bincount(combo, minlength=nvar)
            if code == 1 and not _dualquat_term(e, first_xi):
                continue
            if np.any(np.prod(signs**e, axis=1) < 0):
                continue  # changes sign under a symmetry of the flexure
            rows.append(e)
    return np.array(rows, dtype=np.int64).reshape(len(rows), nvar)


def _dualquat_term(e: np.ndarray, first_xi) -> bool:
    """Standard, not in K, not stressing the element at rest."""
    if e[_SIGMA] >= 2 or (e[_SIGMA] and e[_SDUAL]):
        return False
    if e[_SDUAL] and first_xi is not None and e[first_xi] >= 2:
        return False
    rest = e[list(DQ_DISPLACEMENT)].sum()
    if e[_SDUAL] == 0 and e[_SIGMA] == 0 and rest == 2:
        return False  # a [xi; x'] quadratic: part of K
    return not (e[_SIGMA] == 1 and e[_SDUAL] == 0 and rest == 1)


def workless_generalized_forces(q):
    """Basis of the generalized forces that do no work, for unit dual quaternions ``q``.

    Parameters
    ----------
    q : array_like, shape (..., 8)
        ``(sigma, xi, s', x')`` as returned by ``dual_quaternion_from_transform``.

    Returns
    -------
    N : ndarray, shape (..., 2, 8)
        Rows ``(sigma, xi, 0, 0)`` and ``(s', x', sigma, xi)``: the gradients of the constraints
        ``|q_r|^2 = 1`` and ``q_r . q_d = 0`` (halved). They span the null space of the 6x8 map
        of eq. 116 (footnote 4): adding any combination of them to generalized forces leaves
        the wrench unchanged.

    Examples
    --------
    >>> import numpy as np
    >>> import mjflex
    >>> q = mjflex.dual_quaternion_from_transform(np.eye(3), [0.2, 0.0, 0.0])
    >>> print(np.round(mjflex.workless_generalized_forces(q), 6) + 0.0)
    [[1.  0.  0.  0.  0.  0.  0.  0. ]
     [0.  0.1 0.  0.  1.  0.  0.  0. ]]
    """
    q = as_array(q, "q", (8,))
    N = np.zeros((*q.shape[:-1], 2, 8))
    N[..., 0, :4] = q[..., :4]
    N[..., 1, :4] = q[..., 4:]
    N[..., 1, 4:] = q[..., :4]
    return N

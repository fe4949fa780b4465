"""Exact Taylor coefficients of the scalar functions the kernels evaluate near zero.

Each function below is smooth at zero but its closed form cancels catastrophically there
(``1 - cos``, ``a - sin a``, ``1 - (a/2) cot(a/2)``). The kernels switch to these
series below a threshold where the series has converged to round-off and the closed form
has not yet lost digits; ``tests/test_series.py`` checks both branches against mpmath.

Coefficients are computed once, exactly, with :class:`fractions.Fraction`.
"""

from fractions import Fraction
from math import comb, factorial

import numpy as np


def _bernoulli_numbers(n_max: int) -> list[Fraction]:
    """Bernoulli numbers ``B_0 .. B_{n_max}`` (convention ``B_1 = -1/2``)."""
    b = [Fraction(0)] * (n_max + 1)
    b[0] = Fraction(1)
    for m in range(1, n_max + 1):
        b[m] = -sum(comb(m + 1, k) * b[k] for k in range(m)) / (m + 1)
    return b


def series_coefficients(n_terms: int) -> dict[str, np.ndarray]:
    bern = _bernoulli_numbers(2 * n_terms + 4)
    # (x/2) cot(x/2) = sum_{n>=0} (-1)^n B_{2n} x^{2n} / (2n)!, hence
    # c(x) = (1 - (x/2) cot(x/2)) / x^2 = sum_{n>=1} a_n x^{2n-2}, a_n = (-1)^{n+1} B_{2n}/(2n)!
    a = {n: (-1) ** (n + 1) * bern[2 * n] / factorial(2 * n) for n in range(1, n_terms + 3)}
    c = [a[n] for n in range(1, n_terms + 1)]
    # g(x) = c'(x) / x = sum_{n>=2} a_n (2n - 2) x^{2n-4}
    g = [a[n] * (2 * n - 2) for n in range(2, n_terms + 2)]
    # (x - sin x) / x^3 = sum_k (-1)^k x^{2k} / (2k+3)!
    s3 = [Fraction((-1) ** k, factorial(2 * k + 3)) for k in range(n_terms)]
    return {
        "c": np.array([float(v) for v in c]),
        "g": np.array([float(v) for v in g]),
        "s3": np.array([float(v) for v in s3]),
    }


_COEFFS = series_coefficients(12)

#: Coefficients in ``x**2`` of ``c(x) = (1 - (x/2) cot(x/2)) / x**2`` (the ``(u^)^2`` term
#: of the inverse left Jacobian of SO(3), eq. 44 of the paper, divided by ``x**2``).
JL_INV_COEFFS = _COEFFS["c"]
#: Coefficients in ``x**2`` of ``g(x) = c'(x) / x`` (the dual part of eq. 44).
JL_INV_RATE_COEFFS = _COEFFS["g"]
#: Coefficients in ``x**2`` of ``(x - sin x) / x**3`` (the ``(u^)^2`` term of eq. 19).
EXP_S3_COEFFS = _COEFFS["s3"]

#: Below this angle [rad] the kernels evaluate the series above instead of closed forms.
SERIES_THRESHOLD = 1.0

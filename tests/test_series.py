"""Scalar coefficient functions of the kernels against 50-digit mpmath, on both sides of the series threshold."""

import math

import mpmath as mp
import numpy as np
import pytest

from mjflex.core import _kernels as k
from mjflex.core.series import SERIES_THRESHOLD

mp.mp.dps = 50

ANGLES = np.concatenate(
    [
        np.geomspace(1e-12, 0.5, 30),
        np.linspace(0.5, np.pi, 60),
        SERIES_THRESHOLD * np.array([1 - 1e-12, 1.0, 1 + 1e-12]),
    ]
)


def _c(a):
    a = mp.mpf(a)
    h = a / 2
    return (1 - h * mp.cot(h)) / a**2


def _g(a):
    return mp.diff(_c, mp.mpf(a)) / mp.mpf(a)


@pytest.mark.parametrize("a", ANGLES)
def test_inverse_jacobian_coefficient(a):
    assert abs(k.jl_inv_coef(a) - float(_c(a))) <= 2e-15 * abs(float(_c(a)))


@pytest.mark.parametrize("a", ANGLES)
def test_inverse_jacobian_rate_coefficient(a):
    ref = float(_g(a))
    assert abs(k.jl_inv_coefs(a, math.cos(a / 2), math.sin(a / 2))[1] - ref) <= 1e-12 * abs(ref)


@pytest.mark.parametrize("a", list(ANGLES) + [0.0])
def test_exp_coefficients(a):
    am = mp.mpf(a)
    if a == 0:
        ref = (0.5, 0.5, 1 / 6)
    else:
        ref = (mp.sin(am / 2) / am, (1 - mp.cos(am)) / am**2, (am - mp.sin(am)) / am**3)
    got = k.exp_coefs(a)
    for g, r in zip(got, ref, strict=True):
        assert abs(g - float(r)) <= 2e-15 * abs(float(r))


def test_coefficients_at_zero_limit():
    assert k.jl_inv_coef(0.0) == 1 / 12
    assert k.jl_inv_coefs(0.0, 1.0, 0.0)[1] == 1 / 360

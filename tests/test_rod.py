"""The leaf-spring reference chain (mjflex.geometry.rod) against closed forms and the elastica.

References: the circular arc of a pure end moment (exact for a rod), Timoshenko's cantilever
deflection for a small end force, and the inextensible elastica solved here with
``scipy.integrate.solve_bvp``. The chain converges with O(h^2), so errors are checked at two
resolutions (their ratio ~4) rather than against a fixed tolerance only.
"""

import numpy as np
import pytest
from scipy.integrate import solve_bvp

from mjflex.geometry.rod import LeafChain

L, T, B, E, NU = 0.04, 0.0004, 0.008, 200e9, 0.3


def _chain(n):
    return LeafChain(L, T, B, E, NU, n=n)


def test_pure_moment_bends_a_circular_arc():
    errors = []
    for n in (10, 20):
        chain = _chain(n)
        q = chain.solve([chain.EI / L, 0.0, 0.0])  # curvature 1/L: tip rotation 1 rad
        assert abs(q[-1, 0] - 1.0) <= 1e-8
        assert chain.residual(q, [chain.EI / L, 0.0, 0.0]) <= chain.tolerance
        arc = np.array([L * np.sin(1.0), L * (1.0 - np.cos(1.0))])
        errors.append(np.linalg.norm(q[-1, 1:] - arc) / L)
    assert errors[1] <= 3e-4
    assert 3.5 <= errors[0] / errors[1] <= 4.5  # O(h^2)


def test_small_end_force_matches_timoshenko_cantilever():
    G, kappa = E / (2 * (1 + NU)), 10 * (1 + NU) / (12 + 11 * NU)
    errors = []
    for n in (10, 20):
        chain = _chain(n)
        F = 1e-3 * chain.EI / L**2
        q = chain.solve([0.0, 0.0, F], steps=1)
        deflection = F * L**3 / (3 * chain.EI) + F * L / (kappa * G * B * T)
        errors.append(abs(q[-1, 2] / deflection - 1.0))
    assert errors[1] <= 1e-3
    assert 3.5 <= errors[0] / errors[1] <= 4.5


def _elastica_tip(EI, Fy):
    """Tip (theta, x, y) of the inextensible cantilever elastica under an end force Fy (solve_bvp)."""

    def rhs(s, y):  # theta, curvature, x, y
        return np.vstack([y[1], -np.cos(y[0]) * Fy / EI, np.cos(y[0]), np.sin(y[0])])

    def bc(ya, yb):
        return np.array([ya[0], ya[2], ya[3], yb[1]])

    s = np.linspace(0, L, 200)
    y0 = np.zeros((4, s.size))
    y0[2] = s
    sol = solve_bvp(rhs, bc, s, y0, tol=1e-10, max_nodes=100000)
    assert sol.status == 0
    return sol.y[[0, 2, 3], -1]


def test_large_deflection_converges_to_the_elastica():
    """End force F L^2 / EI = 2: tip rotation 45 degrees (Bisshopp and Drucker's case)."""
    errors = []
    for n in (10, 20):
        chain = _chain(n)
        Fy = 2.0 * chain.EI / L**2
        q = chain.solve([0.0, 0.0, Fy])
        ref = _elastica_tip(chain.EI, Fy)
        errors.append(np.linalg.norm(q[-1, 1:] - ref[1:]) / L)
    assert abs(np.degrees(ref[0]) - 44.8) < 0.1  # the published tip angle: checks the reference solver itself
    assert errors[1] <= 5e-4
    assert errors[0] > 3 * errors[1]  # converging (plus the rod's own shear and stretch, ~(t/L)^2)


def test_bad_arguments_and_non_convergence_are_reported():
    with pytest.raises(ValueError, match="n must be an integer >= 2"):
        LeafChain(L, T, B, E, NU, n=1)
    chain = _chain(10)
    with pytest.raises(RuntimeError, match="did not converge under load"):
        chain.solve([0.0, 0.0, 2.0 * chain.EI / L**2], steps=1, max_iter=1)

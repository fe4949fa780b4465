"""Stiffness from geometry: closed forms, asymptotics, scaling laws, published tables and finite elements."""

import numpy as np
import pytest

import mjflex
from mjflex.geometry import fe2d, hinges

E, NU, B = 3.5e9, 0.33, 0.0095
R = 0.004


def paros_weisbord_exact(R, t, b, E):
    """Angular compliance [rad/(N m)] of a circular notch hinge, Paros & Weisbord (1965), full equation."""
    beta = t / (2 * R)
    s = 2 * beta + beta**2
    bracket = (3 + 4 * beta + 2 * beta**2) / ((1 + beta) * s) + 6 * (1 + beta) / s**1.5 * np.arctan(
        np.sqrt((2 + beta) / beta)
    )
    return 3 / (2 * E * b * R**2) / s * bracket


@pytest.mark.parametrize("ratio", [0.05, 0.125, 0.3, 0.8])
def test_compliant_rotation_equals_paros_weisbord(ratio):
    K = mjflex.geometry.notch_hinge_stiffness(R, ratio * R, B, E, NU, wide=False)
    assert 1 / K[2, 2] == pytest.approx(paros_weisbord_exact(R, ratio * R, B, E), rel=1e-10)


def test_wide_hinge_uses_plane_strain_modulus():
    narrow = mjflex.geometry.notch_hinge_stiffness(R, 0.1 * R, B, E, NU, wide=False)
    wide = mjflex.geometry.notch_hinge_stiffness(R, 0.1 * R, B, E, NU)  # b/t = 23.75: wide by default
    assert wide[2, 2] / narrow[2, 2] == pytest.approx(1 / (1 - NU**2), rel=1e-12)
    assert wide[3, 3] == pytest.approx(narrow[3, 3], rel=1e-12)  # axial keeps E


def test_thin_web_asymptote():
    """As t/R -> 0 the compliance tends to 9 pi R^(1/2) / (2 E b t^(5/2)) (Paros-Weisbord, simplified)."""
    errors = []
    for ratio in [1e-2, 1e-3, 1e-4]:
        t = ratio * R
        K = mjflex.geometry.notch_hinge_stiffness(R, t, B, E, NU, wide=False, allow_out_of_range=True)
        simple = 9 * np.pi * np.sqrt(R) / (2 * E * B * t**2.5)
        errors.append(abs(1 / K[2, 2] / simple - 1))
    assert errors[-1] < 2e-3 and errors[0] > errors[1] > errors[2]


def test_scaling_laws():
    K = mjflex.geometry.notch_hinge_stiffness(R, 0.125 * R, B, E, NU)
    assert np.allclose(mjflex.geometry.notch_hinge_stiffness(R, 0.125 * R, B, 2 * E, NU), 2 * K, rtol=1e-12)
    s = 3.0  # geometric similarity: rotational stiffness ~ E L^3, translational ~ E L
    Ks = mjflex.geometry.notch_hinge_stiffness(s * R, 0.125 * s * R, s * B, E, NU)
    assert np.allclose(np.diag(Ks)[:3], s**3 * np.diag(K)[:3], rtol=1e-9)
    assert np.allclose(np.diag(Ks)[3:], s * np.diag(K)[3:], rtol=1e-9)
    # compliant bending and axial stiffness grow linearly with the width
    K2 = mjflex.geometry.notch_hinge_stiffness(R, 0.125 * R, 2 * B, E, NU)
    assert K2[2, 2] == pytest.approx(2 * K[2, 2], rel=1e-12) and K2[3, 3] == pytest.approx(2 * K[3, 3], rel=1e-12)
    # the thin directions are far softer than the stiff ones
    assert K[1, 1] > 100 * K[2, 2] and K[5, 5] > 3 * K[4, 4]


def test_slender_leaf_spring_matches_euler_bernoulli():
    L, t = 0.05, 0.0005
    K = mjflex.geometry.leaf_spring_stiffness(L, t, B, E, NU, wide=False)
    I = B * t**3 / 12
    assert K[2, 2] == pytest.approx(E * I / L, rel=1e-12)
    # guided-beam stiffness; Timoshenko shear lowers it by (E / (kappa G)) (t / L)^2 = 3.1e-4 here
    assert K[4, 4] == pytest.approx(12 * E * I / L**3, rel=5e-4)
    assert K[4, 4] < 12 * E * I / L**3
    assert K[3, 3] == pytest.approx(E * B * t / L, rel=1e-12)
    G = E / (2 * (1 + NU))
    assert K[0, 0] == pytest.approx(G * B * t**3 / 3 * (1 - 0.630 * t / B) / L, rel=2e-3)  # thin-strip torsion


@pytest.mark.parametrize(
    "aspect, beta",
    [(1.0, 0.141), (1.5, 0.196), (2.0, 0.229), (3.0, 0.263), (4.0, 0.281), (5.0, 0.291), (10.0, 0.312)],
)
def test_torsion_constant_against_published_table(aspect, beta):
    """J = beta a c^3 (Timoshenko & Goodier, Theory of Elasticity, Table 6; Roark's Formulas)."""
    c = 1.0
    J = hinges.rectangle_torsion_constant(aspect * c, c)
    assert J / (aspect * c * c**3) == pytest.approx(beta, abs=6e-4)
    assert hinges.rectangle_torsion_constant(c, aspect * c) == J  # symmetric in its arguments


def test_paper_hinge_against_finite_elements():
    """The documented error of the beam model at the paper's notch (t/R = 0.125), plane stress."""
    t = 0.125 * R

    def h(x):
        return hinges.notch_hinge_thickness(x, R, t) if abs(x) <= R else t + 2 * R

    beam = hinges._beam_compliance(h, 2 * R, B, E, NU, False)
    fe = np.diag(fe2d.centre_compliance(h, 2 * R, B, E, NU, plane="stress", nx=120, ny=6))
    ratio = beam[[3, 4, 2]] / fe
    assert ratio == pytest.approx([0.877, 0.926, 0.953], abs=0.01)


def test_uniform_leaf_against_finite_elements():
    L, t = 0.009, 0.0005  # the paper's leaf
    beam = np.diag(np.linalg.inv(mjflex.geometry.leaf_spring_stiffness(L, t, B, E, NU, wide=False)))
    fe = np.diag(fe2d.centre_compliance(lambda x: t, L / 2, B, E, NU, plane="stress", nx=40, ny=4, grading=1.0))
    assert beam[[3, 4, 2]] / fe == pytest.approx([1.0, 1.0, 1.0], abs=0.01)


def test_in_plane_fe_option():
    t = 0.125 * R
    K_fe = mjflex.geometry.notch_hinge_stiffness(R, t, B, E, NU, in_plane="fe")
    K_beam = mjflex.geometry.notch_hinge_stiffness(R, t, B, E, NU)
    assert np.allclose(np.diag(K_fe)[[0, 1, 5]], np.diag(K_beam)[[0, 1, 5]], rtol=1e-12)
    assert 0.9 < K_fe[2, 2] / K_beam[2, 2] < 1.0  # FE is more compliant than the beam
    with pytest.raises(ValueError, match="in_plane must be 'beam' or 'fe'"):
        mjflex.geometry.notch_hinge_stiffness(R, t, B, E, NU, in_plane="3d")


def test_out_of_range_and_bad_input():
    with pytest.raises(
        ValueError, match=r"notch hinge t/R = 1\.5 is outside the validated range.*allow_out_of_range=True"
    ):
        mjflex.geometry.notch_hinge_stiffness(R, 1.5 * R, B, E, NU)
    assert mjflex.geometry.notch_hinge_stiffness(R, 1.5 * R, B, E, NU, allow_out_of_range=True)[2, 2] > 0
    with pytest.raises(ValueError, match=r"leaf spring with L/t = 2 .*outside the beam model's range"):
        mjflex.geometry.leaf_spring_stiffness(0.001, 0.0005, B, E, NU)
    with pytest.raises(ValueError, match=r"t must be a positive finite number; got -0\.001"):
        mjflex.geometry.notch_hinge_stiffness(R, -0.001, B, E, NU)
    with pytest.raises(ValueError, match=r"Poisson ratio nu must be in \[0, 0\.5\); got 0\.5"):
        mjflex.geometry.leaf_spring_stiffness(0.01, 0.0005, B, E, 0.5)


def test_stiffness_is_valid_for_an_element():
    K = mjflex.geometry.notch_hinge_stiffness(R, 0.125 * R, B, E, NU)
    assert np.all(np.diag(K) > 0) and np.count_nonzero(K - np.diag(np.diag(K))) == 0
    assert np.allclose(mjflex.centre_of_stiffness(K), 0.0)
    strain = mjflex.geometry.bending_strain_per_radian(K, 0.125 * R, B, E, NU)
    assert 0.0 < strain < 1.0

r"""6x6 stiffness of notch hinges and leaf springs from their geometry and material.

Frames and ordering (all functions): origin at the centre of the flexure, which is its
centre of stiffness (both parts are symmetric about it); ``x`` along the flexure (the beam
axis), ``y`` across its thin dimension (in the plane of motion), ``z`` along its width ``b``
(the axis of the compliant rotation). Rows/columns are ``[rot_x, rot_y, rot_z, x, y, z]``:
torsion, out-of-plane bending, compliant rotation, axial, in-plane shear, out-of-plane shear.
SI units; the matrices are diagonal in this frame.

Model: Timoshenko beam with a variable section, integrated along the flexure by Castigliano's
theorem (the unit-load method): for a symmetric flexure of length ``2l`` and wrench
``(M, F)`` referred to the centre,

    C_rot_z = int dx / (E* I_z),   C_y = int x^2 dx / (E* I_z) + int dx / (kappa G A),
    C_x = int dx / (E A),          C_rot_y = int dx / (E I_y),
    C_z = int x^2 dx / (E I_y) + int dx / (kappa G A),   C_rot_x = int dx / (G J),

with ``I_z = b h^3/12``, ``I_y = h b^3/12``, ``A = b h``, Saint-Venant's torsion constant ``J`` of
the ``h x b`` rectangle (:func:`rectangle_torsion_constant`), Cowper's shear coefficient
``kappa = 10 (1 + nu) / (12 + 11 nu)`` and ``G = E / (2 (1 + nu))``; ``K = C^-1``. For wide
flexures (``b >= WIDE_RATIO t``) the compliant bending is plate-like (anticlastic curvature
suppressed), so ``E* = E / (1 - nu^2)``; otherwise ``E* = E``.
"""

import math

import numpy as np
from scipy import integrate

#: Width-to-thickness ratio above which the compliant bending uses the plane-strain modulus.
WIDE_RATIO = 5.0
#: Range of t/R where the notch-hinge model is validated (see notch_hinge_stiffness).
NOTCH_T_OVER_R = (0.05, 0.8)
#: Minimum L/t for the leaf-spring (beam) model.
LEAF_MIN_L_OVER_T = 5.0


def _positive(**values):
    for name, v in values.items():
        if not (isinstance(v, int | float | np.floating | np.integer) and math.isfinite(v) and v > 0):
            raise ValueError(f"{name} must be a positive finite number; got {v!r}")


def _material(E, nu):
    _positive(E=E)
    if not (0.0 <= nu < 0.5):
        raise ValueError(f"Poisson ratio nu must be in [0, 0.5); got {nu!r}")
    return E / (2.0 * (1.0 + nu)), 10.0 * (1.0 + nu) / (12.0 + 11.0 * nu)


def rectangle_torsion_constant(a, c):
    """Saint-Venant torsion constant of an ``a x c`` rectangle [m^4] (exact series).

    ``J = (A C^3 / 3) [1 - (192 / pi^5)(C / A) sum_{n odd} tanh(n pi A / (2 C)) / n^5]`` with
    ``A = max(a, c)``, ``C = min(a, c)`` (Timoshenko & Goodier, Theory of Elasticity, sec. 109).
    Accepts arrays; the series is summed to round-off.
    """
    a, c = np.asarray(a, dtype=float), np.asarray(c, dtype=float)
    A, C = np.maximum(a, c), np.minimum(a, c)
    s = np.zeros(np.broadcast(A, C).shape)
    for n in range(1, 40, 2):
        s = s + np.tanh(n * np.pi * A / (2 * C)) / n**5
    return A * C**3 / 3.0 * (1.0 - 192.0 / np.pi**5 * (C / A) * s)


def _beam_compliance(h, half_length, b, E, nu, wide):
    """Diagonal compliance at the centre of a symmetric beam of thickness ``h(x)``, ``|x| <= half_length``."""
    G, kappa = _material(E, nu)
    E_bend = E / (1.0 - nu**2) if wide else E

    def quad(f):
        # symmetric integrand: integrate over [0, l] and double; points concentrate at the neck
        return 2.0 * integrate.quad(f, 0.0, half_length, limit=400, epsabs=0.0, epsrel=1e-12)[0]

    C = np.zeros(6)
    C[0] = quad(lambda x: 1.0 / (G * rectangle_torsion_constant(h(x), b)))
    C[1] = quad(lambda x: 12.0 / (E * h(x) * b**3))
    C[2] = quad(lambda x: 12.0 / (E_bend * b * h(x) ** 3))
    C[3] = quad(lambda x: 1.0 / (E * b * h(x)))
    shear = quad(lambda x: 1.0 / (kappa * G * b * h(x)))
    C[4] = quad(lambda x: 12.0 * x * x / (E_bend * b * h(x) ** 3)) + shear
    C[5] = quad(lambda x: 12.0 * x * x / (E * h(x) * b**3)) + shear
    return C


def notch_hinge_thickness(x, R, t):
    """Thickness of a circular notch hinge at ``x`` from its centre: ``t + 2 (R - sqrt(R^2 - x^2))``."""
    x = np.minimum(np.abs(x), R)
    return t + 2.0 * (R - np.sqrt(np.maximum(R * R - x * x, 0.0)))


def notch_hinge_stiffness(R, t, b, E, nu, *, wide=None, in_plane="beam", allow_out_of_range=False):
    r"""6x6 stiffness of a right-circular notch hinge at its centre.

    Parameters
    ----------
    R : float
        Radius of the two circular cuts (holes) [m]; the hinge spans ``-R <= x <= R``.
    t : float
        Minimum web thickness between the cuts [m].
    b : float
        Width of the hinge (along the compliant rotation axis ``z``) [m].
    E : float
        Young's modulus [Pa].
    nu : float
        Poisson ratio.
    wide : bool, optional
        Use the plane-strain modulus for the compliant bending; default ``b >= WIDE_RATIO t``.
    in_plane : {"beam", "fe"}
        ``"beam"``: the closed beam integrals below. ``"fe"``: replace the three in-plane terms
        (compliant rotation, axial, in-plane shear) by a 2-D finite-element solution of the
        same profile (:mod:`mjflex.geometry.fe2d`; plane strain if ``wide``, else plane stress;
        about 0.5 s).
    allow_out_of_range : bool
        Compute outside the validated range ``NOTCH_T_OVER_R`` of ``t/R`` instead of raising.

    Returns
    -------
    K : ndarray, shape (6, 6)
        Diagonal stiffness ``[rot_x, rot_y, rot_z, x, y, z]`` (module docstring): ``N m/rad``
        for rotations, ``N/m`` for translations.

    Notes
    -----
    Formula: the variable-section beam integrals of the module docstring over the profile
    ``h(x) = t + 2 (R - sqrt(R^2 - x^2))``, ``|x| <= R``. Its compliant-rotation term equals the
    exact Paros & Weisbord (1965, Machine Design 37(27)) equation; as ``t/R -> 0`` it tends to
    their simplified ``9 pi R^(1/2) / (2 E* b t^(5/2))``. Same model as Lobontiu (2003),
    *Compliant Mechanisms: Design of Flexure Hinges*, ch. 2, with shear added.

    Validity and error (``in_plane="beam"``), range ``0.05 <= t/R <= 0.8``: against 2-D
    finite elements of the same profile continued by a block of length ``R`` on each side
    (``scripts/hinge_fe_check.py``; mesh-converged to 0.2 %), the beam model is too stiff, and
    increasingly so for thick webs. Compliance beam / FE: compliant rotation 0.98 at
    ``t/R = 0.05``, 0.95 at 0.125 (the paper's hinge), 0.90 at 0.3, 0.81 at 0.8; in-plane shear
    0.92-1.02; axial 0.85-0.91 in plane stress and 0.96-1.02 in plane strain. The out-of-plane
    terms (torsion, out-of-plane bending and shear) are not checked against 3-D finite
    elements; Saint-Venant torsion ignores the warping restraint by the thick ends, so the
    torsional stiffness is a lower bound.
    """
    _positive(R=R, t=t, b=b)
    ratio = t / R
    if not allow_out_of_range and not (NOTCH_T_OVER_R[0] <= ratio <= NOTCH_T_OVER_R[1]):
        raise ValueError(
            f"notch hinge t/R = {ratio:.3g} is outside the validated range {NOTCH_T_OVER_R}; pass "
            "allow_out_of_range=True to use the beam model anyway (its error grows outside the range)"
        )
    if in_plane not in ("beam", "fe"):
        raise ValueError(f"in_plane must be 'beam' or 'fe'; got {in_plane!r}")
    wide = b >= WIDE_RATIO * t if wide is None else wide
    C = _beam_compliance(lambda x: notch_hinge_thickness(x, R, t), R, b, E, nu, wide)
    if in_plane == "fe":
        from .fe2d import centre_compliance

        C_fe = centre_compliance(
            lambda x: notch_hinge_thickness(x, R, t), R, b, E, nu, plane="strain" if wide else "stress"
        )
        C[3], C[4], C[2] = np.diag(C_fe)
    return np.diag(1.0 / C)


def leaf_spring_stiffness(L, t, b, E, nu, *, wide=None, allow_out_of_range=False):
    r"""6x6 stiffness of a rectangular leaf spring (cantilever flexure) at its centre.

    Parameters
    ----------
    L : float
        Free length between the clamping blocks [m] (along ``x``).
    t : float
        Thickness [m] (along ``y``; the leaf bends across it, about ``z``).
    b : float
        Width [m] (along ``z``).
    E : float
        Young's modulus [Pa].
    nu : float
        Poisson ratio.
    wide : bool, optional
        Plane-strain modulus for the compliant bending; default ``b >= WIDE_RATIO t``.
    allow_out_of_range : bool
        Compute for ``L/t < LEAF_MIN_L_OVER_T`` or ``t > b`` instead of raising.

    Returns
    -------
    K : ndarray, shape (6, 6)
        Diagonal stiffness ``[rot_x, rot_y, rot_z, x, y, z]`` at the centroid (the centre of
        stiffness): ``K_rot_z = E* I / L``, ``K_y = 1 / (L^3 / (12 E* I) + L / (kappa G A))``,
        ``K_x = E A / L``, ``K_rot_x = G J / L``, and the same for the stiff direction.

    Notes
    -----
    Formula: uniform Timoshenko beam (module docstring), as in Fasse & Breedveld (1998) for
    the paper's cantilever flexures; torsion constant of the ``t x b`` rectangle. Validity:
    ``L/t >= 5`` and ``t <= b``. Against 2-D finite elements of the leaf between ideally rigid
    clamps (``scripts/hinge_fe_check.py``) the bending and shear compliances agree within 1 %
    for ``L/t >= 5`` (plane stress, and plane strain with ``wide``); the axial compliance
    (always with ``E``) is exact in plane stress and 13 % above the plane-strain value, which
    bounds a wide leaf's 3-D answer from the other side. Real clamps (machined roots, fillets)
    add compliance that neither model contains. Out-of-plane terms are not checked against
    3-D finite elements.
    """
    _positive(L=L, t=t, b=b)
    if not allow_out_of_range and (L / t < LEAF_MIN_L_OVER_T or t > b):
        raise ValueError(
            f"leaf spring with L/t = {L / t:.3g} and t/b = {t / b:.3g} is outside the beam model's range "
            f"(L/t >= {LEAF_MIN_L_OVER_T:g}, t <= b); pass allow_out_of_range=True to use it anyway"
        )
    wide = b >= WIDE_RATIO * t if wide is None else wide
    C = _beam_compliance(lambda x: t, 0.5 * L, b, E, nu, wide)
    return np.diag(1.0 / C)


def bending_strain_per_radian(K, t, b, E, nu, *, wide=None):
    """Peak bending strain at the thinnest section per radian of compliant rotation.

    ``eps / theta = 6 K_rot_z / (E* b t^2)``: the moment ``K_rot_z theta`` over the section
    modulus ``b t^2 / 6`` of the thinnest section, divided by the bending modulus.
    """
    wide = b >= WIDE_RATIO * t if wide is None else wide
    E_bend = E / (1.0 - nu**2) if wide else E
    return 6.0 * np.asarray(K)[2, 2] / (E_bend * b * t * t)

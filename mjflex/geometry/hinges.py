r"""6x6 stiffness of notch hinges and leaf springs from their geometry and material.

Frames and ordering (all functions): origin at the centre of the flexure, which is its
centre of stiffness (both parts are symmetric about it); ``x`` along the flexure (the beam
axis), ``y`` across its thin dimension (in the plane of motion), ``z`` along its width ``b``
(the axis of the compliant rotation). Rows/columns are ``[rot_x, rot_y, rot_z, x, y, z]``:
torsion, out-of-plane bending, compliant rotation, axial, in-plane shear, out-of-plane shear.
SI units; the matrices are diagonal in this frame.

What ``K`` means: the stiffness of the element that, placed at the centre between two rigid
bodies that begin at the flexure's ends (``|x| = R`` for a notch, ``|x| = L/2`` for a leaf),
reproduces the elastic solid -- the flexure together with the blocks it is cut from, whose
own plain-bar compliance is subtracted (:mod:`mjflex.geometry.fe` states the reduction).

Three methods (``method=`` of both functions):

``"table"`` (default)
    3-D finite elements, tabulated: the beam formula below times a stored correction factor
    per diagonal entry (:mod:`mjflex.geometry.tables`), microseconds per call. Its error
    against converged finite elements is stated per entry in the functions' docstrings.
``"fe"``
    3-D finite elements of the given geometry (:func:`mjflex.geometry.fe.element_compliance`;
    seconds at ``fe_level=1``, the tables' mesh), for geometry outside the tables.
``"beam"``
    The closed-form beam model (the previous default): a Timoshenko beam with a variable
    section, integrated along the flexure by Castigliano's theorem (the unit-load method):
    for a symmetric flexure of length ``2l`` and wrench ``(M, F)`` referred to the centre,

        C_rot_z = int dx / (E* I_z),   C_y = int x^2 dx / (E* I_z) + int dx / (kappa G A),
        C_x = int dx / (E A),          C_rot_y = int dx / (E I_y),
        C_z = int x^2 dx / (E I_y) + int dx / (kappa G A),   C_rot_x = int dx / (G J),

    with ``I_z = b h^3/12``, ``I_y = h b^3/12``, ``A = b h``, Saint-Venant's torsion constant
    ``J`` of the ``h x b`` rectangle (:func:`rectangle_torsion_constant`), Cowper's shear
    coefficient ``kappa = 10 (1 + nu) / (12 + 11 nu)`` and ``G = E / (2 (1 + nu))``;
    ``K = C^-1``. For wide flexures (``b >= WIDE_RATIO t``) the compliant bending uses
    ``E* = E / (1 - nu^2)`` (anticlastic curvature suppressed); otherwise ``E* = E``. The
    tables store ``K_FE / K_beam`` against this model with ``E* = E`` (``wide=False``).
"""

import math

import numpy as np
from scipy import integrate

from .sections import check_positive, rectangle_torsion_constant, shear_constants

#: Width-to-thickness ratio above which the compliant bending uses the plane-strain modulus.
WIDE_RATIO = 5.0
#: Range of t/R where the notch-hinge beam model is validated (see notch_hinge_stiffness).
NOTCH_T_OVER_R = (0.05, 0.8)
#: Minimum L/t for the leaf-spring (beam) model.
LEAF_MIN_L_OVER_T = 5.0


def _beam_compliance(h, half_length, b, E, nu, wide):
    """Diagonal compliance at the centre of a symmetric beam of thickness ``h(x)``, ``|x| <= half_length``."""
    G, kappa = shear_constants(E, nu)
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
    """Thickness of a circular notch hinge at ``x`` from its centre: ``t + 2 (R - sqrt(R^2 - x^2))``.

    Parameters
    ----------
    x : float or array_like
        Position along the hinge from its centre [m], ``-R <= x <= R``.
    R : float
        Radius of the two circular cuts [m].
    t : float
        Minimum web thickness, at ``x = 0`` [m].

    Returns
    -------
    h : float or ndarray
        The thickness at ``x`` [m] (``x``'s shape).

    Examples
    --------
    >>> import numpy as np
    >>> import mjflex
    >>> t_x = mjflex.geometry.notch_hinge_thickness(np.array([0.0, 1e-3, 2e-3]), R=2e-3, t=0.3e-3)
    >>> print(np.round(t_x * 1e3, 4))  # [mm]
    [0.3    0.8359 4.3   ]
    """
    x = np.minimum(np.abs(x), R)
    return t + 2.0 * (R - np.sqrt(np.maximum(R * R - x * x, 0.0)))


METHODS = ("table", "fe", "beam")


def _method(method, wide):
    if method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}; got {method!r}")
    if wide is not None and method != "beam":
        raise ValueError(
            f"wide={wide!r} applies to method='beam' only (the finite elements and the tables are 3-D); drop it"
        )


def _fe_module():
    try:
        from . import fe  # scikit-fem, an optional dependency, loads only for method="fe"
    except ImportError as err:  # scikit-fem is an optional dependency
        raise ImportError(f"method='fe' needs scikit-fem ({err}); install it: pip install 'mjflex[fe]'") from err
    return fe


def notch_hinge_stiffness(
    R, t, b, E, nu, *, method="table", wide=None, allow_out_of_range=False, fe_level=1, block_length=None
):
    r"""6x6 stiffness of a right-circular notch hinge at its centre.

    Parameters
    ----------
    R : float
        Radius of the two circular cuts (holes) [m]; the hinge spans ``-R <= x <= R`` and is
        cut into a bar of height ``H = t + 2 R`` (the blocks).
    t : float
        Minimum web thickness between the cuts [m].
    b : float
        Width of the hinge (along the compliant rotation axis ``z``) [m].
    E : float
        Young's modulus [Pa].
    nu : float
        Poisson ratio.
    method : {"table", "fe", "beam"}
        See the module docstring. ``"table"`` covers ``0.05 <= t/R <= 1``,
        ``0.25 <= b/R <= 10`` and ``0.2 <= nu <= 0.45`` and raises outside.
    wide : bool, optional
        ``method="beam"`` only: use the plane-strain modulus for the compliant bending;
        default ``b >= WIDE_RATIO t``.
    allow_out_of_range : bool
        ``method="beam"`` only: compute outside ``NOTCH_T_OVER_R`` instead of raising.
    fe_level : int
        ``method="fe"`` only: mesh level (1: the tables' mesh, seconds; 2: every element count
        doubled, minutes).
    block_length : float, optional
        ``method="fe"`` only: length of each block in the model [m]; default ``H``.

    Returns
    -------
    K : ndarray, shape (6, 6)
        Diagonal stiffness ``[rot_x, rot_y, rot_z, x, y, z]`` (module docstring): ``N m/rad``
        for rotations, ``N/m`` for translations.

    Notes
    -----
    Error of ``method="table"`` against converged 3-D finite elements with blocks (stored
    bands, ``mjflex.geometry.tables.error_bands("notch")``, from
    ``python scripts/build_stiffness_tables.py``; interpolation error at off-grid points plus
    the table mesh's discretisation error), max over the table's range:

    ======================  =======  ==================================
    entry                   band     of which mesh
    ======================  =======  ==================================
    torsion ``rot_x``       1.4 %    0.4 %
    bending ``rot_y``       0.12 %   0.08 %
    compliant ``rot_z``     0.45 %   0.25 %
    axial ``x``             0.13 %   0.08 %
    shear ``y``             0.6 %    0.4 %
    shear ``z``             1.32 %   0.4 %
    ======================  =======  ==================================

    ``method="fe"`` at ``fe_level=1`` carries the "mesh" column's error.

    ``method="beam"``: its compliant-rotation term equals the exact Paros & Weisbord (1965,
    Machine Design 37(27)) equation and tends, as ``t/R -> 0``, to their simplified
    ``9 pi R^(1/2) / (2 E* b t^(5/2))``; it is the model of Lobontiu (2003), *Compliant
    Mechanisms*, ch. 2, with shear added. Against the finite elements it is too stiff in the
    compliant rotation, increasingly with ``t/R`` (``python scripts/hinge_fe_check.py``;
    ``b = 9.5 mm``, ``nu = 0.33``, default ``wide``): stiffness ratio beam / FE in the
    compliant rotation 1.03 at ``t/R = 0.05``, 1.07 at 0.125 (the paper's hinge), 1.16 at
    0.3, 1.20 at 0.8; axial 1.08-1.33; in-plane shear 0.99-1.13; out-of-plane bending and
    shear 1.1-1.5; torsion 0.05-0.8 (Saint-Venant torsion ignores the blocks' restraint of
    the neck's warping, so it is far too soft for short, wide necks).

    Examples
    --------
    >>> import mjflex
    >>> K = mjflex.geometry.notch_hinge_stiffness(R=2e-3, t=0.3e-3, b=5e-3, E=70e9, nu=0.33)  # aluminium
    >>> print(f"compliant rotation {K[2, 2]:.4f} N m/rad, axial {K[3, 3]:.3g} N/m")
    compliant rotation 0.9135 N m/rad, axial 5.03e+07 N/m
    >>> K_beam = mjflex.geometry.notch_hinge_stiffness(2e-3, 0.3e-3, 5e-3, 70e9, 0.33, method="beam")
    >>> print(f"beam model / tables: {K_beam[2, 2] / K[2, 2]:.3f}")
    beam model / tables: 1.081
    """
    check_positive(R=R, t=t, b=b)
    _method(method, wide)
    shear_constants(E, nu)
    if method == "beam":
        ratio = t / R
        if not allow_out_of_range and not (NOTCH_T_OVER_R[0] <= ratio <= NOTCH_T_OVER_R[1]):
            raise ValueError(
                f"notch hinge t/R = {ratio:.3g} is outside the validated range {NOTCH_T_OVER_R}; pass "
                "allow_out_of_range=True to use the beam model anyway (its error grows outside the range)"
            )
        wide = b >= WIDE_RATIO * t if wide is None else wide
        return np.diag(1.0 / _beam_compliance(lambda x: notch_hinge_thickness(x, R, t), R, b, E, nu, wide))
    if method == "fe":
        fe = _fe_module()
        profile = fe.notch_profile(R, t, block_length)
        C = fe.element_compliance(profile, b, E, nu, level=fe_level, counts=fe.NOTCH_COUNTS)
        return np.diag(1.0 / np.diag(C))
    from .tables import correction_factors  # late: reads the stored FE tables, only for the table method

    f = correction_factors("notch", t / R, b / R, nu)
    return np.diag(f / _beam_compliance(lambda x: notch_hinge_thickness(x, R, t), R, b, E, nu, False))


def leaf_spring_stiffness(
    L, t, b, E, nu, *, method="table", wide=None, allow_out_of_range=False, fe_level=1, block_height=None
):
    r"""6x6 stiffness of a rectangular leaf spring between two blocks, at its centre.

    Parameters
    ----------
    L : float
        Free length between the blocks [m] (along ``x``).
    t : float
        Thickness [m] (along ``y``; the leaf bends across it, about ``z``).
    b : float
        Width [m] (along ``z``); the blocks have the same width.
    E : float
        Young's modulus [Pa].
    nu : float
        Poisson ratio.
    method : {"table", "fe", "beam"}
        See the module docstring. ``"table"`` covers ``1 <= L/t <= 64``, ``1 <= b/t <= 40``,
        ``0.2 <= nu <= 0.45`` and blocks of height ``10 t`` (``LEAF_BLOCK_HEIGHT``), centred on
        the leaf, with sharp corners; it raises outside.
    wide : bool, optional
        ``method="beam"`` only: plane-strain modulus for the compliant bending; default
        ``b >= WIDE_RATIO t``.
    allow_out_of_range : bool
        ``method="beam"`` only: compute for ``L/t < LEAF_MIN_L_OVER_T`` or ``t > b``.
    fe_level : int
        ``method="fe"`` only: mesh level (1: the table's mesh).
    block_height : float, optional
        Height of the blocks [m]; default ``10 t``. Other heights need ``method="fe"`` (the
        axial and shear entries of short leaves depend on it, see Notes).

    Returns
    -------
    K : ndarray, shape (6, 6)
        Diagonal stiffness ``[rot_x, rot_y, rot_z, x, y, z]`` at the centroid (the centre of
        stiffness).

    Notes
    -----
    Error of ``method="table"`` against converged 3-D finite elements with blocks
    (``mjflex.geometry.tables.error_bands("leaf")``), max over the table's range:

    ======================  =======  ==================================
    entry                   band     of which mesh
    ======================  =======  ==================================
    torsion ``rot_x``       1.47 %   0.7 %
    bending ``rot_y``       0.44 %   0.38 %
    compliant ``rot_z``     0.76 %   0.61 %
    axial ``x``             0.47 %   0.38 %
    shear ``y``             1.72 %   1.1 %
    shear ``z``             0.96 %   0.24 %
    ======================  =======  ==================================

    The table's blocks are ``10 t`` high. Their height matters little for the compliant
    rotation (plane stress: 10 t to 20 t changes it by < 0.3 %; 5 t instead of 10 t by 2 % at
    ``L/t = 1``, 0.2 % at 18) but the load spreads into them
    (a half-plane's compliance grows with its size), so the axial and in-plane shear entries
    of short leaves depend on it: give ``block_height`` with ``method="fe"`` when it differs.

    ``method="beam"``: uniform Timoshenko beam (module docstring), as in Fasse & Breedveld
    (1998) for the paper's cantilever flexures: ``K_rot_z = E* I / L``,
    ``K_y = 1 / (L^3 / (12 E* I) + L / (kappa G A))``, ``K_x = E A / L``,
    ``K_rot_x = G J / L``. It leaves out the compliance of the roots in the blocks and the
    warping restraint of torsion there (``python scripts/hinge_fe_check.py``; ``b = 9.5 mm``,
    ``t = 0.5 mm``, ``nu = 0.33``, default ``wide``): stiffness ratio beam / FE in the
    compliant rotation 1.42 at ``L/t = 2``, 1.18 at 5, 1.09 at 18 (the paper's leaf), 1.10 at
    40 (a long wide leaf bends with free anticlastic curvature away from its roots, nearer
    ``E`` than the plane-strain modulus the default ``wide`` uses); in-plane shear 1.84, 1.46,
    1.16, 1.10; axial and out-of-plane entries up to 2.1 for ``L/t = 2``; torsion 0.05-0.8.

    Examples
    --------
    >>> import mjflex
    >>> K = mjflex.geometry.leaf_spring_stiffness(L=10e-3, t=0.5e-3, b=8e-3, E=200e9, nu=0.3)  # steel
    >>> print(f"compliant rotation {K[2, 2]:.4f} N m/rad, in-plane shear {K[4, 4]:.4g} N/m")
    compliant rotation 1.6850 N m/rad, in-plane shear 1.904e+05 N/m
    """
    check_positive(L=L, t=t, b=b)
    _method(method, wide)
    shear_constants(E, nu)
    if method == "beam":
        if not allow_out_of_range and (L / t < LEAF_MIN_L_OVER_T or t > b):
            raise ValueError(
                f"leaf spring with L/t = {L / t:.3g} and t/b = {t / b:.3g} is outside the beam model's range "
                f"(L/t >= {LEAF_MIN_L_OVER_T:g}, t <= b); pass allow_out_of_range=True to use it anyway"
            )
        wide = b >= WIDE_RATIO * t if wide is None else wide
        return np.diag(1.0 / _beam_compliance(lambda x: t, 0.5 * L, b, E, nu, wide))
    from .tables import LEAF_BLOCK_HEIGHT, correction_factors  # late: reads the stored FE tables, for this method

    H = LEAF_BLOCK_HEIGHT * t if block_height is None else block_height
    check_positive(block_height=H)
    if method == "fe":
        fe = _fe_module()
        C = fe.element_compliance(fe.leaf_profile(L, t, H), b, E, nu, level=fe_level, counts=fe.LEAF_COUNTS)
        return np.diag(1.0 / np.diag(C))
    if not math.isclose(H, LEAF_BLOCK_HEIGHT * t, rel_tol=1e-9):
        raise ValueError(
            f"leaf spring block_height = {H:.4g} m is {H / t:.3g} t; the table holds for {LEAF_BLOCK_HEIGHT:g} t "
            "only: use method='fe' for other block heights"
        )
    f = correction_factors("leaf", L / t, b / t, nu)
    return np.diag(f / _beam_compliance(lambda x: t, 0.5 * L, b, E, nu, False))


def bending_strain_per_radian(K, t, b, E, nu, *, wide=None):
    """Peak bending strain at the thinnest section per radian of compliant rotation.

    ``eps / theta = 6 K_rot_z / (E* b t^2)``: the moment ``K_rot_z theta`` over the section
    modulus ``b t^2 / 6`` of the thinnest section, divided by the bending modulus.

    Parameters
    ----------
    K : array_like, shape (6, 6)
        The flexure's stiffness (:func:`notch_hinge_stiffness`, :func:`leaf_spring_stiffness`);
        its compliant-rotation entry ``K[2, 2]`` [N m/rad] is used.
    t : float
        Thickness of the thinnest section [m].
    b : float
        Width of the flexure [m].
    E : float
        Young's modulus [Pa].
    nu : float
        Poisson ratio.
    wide : bool, optional
        Use the plane-strain modulus ``E* = E / (1 - nu^2)``; default ``b >= WIDE_RATIO t``
        (otherwise ``E* = E``).

    Returns
    -------
    float
        Peak bending strain per radian of rotation about the flexure's ``z`` axis [1/rad]: the
        record's ``"strain_per_radian"``.

    Examples
    --------
    >>> import mjflex
    >>> K = mjflex.geometry.notch_hinge_stiffness(2e-3, 0.3e-3, 5e-3, 70e9, 0.33)
    >>> eps = mjflex.geometry.bending_strain_per_radian(K, t=0.3e-3, b=5e-3, E=70e9, nu=0.33)
    >>> print(f"{eps:.4f} per rad: 0.5 % strain at {0.005 / eps:.3f} rad")
    0.1551 per rad: 0.5 % strain at 0.032 rad
    """
    wide = b >= WIDE_RATIO * t if wide is None else wide
    E_bend = E / (1.0 - nu**2) if wide else E
    return 6.0 * np.asarray(K)[2, 2] / (E_bend * b * t * t)

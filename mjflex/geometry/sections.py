"""Cross-sections and materials that the stiffness models share: Saint-Venant's torsion constant of a rectangle,
the shear constants of a material, and the argument checks (no mujoco)."""

import math

import numpy as np


def check_positive(**values):
    """ValueError naming the first of ``values`` (name=value) that is not a positive finite number."""
    for name, v in values.items():
        if not (isinstance(v, int | float | np.floating | np.integer) and math.isfinite(v) and v > 0):
            raise ValueError(f"{name} must be a positive finite number; got {v!r}")


def shear_constants(E, nu):
    """``(G, kappa)``: shear modulus [Pa] and Cowper's shear coefficient of a rectangle, for ``E`` > 0 and ``nu`` in
    [0, 0.5); ValueError naming the bad one."""
    check_positive(E=E)
    if not (0.0 <= nu < 0.5):
        raise ValueError(f"Poisson ratio nu must be in [0, 0.5); got {nu!r}")
    return E / (2.0 * (1.0 + nu)), 10.0 * (1.0 + nu) / (12.0 + 11.0 * nu)


def rectangle_torsion_constant(a, c):
    """Saint-Venant torsion constant of an ``a x c`` rectangle [m^4] (exact series).

    ``J = (A C^3 / 3) [1 - (192 / pi^5)(C / A) sum_{n odd} tanh(n pi A / (2 C)) / n^5]`` with
    ``A = max(a, c)``, ``C = min(a, c)`` (Timoshenko & Goodier, Theory of Elasticity, sec. 109).
    Accepts arrays; the series is summed to round-off.

    Parameters
    ----------
    a, c : float or array_like
        The rectangle's sides [m], in either order (positive; arrays broadcast).

    Returns
    -------
    J : float or ndarray
        The torsion constant [m^4]; the torsional stiffness of a bar of length ``L`` is ``G J / L``.

    Examples
    --------
    >>> import mjflex
    >>> J = mjflex.geometry.rectangle_torsion_constant(8e-3, 0.5e-3)  # a thin strip: about a c^3 / 3
    >>> print(f"{J:.4e} m^4, thin-strip limit {8e-3 * 0.5e-3**3 / 3:.4e} m^4")
    3.2020e-13 m^4, thin-strip limit 3.3333e-13 m^4
    """
    a, c = np.asarray(a, dtype=float), np.asarray(c, dtype=float)
    A, C = np.maximum(a, c), np.minimum(a, c)
    s = np.zeros(np.broadcast(A, C).shape)
    for n in range(1, 40, 2):
        s = s + np.tanh(n * np.pi * A / (2 * C)) / n**5
    return A * C**3 / 3.0 * (1.0 - 192.0 / np.pi**5 * (C / A) * s)

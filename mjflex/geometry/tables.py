r"""Tabulated finite-element corrections of the beam formulas (fast evaluation of the 6x6).

The tables hold, for every diagonal entry ``i`` of the stiffness at the centre, the factor

    f_i = K_i(3-D finite elements, blocks subtracted) / K_i(beam formula, modulus E),

on a grid of the dimensionless ratios that fix it (stiffness scales with ``E``, and with the
length cubed for rotations and linearly for translations, so the ratios are all it depends
on). Notch hinges: ``t/R``, ``b/R``, ``nu``; leaf springs: ``L/t``, ``b/t``, ``nu`` (blocks of
height ``LEAF_BLOCK_HEIGHT * t``). ``log f`` is interpolated with bicubic splines in the log
of the two geometric ratios on each tabulated ``nu``, then quadratically in ``nu``.

The factors, their grid, the mesh, and the measured errors (interpolation at off-grid points
against finite elements on the same mesh, and that mesh against a refined, Richardson-
extrapolated solution) are stored in ``mjflex/geometry/data/*.json``, written by
``python scripts/build_stiffness_tables.py`` (finite elements: :mod:`mjflex.geometry.fe`).
"""

import functools
import json
from importlib import resources

import numpy as np
from scipy.interpolate import RectBivariateSpline

#: Height of a leaf spring's blocks, in leaf thicknesses, for which the leaf table holds.
LEAF_BLOCK_HEIGHT = 10.0
#: The diagonal entries, in order.
ENTRIES = ("rot_x", "rot_y", "rot_z", "x", "y", "z")
#: Names of the table files (package data).
TABLE_FILES = {"notch": "notch_hinge.json", "leaf": "leaf_spring.json"}


@functools.cache
def load_table(kind):
    """The stored table ``kind`` (``"notch"`` or ``"leaf"``) as a dict (JSON of the generator)."""
    text = resources.files(__package__).joinpath("data", TABLE_FILES[kind]).read_text()
    return json.loads(text)


def _splines_of(table):
    a1, a2, nus = (np.asarray(table["axes"][k], float) for k in table["axis_names"])
    logf = np.log(np.asarray(table["factors"], float))  # (n1, n2, n_nu, 6)
    splines = [[RectBivariateSpline(np.log(a1), np.log(a2), logf[:, :, k, i], kx=3, ky=3) for i in range(6)]
               for k in range(nus.size)]  # fmt: skip
    return splines, nus


@functools.cache
def _splines(kind):
    return _splines_of(load_table(kind))


def correction_factors(kind, ratio_1, ratio_2, nu):
    """Factors ``K_FE / K_beam`` (6,) of the diagonal ``[rot_x, rot_y, rot_z, x, y, z]``.

    Parameters
    ----------
    kind : {"notch", "leaf"}
    ratio_1, ratio_2 : float
        ``t/R`` and ``b/R`` (notch) or ``L/t`` and ``b/t`` (leaf).
    nu : float
        Poisson ratio.

    Raises
    ------
    ValueError
        Outside the table (the message names the ratio, the range and the alternatives).
    """
    return _evaluate(load_table(kind), *_splines(kind), ratio_1, ratio_2, nu)


def correction_factors_from(table, ratio_1, ratio_2, nu):
    """:func:`correction_factors` of a table dict that is not (yet) package data."""
    return _evaluate(table, *_splines_of(table), ratio_1, ratio_2, nu)


def _evaluate(table, splines, nus, ratio_1, ratio_2, nu):
    kind, names = table["kind"], table["axis_names"]
    for name, value in zip(names, (ratio_1, ratio_2, nu), strict=True):
        lo, hi = min(table["axes"][name]), max(table["axes"][name])
        if not (lo * (1 - 1e-12) <= value <= hi * (1 + 1e-12)):
            raise ValueError(
                f"{kind} table: {name} = {value:.4g} is outside the tabulated range [{lo:g}, {hi:g}]; use "
                "method='fe' (finite elements, seconds) or method='beam' (closed form, less accurate)"
            )
    per_nu = np.array([[float(s(np.log(ratio_1), np.log(ratio_2))[0, 0]) for s in row] for row in splines])
    # quadratic Lagrange interpolation in nu through the tabulated values
    w = np.array([np.prod([(nu - nus[m]) / (nus[k] - nus[m]) for m in range(nus.size) if m != k])
                  for k in range(nus.size)])  # fmt: skip
    return np.exp(w @ per_nu)


def error_bands(kind):
    """Stored error bands of the table ``kind``: ``{entry: max |relative error|}`` vs converged FE."""
    return dict(load_table(kind)["error_band"])

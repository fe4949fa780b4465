r"""Structured, exactly curved quadratic meshes of a flexure and its two blocks (scikit-fem).

A mesh is the image of a regular lattice in parameter space ``(s, eta, zeta)`` under an
analytic map to ``(x, y, z)``: the lattice is meshed with scikit-fem's tensor meshes
(``MeshQuad1`` / ``MeshHex1``), promoted to quadratic meshes (``MeshQuad2`` / ``MeshHex2``;
the extra nodes sit at parameter-space midpoints) and every node is then moved through the
map. The quadratic nodes therefore lie exactly on the circular notch, and refining a level
(doubling every count) keeps the grading, so meshes of successive levels are geometrically
similar, as Richardson extrapolation needs.

Only the quarter ``y >= 0, z >= 0`` (3-D) or the half ``y >= 0`` (2-D) is meshed: the
flexures are symmetric about ``y = 0`` and ``z = 0``, and :mod:`mjflex.geometry.fe` splits
every load case into symmetric and antisymmetric parts.

Frame (as in :mod:`mjflex.geometry.hinges`): origin at the centre of the flexure, ``x`` along
it, ``y`` across its thin dimension, ``z`` along its width ``b``. The blocks span
``half_length <= |x| <= half_length + block_length`` with full height ``H``; the meshed
solid ends at the faces ``x = +-x_end``.
"""

from dataclasses import dataclass, replace

import numpy as np
from scipy.optimize import brentq
from skfem import MeshHex1, MeshHex2, MeshQuad1, MeshQuad2


@dataclass(frozen=True)
class Counts:
    """Elements per direction at level 1 (each doubles per level).

    ``flexure`` along the flexure (all of ``|x| <= half_length``), ``block`` along each block,
    ``thin`` across the half thickness of the flexure, ``outer`` across the block beyond it
    (leaf springs only), ``width`` across the half width ``b/2`` (3-D only).
    """

    flexure: int = 16
    block: int = 4
    thin: int = 2
    outer: int = 3
    width: int = 3

    def at(self, level):
        k = 2 ** (int(level) - 1)
        return Counts(*(k * getattr(self, f) for f in ("flexure", "block", "thin", "outer", "width")))


DEFAULT_COUNTS = Counts()  # a module constant: the default of the mesh functions (frozen, so shared safely)


def _graded(u, c):
    """Map ``u`` in [0, 1] to [0, 1] with points clustered towards 0 (``c > 0``); ``c = 0``: identity."""
    return u if c == 0 else np.expm1(c * u) / np.expm1(c)


def _width_map(zeta, half_width, edge, layers):
    """``z(zeta)`` on [0, b/2], clustered towards the free face ``z = b/2``.

    The grading puts the outermost of ``layers`` equal parameter steps at about ``edge``; it is
    fixed at level 1, so finer levels subdivide the same map.
    """
    c = _grading_for_first_cell(edge / half_width, layers)
    return half_width * (1.0 - _graded(1.0 - zeta, c))


def _grading_for_first_cell(fraction, n):
    """Grading ``c`` for which the first of ``n`` equal parameter steps maps to ``fraction`` of the length."""
    if n == 1 or fraction >= 1.0 / n:  # one step is the whole length: no grading moves a lattice vertex
        return 0.0
    return brentq(lambda c: np.expm1(c / n) / np.expm1(c) - fraction, 1e-9, 200.0, xtol=1e-300)


def _columns(block, flexure):
    """Parameter ``s`` of the lattice's columns: ``block`` per block in [-2, -1] and [1, 2], ``flexure`` in [-1, 1]."""
    return np.concatenate([np.linspace(-2, -1, block + 1)[:-1], np.linspace(-1, 1, flexure + 1),
                           np.linspace(1, 2, block + 1)[1:]])  # fmt: skip


@dataclass(frozen=True)
class NotchProfile:
    """Right-circular notch of radius ``R`` and web ``t`` cut into a bar of height ``H = t + 2R``.

    ``filled=True`` gives the plain bar of the same outline (the reference of the block
    subtraction in :mod:`mjflex.geometry.fe`), meshed with the same block columns.
    """

    R: float
    t: float
    block_length: float
    filled: bool = False

    @property
    def half_length(self):
        return self.R

    @property
    def height(self):
        return self.t + 2.0 * self.R

    @property
    def x_end(self):
        return self.R + self.block_length

    def _neck_grading(self):
        # half of the notch columns within |phi| <= 2 sqrt(t/R), where the bending strain concentrates
        q = min(1.0, 4.0 / np.pi * np.sqrt(self.t / self.R))
        return 0.0 if q >= 0.5 else 2.0 * np.arccosh(1.0 / (2.0 * q))

    def lattice(self, n: Counts):
        return _columns(n.block, n.flexure), np.linspace(0.0, 1.0, n.thin + 1)

    def mask(self, s_mid, eta_mid):
        return np.ones((s_mid.size, eta_mid.size), bool)

    def _angle(self, s):
        a = self._neck_grading()
        sc = np.clip(s, -1.0, 1.0)
        return 0.5 * np.pi * (np.sinh(a * sc) / np.sinh(a) if a > 0 else sc)

    def _foot(self, s):
        """Column foot on ``y = 0``: near-vertical columns at the neck, evenly spread at the roots."""
        phi = self._angle(s)
        sin2 = np.sin(phi) ** 2
        m = self.R * ((1.0 - sin2) * np.sin(phi) + sin2 * 2.0 * phi / np.pi)
        u = np.clip(np.abs(s) - 1.0, 0.0, 1.0)
        return np.where(np.abs(s) <= 1.0, m, np.sign(s) * (self.R + self.block_length * _graded(u, 1.5)))

    def map(self, s, eta, lattice):
        """Physical ``(x, y)`` of parameter points (arrays of the same shape), upper half."""
        sv = lattice[0]
        phi = _between(s, sv, self._angle(sv))  # mid-nodes at the mid-angle: on the arc
        foot = _between(s, sv, self._foot(sv))  # straight bottom edges, mid-nodes at midpoints
        inner = np.abs(s) <= 1.0
        if self.filled:
            top_x, top_y = foot, np.full_like(foot, 0.5 * self.height)
        else:
            top_x = np.where(inner, self.R * np.sin(phi), foot)
            top_y = np.where(inner, 0.5 * self.height - self.R * np.cos(phi), 0.5 * self.height)
        return foot + eta * (top_x - foot), eta * top_y


def _towards(u, beta):
    """Map ``u`` in [0, 1] to [0, 1] with power grading ``beta`` towards 1 (a corner there)."""
    return 1.0 - (1.0 - u) ** beta


#: Power of the grading towards the re-entrant corners of a leaf. Near such a corner the
#: displacement varies as r^0.54; elements of size ~ (distance)^(1 - 1/beta) with beta > 2/0.54
#: keep the quadratic elements' h^4 convergence of the compliance.
CORNER_GRADING = 3.0


@dataclass(frozen=True)
class LeafProfile:
    """Leaf of length ``L`` and thickness ``t`` between blocks of height ``H`` (sharp corners).

    ``filled=True``: the plain bar of height ``H`` with the same lattice (reference). The leaf's
    element count grows with ``(L / t)^(1/3)`` so long leaves keep sensible element shapes.
    """

    L: float
    t: float
    H: float
    block_length: float
    filled: bool = False

    @property
    def half_length(self):
        return 0.5 * self.L

    @property
    def height(self):
        return self.H

    @property
    def x_end(self):
        return 0.5 * self.L + self.block_length

    def _leaf_columns(self, n):
        return 2 * int(np.ceil(0.5 * n.flexure * max(1.0, 0.5 * (self.L / self.t) ** (1 / 3))))

    def lattice(self, n: Counts):
        eta = np.concatenate([np.linspace(0, 1, n.thin + 1), np.linspace(1, 2, n.outer + 1)[1:]])
        return _columns(n.block, self._leaf_columns(n)), eta

    def mask(self, s_mid, eta_mid):
        keep = np.ones((s_mid.size, eta_mid.size), bool)
        if not self.filled:
            keep &= ~((np.abs(s_mid)[:, None] < 1.0) & (eta_mid[None, :] > 1.0))
        return keep

    def _x(self, s):
        a = np.abs(s)
        xl = 0.5 * self.L * _towards(np.clip(a, 0, 1), CORNER_GRADING)
        xb = 0.5 * self.L + self.block_length * (1.0 - _towards(1.0 - np.clip(a - 1, 0, 1), CORNER_GRADING))
        return np.sign(s) * np.where(a <= 1.0, xl, xb)

    def _y(self, eta):
        yi = 0.5 * self.t * _towards(np.clip(eta, 0, 1), CORNER_GRADING)
        yo = 0.5 * self.t + 0.5 * (self.H - self.t) * (1.0 - _towards(1.0 - np.clip(eta - 1.0, 0, 1), CORNER_GRADING))
        return np.where(eta <= 1.0, yi, yo)

    def map(self, s, eta, lattice):
        """Physical ``(x, y)``: graded vertices, straight-sided (rectangular) elements."""
        return _between(s, lattice[0], self._x(lattice[0])), _between(eta, lattice[1], self._y(lattice[1]))


def _between(u, vertices, values):
    """Piecewise-linear map through ``values`` at the lattice ``vertices``.

    Grading is applied to the vertices only; mid-nodes land at the midpoints of straight
    edges, so every straight-sided element is affine along that direction and the quadratic
    elements keep representing all quadratic fields (pure bending and tension exactly).
    """
    return np.interp(u, vertices, values)


def _mids(v):
    return 0.5 * (v[1:] + v[:-1])


def _quadratic(profile, lin_cls, quad_cls, lattice):
    """The quadratic mesh of the lattice's cells that ``profile`` keeps (found by their centres)."""
    mesh = lin_cls.init_tensor(*lattice)
    centres = mesh.p[:, mesh.t].mean(axis=1)
    s, eta = lattice[:2]
    keep = profile.mask(_mids(s), _mids(eta))[np.searchsorted(s, centres[0]) - 1, np.searchsorted(eta, centres[1]) - 1]
    if not keep.all():
        mesh = mesh.remove_elements(np.flatnonzero(~keep))
    return quad_cls.from_mesh(mesh)


def section_mesh(profile, level=1, counts=DEFAULT_COUNTS):
    """Quadratic 2-D mesh (``MeshQuad2``) of the half ``y >= 0`` of the flexure and its blocks."""
    s, eta = profile.lattice(counts.at(level))
    mesh = _quadratic(profile, MeshQuad1, MeshQuad2, (s, eta))
    x, y = profile.map(*mesh.doflocs, (s, eta))
    return replace(mesh, doflocs=np.vstack([x, y]))


def solid_mesh(profile, width, level=1, counts=DEFAULT_COUNTS):
    """Quadratic 3-D mesh (``MeshHex2``) of the quarter ``y >= 0, z >= 0`` (``width`` is the full ``b``)."""
    n = counts.at(level)
    s, eta = profile.lattice(n)
    zeta = np.linspace(0.0, 1.0, n.width + 1)
    mesh = _quadratic(profile, MeshHex1, MeshHex2, (s, eta, zeta))
    x, y = profile.map(mesh.doflocs[0], mesh.doflocs[1], (s, eta))
    z = _between(mesh.doflocs[2], zeta, _width_map(zeta, 0.5 * width, 0.5 * profile.t, counts.width))
    return replace(mesh, doflocs=np.vstack([x, y, z]))

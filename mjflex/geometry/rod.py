r"""Large-deflection statics of a planar leaf spring as a chain of short mjflex elements.

A fine reference model for fitting higher-order potentials (:func:`mjflex.fit_potential`): the
leaf (length ``L``, thickness ``t`` across the plane of bending, width ``b``) is cut into ``n``
segments of length ``h = L/n``; consecutive nodes are joined by planar twist elements whose frames
sit at the segment midpoints, with the stiffness of the section per unit length divided by ``h``,

    ``K_seg = diag(E* I, E A, kappa G A) / h``   (rows ``[theta; x; y]``, x along the leaf),

so that the energy is ``h/2 eps^T C eps`` for a segment of constant strain ``eps = xi/h``. As
``n`` grows the chain converges (error ``O(h^2)``) to the geometrically exact planar Reissner
rod (bending, stretching and shear at any deflection); for ``t << L`` that is the Euler elastica.
``E* = E/(1 - nu^2)`` for wide leaves (``b >= WIDE_RATIO t``) as in
:func:`mjflex.geometry.leaf_spring_stiffness`; ``kappa`` is Cowper's shear coefficient.

Node 0 is clamped at the origin with the leaf along +x; the load acts on the last node (the tip):
a moment ``M_z`` and a force ``(F_x, F_y)`` fixed in world axes (planar loads of this kind are
conservative). :func:`leaf_spring_statics` minimizes the total potential by Newton's method with
load continuation and a line search, and raises if it does not converge; the Hessian is the
finite-difference Jacobian of the element wrenches (9 coloured perturbations, the chain being
tridiagonal).
"""

import numpy as np
from scipy.linalg import solve_banded

from ..core import planar_potential, planar_wrench_on_b
from .hinges import WIDE_RATIO
from .sections import check_positive, shear_constants

#: Relative (to ``E* I / L`` and ``E* I / L^2``) equilibrium residual at which Newton stops, or
#: 100 times the round-off of the axial forces (``E A / h`` times ``eps L``) if that is larger.
RESIDUAL_RTOL = 1e-10


def rod_segment_stiffness(h, t, b, E, nu, *, wide=None):
    """Planar 3x3 stiffness ``diag(E* I, E A, kappa G A) / h`` of a segment of length ``h`` [m].

    Rows ``[theta; x; y]`` (``N m/rad``, ``N/m``), about the segment's midpoint, x along it.

    Parameters
    ----------
    h : float
        Segment length [m].
    t : float
        Leaf thickness (in the plane of bending) [m].
    b : float
        Leaf width [m].
    E : float
        Young's modulus [Pa].
    nu : float
        Poisson ratio (the shear modulus and Cowper's shear coefficient ``kappa``).
    wide : bool, optional
        Use the plane-strain modulus ``E* = E / (1 - nu^2)`` in bending; default for wide
        leaves (``b >= WIDE_RATIO t``, as :func:`mjflex.geometry.leaf_spring_stiffness`).

    Returns
    -------
    K : ndarray, shape (3, 3)
        Diagonal planar stiffness ``[theta; x; y]`` (N m/rad, N/m).

    Examples
    --------
    >>> import mjflex
    >>> K = mjflex.geometry.rod_segment_stiffness(h=1e-3, t=0.5e-3, b=8e-3, E=200e9, nu=0.3)
    >>> print(f"bending {K[0, 0]:.4g} N m/rad, axial {K[1, 1]:.4g} N/m, shear {K[2, 2]:.4g} N/m")
    bending 18.32 N m/rad, axial 8e+08 N/m, shear 2.614e+08 N/m
    """
    check_positive(h=h, t=t, b=b)
    G, kappa = shear_constants(E, nu)
    wide = b >= WIDE_RATIO * t if wide is None else wide
    E_bend = E / (1.0 - nu**2) if wide else E
    A = b * t
    return np.diag([E_bend * b * t**3 / 12.0, E * A, kappa * G * A]) / h


class LeafChain:
    """A clamped leaf spring as a chain of ``n`` planar twist elements (module docstring).

    Parameters
    ----------
    L, t, b : float
        Length, thickness and width [m].
    E, nu : float
        Young's modulus [Pa] and Poisson ratio.
    n : int
        Number of segments (>= 2).
    wide : bool, optional
        Plane-strain bending modulus; default ``b >= WIDE_RATIO t``.

    Examples
    --------
    >>> import numpy as np
    >>> import mjflex
    >>> chain = mjflex.geometry.LeafChain(L=0.04, t=0.5e-3, b=8e-3, E=200e9, nu=0.3, n=20)
    >>> q = chain.solve([chain.EI / chain.L, 0.0, 0.0])  # a tip moment bending the leaf by 1 rad
    >>> print(f"tip rotation {q[-1, 0]:.6f} rad")  # pure bending: M L / EI
    tip rotation 1.000000 rad
    """

    def __init__(self, L, t, b, E, nu, *, n=40, wide=None):
        check_positive(L=L)
        if not (isinstance(n, int) and n >= 2):
            raise ValueError(f"n must be an integer >= 2 (number of segments); got {n!r}")
        self.L, self.n, self.h = float(L), n, L / n
        self.K = rod_segment_stiffness(self.h, t, b, E, nu, wide=wide)
        self.EI = self.K[0, 0] * self.h
        roundoff = np.finfo(float).eps * self.K[1, 1] * self.L / (self.EI / self.L**2)
        self.tolerance = max(RESIDUAL_RTOL, 100.0 * roundoff)
        self._half = np.array([0.5 * self.h, 0.0])

    def _frames(self, q):
        """Element frames (theta_a, p_a, theta_b, p_b) for node poses ``q`` (n+1, 3)."""
        th, p = q[:, 0], q[:, 1:]
        c, s = np.cos(th), np.sin(th)
        off = self._half[0] * np.stack([c, s], axis=1)
        return th[:-1], p[:-1] + off[:-1], th[1:], p[1:] - off[1:]

    def _forces(self, q, load):
        """Generalized forces ``[moment about the node; fx; fy]`` on every node, shape (n+1, 3)."""
        ta, pa, tb, pb = self._frames(q)
        W = planar_wrench_on_b(ta, pa, tb, pb, self.K, check=False)
        G = np.zeros_like(q)
        rb = pb - q[1:, 1:]  # frame b relative to node i+1
        ra = pb - q[:-1, 1:]  # frame b relative to node i
        G[1:, 0] += W[:, 0] + rb[:, 0] * W[:, 2] - rb[:, 1] * W[:, 1]
        G[1:, 1:] += W[:, 1:]
        G[:-1, 0] -= W[:, 0] + ra[:, 0] * W[:, 2] - ra[:, 1] * W[:, 1]
        G[:-1, 1:] -= W[:, 1:]
        G[-1] += load
        return G

    def energy(self, q, load):
        """Total potential: elastic energy minus the work of the tip load [J]."""
        ta, pa, tb, pb = self._frames(q)
        return float(np.sum(planar_potential(ta, pa, tb, pb, self.K, check=False)) - load @ q[-1])

    def _hessian(self, q, load):
        """``-dG/dq`` of the free nodes by coloured central differences, shape (3n, 3n)."""
        n = self.n
        H = np.zeros((3 * n, 3 * n))
        steps = np.array([1e-6, 1e-6 * self.L, 1e-6 * self.L])
        for colour in range(3):
            nodes = np.arange(1 + colour, n + 1, 3)
            for d in range(3):
                dq = np.zeros_like(q)
                dq[nodes, d] = steps[d]
                dG = (self._forces(q + dq, load) - self._forces(q - dq, load)) / (2 * steps[d])
                for j in nodes:
                    for k in range(max(j - 1, 1), min(j + 1, n) + 1):
                        H[3 * (k - 1) : 3 * k, 3 * (j - 1) + d] = -dG[k]
        return 0.5 * (H + H.T)

    def _scale(self):
        return np.array([self.EI / self.L, self.EI / self.L**2, self.EI / self.L**2])

    def solve(self, load, q0=None, *, steps=4, max_iter=40):
        """Node poses ``(n+1, 3)`` rows ``(theta, x, y)`` in equilibrium under the tip ``load``.

        Parameters
        ----------
        load : array_like, shape (3,)
            ``(M_z, F_x, F_y)`` on the tip [N m, N, N], world axes, moment about the tip node.
        q0 : ndarray, shape (n+1, 3), optional
            Starting configuration (default the straight leaf); the load is ramped in ``steps``.

        Raises
        ------
        RuntimeError
            If Newton's method does not reach ``tolerance`` (e.g. past a buckling load).
        """
        load = np.asarray(load, dtype=float)
        q = self.straight() if q0 is None else np.array(q0, dtype=float)
        scale = self._scale()
        for lam in np.linspace(0.0, 1.0, steps + 1)[1:]:
            f = lam * load
            for _ in range(max_iter):
                G = self._forces(q, f)
                if np.abs(G[1:] / scale).max() <= self.tolerance:
                    break
                dq = _solve_banded(self._hessian(q, f), G[1:].reshape(-1)).reshape(-1, 3)
                q = self._line_search(q, dq, f)
            else:
                raise RuntimeError(
                    f"leaf chain statics did not converge under load {f} (residual {np.abs(G[1:] / scale).max():.3g}); "
                    "the load may exceed a buckling load: reduce it or pass more continuation steps="
                )
        return q

    def _line_search(self, q, dq, load):
        e0 = self.energy(q, load)
        step = 1.0
        for _ in range(30):
            trial = q.copy()
            trial[1:] += step * dq
            if self.energy(trial, load) <= e0 + 1e-14 * abs(e0):
                return trial
            step *= 0.5
        trial = q.copy()
        trial[1:] += step * dq
        return trial

    def straight(self):
        """The unloaded configuration: nodes along +x."""
        q = np.zeros((self.n + 1, 3))
        q[:, 1] = np.linspace(0.0, self.L, self.n + 1)
        return q

    def residual(self, q, load):
        """Largest equilibrium residual of the free nodes, relative to ``E I / L`` and ``E I / L^2``."""
        return float(np.abs(self._forces(q, np.asarray(load, dtype=float))[1:] / self._scale()).max())


def _solve_banded(H, g):
    """Solve ``H x = g`` for the chain's Hessian (half bandwidth 5: neighbouring nodes only)."""
    n, w = len(H), 5
    ab = np.zeros((2 * w + 1, n))
    for u in range(-w, w + 1):
        ab[w - u, max(u, 0) : n + min(u, 0)] = np.diagonal(H, u)
    return solve_banded((w, w), ab, g)

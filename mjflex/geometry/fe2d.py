"""A small 2-D finite-element check of flexure stiffness (independent of the beam model).

The flexure is the region ``|x| <= half_length``, ``|y| <= h(x)/2`` of a plate of width ``b``
(out of the plane). It is meshed with a mapped grid of 9-node biquadratic (Q9) elements,
clamped on the left edge, and its right edge is made rigid (three master degrees of freedom
``u, v, theta`` about the edge centre). The condensed 3x3 stiffness of that edge is moved to
the centre of the flexure, giving the in-plane compliances ``x`` (axial), ``y`` (shear) and
``rot_z`` that the beam model of :mod:`mjflex.geometry.hinges` predicts.

Used by the tests and by ``scripts/hinge_fe_check.py`` to state the beam model's error.
"""

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.linalg import splu

_G = np.array([-np.sqrt(0.6), 0.0, np.sqrt(0.6)])
_W = np.array([5.0, 8.0, 5.0]) / 9.0


def _shape_1d(s):
    return np.array([0.5 * s * (s - 1), 1 - s * s, 0.5 * s * (s + 1)]), np.array([s - 0.5, -2 * s, s + 0.5])


def _elasticity(E, nu, plane):
    if plane == "stress":
        return E / (1 - nu**2) * np.array([[1, nu, 0], [nu, 1, 0], [0, 0, (1 - nu) / 2]])
    c = E / ((1 + nu) * (1 - 2 * nu))
    return c * np.array([[1 - nu, nu, 0], [nu, 1 - nu, 0], [0, 0, (1 - 2 * nu) / 2]])


def _element_stiffness(xy, D, width):
    """Stiffness (18x18) of a Q9 element with node coordinates ``xy`` (3x3 grid, [i_xi, i_eta, 2])."""
    Ke = np.zeros((18, 18))
    for a, wa in zip(_G, _W, strict=True):
        Na, dNa = _shape_1d(a)
        for c, wc in zip(_G, _W, strict=True):
            Nc, dNc = _shape_1d(c)
            dxi = np.outer(dNa, Nc).ravel()  # dN/dxi for nodes ordered (i_xi, i_eta)
            deta = np.outer(Na, dNc).ravel()
            pts = xy.reshape(9, 2)
            J = np.array([dxi @ pts, deta @ pts])  # [[dx/dxi, dy/dxi], [dx/deta, dy/deta]]
            det = np.linalg.det(J)
            dN = np.linalg.solve(J, np.array([dxi, deta]))  # rows: dN/dx, dN/dy
            Bm = np.zeros((3, 18))
            Bm[0, 0::2] = dN[0]
            Bm[1, 1::2] = dN[1]
            Bm[2, 0::2] = dN[1]
            Bm[2, 1::2] = dN[0]
            Ke += Bm.T @ D @ Bm * det * wa * wc * width
    return Ke


def centre_compliance(h, half_length, width, E, nu, *, plane="stress", nx=60, ny=4, grading=2.0):
    """In-plane compliance ``diag(C_x, C_y, C_rot_z)`` at the centre of a flexure, by 2-D FE.

    Parameters
    ----------
    h : callable
        Thickness ``h(x)`` [m] for ``|x| <= half_length``.
    half_length : float
        Half length of the meshed region [m]; both ends are its clamped / rigid edges.
    width : float
        Out-of-plane width ``b`` [m].
    E, nu : float
        Material [Pa, -].
    plane : {"stress", "strain"}
        2-D idealization.
    nx, ny : int
        Elements along x and across y.
    grading : float
        Exponent clustering the elements towards ``x = 0`` (the neck).

    Returns
    -------
    C : ndarray, shape (3, 3)
        Compliance relating ``[F_x, F_y, M_z]`` at the centre to the displacement ``[u, v, theta]``
        of the right edge's rigid body referred to the centre.
    """
    # node grid: 2 nx + 1 columns, 2 ny + 1 rows, x graded towards 0 (symmetric)
    s = np.linspace(-1.0, 1.0, 2 * nx + 1)
    x = half_length * np.sign(s) * np.abs(s) ** grading
    eta = np.linspace(-1.0, 1.0, 2 * ny + 1)
    X = np.repeat(x[:, None], eta.size, axis=1)
    Y = eta[None, :] * np.array([h(xi) for xi in x])[:, None] / 2.0
    nodes = np.stack([X, Y], -1)  # (cols, rows, 2)
    ncol, nrow = nodes.shape[:2]
    index = np.arange(ncol * nrow).reshape(ncol, nrow)
    D = _elasticity(E, nu, plane)
    rows, cols, vals = [], [], []
    for i in range(nx):
        for j in range(ny):
            ids = index[2 * i : 2 * i + 3, 2 * j : 2 * j + 3].ravel()
            Ke = _element_stiffness(nodes[2 * i : 2 * i + 3, 2 * j : 2 * j + 3], D, width)
            dofs = np.stack([2 * ids, 2 * ids + 1], -1).ravel()
            rows.append(np.repeat(dofs, 18))
            cols.append(np.tile(dofs, 18))
            vals.append(Ke.ravel())
    n = 2 * ncol * nrow
    K = coo_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(n, n)).tocsc()
    left = index[0].ravel()
    right = index[-1].ravel()
    fixed = np.concatenate([2 * left, 2 * left + 1])
    ridge = np.concatenate([2 * right, 2 * right + 1])
    free = np.setdiff1d(np.arange(n), np.concatenate([fixed, ridge]))
    # rigid right edge: u = U - theta y, v = V (edge centre at (half_length, 0))
    T = np.zeros((ridge.size, 3))
    T[: right.size, 0] = 1.0
    T[: right.size, 2] = -nodes[-1, :, 1]
    T[right.size :, 1] = 1.0
    K_ff = K[free][:, free]
    K_fr = K[free][:, ridge] @ T
    K_rr = T.T @ (K[ridge][:, ridge] @ T)
    S = K_rr - K_fr.T @ splu(K_ff).solve(K_fr)  # condensed stiffness of the rigid edge
    C_end = np.linalg.inv(0.5 * (S + S.T))
    # refer to the centre: [U, V, theta]_edge = A [U, V, theta]_centre
    A = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, half_length], [0.0, 0.0, 1.0]])
    Ainv = np.linalg.inv(A)
    return Ainv @ C_end @ Ainv.T

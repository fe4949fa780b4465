r"""Linear-elastic finite elements of a flexure with its blocks (scikit-fem): the element's 6x6.

The element stiffness ``K`` is what a lumped model (two rigid bodies joined at the flexure's
ends ``x = +-half_length`` plus the element at the centre) needs to reproduce the elastic
solid. It is found in three steps, all in the flexure frame (origin at the centre; ``x``
along, ``y`` across the thin dimension, ``z`` along the width ``b``; rows
``[rot_x, rot_y, rot_z, x, y, z]``):

1. **Flexure with blocks.** The solid (flexure plus a block of the full height on each side,
   :mod:`mjflex.geometry.fe_mesh`) is meshed with quadratic elements. Its two end faces
   ``x = +-x_end`` are rigid couplings (multi-point constraints): every node of a face moves
   with one master rigid motion ``u = U + Theta x (p - c)`` about the face centre ``c``. The
   left master is fixed, the right one carries the load; condensing the solid onto it gives
   the face-to-face compliance ``C_c`` at ``c = (x_end, 0, 0)``, which is moved to the centre
   with the rigid-body adjoint, ``C = A C_c A^T``. A rigid coupling is used (not a fit of the
   face's displacement) because the lumped bodies are rigid and it gives an exactly symmetric
   compliance from one condensation; it stiffens the solid locally (it stops the face's
   Poisson contraction and warping), an error that the next step removes.
2. **Blocks subtracted.** The same computation on the plain bar of the same outline (the
   flexure region filled to the full height, the block meshes identical) gives ``C_bar``.
   The end effects of the couplings and the discretisation error of the blocks are the same
   in both, so ``C - C_bar`` is the compliance that cutting the flexure adds to the bar,
   measured between rigid motions of the blocks far from it.
3. **Plain segment added back.** The plain bar's own compliance over ``|x| <= half_length``
   (Saint-Venant / Timoshenko beam of the full section, :func:`plain_segment_compliance`)
   is added, so that the result is the flexure's compliance between rigid bodies at its
   ends: ``C_element = C - C_bar + C_segment``, ``K = C_element^-1``. In other words the
   blocks' plain-bar compliance (beyond ``|x| = half_length``) is subtracted, with the end
   effects of the couplings removed. The plain segment uses Cowper's shear coefficient (the
   section-average definition of the deflection); the energy definition (5/6) instead would
   change only the shear rows, by up to 0.9 % (``t/R = 1``, ``nu = 0.45``; 0.02 % at
   ``t/R = 0.05``).

Blocks are as long as they are high (``notch_profile``, ``leaf_profile``): long enough that
the flexure's disturbance has decayed at the coupled faces. Doubling them changes the axial
entry by < 0.5 % and the others by < 0.05 % (2-D check, ``t/R`` 0.05-1 and ``L/t`` 1-8).

The flexure is symmetric about ``x = 0``, ``y = 0`` and ``z = 0``, so ``K`` is diagonal at the
centre (the centre of stiffness). Only the quarter ``y, z >= 0`` (the half ``y >= 0`` in 2-D)
is meshed; the six load cases split into four symmetry classes, each solved with its own
symmetry conditions: ``{F_x}``, ``{F_y, M_z}``, ``{F_z, M_y}`` and ``{M_x}``.

2-D models (``model="plane_stress"`` or ``"plane_strain"``, width ``b`` out of the plane)
give the in-plane rows ``rot_z, x, y``; 3-D (``model="solid"``) gives all six.
"""

from dataclasses import dataclass

import numpy as np
from scipy.sparse import coo_matrix, csr_matrix
from scipy.sparse.linalg import splu
from skfem import Basis, ElementHex2, ElementQuad2

from .fe_mesh import Counts, LeafProfile, NotchProfile, section_mesh, solid_mesh
from .sections import rectangle_torsion_constant, shear_constants

#: Models accepted by the functions of this module.
MODELS = ("solid", "plane_stress", "plane_strain")
#: Meshes of the stored tables and of ``method="fe"`` at ``fe_level=1`` (each level doubles every count).
NOTCH_COUNTS = Counts(flexure=24, block=4, thin=3, outer=3, width=3)
LEAF_COUNTS = Counts(flexure=16, block=6, thin=4, outer=4, width=3)

# symmetry classes: (antisymmetric about y = 0, antisymmetric about z = 0, active master dofs)
# master dofs are numbered [rot_x, rot_y, rot_z, x, y, z]
_CLASSES_3D = ((False, False, (3,)), (True, False, (2, 4)), (False, True, (1, 5)), (True, True, (0,)))
_CLASSES_2D = ((False, False, (3,)), (True, False, (2, 4)))
_OUT_OF_PLANE = [0, 1, 5]


def _lame(E, nu, model):
    lam, mu = E * nu / ((1 + nu) * (1 - 2 * nu)), E / (2 * (1 + nu))
    if model == "plane_stress":
        lam = 2 * lam * mu / (lam + 2 * mu)
    return lam, mu


@dataclass
class _Assembled:
    K: csr_matrix
    X: np.ndarray  # (dim, ndofs) location of each dof
    comp: np.ndarray  # (ndofs,) displacement component of each dof
    dim: int


def _assemble(mesh, E, nu, model):
    """Global stiffness of the vector elasticity problem on a quadratic mesh.

    scikit-fem supplies the quadratic scalar basis (shape-function gradients through the
    curved element map, 3-point Gauss rule per direction); the element matrices
    ``K_e[a i, b j] = int lam N_a,i N_b,j + mu (delta_ij grad N_a . grad N_b + N_a,j N_b,i)``
    are formed here by batched products (scikit-fem's generic vector assembly is far slower
    for 27-node hexahedra); the test suite checks them against
    ``skfem.models.elasticity.linear_elasticity``. Dof ``d * node + i`` is component ``i`` of
    node ``node``.
    """
    dim = mesh.p.shape[0]
    basis = Basis(mesh, ElementHex2() if dim == 3 else ElementQuad2(), intorder=4)
    lam, mu = _lame(E, nu, model)
    n = basis.Nbfun
    G = np.stack([basis.basis[a][0].grad for a in range(n)])  # (n, dim, elements, points)
    G = G.transpose(2, 3, 0, 1).reshape(G.shape[2], G.shape[3], n * dim)  # (e, q, a i)
    Gw = G * basis.dx[:, :, None]
    A = (Gw.transpose(0, 2, 1) @ G).reshape(-1, n, dim, n, dim)  # sum_q w N_a,i N_b,j
    L = np.trace(A, axis1=2, axis2=4)  # sum_q w grad N_a . grad N_b
    Ke = lam * A + mu * A.swapaxes(2, 4)
    Ke += mu * L[:, :, None, :, None] * np.eye(dim)[None, None, :, None, :]
    dofs = (dim * basis.element_dofs.T[:, :, None] + np.arange(dim)).reshape(-1, n * dim)  # (e, a i)
    rows = np.repeat(dofs, n * dim, axis=1).ravel()
    cols = np.tile(dofs, (1, n * dim)).ravel()
    N = dim * basis.N
    K = coo_matrix((Ke.ravel(), (rows, cols)), shape=(N, N)).tocsr()
    X = np.repeat(basis.doflocs, dim, axis=1)
    comp = np.tile(np.arange(dim), basis.N)
    return _Assembled(K, X, comp, dim)


def _rigid_rows(X, comp, dim, centre, masters):
    """Coefficients of the face dofs on the master dofs: ``u_k = U_k + (Theta x (p - c))_k``."""
    r = X - np.asarray(centre)[:dim, None]
    rx, ry = r[0], r[1]
    rz = r[2] if dim == 3 else np.zeros_like(rx)
    # d u_k / d [Theta_x, Theta_y, Theta_z, U_x, U_y, U_z]
    table = {
        0: {1: rz, 2: -ry, 3: 1.0},  # u_x = U_x + Theta_y r_z - Theta_z r_y
        1: {0: -rz, 2: rx, 4: 1.0},  # u_y = U_y + Theta_z r_x - Theta_x r_z
        2: {0: ry, 1: -rx, 5: 1.0},  # u_z = U_z + Theta_x r_y - Theta_y r_x
    }
    coeff = np.zeros((comp.size, len(masters)))
    for j, m in enumerate(masters):
        for k in range(dim):
            if m in table[k]:
                sel = comp == k
                coeff[sel, j] = np.broadcast_to(table[k][m], comp.shape)[sel]
    return coeff


def _class_compliance(a, x_end, anti_y, anti_z, masters):
    """Compliance of the right face's master dofs (left face clamped) for one symmetry class."""
    X, comp, dim = a.X, a.comp, a.dim
    tol = 1e-9 * x_end
    right = np.abs(X[0] - x_end) < tol
    left = np.abs(X[0] + x_end) < tol
    fixed = left.copy()
    on_y0 = np.abs(X[1]) < tol
    fixed |= on_y0 & (np.isin(comp, (0, 2)) if anti_y else comp == 1)
    if dim == 3:
        on_z0 = np.abs(X[2]) < tol
        fixed |= on_z0 & (np.isin(comp, (0, 1)) if anti_z else comp == 2)
    fixed &= ~right  # the coupling defines the right face (its rigid motions respect the symmetry)
    free = np.flatnonzero(~fixed & ~right)
    face = np.flatnonzero(right)
    coeff = _rigid_rows(X[:, face], comp[face], dim, (x_end, 0.0, 0.0), masters)
    n_free, n_m = free.size, len(masters)
    rows = np.concatenate([free, np.repeat(face, n_m)])
    cols = np.concatenate([np.arange(n_free), n_free + np.tile(np.arange(n_m), face.size)])
    vals = np.concatenate([np.ones(n_free), coeff.ravel()])
    T = coo_matrix((vals, (rows, cols)), shape=(comp.size, n_free + n_m)).tocsc()
    S = (T.T @ a.K @ T).tocsc()
    rhs = np.zeros((n_free + n_m, n_m))
    rhs[n_free:, :] = np.eye(n_m)
    u = splu(S).solve(rhs)
    return u[n_free:, :]


def face_compliance(mesh, E, nu, x_end, model="solid", width=None):
    """Compliance (6x6) of the rigid right face about its centre ``(x_end, 0, 0)``, left face clamped.

    Parameters
    ----------
    mesh : skfem.MeshHex2 or skfem.MeshQuad2
        Quarter ``y, z >= 0`` (3-D) or half ``y >= 0`` (2-D) of a solid symmetric about
        ``y = 0`` and ``z = 0`` whose end faces are ``x = +-x_end`` [m].
    E, nu : float
        Young's modulus [Pa] and Poisson ratio.
    model : {"solid", "plane_stress", "plane_strain"}
    width : float
        Out-of-plane width ``b`` [m] of a 2-D model.

    Returns
    -------
    C : ndarray, shape (6, 6)
        Rows ``[rot_x, rot_y, rot_z, x, y, z]``: rotation [rad] and displacement [m] of the
        face's rigid motion per unit moment [N m] and force [N] at the face centre, axes of the
        flexure frame. A 2-D model fills only the in-plane rows ``rot_z, x, y`` (others zero).
    """
    a = _assemble(mesh, E, nu, model)
    C = np.zeros((6, 6))
    classes, scale = (_CLASSES_3D, 0.25) if a.dim == 3 else (_CLASSES_2D, 0.5 / width)
    for anti_y, anti_z, masters in classes:
        C[np.ix_(masters, masters)] = scale * _class_compliance(a, x_end, anti_y, anti_z, masters)
    return C


def transport_compliance(C, x):
    """Move a compliance from the point ``(x, 0, 0)`` to the origin: ``A C A^T`` (rigid-body adjoint).

    ``A`` maps the small rigid motion ``[theta; d]`` referred to ``(x, 0, 0)`` to the same
    motion referred to the origin: ``d_O = d + theta x (O - c) = d - x e_x x theta``.
    """
    A = np.eye(6)
    cx = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, -x], [0.0, x, 0.0]])  # [c - O]_x with c - O = (x, 0, 0)
    A[3:, :3] = cx
    return A @ C @ A.T


def plain_segment_compliance(length, height, width, E, nu, model="solid"):
    """Diagonal compliance (6x6) at the centre of a plain bar segment ``|x| <= length/2``.

    Saint-Venant beam of the ``height x width`` rectangle (``y x z``): torsion with the exact
    rectangle constant, bending with ``E`` (``E / (1 - nu^2)`` and axial likewise in plane
    strain), shear with Cowper's coefficient (:func:`mjflex.geometry.sections.shear_constants`).
    """
    G, kappa = shear_constants(E, nu)
    Ep = E / (1 - nu**2) if model == "plane_strain" else E
    A, Iz, Iy = height * width, width * height**3 / 12, height * width**3 / 12
    ell = length
    c = np.array([
        ell / (G * float(rectangle_torsion_constant(height, width))),
        ell / (E * Iy),
        ell / (Ep * Iz),
        ell / (Ep * A),
        ell**3 / (12 * Ep * Iz) + ell / (kappa * G * A),
        ell**3 / (12 * E * Iy) + ell / (kappa * G * A),
    ])  # fmt: skip
    return np.diag(c)


def element_compliance(profile, width, E, nu, *, model="solid", level=1, counts=None):
    """Compliance (6x6) at the centre of the flexure of ``profile`` between rigid bodies at its ends.

    ``C_element = A (C_c - C_bar,c) A^T + C_segment`` (module docstring). Entries a 2-D model
    does not give are NaN.

    Parameters
    ----------
    profile : NotchProfile or LeafProfile
        The flexure and its blocks (:func:`notch_profile`, :func:`leaf_profile`) [m].
    width : float
        Width ``b`` along ``z`` [m].
    E, nu : float
        Young's modulus [Pa] and Poisson ratio.
    model : {"solid", "plane_stress", "plane_strain"}
    level : int
        Mesh level: every element count of ``counts`` times ``2**(level - 1)``.
    counts : Counts, optional
        Element counts at level 1 (default ``Counts()``; the tables use ``NOTCH_COUNTS`` and
        ``LEAF_COUNTS``).

    Returns
    -------
    C : ndarray, shape (6, 6)
        Compliance at the centre, rows ``[rot_x, rot_y, rot_z, x, y, z]``, flexure frame
        [rad/(N m), m/N]; diagonal up to round-off.
    """
    counts = Counts() if counts is None else counts
    mesh_of = (lambda p: solid_mesh(p, width, level, counts)) if model == "solid" else (
        lambda p: section_mesh(p, level, counts))  # fmt: skip
    x_end = profile.x_end
    filled = type(profile)(**{**profile.__dict__, "filled": True})
    C = face_compliance(mesh_of(profile), E, nu, x_end, model, width)
    C_bar = face_compliance(mesh_of(filled), E, nu, x_end, model, width)
    C_el = transport_compliance(C - C_bar, x_end)
    C_el += plain_segment_compliance(2 * profile.half_length, profile.height, width, E, nu, model)
    if model != "solid":
        C_el[_OUT_OF_PLANE, :] = np.nan
        C_el[:, _OUT_OF_PLANE] = np.nan
    return C_el


def notch_profile(R, t, block_length=None):
    """The notch of :func:`element_compliance`: blocks as long as the bar is high unless given."""
    return NotchProfile(R, t, t + 2 * R if block_length is None else block_length)


def leaf_profile(L, t, H, block_length=None):
    """The leaf of :func:`element_compliance`: blocks of height ``H``, as long as high unless given."""
    return LeafProfile(L, t, H, H if block_length is None else block_length)

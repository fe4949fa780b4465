"""Finite elements of flexures (mjflex.geometry.fe) against closed-form elasticity and limits."""

import numpy as np
import pytest
from skfem import Basis, ElementHex2, ElementQuad2, ElementVector, asm
from skfem.models.elasticity import linear_elasticity

from mjflex.geometry import fe, hinges
from mjflex.geometry.fe_mesh import Counts, NotchProfile, section_mesh, solid_mesh

E, NU = 1.0, 0.3
G = E / (2 * (1 + NU))
COARSE = Counts(flexure=8, block=2, thin=2, outer=2, width=3)


@pytest.mark.parametrize("dim", [2, 3])
def test_assembly_equals_scikit_fem_linear_elasticity(dim):
    """Our batched element matrices equal scikit-fem's generic vector assembly (round-off)."""
    profile = fe.notch_profile(1.0, 0.3)
    tiny = Counts(2, 1, 1, 1, 1)
    mesh = section_mesh(profile, 1, tiny) if dim == 2 else solid_mesh(profile, 1.0, 1, tiny)
    model = "plane_stress" if dim == 2 else "solid"
    ours = fe._assemble(mesh, E, NU, model)
    vb = Basis(mesh, ElementVector(ElementQuad2() if dim == 2 else ElementHex2()), intorder=4)
    K = asm(linear_elasticity(*fe._lame(E, NU, model)), vb).toarray()
    perm = np.empty(vb.N, dtype=int)
    for k, idx in enumerate(vb.split_indices()):  # scikit-fem: one block per component
        perm[idx] = dim * np.arange(idx.size) + k
    assert np.allclose(vb.doflocs, ours.X[:, perm], atol=0)
    assert np.abs(ours.K.toarray()[np.ix_(perm, perm)] - K).max() < 1e-12 * np.abs(K).max()


def _plain_bars(H, block):
    """Two plain bars of height H with identical blocks, central lengths 2 and 0.5 (R = 1, 0.25)."""
    return [NotchProfile(R, H - 2 * R, block, filled=True) for R in (1.0, 0.25)]


@pytest.mark.parametrize("model", ["plane_stress", "plane_strain"])
def test_plain_bar_axial_and_bending_2d(model):
    """Lengthening a plain bar by dL adds dL/(E' A) axially and dL/(E' I) in rotation, E' = E/(1-nu^2) in strain.

    The bars share their (coupled) ends, so the end effects cancel and the result is exact
    for quadratic elements (pure bending and tension are quadratic fields): round-off only.
    """
    H, dL = 2.5, 1.5
    Ep = E if model == "plane_stress" else E / (1 - NU**2)
    C = [fe.face_compliance(section_mesh(p, 1, COARSE), E, NU, p.x_end, model, 1.0) for p in _plain_bars(H, 2.5)]
    d = np.diag(C[0] - C[1])
    assert d[2] == pytest.approx(dL / (Ep * H**3 / 12), rel=1e-5)
    assert d[3] == pytest.approx(dL / (Ep * H), rel=1e-5)


def test_plain_bar_3d_bending_axial_and_saint_venant_torsion():
    """3-D: bending about both axes and tension exact; torsion against Saint-Venant's series for the rectangle.

    Tolerance: bending/axial 5e-4 (three quadratic layers across the half width represent the
    anticlastic section with that error), torsion 2e-3 (the warping function of the 2.5 x 2.5
    section resolved by 2 x 3 quadratic elements on the quarter).
    """
    H, b, dL = 2.5, 2.5, 1.5
    C = [fe.face_compliance(solid_mesh(p, b, 1, COARSE), E, NU, p.x_end, "solid") for p in _plain_bars(H, 2.5)]
    d = np.diag(C[0] - C[1])
    J = float(hinges.rectangle_torsion_constant(H, b))
    assert d[0] == pytest.approx(dL / (G * J), rel=2e-3)
    assert d[1] == pytest.approx(dL / (E * H * b**3 / 12), rel=5e-4)
    assert d[2] == pytest.approx(dL / (E * b * H**3 / 12), rel=5e-4)
    assert d[3] == pytest.approx(dL / (E * H * b), rel=5e-4)


def _edge_loads(y_nodes, traction):
    """Consistent nodal loads of a traction t(y) on a straight edge of quadratic segments (nodes sorted by y)."""
    g, w = np.polynomial.legendre.leggauss(3)
    f = np.zeros(y_nodes.size)
    for k in range(0, y_nodes.size - 2, 2):
        y0, y2 = y_nodes[k], y_nodes[k + 2]
        yq = 0.5 * (y0 + y2) + 0.5 * (y2 - y0) * g
        N = np.array([0.5 * g * (g - 1), 1 - g * g, 0.5 * g * (g + 1)])
        f[k : k + 3] += N @ (w * traction(yq)) * 0.5 * (y2 - y0)
    return f


def test_end_loaded_cantilever_matches_timoshenko_goodier():
    """Plane stress, end shear with the parabolic distribution: the exact solution (bending + shear).

    Timoshenko & Goodier, Theory of Elasticity, sec. 21: with the load P at X = 0 and depth 2c,
    ``u = -P X^2 y/(2EI) - nu P y^3/(6EI) + P y^3/(6IG)``,
    ``v = nu P X y^2/(2EI) + P X^3/(6EI) - P c^2 X/(2IG)`` (a particular rigid motion; the last
    term is the shear deflection). The exact field is imposed at the far end X = l, the traction
    at X = 0; quadratic elements reproduce the cubic field to 1e-4 of the tip deflection.
    """
    profile = NotchProfile(1.0, 0.5, 3.0, filled=True)  # plain bar, depth 2c = 2.5, length l = 8
    mesh = section_mesh(profile, 3, COARSE)
    a = fe._assemble(mesh, E, NU, "plane_stress")
    c, x_end = 0.5 * profile.height, profile.x_end
    inertia, P = 2 * c**3 / 3, 1.0
    X, y = a.X[0] + x_end, a.X[1]

    def exact(X, y):
        u = -P * X**2 * y / (2 * E * inertia) - NU * P * y**3 / (6 * E * inertia) + P * y**3 / (6 * inertia * G)
        v = NU * P * X * y**2 / (2 * E * inertia) + P * X**3 / (6 * E * inertia) - P * c**2 * X / (2 * inertia * G)
        return np.where(a.comp == 0, u, v)

    tol = 1e-9
    prescribed = (np.abs(X - 2 * x_end) < tol) | ((np.abs(y) < tol) & (a.comp == 0))
    u = np.where(prescribed, exact(X, y), 0.0)
    f = np.zeros(u.size)
    loaded = np.flatnonzero((np.abs(X) < tol) & (a.comp == 1))
    order = loaded[np.argsort(y[loaded])]
    # on X = 0 (outward normal -x) the traction is -tau_xy = P (c^2 - y^2) / (2 I); half depth, half the load
    f[order] = _edge_loads(y[order], lambda s: P * (c**2 - s**2) / (2 * inertia))
    free = np.flatnonzero(~prescribed)
    from scipy.sparse.linalg import spsolve

    K = a.K.tocsr()
    u[free] = spsolve(K[free][:, free].tocsc(), f[free] - K[free][:, prescribed] @ u[prescribed])
    ref = exact(X, y)
    assert np.abs(u - ref).max() < 1e-4 * np.abs(ref).max()
    # the shear term matters at this depth: without it the field would be off by a few per cent
    shear = P * c**2 * (2 * x_end) / (2 * inertia * G)
    assert shear > 0.02 * np.abs(ref).max()


def test_thin_notch_limit_of_paros_weisbord():
    """As t/R -> 0 the FE compliant rotation (blocks subtracted) tends to Paros & Weisbord's exact formula."""
    ratios = []
    for t in (0.04, 0.02, 0.01):
        beam = hinges._beam_compliance(lambda x, t=t: hinges.notch_hinge_thickness(x, 1.0, t), 1.0, 1.0, E, NU, False)
        C = fe.element_compliance(fe.notch_profile(1.0, t), 1.0, E, NU, model="plane_stress", level=2,
                                  counts=fe.NOTCH_COUNTS)  # fmt: skip
        ratios.append(C[2, 2] / beam[2])
    assert ratios[0] > ratios[1] > ratios[2] > 1.0
    assert ratios[2] - 1.0 < 0.006  # the beam's error is about 0.4 t/R here


def test_mesh_convergence_is_fourth_order():
    """Quadratic elements: compliance errors fall ~16x per halving of h (Richardson order 3-5)."""
    c = [fe.element_compliance(fe.notch_profile(1.0, 0.3), 1.0, E, NU, model="plane_stress", level=lev,
                               counts=COARSE)[2, 2] for lev in (1, 2, 3)]  # fmt: skip
    order = np.log2((c[1] - c[0]) / (c[2] - c[1]))
    assert 3.0 < order < 5.0


def test_solid_limits_plane_stress_and_plane_strain():
    """3-D in-plane rows: plane stress for thin plates (b/R = 0.1), plane strain per width for wide ones (b/R = 30)."""
    p = fe.notch_profile(1.0, 0.3)
    C = {}
    for b in (0.1, 30.0):
        for model in ("solid", "plane_stress", "plane_strain"):
            C[b, model] = np.diag(fe.element_compliance(p, b, E, NU, model=model, counts=COARSE))[[2, 3, 4]]
    # same in-plane mesh in 2-D and 3-D, so these ratios are free of the in-plane discretisation error
    assert np.abs(C[0.1, "solid"] / C[0.1, "plane_stress"] - 1.0).max() < 2e-3
    # wide: the free edges' zone (width ~ t) still softens by ~1/(b/t): 0.3 % in rotation and shear, 3 % axially
    rot, axial, shear = C[30.0, "solid"] / C[30.0, "plane_strain"] - 1.0
    assert abs(rot) < 5e-3 and abs(shear) < 1e-2 and 0.0 < axial < 0.04


def test_element_is_diagonal_at_its_centre():
    """Symmetric flexure: the centre is the centre of stiffness (all couplings vanish)."""
    C = fe.element_compliance(fe.notch_profile(1.0, 0.2), 2.0, E, NU, counts=COARSE)
    off = C / np.sqrt(np.outer(np.diag(C), np.diag(C))) - np.eye(6)
    assert np.abs(off).max() < 1e-8

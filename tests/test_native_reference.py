"""The C engine against references that share nothing with it (issue 22), and the mutations the suite missed.

* The C energy's gradient by finite differences (Ridders) against the C wrench, for both methods and
  every kind of term: diagonal, full and planar K, and each monomial of the polynomial bases alone.
* The C forces of plugin models (MuJoCo's ``qfrc_passive``) against ``tests/reference_element.py``
  (the wrench written from the definitions) mapped to generalized forces by MuJoCo's own Jacobians
  (``mj_applyFT``), on random states: free bodies, and a chain of hinge, slide and ball joints with a
  jointless body welded to it (the dof chain).
* Tests with computed expectations for the five planted bugs the suite did not catch (the issue's
  list): the dof chain's climb to a body with dofs, the smallest eigenvalue's last entry, the single
  body form of ``make_compliant(collide=...)``, ``reduce`` keeping the terms of a whole element, and
  gravity compensation in ``normal_modes``'s gravity stiffness (with ``normal_modes(qpos=...)``).
"""

import re

import mujoco
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import mjflex
from mjflex.mjcf import schema
from mjflex.native import library as _native
from tests.helpers import gradient_wrt_b, random_rotation, random_spd
from tests.native_cases import chain_xml, two_body_xml
from tests.reference_element import reference_wrench

METHODS = ("twist", "dualquat")


# ------------------------------------------------------------------ the C energy's gradient against the C wrench


def _c(a):
    return np.ascontiguousarray(a, dtype=np.float64)


def _terms(exps, coefs):
    if exps is None:
        return np.zeros((1, 8), np.int32), np.zeros(1), 0, 0
    table = np.zeros((len(exps), 8), np.int32)
    table[:, : np.shape(exps)[1]] = exps
    return table, _c(coefs), len(coefs), int(table.max())


def c_wrench(method, R_WA, p_WA, R_WB, p_WB, K, exps=None, coefs=None, B=None, vel=None):
    """mjfx_wrench_batch of one element: (wrench on B [moment about p_WB; force], world axes; dissipated power)."""
    table, c, n, top = _terms(exps, coefs)
    out, power = np.empty(6), np.empty(1)
    vel = [None] * 4 if vel is None else [_c(v) for v in vel]
    args = [_c(a) for a in (R_WA, p_WA, R_WB, p_WB, K)] + [None if B is None else _c(B)]
    rc = _native.lib().mjfx_wrench_batch(
        1, METHODS.index(method), *(None if a is None else a.ctypes.data for a in args), int(B is not None),
        *(None if v is None else v.ctypes.data for v in vel), table.ctypes.data, c.ctypes.data, n, top,
        out.ctypes.data, power.ctypes.data,
    )  # fmt: skip
    assert rc == 0
    return out, power[0]


def c_energy(method, R_WA, p_WA, R_WB, p_WB, K, exps=None, coefs=None):
    table, c, n, top = _terms(exps, coefs)
    out = np.empty(1)
    args = [_c(a) for a in (R_WA, p_WA, R_WB, p_WB, K)]
    rc = _native.lib().mjfx_potential_batch(1, METHODS.index(method), *(a.ctypes.data for a in args),
                                            table.ctypes.data, c.ctypes.data, n, top, out.ctypes.data)  # fmt: skip
    assert rc == 0
    return out[0]


def _pose(rng, angle, trans=0.05):
    R_WA, p_WA = random_rotation(rng), rng.normal(size=3)
    R_ab, p_ab = random_rotation(rng, angle), trans * rng.normal(size=3)
    return R_WA, p_WA, R_WA @ R_ab, p_WA + R_WA @ p_ab


def _check_gradient(method, pose, K, exps=None, coefs=None, rtol=1e-7):
    R_WA, p_WA, R_WB, p_WB = pose
    W, _ = c_wrench(method, R_WA, p_WA, R_WB, p_WB, K, exps, coefs)
    g = gradient_wrt_b(lambda R, p: c_energy(method, R_WA, p_WA, R, p, K, exps, coefs), R_WB, p_WB, 1e-3, 1e-3)
    scale = np.linalg.norm(W)
    assert scale > 0
    err = np.linalg.norm(W + g) / scale
    assert err <= rtol, f"relative error {err:.3g}: C wrench {W} against minus the C energy's gradient {-g}"


KINDS = {
    "diagonal K": lambda rng: np.diag(rng.uniform(0.5, 2.0, 6) * [1, 1, 1, 50, 50, 50]),
    "full K": lambda rng: random_spd(rng, cond=50.0, scales=[1, 1, 1, 30, 30, 30]),
    "planar K": lambda rng: schema.embed_planar(random_spd(rng, n=3, scales=[1, 20, 20])),
}


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("kind", list(KINDS))
@pytest.mark.parametrize("angle", [1e-3, 0.3, 1.5, 3.0])
def test_c_wrench_is_minus_the_c_energy_gradient(method, kind, angle):
    rng = np.random.default_rng(int(angle * 1000) + len(kind))
    _check_gradient(method, _pose(rng, angle), KINDS[kind](rng))


def _monomials(method):
    """Each monomial of the order-4 basis, and single-coordinate powers up to 8 (every exponent pattern the
    C power tables handle)."""
    basis = [tuple(r) for r in mjflex.polynomial_basis(method, 4)]
    nvar = 6 if method == "twist" else 8
    first = 0 if method == "twist" else 1  # dual quaternions: sigma alone is not a displacement
    for k in range(first, nvar):
        for power in (6, 8):
            row = [0] * nvar
            row[k] = power
            basis.append(tuple(row))
    return basis


@pytest.mark.parametrize("method", METHODS)
def test_each_polynomial_term_alone_is_differentiated_exactly(method):
    """K = 0 and one monomial of coefficient +-1: the energy is the term alone, so no term's gradient can hide
    under K's."""
    rng = np.random.default_rng(17)
    K = np.zeros((6, 6))
    for row in _monomials(method):
        _check_gradient(method, _generic_pose(rng), K, np.array([row]), np.array([rng.choice([-1.0, 1.0])]))


def _generic_pose(rng):
    """A relative pose none of whose coordinates is small (each monomial's energy and gradient are of order 1)."""
    signs = rng.choice([-1.0, 1.0], size=(2, 3))
    axis = signs[0] * rng.uniform(0.4, 1.0, 3)
    R_ab = Rotation.from_rotvec(rng.uniform(1.0, 2.5) * axis / np.linalg.norm(axis)).as_matrix()
    p_ab = signs[1] * rng.uniform(0.1, 0.4, 3)
    R_WA, p_WA = random_rotation(rng), rng.normal(size=3)
    return R_WA, p_WA, R_WA @ R_ab, p_WA + R_WA @ p_ab


@pytest.mark.parametrize("method", METHODS)
def test_the_viscous_wrench_does_the_dissipated_power(method):
    """K = 0: the damping wrench's power on the relative motion is minus the C dissipation power."""
    rng = np.random.default_rng(23)
    for _ in range(50):
        R_WA, p_WA, R_WB, p_WB = _pose(rng, rng.uniform(0.0, 3.0))
        wa, va, wb, vb = rng.normal(size=(4, 3))
        W, power = c_wrench(method, R_WA, p_WA, R_WB, p_WB, np.zeros((6, 6)), B=random_spd(rng),
                            vel=[wa, va, wb, vb])  # fmt: skip
        va_at_b = va + np.cross(wa, p_WB - p_WA)  # A's velocity at frame b's origin
        done = W[:3] @ (wb - wa) + W[3:] @ (vb - va_at_b)
        assert power > 0 and abs(done + power) <= 1e-12 * power


# ------------------------------------------------------------------ the C forces against reference_element.py


def _with_matrices(xml, K, B):
    """The model text with every instance's K and B replaced (36 numbers each, row-major)."""
    K, B = (" ".join(repr(float(v)) for v in M.ravel()) for M in (K, B))
    xml = re.sub(r'<config key="K" value="[^"]*"/>', f'<config key="K" value="{K}"/>', xml)
    xml = re.sub(r'<config key="B" value="[^"]*"/>', "", xml)
    return xml.replace("</instance>", f'<config key="B" value="{B}"/></instance>')


def _elements(model, xml):
    """(site a, site b, body a, body b, method) of each plugin instance, read from the model text (not from mjflex)."""
    out = []
    for instance in re.findall(r"<instance .*?</instance>", xml, re.S):
        config = dict(re.findall(r'<config key="(\w+)" value="([^"]*)"/>', instance))
        sa = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, config["site_a"])
        sb = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, config["site_b"])
        out.append((sa, sb, model.site_bodyid[sa], model.site_bodyid[sb], config.get("method", "twist")))
    assert len(out) == model.nplugin
    return out


def _quat(R):
    return Rotation.from_matrix(R).as_quat(scalar_first=True)


def reference_qfrc(model, data, elements, K, B, rest):
    """The elements' generalized forces from reference_element.reference_wrench and MuJoCo's mj_applyFT."""
    qfrc = np.zeros(model.nv)
    for (sa, sb, ba, bb, method), (R0, p0) in zip(elements, rest, strict=True):
        R_a, p_a = data.site_xmat[sa].reshape(3, 3), data.site_xpos[sa]
        R_b = data.site_xmat[sb].reshape(3, 3) @ R0.T  # frame b*: site b with the rest offset removed
        p_b = data.site_xpos[sb] - R_b @ p0
        twists = []
        for site, R, p in ((sa, R_a, p_a), (sb, R_b, p_b)):
            v = np.empty(6)
            mujoco.mj_objectVelocity(model, data, mujoco.mjtObj.mjOBJ_SITE, int(site), v, 0)  # world axes
            twists.append(np.r_[R.T @ v[:3], R.T @ (v[3:] + np.cross(v[:3], p - data.site_xpos[site]))])
        W = reference_wrench(method, _quat(R_a), p_a, _quat(R_b), p_b, *twists, K, B)
        mujoco.mj_applyFT(model, data, W[3:].copy(), W[:3].copy(), p_b.copy(), int(bb), qfrc)
        mujoco.mj_applyFT(model, data, -W[3:], -W[:3], p_b.copy(), int(ba), qfrc)
    return qfrc


def _rest_offsets(model, elements):
    d = mujoco.MjData(model)
    mujoco.mj_kinematics(model, d)
    out = []
    for sa, sb, *_ in elements:
        R_a = d.site_xmat[sa].reshape(3, 3)
        out.append((R_a.T @ d.site_xmat[sb].reshape(3, 3), R_a.T @ (d.site_xpos[sb] - d.site_xpos[sa])))
    return out


def _random_state(model, data, rng, scale):
    data.qpos[:] = model.qpos0
    for j in range(model.njnt):
        adr, kind = model.jnt_qposadr[j], model.jnt_type[j]
        if kind == mujoco.mjtJoint.mjJNT_FREE:
            data.qpos[adr : adr + 3] += 0.05 * scale * rng.normal(size=3)
            q = Rotation.from_quat(data.qpos[adr + 3 : adr + 7], scalar_first=True)
            data.qpos[adr + 3 : adr + 7] = (Rotation.from_rotvec(scale * rng.normal(size=3)) * q).as_quat(
                scalar_first=True
            )
        elif kind == mujoco.mjtJoint.mjJNT_BALL:
            data.qpos[adr : adr + 4] = Rotation.from_rotvec(scale * rng.normal(size=3)).as_quat(scalar_first=True)
        else:
            data.qpos[adr] += scale * rng.normal() * (0.1 if kind == mujoco.mjtJoint.mjJNT_SLIDE else 1.0)
    data.qvel[:] = rng.normal(size=model.nv)
    mujoco.mj_forward(model, data)


CASES = {
    "free bodies": lambda method: two_body_xml(3, method=method),
    "dof chain": lambda method: chain_xml(5, method=method),
}


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("case", list(CASES))
def test_plugin_forces_match_the_reference_element(method, case):
    """On 40 random states (rotations up to ~2 rad), the plugin's qfrc_passive is the reference's to 1e-9."""
    rng = np.random.default_rng(5)
    K = random_spd(rng, cond=30.0, scales=[1, 1, 1, 40, 40, 40])
    B = 0.02 * random_spd(rng, cond=10.0)
    xml = _with_matrices(CASES[case](method), K, B)
    model = mujoco.MjModel.from_xml_string(xml)
    elements = _elements(model, xml)
    data, rest = mujoco.MjData(model), _rest_offsets(model, elements)
    assert model.nv > 0 and not model.opt.gravity.any() and not model.dof_damping.any()
    for k in range(40):
        _random_state(model, data, rng, scale=0.05 + 2.0 * k / 40)
        expected = reference_qfrc(model, data, elements, K, B, rest)
        scale = np.linalg.norm(expected)
        assert scale > 0 and np.linalg.norm(data.qfrc_passive - expected) <= 1e-9 * scale, (k, data.qfrc_passive,
                                                                                           expected)  # fmt: skip


# ------------------------------------------------------------------ the five planted bugs the suite missed

ARM_WITH_HAND = """<mujoco><option gravity="0 0 0"/>
<extension><plugin plugin="mjflex.flexure"><instance name="grip">
<config key="site_a" value="grip/a"/><config key="site_b" value="grip/b"/><config key="K" value="5 5 5 1000 1000 1000"/>
</instance></plugin></extension>
<worldbody><site name="grip/a" pos="0 0 1"/>
<body name="arm" pos="0 0 1"><joint name="hinge" type="hinge" axis="0 1 0"/>
<geom type="capsule" fromto="0 0 0 0.2 0 0" size="0.02" contype="0" conaffinity="0"/>
<body name="hand" pos="0 0 0"><geom type="sphere" size="0.03" pos="0.2 0 0" contype="0" conaffinity="0"/>
<site name="grip/b" pos="0 0 0"/></body></body></worldbody></mujoco>"""


@pytest.mark.parametrize("kind", ["plugin", "record"])
def test_an_element_on_a_jointless_body_acts_on_the_joint_it_is_welded_to(kind):
    """Planted bug "dof chain" (mjfx_dof_chain no longer climbs to the nearest body with dofs): the element joins
    the world to a jointless hand welded to a hinged arm, its frame on the hinge axis; at 1 rad the twist energy
    (5 N m/rad) x^2 / 2 puts -5 N m on the hinge (0 with the bug)."""
    model = mujoco.MjModel.from_xml_string(ARM_WITH_HAND)
    if kind == "record":
        from mjflex.mjcf.convert import copy_spec, plugins_to_records

        spec = copy_spec(mujoco.MjSpec.from_string(ARM_WITH_HAND))
        plugins_to_records(spec)
        model = spec.compile()
    flex = mjflex.Flexures(model)
    data = mujoco.MjData(model)
    data.qpos[0] = 1.0
    mujoco.mj_forward(model, data)
    with flex:
        mujoco.mj_forward(model, data)
    assert data.qfrc_passive[0] == pytest.approx(-5.0, rel=1e-12)
    assert flex.generalized_forces(data)[0] == pytest.approx(-5.0, rel=1e-12)


def test_the_smallest_eigenvalue_is_found_in_every_position():
    """Planted bug "eigenvalue check" (the loop skips the last eigenvalue): mjfx_min_eigenvalue against numpy's on
    random symmetric matrices of every size, the smallest eigenvalue in every diagonal position."""
    lib, rng = _native.lib(), np.random.default_rng(8)
    for n in range(1, 7):
        for trial in range(60):
            lam = rng.uniform(1.0, 10.0, n)
            lam[trial % n] = -rng.uniform(0.1, 5.0)  # the smallest, in position trial % n when nearly diagonal
            Q = random_rotation(rng) if n == 3 and trial % 2 else np.eye(n)
            M = _c(Q @ np.diag(lam) @ Q.T)
            expected = np.linalg.eigvalsh(M)[0]
            assert lib.mjfx_min_eigenvalue(M.ctypes.data, n) == pytest.approx(expected, rel=1e-10, abs=1e-12)


@pytest.mark.parametrize("position", range(6))
def test_an_indefinite_k_is_refused_wherever_its_negative_direction_is(position):
    """The issue's K = "1 2 3 1000 2000 -3000" compiled with the bug; here the negative entry in each position."""
    K = [1.0, 2.0, 3.0, 1000.0, 2000.0, 3000.0]
    K[position] = -K[position]
    xml = re.sub(r'<config key="K" value="[^"]*"/>', f'<config key="K" value="{" ".join(map(str, K))}"/>',
                 two_body_xml(1))  # fmt: skip
    with pytest.raises(ValueError, match=r"flexure 'e0'.*K is not positive semi-definite: its smallest eigenvalue"):
        mujoco.MjModel.from_xml_string(xml)


def test_make_compliant_keeps_every_pair_of_a_single_body_in_collide():
    """Planted bug "collide": make_compliant(collide=["hand"]) ignored the single-body form. The hand's cuff overlaps
    link2 (tests/robots.py): the pair the weld had filtered is kept, not excluded, for each way of naming it."""
    from tests.robots import K_HAND, arm_spec

    for collide in (["hand"], ["link2"], [("hand", "link2")], [("link2", "*")]):
        spec = arm_spec()
        with pytest.warns(UserWarning, match="touch in the reference configuration"):
            c = mjflex.make_compliant(spec, "hand", K=K_HAND, site="wrist", collide=collide)
        assert c.excludes == () and c.kept == (("link2", "hand"),), collide
        assert len(spec.excludes) == 0
    spec = arm_spec()
    c = mjflex.make_compliant(spec, "hand", K=K_HAND, site="wrist", collide=["link1"])  # another body's pairs
    assert c.excludes == (("link2", "hand"),) and c.kept == ()


@pytest.mark.parametrize("kind", ["plugin", "record"])
def test_reduce_keeps_the_polynomial_terms_of_an_element_it_keeps_whole(kind):
    """Planted bug "reduce": an element kept whole lost its terms. Its damping is negligible, so reduce rewrites it
    (damping dropped) while keeping it whole: the reduced model's element has the same terms, and its energy at a
    large displacement is the core's potential with those terms."""
    from tests.models import K_DEMO, two_body_spec
    from tests.plugin_models import polynomial_terms

    terms = polynomial_terms("twist")
    source = two_body_spec(B=1e-9 * K_DEMO, terms=terms, kind=kind)
    variant = mjflex.reduce(source, 1e6, verify=False)
    model = variant.model
    assert model.nq == source.compile().nq  # nothing restricted: the element is kept whole
    (record,) = mjflex.Flexures(model).records
    assert not record.viscous  # rewritten: its damping was dropped
    assert np.array_equal(record.terms.exponents, terms.exponents)
    assert np.array_equal(record.terms.coefficients, terms.coefficients)
    flex, data = mjflex.Flexures(model), mujoco.MjData(model)
    data.qpos[10:14] = Rotation.from_rotvec([0.3, -0.5, 0.4]).as_quat(scalar_first=True)
    data.qpos[7:10] += [0.01, 0.02, -0.01]
    mujoco.mj_forward(model, data)
    sa, sb = flex.site_ids[0]
    R0, p0 = _rest_offsets_of(model, sa, sb)
    R_b = data.site_xmat[sb].reshape(3, 3) @ R0.T
    p_b = data.site_xpos[sb] - R_b @ p0
    expected = mjflex.potential(data.site_xmat[sa].reshape(3, 3), data.site_xpos[sa], R_b, p_b, record.K,
                                method="twist", terms=terms)  # fmt: skip
    without = mjflex.potential(data.site_xmat[sa].reshape(3, 3), data.site_xpos[sa], R_b, p_b, record.K)
    assert abs(expected - without) > 1e-3 * abs(expected)  # the terms matter at this displacement
    assert flex.potential_energies(data)[0] == pytest.approx(expected, rel=1e-12)


def _rest_offsets_of(model, sa, sb):
    d = mujoco.MjData(model)
    mujoco.mj_kinematics(model, d)
    R_a = d.site_xmat[sa].reshape(3, 3)
    return R_a.T @ d.site_xmat[sb].reshape(3, 3), R_a.T @ (d.site_xpos[sb] - d.site_xpos[sa])


def _pendulum(gravcomp):
    spec = mujoco.MjSpec()
    body = spec.worldbody.add_body(name="bob", pos=[0, 0, -0.5], gravcomp=gravcomp)
    body.add_joint(name="swing", axis=[0, 1, 0], pos=[0, 0, 0.5])
    body.add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[0.05, 0, 0], mass=2.0)
    return spec.compile()


@pytest.mark.parametrize("gravcomp", [0.0, 0.5, 1.0])
def test_gravity_compensation_lowers_the_gravity_stiffness(gravcomp):
    """Planted bug "normal_modes" (qfrc_gravcomp dropped from the gravity stiffness): a pendulum whose body is
    compensated by a fraction c swings at sqrt((1 - c) m g L / I)."""
    freq, _ = mjflex.normal_modes(_pendulum(gravcomp), None, gravity=True)
    m, r, L, g = 2.0, 0.05, 0.5, 9.81
    expected = np.sqrt((1.0 - gravcomp) * m * g * L / (m * L**2 + 0.4 * m * r**2)) / (2 * np.pi)
    assert freq[0] == pytest.approx(expected, rel=1e-6, abs=1e-6)


def test_normal_modes_at_a_given_qpos():
    """normal_modes(qpos=...) (untested before): the arm's servos hold it like springs kp (tests/robots.py), so the
    frequencies are the generalized eigenvalues of diag(kp) and MuJoCo's inertia at that qpos; and at a keyframe's
    qpos, without the keyframe, they are the keyframe's."""
    import scipy.linalg

    from tests.robots import arm_spec

    model = arm_spec().compile()
    kp = model.actuator_gainprm[:, 0]
    for q in ([0.7, -1.1, 0.2], [-0.4, 0.3, 1.2]):
        freq, _ = mjflex.normal_modes(model, None, qpos=q, actuator_stiffness=True)
        data = mujoco.MjData(model)
        data.qpos[:] = q
        mujoco.mj_forward(model, data)
        M = np.zeros((model.nv, model.nv))
        mujoco.mj_fullM(model, data, M)
        expected = np.sqrt(scipy.linalg.eigh(np.diag(kp), M, eigvals_only=True)) / (2 * np.pi)
        np.testing.assert_allclose(freq, expected, rtol=1e-6)
    at_key, _ = mjflex.normal_modes(model, None, keyframe=1, actuator_stiffness=True)
    at_qpos, _ = mjflex.normal_modes(model, None, qpos=model.key_qpos[1], actuator_stiffness=True)
    at_zero, _ = mjflex.normal_modes(model, None, actuator_stiffness=True)
    np.testing.assert_allclose(at_qpos, at_key, rtol=1e-9)
    assert np.abs(at_key - at_zero).max() > 1e-2 * at_key.max()

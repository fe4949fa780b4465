"""An element's rest pose (issue 31): the pose of frame b in frame a at which its energy is zero.

The core against finite differences and scipy; the C engine of both forms against the core, on models whose sites
carry a deliberate rounding residual (so that the order "residual, then rest pose" is checked: the other order
differs by far more than round-off); closed forms of a preload; bad input in every form.
"""

import mujoco
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import mjflex
from tests.helpers import gradient_wrt_b, random_rotation
from tests.test_stop_damping import core_element

pytestmark = [pytest.mark.usefixtures("clean_callback")]
INF = np.inf
K = np.diag([0.4, 0.5, 0.3, 2e3, 3e3, 1e3])


def _quat(rotvec):
    return Rotation.from_rotvec(rotvec).as_quat(scalar_first=True)


# ------------------------------------------------------------------ the core


@pytest.mark.parametrize("method", ["twist", "dualquat"])
def test_core_energy_counts_from_the_rest_pose(method):
    """Zero energy and wrench where frame b sits at the rest pose in frame a; elsewhere the energy of the pose
    relative to the rest pose (frame b* = b X_r^-1, built here with scipy), the wrench minus its gradient about
    p_WB, the stops' coordinates zero at rest."""
    rng = np.random.default_rng(1 if method == "twist" else 2)
    rest = (0.01 * rng.normal(size=3), _quat(0.4 * rng.normal(size=3)))
    R_r, p_r = Rotation.from_quat(rest[1], scalar_first=True).as_matrix(), rest[0]
    R_WA, p_WA = random_rotation(rng), rng.normal(size=3)
    at_rest = (R_WA @ R_r, p_WA + R_WA @ p_r)
    assert abs(mjflex.potential(R_WA, p_WA, *at_rest, K, method=method, rest=rest)) < 1e-20
    assert np.abs(mjflex.wrench_on_b(R_WA, p_WA, *at_rest, K, method=method, rest=rest)).max() < 1e-12
    assert np.abs(mjflex.stop_coordinates(R_WA, p_WA, *at_rest, rest=rest)).max() < 1e-14
    R_WB, p_WB = R_WA @ random_rotation(rng, 0.7), p_WA + 0.02 * rng.normal(size=3)
    R_b = R_WB @ R_r.T
    U = mjflex.potential(R_WA, p_WA, R_WB, p_WB, K, method=method, rest=rest)
    assert np.isclose(U, mjflex.potential(R_WA, p_WA, R_b, p_WB - R_b @ p_r, K, method=method), rtol=1e-13)
    W = mjflex.wrench_on_b(R_WA, p_WA, R_WB, p_WB, K, method=method, rest=rest)
    g = gradient_wrt_b(lambda R, p: mjflex.potential(R_WA, p_WA, R, p, K, method=method, rest=rest), R_WB, p_WB,
                       1e-3, 1e-4)  # fmt: skip
    assert np.linalg.norm(W + g) <= 1e-8 * np.linalg.norm(W)


def test_core_damping_with_a_rest_pose_uses_the_velocity_of_frame_b_star():
    """A rest pose with a translation: the viscous wrench of a body spinning about frame b's origin is the one of the
    frame pair (a, b*) whose origin moves with the spin (v = w x (p_b* - p_b)), moved back to p_WB."""
    rest = ([0.0, 0.01, 0.0], [1.0, 0.0, 0.0, 0.0])
    B = np.diag([0.0, 0.0, 0.0, 10.0, 10.0, 10.0])
    W = mjflex.wrench_on_b(np.eye(3), np.zeros(3), np.eye(3), [0, 0.01, 0], 0 * K, B=B, w_WB=[0, 0, 2.0], rest=rest)
    # b* is at the origin, moving at w x (0 - p_b) = [0.02, 0, 0]: the damping pushes back along -x with 0.2 N, whose
    # moment about p_b = [0, 0.01, 0] is (0 - p_b) x f = [0, 0, -0.002]
    np.testing.assert_allclose(W, [0, 0, -0.002, -0.2, 0, 0], atol=1e-15)
    P = mjflex.dissipation_power(np.eye(3), np.zeros(3), np.eye(3), [0, 0.01, 0], B, w_WB=[0, 0, 2.0], rest=rest)
    assert np.isclose(P, 10 * 0.02**2, rtol=1e-14)


@pytest.mark.parametrize(
    ("rest", "match"),
    [
        (([0, 0, 0], [1.0, 1.0, 0, 0]), "norm 1.41421356, so it is not a rotation"),
        (([0, 0, 0], [0.0, 0, 0, 0]), "not a rotation"),
        (([0, 0], [1.0, 0, 0, 0]), "pos must have 3 numbers"),
        (([0, 0, np.nan], [1.0, 0, 0, 0]), "pos is not finite"),
        (([0, 0, 0], [np.nan, 0, 0, 0]), "quat is not finite"),
        (([0, 0, 0],), "must be a pose"),
    ],
)
def test_core_refuses_a_rest_pose_that_is_not_one(rest, match):
    with pytest.raises(ValueError, match=match):
        mjflex.potential(np.eye(3), np.zeros(3), np.eye(3), np.zeros(3), K, rest=rest)


# ------------------------------------------------------------------ the C engine of both forms


#: the joint's quaternion written with 7 significant digits: norm 1 within the tolerance, not to the last bit (the C
#: library normalizes it, as the core does)
RESTS = {"grounded": ([0.003, -0.002, 0.001], _quat([0.3, -0.1, 0.2])),
         "joint": ([0.0, 0.0, 0.0], [float(f"{v:.7g}") for v in _quat([0, 0, 0.4])])}  # fmt: skip


def residual_spec(kind):
    """Two free bodies, a grounded element and one between them, both with rest poses; site b of each moved by a
    residual within the coincidence tolerance (1.5 um, 6 urad: what a model's rounding might leave)."""
    spec = mujoco.MjSpec()
    spec.option.gravity = [0, 0, 0]
    for i in range(2):
        body = spec.worldbody.add_body(name=f"b{i}", pos=[0.1 * (i + 1), 0.0, 0.0], mass=0.2, inertia=[2e-4] * 3,
                                       ipos=[0.01, 0, 0], iquat=[1, 0, 0, 0])  # fmt: skip
        body.explicitinertial = True
        body.add_freejoint()
    for name, a, b, method in (("grounded", "world", "b0", "twist"), ("joint", "b0", "b1", "dualquat")):
        handle = mjflex.add_flexure(spec, name, a, b, pos=[0.15, 0.01, 0.0], quat=_quat([0.2, 0.1, 0]), K=K,
                                    method=method, kind=kind, rest=RESTS[name])  # fmt: skip
        site = handle.site_b
        site.pos = site.pos + [1e-6, -0.5e-6, 1e-6]
        q = np.empty(4)
        mujoco.mju_mulQuat(q, site.quat, _quat([5e-6, 0, -3e-6]))
        site.quat = q
    return spec


@pytest.mark.parametrize("kind", ["plugin", "record"])
def test_c_energies_wrenches_and_stop_coordinates_count_from_the_rest_pose(kind):
    """The C engine against the core with the residual removed from frame b first, then the rest pose: to round-off;
    the other order (rest pose first) is off by orders of magnitude more, so the order is what is tested."""
    model = residual_spec(kind).compile()
    flex = mjflex.Flexures(model)
    assert flex.element_table.elements["offset"][:2].all() and flex.element_table.elements["rest"][:2].all()
    rng = np.random.default_rng(3)
    data = mujoco.MjData(model)
    data.qpos[:] = model.qpos0 + 0.05 * rng.normal(size=model.nq)
    for j in range(2):
        data.qpos[7 * j + 3 : 7 * j + 7] /= np.linalg.norm(data.qpos[7 * j + 3 : 7 * j + 7])
    data.qvel[:] = rng.normal(size=model.nv)
    mujoco.mj_forward(model, data)
    W, U, Z = flex.wrenches(data), flex.potential_energies(data), flex.stop_coordinates(data)
    ref = mujoco.MjData(model)
    mujoco.mj_kinematics(model, ref)
    for e, rec in enumerate(flex.records):
        We, _ = core_element(model, flex, data, e)
        assert np.abs(W[e] - We).max() <= 1e-12 * np.abs(We).max()
        sa, sb = flex.site_ids[e]
        Ra0, Rb0 = ref.site_xmat[sa].reshape(3, 3), ref.site_xmat[sb].reshape(3, 3)
        R_res, p_res = Ra0.T @ Rb0, Ra0.T @ (ref.site_xpos[sb] - ref.site_xpos[sa])
        R_a, p_a = data.site_xmat[sa].reshape(3, 3), data.site_xpos[sa]
        R_b = data.site_xmat[sb].reshape(3, 3) @ R_res.T
        p_b = data.site_xpos[sb] - R_b @ p_res
        Ue = mjflex.potential(R_a, p_a, R_b, p_b, rec.K, method=rec.method, rest=rec.rest)
        assert abs(U[e] - Ue) <= 1e-12 * Ue
        Ze = mjflex.stop_coordinates(R_a, p_a, R_b, p_b, rest=rec.rest)
        assert np.abs(Z[e] - Ze).max() <= 1e-13 * np.abs(Ze).max()
        # the other order: frame b less the rest pose first, then the residual (X_res X_r)
        R_r = Rotation.from_quat(rec.rest[1], scalar_first=True).as_matrix()
        R_other, p_other = R_res @ R_r, R_res @ np.asarray(rec.rest[0]) + p_res
        R_b2 = data.site_xmat[sb].reshape(3, 3) @ R_other.T
        p_b2 = data.site_xpos[sb] - R_b2 @ p_other
        U2 = mjflex.potential(R_a, p_a, R_b2, p_b2, rec.K, method=rec.method)
        assert abs(U2 - Ue) > 1e5 * 1e-12 * Ue


@pytest.mark.filterwarnings("ignore::mjflex.LikelyMistakeWarning")  # the element beside the joints, on purpose
@pytest.mark.parametrize("kind", ["plugin", "record"])
@pytest.mark.parametrize("method", ["twist", "dualquat"])
@pytest.mark.parametrize("which", ["turned", "moved"])
def test_a_rest_pose_preloads_like_a_springref(kind, method, which):
    """A body on a slide (x) and a hinge (z), held by a grounded element at the hinge's axis whose rest pose is turned
    0.2 rad about z, or moved 1 mm along x: at qpos0 the element pushes toward its rest pose as a joint spring with
    that springref would, K_zz 0.2 (twist; 2 K_zz sin(0.1) cos(0.1) dual quaternion) or K_xx 1e-3, and at the rest
    pose it pushes with nothing."""
    spec = mujoco.MjSpec()
    spec.option.gravity = [0, 0, 0]
    body = spec.worldbody.add_body(name="b", mass=0.1, inertia=[1e-4] * 3, ipos=[0, 0, 0], iquat=[1, 0, 0, 0])
    body.explicitinertial = True
    body.add_joint(name="x", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[1, 0, 0])
    body.add_joint(name="rz", type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0, 0, 1])
    rest = ([0, 0, 0], _quat([0, 0, 0.2])) if which == "turned" else ([1e-3, 0, 0], [1.0, 0, 0, 0])
    mjflex.add_flexure(spec, "hinge", "world", "b", pos=[0, 0, 0], K=[0.4, 0.5, 0.3, 2e3, 3e3, 1e3], method=method,
                       kind=kind, rest=rest)  # fmt: skip
    model = spec.compile()
    flex, data = mjflex.Flexures(model), mujoco.MjData(model)
    if which == "turned":
        expected = [0.0, 0.3 * 0.2 if method == "twist" else 2 * 0.3 * np.sin(0.1) * np.cos(0.1)]
    else:
        expected = [2e3 * 1e-3 if method == "twist" else 2e3 * 1e-3 * 1.0, 0.0]
    with flex:
        mujoco.mj_forward(model, data)
        np.testing.assert_allclose(data.qfrc_passive, expected, rtol=1e-12, atol=1e-15)
        data.qpos[:] = [0.0, 0.2] if which == "turned" else [1e-3, 0.0]
        mujoco.mj_forward(model, data)
        assert np.abs(data.qfrc_passive).max() < 1e-12
        assert flex.potential_energy(data) < 1e-20


def test_a_rest_pose_given_as_the_identity_changes_nothing():
    """The identity composed into a measured residual gives its rest offset bit for bit."""
    spec = residual_spec("plugin")
    for p in spec.plugins:
        p.config = {k: v for k, v in dict(p.config).items() if not k.startswith("rest_")}
    plain = mjflex.Flexures(spec.compile())
    assert plain.element_table.elements["offset"][:2].all() and not plain.element_table.elements["rest"].any()
    for p in spec.plugins:
        p.config = {**dict(p.config), "rest_pos": "0 0 0", "rest_quat": "1 0 0 0"}
    same = mjflex.Flexures(spec.compile())
    for field in ("R0", "p0", "qb", "lever_b"):
        assert np.array_equal(same.element_table.elements[field], plain.element_table.elements[field])


# ------------------------------------------------------------------ bad input, every form


def _one(kind="plugin", **kwargs):
    spec = mujoco.MjSpec()
    spec.option.gravity = [0, 0, 0]  # 1 N/m would let the 0.2 kg body sag 2 m (a LikelyMistakeWarning)
    body = spec.worldbody.add_body(name="b0", pos=[0.1, 0, 0], mass=0.2, inertia=[2e-4] * 3)
    body.explicitinertial = True
    body.add_freejoint()
    handle = mjflex.add_flexure(spec, "disc", "world", "b0", pos=[0.1, 0, 0], kind=kind, **{"K": [1.0] * 6, **kwargs})
    return spec, handle


@pytest.mark.parametrize(
    ("rest", "match"),
    [
        (([0, 0, 0], [1.0, 1.0, 0, 0]), r"flexure 'disc2': rest.quat \(1 1 0 0\) has norm 1.41421356, so it is not a"),
        (([0, 0, 0], [0.7071, 0, 0, 0.7071]), r"rest.quat \(0.7071 0 0 0.7071\) has norm 0.99999\d*, so it is not a"),
        (([0, 0, np.nan], [1.0, 0, 0, 0]), r"flexure 'disc2': rest.pos has nan \(number 2\); give finite numbers"),
        (([0, 0, 0, 0], [1.0, 0, 0, 0]), r"flexure 'disc2': rest.pos has 4 numbers; give 3"),
        (([0, 0, 0], [1.0, 0, 0]), r"flexure 'disc2': rest.quat has 3 numbers; give 4"),
        ({"pos": [0, 0, 0]}, r"flexure 'disc2': rest must be a pose \(pos, quat\)"),
    ],
)
def test_add_flexure_refuses_a_bad_rest_pose_naming_the_element(rest, match):
    spec, _ = _one()
    before = spec.to_xml()
    with pytest.raises(ValueError, match=match):
        mjflex.add_flexure(spec, "disc2", "world", "b0", pos=[0.1, 0, 0], K=[1.0] * 6, rest=rest)
    assert spec.to_xml() == before


@pytest.mark.parametrize(
    ("config", "match"),
    [
        ({"rest_quat": "1 1 0 0"}, r"rest_quat \(1 1 0 0\) has norm 1.41421356, so it is not a rotation"),
        ({"rest_quat": "nan 0 0 0"}, r"rest_quat has nan \(number 0\); give finite numbers"),
        ({"rest_quat": "1 0 0"}, "rest_quat has 3 numbers; give 4"),
        ({"rest_pos": "0 0"}, "rest_pos has 2 numbers; give 3"),
        ({"rest_pos": "0 x 0"}, "rest_pos has 'x', which is not a number"),
    ],
)
def test_a_plugin_instance_with_a_bad_rest_pose_fails_to_compile_naming_the_element(config, match):
    spec, handle = _one()
    handle.plugin.config = {**dict(handle.plugin.config), **config}
    with pytest.raises(ValueError, match=rf"mjflex: flexure 'disc' \(plugin instance of mjflex.flexure\): {match}"):
        spec.compile()


@pytest.mark.parametrize(
    ("rest_json", "match"),
    [
        ('{"pos": [0, 0, 0], "quat": [1, 1, 0, 0]}', "not a rotation"),
        ('{"pos": [0, 0]}', "rest.pos has 2 numbers; give 3"),
        ('{"angle": 1}', r'"rest" has unknown key\(s\) \[\'angle\'\]; the allowed keys are \[\'pos\', \'quat\'\]'),
        ("[0, 0, 0]", '"rest" must be an object'),
    ],
)
def test_a_record_with_a_bad_rest_pose_is_a_model_error_naming_the_element(rest_json, match):
    spec, _ = _one("record")
    text = spec.text("mjflex:disc")
    text.data = text.data[:-1] + f', "rest": {rest_json}}}'
    with pytest.raises(mjflex.ModelError, match=rf"flexure 'disc': .*{match}"):  # the C library's, or JSON's
        mjflex.Flexures(spec.compile())


@pytest.mark.parametrize("kind", ["plugin", "record"])
@pytest.mark.parametrize("part", ["pos", "quat"])
def test_a_rest_pose_given_in_part_is_the_identity_elsewhere_in_python_as_in_c(kind, part):
    """Only the rest position (or only the quaternion) given: the record's rest pose holds the identity's other part,
    the one the C library composes, so the core with the record's rest pose gives C's wrench."""
    given = {"pos": [0.002, -0.001, 0.003], "quat": [float(v) for v in _quat([0.1, 0.2, -0.1])]}[part]
    spec, handle = _one(kind)
    if kind == "plugin":
        handle.plugin.config = {**dict(handle.plugin.config), f"rest_{part}": " ".join(map(repr, given))}
    else:
        text = spec.text("mjflex:disc")
        text.data = text.data[:-1] + f', "rest": {{"{part}": {given}}}}}'
    model = spec.compile()
    flex, data = mjflex.Flexures(model), mujoco.MjData(model)
    identity = {"pos": (0.0, 0.0, 0.0), "quat": (1.0, 0.0, 0.0, 0.0)}
    assert flex.records[0].rest == tuple(tuple(given) if p == part else identity[p] for p in ("pos", "quat"))
    data.qpos[:3] += [0.01, -0.02, 0.005]
    mujoco.mj_forward(model, data)
    We, _ = core_element(model, flex, data, 0)
    assert np.abs(flex.wrenches(data)[0] - We).max() <= 1e-12 * np.abs(We).max()


@pytest.mark.parametrize("method", ["twist", "dualquat"])
def test_the_largest_rest_position_and_stiffness_give_finite_forces(method):
    """At the table's bounds, a rest position of 1e10 m (MuJoCo's largest position, mjMAXVAL) and K of 1e280, the
    forces, wrenches and energy are finite at the compiled pose and at MuJoCo's largest position, turned half a
    turn (the native fuzzer, seed 33, config:852, found a rest position of -1e280 accepted and its forces
    infinite)."""
    for quat in ([1.0, 0, 0, 0], [0, 0, 0, 1.0]):
        spec, _ = _one(K=[1e280] * 6, method=method, rest=([1e10, -1e10, 1e10], quat))
        model = spec.compile()
        data, flex = mujoco.MjData(model), mjflex.Flexures(model)
        for q in (0.0, 1e10):
            data.qpos[:3] = [q, -q, q]
            data.qpos[3:7] = [0, 1, 0, 0] if q else [1, 0, 0, 0]
            mujoco.mj_forward(model, data)
            assert np.abs(data.qfrc_passive).max() > 1e289 and np.isfinite(data.qfrc_passive).all()
            assert np.isfinite(flex.wrenches(data)).all() and 1e299 < flex.potential_energy(data) < np.inf


def test_variants_say_what_becomes_of_a_rest_pose():
    """The MuJoCo-native variants cannot hold a preload: their reports say so; reduce keeps the rest pose of an
    element it keeps whole, also where it rewrites its record (here: its negligible damping dropped)."""
    spec, _ = _one(rest=([0, 0, 0.001], list(_quat([0, 0, 0.1]))), B=[1e-9] * 6)
    for build in (mjflex.bushing_variant, mjflex.weld_variant):
        assert "disc: its rest pose (a preload) is kept by an element kept whole only" in build(spec).report
    kept = mjflex.reduce(spec, keep_below_hz=1e9)
    assert "disc: kept as an element" in kept.report and not mjflex.Flexures(kept.model).records[0].viscous
    assert mjflex.Flexures(kept.model).records[0].rest == mjflex.Flexures(spec.compile()).records[0].rest

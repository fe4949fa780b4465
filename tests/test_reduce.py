"""mjflex.reduce: cheaper models that keep the low modes, their state maps and their dynamics."""

import itertools
import os
import warnings

import mujoco
import numpy as np
import pytest

import mjflex
from mjflex.analysis.linearize import normal_modes
from mjflex.app.scenes import cantilever_spec, parallelogram_spec
from mjflex.variants.planar import in_plane_modes
from mjflex.variants.variant import equality_rows
from tests.models import two_body_spec
from tests.plugin_models import as_records


def _elastic(freq):
    return freq[freq > 1e-2]


@pytest.fixture(scope="module")
def parallelogram():
    spec = parallelogram_spec()
    return spec, spec.compile(), mjflex.reduce(spec, 100.0)


def test_parallelogram_becomes_one_hinge_mechanism_with_the_same_guide_frequency(parallelogram):
    _, full, variant = parallelogram
    f_full, _ = normal_modes(full, mjflex.Flexures(full))
    f_red, _ = normal_modes(variant.model, mjflex.Flexures(variant.model), joint_springs=True, constraints="project")
    # The notches' five stiff directions, held rigid, raise the guide mode by their compliance in series
    # (~0.1 % here); reduce() promises freq_tol = 1 %.
    assert _elastic(f_red)[0] == pytest.approx(_elastic(f_full)[0], rel=0.01)
    assert variant.model.nv == 3  # three hinges (rod1, platform, rod2); the fourth closes the loop
    assert variant.details["loops"] == "constraint" and variant.details["loop_closers"] == ["notch2_top"]
    assert all(e["soft"] == ["rz"] for e in variant.details["elements"].values())
    assert variant.details["modes"]["max_relative_error"] < 0.01
    assert "two connect constraints" in variant.report


def test_parallelogram_dynamics_follow_the_full_model(parallelogram):
    _, full, variant = parallelogram
    traj = []
    for model in (full, variant.model):
        data = mujoco.MjData(model)
        mujoco.mj_resetDataKeyframe(model, data, 0)
        x = []
        with mjflex.Flexures(model):
            for _ in range(3000):  # 30 ms, about one period of the 36.5 Hz guide mode
                mujoco.mj_step(model, data)
                x.append(data.xpos[model.body("platform").id, 0])
        traj.append(np.array(x) - x[0])
    amplitude = np.abs(traj[0]).max()
    # The kick also rings the full model's stiff directions (kHz, a few % of the amplitude); the reduced
    # model has none of them, so the trajectories agree to a few % of the stroke, not to round-off.
    assert np.abs(traj[1] - traj[0]).max() < 0.05 * amplitude


def test_state_from_recovers_a_state_the_variant_can_represent(parallelogram):
    _, full, variant = parallelogram
    m = variant.model
    rng = np.random.default_rng(3)
    dv = mujoco.MjData(m)
    # a state of the mechanism (loop closed): move the hinges along the null space of the loop constraint
    dv.qpos[:] = m.qpos0
    _, G = equality_rows(m, dv)
    null = np.linalg.svd(G)[2][np.linalg.matrix_rank(G) :].T
    mujoco.mj_integratePos(m, dv.qpos, null @ (0.02 * rng.normal(size=null.shape[1])), 1.0)
    for _ in range(20):  # close the loop exactly (Gauss-Newton on the constraint residual)
        e, G = equality_rows(m, dv)
        mujoco.mj_integratePos(m, dv.qpos, np.linalg.lstsq(G, -e, rcond=None)[0], 1.0)
    _, G = equality_rows(m, dv)
    null = np.linalg.svd(G)[2][np.linalg.matrix_rank(G) :].T
    dv.qvel[:] = null @ rng.normal(size=null.shape[1])
    mujoco.mj_forward(m, dv)
    # the same poses and velocities written into the source's free joints
    ds = mujoco.MjData(full)
    for name in ("rod1", "rod2", "platform"):
        j = full.body(name).jntadr[0]
        qa, va = full.jnt_qposadr[j], full.jnt_dofadr[j]
        b = m.body(name).id
        ds.qpos[qa : qa + 3], ds.qpos[qa + 3 : qa + 7] = dv.xpos[b], dv.xquat[b]
        vel = np.zeros(6)
        mujoco.mj_objectVelocity(m, dv, mujoco.mjtObj.mjOBJ_BODY, b, vel, 1)  # local frame, at the body origin
        ds.qvel[va : va + 3] = dv.xmat[b].reshape(3, 3) @ vel[3:]
        ds.qvel[va + 3 : va + 6] = vel[:3]
    mujoco.mj_forward(full, ds)
    qpos, qvel = variant.state_from(full, ds)
    assert variant.state_from.last_residual < 1e-10
    np.testing.assert_allclose(qpos, dv.qpos, atol=1e-10)
    np.testing.assert_allclose(qvel, dv.qvel, rtol=1e-8, atol=1e-10 * np.abs(dv.qvel).max())


def test_body_map_covers_every_source_body_and_keyframes_carry_over(parallelogram):
    _, full, variant = parallelogram
    names = {full.body(i).name for i in range(1, full.nbody)}
    assert set(variant.body_map) == names
    assert all(np.array_equal(X, np.eye(4)) for _, X in variant.body_map.values())
    assert variant.model.nkey == 1 and variant.model.key("push").id == 0
    d = mujoco.MjData(variant.model)
    mujoco.mj_resetDataKeyframe(variant.model, d, 0)
    mujoco.mj_forward(variant.model, d)
    vel = np.zeros(6)
    mujoco.mj_objectVelocity(variant.model, d, mujoco.mjtObj.mjOBJ_XBODY, variant.model.body("platform").id, vel, 0)
    # The push moves the platform at 0.05 m/s; the reduced state carries the momentum its one mode can take
    assert 0.02 < vel[3] < 0.05


def test_cantilever_keeps_its_first_modes_and_drops_the_stiff_ones():
    spec = cantilever_spec(n=4)
    full = spec.compile()
    variant = mjflex.reduce(spec, 3000.0)
    f_full = _elastic(normal_modes(full, mjflex.Flexures(full))[0])
    f_red = _elastic(normal_modes(variant.model, mjflex.Flexures(variant.model) if variant.has_flexures else None,
                                  joint_springs=True)[0])  # fmt: skip
    kept = f_full[f_full < 3000.0]
    assert len(kept) >= 3
    np.testing.assert_allclose(f_red[: len(kept)], kept, rtol=0.01)  # the promised freq_tol
    assert f_red.max() < f_full.max()  # stiff directions held rigid: the highest mode drops
    assert variant.model.nv < full.nv


def test_planar_scene_becomes_a_planar_model():
    spec = cantilever_spec(n=4)
    full = spec.compile()
    variant = mjflex.reduce(spec, 3000.0, plane="auto", scene=("kick", 1e-3))
    m = variant.model
    assert variant.details["plane"] == pytest.approx([0.0, 0.0, 1.0])
    joints = [m.jnt_type[j] for j in range(m.njnt)]
    assert mujoco.mjtJoint.mjJNT_FREE not in joints and mujoco.mjtJoint.mjJNT_BALL not in joints
    d = mujoco.MjData(m)
    mujoco.mj_kinematics(m, d)
    mujoco.mj_comPos(m, d)
    for b in range(1, m.nbody):  # every joint moves the bodies in the x-y plane only
        jacp, jacr = np.zeros((3, m.nv)), np.zeros((3, m.nv))
        mujoco.mj_jacBody(m, d, jacp, jacr, b)
        assert np.abs(jacp[2]).max() < 1e-12 and np.abs(jacr[:2]).max() < 1e-12
    f_full, modes = normal_modes(full, mjflex.Flexures(full))
    in_plane = f_full[(f_full > 1e-2) & (f_full < 3000.0) & in_plane_modes(full, modes, np.array([0, 0, 1.0]))]
    f_red = _elastic(normal_modes(m, None, joint_springs=True)[0])
    assert len(in_plane) == 3 and len(in_plane) < len(_elastic(f_full[f_full < 3000.0]))  # out-of-plane ones go
    np.testing.assert_allclose(f_red[:3], in_plane, rtol=0.01)


def test_joints_the_element_springs_have_no_spring_of_their_own():
    """A restricted element's joints, and a planar scene's root joints, hold no stiffness or damping: the element (in
    its compliant directions) springs them, once."""
    spec = mujoco.MjSpec.from_string(
        '<mujoco><worldbody><body name="block" pos="0 0 -0.1"><freejoint/>'
        '<geom type="box" size="0.02 0.02 0.02" mass="0.5"/></body></worldbody></mujoco>'
    )
    K = [2, 2, 1, 1e5, 1e5, 1e5]
    mjflex.add_flexure(spec, "leaf", "world", "block", pos=[0, 0, -0.05], K=K, B=1e-4 * np.diag(K))
    restricted = mjflex.reduce(spec, verify=False).model  # at the file's step: 4 compliant directions, > max_joints
    assert restricted.njnt == 4 and len(mjflex.Flexures(restricted)) == 1
    np.testing.assert_array_equal(restricted.jnt_stiffness, 0.0)
    np.testing.assert_array_equal(restricted.dof_damping, 0.0)
    two_body = os.path.join(os.path.dirname(__file__), "..", "models", "two_body.xml")
    planar = mjflex.reduce(two_body, 500.0, plane="auto", verify=False).model
    roots = [j for j in range(planar.njnt) if ":plane_" in mujoco.mj_id2name(planar, mujoco.mjtObj.mjOBJ_JOINT, j)]
    assert len(roots) == 3
    np.testing.assert_array_equal(planar.jnt_stiffness[roots], 0.0)
    np.testing.assert_array_equal(planar.dof_damping[planar.jnt_dofadr[roots]], 0.0)


def test_plane_checks_say_what_is_not_planar():
    with pytest.raises(ValueError, match="couples in-plane and out-of-plane"):
        mjflex.reduce(two_body_spec(), 100.0, plane=[0.0, 0.0, 1.0])
    spec = parallelogram_spec()
    with pytest.raises(ValueError, match="gravity"):
        tilted = mjflex.copy_spec(spec)  # MjSpec.copy drops the plugin instances
        tilted.option.gravity = [0.0, 0.0, -9.81]
        mjflex.reduce(tilted, 100.0, plane=[0.0, 0.0, 1.0])
    kick = (_out_of_plane_kick(), 1e-4)
    variant = mjflex.reduce(cantilever_spec(n=3), 3000.0, plane="auto", verify=False, scene=kick)
    assert "not planar (the scene's initial velocities leave the plane)" in variant.report
    assert variant.details["plane"] is None


def _out_of_plane_kick():
    model = cantilever_spec(n=3).compile()
    qvel = np.zeros(model.nv)
    qvel[model.jnt_dofadr[model.body("link3").jntadr[0]] + 2] = 0.1  # the tip moves along z
    return model.qpos0.copy(), qvel


def test_rigid_band_merges_everything_and_damping_goes_where_negligible():
    spec = two_body_spec(B=1e-7 * np.eye(6))
    variant = mjflex.reduce(spec, 1e-3)  # below every elastic mode: nothing to resolve
    assert variant.model.nv == 6  # one free rigid body left (B nested in A without joints)
    assert variant.details["elements"]["link"]["soft"] == []
    assert "rigid, bodies merged" in variant.report
    assert variant.body_map["B"][0] == "B" and variant.model.body("B").jntnum[0] == 0
    damped = mjflex.reduce(two_body_spec(B=np.diag([1e-3, 1e-3, 1e-3, 1.0, 1.0, 1.0])), 1e4, verify=False)
    light = mjflex.reduce(two_body_spec(B=1e-9 * np.eye(6)), 1e4, verify=False)
    assert not damped.details["elements"]["link"]["damping_dropped"]
    assert light.details["elements"]["link"]["damping_dropped"]


def test_bad_input_is_named():
    spec = parallelogram_spec()
    with pytest.raises(ValueError, match="keep_below_hz"):
        mjflex.reduce(spec, 0.0)
    with pytest.raises(ValueError, match="loops"):
        mjflex.reduce(spec, 100.0, loops="weld")
    bare = mujoco.MjSpec()
    bare.worldbody.add_body(name="b").add_geom(size=[0.1, 0, 0])
    with pytest.raises(ValueError, match="no mjflex elements"):
        mjflex.reduce(bare, 100.0)
    with pytest.raises(ValueError, match="keyframe"):
        mjflex.reduce(spec, 100.0, scene=("nope", 0.01))
    other = two_body_spec().compile()  # compiled from a spec, not the XML MuJoCo loaded last
    mujoco.MjModel.from_xml_path("models/two_body.xml")
    with pytest.raises(TypeError, match="MJCF path or the MjSpec"):
        mjflex.reduce(other, 100.0)


def test_a_looser_frequency_tolerance_never_keeps_more_on_arcade():
    # ARCADE at 200 Hz kept nv 85 with freq_tol = 5 % but nv 63 with 1 %: its leaf springs, three joints each at 5 %
    # (kept whole at 1 %), went into the trees and pushed one-joint hinges out to close loops. A looser tolerance
    # must hold at least the directions a tighter one holds, keep at most its elements, and leave at most its dofs.
    tolerances = (0.005, 0.01, 0.02, 0.05, 0.1)
    runs = [mjflex.reduce("models/arcade.xml", 200.0, freq_tol=tol, verify=False).details for tol in tolerances]
    nv = [d["nv"] for d in runs]
    assert all(a >= b for a, b in itertools.pairwise(nv)), dict(zip(tolerances, nv, strict=True))
    assert nv[0] > nv[-1]  # the tolerance matters here: otherwise the check above would be empty
    for tight, loose in itertools.pairwise(runs):
        for name, e in loose["elements"].items():
            assert set(e["soft"]) <= set(tight["elements"][name]["soft"]), name
            assert not e["kept"] or tight["elements"][name]["kept"], name
    for d, tol in zip(runs, tolerances, strict=True):
        assert d["predicted_error"] <= tol


def _damping_ratios(model, viscous_off=()):
    """Damping ratios of a model's modes, ascending in frequency, from its linearization at qpos0 by MuJoCo itself.

    Central differences of ``qacc`` (``mj_forward`` with the elements installed) along each tangent direction and
    each velocity give ``A = M^-1 K`` and ``D = M^-1 B``; the eigenvalues of ``[[0, I], [-A, -D]]`` are the damped
    modes, ``zeta = -Re(lambda) / |lambda|``. Independent of how reduce() estimates damping (modal projections of
    each element's principal damping).
    """
    flex = mjflex.Flexures(model)
    for name in viscous_off:
        flex.set_viscous(name, False)
    data, nv, eps = mujoco.MjData(model), model.nv, 1e-7
    A, D = np.zeros((nv, nv)), np.zeros((nv, nv))
    with flex:
        for i in range(nv):
            for J, velocity in ((A, False), (D, True)):
                qacc = []
                for sign in (1.0, -1.0):
                    data.qpos[:], data.qvel[:] = model.qpos0, 0.0
                    dx = np.zeros(nv)
                    dx[i] = sign * eps
                    if velocity:
                        data.qvel[:] = dx
                    else:
                        mujoco.mj_integratePos(model, data.qpos, dx, 1.0)
                    mujoco.mj_forward(model, data)
                    qacc.append(data.qacc.copy())
                J[:, i] = -(qacc[0] - qacc[1]) / (2.0 * eps)
    lam = np.linalg.eigvals(np.block([[np.zeros((nv, nv)), np.eye(nv)], [-A, -D]]))
    lam = lam[lam.imag > 0]
    lam = lam[np.argsort(lam.imag)]
    return -lam.real / np.abs(lam)


def test_damping_is_dropped_within_a_budget_shared_by_all_the_dropped_elements():
    # Four damped elements (B = beta K) on a cantilever, every mode kept (nothing held rigid): the only reduction is
    # which damping goes. The budget is half the largest damping ratio, so each element's damping alone fits in it
    # for most elements but not all of them together: a budget counted per element would drop too much.
    spec = as_records(cantilever_spec(n=4, beta=2e-9))  # text records: switched per element at run time below
    full = spec.compile()
    zeta = _damping_ratios(full)
    tol = 0.5 * zeta.max()
    variant = mjflex.reduce(spec, 1e6, viscous_tol=tol, verify=False)
    elements = variant.details["elements"]
    dropped = [name for name, e in elements.items() if e["damping_dropped"]]
    kept = [name for name, e in elements.items() if not e["damping_dropped"]]
    assert all(e["kept"] for e in elements.values())  # every mode kept: the model is the full one but for damping
    alone = {name: zeta - _damping_ratios(full, [name]) for name in elements}  # each element's own contribution
    assert sum(alone[n].max() <= tol for n in elements) > len(dropped)  # a per-element budget would drop more
    # the promise: no mode loses more than viscous_tol of damping ratio (measured on the model reduce built). The
    # 1 % slack covers reduce's first-order estimate (phi^T B phi / 2 omega) against the exact damped eigenvalues,
    # whose difference is of order zeta^2 / zeta = zeta <= 5e-4 relative here.
    loss = zeta - _damping_ratios(variant.model)
    assert 0 < loss.max() <= 1.01 * tol
    assert dropped and kept
    for name in kept:  # and it drops all it can: each element kept would overrun the budget if dropped as well
        more = zeta - _damping_ratios(variant.model, [name])
        assert more.max() > tol, name


def test_mirror_equal_elements_keep_or_drop_their_damping_together():
    # The parallelogram is symmetric about x = w / 2: notch1_* mirror notch2_*, so each pair adds equal damping to
    # every mode. Over a grid of budgets finer than a factor 2 (one element of a pair fits where both do not), a pair
    # is always treated alike, and the grid crosses each pair's threshold.
    spec = parallelogram_spec()
    pairs = (("notch1_ground", "notch2_ground"), ("notch1_top", "notch2_top"))
    seen = {pair: set() for pair in pairs}
    for tol in np.geomspace(1e-6, 1e-2, 28):  # factor 1.41 between budgets
        elements = mjflex.reduce(spec, 100.0, viscous_tol=tol, verify=False).details["elements"]
        for a, b in pairs:
            assert elements[a]["damping_dropped"] == elements[b]["damping_dropped"], (tol, a, b)
            seen[a, b].add(elements[a]["damping_dropped"])
    assert all(s == {True, False} for s in seen.values())


def test_a_scene_keeps_the_directions_it_strains_within_twice_freq_tol_of_its_energy():
    # A cantilever kicked at the tip along its axis and across: the axial directions, rigid for the first mode
    # (200 Hz band), store about 2 % each of the scene's peak strain energy. Held rigid, they may together remove at
    # most 2 freq_tol of it (smallest first). The shares are recomputed here from the elements' own energies
    # (diagonal K at the element origin, so the principal directions are the element axes) along the same run.
    spec = cantilever_spec(n=4)
    model = spec.compile()
    flex = mjflex.Flexures(model)
    K = np.stack([np.diag(r.K) for r in flex.records])
    assert all(np.allclose(r.K, np.diag(np.diag(r.K)), rtol=0, atol=1e-9 * np.abs(r.K).max()) for r in flex.records)
    qvel = np.zeros(model.nv)
    tip = model.jnt_dofadr[model.body("link4").jntadr[0]]
    qvel[tip : tip + 2] = [0.3, 2.0]
    duration, tol = 1e-3, 0.01
    data = mujoco.MjData(model)
    data.qpos[:], data.qvel[:] = model.qpos0, qvel
    peak, total = np.zeros_like(K), 0.0
    with flex:
        for _ in range(round(duration / model.opt.timestep)):
            mujoco.mj_step(model, data)
            mujoco.mj_forward(model, data)
            peak = np.maximum(peak, 0.5 * K * flex.displacements(data) ** 2)
            total = max(total, flex.potential_energy(data))
    share = peak / total
    labels = ("rx", "ry", "rz", "x", "y", "z")

    def rigid(variant):
        soft = [variant.details["elements"][name]["soft"] for name in flex.names]
        return {(e, i) for e in range(len(soft)) for i in range(6) if labels[i] not in soft[e]}

    with_scene = rigid(mjflex.reduce(spec, 200.0, freq_tol=tol, scene=((model.qpos0, qvel), duration), verify=False))
    modes_only = rigid(mjflex.reduce(spec, 200.0, freq_tol=tol, verify=False))
    spared = modes_only - with_scene  # held rigid by the modes, kept compliant for the scene
    assert spared and with_scene <= modes_only
    held = sum(share[c] for c in with_scene)
    # same run, same samples (every step): equal up to round-off
    assert held <= 2.0 * tol * (1.0 + 1e-9)
    # and the budget is used: holding the smallest spared direction as well would overrun it
    assert held + min(share[c] for c in spared) > 2.0 * tol


def _hanging_leaf(zeta_z):
    """A 0.5 kg block hanging on a leaf spring (the reduce docstring's), damped in its axial stretch (71 Hz) by
    ``zeta_z``: at 2 ms Euler an undamped 71 Hz mode is resolved with the advice's margin, one damped by 0.2 is not
    (the explicit damping lowers the limit by ``sqrt(1 + zeta^2) - zeta``)."""
    spec = mujoco.MjSpec.from_string(
        '<mujoco><worldbody><body name="block" pos="0 0 -0.1"><freejoint/>'
        '<geom type="box" size="0.02 0.02 0.02" mass="0.5"/></body></worldbody></mujoco>'
    )
    B = np.zeros(6)
    B[5] = 2.0 * zeta_z * np.sqrt(1e5 * 0.5)
    mjflex.add_flexure(spec, "leaf", "world", "block", pos=[0, 0, -0.05], K=[2, 2, 1, 1e5, 1e5, 1e5], B=B)
    return spec


@pytest.mark.parametrize(("zeta", "soft"), [(0.0, ["rx", "ry", "rz", "z"]), (0.2, ["rx", "ry", "rz"])])
def test_a_step_keeps_compliant_what_the_step_advice_resolves_where_the_scene_rests(zeta, soft):
    """reduce(timestep=...) and the step advice agree: the reduced model's advice at its rest under gravity resolves
    the step (asked independently here), and the damped axial stretch, which the advice does not resolve at 2 ms,
    goes rigid; undamped it stays."""
    spec = _hanging_leaf(zeta)
    with warnings.catch_warnings():
        warnings.simplefilter("error", mjflex.analysis.linearize.NotAtRestWarning)
        warnings.simplefilter("error", mjflex.ReductionWarning)
        variant = mjflex.reduce(spec)
    assert variant.details["elements"]["leaf"]["soft"] == soft
    m = variant.model
    flex = mjflex.Flexures(m) if variant.has_flexures else None
    advice = mjflex.step_advice(m, flex, qpos=mjflex.static_equilibrium(m, flex))
    assert advice.recommended >= m.opt.timestep == 0.002
    assert variant.details["step"]["advised_step"] == pytest.approx(advice.recommended, rel=1e-3)
    omega = np.sqrt(1e5 / 0.5)  # the stretch alone: symplectic Euler with explicit damping, 2 (sqrt(1+z^2)-z) / w
    resolved = 0.5 * 2.0 * (np.sqrt(1.0 + zeta**2) - zeta) / omega >= 0.002
    assert ("z" in soft) == resolved

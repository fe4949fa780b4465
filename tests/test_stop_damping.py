"""Damped end stops (issue 31): the core against finite differences, the C engine against the core in every lane
count, the energy balance, the clamp that never attracts, a damping from a ratio or a time constant, the stored forms
and bad input.

The core's damped stop wrench is checked against quantities the test builds itself: the rates of the stop
coordinates by Ridders' central differences along the bodies' motion (``stop_coordinates`` of poses moved by their
velocities), the stops' total force ``G'`` from the clamp written out here, and the wrench as minus the transposed
finite-difference Jacobian of the coordinates times ``G' - G``. The C engine is checked against the core (the frames'
rounding residual removed from the sites' own poses, then the rest pose), the elastic part against finite
differences of the C energy, and its dissipated power against the power of its damping forces.
"""

import itertools

import mujoco
import numpy as np
import pytest

import mjflex
from mjflex.native import library as _native
from tests.helpers import gradient_wrt_b, random_rotation, ridders, rot_exp
from tests.plugin_models import assert_not_diverged
from tests.test_stops import K_BUSH, _bodies, _gradient, _random_state

pytestmark = [pytest.mark.usefixtures("clean_callback")]
INF = np.inf


# ------------------------------------------------------------------ the core against finite differences


def _moving_pose(rng, angle):
    """Poses of frames a and b and their world velocities [w_A, v_A (at p_WA), w_B, v_B (at p_WB)]."""
    R_WA, p_WA = random_rotation(rng), rng.normal(size=3)
    R_ab, p_ab = random_rotation(rng, angle), 0.01 * rng.normal(size=3)
    vel = [rng.normal(size=3), 0.1 * rng.normal(size=3), rng.normal(size=3), 0.1 * rng.normal(size=3)]
    return (R_WA, p_WA, R_WA @ R_ab, p_WA + R_WA @ p_ab), vel


def _at_time(pose, vel, t):
    """The poses moved for time t at constant world velocities (rotations about the frames' origins)."""
    R_WA, p_WA, R_WB, p_WB = pose
    return rot_exp(t * vel[0]) @ R_WA, p_WA + t * vel[1], rot_exp(t * vel[2]) @ R_WB, p_WB + t * vel[3]


def _clamped(z, zdot, lo, hi, k, b):
    """The damped stops' total force G' written out from the module docstring (one coordinate at a time)."""
    out = np.zeros(6)
    for i in range(6):
        if z[i] > hi[i]:
            out[i] = max(k[i] * (z[i] - hi[i]) + b[i] * zdot[i], 0.0)
        elif z[i] < lo[i]:
            out[i] = -max(k[i] * (lo[i] - z[i]) - b[i] * zdot[i], 0.0)
    return out


@pytest.mark.parametrize("angle", [1e-3, 0.5, 2.0, 3.0])
@pytest.mark.parametrize("with_rest", [False, True])
def test_core_damping_is_its_force_through_the_coordinates_jacobian(angle, with_rest):
    """Every coordinate past a limit or well inside a range; dampings that leave some clamps open and make others
    hold. The damping's wrench is -J^T (G' - G) and its power (G' - G) . zdot, with J and zdot by finite
    differences of the coordinates; the elastic part stays minus the energy's gradient; zero damping gives the
    undamped wrench bit for bit."""
    rng = np.random.default_rng(int(1000 * angle) + with_rest)
    rest = (0.01 * rng.normal(size=3), np.r_[np.cos(0.2), np.sin(0.2) * rng.normal(size=3) / np.sqrt(3)])
    rest = (rest[0], rest[1] / np.linalg.norm(rest[1])) if with_rest else None
    pose, vel = _moving_pose(rng, angle)
    z = mjflex.stop_coordinates(*pose, rest=rest)
    zdot = np.array([ridders(lambda h, i=i: (mjflex.stop_coordinates(*_at_time(pose, vel, h), rest=rest)[i], h),
                             1e-3)[0] for i in range(6)])  # fmt: skip
    # each coordinate at random: past a stop it moves back from, damped 3 times harder than the stop pushes (the
    # clamp holds); past a stop it moves on into, damped 0.3 times (open); inside a range (nothing)
    lo, hi, size = np.full(6, -INF), np.full(6, INF), np.maximum(np.abs(z), 1e-3)
    mode = rng.permutation([0, 1, 2, 0, 1, 2])
    into_upper = (mode == 1) == (zdot > 0)  # the stop whose side the coordinate moves on into (mode 1) or back from
    hi[(mode < 2) & into_upper] = (z - 0.5 * size)[(mode < 2) & into_upper]
    lo[(mode < 2) & ~into_upper] = (z + 0.5 * size)[(mode < 2) & ~into_upper]
    lo[mode == 2], hi[mode == 2] = (z - size)[mode == 2], (z + size)[mode == 2]
    k = rng.uniform(0.5, 2.0, size=6) * [10, 10, 10, 1e4, 1e4, 1e4]
    over = np.maximum(z - hi, 0) + np.maximum(lo - z, 0)
    b = np.where(mode == 0, 3.0, 0.3) * k * over / np.abs(zdot) + (mode == 2)
    velocities = dict(zip(("w_WA", "v_WA", "w_WB", "v_WB"), vel, strict=True))
    W = mjflex.stop_wrench_on_b(*pose, lo, hi, k, damping=b, rest=rest, **velocities)
    W0 = mjflex.stop_wrench_on_b(*pose, lo, hi, k, rest=rest)
    P = mjflex.stop_dissipation_power(*pose, lo, hi, k, b, rest=rest, **velocities)
    G = k * (np.maximum(z - hi, 0) - np.maximum(lo - z, 0))
    Gd = _clamped(z, zdot, lo, hi, k, b)
    assert ((Gd == 0) == (mode != 1)).all() and (np.abs(Gd) > np.abs(G))[mode == 1].all()  # as planned
    J = np.array([gradient_wrt_b(lambda R, p, i=i: mjflex.stop_coordinates(*pose[:2], R, p, rest=rest)[i],
                                 pose[2], pose[3], 1e-3, 1e-4) for i in range(6)])  # fmt: skip
    expected = -J.T @ (Gd - G)
    assert np.linalg.norm(W - W0 - expected) <= 1e-7 * np.linalg.norm(expected)
    assert np.isclose(P, (Gd - G) @ zdot, rtol=1e-7) and P > 0
    assert np.linalg.norm(W0 + J.T @ G) <= 1e-7 * np.linalg.norm(J.T @ G)  # the elastic part: -grad U_s
    zero = mjflex.stop_wrench_on_b(*pose, lo, hi, k, damping=np.zeros(6), rest=rest, **velocities)
    assert np.array_equal(zero, W0)
    assert mjflex.stop_dissipation_power(*pose, lo, hi, k, np.zeros(6), rest=rest, **velocities) == 0.0


def test_core_stop_damping_acts_only_beyond_the_limit_and_never_attracts():
    """About one axis, past an upper stop at rate zdot: the moment is -(k over + b zdot) while that is negative,
    0 beyond (moving out faster than k over / b), continuous at the switch; inside the range nothing at any rate."""
    R_WB, _ = mjflex.transform_from_twist([0, 0, 0.3, 0, 0, 0])
    upper = [INF, INF, 0.25, INF, INF, INF]
    k, b = 7.0, 2.0
    for rate in (3.0, 0.1, -0.1, -0.175 + 1e-12, -0.175 - 1e-12, -5.0):
        W = mjflex.stop_wrench_on_b(np.eye(3), np.zeros(3), R_WB, np.zeros(3), None, upper, [k] * 6, damping=[b] * 6,
                                    w_WB=[0, 0, rate])  # fmt: skip
        assert np.allclose(W, [0, 0, -max(k * 0.05 + b * rate, 0.0), 0, 0, 0], atol=1e-12)
        assert W[2] <= 0.0
    inside = mjflex.stop_wrench_on_b(np.eye(3), np.zeros(3), R_WB, np.zeros(3), None, [INF, INF, 0.35, INF, INF, INF],
                                     [k] * 6, damping=[b] * 6, w_WB=[0, 0, 10.0])  # fmt: skip
    assert not inside.any()


# ------------------------------------------------------------------ the C engine against the core


REST = {  # element -> rest pose (pos [m], quat w-first)
    "grounded": ([0.002, -0.001, 0.003], [np.cos(0.15), 0.0, np.sin(0.15) * 0.6, np.sin(0.15) * 0.8]),
    "joint": ([0.0, 0.001, 0.0], [np.cos(0.1), np.sin(0.1), 0.0, 0.0]),
}
LAYOUT = (  # (element, body a, body b, method, frame quat, damping)
    ("grounded", "world", "b0", "twist", [0.9, 0.1, -0.3, 0.2], [0.02, 0.03, 0.01, 20.0, 30.0, 10.0]),
    ("joint", "b0", "b1", "dualquat", [0.8, 0.0, 0.6, 0.0], 0.05),
    ("pure", "world", "b1", "twist", [1, 0, 0, 0], [0.01, 0.02, 0.03, 5.0, 6.0, 7.0]),
    ("plain", "b0", "b1", "twist", [1, 0, 0, 0], None),
)


def damped_spec(qpos=None, *, kind="plugin", seed=0, margin=0.3, B=None, damping=True):
    """Two free bodies and four elements with end stops, placed as tests/test_stops.stops_spec places them around
    ``qpos`` (in each element's coordinates, counted from its rest pose): damped stops with rest poses on a twist
    and a dual-quaternion element, damped stops alone on an element with K = 0, and undamped stops beside them."""
    spec = _bodies(mujoco.MjSpec())
    rng = np.random.default_rng(seed)
    zs = None
    if qpos is not None:
        model = damped_spec(kind=kind).compile()
        flex, data = mjflex.Flexures(model), mujoco.MjData(model)
        data.qpos[:] = qpos
        mujoco.mj_kinematics(model, data)
        zs = flex.stop_coordinates(data)
    for e, (name, a, b, method, quat, b_stop) in enumerate(LAYOUT):
        stops = None
        if zs is not None:
            lower, upper = np.full(6, -INF), np.full(6, INF)
            for i, z in enumerate(zs[e]):
                size = max(abs(z), 1e-3)
                which = rng.integers(3)
                if which == 0:
                    upper[i] = z - margin * size
                elif which == 1:
                    lower[i] = z + margin * size
                else:
                    lower[i], upper[i] = z - size, z + size
            stiffness = (None, 5.0 * K_BUSH[0, 0], 10 * np.diagonal(K_BUSH), None)[e]
            stops = mjflex.Stops(list(lower), list(upper), stiffness, b_stop if damping else None)
        K = 0 * K_BUSH if name == "pure" else K_BUSH
        mjflex.add_flexure(spec, name, a, b, pos=[0.15, 0.01, 0.0], quat=quat, K=K, B=B, method=method, stops=stops,
                           kind=kind, rest=REST.get(name))  # fmt: skip
    return spec


def _state(model, qpos, seed, speed=1.0):
    data = mujoco.MjData(model)
    data.qpos[:] = qpos
    data.qvel[:] = speed * np.random.default_rng(seed).normal(size=model.nv)
    mujoco.mj_forward(model, data)
    return data


def core_element(model, flex, data, e, qvel=True):
    """Element e's wrench on B (moment about site b, world axes) and dissipated power from the core: frames from the
    sites' poses, the rounding residual measured at qpos0 removed from frame b, then the rest pose (its own)."""
    rec = flex.records[e]
    sa, sb = flex.site_ids[e]
    ref = mujoco.MjData(model)
    mujoco.mj_kinematics(model, ref)
    Ra0, pa0 = ref.site_xmat[sa].reshape(3, 3), ref.site_xpos[sa]
    Rb0, pb0 = ref.site_xmat[sb].reshape(3, 3), ref.site_xpos[sb]
    R_res, p_res = Ra0.T @ Rb0, Ra0.T @ (pb0 - pa0)  # frame b seen from frame a at qpos0
    R_a, p_a = data.site_xmat[sa].reshape(3, 3), data.site_xpos[sa]
    R_b = data.site_xmat[sb].reshape(3, 3) @ R_res.T  # frame b less the residual: where the element frame was put
    p_b = data.site_xpos[sb] - R_b @ p_res
    vel = []
    for site, point in ((sa, p_a), (sb, p_b)):
        v = np.empty(6)
        mujoco.mj_objectVelocity(model, data, mujoco.mjtObj.mjOBJ_SITE, int(site), v, 0)
        vel += [v[:3], v[3:] + np.cross(v[:3], point - data.site_xpos[site])]
    kw = dict(zip(("w_WA", "v_WA", "w_WB", "v_WB"), vel, strict=True)) if qvel else {}
    method = rec.method
    W = mjflex.wrench_on_b(R_a, p_a, R_b, p_b, rec.K, method=method, rest=rec.rest,
                           **({"B": rec.B, **kw} if rec.B is not None else {}))  # fmt: skip
    P = mjflex.dissipation_power(R_a, p_a, R_b, p_b, rec.B, method=method, rest=rec.rest, **kw) if rec.B is not None \
        else 0.0  # fmt: skip
    if rec.stops:
        limits, b = _stop_parameters(rec.stops, rec.K)
        W = W + mjflex.stop_wrench_on_b(R_a, p_a, R_b, p_b, *limits, damping=b, rest=rec.rest, **kw)
        P = P + mjflex.stop_dissipation_power(R_a, p_a, R_b, p_b, *limits, b, rest=rec.rest, **kw)
    W[:3] += np.cross(p_b - data.site_xpos[sb], W[3:])  # about site b
    return W, P


def _stop_parameters(stops, K):
    """``(lower, upper, stiffness), damping`` of a spatial element's stops, laid out here from what the record gives
    (the core's derived stiffness), not read back from the C library's element."""
    lower, upper = stops.limits_for(6)
    limited = np.isfinite(lower) | np.isfinite(upper)
    k = mjflex.derived_stop_stiffness(K) if stops.stiffness is None else np.broadcast_to(stops.stiffness, (6,))
    b = np.zeros(6) if stops.damping is None else np.broadcast_to(stops.damping, (6,))
    return (lower, upper, np.where(limited, k, 0.0)), np.where(limited, b, 0.0)


@pytest.fixture
def lanes():
    native = _native.lib()
    yield lambda n: native.mjfx_set_lanes(n)
    native.mjfx_set_lanes(0)


@pytest.mark.parametrize("kind", ["plugin", "record"])
@pytest.mark.parametrize("seed", range(3))
def test_c_damped_stops_and_rest_poses_match_the_core_in_every_lane_count(kind, seed, lanes):
    """Wrenches (about site b), dissipated powers and generalized forces of the C engine against the core, to
    round-off, with most stop coordinates engaged and the bodies moving; every lane count gives the same bits."""
    rng = np.random.default_rng(40 + seed)
    qpos = _random_state(damped_spec(kind=kind).compile(), rng)
    model = damped_spec(qpos, kind=kind, seed=seed, B=1e-3 * K_BUSH).compile()
    flex = mjflex.Flexures(model)
    rows = flex.element_table.elements[: len(flex)]
    assert list(rows["stop_damped"]) == [1, 1, 1, 0] and list(rows["rest"]) == [1, 1, 0, 0]
    data = _state(model, qpos, seed)
    assert (flex.dissipation_powers(data) > 0).all()
    results = []
    for n in [n for n in (1, 2, 4) if _native.lib().mjfx_lanes_available(n)]:
        lanes(n)
        W, P, Q = flex.wrenches(data), flex.dissipation_powers(data), flex.generalized_forces(data)
        results.append((W, P, Q))
        expected, scale = np.zeros(model.nv), np.zeros(model.nv)
        for e in range(len(flex)):
            We, Pe = core_element(model, flex, data, e)
            assert np.abs(W[e] - We).max() <= 1e-12 * np.abs(We).max(), (e, W[e], We)
            assert abs(P[e] - Pe) <= 1e-12 * abs(Pe), (e, P[e], Pe)
            for sign, body in ((1.0, model.site_bodyid[flex.site_ids[e, 1]]),
                               (-1.0, model.site_bodyid[flex.site_ids[e, 0]])):  # fmt: skip
                one = np.zeros(model.nv)
                mujoco.mj_applyFT(model, data, sign * We[3:], sign * We[:3], data.site_xpos[flex.site_ids[e, 1]],
                                  int(body), one)  # fmt: skip
                expected += one
                scale += np.abs(one)
        assert np.all(np.abs(Q - expected) <= 1e-12 * scale)
    for other in results[1:]:
        for got, first in zip(other, results[0], strict=True):
            assert np.array_equal(got, first)


@pytest.mark.parametrize("kind", ["plugin", "record"])
def test_c_elastic_part_is_minus_the_gradient_of_the_c_energy(kind):
    """At rest (qvel = 0, the damped stops' code with zero rates), with rest poses: the generalized forces are minus
    the finite-difference gradient of the engine's energy (elastic + stops)."""
    rng = np.random.default_rng(7)
    qpos = _random_state(damped_spec(kind=kind).compile(), rng)
    model = damped_spec(qpos, kind=kind, seed=2).compile()
    flex = mjflex.Flexures(model)
    data = _state(model, qpos, 0, speed=0.0)
    with flex:
        mujoco.mj_forward(model, data)
        qfrc = data.qfrc_passive.copy()
    g = _gradient(model, flex, qpos, 1e-5)  # steps well within every stop's margin
    assert np.linalg.norm(qfrc + g) <= 1e-7 * np.linalg.norm(g)


def test_c_dissipated_power_is_the_power_of_the_damping_forces():
    """The generalized forces less those at zero velocity are the damping's (B and the stops'): their power is minus
    the dissipated power the engine reports, and zero damping gives the undamped engine bit for bit."""
    rng = np.random.default_rng(3)
    qpos = _random_state(damped_spec().compile(), rng)
    model = damped_spec(qpos, seed=1, B=1e-3 * K_BUSH).compile()
    flex = mjflex.Flexures(model)
    data = _state(model, qpos, 1)
    moving = flex.generalized_forces(data)
    still = mujoco.MjData(model)
    still.qpos[:] = qpos
    mujoco.mj_forward(model, still)
    damping = moving - flex.generalized_forces(still)
    power = flex.dissipation_power(data)
    assert np.isclose(-damping @ data.qvel, power, rtol=1e-11) and power > 0
    # stops with zero damping: no damped kind, the same bits as stops without damping
    spec = damped_spec(qpos, seed=1, damping=False)
    zero = damped_spec(qpos, seed=1, damping=False)
    for rec_name in ("grounded", "joint", "pure"):
        plugin = next(p for p in zero.plugins if p.name == rec_name)
        plugin.config = {**dict(plugin.config), "stop_damping": "0"}
    a, b = spec.compile(), zero.compile()
    a.opt.timestep = b.opt.timestep = 1e-5  # stops as stiff as 10 K: far from rest, 2 ms would diverge
    assert not mjflex.Flexures(b).element_table.elements["stop_damped"].any()
    assert mjflex.Flexures(b).records[0].stops.damping == 0.0
    da, db = _state(a, qpos, 1), _state(b, qpos, 1)
    for _ in range(20):
        mujoco.mj_step(a, da), mujoco.mj_step(b, db)
    assert_not_diverged(da, "zero stop damping")
    assert np.array_equal(da.qpos, db.qpos) and np.array_equal(da.qvel, db.qvel)


# ------------------------------------------------------------------ dynamics: the energy balance


def rotor_spec(integrator="rk4", h=2.5e-4, stops=None, kind="plugin", K=(0.2, 0.2, 0.1, 1e3, 1e3, 1e3)):
    """A free rotor (inertia 1e-3 kg m^2 about z) on a grounded element at its centre of mass."""
    spec = mujoco.MjSpec()
    spec.option.gravity = [0, 0, 0]
    spec.option.integrator = getattr(mujoco.mjtIntegrator, f"mjINT_{integrator.upper()}")
    spec.option.timestep = h
    spec.option.enableflags |= mujoco.mjtEnableBit.mjENBL_ENERGY
    body = spec.worldbody.add_body(name="rotor", pos=[0, 0, 0.1], mass=0.5, inertia=[2e-3, 2e-3, 1e-3],
                                   ipos=[0, 0, 0], iquat=[1, 0, 0, 0])  # fmt: skip
    body.explicitinertial = True
    body.add_freejoint()
    mjflex.add_flexure(spec, "hinge", "world", "rotor", pos=[0, 0, 0.1], K=list(K), stops=stops, kind=kind)
    return spec


def _bounce(model, T=0.5, speed=3.0):
    """Spun at ``speed`` about z into the stop: largest |E + W - E0|, W (the dissipation integrated by the
    trapezoidal rule), E0, and the rotation's history."""
    flex, data = mjflex.Flexures(model), mujoco.MjData(model)
    data.qvel[5] = speed
    mujoco.mj_forward(model, data)
    E0 = data.energy[1] + flex.potential_energy(data)
    h = model.opt.timestep
    power, dissipated, error, angle = flex.dissipation_power(data), 0.0, 0.0, []
    with flex:
        for _ in range(round(T / h)):
            mujoco.mj_step(model, data)
            mujoco.mj_forward(model, data)
            now = flex.dissipation_power(data)
            dissipated += 0.5 * h * (power + now)
            power = now
            error = max(error, abs(data.energy[1] + flex.potential_energy(data) + dissipated - E0))
            angle.append(flex.stop_coordinates(data)[0, 2])
    assert_not_diverged(data, "rotor")
    return error, dissipated, E0, np.array(angle)


@pytest.mark.parametrize("kind", ["plugin", "record"])
def test_the_energy_balance_closes_with_damped_stops(kind):
    """The rotor spun into a damped stop (no element damping): the energy the engine reports as dissipated is what
    the rotor lost, E + W -> E0 as the step shrinks. With RK4 the mismatch is first order in the step: the damping
    force starts at the limit with the entry velocity (as a MuJoCo limit's), a jump that the step and the
    trapezoidal rule on the power resolve to O(h) (0.5 h b zdot^2 at the entry). The stop took most of the energy;
    conservative stops lose none."""
    stops = mjflex.Stops(upper=[None, None, 0.1, None, None, None], damping_ratio=0.3)
    runs = [_bounce(rotor_spec(stops=stops, kind=kind, h=h).compile()) for h in (2.5e-4, 1.25e-4, 6.25e-5)]
    for _error, W, E0, angle in runs:
        assert angle.max() > 0.1 and W > 0.5 * E0
    ratios = [a[0] / b[0] for a, b in itertools.pairwise(runs)]
    assert all(1.8 < r < 2.2 for r in ratios), ratios
    assert runs[-1][0] < 5e-3 * runs[-1][1]
    error, W, E0, _ = _bounce(rotor_spec(stops=mjflex.Stops(upper=[None, None, 0.1, None, None, None]),
                                         kind=kind).compile())  # fmt: skip
    assert W == 0.0 and error < 1e-3 * E0


@pytest.mark.parametrize("kind", ["plugin", "record"])
def test_c_stop_never_pulls_the_body_back_in(kind):
    """The rotor 0.05 rad past its stop (an element of stops alone, k = 10, b = 2): moving back out faster than
    k over / b = 0.25 rad/s the stop pushes with nothing; slower, with k over + b zdot; moving in, with more; the
    force is continuous where the clamp starts to hold."""
    stops = mjflex.Stops(upper=[None, None, 0.1, None, None, None], stiffness=10.0, damping=2.0)
    model = rotor_spec(stops=stops, kind=kind, K=[0.0] * 6).compile()
    flex, data = mjflex.Flexures(model), mujoco.MjData(model)
    data.qpos[3:7] = [np.cos(0.075), 0, 0, np.sin(0.075)]
    with flex:
        for rate in (1.0, 0.0, -0.2, -0.25 + 1e-9, -0.25 - 1e-9, -0.3, -3.0):
            data.qvel[5] = rate
            mujoco.mj_forward(model, data)
            assert np.isclose(data.qfrc_passive[5], -max(10 * 0.05 + 2.0 * rate, 0.0), rtol=1e-12, atol=1e-8)
            assert data.qfrc_passive[5] <= 0.0
            if rate < -0.25:
                assert data.qfrc_passive[5] == 0.0 and flex.dissipation_power(data) > 0


def test_the_damper_disable_flag_switches_the_stops_damping_off():
    """MuJoCo's damper flag off: the stop is conservative (its elastic force only); the spring flag off: no stop."""
    stops = mjflex.Stops(upper=[None, None, 0.1, None, None, None], stiffness=10.0, damping=2.0)
    model = rotor_spec(stops=stops, K=[0.0] * 6).compile()
    flex, data = mjflex.Flexures(model), mujoco.MjData(model)
    data.qpos[3:7] = [np.cos(0.075), 0, 0, np.sin(0.075)]
    data.qvel[5] = 1.0
    mujoco.mj_forward(model, data)
    assert np.isclose(data.qfrc_passive[5], -(10 * 0.05 + 2.0), rtol=1e-12)
    model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_DAMPER
    mujoco.mj_forward(model, data)
    assert np.isclose(data.qfrc_passive[5], -10 * 0.05, rtol=1e-12) and flex.dissipation_power(data) == 0.0
    model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_SPRING
    mujoco.mj_forward(model, data)
    assert not data.qfrc_passive.any()


# ------------------------------------------------------------------ a damping from a ratio or a time constant


def test_a_ratio_and_a_time_constant_become_numbers_from_the_effective_masses():
    """The rotor: about z its stop's effective inertia is I_zz = 1e-3; along x at the element's origin, 2 cm from the
    centre of mass along y, 1 / (1/m + r_y^2 / I_zz) (the closed form). A ratio gives b = 2 zeta sqrt(k m) for the
    derived stiffness; a time constant gives MuJoCo's map k = m / (tau zeta)^2, b = 2 m / tau."""
    limits = {"upper": [None, None, 0.1, 0.001, None, None]}
    m = np.array([1e-3, 1.0 / (1.0 / 0.5 + 0.02**2 / 1e-3)])
    k_derived = 100 * np.array([0.1, 1e3])
    for stops, k, b in (
        (mjflex.Stops(**limits, damping_ratio=0.5), k_derived, 2 * 0.5 * np.sqrt(k_derived * m)),
        (mjflex.Stops(**limits, time_constant=0.004, damping_ratio=0.8), m / (0.004 * 0.8) ** 2, 2 * m / 0.004),
        (mjflex.Stops(**limits, time_constant=0.01), m / 0.01**2, 2 * m / 0.01),
    ):
        spec = mujoco.MjSpec()
        spec.option.gravity = [0, 0, 0]
        body = spec.worldbody.add_body(name="rotor", pos=[0, 0, 0.1], mass=0.5, inertia=[2e-3, 2e-3, 1e-3],
                                       ipos=[0, 0, 0], iquat=[1, 0, 0, 0])  # fmt: skip
        body.explicitinertial = True
        body.add_freejoint()
        mjflex.add_flexure(spec, "hinge", "world", "rotor", pos=[0, 0.02, 0.1], K=[0.2, 0.2, 0.1, 1e3, 1e3, 1e3],
                           stops=stops)  # fmt: skip
        rec = mjflex.Flexures(spec.compile()).records[0]
        assert rec.stops.damping_ratio is None and rec.stops.time_constant is None  # the file holds numbers
        np.testing.assert_allclose(rec.stops.stiffness_for(rec.K)[[2, 3]], k, rtol=1e-12)
        np.testing.assert_allclose(rec.stops.damping_for(6)[[2, 3]], b, rtol=1e-12)
        assert not rec.stops.damping_for(6)[[0, 1, 4, 5]].any()


# ------------------------------------------------------------------ stored forms and bad input


def test_conversion_keeps_the_damping_and_the_rest_pose_exactly(tmp_path):
    rng = np.random.default_rng(9)
    qpos = _random_state(damped_spec().compile(), rng)
    spec = damped_spec(qpos, seed=9)
    expected = [(r.stops, r.rest) for r in mjflex.Flexures(spec.compile()).records]
    assert all(s and s.damping is not None for s, _ in expected[:3])
    for e, name in enumerate(("grounded", "joint")):  # as given to add_flexure, every digit
        assert expected[e][1] == tuple(tuple(float(v) for v in part) for part in REST[name])
    source, target, back = tmp_path / "plugin.xml", tmp_path / "record.xml", tmp_path / "plugin_again.xml"
    source.write_text(spec.to_xml())
    mjflex.convert_file(source, target, to="record")
    mjflex.convert_file(target, back, to="plugin")
    for path in (target, back):
        got = [(r.stops, r.rest) for r in mjflex.Flexures(mujoco.MjModel.from_xml_path(str(path))).records]
        assert got == expected
    assert "stop_damping" in back.read_text() and '"damping"' in target.read_text().replace("&quot;", '"')


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"upper": [0.1] * 6, "damping": -1.0}, r"stops.damping of every coordinate is -1; give a finite number >= 0"),
        ({"upper": [0.1] * 6, "damping": [0, np.nan, 0, 0, 0, 0]}, r"stops.damping of ry is nan; give a finite number"),
        ({"upper": [0.1] * 6, "damping": [1.0] * 5}, r"stops.damping has 5 numbers; give 1 \(every coordinate\) or 6"),
        ({"damping": 1.0}, "damping is given but there is no stop"),
        ({"upper": [0.1] * 6, "damping": 1.0, "damping_ratio": 1.0}, "give damping or damping_ratio, not both"),
        ({"upper": [0.1] * 6, "stiffness": 1.0, "time_constant": 0.01}, "give stiffness or time_constant"),
        ({"upper": [0.1] * 6, "time_constant": 0.0}, "time_constant must be finite, > 0"),
        ({"upper": [0.1] * 6, "damping_ratio": -0.5}, "damping_ratio must be finite, >= 0"),
    ],
)
def test_bad_stop_damping_is_refused_saying_what_to_fix(kwargs, match):
    with pytest.raises(ValueError, match=match):
        mjflex.Stops(**kwargs)


def test_a_ratio_is_not_stored_without_the_model():
    stops = mjflex.Stops(upper=[0.1] * 6, damping_ratio=1.0)
    with pytest.raises(ValueError, match="damping_ratio is turned into a damping where the model is known"):
        stops.to_dict()


@pytest.mark.parametrize(
    ("config", "match"),
    [
        ({"stop_upper": "0.1 inf inf inf inf inf", "stop_damping": "-1"}, "stop_damping of every coordinate is -1"),
        ({"stop_upper": "0.1 inf inf inf inf inf", "stop_damping": "0 0 0 -1 0 0"}, "stop_damping of x is -1"),
        ({"stop_upper": "0.1 inf inf inf inf inf", "stop_damping": "nan"}, "stop_damping of every coordinate is nan"),
        ({"stop_upper": "0.1 inf inf inf inf inf", "stop_damping": "1 2"}, "stop_damping has 2 numbers"),
        ({"stop_upper": "0.1 inf inf inf inf inf", "stop_damping": "x"}, "stop_damping has 'x', which is not a number"),
        ({"stop_damping": "3"}, "stop_damping is given but there is no stop"),
    ],
)
def test_a_plugin_instance_with_bad_stop_damping_fails_to_compile_naming_the_element(config, match):
    spec = _bodies(mujoco.MjSpec(), 1)
    handle = mjflex.add_flexure(spec, "disc", "world", "b0", pos=[0.1, 0, 0], K=[1.0] * 6)
    handle.plugin.config = {**dict(handle.plugin.config), **config}
    with pytest.raises(ValueError, match=rf"mjflex: flexure 'disc' \(plugin instance of mjflex.flexure\): {match}"):
        spec.compile()


@pytest.mark.parametrize(
    ("stops_json", "match"),
    [
        ('{"upper": [0.1, 0.1, 0.1, 0.1, 0.1, 0.1], "damping": -2}', "stops.damping of every coordinate is -2; give a"),
        ('{"upper": [0.1, 0.1, 0.1, 0.1, 0.1, 0.1], "damping": [1, 2]}', "stops.damping has 2 numbers; give 1"),
        ('{"damping": 1}', "stops.damping is given but there is no stop"),
    ],
)
def test_a_record_with_bad_stop_damping_is_a_model_error_naming_the_element(stops_json, match):
    spec = _bodies(mujoco.MjSpec(), 1)
    mjflex.add_flexure(spec, "disc", "world", "b0", pos=[0.1, 0, 0], K=[1.0] * 6, kind="record")
    text = spec.text("mjflex:disc")
    text.data = text.data[:-1] + f', "stops": {stops_json}}}'
    with pytest.raises(mjflex.ModelError, match=rf"flexure 'disc': .*{match}"):  # the C library's message
        mjflex.Flexures(spec.compile())


def test_a_planar_elements_stop_damping_lands_on_rz_x_y():
    """A planar element's damping on [theta, x, y] is the spatial element's on rz, x, y (K embedded), bit for bit:
    the same rows, and the same forces when both move alike."""
    planar = mjflex.Stops([-0.05, None, -0.002], [0.1, 0.001, None], stiffness=[40.0, 9e3, 1.2e4], damping=[0.5, 3, 4])
    spatial = mjflex.Stops([None, None, -0.05, None, -0.002, None], [None, None, 0.1, 0.001, None, None],
                           stiffness=[1.0, 1.0, 40.0, 9e3, 1.2e4, 1.0], damping=[7.0, 7.0, 0.5, 3, 4, 7.0])  # fmt: skip
    K3 = np.array([[0.4, 0.02, -0.01], [0.02, 90.0, 4.0], [-0.01, 4.0, 120.0]])
    spec = _bodies(mujoco.MjSpec(), 2)
    mjflex.add_flexure(spec, "planar", "world", "b0", pos=[0.1, 0, 0], K=K3, stops=planar)
    mjflex.add_flexure(spec, "spatial", "world", "b1", pos=[0.2, 0, 0], K=mjflex.mjcf.schema.embed_planar(K3),
                       stops=spatial)  # fmt: skip
    model = spec.compile()
    flex = mjflex.Flexures(model)
    rows = flex.element_table.elements
    for field in ("stop_lo", "stop_hi", "stop_k", "stop_b", "stop_damped"):
        assert np.array_equal(rows[field][0], rows[field][1]), field
    assert np.array_equal(rows["stop_b"][0], [0, 0, 0.5, 3, 4, 0])
    data = mujoco.MjData(model)
    for body in range(2):  # the same in-plane motion, past the theta and x stops, moving on into them
        data.qpos[7 * body : 7 * body + 3] += [0.003, -0.001, 0.0]
        data.qpos[7 * body + 3 : 7 * body + 7] = [np.cos(0.06), 0, 0, np.sin(0.06)]
        data.qvel[6 * body : 6 * body + 6] = [0.1, 0.02, 0, 0, 0, 0.5]
    mujoco.mj_forward(model, data)
    W, P = flex.wrenches(data), flex.dissipation_powers(data)
    assert np.array_equal(W[0], W[1]) and P[0] == P[1] and P[0] > 0

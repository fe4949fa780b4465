"""End stops of elements in MuJoCo models: the C engine's stop forces against finite differences of its own energy and
against the core, both element forms, planar elements, the linearization, the energy balance, and bad input.

The C engine's generalized forces are differentiated against its energy (``Flexures.potential_energy``) along each
tangent direction of the configuration (``mj_integratePos``: free joints on their rotation manifold), by Ridders'
extrapolated central differences; the poses keep every engaged coordinate well past its limit and every free one
well inside, so that no difference step crosses a limit (where the energy's second derivative jumps).
"""

import itertools

import mujoco
import numpy as np
import pytest

import mjflex
from tests.helpers import ridders
from tests.plugin_models import as_plugins, as_records, planar_spec

pytestmark = [pytest.mark.usefixtures("clean_callback")]
INF = np.inf
K_BUSH = np.diag([0.4, 0.5, 0.3, 2e3, 3e3, 1e3])  # a bushing: N m/rad, N/m


def _bodies(spec, n=2):
    spec.option.gravity = [0, 0, 0]
    for i in range(n):
        body = spec.worldbody.add_body(name=f"b{i}", pos=[0.1 * (i + 1), 0.0, 0.0], mass=0.2 + 0.1 * i,
                                       inertia=[2e-4, 3e-4, 4e-4], ipos=[0.01, 0, 0], iquat=[1, 0, 0, 0])  # fmt: skip
        body.explicitinertial = True
        body.add_freejoint()
    return spec


def _random_state(model, rng, angle=0.4, shift=0.005):
    qpos = model.qpos0.copy()
    for j in range(model.njnt):
        a = model.jnt_qposadr[j]
        qpos[a : a + 3] += shift * rng.normal(size=3)
        turn = np.empty(4)
        mujoco.mju_axisAngle2Quat(turn, rng.normal(size=3), rng.uniform(0.3, 1.0) * angle)
        q = np.empty(4)
        mujoco.mju_mulQuat(q, turn, qpos[a + 3 : a + 7])
        qpos[a + 3 : a + 7] = q
    return qpos


LAYOUT = (  # (element, body a, body b, method, frame quat)
    ("grounded", "world", "b0", "twist", [0.9, 0.1, -0.3, 0.2]),
    ("joint", "b0", "b1", "dualquat", [0.8, 0.0, 0.6, 0.0]),
    ("pure", "world", "b1", "twist", [1, 0, 0, 0]),
)


def stops_spec(qpos=None, *, kind="plugin", seed=0, margin=0.3, B=None):
    """Two free bodies and three elements with end stops: a twist element grounding b0 (derived stiffness), a
    dual-quaternion one between b0 and b1 (stated stiffness, one number) and a twist one with K = 0, stops only
    (stated stiffness per coordinate). With ``qpos``, each coordinate's stop is placed (at random: past an upper
    limit, past a lower one, or a two-sided range around it) ``margin`` of its size or more away from its value
    there."""
    spec = _bodies(mujoco.MjSpec())
    rng = np.random.default_rng(seed)
    zs = None
    if qpos is not None:
        plain = stops_spec(kind=kind)
        model = plain.compile()
        flex, data = mjflex.Flexures(model), mujoco.MjData(model)
        data.qpos[:] = qpos
        mujoco.mj_kinematics(model, data)
        zs = _stop_coordinates(flex, data)
    for e, (name, a, b, method, quat) in enumerate(LAYOUT):
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
            stiffness = (None, 5.0 * K_BUSH[0, 0], 10 * np.diagonal(K_BUSH))[e]
            stops = mjflex.Stops(list(lower), list(upper), stiffness)
        K = 0 * K_BUSH if name == "pure" else K_BUSH
        mjflex.add_flexure(spec, name, a, b, pos=[0.15, 0.01, 0.0], quat=quat, K=K, B=B, method=method, stops=stops,
                           kind=kind)  # fmt: skip
    return spec


def _stop_coordinates(flex, data):
    """The stop coordinates of each element from the core (site poses, rest offset removed)."""
    out = []
    for e in range(len(flex)):
        row = flex.element_table.elements[e]
        sa, sb = flex.site_ids[e]
        R_a, p_a = data.site_xmat[sa].reshape(3, 3), data.site_xpos[sa]
        R_b = data.site_xmat[sb].reshape(3, 3) @ row["R0"].reshape(3, 3).T
        p_b = data.site_xpos[sb] - R_b @ row["p0"]
        out.append(mjflex.stop_coordinates(R_a, p_a, R_b, p_b))
    out = np.array(out)
    assert np.array_equal(flex.stop_coordinates(data), out)  # the provider's query: the same
    return out


def _gradient(model, flex, qpos, h0):
    """dU/dq along each tangent direction of qpos (Ridders), U the elements' energy from the C engine."""
    data = mujoco.MjData(model)
    g = np.zeros(model.nv)
    for i in range(model.nv):

        def energy(h, i=i):
            dq = np.zeros(model.nv)
            dq[i] = h
            data.qpos[:] = qpos
            mujoco.mj_integratePos(model, data.qpos, dq, 1.0)
            mujoco.mj_kinematics(model, data)
            return flex.potential_energy(data), h

        g[i] = ridders(energy, h0)[0]
    return g


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("kind", ["plugin", "record"])
def test_c_stop_forces_are_minus_the_gradient_of_the_c_energy(kind, seed):
    """The engine's generalized forces of elements whose stops are engaged (most coordinates of the three) against
    finite differences of the engine's energy: elastic + stops; the pure-stop element alone carries only stops."""
    rng = np.random.default_rng(seed)
    qpos = _random_state(stops_spec(kind=kind).compile(), rng)
    model = stops_spec(qpos, kind=kind, seed=seed).compile()
    flex = mjflex.Flexures(model)
    data = mujoco.MjData(model)
    data.qpos[:] = qpos
    mujoco.mj_forward(model, data)
    engaged = [rec.stops is not None for rec in flex.records]
    assert all(engaged)
    energies = flex.potential_energies(data)
    assert energies[2] > 0  # the pure-stop element stores energy only through its engaged stops
    f = flex.generalized_forces(data)
    if kind == "plugin":
        assert np.array_equal(data.qfrc_passive, f)  # the model's own forces, through the plugin
    g = _gradient(model, flex, qpos, 1e-5)
    err = np.linalg.norm(f + g) / np.linalg.norm(f)
    assert err <= 1e-7, (err, f, -g)


def test_stop_energy_and_wrench_of_the_engine_are_the_cores():
    """Per element: the engine's energy and wrench minus the element's own (core) are the core's stop energy and
    wrench, for both methods and stops on every coordinate."""
    rng = np.random.default_rng(7)
    qpos = _random_state(stops_spec().compile(), rng)
    model = stops_spec(qpos, seed=7).compile()
    flex, data = mjflex.Flexures(model), mujoco.MjData(model)
    data.qpos[:] = qpos
    mujoco.mj_forward(model, data)
    U, W = flex.potential_energies(data), flex.wrenches(data)
    for e, rec in enumerate(flex.records):
        row = flex.element_table.elements[e]
        sa, sb = flex.site_ids[e]
        R_a, p_a = data.site_xmat[sa].reshape(3, 3), data.site_xpos[sa]
        R_b = data.site_xmat[sb].reshape(3, 3) @ row["R0"].reshape(3, 3).T
        p_b = data.site_xpos[sb] - R_b @ row["p0"]
        limits = (*rec.stops.limits_for(6), rec.stops.stiffness_for(rec.K))
        Us = mjflex.stop_potential(R_a, p_a, R_b, p_b, *limits)
        Ws = mjflex.stop_wrench_on_b(R_a, p_a, R_b, p_b, *limits)
        U0 = mjflex.potential(R_a, p_a, R_b, p_b, rec.K, method=rec.method)
        W0 = mjflex.wrench_on_b(R_a, p_a, R_b, p_b, rec.K, method=rec.method)
        assert Us > 0 and np.abs(Ws).max() > 0
        assert np.isclose(U[e], U0 + Us, rtol=1e-12), (e, U[e], U0 + Us)
        assert np.allclose(W[e], W0 + Ws, rtol=1e-11, atol=1e-12 * np.abs(W0 + Ws).max())


def test_stops_inside_their_range_change_no_bit():
    """An element whose stops are not engaged gives exactly the forces and energy of the element without stops."""
    rng = np.random.default_rng(2)
    qpos = _random_state(stops_spec().compile(), rng, angle=0.05, shift=1e-4)
    plain = stops_spec().compile()
    spec = _bodies(mujoco.MjSpec())
    for name, a, b, method, quat in LAYOUT:
        K = 0 * K_BUSH if name == "pure" else K_BUSH
        far = mjflex.Stops([-3.0] * 3 + [-1.0] * 3, [3.0] * 3 + [1.0] * 3, stiffness=1e3)
        mjflex.add_flexure(spec, name, a, b, pos=[0.15, 0.01, 0.0], quat=quat, K=K, method=method, stops=far)
    free = spec.compile()
    out = []
    for model in (plain, free):
        flex, data = mjflex.Flexures(model), mujoco.MjData(model)
        data.qpos[:] = qpos
        mujoco.mj_forward(model, data)
        out.append((data.qfrc_passive.copy(), flex.potential_energies(data), flex.wrenches(data)))
    for a, b in zip(*out, strict=True):
        assert np.array_equal(a, b)
    assert np.abs(out[0][0]).max() > 0


def test_record_and_plugin_forms_move_bit_identically_into_their_stops():
    """The text record (mjcb_passive dispatcher) and the plugin instance of the same elements with stops: the same C
    loop on the same table, so the same trajectories, bit for bit; and the plugin's init lays out the stops as
    Python does."""
    rng = np.random.default_rng(5)
    qpos = _random_state(stops_spec().compile(), rng)
    spec = stops_spec(qpos, kind="record", seed=5, B=1e-3 * K_BUSH)
    record, plugin = as_records(spec).compile(), as_plugins(spec).compile()
    flex = mjflex.Flexures(record)
    assert flex.kinds == ("record",) * 3 and mjflex.Flexures(plugin).kinds == ("plugin",) * 3
    runs = []
    for model, provider in ((record, flex), (plugin, None)):
        model.opt.timestep = 2e-4
        data = mujoco.MjData(model)
        data.qpos[:] = qpos
        with provider or mjflex.Flexures(model):
            mujoco.mj_step(model, data, nstep=200)
        runs.append(np.r_[data.qpos, data.qvel])
    assert np.array_equal(runs[0], runs[1]) and np.isfinite(runs[0]).all()
    pflex = mjflex.Flexures(plugin)
    for e in range(len(pflex)):  # the plugin's row is the record's (one reader in C, mjfx_read_element)
        row = flex.element_table.elements[e : e + 1]
        mine = pflex.element_table.elements[e : e + 1]
        for field in ("stops", "stop_lo", "stop_hi", "stop_k", "K"):
            assert row[field].tobytes() == mine[field].tobytes(), (e, field)
    assert pflex.element_table.elements["stops"][:3].all()


# ------------------------------------------------------------------ planar elements


@pytest.mark.parametrize("method", ["twist", "dualquat"])
@pytest.mark.parametrize("kind", ["plugin", "record"])
def test_planar_stops_act_on_theta_x_y_and_are_minus_the_gradient(kind, method):
    stops = mjflex.Stops(lower=[-0.05, None, -0.002], upper=[0.1, 0.001, None])  # derived: 100 x K's diagonal
    model = planar_spec(kind, method, stops).compile()  # qvel = 0 below: its damping plays no part
    flex, data = mjflex.Flexures(model), mujoco.MjData(model)
    assert flex.records[0].planar and flex.records[0].stops == stops
    qpos = np.array([0.001, -0.002, 0.05, 0.004, -0.008, -0.15])  # theta -0.2, x and y past their stops
    data.qpos[:] = qpos
    mujoco.mj_forward(model, data)
    f = flex.generalized_forces(data)
    err = np.linalg.norm(f + _gradient(model, flex, qpos, 1e-5)) / np.linalg.norm(f)
    assert err <= 1e-7, err
    # the engine's energy: the element's plus the core's planar stops, on [theta, x, y] of frame b in frame a
    sa, sb = flex.site_ids[0]
    theta = [np.arctan2(data.site_xmat[s][3], data.site_xmat[s][0]) for s in (sa, sb)]
    p = [data.site_xpos[s][:2] for s in (sa, sb)]
    rec = flex.records[0]
    Us = mjflex.planar_stop_potential(theta[0], p[0], theta[1], p[1], *stops.limits_for(3), stops.stiffness_for(rec.K))
    U0 = mjflex.planar_potential(theta[0], p[0], theta[1], p[1], rec.K, method=method)
    z = mjflex.stop_coordinates(data.site_xmat[sa].reshape(3, 3), data.site_xpos[sa],
                                data.site_xmat[sb].reshape(3, 3), data.site_xpos[sb])[[2, 3, 4]]  # fmt: skip
    assert z[0] < -0.05 and z[1] > 0.001 and z[2] < -0.002  # all three engaged
    assert np.isclose(flex.potential_energy(data), U0 + Us, rtol=1e-11) and Us > 10 * U0


def test_planar_stops_are_the_same_bits_as_the_spatial_stops_on_rz_x_y():
    """The element rows the C library lays out (mjfx_read_element): a planar element's stops on [theta, x, y] land on
    rz, x, y of the spatial element with K embedded, bit for bit."""
    planar = mjflex.Stops([-0.05, None, -0.002], [0.1, 0.001, None], stiffness=[40.0, 9e3, 1.2e4])
    spatial = mjflex.Stops([None, None, -0.05, None, -0.002, None], [None, None, 0.1, 0.001, None, None],
                           stiffness=[1.0, 1.0, 40.0, 9e3, 1.2e4, 1.0])  # fmt: skip
    K3 = np.array([[0.4, 0.02, -0.01], [0.02, 90.0, 4.0], [-0.01, 4.0, 120.0]])
    spec = _bodies(mujoco.MjSpec(), 2)
    mjflex.add_flexure(spec, "planar", "world", "b0", pos=[0.1, 0, 0], K=K3, stops=planar)
    mjflex.add_flexure(spec, "spatial", "world", "b1", pos=[0.2, 0, 0], K=mjflex.mjcf.schema.embed_planar(K3),
                       stops=spatial)  # fmt: skip
    rows = mjflex.Flexures(spec.compile()).element_table.elements
    for field in ("stop_lo", "stop_hi", "stop_k"):
        assert np.array_equal(rows[field][0], rows[field][1]), field


# ------------------------------------------------------------------ linearization and the time step


def rotor_spec(integrator="euler", h=1e-3, B=None, stops=True, kind="plugin"):
    """A free rotor on a grounded element at its centre of mass; a stop at rz <= 0.1 rad (derived stiffness)."""
    spec = mujoco.MjSpec()
    spec.option.gravity = [0, 0, 0]
    spec.option.integrator = getattr(mujoco.mjtIntegrator, f"mjINT_{integrator.upper()}")
    spec.option.timestep = h
    spec.option.enableflags |= mujoco.mjtEnableBit.mjENBL_ENERGY
    body = spec.worldbody.add_body(name="rotor", pos=[0, 0, 0.1], mass=0.5, inertia=[2e-3, 2e-3, 1e-3],
                                   ipos=[0, 0, 0], iquat=[1, 0, 0, 0])  # fmt: skip
    body.explicitinertial = True
    body.add_freejoint()
    limits = mjflex.Stops(upper=[None, None, 0.1, None, None, None]) if stops else None
    mjflex.add_flexure(spec, "hinge", "world", "rotor", pos=[0, 0, 0.1], K=[0.2, 0.2, 0.1, 1e3, 1e3, 1e3], B=B,
                       stops=limits, kind=kind)  # fmt: skip
    return spec


def _turned(model, angle):
    qpos = model.qpos0.copy()
    qpos[3:7] = [np.cos(angle / 2), 0, 0, np.sin(angle / 2)]
    return qpos


def test_normal_modes_see_an_engaged_stop():
    """At a pose past the stop the rotor's mode about z has the element's and the stop's stiffness, 101 K: its
    frequency is sqrt(101) times the free one; inside the range it is the element's alone."""
    model = rotor_spec().compile()
    flex = mjflex.Flexures(model)
    free = np.sqrt(0.1 / 1e-3) / (2 * np.pi)  # rz: K 0.1 N m/rad, inertia 1e-3 kg m^2
    inside, _ = mjflex.normal_modes(model, flex, qpos=_turned(model, 0.05))
    engaged, _ = mjflex.normal_modes(model, flex, qpos=_turned(model, 0.15))
    assert np.isclose(inside, free, rtol=1e-5).sum() >= 1 and not np.isclose(inside, np.sqrt(101) * free).any()
    assert np.isclose(engaged, np.sqrt(101) * free, rtol=1e-5).sum() == 1
    assert engaged.max() > 0.99 * np.sqrt(101) * free  # the stiffest mode now: the time step must follow it


def test_springs_disabled_switch_the_stops_off_with_the_elastic_part():
    model = rotor_spec().compile()
    flex, data = mjflex.Flexures(model), mujoco.MjData(model)
    data.qpos[:] = _turned(model, 0.15)
    mujoco.mj_forward(model, data)
    assert data.qfrc_passive[5] < -0.1 * 0.15 - 0.5 * 10 * 0.05  # element and stop push back
    model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_SPRING
    mujoco.mj_forward(model, data)
    assert not data.qfrc_passive.any() and flex.potential_energy(data) == 0.0


# ------------------------------------------------------------------ the energy balance


def _bounce(integrator, h, B=None, T=0.5):
    """The rotor spun at 3 rad/s about z into its stop (free, it would swing to 0.3 rad): the largest |E + W - E0|
    over the run (E kinetic + the elements' potential, W the energy the element dissipated, by the trapezoidal rule
    on the step ends), W, and the largest rotation."""
    model = rotor_spec(integrator, h, B).compile()
    flex, data = mjflex.Flexures(model), mujoco.MjData(model)
    data.qvel[5] = 3.0
    mujoco.mj_forward(model, data)
    E0 = data.energy[1] + flex.potential_energy(data)
    power, dissipated, error, top = flex.dissipation_power(data), 0.0, 0.0, 0.0
    for _ in range(round(T / h)):
        mujoco.mj_step(model, data)
        mujoco.mj_forward(model, data)
        now = flex.dissipation_power(data)
        dissipated += 0.5 * h * (power + now)
        power = now
        error = max(error, abs(data.energy[1] + flex.potential_energy(data) + dissipated - E0))
        top = max(top, flex.displacements(data)[0, 2])
    return error, dissipated, top, E0


STEPS = (1e-3, 5e-4, 2.5e-4, 1.25e-4)


def test_a_run_into_a_stop_conserves_energy_to_the_integrators_order():
    """Without damping the energy (kinetic + element + stop) is conserved: Euler's error halves with the step (first
    order); RK4's shrinks at least as h^2 (the stop's stiffness jumps at the limit, which costs RK4 its fourth order in
    the steps where the stop engages). The swing ends where the energy says: K z^2 + 100 K (z - 0.1)^2 = K 0.3^2."""
    top_expected = (20 + np.sqrt(400 - 4 * 101 * 0.91)) / 202  # 101 z^2 - 20 z + 0.91 = 0
    euler = [_bounce("euler", h) for h in STEPS[:3]]
    rk4 = [_bounce("rk4", h) for h in STEPS]
    E0 = euler[0][3]
    assert np.isclose(E0, 0.5 * 1e-3 * 3.0**2)
    for errors in (euler, rk4):
        assert abs(errors[-1][2] - top_expected) < 2e-3 * top_expected  # it did reach and bounce off the stop
    ratios = [a[0] / b[0] for a, b in itertools.pairwise(euler)]
    assert all(1.8 < r < 2.3 for r in ratios), ratios
    assert euler[0][0] < 0.06 * E0
    order = np.polyfit(np.log(STEPS), np.log([r[0] for r in rk4]), 1)[0]
    assert order >= 2.0, order
    assert rk4[0][0] < 1e-3 * E0


def test_with_damping_the_dissipated_energy_is_accounted_for():
    """With damping on the rotation about z, E + W stays E0: RK4 to 1e-5 of W (the trapezoidal rule on the power is
    second order), Euler's mismatch first order in the step."""
    B = [0, 0, 2e-3, 0, 0, 0]
    rk4 = _bounce("rk4", 2.5e-4, B)
    assert rk4[1] > 0.5 * rk4[3]  # most of the energy was dissipated
    assert rk4[0] < 1e-5 * rk4[1]
    euler = [_bounce("euler", h, B) for h in STEPS[:3]]
    assert euler[-1][0] < 0.02 * euler[-1][1]  # the largest mismatch over the run: Euler oscillates by O(h)
    assert all(1.8 < a[0] / b[0] < 2.3 for a, b in itertools.pairwise(euler))


# ------------------------------------------------------------------ the API, the stored forms, bad input


def test_stops_keep_what_was_given_and_derive_the_rest():
    stops = mjflex.Stops(lower=[-0.1, None, -INF, None, None, -0.002], upper=None)
    assert stops.lower == (-0.1, -INF, -INF, -INF, -INF, -0.002) and stops.upper is None and stops.size == 6
    assert stops and not mjflex.Stops() and not mjflex.Stops(lower=[None] * 6)  # no limit: no stops
    K = np.diag([2.0, 0.0, 1.0, 1e4, 0.0, 3e4])  # zero stiffness where no stop asks for one: fine
    assert np.array_equal(stops.stiffness_for(K), [200.0, 0, 0, 0, 0, 3e6])
    assert np.array_equal(mjflex.Stops(upper=[0.1, 0.2, 0.3], stiffness=5).stiffness_for(np.eye(3)), [5.0, 5.0, 5.0])
    assert mjflex.Stops.from_dict(stops.to_dict()) == stops
    assert stops.to_dict() == {"lower": [-0.1, None, None, None, None, -0.002]}
    assert mjflex.Stops.from_config(stops.config()) == stops
    assert stops.config() == {"stop_lower": "-0.1 -inf -inf -inf -inf -0.002"}
    given = mjflex.Stops([-0.1] * 3, [0.2] * 3, stiffness=[1.0, 2.0, 3.0])
    assert mjflex.Stops.from_dict(given.to_dict()) == given == mjflex.Stops.from_config(given.config())


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"lower": [0.2] + [None] * 5, "upper": [0.1] + [None] * 5}, r"lower of rx \(0.2\) is above its stops.upper"),
        ({"upper": [np.nan] * 6}, "upper of rx is NaN"),
        ({"lower": [INF] * 6}, r"lower of rx is inf, a stop that would push at every pose"),
        ({"upper": [None, None, 20.0, None, None, None]}, r"upper of rz is 20 rad, beyond pi.*not degrees"),
        ({"upper": [None, None, 0.1]}, None),  # planar: fine
        ({"upper": [0.1] * 4}, r"stops.upper has 4 limits: give one per coordinate, 6"),
        ({"lower": [-0.1] * 6, "upper": [0.1] * 3}, "stops.lower has 6 limits but stops.upper 3"),
        ({"upper": [0.1] * 6, "stiffness": -1.0}, ">= 0"),
        ({"upper": [0.1] * 6, "stiffness": [1.0] * 5}, "one per coordinate"),
        ({"upper": [0.1] * 6, "stiffness": np.inf}, "finite"),
        ({"stiffness": 3.0}, "stiffness is given but there is no stop"),
        ({"upper": "0.1 0.1"}, "must be a list"),
        ({"upper": [True] * 6}, "boolean"),
    ],
)
def test_bad_stops_are_refused_saying_what_to_fix(kwargs, match):
    if match is None:
        mjflex.Stops(**kwargs)
        return
    with pytest.raises(ValueError, match=match):
        mjflex.Stops(**kwargs)


def test_add_flexure_checks_the_stops_against_the_element_before_changing_the_spec():
    spec = _bodies(mujoco.MjSpec(), 1)
    before = spec.to_xml()
    with pytest.raises(ValueError, match=r"flexure 'x': stops.upper has 6 limits but the element is planar"):
        mjflex.add_flexure(
            spec, "x", "world", "b0", pos=[0.1, 0, 0], K=[1.0, 1e3, 1e3], stops=mjflex.Stops(upper=[0.1] * 6)
        )
    with pytest.raises(ValueError, match=r"flexure 'x': the stop on ry needs a stiffness: K\[1, 1\] is 0"):
        mjflex.add_flexure(spec, "x", "world", "b0", pos=[0.1, 0, 0], K=[1.0, 0, 1.0, 1e3, 1e3, 1e3],
                           stops=mjflex.Stops(upper=[0.1] * 6))  # fmt: skip
    with pytest.raises(TypeError, match=r"stops must be a mjflex.Stops"):
        mjflex.add_flexure(spec, "x", "world", "b0", pos=[0.1, 0, 0], K=[1.0] * 6, stops={"upper": [0.1] * 6})
    assert spec.to_xml() == before
    mjflex.add_flexure(spec, "x", "world", "b0", pos=[0.1, 0, 0], K=[1.0, 0, 1.0, 1e3, 1e3, 1e3],
                       stops=mjflex.Stops(upper=[0.1] * 6, stiffness=10.0))  # fmt: skip
    assert mjflex.Flexures(spec.compile()).records[0].stops.stiffness == 10.0


def _record_model(stops_json):
    spec = _bodies(mujoco.MjSpec(), 1)
    mjflex.add_flexure(spec, "disc", "world", "b0", pos=[0.1, 0, 0], K=[1.0] * 6, kind="record")
    text = spec.text("mjflex:disc")
    text.data = text.data[:-1] + f', "stops": {stops_json}}}'
    return spec.compile()


@pytest.mark.parametrize(
    ("stops_json", "match"),
    [
        ('{"lower": [0.1, null, null, null, null, null], "upper": [0.0, null, null, null, null, null]}', "above its"),
        ('{"upper": [0.1, 0.1, 0.1]}', "stops.upper has 3 limits but the element is spatial"),
        ('{"upper": [0.1, 0.1, 0.1, 0.1, 0.1, 0.1], "stiffness": -2}', ">= 0"),
        ('{"upper": [0.1, 0.1, 0.1, 0.1, 0.1, 0.1], "range": 1}', r"unknown key\(s\) \['range'\]"),
        ('{"upper": [90, null, null, null, null, null]}', "beyond pi"),
        ("[0.1]", '"stops" must be an object'),
    ],
)
def test_a_record_with_bad_stops_is_a_model_error_naming_the_element(stops_json, match):
    model = _record_model(stops_json)
    with pytest.raises(mjflex.ModelError, match=rf"flexure 'disc': .*{match}"):
        mjflex.Flexures(model)


@pytest.mark.parametrize(
    ("config", "match"),
    [
        (
            {"stop_lower": "0.1 0 0 0 0 0", "stop_upper": "0 0 0 0 0 0"},
            r"stop_lower of rx \(0.1\) is above its stop_upper",
        ),
        ({"stop_upper": "0.1 0.1 0.1"}, "stop_upper has 3 limits but the element is spatial: give 6"),
        ({"stop_upper": "nan inf inf inf inf inf"}, "stop_upper of rx is NaN"),
        ({"stop_upper": "0.1 inf inf inf inf inf", "stop_stiffness": "-1"}, "stop_stiffness of every coordinate is -1"),
        ({"stop_upper": "0.1 inf inf inf inf inf", "stop_stiffness": "1 2"}, "stop_stiffness has 2 numbers"),
        ({"stop_stiffness": "3"}, "stop_stiffness is given but there is no stop"),
        ({"stop_lower": "-200 -inf -inf -inf -inf -inf"}, "stop_lower of rx is -200 rad, beyond pi"),
        ({"stop_lower": "inf -inf -inf -inf -inf -inf"}, "stop_lower of rx is inf"),
        ({"stop_upper": "0.1 x 0 0 0 0"}, "stop_upper has 'x', which is not a number"),
        ({"stop_upper": "inf 0.1 inf inf inf inf"}, r"the stop on ry needs a stiffness: K\[1, 1\] is 0"),
    ],
)
def test_a_plugin_instance_with_bad_stops_fails_to_compile_naming_the_element(config, match):
    spec = _bodies(mujoco.MjSpec(), 1)
    handle = mjflex.add_flexure(spec, "disc", "world", "b0", pos=[0.1, 0, 0], K=[1.0, 0.0, 1.0, 1e3, 1e3, 1e3])
    handle.plugin.config = {**dict(handle.plugin.config), **config}
    with pytest.raises(ValueError, match=rf"mjflex: flexure 'disc' \(plugin instance of mjflex.flexure\): {match}"):
        spec.compile()


def test_conversion_between_the_forms_keeps_the_stops_exactly(tmp_path):
    rng = np.random.default_rng(9)
    qpos = _random_state(stops_spec().compile(), rng)
    spec = stops_spec(qpos, seed=9)
    expected = [r.stops for r in mjflex.Flexures(spec.compile()).records]
    assert all(expected)
    records = as_records(spec)
    again = as_plugins(records)
    for s in (records, again):
        assert [r.stops for r in mjflex.Flexures(s.compile()).records] == expected
    assert [dict(p.config) for p in again.plugins] == [dict(p.config) for p in spec.plugins]
    source, target, back = tmp_path / "plugin.xml", tmp_path / "record.xml", tmp_path / "plugin_again.xml"
    source.write_text(spec.to_xml())
    mjflex.convert_file(source, target, to="record")
    mjflex.convert_file(target, back, to="plugin")
    for path in (target, back):
        assert [r.stops for r in mjflex.Flexures(mujoco.MjModel.from_xml_path(str(path))).records] == expected


def test_variants_say_what_becomes_of_the_stops():
    """The MuJoCo-native variants have no range for an element's stops: their reports say so; reduce keeps the stops
    of an element it keeps whole."""
    spec = _bodies(mujoco.MjSpec(), 1)
    mjflex.add_flexure(spec, "disc", "world", "b0", pos=[0.1, 0, 0], K=np.diagonal(K_BUSH),
                       stops=mjflex.Stops(upper=[0.1] * 6))  # fmt: skip
    for build in (mjflex.bushing_variant, mjflex.weld_variant, mjflex.pseudo_rigid_body_variant):
        assert "disc: its end stops are not represented: the replacement has no range" in build(spec).report
    kept = mjflex.reduce(spec, keep_below_hz=1e9)
    assert "disc: kept as an element" in kept.report and "disc: its end stops are kept if" in kept.report
    assert mjflex.Flexures(kept.model).records[0].stops == mjflex.Stops(upper=[0.1] * 6)

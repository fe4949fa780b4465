"""End stops of elements in MuJoCo models: the C engine's stop forces against finite differences of its own energy and
against the core, both element forms, planar elements, the linearization, the energy balance, and bad input.

The C engine's generalized forces are differentiated against its energy (``Flexures.potential_energy``) along each
tangent direction of the configuration (``mj_integratePos``: free joints on their rotation manifold), by Ridders'
extrapolated central differences; the poses keep every engaged coordinate well past its limit and every free one
well inside, so that no difference step crosses a limit (where the energy's second derivative jumps).
"""

import mujoco
import numpy as np
import pytest

import mjflex
from mjflex.mj import _native
from tests.helpers import ridders
from tests.plugin_models import as_plugins, as_records

pytestmark = pytest.mark.usefixtures("clean_callback")
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
        row = flex._elements[e]
        sa, sb = flex.site_ids[e]
        R_a, p_a = data.site_xmat[sa].reshape(3, 3), data.site_xpos[sa]
        R_b = data.site_xmat[sb].reshape(3, 3) @ row["R0"].reshape(3, 3).T
        p_b = data.site_xpos[sb] - R_b @ row["p0"]
        out.append(mjflex.stop_coordinates(R_a, p_a, R_b, p_b))
    return np.array(out)


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
        row = flex._elements[e]
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
    pflex, data = mjflex.Flexures(plugin), mujoco.MjData(plugin)
    native = _native.lib()
    for e, instance in enumerate(pflex._tables.instances):
        row = np.zeros(1, dtype=_native.ELEMENT_DTYPE)
        assert native.mjfx_plugin_element(plugin._address, data._address, instance, row.ctypes.data) == 0
        mine = pflex._elements[e : e + 1]
        for field in ("stops", "stop_lo", "stop_hi", "stop_k", "K"):
            assert row[field].tobytes() == mine[field].tobytes(), (e, field)
    assert pflex._elements["stops"][:3].all()

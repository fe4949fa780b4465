"""End stops of elements on MuJoCo Warp (``mjflex.warp``), on Warp's CPU device, against the C engine in float64.

The bounds are tests/warp_bounds.py's, derived from float32 rounding (tests/test_warp.py states the
derivation), with the stops' own terms (warp_bounds' module docstring): nothing here is tuned.
"""

import copy

import mujoco
import mujoco_warp as mjw
import numpy as np
import pytest
import warp as wp

import mjflex
import mjflex.warp as mw
from mjflex.mjcf import elements
from tests import warp_bounds as wb
from tests.test_warp import TWO_BODY, _state_data, _warp_queries, _worlds
from tests.warp_models import INF, STOPS, N, features_model, features_xml, random_state


@pytest.fixture(scope="module", autouse=True)
def cpu():
    """Every test of the module on Warp's CPU device."""
    with wp.ScopedDevice("cpu"):
        yield


@pytest.fixture(scope="module")
def stopped():
    """Every element feature, with end stops (tests/warp_models.STOPS), as text records."""
    return features_model("record", stops=True)


#: The queries compared with the C engine.
KEYS = ("wrench", "qfrc", "energy", "power", "twist", "stops")


def _engaged(flex, data):
    """``(n, 6)`` bool: the coordinates beyond a limit."""
    el = flex.element_table.elements[: len(flex)]
    z = flex.stop_coordinates(data)
    return (z < el["stop_lo"]) | (z > el["stop_hi"])


def _compare(got, world, model, flex, data, keys, arith=wb.U32):
    """Largest error / bound of each query of ``world``; fails on the first error beyond its bound."""
    ref, bound = wb.c_queries(flex, data), wb.bounds(model, data, flex, arith)
    worst = {}
    for key in keys:
        err = np.abs(got[key][world] - ref[key])
        ratio = float(np.max(err / np.maximum(bound[key], 1e-300), initial=0.0))
        assert (err <= bound[key]).all(), (key, world, ratio)
        worst[key] = ratio
    return ref, worst


@pytest.mark.parametrize("precision", ["float32", "float64"])
def test_end_stops_match_the_c_engine_on_random_states(stopped, precision):
    """Forces, generalized forces, energies, twists and stop coordinates of elements with end stops (both methods,
    planar, dof chains, explicit and derived stiffness, one- and two-sided limits, beside elements without stops)
    on 12 random states, relative rotations up to 2.5 rad: every element with stops is engaged in some states and
    free in others. Within the derived bound; and the stops matter: without them (the C engine on the same elements
    without stops), exactly the elements with stops that are enabled are outside the bound in some state."""
    rng = np.random.default_rng(11)
    states = [random_state(stopped, rng, angle=2.5) for _ in range(12)]
    m = mw.put_model(stopped, precision=precision)
    got = _warp_queries(m, _worlds(stopped, m, states))
    flex = mjflex.Flexures(stopped)
    free = mjflex.Flexures(features_model("record"))  # the same elements without stops
    arith = wb.U64 if precision == "float64" else wb.U32
    engaged, worst, seen = [], {}, np.zeros(len(flex), bool)
    for i, (qpos, qvel) in enumerate(states):
        data = _state_data(stopped, qpos, qvel)
        ref, ratios = _compare(got, i, stopped, flex, data, KEYS, arith)
        worst = {k: max(worst.get(k, 0.0), v) for k, v in ratios.items()}
        engaged.append(_engaged(flex, data).any(axis=1))
        bound = wb.bounds(stopped, data, flex, arith)["wrench"]
        seen |= (np.abs(free.wrenches(data) - ref["wrench"]) > bound).any(axis=1)
    engaged = np.array(engaged)
    has = flex.element_table.elements["stops"][: len(flex)].astype(bool)
    assert has.sum() == len(STOPS) and (engaged[:, has].any(0) & ~engaged[:, has].all(0)).all(), engaged.T
    np.testing.assert_array_equal(seen, has & flex.enabled)
    print(f"largest error / bound ({precision}):", {k: f"{v:.2g}" for k, v in worst.items()})


def test_both_forms_with_stops_give_the_same_forces(stopped):
    """Stops written as a record's "stops" and as plugin attributes: the same kernel inputs, the same bits."""
    plugin = features_model("plugin", stops=True)
    rng = np.random.default_rng(4)
    states = [random_state(stopped, rng, angle=2.5) for _ in range(3)]
    forms = []
    for model in (stopped, plugin):
        m = mw.put_model(model)
        forms.append(_warp_queries(m, _worlds(model, m, states)))
    for key in forms[0]:
        np.testing.assert_array_equal(forms[0][key], forms[1][key], err_msg=key)


def test_spring_disable_flag_switches_the_stops_off(stopped):
    """As in the C engine, the stops are part of the elastic force: MuJoCo's spring disable flag removes them."""
    model = copy.copy(stopped)
    model.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_SPRING)
    state = random_state(model, np.random.default_rng(5), angle=2.5)
    m = mw.put_model(model)
    got = _warp_queries(m, _worlds(model, m, [state]))
    flex = mjflex.Flexures(model)
    data = _state_data(model, *state)
    assert _engaged(flex, data).any()
    _compare(got, 0, model, flex, data, ("wrench", "qfrc", "energy"))
    assert not got["energy"].any()


# ------------------------------------------------------------------------ per-world stops


def _world_stops(forces, K):
    """The four worlds' stops of the per-world test, and the same as tests/warp_models.STOPS dicts."""
    n = len(forces)
    p = forces.parameters()
    lower, upper = np.repeat(p["stop_lower"], 4, axis=0), np.repeat(p["stop_upper"], 4, axis=0)
    e0, e5, planar = forces.index("e0"), forces.index("e5"), forces.index("planar")
    given = {w: dict(STOPS) for w in range(4)}
    # world 1: K three times stiffer; derived stiffness follows it. World 2: narrower rotation limits of e0, and
    # planar's theta one-sided
    lower[2, e0, :3], upper[2, e0, :3] = -0.2, 0.2
    lower[2, planar, 2] = -INF
    given[2]["e0"] = mjflex.Stops(lower=[-0.2] * 3 + [N] * 3, upper=[0.2] * 3 + [N] * 3)
    given[2]["planar"] = mjflex.Stops(lower=[N, N, -0.05], upper=[2.0, 0.08, N])
    # world 3: e0's stops off, e5 (none in the model) gets stops; every stiffness given (the model's effective
    # ones, e5's its own, e0's on rx 70)
    lower[3, e0], upper[3, e0] = -INF, INF
    lower[3, e5, 3:], upper[3, e5, 3:] = -0.004, 0.004
    stiffness = np.repeat(p["stop_stiffness"], 4, axis=0)[3]
    stiffness[e5, 3:] = 8e3
    stiffness[e0] = 70.0
    given[3].pop("e0")
    given[3]["e5"] = mjflex.Stops(lower=[N] * 3 + [-0.004] * 3, upper=[N] * 3 + [0.004] * 3, stiffness=8e3)
    for name, stops in STOPS.items():  # as given: a derived stiffness written out (world 3 sets them all)
        if stops.stiffness is None and name != "e0":
            e = forces.index(name)
            k = stiffness[e][[2, 3, 4]] if name == "planar" else stiffness[e]
            given[3][name] = mjflex.Stops(stops.lower, stops.upper, stiffness=tuple(k))
    assert n == len(STOPS) + 2
    return lower, upper, stiffness, given


def test_per_world_stops_match_models_edited_in_the_c_engine(stopped):
    """Four worlds: the model's stops; K three times stiffer (a derived stop stiffness follows K, as when K is
    edited in the model); narrower and one-sided limits; stops switched off on one element, added to an element
    the model gave none, and every stiffness given. Each against the C engine on a model written with those stops,
    within the derived bound."""
    from mjflex.mjcf.elements import edit_flexure

    m = mw.put_model(stopped)
    forces = mw.flexures(m)
    K = forces.parameters()["K"][0]
    scale = np.array([1.0, 3.0, 1.0, 1.0])
    lower, upper, stiffness, given = _world_stops(forces, K)
    mw.set_parameters(m, K=scale[:, None, None, None] * K[None], stop_lower=lower, stop_upper=upper)
    mw.set_parameters(m, stop_stiffness=np.stack([forces.parameters()["stop_stiffness"][w] for w in range(3)]
                                                 + [stiffness]))  # fmt: skip
    qpos, qvel = random_state(stopped, np.random.default_rng(9), angle=2.5)
    got = _warp_queries(m, _worlds(stopped, m, [(qpos, qvel)] * 4))
    table = mw.element_table(copy.copy(stopped))
    for w in range(4):
        spec = mujoco.MjSpec.from_string(features_xml("record", stops=given[w]))
        if scale[w] != 1.0:
            for e, name in enumerate(table.names):
                idx = np.ix_((2, 3, 4), (2, 3, 4))
                edit_flexure(spec, name, K=scale[w] * (table.K[e][idx] if table.planar[e] else table.K[e]))
        model = spec.compile()
        flex = mjflex.Flexures(model)
        data = _state_data(model, qpos, qvel)
        assert _engaged(flex, data).any(axis=1).sum() >= 4, w
        _compare(got, w, model, flex, data, ("wrench", "qfrc", "energy", "stops"))
    k = forces.parameters()["stop_stiffness"]
    e0 = forces.index("e0")
    np.testing.assert_allclose(k[1, e0, :3], 3 * k[0, e0, :3])  # derived: follows K
    assert not k[3, e0].any() and (k[3, forces.index("e5"), 3:] == 8e3).all()


def test_a_run_into_a_stop_matches_the_c_engine():
    """The two-body model's swing (B spins at 20 rad/s) with a stop at 0.03 rad on the hinge's rotation (250 N m/rad,
    1000 times the hinge's own stiffness): it engages after about 75 steps and throws B back within the 200 steps
    compared (MuJoCo Warp, float32, RK4 against the C
    plugin, float64), within the trajectory bound of tests/test_warp.py::test_trajectories_match_the_c_engine."""
    spec = mujoco.MjSpec.from_file(TWO_BODY)
    record = elements.element_record(spec, "hinge")
    record.stops = mjflex.Stops(lower=[N, N, -0.03, N, N, N], upper=[N, N, 0.03, N, N, N], stiffness=250.0)
    elements.write_record(spec, "hinge", record)
    model = spec.compile()
    key = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, key, 0)
    m = mw.put_model(model)
    d = _worlds(model, m, [(key.qpos, key.qvel)])
    nstep = 200
    got, rz = np.empty((nstep, model.nq + model.nv)), np.empty(nstep)
    for k in range(nstep):
        mjw.step(m, d)
        got[k] = np.concatenate([d.qpos.numpy()[0], d.qvel.numpy()[0]])
        rz[k] = mw.stop_coordinates(m, d)[0, 0, 2]
    assert not mw.divergences(m, d)
    engaged = np.flatnonzero(rz > 0.03)
    assert 20 < engaged[0] < 120 and rz.max() > 0.035 and rz[-1] < rz.max(), (engaged[:3], rz.max(), rz[-1])
    ref, bound = wb.trajectory_bound(model, key.qpos, key.qvel, nstep)
    groups = wb.state_groups(model)
    err = np.stack([np.abs(got - ref)[:, g].max(1) for g in groups], 1)
    ratio = err / np.maximum(bound, 1e-300)
    assert (err <= bound).all(), (np.unravel_index(np.argmax(ratio), ratio.shape), ratio.max())
    print(f"run into a stop: largest error / bound {ratio.max():.2g} over {nstep} steps")


# ------------------------------------------------------------------------ the boundary and the cost


def test_stop_parameters_are_checked_at_the_boundary(stopped):
    """Each rule of an element's stops (mjflex.Stops), in every world, named with the element, the coordinate and
    the world; a refused call changes nothing."""
    m = mw.put_model(stopped)
    forces = mw.flexures(m)
    before = forces.parameters()
    lower, upper = before["stop_lower"][0], before["stop_upper"][0]
    e0, planar = forces.index("e0"), forces.index("planar")

    def refused(match, **given):
        with pytest.raises(ValueError, match=match):
            mw.set_parameters(m, **given)
        after = forces.parameters()
        assert all(np.array_equal(after[k], before[k]) for k in before), "a refused call changed the parameters"

    bad = np.stack([lower, lower])
    bad[1, e0, 1] = np.nan
    refused("stop_lower has NaN", stop_lower=bad)
    bad = np.stack([lower, lower])
    bad[1, e0, 1] = 0.7
    refused(r"end stop on ry of flexure 'e0' \(world 1\): stop_lower is above stop_upper", stop_lower=bad)
    bad = lower.copy()
    bad[e0, 2] = -200.0
    refused("end stop on rz of flexure 'e0': a rotation limit is beyond pi", stop_lower=bad)
    bad = lower.copy()
    bad[e0, 4] = np.inf
    refused("stop_lower is \\+inf", stop_lower=bad)
    bad = lower.copy()
    bad[planar, 0] = -0.1
    refused("end stop on rx of flexure 'planar': the element is planar", stop_lower=bad)
    bad, e5 = lower.copy(), forces.index("e5")
    bad[e5, 3] = -0.01  # a stop e5 has not in the model: derived from K (100 K_xx) it is fine, given as 0 it is not
    k = before["stop_stiffness"][0].copy()
    k[e5] = 0.0
    refused("end stop on x of flexure 'e5': the stop has no stiffness", stop_lower=bad, stop_stiffness=k)
    refused(r"stop_upper must have shape \(12, 6\)", stop_upper=upper[:3])
    refused("different numbers of worlds", stop_lower=np.stack([lower] * 2), stop_upper=np.stack([upper] * 3))
    refused("beyond float32's range", stop_stiffness=np.full((len(forces), 6), 1e39))
    mw.set_parameters(m, stop_lower=bad)  # with the derived stiffness: a stop e5 did not have
    assert forces.parameters()["stop_stiffness"][0, e5, 3] == 100 * forces.parameters()["K"][0, e5, 3, 3]
    assert forces._params.stops.numpy()[e5] == 1


def test_kernels_without_the_stop_code_give_the_same_bits_to_elements_without_stops(stopped):
    """The baseline of the cost measurement (scripts/bench_warp_stops.py): kernels built without the stops' code
    compute elements without stops to the same bits as mjflex's kernels; they refuse a model with stops."""
    from mjflex.warp._forces import WarpFlexures

    model = features_model("record")
    state = random_state(model, np.random.default_rng(6), angle=2.5)
    m = mw.put_model(model)
    got = _warp_queries(m, _worlds(model, m, [state]))
    forces = mw.flexures(m)
    m.callback.passive = WarpFlexures(forces._table, forces.mjmodel, "float32", (), with_stops=False)
    bare = _warp_queries(m, _worlds(model, m, [state]))
    for key in got:
        np.testing.assert_array_equal(got[key], bare[key], err_msg=key)
    with pytest.raises(ValueError, match="kernels without the stops' code"):
        WarpFlexures(mw.element_table(copy.copy(stopped)), stopped, "float32", (), with_stops=False)


def test_cost_benchmark_writes_its_table_and_json(tmp_path):
    """scripts/bench_warp_stops.py at its smallest (what the stops' flag costs is measured there, never in a timed
    test): every case timed in every repeat, each ratio against its own kind's baseline of the same repeat."""
    import json
    import os
    import sys

    sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "scripts"))
    import bench_warp_stops

    bench_warp_stops.main(["--out", str(tmp_path), "--models", "two_body", "--worlds", "2", "--repeat", "2",
                           "--target", "0.002"])  # fmt: skip
    with open(tmp_path / "bench_warp_stops_cpu.json") as f:
        payload = json.load(f)
    row = payload["models"]["two_body"]["worlds"]["2"]
    assert set(row) == set(bench_warp_stops.CASES) and payload["models"]["two_body"]["elements"] == 1
    for case, base in bench_warp_stops.BASELINE.items():
        assert row[case]["repeats"] == 2 and row[case]["median_s"] > 0, case
        np.testing.assert_allclose(row[case]["ratios"], np.divide(row[case]["times_s"], row[base]["times_s"]),
                                   rtol=1e-4)  # fmt: skip
    assert {"command", "date", "machine"} <= set(payload)

"""mjflex on MuJoCo Warp (``mjflex.warp``), on Warp's CPU device, against the C engine in float64.

Every comparison has a bound derived from float32 rounding (tests/warp_bounds.py and the
docstrings below), not a tolerance tuned to pass. Kernels compile on first use and are cached by
Warp (its kernel cache directory, ``WARP_CACHE_PATH`` or ``~/.cache/warp``); the models are built
once per module and share MuJoCo Warp's compiled kernels where their sizes allow.
"""

import copy
import ctypes
import dataclasses
import re

import mujoco
import mujoco_warp as mjw
import numpy as np
import pytest
import warp as wp

import mjflex
import mjflex.warp as mw
from mjflex.native import library as _native
from mjflex.warp import _kernels
from tests import warp_bounds as wb
from tests.warp_models import features_model, features_xml, random_state

TWO_BODY = "models/two_body_plugin.xml"
ARCADE = "models/arcade.xml"


@pytest.fixture(scope="module", autouse=True)
def cpu():
    """Every test of the module on Warp's CPU device."""
    with wp.ScopedDevice("cpu"):
        yield


@pytest.fixture(scope="module")
def features():
    return features_model("plugin")


@pytest.fixture(scope="module")
def two_body():
    return mujoco.MjModel.from_xml_path(TWO_BODY)


def _state_data(model, qpos, qvel):
    """A MuJoCo data at the float32 rounding of (qpos, qvel): the state MuJoCo Warp holds."""
    data = mujoco.MjData(model)
    data.qpos[:], data.qvel[:] = qpos.astype(np.float32), qvel.astype(np.float32)
    mujoco.mj_forward(model, data)
    return data


def _worlds(model, m, states):
    d = mjw.make_data(model, nworld=len(states))
    d.qpos.assign(np.array([s[0] for s in states], np.float32))
    d.qvel.assign(np.array([s[1] for s in states], np.float32))
    mjw.forward(m, d)
    return d


def _warp_queries(m, d):
    return {"wrench": mw.wrenches(m, d), "energy": mw.potential_energies(m, d), "power": mw.dissipation_powers(m, d),
            "twist": mw.displacements(m, d), "qfrc": mw.generalized_forces(m, d),
            "stops": mw.stop_coordinates(m, d)}  # fmt: skip


# ------------------------------------------------------------------------ the element math


@pytest.mark.parametrize("precision", ["float32", "float64"])
def test_angle_functions_match_the_c_engine(precision):
    """alpha / n, c(alpha), g(alpha) of the twist map from 1e-8 rad to pi, both branches (series below 2.2 rad).

    Bound: the C engine's values are exact to a few float64 ulps (tests/test_native_kernel.py); the
    Warp functions evaluate atan2, a 20-term Horner series (or the closed forms) in the kernels'
    precision: about 40 roundings of quantities no larger than the result (the series' terms are
    positive), so 64 u of the precision, relative.
    """
    angles = np.concatenate([np.geomspace(1e-8, 2.19, 40), [2.2, np.nextafter(2.2, 3)], np.linspace(2.21, np.pi, 20)])
    w, n = np.cos(angles / 2), np.sin(angles / 2)
    real = np.float64 if precision == "float64" else np.float32
    k = _kernels.kernels(precision)
    el = k["Elements"]()
    series = mw.element_table(mujoco.MjModel.from_xml_path(TWO_BODY))
    el.series_c, el.series_g = (wp.array(a.astype(real), dtype=k["real"]) for a in (series.series_c, series.series_g))
    out = wp.zeros(len(angles), dtype=k["V3"])
    n2_in, w_in = (wp.array((x).astype(real), dtype=k["real"]) for x in (n * n, w))
    wp.launch(k["scalars"], dim=len(angles), inputs=[n2_in, w_in, el], outputs=[out])
    got = out.numpy()
    u = 2.0**-53 if precision == "float64" else 2.0**-24
    for i in range(len(angles)):
        ref = [ctypes.c_double() for _ in range(3)]
        _native.lib().mjfx_angle_coefs(float(real(n[i]) ** 2), float(real(w[i])), *(ctypes.byref(r) for r in ref))
        ref = np.array([r.value for r in ref])
        np.testing.assert_array_less(np.abs(got[i] - ref), 64 * u * np.abs(ref) + 1e-300, err_msg=f"angle {angles[i]}")


@pytest.mark.parametrize("precision", ["float32", "float64"])
def test_forces_and_energies_match_the_c_engine_on_random_states(features, precision):
    """Wrenches, generalized forces, energies, dissipated powers and twists of every element feature, on 12 random
    states (relative rotations up to 2.5 rad, random velocities), MuJoCo Warp's own float32 kinematics.

    Derivation of the bound (tests/warp_bounds.py): the reference is the C engine in float64 at the same
    (float32) state. The Warp result's inputs (MuJoCo Warp's kinematics) are off by at most
    ``8 per tree level + 12`` (kernel) roundings of ``u |row|`` each; their effect is the input
    sensitivity ``S_in`` computed with the C engine (central differences with those perturbations): the
    condition of the element map times ``u`` times the scale of its inputs. The element math adds at most
    ``48 u`` of the magnitudes it combines (``|K| |xi| + |B| |V| + |result|``, times ``(1 + |xi|)^2``).
    ``u`` is 2^-24 for the inputs always (MuJoCo Warp is float32) and 2^-24 or 2^-53 for the arithmetic.
    Bound = (8 depth + 12) S_in + 48 u S_arith, per component; the energy adds the second-order term of
    its own displacement error, 1/2 dxi^T |K| dxi.
    """
    rng = np.random.default_rng(11)
    states = [random_state(features, rng, angle=2.5) for _ in range(12)]
    m = mw.put_model(features, precision=precision)
    got = _warp_queries(m, _worlds(features, m, states))
    flex = mjflex.Flexures(features)
    arith = wb.U64 if precision == "float64" else wb.U32
    worst = {}
    for i, (qpos, qvel) in enumerate(states):
        data = _state_data(features, qpos, qvel)
        ref, bound = wb.c_queries(flex, data), wb.bounds(features, data, flex, arith)
        for key in ref:
            err = np.abs(got[key][i] - ref[key])
            assert (err <= bound[key]).all(), (key, i, np.max(err / np.maximum(bound[key], 1e-300)))
            worst[key] = max(worst.get(key, 0.0), float(np.max(err / np.maximum(bound[key], 1e-300))))
    print(f"largest error / bound ({precision}):", {k: f"{v:.2g}" for k, v in worst.items()})


def test_both_forms_of_a_model_give_the_same_forces(two_body):
    """Text records and plugin instances of one element: the same kernel inputs, the same bits."""
    records = mujoco.MjModel.from_xml_path("models/two_body.xml")
    rng = np.random.default_rng(3)
    states = [random_state(two_body, rng) for _ in range(3)]
    forms = []
    for model in (records, two_body):
        m = mw.put_model(model)
        assert mw.flexures(m).kinds == (("plugin",) if model is two_body else ("record",))
        forms.append(_warp_queries(m, _worlds(model, m, states)))
    for key in forms[0]:
        np.testing.assert_array_equal(forms[0][key], forms[1][key], err_msg=key)


def test_disable_flags_switch_off_the_elastic_and_viscous_parts(features):
    """MuJoCo's spring / damper disable flags, as the C engine reads them (same derived bound)."""
    rng = np.random.default_rng(5)
    states = [random_state(features, rng) for _ in range(2)]
    for flag in (mujoco.mjtDisableBit.mjDSBL_SPRING, mujoco.mjtDisableBit.mjDSBL_DAMPER):
        model = copy.copy(features)
        model.opt.disableflags |= int(flag)
        m = mw.put_model(model)
        got = _warp_queries(m, _worlds(model, m, states))
        flex = mjflex.Flexures(model)
        for i, (qpos, qvel) in enumerate(states):
            data = _state_data(model, qpos, qvel)
            ref, bound = wb.c_queries(flex, data), wb.bounds(model, data, flex)
            for key in ("wrench", "qfrc", "energy", "power"):
                assert (np.abs(got[key][i] - ref[key]) <= bound[key]).all(), (flag, key)
        if flag == mujoco.mjtDisableBit.mjDSBL_SPRING:
            assert not got["energy"].any()
        else:
            assert not got["power"].any()


# ------------------------------------------------------------------------ trajectories


@pytest.mark.parametrize(("path", "nstep"), [(TWO_BODY, 200), (ARCADE, 100)])
def test_trajectories_match_the_c_engine(path, nstep):
    """The two-body model (200 steps of 2e-5 s: 7.5 periods of its stiffest mode, 1.9 kHz) and ARCADE (100 steps of
    1e-5 s of the paper's run, 105 rad/s and 5 m/s: 13 periods of its stiffest mode, 12.7 kHz), each from its
    keyframe and from a random state, stepped by MuJoCo Warp (RK4, float32) against the C plugin (RK4, float64).

    Derivation of the bound: MuJoCo Warp rounds, in every step, what it stores (qpos, qvel) and in each of
    RK4's four stages the kinematics and the forces: 10 roundings per step, each at most u = 2^-24 of the
    magnitudes combined, which act like perturbations of the state of that size: positions by u L (L the
    model's size: kinematics and forces are computed from coordinates of that size), rotations by u,
    velocities by u |v| (tests/warp_bounds.perturbation_scales). How the trajectory amplifies such
    perturbations (its condition, stiff modes included) is measured with the C engine in float64: the run is
    repeated with every qpos and qvel component moved by +- 10 u times its scale before each step (random
    signs, 4 seeds). The bound, per step and per joint group (positions, rotation, linear and angular
    velocity), is the largest deviation of those runs from the unperturbed one. Both start from the float32
    rounding of the state.
    """
    model = mujoco.MjModel.from_xml_path(path)
    rng = np.random.default_rng(2)
    key = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, key, 0)
    starts = [(key.qpos.copy(), key.qvel.copy()), random_state(model, rng, angle=0.05, shift=1e-4, speed=0.5)]
    m = mw.put_model(model)
    d = _worlds(model, m, starts)
    got = np.empty((nstep, len(starts), model.nq + model.nv))
    for k in range(nstep):
        mjw.step(m, d)
        got[k] = np.concatenate([d.qpos.numpy(), d.qvel.numpy()], axis=1)
    assert not mw.divergences(m, d)
    groups = wb.state_groups(model)
    for w, (qpos, qvel) in enumerate(starts):
        ref, bound = wb.trajectory_bound(model, qpos, qvel, nstep)
        err = np.stack([np.abs(got[:, w] - ref)[:, g].max(1) for g in groups], 1)
        ratio = err / np.maximum(bound, 1e-300)
        assert (err <= bound).all(), (w, np.unravel_index(np.argmax(ratio), ratio.shape), ratio.max())
        print(f"{path} world {w}: largest error / bound {ratio.max():.2g} over {nstep} steps")


# ------------------------------------------------------------------------ divergence


def test_divergence_is_reported_per_world_with_the_element_and_the_step(two_body):
    """Worlds 1 and 3 are 1e4 times stiffer (unstable at the model's step: omega h ~ 20), world 4 has a stiffness
    whose wrench overflows float32 at a finite state: each is reported with the element and the step, the step
    the same as the C engine's report for that stiffness; the other worlds run on unaffected; a diverged world's
    state is NaN from then on; a reset (time running back) starts a new run."""
    table = mw.element_table(copy.copy(two_body))
    scale = np.array([1.0, 1e4, 1.0, 1e4, 1.0])
    m = mw.put_model(two_body)
    K = scale[:, None, None, None] * table.K[None]
    K[4, 0] = np.diag([3e38] * 3 + [1e5] * 3)
    mw.set_parameters(m, K=K, B=scale[:, None, None, None] * table.B[None])
    key = mujoco.MjData(two_body)
    mujoco.mj_resetDataKeyframe(two_body, key, 0)
    qpos = key.qpos.copy()
    qpos[10:14] = [np.cos(1.25), 0, 0, np.sin(1.25)]  # world 4: B turned by 2.5 rad about z: K tau > 3.4e38
    d = _worlds(two_body, m, [(key.qpos, key.qvel)] * 4 + [(qpos, key.qvel)])
    for _ in range(10):
        mjw.step(m, d)
    found = {v.world: v for v in mw.divergences(m, d)}
    assert sorted(found) == [1, 3, 4]
    np.testing.assert_array_equal(mw.diverged(m, d), [False, True, False, True, True])
    # the C engine on the same stiffness, auto-reset off: its report names the step
    spec = mujoco.MjSpec.from_file(TWO_BODY)
    from mjflex.mjcf.elements import edit_flexure

    edit_flexure(spec, "hinge", K=1e4 * table.K[0], B=1e4 * table.B[0])
    model = spec.compile()
    model.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_AUTORESET)
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, 0)
    with pytest.raises(mujoco.FatalError, match=r"step index (\d+)") as c_error:
        mujoco.mj_step(model, data, 10)
    c_step = int(re.search(r"step index (\d+)", str(c_error.value)).group(1))
    for w in (1, 3):
        v = found[w]
        assert (v.element, v.step) == ("hinge", c_step), v
        assert f"world {w} diverged in the step from t = {c_step * 2e-5:.9g} s (step index {c_step}" in v.message
        assert "flexure 'hinge''s force alone accelerated" in v.message
    assert found[4].step == 0 and found[4].reason.startswith("its wrench is not finite"), found[4]
    qpos_now, qvel_now = d.qpos.numpy(), d.qvel.numpy()
    # (MuJoCo Warp normalizes a NaN quaternion to the identity: positions and velocities stay NaN)
    assert np.isnan(qvel_now[[1, 3, 4]]).all() and np.isnan(qpos_now[[1, 3, 4]]).any(axis=1).all()
    assert np.isfinite(qpos_now[[0, 2]]).all() and np.isfinite(qvel_now[[0, 2]]).all()
    np.testing.assert_array_equal(qpos_now[0], qpos_now[2])  # the others run on as one
    mjw.reset_data(m, d)  # every world back to qpos0 at rest, time 0: a new run
    mjw.step(m, d)
    assert not mw.divergences(m, d) and np.isfinite(d.qvel.numpy()).all()


# ------------------------------------------------------------------------ per-world parameters


def test_per_world_parameters_match_models_edited_in_the_c_engine(features):
    """Four worlds with their own K, B, enabled and viscous switches: each matches the C engine on a model whose
    elements were edited to those values (mjflex.edit_elements / the spec), within the derived bound."""
    from mjflex.mjcf.elements import edit_flexure

    table = mw.element_table(copy.copy(features))
    n = len(table.names)
    rng = np.random.default_rng(9)
    scale = np.array([1.0, 3.0, 0.2, 10.0])
    K = scale[:, None, None, None] * table.K[None]
    B = np.stack([table.B, 4 * table.B, table.B, 0 * table.B])
    enabled = np.ones((4, n), bool)
    enabled[2, [0, 3]] = False
    viscous = table.viscous[None].repeat(4, 0)
    viscous[3] = False
    m = mw.put_model(features)
    mw.set_parameters(m, K=K, B=B, enabled=enabled, viscous=viscous)
    qpos, qvel = random_state(features, rng)
    got = _warp_queries(m, _worlds(features, m, [(qpos, qvel)] * 4))
    for w in range(4):
        spec = mujoco.MjSpec.from_string(features_xml("plugin"))
        for e, name in enumerate(table.names):
            idx = np.ix_((2, 3, 4), (2, 3, 4))
            k, b = (K[w, e][idx], B[w, e][idx]) if table.planar[e] else (K[w, e], B[w, e])
            edit_flexure(spec, name, K=k, B=b if b.any() else [])
        for flag, on in (("enabled", enabled[w]), ("viscous", viscous[w])):
            for value in (True, False):
                names = [
                    name
                    for e, name in enumerate(table.names)
                    if on[e] == value and (B[w, e].any() or flag == "enabled")
                ]
                if names:
                    mjflex.edit_elements(spec, names, **{flag: value})
        model = spec.compile()
        flex = mjflex.Flexures(model)
        data = _state_data(model, qpos, qvel)
        ref, bound = wb.c_queries(flex, data), wb.bounds(model, data, flex)
        for key in ("wrench", "qfrc", "energy", "power"):
            err = np.abs(got[key][w] - ref[key])
            assert (err <= bound[key]).all(), (w, key, np.max(err / np.maximum(bound[key], 1e-300)))
    assert not got["wrench"][2, [0, 3]].any() and not got["power"][3].any()


def test_parameters_are_checked_at_the_boundary(features):
    m = mw.put_model(features)
    forces = mw.flexures(m)
    n = len(forces)
    K = forces.parameters()["K"].copy()
    bad = K.copy()
    bad[0, 3, 0, 0] = -1.0
    with pytest.raises(ValueError, match=r"K of flexure 'e3'.*not positive semi-definite"):
        mw.set_parameters(m, K=bad)
    with pytest.raises(ValueError, match=rf"shape \({n}, 6, 6\) or \(worlds, {n}, 6, 6\)"):
        mw.set_parameters(m, K=K[0, :3])
    planar = K.copy()
    planar[0, forces.index("planar"), 0, 0] = 1.0
    with pytest.raises(ValueError, match="flexure 'planar': the element is planar"):
        mw.set_parameters(m, K=planar)
    with pytest.raises(ValueError, match="beyond float32's range"):
        mw.set_parameters(m, K=K[0] * 1e40)
    with pytest.raises(TypeError, match="enabled must be booleans"):
        mw.set_parameters(m, enabled=np.ones(n))
    mw.set_parameters(m, K=np.repeat(K, 3, axis=0))
    d = mjw.make_data(features, nworld=2)
    with pytest.raises(ValueError, match="per-world K has 3 worlds but the data has 2"):
        mw.wrenches(m, d)


# ------------------------------------------------------------------------ the model


def test_put_model_works_on_a_copy_and_says_what_it_did(two_body):
    """The user's model is untouched; sleep="never" and the plugin instances are handled on the copy and listed."""
    before = two_body.tree_sleep_policy.copy()
    m = mw.put_model(two_body)
    np.testing.assert_array_equal(two_body.tree_sleep_policy, before)
    assert (before == int(mujoco.mjtSleepPolicy.mjSLEEP_NEVER)).all()
    forces = mw.flexures(m)
    notes = " ".join(forces.adaptations)
    assert "mjSLEEP_NEVER of the trees of A, B set to mjSLEEP_AUTO_NEVER" in notes
    assert "1 mjflex.flexure plugin instances" in notes
    assert forces.names == ("hinge",) and forces.precision == "float32"
    with pytest.raises(TypeError, match=r"make it with mjflex\.warp\.put_model"):
        mw.flexures(mjw.put_model(mujoco.MjModel.from_xml_path("models/two_body.xml")))


def test_mujoco_warp_itself_still_fails_on_plugin_instances(two_body):
    """mjflex.warp.put_model works around MuJoCo Warp 4.0.0's put_model on models with non-geom plugin instances;
    when this fails, MuJoCo Warp was fixed and the work-around (mjflex.warp._adapt.plugin_arrays_sized) can go."""
    model = copy.copy(two_body)
    model.tree_sleep_policy[:] = int(mujoco.mjtSleepPolicy.mjSLEEP_AUTO_NEVER)
    with pytest.raises(RuntimeError, match="reshape"):
        mjw.put_model(model)


def test_features_the_kernels_lack_are_refused_by_name(two_body):
    """An element feature the Warp kernels do not implement is refused with the element's and the feature's names,
    never ignored: here a record field they do not know (a feature added to mjflex.FlexureRecord later, planted as a
    subclass's field), which is refused without anyone listing it, because the kernels name what they implement
    (``SUPPORTED_FIELDS``), not what they lack; and a method they do not know. (End stops, the field this test
    planted before they existed, are implemented now: tests/test_warp_stops.py.)"""
    from mjflex.mjcf.schema import FlexureRecord
    from mjflex.warp import _mjflex

    @dataclasses.dataclass
    class WithBacklash(FlexureRecord):
        backlash: tuple | None = None

    flex = mjflex.Flexures(copy.copy(two_body))
    fields = {f.name: getattr(flex.records[0], f.name) for f in dataclasses.fields(FlexureRecord)}
    flex._tables.records[0] = WithBacklash(**fields, backlash=(0.1, 0.2))
    with pytest.raises(mw.UnsupportedElementError, match="flexure 'hinge' uses backlash, which the MuJoCo Warp"):
        _mjflex.element_table(flex.model, flex)
    flex._tables.records[0] = WithBacklash(**fields)  # the default: nothing to refuse
    assert _mjflex.element_table(flex.model, flex).names == ("hinge",)
    flex._tables.records[0] = dataclasses.replace(flex.records[0], method="screw")
    with pytest.raises(mw.UnsupportedElementError, match="flexure 'hinge' uses method 'screw'"):
        _mjflex.element_table(flex.model, flex)


def test_foreign_plugin_instances_and_sleeping_at_start_are_refused(two_body, monkeypatch):
    """A plugin instance that is not an mjflex element and not attached to a geom would be dropped silently by
    MuJoCo Warp (plugins attached to bodies, actuators or sensors it refuses itself); no such plugin ships with
    MuJoCo, so the model's mjflex instance is made to look foreign. Trees that start asleep are refused too."""
    from mjflex.warp import _mjflex

    with monkeypatch.context() as patch:
        patch.setattr(_mjflex, "mjflex_instances", lambda model: [])
        with pytest.raises(NotImplementedError, match=r"'hinge' are neither mjflex\.flexure elements nor attached"):
            mw.put_model(two_body)
    spec = mujoco.MjSpec.from_file(TWO_BODY)
    spec.option.enableflags |= int(mujoco.mjtEnableBit.mjENBL_SLEEP)
    spec.body("A").sleep = mujoco.mjtSleepPolicy.mjSLEEP_INIT
    with (
        pytest.raises(NotImplementedError, match="tree of body 'A' starts asleep"),
        pytest.warns(UserWarning, match="may sleep"),
    ):
        mw.put_model(spec.compile())


# ------------------------------------------------------------------------ the benchmark script


def test_benchmark_script_writes_its_table_json_and_log(tmp_path):
    """scripts/bench_warp.py at the smallest sizes (the documented figures come from it, on an idle machine and on a
    GPU): one timed size per case with its spread and its ratio to rollout, the next size skipped for the time
    budget and said so, the device and the command recorded."""
    import json
    import os
    import sys

    sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "scripts"))
    import bench_warp

    bench_warp.main(["--out", str(tmp_path), "--models", "two_body", "--worlds", "2,8192", "--repeat", "2", "--target",
                     "0.01", "--threads", "1", "--budget", "24", "--no-check"])  # fmt: skip
    with open(tmp_path / "bench_warp_cpu.json") as f:
        payload = json.load(f)
    model = payload["models"]["two_body"]
    row = model["worlds"]["2"]
    assert set(row) >= {"warp", "warp_bare", "rollout", "batch"} and row["rollout"]["ratio_median"] == 1.0
    for case in ("warp", "warp_bare", "rollout", "batch"):
        assert row[case]["world_steps_per_s_median"] > 0 and row[case]["repeats"] == 2
        assert row[case]["world_steps_per_s_min"] <= row[case]["world_steps_per_s_max"]
    assert row["diverged_worlds"] == {"warp": 0} and "8192" in model["skipped"] and "budget" in model["skipped"]["8192"]
    assert payload["device"]["is_cuda"] is False and {"command", "date", "machine"} <= set(payload)
    log = (tmp_path / "bench_warp_cpu.log").read_text()
    assert "two_body       2 worlds: rollout" in log and "skipped" in log


def test_only_mjflex_warp_imports_warp():
    """mjflex, its command line and its sweeps import neither warp nor mujoco_warp until the warp executor runs."""
    import subprocess
    import sys

    code = (
        "import sys, mjflex, mjflex.app.cli, mjflex.app.sweep, mjflex.app.sweep.warp, mjflex.app.sweep.arcade; "
        "found = {'warp', 'mujoco_warp'} & set(sys.modules); assert not found, found"
    )
    subprocess.run([sys.executable, "-c", code], check=True)


def test_a_model_without_elements_gets_a_callback_that_adds_nothing():
    model = mujoco.MjModel.from_xml_string('<mujoco><worldbody><body><freejoint/><geom size="0.1"/></body></worldbody>'
                                           "</mujoco>")  # fmt: skip
    m = mw.put_model(model)
    d = mjw.make_data(model, nworld=2)
    before = d.qfrc_passive.numpy().copy()
    m.callback.passive(m, d)  # what mujoco_warp.step calls (not stepped here: no MuJoCo Warp kernels to compile)
    np.testing.assert_array_equal(d.qfrc_passive.numpy(), before)
    assert mw.flexures(m).names == () and mw.wrenches(m, d).shape == (2, 0, 6) and not mw.divergences(m, d)

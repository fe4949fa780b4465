"""The engine plugin mjflex.flexure: the same motion as the mjcb_passive provider, and it works where the hook cannot.

Plugin and text-record versions of one model run the same C loop on the same element table (built by
the plugin's init from the configuration, by Python from the record), so trajectories are compared
bit for bit, not to a tolerance.
"""

import concurrent.futures
import copy
import ctypes
import multiprocessing
import os
import pickle
import threading

import mujoco
import numpy as np
import pytest
from mujoco import batch as mjbatch
from mujoco import rollout

import mjflex
from mjflex.native import library as _native
from tests.models import B_DEMO, K_DEMO, hinge_chain_spec, two_body_spec
from tests.plugin_models import MODELS, as_plugins, as_records, assert_not_diverged, planar_spec, polynomial_terms

pytestmark = pytest.mark.usefixtures("clean_callback")
STEPS = 1000


def _trajectory(model, qvel, steps=STEPS, key=None, qpos=None):
    data = mujoco.MjData(model)
    if key is not None:
        mujoco.mj_resetDataKeyframe(model, data, key)
    if qpos is not None:
        data.qpos[:] = qpos
    data.qvel[:] = qvel if qvel is not None else data.qvel
    out = np.empty((steps, model.nq + model.nv))
    for i in range(steps):
        mujoco.mj_step(model, data)
        out[i, : model.nq], out[i, model.nq :] = data.qpos, data.qvel
    assert_not_diverged(data, f"the run of {steps} steps")
    return out


def _both(spec, method=None):
    """(text-record model, plugin model) of one spec; the record model's provider uses ``method`` too."""
    record = as_records(spec).compile()
    flex = mjflex.Flexures(record)
    if method is not None:
        for name in flex.names:
            flex.set_method(name, method)
    return record, flex, as_plugins(spec, method).compile()


CASES = {
    "two_body.xml": lambda: mujoco.MjSpec.from_file(os.path.join(MODELS, "two_body.xml")),
    # random cubic and quartic terms make an energy unbounded below: at scale 20 the run leaves through it (diverges)
    "polynomial twist": lambda: two_body_spec(B=B_DEMO, terms=polynomial_terms("twist", scale=5.0)),
    "polynomial dualquat": lambda: two_body_spec(B=B_DEMO, method="dualquat", terms=polynomial_terms("dualquat")),
    "planar twist": lambda: planar_spec(),
    "planar dualquat": lambda: planar_spec(method="dualquat"),
    "chain (hinge, slide, ball joints)": lambda: hinge_chain_spec(n=4, B=B_DEMO, K=1e-3 * K_DEMO),
}


@pytest.mark.parametrize("case", list(CASES))
def test_plugin_moves_bit_identically_to_the_callback(case):
    record, flex, plugin = _both(CASES[case]())
    assert mjflex.Flexures(plugin).kinds == ("plugin",) * len(flex)
    qvel = 0.3 * np.random.default_rng(1).normal(size=record.nv)
    with flex:
        expected = _trajectory(record, qvel)
    got = _trajectory(plugin, qvel)
    assert np.array_equal(got, expected)
    assert np.abs(expected[-1] - expected[0]).max() > 1e-4  # it moved


@pytest.mark.parametrize("method", ["twist", "dualquat"])
def test_arcade_plugin_moves_bit_identically_to_the_callback(method):
    spec = mujoco.MjSpec.from_file(os.path.join(MODELS, "arcade.xml"))
    record, flex, plugin = _both(spec, method)
    assert len(flex) == 48 and plugin.nplugin == 48
    with flex:
        expected = _trajectory(record, None, key=0)
    got = _trajectory(plugin, None, key=0)
    assert np.array_equal(got, expected)
    assert record.opt.integrator == mujoco.mjtIntegrator.mjINT_RK4


def test_the_plugins_table_is_the_records_table():
    """An element lays out the same row in both forms: one reader in C (mjfx_read_element) for the plugin's init and
    for Flexures, whether the element is a plugin instance or a text record given to C as the same configuration."""
    spec = mujoco.MjSpec.from_file(os.path.join(MODELS, "arcade.xml"))
    plugins, records = mjflex.Flexures(as_plugins(spec).compile()), mjflex.Flexures(as_records(spec).compile())
    assert plugins.kinds == ("plugin",) * 48 and records.kinds == ("record",) * 48
    assert plugins.names == records.names
    for e in range(len(plugins)):
        row, mine = plugins._elements[e : e + 1].copy(), records._elements[e : e + 1].copy()
        assert row.tobytes() == mine.tobytes(), plugins.names[e]
    assert np.array_equal(plugins._tables.chain, records._tables.chain)
    assert np.array_equal(plugins._tables.exps, records._tables.exps)


# ------------------------------------------------------------------ Python's analysis on plugin models


def test_every_analysis_function_works_on_plugin_models():
    record, flex, plugin = _both(two_body_spec(B=B_DEMO))
    pflex = mjflex.Flexures(plugin)
    assert pflex.names == flex.names and pflex.kinds == ("plugin",)
    for r, p in zip(pflex.records, flex.records, strict=True):
        assert np.array_equal(r.K, p.K) and np.array_equal(r.B, p.B) and r.method == p.method
    rd, pd = mujoco.MjData(record), mujoco.MjData(plugin)
    for d, m in ((rd, record), (pd, plugin)):
        d.qpos[7:10] += [0.01, -0.02, 0.005]
        d.qvel[:] = 1.0
        mujoco.mj_forward(m, d)
    for name in ("wrenches", "potential_energies", "dissipation_powers", "displacements", "generalized_forces"):
        assert np.array_equal(getattr(pflex, name)(pd), getattr(flex, name)(rd)), name
    assert np.array_equal(pflex.results(pd)["wrench"], flex.results(rd)["wrench"])
    assert np.array_equal(pd.qfrc_passive, pflex.generalized_forces(pd))  # the model's own forces, no install


def test_install_on_a_plugin_model_adds_nothing_twice():
    """The forces belong to the model: `with flex:` must not add them again (a documented no-op)."""
    model = two_body_spec(B=B_DEMO, kind="plugin").compile()
    flex = mjflex.Flexures(model)
    data = mujoco.MjData(model)
    data.qpos[7:10] += [0.01, -0.02, 0.005]
    mujoco.mj_forward(model, data)
    alone = data.qfrc_passive.copy()
    assert flex.installed  # always: the model adds them
    with flex:
        assert mujoco.get_mjcb_passive() is None
        mujoco.mj_forward(model, data)
    assert np.array_equal(data.qfrc_passive, alone) and np.abs(alone).max() > 1.0
    with flex.serve([copy.copy(model)]):  # copies carry the forces already: nothing to serve either
        assert mujoco.get_mjcb_passive() is None
    with pytest.raises(
        ValueError, match=r"flexure 'link' is an mjflex.flexure plugin instance: .*mjflex.edit_elements\(spec"
    ):
        flex.set_enabled("link", False)
    with pytest.raises(ValueError, match=r"plugin instance"):
        flex.set_method("link", "dualquat")


def test_a_model_with_records_and_plugin_instances():
    """Records are installed, instances are the model's; both evaluated by Flexures, records first."""
    spec = two_body_spec(B=B_DEMO)
    mjflex.add_flexure(spec, "second", "A", "B", pos=[0.12, 0.0, 0.5], K=2 * K_DEMO, kind="plugin")
    model = spec.compile()
    flex = mjflex.Flexures(model)
    assert flex.names == ("link", "second") and flex.kinds == ("record", "plugin")
    data = mujoco.MjData(model)
    data.qpos[7:10] += [0.01, -0.02, 0.005]
    data.qvel[:] = 0.5
    mujoco.mj_forward(model, data)
    plugin_only = data.qfrc_passive.copy()
    total = flex.generalized_forces(data)
    with flex:
        mujoco.mj_forward(model, data)
    assert np.allclose(data.qfrc_passive, total, rtol=1e-13, atol=1e-15)
    assert not np.allclose(plugin_only, total)
    flex.set_enabled("link", False)  # a record's switch still works
    assert np.allclose(flex.generalized_forces(data), plugin_only, rtol=1e-13, atol=1e-15)


def test_attached_and_unattached_instances_are_computed():
    """MuJoCo keeps instances attached to no body and calls their compute (add_flexure writes them so)."""
    spec = two_body_spec(B=B_DEMO, kind="plugin")
    unattached = spec.compile()
    spec.body("B").plugin = spec.plugins[0]
    attached = spec.compile()
    assert attached.body_plugin.max() == 0 and unattached.body_plugin.max() == -1
    qvel = np.random.default_rng(3).normal(size=unattached.nv)
    assert np.array_equal(_trajectory(attached, qvel, 200), _trajectory(unattached, qvel, 200))


# ------------------------------------------------------------------ where the hook cannot


def _plugin_model(K=K_DEMO, method="twist"):
    return two_body_spec(K=K, B=B_DEMO, method=method, integrator="Euler", kind="plugin").compile()


def _qvels(model, n):
    return [np.random.default_rng(seed).normal(size=model.nv) for seed in range(n)]


def _serial(model, qvels, steps=300):
    return np.array([_trajectory(model, q, steps)[-1, : model.nq] for q in qvels])


def test_batch_of_the_plain_model_needs_no_serve():
    model = _plugin_model()
    qvels = _qvels(model, 4)
    batch = mjbatch.Batch(model, nsim=4, nthread=2)  # the batch's own copy of the model carries the forces
    batch.qvel = np.array(qvels)
    batch.step(nstep=300)
    assert np.array_equal(batch.qpos, _serial(model, qvels))


def test_batch_with_a_model_per_simulation_gives_each_its_own_elements():
    """``Batch.set_models`` steps each simulation's data with another model object than the one it was made from
    (per-simulation parameters): the plugin reads the elements of the model it is stepped with, so every simulation
    moves as a serial loop of its own model does (bit for bit), not with the elements of the batch's first model."""
    models = [_plugin_model(K=scale * K_DEMO) for scale in (1.0, 0.5, 2.0, 4.0)]
    qvels = _qvels(models[0], 4)
    batch = mjbatch.Batch(models[0], nsim=4, nthread=2)
    batch.set_models(models)
    batch.qvel = np.array(qvels)
    batch.step(nstep=300)
    expected = np.array([_serial(m, [q])[0] for m, q in zip(models, qvels, strict=True)])
    assert not np.array_equal(expected[0], _serial(models[1], qvels[:1])[0])  # the stiffness matters here
    assert np.array_equal(batch.qpos, expected)


def test_a_data_stepped_with_another_model_reads_that_models_elements():
    """A data made from one model and stepped with an edited copy (other stiffness, another site pose: another rest
    offset) moves as a data of the copy, and its kinematics stay its own."""
    stiff = two_body_spec(K=3 * K_DEMO, B=B_DEMO, integrator="Euler", kind="plugin")
    stiff.site("link/b").pos = stiff.site("link/b").pos + [1e-6, 0, 0]  # a rest offset of its own (within tolerance)
    soft, stiff = _plugin_model(), stiff.compile()
    qvel = _qvels(soft, 1)[0]
    own = _trajectory(stiff, qvel, 300)
    data = mujoco.MjData(soft)  # made from the soft model
    data.qvel[:] = qvel
    mujoco.mj_forward(stiff, data)
    before = data.site_xpos.copy()
    mujoco.mj_forward(stiff, data)  # the second call with the same model reads nothing again
    assert np.array_equal(data.site_xpos, before)
    mujoco.mj_step(stiff, data, nstep=300)
    assert np.array_equal(np.r_[data.qpos, data.qvel], own[-1])
    mujoco.mj_forward(stiff, data)
    assert np.array_equal(data.qfrc_passive, _data_at(stiff, data).qfrc_passive)  # the forces its own data gets


def _data_at(model, other):
    data = mujoco.MjData(model)
    data.qpos[:], data.qvel[:] = other.qpos, other.qvel
    mujoco.mj_forward(model, data)
    return data


def test_rollout_with_two_threads():
    model = _plugin_model()
    qvels = _qvels(model, 4)
    kind = mujoco.mjtState.mjSTATE_FULLPHYSICS
    states = []
    for q in qvels:
        data = mujoco.MjData(model)
        data.qvel[:] = q
        state = np.empty(mujoco.mj_stateSize(model, kind))
        mujoco.mj_getState(model, data, state, kind)
        states.append(state)
    out, _ = rollout.rollout(model, [mujoco.MjData(model) for _ in range(2)], np.array(states), nstep=300)
    assert np.array_equal(out[:, -1, 1 : 1 + model.nq], _serial(model, qvels))


def _step_pickled(blob, qvel, steps):
    model = pickle.loads(blob)  # a fresh interpreter: `import mujoco` registered the plugin
    return _trajectory(model, qvel, steps)[-1, : model.nq]


def test_a_pickled_model_in_a_spawned_process():
    model = _plugin_model()
    qvel = _qvels(model, 1)[0]
    spawn = multiprocessing.get_context("spawn")
    with concurrent.futures.ProcessPoolExecutor(1, mp_context=spawn) as pool:
        there = pool.submit(_step_pickled, pickle.dumps(model), qvel, 300).result(timeout=300)
    assert np.array_equal(there, _serial(model, [qvel])[0])


def test_model_copies():
    model = _plugin_model()
    qvel = _qvels(model, 1)
    expected = _serial(model, qvel)
    for c in (copy.copy(model), copy.deepcopy(model)):
        assert np.array_equal(_serial(c, qvel), expected)
    data = mujoco.MjData(model)
    data.qvel[:] = qvel[0]
    mujoco.mj_step(model, data)
    twin = copy.copy(data)  # MjData copies: the plugin's init and copy run
    for d in (data, twin):
        for _ in range(299):
            mujoco.mj_step(model, d)
    assert np.array_equal(twin.qpos, data.qpos) and np.array_equal(data.qpos, expected[0])


def test_two_plugin_models_in_two_threads_at_once():
    models = [_plugin_model(), _plugin_model(K=3 * K_DEMO, method="dualquat")]
    qvels = _qvels(models[0], 1)
    expected = [_serial(m, qvels, 2000) for m in models]
    got = [None, None]
    barrier = threading.Barrier(2)

    def run(i):
        barrier.wait()
        got[i] = _serial(models[i], qvels, 2000)

    threads = [threading.Thread(target=run, args=(i,)) for i in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert all(np.array_equal(g, e) for g, e in zip(got, expected, strict=True))
    assert not np.array_equal(expected[0], expected[1])


def test_a_python_callback_beside_the_plugin():
    """The plugin needs no hook: a user's own passive callback runs beside it, untouched."""
    model = _plugin_model()
    data = mujoco.MjData(model)
    data.qpos[7:10] += 0.01
    mujoco.mj_forward(model, data)
    alone = data.qfrc_passive.copy()
    hits = ctypes.c_int(0)

    @ctypes.CFUNCTYPE(None, ctypes.c_void_p, ctypes.c_void_p)
    def user(m, d):
        hits.value += 1

    mujoco.set_mjcb_passive(user)
    try:
        mujoco.mj_forward(model, data)
    finally:
        mujoco.set_mjcb_passive(None)
    assert hits.value == 1 and np.array_equal(data.qfrc_passive, alone)


def test_every_mjData_frees_its_instances():
    """init allocates per mjData (the element, its dof chain, the leader's table and watch); destroy frees it."""
    import copy as copy_module
    import gc

    model = _plugin_model()
    native = _native.lib()
    alive = native.mjfx_live_instances()
    datas = [mujoco.MjData(model) for _ in range(5)]
    datas += [copy_module.copy(d) for d in datas]
    assert native.mjfx_live_instances() == alive + 10 * model.nplugin
    del datas
    gc.collect()
    assert native.mjfx_live_instances() == alive

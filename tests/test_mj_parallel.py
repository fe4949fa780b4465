"""Providers in other processes (pickling), in mujoco.batch.Batch threads, and installed from several threads."""

import concurrent.futures
import copy
import multiprocessing
import pickle
import threading

import mujoco
import numpy as np
import pytest
from mujoco import batch as mjbatch

import mjflex
from mjflex.runtime import registry as _callback
from tests.helpers import c_output
from tests.models import B_DEMO, K_DEMO, two_body_spec

STEPS = 200


pytestmark = pytest.mark.usefixtures("clean_callback")


def _qvel(model, seed):
    return np.random.default_rng(seed).normal(size=model.nv)


def _simulate(flex, qvel, steps=STEPS, model=None):
    """qpos after ``steps`` steps of ``model`` (default flex.model) from rest with velocity ``qvel``."""
    model = flex.model if model is None else model
    data = mujoco.MjData(model)
    data.qvel[:] = qvel
    with flex:
        for _ in range(steps):
            mujoco.mj_step(model, data)
    return data.qpos.copy()


def _diverge(flex):
    """The error a NaN velocity of body B raises (auto-reset disabled in the model)."""
    data = mujoco.MjData(flex.model)
    data.qvel[6] = np.nan
    try:
        with flex:
            mujoco.mj_forward(flex.model, data)
    except mujoco.FatalError as exc:
        return str(exc)
    return "no error"


def _model(**kwargs):
    return two_body_spec(B=B_DEMO, integrator="Euler", **kwargs).compile()


# ------------------------------------------------------------------ pickling (other processes)


def test_pickled_provider_runs_identically_in_another_process():
    model = _model()
    model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_AUTORESET
    flex = mjflex.Flexures(model)
    flex.set_method("link", "dualquat")  # run-time switches travel too
    qvel = _qvel(model, 1)
    here = _simulate(flex, qvel)
    same = pickle.loads(pickle.dumps(flex))
    assert same.methods == ("dualquat",) and not same.installed
    assert np.array_equal(_simulate(same, qvel), here)
    spawn = multiprocessing.get_context("spawn")  # a fresh interpreter, as Dask, Ray or a pool on macOS use
    with concurrent.futures.ProcessPoolExecutor(1, mp_context=spawn) as pool:
        there = pool.submit(_simulate, flex, qvel).result(timeout=300)
        message = pool.submit(_diverge, flex).result(timeout=300)
    assert np.array_equal(there, here)
    assert message.startswith(
        "mjflex: flexure 'link' of model 'two_body' diverged in the step from t = 0 s (step index 0, counting from 0)"
    )


# ------------------------------------------------------------------ mujoco.batch.Batch


def _batch(model, qvels, nthread=2):
    batch = mjbatch.Batch(model, nsim=len(qvels), nthread=nthread)
    batch.qvel = np.array(qvels)
    return batch


def test_batch_gets_the_forces_bit_identical_to_a_serial_loop():
    model = _model()
    flex = mjflex.Flexures(model)
    qvels = [_qvel(model, seed) for seed in range(4)]
    serial = np.array([_simulate(flex, qvel) for qvel in qvels])
    plain = _batch(model, qvels)
    with flex:  # a Batch steps its own copy of the model, which a callback cannot tell from any other model
        plain.step(nstep=STEPS)
    assert np.abs(plain.qpos - serial).max() > 1e-3
    batch = _batch(model, qvels)
    flex.serve(batch)  # points the batch at flex.model (Batch.set_models)
    assert batch.models is model and flex.models == (model,)
    with flex:
        batch.step(nstep=STEPS)
    assert np.array_equal(batch.qpos, serial)


def test_batch_of_edited_copies():
    """Per-simulation parameters through Batch.set_models: each copy is served and checked."""
    model = _model()
    flex = mjflex.Flexures(model)
    copies = [copy.copy(model) for _ in range(3)]
    for i, c in enumerate(copies):
        c.opt.gravity[:] = [0.0, 0.0, -3.0 * i]
    qvels = [_qvel(model, seed) for seed in range(3)]
    batch = _batch(model, qvels)
    batch.set_models(copies)
    flex.serve(batch)
    assert flex.models == (model, *copies)
    with flex:
        batch.step(nstep=STEPS)
    serial = np.array([_simulate(flex, qvel, model=c) for qvel, c in zip(qvels, copies, strict=True)])
    assert np.array_equal(batch.qpos, serial)
    assert np.abs(serial[0] - serial[2]).max() > 1e-3  # the copies did differ
    other = two_body_spec(B=2 * B_DEMO, integrator="Euler").compile()
    with pytest.raises(mjflex.ModelError, match=r"model 0 given to serve\(\): the text record of flexure 'link'"):
        flex.serve([other])
    expanded = _batch(model, qvels)
    expanded.expand("opt.gravity")
    with pytest.raises(ValueError, match=r"per-simulation fields .* batch.set_models\(copies\)"):
        flex.serve(expanded)


def test_divergence_in_batch_threads(capfd):
    """Auto-reset on: a warning naming the element, then MuJoCo's reset; off: SimulationError naming it."""
    model = _model(timestep=0.5)  # Euler far beyond 2/omega_max: diverges within a few steps
    flex = mjflex.Flexures(model)
    batch = _batch(model, [_qvel(model, seed) for seed in range(4)])
    flex.serve(batch)
    with flex:
        batch.step(nstep=10)  # every simulation diverges; none raises, whichever thread runs it
    out = c_output(capfd)
    # MuJoCo's default handler writes its "WARNING: " prefix and the message in separate writes, so with two
    # threads printing at once a prefix can land beside another thread's message (seen under load): count the
    # messages themselves, each of which is written in one piece.
    assert out.count("mjflex: flexure 'link' of model 'two_body' diverged in the step from t = ") >= 4
    assert out.count("Nan, Inf or huge value in QACC") >= 4  # then MuJoCo's own handling: reset
    assert np.all(np.isfinite(batch.qpos)) and np.all(batch.time < 10 * 0.5)
    model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_AUTORESET
    batch.set_models(model)  # as Batch asks after editing a model
    batch.reset()
    batch.qvel = [_qvel(model, seed) for seed in range(4)]
    with flex, pytest.raises(mjbatch.SimulationError) as info:
        batch.step(nstep=10)
    assert info.value.ids.tolist() == [0, 1, 2, 3]
    assert all("flexure 'link' of model 'two_body' diverged in the step from t = " in batch.error(i) for i in range(4))


# ------------------------------------------------------------------ registry under threads


def test_installing_from_many_threads_while_another_steps():
    """Install/uninstall storms in 6 threads must not disturb a model stepped meanwhile in another."""
    models = [_model() for _ in range(7)]
    providers = [mjflex.Flexures(m) for m in models]
    qvel = _qvel(models[0], 5)
    reference = _simulate(providers[0], qvel, steps=2000)
    result = {}

    def step():
        result["qpos"] = _simulate(providers[0], qvel, steps=2000)

    def churn(p):
        for _ in range(300):
            with p:
                with p:
                    pass

    with providers[0]:
        threads = [threading.Thread(target=step)] + [threading.Thread(target=churn, args=(p,)) for p in providers[1:]]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
    assert np.array_equal(result["qpos"], reference)
    assert not _callback._IN_SLOT and _callback.slots_in_use() == 0  # the native registry is empty again
    assert mujoco.get_mjcb_passive() is None


def test_capacity_is_a_clear_error():
    model = _model()
    flex = mjflex.Flexures(model).serve([copy.copy(model) for _ in range(_callback.CAPACITY)])
    with pytest.raises(RuntimeError, match=r"mjflex serves at most 1024 models per process"):
        flex.install()
    assert not flex.installed and not _callback._IN_SLOT and mujoco.get_mjcb_passive() is None
    with flex.serve(flex.models[1:4]):  # fewer copies: fine
        assert flex.installed


def test_batch_of_models_with_different_elements():
    """A stiffness sweep in one Batch: each model has its own records, hence its own provider."""
    import contextlib

    models = [two_body_spec(K=s * K_DEMO, B=B_DEMO, integrator="Euler").compile() for s in (1.0, 2.0, 4.0)]
    providers = [mjflex.Flexures(m) for m in models]
    qvels = [_qvel(models[0], seed) for seed in range(3)]
    serial = np.array([_simulate(p, q) for p, q in zip(providers, qvels, strict=True)])
    batch = _batch(models[0], qvels)
    batch.set_models(models)  # each simulation steps a provider's own model: nothing to serve
    with contextlib.ExitStack() as stack:
        for p in providers:
            stack.enter_context(p)
        batch.step(nstep=STEPS)
    assert np.array_equal(batch.qpos, serial)
    assert np.abs(serial[0] - serial[2]).max() > 1e-3

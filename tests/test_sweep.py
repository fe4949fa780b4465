"""mjflex.sweep against a serial mj_step loop written here: in-process Batch, a spawn pool, Dask.

The reference loop builds each variant with MjSpec + the same edit function, steps it with
``mj_step`` in this thread and observes a copy of the data after ``mj_forward``: the sweep's
results must equal it bit for bit (``assert_array_equal``), whichever executor ran them.
"""

import copy
import json
import multiprocessing
import pickle
import re
import subprocess
import sys
from concurrent.futures import ProcessPoolExecutor, ThreadPoolExecutor

import mujoco
import numpy as np
import pytest
import xarray as xr

import mjflex
from mjflex.app.sweep import engine
from mjflex.mjcf.elements import edit_flexure
from tests.sweep_recipes import hinge_state, scale_hinge

MODEL = "models/two_body.xml"
RECIPE = mjflex.Recipe(MODEL, scale_hinge, keyframe="swing")
# 1e4 x the stiffness makes the 2e-5 s RK4 step unstable (omega h ~ 20): those variants diverge
GRID = {"k_scale": [0.5, 1e4, 1.0, 2.0], "b_scale": [0.0, 1.0]}
DURATION, SAMPLES = 0.002, 5  # 100 steps, observed every 25


def serial_loop(params, duration=DURATION, samples=SAMPLES, observe=hinge_state):
    """Observations of one variant at the sample times, or the exception its stepping raised / a NaN state."""
    spec = mujoco.MjSpec.from_file(MODEL)
    scale_hinge(spec, **params)
    model = spec.compile()
    flex = mjflex.Flexures(model)
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, 0)
    steps = round(duration / model.opt.timestep) // (samples - 1)
    out = []
    with flex:
        for k in range(samples):
            if k:
                for _ in range(steps):
                    mujoco.mj_step(model, data)
            seen = copy.copy(data)
            mujoco.mj_forward(model, seen)
            out.append(observe(model, flex, seen))
    return out


def assert_matches_loop(ds, grid=GRID):
    for k_scale in grid["k_scale"]:
        for b_scale in grid["b_scale"]:
            v = ds.sel(k_scale=k_scale, b_scale=b_scale)
            if k_scale > 100:
                continue  # the diverging ones: see test_divergence_is_flagged
            assert v["status"] == "ok", str(v["error"].values)
            for k, ref in enumerate(serial_loop({"k_scale": k_scale, "b_scale": b_scale})):
                for name, value in ref.items():
                    value = value[1] if isinstance(value, tuple) else value
                    np.testing.assert_array_equal(v[name].isel(time=k).values, value, err_msg=name)


@pytest.fixture(scope="module")
def in_process():
    with pytest.warns(RuntimeWarning, match="2 diverged of 8 variants"):
        return mjflex.sweep(RECIPE, GRID, DURATION, hinge_state, threads=2, progress=False, samples=SAMPLES)


@pytest.fixture(scope="module")
def pool():
    with ProcessPoolExecutor(2, mp_context=multiprocessing.get_context("spawn")) as executor:
        yield executor


def test_batch_bit_identical_to_serial_loop(in_process):
    ds = in_process
    assert ds["qpos"].dims == ("k_scale", "b_scale", "time", "qpos_0")
    assert ds["wrench"].dims == ("k_scale", "b_scale", "time", "component")
    np.testing.assert_array_equal(ds["time"], np.linspace(0, DURATION, SAMPLES))
    assert_matches_loop(ds)
    # the observed motion is not trivial: the hinge swings and stiffness changes the trajectory
    assert float(ds["energy"].sel(k_scale=1.0, b_scale=0.0).isel(time=-1)) > 0
    assert not np.array_equal(ds["qpos"].sel(k_scale=0.5), ds["qpos"].sel(k_scale=2.0))


def test_divergence_is_flagged(in_process):
    ds = in_process
    bad = ds.sel(k_scale=1e4)
    assert (bad["status"] == "diverged").all()
    assert np.isnan(bad["qpos"]).all() and np.isnan(bad["energy"]).all()  # never looks like a result
    assert (0 < bad["time_diverged"]).all() and (bad["time_diverged"] < DURATION).all()
    assert (bad["element"] == "hinge").all()
    # the provider reports the element before MuJoCo's bad-acceleration check fires
    assert str(bad["error"].values[0]).startswith(
        "mjflex: flexure 'hinge' of model 'two_body' diverged in the step from t = "
    )
    ok = ds.where(ds["k_scale"] != 1e4, drop=True)
    assert (ok["status"] == "ok").all() and (ok["error"] == "").all()
    # a plain loop agrees that this variant diverges (with auto-reset off, as in the sweep; with
    # MuJoCo's default auto-reset it would warn and silently restart from the keyframe)
    spec = mujoco.MjSpec.from_file(MODEL)
    scale_hinge(spec, k_scale=1e4)
    model = spec.compile()
    model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_AUTORESET
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, 0)
    with mjflex.Flexures(model), pytest.raises(mujoco.FatalError, match="flexure 'hinge'"):
        for _ in range(round(DURATION / model.opt.timestep)):
            mujoco.mj_step(model, data)


def _without_attrs(ds):
    """A shallow copy of ``ds`` without attributes, its own and its variables' (what xarray >= 2024.07 calls
    ``drop_attrs()``; written out so that the oldest xarray mjflex allows runs these tests too)."""
    out = ds.copy()
    out.attrs = {}
    for variable in out.variables.values():
        variable.attrs = {}
    return out


def test_divergence_flagged_whichever_thread_ran_it():
    # many diverging variants among stable ones, on 1 and 2 Batch threads: in a thread MuJoCo
    # started, a flexure can only warn; in the caller's thread the Batch reports an error
    rows = [{"k_scale": 1e4 if i % 2 else 1.0 + i, "b_scale": 1.0} for i in range(12)]
    with pytest.warns(RuntimeWarning, match="6 diverged of 12 variants"):
        results = [mjflex.sweep(RECIPE, rows, 0.001, hinge_state, threads=t, progress=False) for t in (1, 2)]
    for ds in results:
        np.testing.assert_array_equal(ds["status"], ["ok", "diverged"] * 6)
        assert np.isnan(ds["qpos"].sel(variant=ds["status"] == "diverged")).all()
    xr.testing.assert_identical(_without_attrs(results[0]), _without_attrs(results[1]))


def test_process_pool_bit_identical(in_process, pool):
    with pytest.warns(RuntimeWarning, match="diverged"):
        ds = mjflex.sweep(RECIPE, GRID, DURATION, hinge_state, executor=pool, progress=False, samples=SAMPLES,
                          chunk_size=3)  # fmt: skip
    assert ds.attrs["chunks"] == 3 and ds.attrs["executor"] == "ProcessPoolExecutor"
    xr.testing.assert_identical(_without_attrs(ds), _without_attrs(in_process))


def test_thread_pool_runs_chunks_concurrently_in_one_process(in_process):
    # 8 one-variant chunks on 3 threads, each a 2-thread Batch: the registry is shared
    with ThreadPoolExecutor(3) as executor, pytest.warns(RuntimeWarning, match="diverged"):
        ds = mjflex.sweep(RECIPE, GRID, DURATION, hinge_state, executor=executor, threads=2, progress=False,
                          samples=SAMPLES, chunk_size=1)  # fmt: skip
    assert ds.attrs["chunks"] == 8
    xr.testing.assert_identical(_without_attrs(ds), _without_attrs(in_process))


def test_dask_bit_identical(in_process):
    distributed = pytest.importorskip("distributed", reason="Dask is optional: pip install 'mjflex[dask]'")
    with (
        # one worker process (its start-up dominates this test) with 2 threads: chunks run concurrently there
        distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=True, dashboard_address=None) as cluster,
        distributed.Client(cluster) as client,
    ):
        with pytest.warns(RuntimeWarning, match="diverged"):
            ds = mjflex.sweep(RECIPE, GRID, DURATION, hinge_state, executor=client, progress=False, samples=SAMPLES)
    assert ds.attrs["executor"] == "ClientExecutor" and ds.attrs["chunks"] == 4  # 8 variants: 2 tasks per thread
    xr.testing.assert_identical(_without_attrs(ds), _without_attrs(in_process))


def energy(model, flex, data):
    return {"energy": flex.potential_energy(data), "qvel": data.qvel[6:].copy()}


def test_more_than_256_variants_run_in_parts():
    n = engine.PART_SIZE + 44
    rows = [{"k_scale": 0.5 + i / n} for i in range(n)]
    installed = len(engine.registry._IN_SLOT)
    ds = mjflex.sweep(RECIPE, rows, 4e-5, energy, progress=False)  # 2 steps each
    assert ds.attrs["registry_parts"] == 2
    assert (ds["status"] == "ok").all() and ds.sizes["variant"] == n
    assert len(engine.registry._IN_SLOT) == installed  # everything uninstalled again
    for i in (0, 255, 256, n - 1):  # both parts agree with the serial loop
        ref = serial_loop(rows[i], duration=4e-5, samples=2, observe=energy)[-1]
        assert ds["energy"].isel(variant=i).item() == ref["energy"]
        np.testing.assert_array_equal(ds["qvel"].isel(variant=i), ref["qvel"])
    np.testing.assert_array_equal(ds["k_scale"], [r["k_scale"] for r in rows])


def test_a_sweep_that_batch_cannot_step_runs_in_a_loop(in_process, monkeypatch):
    # Batch refuses Python physics callbacks (a user's, which mjflex's dispatcher then chains): the sweep steps each
    # variant in a loop instead, with the same results (the same C loop evaluates the elements either way)
    assert not engine.registry._IN_SLOT
    monkeypatch.setattr(engine, "_batch_usable", lambda: False)
    with pytest.warns(RuntimeWarning, match="diverged"):
        ds = mjflex.sweep(RECIPE, GRID, DURATION, hinge_state, progress=False, samples=SAMPLES)
    assert ds.attrs["stepping"] == "loop"
    assert in_process.attrs["stepping"] == "mujoco.batch.Batch"
    np.testing.assert_array_equal(ds["status"], in_process["status"])
    np.testing.assert_array_equal(ds["element"], in_process["element"])
    for name in ("qpos", "qvel", "energy"):
        np.testing.assert_allclose(ds[name], in_process[name], rtol=1e-9, atol=1e-12)


def bad_stiffness(spec, k):
    edit_flexure(spec, "hinge", K=[k, 40, 0.25, 5e6, 3e5, 1.5e6])


def test_invalid_variant_fails_alone_and_duration_zero_observes_initial_state():
    with pytest.warns(RuntimeWarning, match="1 failed of 2 variants"):
        ds = mjflex.sweep(mjflex.Recipe(MODEL, bad_stiffness), [{"k": 0.3}, {"k": -1.0}], 0.0, energy, progress=False)
    np.testing.assert_array_equal(ds["status"], ["ok", "failed"])
    assert "hinge" in str(ds["error"].values[1]) and np.isnan(ds["energy"].values[1])
    assert ds["energy"].values[0] == 0.0  # at rest in qpos0


def test_bad_input_is_named(pool):
    with pytest.raises(TypeError, match=r"cannot take the grid's parameters \['stiffness'\]"):
        mjflex.sweep(RECIPE, {"stiffness": [1.0]}, DURATION, hinge_state)
    with pytest.raises(ValueError, match="not a whole number of time steps"):
        mjflex.sweep(RECIPE, {"k_scale": [1.0]}, 1.5e-5, hinge_state, progress=False)
    with pytest.raises(ValueError, match="samples - 1 dividing 100"):
        mjflex.sweep(RECIPE, {"k_scale": [1.0]}, DURATION, hinge_state, samples=8, progress=False)
    with pytest.raises(ValueError, match=r"grid\['k_scale'\] repeats \[1.0\]"):
        mjflex.sweep(RECIPE, {"k_scale": [1.0, 1.0]}, DURATION, hinge_state)
    with pytest.raises(ValueError, match="reserved"):
        mjflex.sweep(RECIPE, {"time": [1.0]}, DURATION, hinge_state)
    with pytest.raises(TypeError, match="observe must be a function"):
        mjflex.sweep(RECIPE, {"k_scale": [1.0]}, DURATION, None)
    with pytest.raises(ZeroDivisionError) as err:
        mjflex.sweep(RECIPE, {"k_scale": [1.0]}, DURATION, lambda m, f, d: {"x": 1 / 0}, progress=False)
    assert "while observing variant 0 {'k_scale': 1.0}" in "\n".join(err.value.__notes__)
    with pytest.raises(TypeError, match=r"observe .* cannot be sent to worker processes"):
        mjflex.sweep(RECIPE, {"k_scale": [1.0]}, DURATION, lambda m, f, d: {"x": 1.0}, executor=pool, progress=False)
    with pytest.raises(FileNotFoundError, match="no such MJCF file"):
        mjflex.Recipe("models/missing.xml")


def test_recipe_pickles_and_import_mjflex_stays_light():
    assert pickle.loads(pickle.dumps(RECIPE)) == RECIPE
    code = "import sys, mjflex; assert 'xarray' not in sys.modules and 'mujoco.batch' not in sys.modules; mjflex.sweep"
    subprocess.run([sys.executable, "-c", code], check=True)


def test_command_line_sweep_on_arcade(tmp_path, capsys):
    from mjflex.app.cli import main

    main(["sweep", "--leaf-scale", "1,2", "--beta", "0", "--duration", "2e-4", "--samples", "3", "--quiet",
          "--out", str(tmp_path)])  # fmt: skip
    out = capsys.readouterr().out
    # the guide's first frequency for each leaf scale, computed here on the model file with the leaves scaled, by
    # the study's linearization (central differences of MuJoCo's qacc; independent of the sweep's normal modes)
    from mjflex.app.study._metrics import linearized_frequencies
    from mjflex.app.sweep.arcade import arcade_edit

    expected = {}
    for scale in (1, 2):
        spec = mujoco.MjSpec.from_file("models/arcade.xml")
        arcade_edit(spec, leaf_scale=scale, beta=0.0)
        model = spec.compile()
        expected[scale] = linearized_frequencies(model, mjflex.Flexures(model), model.qpos0).elastic[0]
    line = next(x for x in out.splitlines() if x.startswith("first natural frequency [Hz] by leaf scale:"))
    printed = {int(k): float(v) for k, v in re.findall(r"x([0-9.]+): ([0-9.]+)", line)}
    assert printed.keys() == {1, 2} and expected[2] > expected[1]  # stiffer leaves: a higher guide mode
    for scale, f in expected.items():
        assert printed[scale] == pytest.approx(f, abs=0.0051)  # printed to 0.01 Hz
    with open(tmp_path / "sweep_arcade.json") as f:
        recorded = json.load(f)["first_frequency_hz"]
    for scale, f in expected.items():  # full precision: the two linearizations agree to ~1e-8
        assert recorded[f"{scale:g}"] == pytest.approx(f, rel=1e-6)
    ds = xr.load_dataset(tmp_path / "sweep_arcade.nc")
    assert dict(ds.sizes) == {"leaf_scale": 2, "beta": 1, "time": 3} and (ds["status"] == "ok").all()
    assert (tmp_path / "sweep_arcade.png").stat().st_size > 10_000 and (tmp_path / "sweep_arcade.json").exists()
    with pytest.raises(SystemExit):
        main(["sweep", "--duration", "1.5e-5", "--quiet", "--out", str(tmp_path)])  # not whole steps

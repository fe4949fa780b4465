"""``mjflex.sweep(..., executor="warp")`` and ``python -m mjflex sweep --executor warp`` on Warp's CPU device,
against the in-process ``Batch`` executor (bit-identical to a serial loop: tests/test_sweep.py)."""

import re
import warnings

import mujoco
import numpy as np
import pytest
import warp as wp
import xarray as xr

import mjflex
from tests import warp_bounds as wb
from tests.sweep_recipes import hinge_state, scale_hinge, stop_hinge
from tests.test_sweep import DURATION, GRID, MODEL, RECIPE, SAMPLES


@pytest.fixture(scope="module", autouse=True)
def cpu():
    with wp.ScopedDevice("cpu"):
        yield


@pytest.fixture(scope="module")
def both():
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="mjflex.sweep: 2 diverged", category=RuntimeWarning)
        on_warp = mjflex.sweep(RECIPE, GRID, DURATION, hinge_state, executor="warp", progress=False, samples=SAMPLES)
        on_batch = mjflex.sweep(RECIPE, GRID, DURATION, hinge_state, progress=False, samples=SAMPLES)
    return on_warp, on_batch


def test_same_labelled_results_as_batch(both):
    """Same variables, dimensions, coordinates, statuses; the diverged variants flagged with the same element and
    time; the observed values of the others within the float32 bound of each observation.

    The bound: the trajectory's float32 bound (tests/test_warp.py::test_trajectories_match_the_c_engine: 10
    roundings of u per step, propagated by the C engine in float64) carried to each observed value through its
    sensitivity to the state (central differences).
    """
    on_warp, on_batch = both
    assert on_warp.attrs["executor"] == "warp" and on_warp.attrs["stepping"] == "mujoco_warp"
    assert set(on_warp.data_vars) == set(on_batch.data_vars)
    for name in on_batch.data_vars:
        assert on_warp[name].dims == on_batch[name].dims and on_warp[name].shape == on_batch[name].shape, name
    xr.testing.assert_equal(on_warp["status"], on_batch["status"])
    xr.testing.assert_equal(on_warp["element"], on_batch["element"])
    xr.testing.assert_equal(on_warp["time_diverged"], on_batch["time_diverged"])
    steps = round(DURATION / 2e-5)
    sample_steps = [k * steps // (SAMPLES - 1) for k in range(1, SAMPLES)]
    worst = 0.0
    for k_scale in GRID["k_scale"]:
        for b_scale in GRID["b_scale"]:
            w, b = (ds.sel(k_scale=k_scale, b_scale=b_scale) for ds in (on_warp, on_batch))
            if str(b["status"].values) != "ok":
                error = str(w["error"].values)
                assert re.match(r"mjflex\.warp: world \d+ \(variant \d+\) diverged", error), error
                assert "flexure 'hinge'" in error
                continue
            for name in ("qpos", "qvel", "wrench", "energy"):  # the initial state is observed as it is
                np.testing.assert_array_equal(w[name].isel(time=0), b[name].isel(time=0))
            spec = mujoco.MjSpec.from_file(MODEL)
            scale_hinge(spec, k_scale=k_scale, b_scale=b_scale)
            model = spec.compile()
            data = mujoco.MjData(model)
            mujoco.mj_resetDataKeyframe(model, data, 0)
            bounds = wb.observation_bounds(model, mjflex.Flexures(model), data.qpos, data.qvel, sample_steps,
                                           hinge_state)  # fmt: skip
            for t, bound in enumerate(bounds, start=1):
                for name, limit in bound.items():
                    err = np.abs(w[name].isel(time=t).values - b[name].isel(time=t).values)
                    assert (err <= limit).all(), (k_scale, b_scale, t, name, err, limit)
                    worst = max(worst, float(np.max(err / np.maximum(limit, 1e-300))))
    print(f"largest error / bound: {worst:.2g}")


def denser_b(spec, density_scale=1.0, contype=0):
    """Scale the density of block B's geom (its mass and inertia), set its contype (the pair is excluded: no
    effect on the motion)."""
    geom = spec.body("B").geoms[0]
    geom.density, geom.contype = 2700.0 * density_scale, contype


def test_variants_that_cannot_share_a_model_run_in_groups_of_their_own():
    """Variants whose models differ in what MuJoCo Warp keeps per world (B's mass and inertia) share one batch; a
    variant that differs in what it does not (a geom's contype) runs in a batch of its own. All agree with Batch
    within the float32 bound of test_same_labelled_results_as_batch."""
    recipe = mjflex.Recipe(MODEL, denser_b, keyframe="swing")
    grid = [{"density_scale": 1.0, "contype": 0}, {"density_scale": 2.0, "contype": 0},
            {"density_scale": 1.0, "contype": 1}]  # fmt: skip
    duration = 4e-4  # 20 steps
    ds = mjflex.sweep(recipe, grid, duration, hinge_state, executor="warp", progress=False)
    ref = mjflex.sweep(recipe, grid, duration, hinge_state, progress=False)
    assert ds.attrs["warp_batches"] == 2 and (ds["status"] == "ok").all()
    assert not np.array_equal(ds["qvel"].values[0], ds["qvel"].values[1])  # the mass mattered
    for i, params in enumerate(grid):
        spec = mujoco.MjSpec.from_file(MODEL)
        denser_b(spec, **params)
        model = spec.compile()
        data = mujoco.MjData(model)
        mujoco.mj_resetDataKeyframe(model, data, 0)
        (bound,) = wb.observation_bounds(model, mjflex.Flexures(model), data.qpos, data.qvel, [20], hinge_state)
        for name, limit in bound.items():
            assert (np.abs(ds[name].values[i] - ref[name].values[i]) <= limit).all(), (i, name)


def test_variants_with_different_end_stops_share_one_batch():
    """Variants that differ in their element's end stops (none; +-0.02 rad on the hinge's rotation with the derived
    and with a given stiffness; +-0.03 rad) are the worlds of one batch, with per-world stops; the swing runs into
    them (the stops change the motion), and every variant agrees with Batch within the float32 bound of
    test_same_labelled_results_as_batch."""
    recipe = mjflex.Recipe(MODEL, stop_hinge, keyframe="swing")
    grid = [{"limit": 0.0, "stiffness": 0.0}, {"limit": 0.02, "stiffness": 0.0}, {"limit": 0.02, "stiffness": 250.0},
            {"limit": 0.03, "stiffness": 250.0}]  # fmt: skip
    steps = (50, 100, 150)
    duration = steps[-1] * 2e-5
    ds = mjflex.sweep(recipe, grid, duration, hinge_state, executor="warp", progress=False, samples=len(steps) + 1)
    ref = mjflex.sweep(recipe, grid, duration, hinge_state, progress=False, samples=len(steps) + 1)
    assert ds.attrs["warp_batches"] == 1 and (ds["status"] == "ok").all()
    final = ds["qvel"].values[:, -1]
    assert all(not np.allclose(final[0], final[i], rtol=1e-3) for i in (1, 2, 3)), "the stops did not act"
    for i, params in enumerate(grid):
        spec = mujoco.MjSpec.from_file(MODEL)
        stop_hinge(spec, **params)
        model = spec.compile()
        data = mujoco.MjData(model)
        mujoco.mj_resetDataKeyframe(model, data, 0)
        bounds = wb.observation_bounds(model, mjflex.Flexures(model), data.qpos, data.qvel, steps, hinge_state)
        for t, bound in enumerate(bounds, start=1):
            for name, limit in bound.items():
                err = np.abs(ds[name].values[i][t] - ref[name].values[i][t])
                assert (err <= limit).all(), (i, t, name, err, limit)


def test_command_line_sweep_on_arcade(tmp_path, capsys):
    """``python -m mjflex sweep --executor warp --device cpu``: the ARCADE sweep's files, its variants ok, the strokes
    and energies within the float32 bound of the Batch executor's (as test_same_labelled_results_as_batch)."""
    from mjflex.app.cli import main
    from mjflex.app.sweep.arcade import arcade_edit, arcade_stroke

    args = ["sweep", "--leaf-scale", "1,2", "--beta", "0", "--duration", "2e-4", "--samples", "3", "--quiet"]
    main([*args, "--executor", "warp", "--device", "cpu", "--out", str(tmp_path / "warp")])
    main([*args, "--out", str(tmp_path / "batch")])
    assert "peak stroke [mm] (warp" in capsys.readouterr().out
    on_warp, on_batch = (xr.load_dataset(tmp_path / k / "sweep_arcade.nc") for k in ("warp", "batch"))
    assert on_warp.attrs["executor"] == "warp" and (on_warp["status"] == "ok").all()
    assert on_warp.sizes == on_batch.sizes
    for scale in (1.0, 2.0):
        spec = mujoco.MjSpec.from_file("models/arcade.xml")
        arcade_edit(spec, leaf_scale=scale, beta=0.0)
        model = spec.compile()
        data = mujoco.MjData(model)
        mujoco.mj_resetDataKeyframe(model, data, model.key("paper_run").id)
        bounds = wb.observation_bounds(model, mjflex.Flexures(model), data.qpos, data.qvel, [10, 20], arcade_stroke)
        for t, bound in enumerate(bounds, start=1):
            for name, limit in bound.items():
                got = on_warp[name].sel(leaf_scale=scale, beta=0.0).isel(time=t).values
                want = on_batch[name].sel(leaf_scale=scale, beta=0.0).isel(time=t).values
                assert abs(got - want) <= limit, (scale, t, name, got, want, limit)
    with pytest.raises(SystemExit):
        main([*args, "--device", "cpu", "--out", str(tmp_path)])  # --device without --executor warp

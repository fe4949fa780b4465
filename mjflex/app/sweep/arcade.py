"""The ARCADE sweep of ``python -m mjflex sweep``: cylinder stroke vs leaf stiffness and damping.

The paper's run (105 rad/s spin plus 5 m/s of the cylinder along the axis, keyframe
``paper_run``) is simulated for each leaf-spring stiffness scale and Rayleigh damping factor
``beta`` (``B = beta K`` for every flexure). The observed quantity is the stroke: the axial
position of the cylinder relative to the base, in the base's frame. Variants whose damping is
too stiff for the explicit time step diverge, and the sweep flags them. A second sweep with
duration 0 gives the guide's first (undamped) natural frequency for each leaf stiffness.
"""

import json
import os
import time
import warnings

import numpy as np

from ...mjcf.elements import edit_flexure, flexure_matrices, spec_elements
from ..arcade import arcade_source
from .recipe import Recipe


def arcade_edit(spec, leaf_scale=1.0, beta=2e-6):
    """Scale the 12 leaf springs' stiffness by ``leaf_scale``; damping ``B = beta K`` [s] for all 48 flexures."""
    if not (leaf_scale > 0 and beta >= 0):
        raise ValueError(f"leaf_scale must be > 0 and beta >= 0; got {leaf_scale!r}, {beta!r}")
    for element in [e.name for e in spec_elements(spec)]:  # text records or plugin instances alike
        K, _ = flexure_matrices(spec, element)
        if element.startswith("leaf_"):
            K = leaf_scale * K
        edit_flexure(spec, element, K=K, B=beta * K)


def arcade_stroke(model, flex, data):
    """Axial position of the cylinder relative to the base, in the base frame [m], and the flexures' energy [J]."""
    base, cylinder = model.body("base").id, model.body("cylinder").id
    R = data.xmat[base].reshape(3, 3)
    return {
        "stroke": float((R.T @ (data.xpos[cylinder] - data.xpos[base]))[2]),
        "elastic_energy": flex.potential_energy(data),
    }


def first_frequency(model, flex, data):
    """The lowest non-rigid natural frequency [Hz], linearized about ``qpos0`` (``data`` unused)."""
    from ...analysis.linearize import normal_modes  # late: modal analysis, only for the duration-0 sweep
    from ..modes import RIGID_TOL_HZ  # late: with normal_modes above

    freq, _ = normal_modes(model, flex)
    return {"first_frequency": float(freq[freq >= RIGID_TOL_HZ][0])}


def arcade_recipe() -> Recipe:
    """The recipe on ``models/arcade.xml`` (or the model built in memory, as text): :func:`..arcade.arcade_source`."""
    source, _ = arcade_source()
    return Recipe(source if isinstance(source, str) else source.to_xml(), arcade_edit, keyframe="paper_run")


def make_executor(kind, workers, device=None):
    """``(executor, closer)`` for ``kind`` in ``{"batch", "pool", "dask", "warp"}`` (``device``: Warp's, for warp)."""
    if kind == "batch":
        return None, lambda: None
    if kind == "warp":
        try:
            import warp  # late: the warp extra, for --executor warp only
        except ImportError:
            raise SystemExit('error: --executor warp needs MuJoCo Warp: pip install "mjflex[warp]"') from None
        if device is None:
            return "warp", lambda: None
        scope = warp.ScopedDevice(device)
        scope.__enter__()
        return "warp", lambda: scope.__exit__(None, None, None)
    if kind == "pool":
        import multiprocessing  # late: for --executor pool only
        from concurrent.futures import ProcessPoolExecutor  # late: for --executor pool only

        pool = ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("spawn"))
        return pool, pool.shutdown
    try:
        from distributed import Client, LocalCluster  # late: the dask extra, for --executor dask only
    except ImportError:
        raise SystemExit('error: --executor dask needs Dask: pip install "mjflex[dask]"') from None
    cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None)
    client = Client(cluster)

    def close():
        client.close()
        cluster.close()

    return client, close


def peak_stroke(ds):
    """Largest |stroke - initial stroke| over the run, per variant [m] (NaN where not ok)."""
    s = ds["stroke"]
    return abs(s - s.isel(time=0)).max("time", skipna=False)


def plot(ds, modes, path):
    """Stroke history at the reference damping, peak stroke vs leaf scale for every beta, first frequency."""
    import matplotlib  # late: matplotlib, only for the figure

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # late: after the Agg backend is chosen

    fig, (ax1, ax2, ax3) = plt.subplots(1, 3, figsize=(15, 4.2), constrained_layout=True)
    betas = ds["beta"].values
    ok_beta = [b for b in betas if (ds["status"].sel(beta=b) == "ok").all()]
    ref = ok_beta[len(ok_beta) // 2] if ok_beta else betas[0]
    for scale in ds["leaf_scale"].values:
        s = ds["stroke"].sel(leaf_scale=scale, beta=ref)
        ax1.plot(ds["time"] * 1e3, (s - s.isel(time=0)) * 1e3, label=f"leaf x{scale:g}")
    ax1.set(xlabel="time [ms]", ylabel="stroke [mm]", title=f"cylinder stroke, beta = {ref:g} s")
    ax1.legend(fontsize=8)
    peak = peak_stroke(ds) * 1e3
    for b in betas:
        line = ax2.plot(ds["leaf_scale"], peak.sel(beta=b), "o-", label=f"beta = {b:g} s")[0]
        bad = ds["leaf_scale"].values[(ds["status"].sel(beta=b) != "ok").values]
        if bad.size:
            ax2.plot(bad, np.zeros_like(bad), "x", ms=10, mew=2, color=line.get_color())
    ax2.set(xscale="log", xlabel="leaf-spring stiffness scale", ylabel="peak stroke [mm]",
            title="peak stroke (x on the axis: diverged, no result)")  # fmt: skip
    ax3.plot(modes["leaf_scale"], modes["first_frequency"], "o-", color="k")
    ax3.set(xscale="log", xlabel="leaf-spring stiffness scale", ylabel="frequency [Hz]",
            title="first natural frequency (linearized at rest)")  # fmt: skip
    for ax in (ax2, ax3):
        ax.set_xticks(ds["leaf_scale"].values, [f"{v:g}" for v in ds["leaf_scale"].values])
        ax.minorticks_off()
    ax2.legend(fontsize=8)
    fig.suptitle(f"ARCADE sweep: {ds.sizes['leaf_scale']} x {ds.sizes['beta']} variants, "
                 f"{ds.attrs['duration_s'] * 1e3:g} ms of the paper's run each")  # fmt: skip
    fig.savefig(path, dpi=120)
    plt.close(fig)


def summary(ds, modes) -> dict:
    """Per-variant peak stroke and status, first frequencies, and the run's attributes (for JSON)."""
    peak = peak_stroke(ds)
    rows = []
    for scale in ds["leaf_scale"].values:
        for b in ds["beta"].values:
            v = ds.sel(leaf_scale=scale, beta=b)
            p = float(peak.sel(leaf_scale=scale, beta=b))
            rows.append({"leaf_scale": float(scale), "beta": float(b), "status": str(v["status"].values),
                         "peak_stroke_m": None if np.isnan(p) else p, "error": str(v["error"].values)})  # fmt: skip
    freq = {
        f"{s:g}": float(f) for s, f in zip(modes["leaf_scale"].values, modes["first_frequency"].values, strict=True)
    }
    return {"attrs": dict(ds.attrs), "variants": rows, "first_frequency_hz": freq}


def run_arcade_sweep(out, *, leaf_scale, beta, duration, samples, executor="batch", workers=2, device=None,
                     threads=None, progress=True, provenance=None) -> dict:  # fmt: skip
    """The ``sweep`` command: ARCADE over ``leaf_scale`` x ``beta``, the results written and printed; returns the JSON.

    Writes ``sweep_arcade.nc`` (the Dataset), ``.png`` (:func:`plot`) and ``.json`` (:func:`summary`,
    with ``provenance``: the command line and date) to folder ``out`` (created if missing). ``executor``
    as :func:`make_executor`; ``threads``, ``samples`` and ``progress`` as :func:`mjflex.sweep`.
    """
    from .api import sweep  # late: xarray and tqdm, only when the sweep runs

    started = time.perf_counter()
    executor_name, (executor, close) = executor, make_executor(executor, workers, device)
    recipe = arcade_recipe()
    try:
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", message="mjflex.sweep: ", category=RuntimeWarning)  # listed below instead
            grid = {"leaf_scale": leaf_scale, "beta": beta}
            ds = sweep(recipe, grid, duration, arcade_stroke, executor=executor, threads=threads, progress=progress,
                       samples=samples)  # fmt: skip
            modes = sweep(recipe, {"leaf_scale": leaf_scale}, 0.0, first_frequency, executor=executor,
                          threads=threads, progress=False)  # fmt: skip
    finally:
        close()
    os.makedirs(out, exist_ok=True)  # checked by the command line before the run; made once there are results
    stem = os.path.join(out, "sweep_arcade")
    ds.to_netcdf(stem + ".nc")
    plot(ds, modes, stem + ".png")
    info = {**(provenance or {}), "command_wall_s": round(time.perf_counter() - started, 1), **summary(ds, modes)}
    with open(stem + ".json", "w") as f:
        json.dump(info, f, indent=2)
    print("first natural frequency [Hz] by leaf scale:", ", ".join(f"x{k}: {v:.2f}" for k, v in
                                                               info["first_frequency_hz"].items()))  # fmt: skip
    peak = peak_stroke(ds) * 1e3
    print(f"peak stroke [mm] ({executor_name}, {ds.attrs['wall_time_s']:.2f} s wall):")
    print(peak.to_pandas().to_string(float_format=lambda x: f"{x:.3f}", na_rep="diverged"))
    for v in info["variants"]:
        if v["status"] != "ok":
            print(f"leaf x{v['leaf_scale']:g}, beta {v['beta']:g}: {v['status']}: {v['error']}")
    print(f"wrote {stem}.nc, {stem}.png, {stem}.json")
    return info

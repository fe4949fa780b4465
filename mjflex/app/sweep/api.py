"""``mjflex.sweep``: run a grid of model variants in this process, a process pool, or on Dask."""

import concurrent.futures as cf
import math
import os
import time
import warnings
from collections.abc import Callable

import mujoco
import numpy as np

from . import engine
from .grid import make_grid
from .recipe import Recipe
from .result import assemble, schema_of, summary_line

PROBE_ATTEMPTS = 5
#: ``executor=WARP``: the variants as the worlds of MuJoCo Warp batches (:mod:`.warp`; ``pip install "mjflex[warp]"``).
WARP = "warp"


def _probe(plan, grid):
    """Build the first buildable variant and observe its initial state: the observation schema.

    Errors in the recipe or ``observe`` are raised here, before any work is sent out.
    """
    first = None
    for index, params in enumerate(grid.rows[:PROBE_ATTEMPTS]):
        try:
            sim = engine._Sim(plan, index, params)
        except Exception as exc:
            exc.add_note(f"mjflex.sweep: while building variant {index} {params}")
            first = first or exc
            continue
        data = sim.initial_data()
        with engine.installed([sim.flex]):
            mujoco.mj_forward(sim.model, data)
            try:
                values = sim.values(plan.observe, data)
            except Exception as exc:
                exc.add_note(f"mjflex.sweep: while observing variant {index} {params} at its initial state")
                raise
        if not values:
            raise ValueError("observe returned an empty dict; return at least one named value")
        return schema_of(values)
    raise first


def _workers(executor) -> int:
    """Parallel workers an executor offers (for chunking); os.cpu_count() when it does not say."""
    client = getattr(executor, "_client", None)
    if client is not None and hasattr(client, "nthreads"):
        return max(1, sum(client.nthreads().values()))
    return int(getattr(executor, "_max_workers", 0) or os.cpu_count() or 1)


def _chunks(n, executor, chunk_size):
    if chunk_size is None:
        chunk_size = min(engine.PART_SIZE, max(1, math.ceil(n / (2 * _workers(executor)))))
    return [range(start, min(n, start + chunk_size)) for start in range(0, n, chunk_size)]


def _progress_bar(enabled, total):
    if not enabled:
        return None
    from tqdm.auto import tqdm  # late: tqdm, only with a progress bar

    fmt = "{desc}: {percentage:3.0f}%|{bar}| {n:.1f}/{total:.0f} variants [{elapsed}<{remaining}]"
    return tqdm(total=total, desc="mjflex.sweep", smoothing=0.1, bar_format=fmt)


def _check_args(duration, samples, threads, chunk_size, observe):
    if not callable(observe):
        raise TypeError(f"observe must be a function observe(model, flex, data) -> dict; got {observe!r}")
    if not (isinstance(duration, int | float) and np.isfinite(duration) and duration >= 0):
        raise ValueError(f"duration must be a finite number of seconds >= 0; got {duration!r}")
    if samples is not None:
        if not isinstance(samples, int) or isinstance(samples, bool) or samples < 2:
            raise ValueError(f"samples must be None (observe once, at the end) or an integer >= 2; got {samples!r}")
        if duration == 0:
            raise ValueError("samples needs a duration > 0 (with duration 0 the initial state is observed once)")
    if threads is not None and not (isinstance(threads, int) and threads >= 0):
        raise ValueError(f"threads must be None or an integer >= 0 (0: all CPUs); got {threads!r}")
    if chunk_size is not None and not (
        isinstance(chunk_size, int) and not isinstance(chunk_size, bool) and chunk_size >= 1
    ):
        raise ValueError(f"chunk_size must be a positive integer; got {chunk_size!r}")


def _run_executor(executor, plan, grid, chunk_size, bar):
    chunks = _chunks(len(grid), executor, chunk_size)
    futures = {executor.submit(engine.run_chunk, plan, [(i, grid.rows[i]) for i in c]): c for c in chunks}
    outcomes, stats = [None] * len(grid), {"parts": 0, "stepping": set()}
    for future in cf.as_completed(futures):
        chunk = futures[future]
        try:
            done, got = future.result()
            stats["parts"] += got["parts"]
            stats["stepping"] |= got["stepping"]
        except Exception as exc:  # the worker itself failed (e.g. the process died): flag its variants
            message = f"the worker running variants {chunk.start}..{chunk.stop - 1} failed: {engine._exc_text(exc)}"
            done = [engine.Outcome(i, "failed", message) for i in chunk]
        for o in done:
            outcomes[o.index] = o
        if bar is not None:
            bar.update(len(chunk))
    return outcomes, len(chunks), stats


_WARNED = set()  # deprecated argument names used (each warns once)


def _renamed_recipe(recipe, variants):
    """``recipe``, or what was given as ``variants=`` (its name until 1.0: warns once); TypeError without either."""
    if variants is not None:
        if recipe is not None:
            raise TypeError("sweep() got both recipe and variants (its old name); give recipe")
        if "variants" not in _WARNED:
            _WARNED.add("variants")
            warnings.warn("mjflex.sweep(variants=...) is deprecated; use mjflex.sweep(recipe=...)", DeprecationWarning,
                          stacklevel=3)  # fmt: skip
        recipe = variants
    if recipe is None:
        raise TypeError("sweep() needs the model family: a mjflex.Recipe, a model file or MJCF text (recipe=)")
    return recipe


def sweep(
    recipe=None,
    grid=None,
    duration: float = 0.0,
    observe: Callable | None = None,
    executor=None,
    threads: int | None = None,
    progress: bool = True,
    *,
    samples: int | None = None,
    chunk_size: int | None = None,
    variants=None,
):
    """Simulate every variant of a model family over a grid of parameters and observe each.

    Parameters
    ----------
    recipe : Recipe, str or os.PathLike
        The model family: a :class:`mjflex.Recipe` (source model + module-level
        ``edit(spec, **params)``), or a model file / MJCF text alone (then ``grid`` is empty).
        (Named ``variants`` until 1.0.)
    grid : dict or list of dict, optional
        A dict of 1-D value arrays varies every combination (the result has one dimension
        per parameter, in this order); a list of dicts gives explicit variants (one dimension
        ``variant``, each parameter a coordinate along it). Values are numbers, booleans or
        strings, passed to ``edit`` as keyword arguments. None: one variant.
    duration : float
        Simulated time of every variant [s]; a whole number of each variant's time steps.
        0 observes the initial state only (e.g. for modal analysis).
    observe : callable
        ``observe(model, flex, data) -> dict`` of named numbers or arrays (fixed shape; a value
        may be ``(dims, array)`` to name its dimensions). Runs on the worker after
        ``mj_forward`` at the observed state, with ``flex`` the variant's installed
        :class:`mjflex.Flexures`. With an executor it must be a module-level function.
    executor : concurrent.futures.Executor, distributed.Client or "warp", optional
        None (default): this process, each chunk of variants stepped by MuJoCo's
        ``mujoco.batch.Batch`` on ``threads`` threads. ``"warp"``: this process, the variants
        as the worlds of MuJoCo Warp batches on Warp's default device (a GPU if there is one;
        choose with ``warp.ScopedDevice``), in float32 (:mod:`mjflex.app.sweep.warp` says what
        may vary per world). Otherwise chunks of variants are
        submitted to the executor (e.g. ``ProcessPoolExecutor(mp_context=spawn)`` or Dask's
        ``client.get_executor()``; a Client is accepted as is); the recipe and ``observe``
        travel, and each worker builds its models.
    threads : int, optional
        ``Batch`` threads per process: default all CPUs in this process, 1 per worker.
    progress : bool
        Show a progress bar (tqdm) on stderr.
    samples : int, optional
        Observe at ``samples`` equally spaced times from 0 to ``duration`` (a ``time``
        dimension); ``samples - 1`` must divide each variant's step count. Default: once, at
        the end.
    chunk_size : int, optional
        Variants per task sent to an executor (default: about two tasks per worker, at most
        256); with ``"warp"``, the variants built and stepped at once, as the worlds of
        MuJoCo Warp batches (default 512). Otherwise a process builds and steps at most 256
        variants at once (fewer if its flexure registry, 1024 models, has less room): larger
        sweeps and chunks run in parts, automatically.
    variants : Recipe, str or os.PathLike, optional
        Deprecated: the old name of ``recipe``, which warns once (in mjflex a variant is a
        :class:`mjflex.Variant`, what ``mjflex.study(variants=...)`` compares).

    Returns
    -------
    xarray.Dataset
        One variable per observed name (float64, NaN where the variant is not ok) over the
        grid's dimensions (then ``time``, then the value's own), and per variant ``status``
        (``"ok"``, ``"diverged"``, ``"failed"``), ``error`` (the message, naming the element
        and time of a divergence), ``element`` and ``time_diverged`` [s]. ``attrs`` record the
        recipe, duration, executor, chunks and wall time.

    Notes
    -----
    Results are bit-identical to a serial ``mj_step`` loop over the same variants, whichever
    executor and thread count ran them (tested); with ``"warp"`` they agree within float32's
    effect on the trajectory (tested against perturbed float64 runs). Auto-reset is switched off in every variant
    (``mjDSBL_AUTORESET``) so that a diverged run stays non-finite; a divergence is flagged and
    never stops the sweep. Errors in the recipe or ``observe`` surface before any work is
    sent out: the first variant is built and observed at its initial state in this process.

    Examples
    --------
    A block on a leaf spring, pushed into a rocking motion, with two stiffnesses of the spring; the rocking angle
    observed at three times:

    >>> import mujoco
    >>> import mjflex
    >>> spec = mujoco.MjSpec.from_string(
    ...     '<mujoco><option timestep="1e-4"/><worldbody><body name="block" pos="0 0 -0.1"><freejoint/>'
    ...     '<geom type="box" size="0.02 0.02 0.02" mass="0.5"/></body></worldbody>'
    ...     '<keyframe><key name="push" qvel="0 0 0 1 0 0"/></keyframe></mujoco>'
    ... )
    >>> _ = mjflex.add_flexure(spec, "leaf", "world", "block", pos=[0, 0, -0.05], K=[2, 2, 1, 1e4, 1e4, 1e4])
    >>> from mjflex.app.sweep import edit_flexure, flexure_matrices
    >>> def stiffer(spec, scale):  # edit(spec, **params): one variant
    ...     K, _ = flexure_matrices(spec, "leaf")
    ...     edit_flexure(spec, "leaf", K=scale * K)
    >>> def rocking(model, flex, data):  # observe(model, flex, data) -> dict of numbers or arrays
    ...     return {"angle": flex.displacements(data)[0, 0]}
    >>> recipe = mjflex.Recipe(spec.to_xml(), stiffer, keyframe="push")
    >>> ds = mjflex.sweep(recipe, {"scale": [1.0, 4.0]}, 0.05, rocking, samples=3, progress=False)
    >>> ds["angle"].dims, ds["status"].values.tolist()
    (('scale', 'time'), ['ok', 'ok'])
    >>> bool(abs(ds["angle"]).max() < 0.01)  # a stiffer spring rocks less; both well below 1 rad
    True
    """
    start = time.perf_counter()
    recipe = _renamed_recipe(recipe, variants)
    recipe = recipe if isinstance(recipe, Recipe) else Recipe(recipe)
    _check_args(duration, samples, threads, chunk_size, observe)
    g = make_grid(grid)
    recipe.check_parameters(g.names)
    on_warp = isinstance(executor, str) and executor == WARP
    if isinstance(executor, str) and not on_warp:
        raise ValueError(f'executor must be an Executor, a Dask Client, None or "{WARP}"; got {executor!r}')
    if executor is not None and hasattr(executor, "get_executor"):  # a distributed.Client
        executor = executor.get_executor()
    if executor is not None and not on_warp and not hasattr(executor, "submit"):
        raise TypeError(f'executor must be a concurrent.futures.Executor, a Dask Client or "{WARP}"; got {executor!r}')
    in_process = executor is None or on_warp
    plan = engine.Plan(recipe, observe, float(duration), samples, (threads if threads is not None else 0)
                       if in_process else (threads or 1))  # fmt: skip
    schema = _probe(plan, g)
    if not (in_process or isinstance(executor, cf.ThreadPoolExecutor)):  # these cross a process boundary
        recipe.check_picklable(observe, cloud=type(executor).__module__.startswith("distributed"))
    bar = _progress_bar(progress, len(g))
    blocks = 1 if samples is None else samples - 1
    try:
        if in_process:
            tick = None if bar is None else (lambda k: bar.update(k / blocks))
            if on_warp:
                from . import warp  # late: imports warp (the warp extra), for its executor only

                outcomes, stats = engine.run_chunk(plan, list(enumerate(g.rows)), tick, run_part=warp.run_part,
                                                   part_size=chunk_size or warp.PART_SIZE)  # fmt: skip
            else:
                outcomes, stats = engine.run_chunk(plan, list(enumerate(g.rows)), tick)
            chunks = 1
        else:
            outcomes, chunks, stats = _run_executor(executor, plan, g, chunk_size, bar)
    finally:
        if bar is not None:
            bar.close()
    times = None if samples is None else np.linspace(0.0, duration, samples)
    attrs = {
        "recipe": recipe.describe(), "duration_s": float(duration), "samples": samples or 0,
        "executor": WARP if on_warp else "this process" if in_process else type(executor).__name__,
        "stepping": ", ".join(sorted(stats["stepping"])) or "none (duration 0)",
        "threads": plan.threads, "chunks": chunks, "registry_parts": stats["parts"],
        "wall_time_s": time.perf_counter() - start, "mujoco_version": mujoco.__version__,
    }  # fmt: skip
    if on_warp:
        attrs["warp_batches"] = stats["warp_batches"]  # MuJoCo Warp batches the variants were grouped into
    ds = assemble(g, outcomes, schema, times, attrs)
    line = summary_line(ds)
    if line:
        warnings.warn(f"mjflex.sweep: {line}; see the result's status and error", RuntimeWarning, stacklevel=2)
    return ds

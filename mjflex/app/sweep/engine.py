"""One process's share of a sweep: build variants, step them (MuJoCo's ``Batch`` or a loop), observe.

:func:`run_chunk` is what a worker process (or this one) runs; it is a module-level function of
picklable arguments, so any ``concurrent.futures`` executor can call it. A chunk is run in
parts of at most :data:`PART_SIZE` variants (fewer when the process's flexure registry has less
room), one ``Batch`` per part: the models of a part are built, served, stepped, observed and
released before the next part is built.

A variant that diverges is flagged, never raised: MuJoCo's ``Batch`` reports a ``mju_error`` of
some simulations as ``SimulationError`` (the others run on), and a divergence that only shows
as MuJoCo's bad-state warnings (``mju_warning`` in threads MuJoCo started itself) as rising
warning counters or a non-finite state. Auto-reset is switched off for every variant, so a
diverged state stays non-finite instead of silently restarting from ``qpos0``. Every diverged
variant is then replayed in this thread from its state at the start of the block in which it
failed (bit-identical: ``mjSTATE_INTEGRATION``), stopping at the first error or bad-state
warning, so its message, element and time are the same whichever thread or executor ran it.
"""

import contextlib
import ctypes
import math
import re
import threading
import traceback
from dataclasses import dataclass, field

import mujoco
import numpy as np
from mujoco import batch as mjbatch

from ...runtime import registry
from ...runtime.divergence import step_phrase
from ...runtime.flexures import Flexures
from .recipe import Recipe

BAD_STATE = (mujoco.mjtWarning.mjWARN_BADQPOS, mujoco.mjtWarning.mjWARN_BADQVEL, mujoco.mjtWarning.mjWARN_BADQACC)
_BAD = [int(w) for w in BAD_STATE]
_STATE = mujoco.mjtState.mjSTATE_INTEGRATION
# Model sizes that fix MjData's layout: models equal in these share one Batch (set_models)
_LAYOUT = ("nq", "nv", "nu", "na", "nbody", "njnt", "ngeom", "nsite", "ncam", "nlight", "nflex", "nflexvert",
           "nflexedge", "nflexelem", "nmocap", "nsensor", "nsensordata", "ntendon", "nwrap", "neq", "nuserdata",
           "npluginstate", "nhistory", "narena", "nM", "nB", "nC", "nD", "ntree", "nbvh", "nbvhdynamic", "nJmom",
           "nJten", "nplastic")  # fmt: skip
BATCH, LOOP = "mujoco.batch.Batch", "loop"  # how a group of variants was stepped
#: Variants built and stepped at once in one process: bounds the memory held (models, data,
#: Batch state rows) and leaves the flexure registry (``CAPACITY`` models) room for the user's own.
PART_SIZE = 256
_ROOM = threading.Condition()  # guards installing providers into this process's registry
_HELD = [0]  # providers this module has installed in this process


@dataclass(frozen=True)
class Plan:
    """What every chunk of one sweep needs (picklable); ``threads`` is the ``Batch`` thread count (0: all CPUs)."""

    recipe: Recipe
    observe: object
    duration: float
    samples: int | None
    threads: int


@dataclass
class Outcome:
    """One variant's result: ``status`` is ``"ok"``, ``"diverged"`` or ``"failed"``."""

    index: int
    status: str = "ok"
    error: str = ""
    element: str = ""
    time_diverged: float = math.nan
    values: list = field(default_factory=list)  # one observe() dict per sample


def steps_per_sample(model, duration, samples, what="variant") -> tuple[int, int]:
    """``(blocks, steps per block)`` for ``duration`` observed at ``samples`` times; raises ValueError."""
    h = float(model.opt.timestep)
    steps = round(duration / h)
    if abs(steps * h - duration) > 1e-9 * max(duration, h):
        raise ValueError(
            f"{what}: duration {duration!r} s is not a whole number of time steps ({h!r} s); use "
            f"{steps * h!r} or {(steps + 1) * h!r}"
        )
    if samples is None:
        return (1, steps) if steps else (0, 0)
    blocks = samples - 1
    if steps % blocks:
        raise ValueError(
            f"{what}: {steps} steps of {h!r} s cannot be split into samples - 1 = {blocks} equal blocks; choose "
            f"samples - 1 dividing {steps} (e.g. {_divisor_near(steps, blocks) + 1})"
        )
    return blocks, steps // blocks


def _divisor_near(n, k):
    return min((d for d in range(1, n + 1) if n % d == 0), key=lambda d: abs(d - k))


# ---------------------------------------------------------------------- registry room


def registry_room() -> int:
    """How many more models this process's flexure registry can serve now."""
    return registry.CAPACITY - registry.models_served()


@contextlib.contextmanager
def installed(flexes):
    """Install ``flexes`` together (waiting for room other sweep threads hold), uninstall on exit."""
    flexes = [f for f in flexes if len(f)]
    with _ROOM:
        while registry_room() < len(flexes):
            if not _HELD[0]:
                raise RuntimeError(
                    f"mjflex serves at most {registry.CAPACITY} models per process and {registry.models_served()} "
                    f"are installed outside this sweep; cannot install {len(flexes)}. Uninstall unused providers "
                    "or pass a smaller chunk_size."
                )
            _ROOM.wait()
        for f in flexes:
            f.install()
        _HELD[0] += len(flexes)
    try:
        yield
    finally:
        with _ROOM:
            for f in flexes:
                f.uninstall()
            _HELD[0] -= len(flexes)
            _ROOM.notify_all()


# ---------------------------------------------------------------------- one variant


class _Sim:
    """A built variant: its model, provider, initial keyframe and outcome."""

    def __init__(self, plan: Plan, index: int, params: dict):
        self.outcome = Outcome(index)
        self.model = plan.recipe.build(**params)
        self.model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_AUTORESET
        self.key = plan.recipe.keyframe_index(self.model)
        self.blocks, self.block = steps_per_sample(self.model, plan.duration, plan.samples, f"variant {index}")
        self.flex = Flexures(self.model)

    @property
    def alive(self) -> bool:
        return self.outcome.status == "ok"

    def layout(self):
        return (self.blocks, self.block, *(getattr(self.model, n) for n in _LAYOUT))

    def initial_data(self):
        """A new ``MjData`` at the variant's initial state (its keyframe, or ``qpos0`` at rest), not forwarded."""
        data = mujoco.MjData(self.model)
        if self.key >= 0:
            mujoco.mj_resetDataKeyframe(self.model, data, self.key)
        return data

    def values(self, observe, data):
        """``observe``'s values at ``data`` (forwarded): ``{name: (dims or None, ndarray)}``; raises as it raises."""
        values = observe(self.model, self.flex, data)
        if not hasattr(values, "items"):
            raise TypeError(f"observe must return a dict of named values; got {type(values).__name__}")
        return {name: _plain(name, v) for name, v in values.items()}

    def observe(self, observe, data):
        """Run ``observe`` on ``data`` (state loaded, not yet forwarded); a raise marks the variant failed."""
        try:
            mujoco.mj_forward(self.model, data)
            self.outcome.values.append(self.values(observe, data))
        except Exception as exc:
            self.fail(f"observe raised at t = {data.time:.6g} s: {_exc_text(exc)}")

    def fail(self, message):
        self.outcome.status, self.outcome.error, self.outcome.values = "failed", message, []

    def diverge(self, message, element="", time=math.nan):
        o = self.outcome
        o.status, o.error, o.element, o.time_diverged, o.values = "diverged", message, element, time, []


def _plain(name, value):
    """An observed value as ``(dims or None, ndarray)``."""
    dims = None
    if isinstance(value, tuple) and len(value) == 2 and isinstance(value[0], tuple | list | str):
        dims, value = value
        dims = (dims,) if isinstance(dims, str) else tuple(dims)
    arr = np.array(value)
    if arr.dtype.kind not in "biufc":
        raise TypeError(f"observed value {name!r} is {arr.dtype} ({value!r:.60}); observe must return numbers")
    if dims is not None and len(dims) != arr.ndim:
        raise ValueError(f"observed value {name!r} names dims {dims} for an array of shape {arr.shape}")
    return dims, arr


def _exc_text(exc):
    frame = traceback.extract_tb(exc.__traceback__)[-1:] if exc.__traceback__ else []
    where = f" ({frame[0].filename.rsplit('/', 1)[-1]}:{frame[0].lineno})" if frame else ""
    return f"{type(exc).__name__}: {exc}{where}"


def _warning_counts(data):
    return np.array([data.warning[w].number for w in _BAD])


def _element(message):
    match = re.search(r"flexure '([^']*)'", message)
    return match.group(1) if match else ""


def _bad_state_text(model, data, counts):
    """MuJoCo's text for the first bad-state warning that rose, with the body it concerns."""
    w = _BAD[int(np.flatnonzero(_warning_counts(data) > counts)[0])]
    info = int(data.warning[w].lastinfo)
    text = mujoco.mju_warningText(w, info).split(". The simulation")[0]
    if w != int(mujoco.mjtWarning.mjWARN_BADQPOS) and 0 <= info < model.nv:
        body = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, int(model.dof_bodyid[info])) or "unnamed"
        text += f" (body '{body}')"
    return f"MuJoCo: {text}"


def _most_loaded(sim, row):
    """``(element, energy)``: the flexure holding the most elastic energy in state ``row``, or ``("", nan)``."""
    if not len(sim.flex):
        return "", math.nan
    d = mujoco.MjData(sim.model)
    mujoco.mj_setState(sim.model, d, row, _STATE)
    mujoco.mj_kinematics(sim.model, d)
    energies = sim.flex.potential_energies(d)
    e = int(np.argmax(energies))
    return sim.flex.names[e], float(energies[e])


def replay(sim: _Sim, row: np.ndarray, nstep: int, reported: str = "") -> None:
    """Step ``sim`` from state ``row`` in this thread until it fails; record why, where and when.

    A flexure that mjflex reports (a non-finite wrench, or the element whose force made the
    state MuJoCo found bad: :meth:`mjflex.Flexures.divergences`) is named as the element, with
    mjflex's message. When MuJoCo's checks fire and no element was that violent, the element
    named is the flexure that held the most elastic energy at the start of the failing step, the
    last finite state, and the message says so. Steps are named by the one convention of
    :mod:`mjflex.runtime.divergence` ("the step from t = ... s (step index k, counting from 0)").
    ``reported`` is the error ``Batch`` reported, if any (kept if the replay does not fail).
    """
    m, d = sim.model, mujoco.MjData(sim.model)
    mujoco.mj_setState(m, d, row, _STATE)
    t0, counts, last, h = d.time, _warning_counts(d), row.copy(), m.opt.timestep
    for _ in range(nstep):
        t = d.time
        mujoco.mj_getState(m, d, last, _STATE)
        try:
            mujoco.mj_step(m, d)
        except mujoco.FatalError as exc:
            text = str(exc)
            return sim.diverge(text if "flexure '" in text else f"{text} (in {step_phrase(t, h)})", _element(text), t)
        bad = (_warning_counts(d) > counts).any()
        if bad or not (np.isfinite(d.qpos).all() and np.isfinite(d.qvel).all()):
            found = [v for v in sim.flex.divergences(d).values() if v.time == t] if len(sim.flex) else []
            if found:  # mjflex names the element (the mjcb_passive provider reports it at its next evaluation)
                return sim.diverge(found[0].message, found[0].element, t)
            what = _bad_state_text(m, d, counts) if bad else "the state became non-finite"
            element, energy = _most_loaded(sim, last)
            held = f"; flexure '{element}' held the most elastic energy ({energy:.3g} J) before it" if element else ""
            return sim.diverge(f"{what} in {step_phrase(t, h)}{held}", element, t)
    sim.diverge(
        f"diverged between t = {t0:.6g} and {d.time:.6g} s ({reported or 'MuJoCo bad-state warning'}), but a replay "
        "of that interval in one thread did not reproduce it",
        _element(reported),
    )


# ---------------------------------------------------------------------- stepping


def _batch_usable() -> bool:
    """``Batch`` needs every installed physics callback to be a C function (not a Python one)."""
    getters = [getattr(mujoco, n) for n in dir(mujoco) if n.startswith("get_mjcb_")]
    return all(g() is None or isinstance(g(), ctypes._CFuncPtr) for g in getters)


def _run_batch(plan, sims, progress):
    models = [s.model for s in sims]
    b = mjbatch.Batch(models[0], len(sims), plan.threads)
    b.set_models(models)
    b.reset(keyframe=np.array([s.key for s in sims]))
    data = mujoco.MjData(models[0])

    def observe(ids):
        for i in ids:
            b.get_data(int(i), data)
            sims[i].observe(plan.observe, data)

    alive = np.arange(len(sims))
    if plan.samples is not None:
        observe(alive)
    for _ in range(sims[0].blocks):
        alive = np.array([i for i in alive if sims[i].alive], dtype=np.int32)
        if not alive.size:
            break
        before, counts = b.state[alive].copy(), b.warning[alive][:, _BAD, 1].copy()
        with contextlib.suppress(mjbatch.SimulationError):  # read from status below
            b.step(alive, nstep=sims[0].block)
        bad = (b.status[alive] != 0) | (b.warning[alive][:, _BAD, 1] > counts).any(1)
        bad |= ~np.isfinite(b.state[alive]).all(1)
        for j in np.flatnonzero(bad):
            replay(sims[alive[j]], before[j], sims[0].block, b.error(int(alive[j])))
        observe(alive[~bad])
        if progress:
            progress(len(alive))


def _observe_copy(plan, sim, data, scratch, row):
    """Observe a copy of ``data``'s integration state, so ``observe`` cannot perturb the run."""
    mujoco.mj_getState(sim.model, data, row, _STATE)
    mujoco.mj_setState(sim.model, scratch, row, _STATE)
    sim.observe(plan.observe, scratch)


def _steps_ok(sim, data, nstep):
    """Step ``data`` ``nstep`` times; False if MuJoCo raised, warned of a bad state or it is non-finite."""
    counts = _warning_counts(data)
    try:
        for _ in range(nstep):
            mujoco.mj_step(sim.model, data)
    except mujoco.FatalError:
        return False
    return not (_warning_counts(data) > counts).any() and np.isfinite(data.qpos).all() and np.isfinite(data.qvel).all()


def _run_loop(plan, sims, progress):
    """The fallback when ``Batch`` cannot run (a Python physics callback is installed)."""
    for sim in sims:
        m, d = sim.model, sim.initial_data()
        scratch, row = mujoco.MjData(m), np.empty(mujoco.mj_stateSize(m, _STATE))
        mujoco.mj_forward(m, d)
        if plan.samples is not None:
            _observe_copy(plan, sim, d, scratch, row)
        for _ in range(sim.blocks):
            if not sim.alive:
                break
            before = np.empty_like(row)
            mujoco.mj_getState(m, d, before, _STATE)
            if _steps_ok(sim, d, sim.block):
                _observe_copy(plan, sim, d, scratch, row)
            else:
                replay(sim, before, sim.block)
            if progress:
                progress(1)


def _build(plan, rows):
    sims = []
    for index, params in rows:
        try:
            sims.append(_Sim(plan, index, params))
        except Exception as exc:
            sims.append(Outcome(index, "failed", f"building the variant raised {_exc_text(exc)}"))
    return sims


def _run_part(plan, rows, progress, stats):
    built = _build(plan, rows)
    sims = [s for s in built if isinstance(s, _Sim)]
    groups = {}
    for s in sims:
        groups.setdefault(s.layout(), []).append(s)
    with installed([s.flex for s in sims]):
        for group in groups.values():
            if group[0].blocks == 0:  # duration 0: observe the initial state
                _observe_initial(plan, group, progress)
            elif _batch_usable():
                _run_batch(plan, group, progress)
                stats["stepping"].add(BATCH)
            else:
                _run_loop(plan, group, progress)
                stats["stepping"].add(LOOP)
    return [s.outcome if isinstance(s, _Sim) else s for s in built]


def _observe_initial(plan, sims, progress):
    for s in sims:
        s.observe(plan.observe, s.initial_data())
    if progress:
        progress(len(sims))


def run_chunk(plan: Plan, rows, progress=None, *, run_part=None, part_size=None):
    """Run variants ``rows`` (a list of ``(index, params)``) in this process.

    Returns ``(outcomes, stats)``: one :class:`Outcome` per row, in order, and
    ``{"parts": number of parts the chunk was run in, "stepping": set of BATCH / LOOP (or
    :data:`.warp.WARP`), "warp_batches": MuJoCo Warp batches}``. ``progress(n)``, if given, is
    called as blocks of simulation finish (``n`` variants advanced by one block). A part is
    ``run_part(plan, rows, progress, stats)`` (default: ``Batch`` or a loop; :func:`.warp.run_part`)
    of ``part_size`` variants (default: :data:`PART_SIZE`, fewer when the registry has less room).
    """
    outcomes, parts, start, stats = [], 0, 0, {"stepping": set(), "warp_batches": 0}
    while start < len(rows):
        part = rows[start : start + (part_size or max(1, min(PART_SIZE, registry_room())))]
        ticks = [0.0]

        def tick(n, ticks=ticks):
            ticks[0] += n
            progress(n)

        outcomes += (run_part or _run_part)(plan, part, tick if progress else None, stats)
        if progress:  # variants that diverged or failed early: their remaining blocks
            progress(len(part) * (1 if plan.samples is None else plan.samples - 1) - ticks[0])
        start += len(part)
        parts += 1
    return outcomes, {"parts": parts, **stats}

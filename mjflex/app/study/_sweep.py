"""The study itself: plan the steps, build the reference, sweep the candidates, bisect the limits."""

import datetime
import functools
import math
import os
import time
from dataclasses import dataclass

import numpy as np
from tqdm.auto import tqdm

from ...core import validation
from ...variants.variant import VariantNotApplicableError
from ..simulate import integrator_label
from ._metrics import Errors, Scales, frequency_error, linearized_frequencies
from ._options import METHODS, check_options
from ._result import StudyResult
from ._rows import Limit, Reference, Row
from ._run import Sim, quiet_mujoco_warnings, run_sampled
from ._scene import (
    StudyError,
    build_variant,
    flexures_of,
    initial_state,
    load,
    source_spec_of,
    tracked_items,
    variant_state,
)
from ._stability import MAX_HALVINGS, MAX_NV, advised_limit, limiting_mode, perturbation
from .variants import DEFAULT_VARIANTS

INTEGRATORS = ("rk4", "euler", "implicitfast", "discrete")
#: RK4 is stable for |lambda h| below 2 sqrt(2) on the imaginary axis (2.79 on the real one); the
#: default step range reaches twice the step this gives for the fastest rate of the linearized
#: model (highest frequency, or damping), past every integrator's limit.
RK4_LIMIT = 2.0 * math.sqrt(2.0)
#: Energy change, in units of the reference's largest total energy plus its swing, beyond which a
#: run is taken as diverged before it turns NaN. A bounded but poor run stays below it: symplectic
#: Euler multiplies a linear oscillator's energy by up to 1 / (1 - omega h / 2), 1000 at 0.1 %
#: below its limit omega h = 2, so the detected limit of such a scheme is within 0.1 % of the true one.
ENERGY_LIMIT_FACTOR = 1e3
#: Stepping time [s] of one timing slice. Slices of all candidates are interleaved, one round per
#: repeat, so that the load of a shared machine spreads evenly over them; medians are reported.
TIMING_SLICE = 0.05


@dataclass
class Plan:
    """Sample times and candidate steps. Every step is ``interval / n`` for an integer ``n``, so
    all runs are sampled at the same times, and ``interval`` is a multiple of the model's step."""

    interval: float  # sample interval [s]
    samples: int  # number of sample intervals; duration = samples * interval
    grid: list  # integer divisors n of the interval, ascending (steps descending)
    unit: int  # n of the model file's own time step

    @property
    def duration(self):
        return self.samples * self.interval

    def h(self, n):
        return self.interval / n


def _plan(h_model, freq, rate, *, duration, samples, steps, step_count, max_step, min_step):
    if duration is None:
        duration = 1.0 / freq[0] if len(freq) else 1000 * h_model  # one period of the lowest elastic mode
        duration = min(max(duration, 200 * h_model), 20000 * h_model)
    if steps:  # checked by check_options
        targets = np.asarray(sorted(steps, reverse=True), dtype=float)
    else:
        hi = max_step or (2.0 * RK4_LIMIT / rate if rate > 0 else 4.0 * h_model)
        lo = min_step or hi / 2.0 ** (step_count - 1)
        if not 0 < lo <= hi:
            raise StudyError(f"the step range must satisfy 0 < min_step <= max_step; got {lo:g} .. {hi:g}")
        targets = np.geomspace(hi, lo, step_count)
    unit = max(1, math.ceil(max(targets[0], duration / samples) / h_model - 1e-9))
    if steps:  # prefer an interval that all the given steps divide (up to 4x fewer samples)
        misfit = [max(abs(u * h_model / h - round(u * h_model / h)) / (u * h_model / h) for h in targets)
                  for u in range(unit, 4 * unit + 1)]  # fmt: skip
        unit += next((i for i, m in enumerate(misfit) if m < 1e-9), int(np.argmin(misfit)))
    interval = unit * h_model
    grid = {max(1, round(interval / h)) for h in targets}
    if not steps:  # the model file's own step too: every variant side by side where the file runs
        grid.add(unit)
    grid = sorted(grid)
    return Plan(interval, max(1, round(duration / interval)), grid, unit)


class _Study:
    """State shared by the phases of one study."""

    def __init__(self, result, plan, full, *, repeat, max_run_wall, frequencies, clock, bar):
        self.result, self.plan, self.full, self.bar, self.clock = result, plan, full, bar, clock
        self.repeat, self.max_run_wall, self.n_freq = repeat, max_run_wall, frequencies
        self.ref_traj = self.scales = self.energy_limit = None
        self._freq = {}
        self._timed = []  # (row or reference, sim, integrator, method, h, sampled outcome) to time

    def _run(self, sim, method, integrator, h, what, every=None):
        """The scene at step ``h``, sampled every ``every`` steps (default: any step, sampled at the steps nearest the
        sample interval), shown on the progress bar as ``what``."""
        self.bar.set_description(f"{sim.name} {integrator} {sim.methods_label(method)} {what}h={h:.3g}")
        samples = self.plan.samples
        if every is None:
            every = max(1, round(self.plan.interval / h))
            samples = math.ceil(self.plan.duration / (every * h))
        out = run_sampled(sim, integrator, method, h, samples=samples, every=every, energy_limit=self.energy_limit,
                          max_wall=self.max_run_wall)  # fmt: skip
        self.bar.update()
        return out

    # ---------------------------------------------------------------- reference

    def reference(self, *, tol, max_refinements, start_step):
        plan, full = self.plan, self.full
        n = max(1, round(plan.interval / (start_step or full.model.opt.timestep)))
        ref = Reference("rk4", full.methods_label(None), None, None, None, False)
        self.result.reference = ref
        previous, agreements = None, []
        for _ in range(max_refinements + 1):
            h = plan.h(n)
            out = self._run(full, None, "rk4", h, "reference ", every=n)  # no energy limit yet: it is the reference's
            attempt = {"timestep": h, "status": "ok" if out.ok else (out.skipped or out.divergence.text())}
            ref.attempts.append(attempt)
            if out.skipped:
                break
            if out.divergence:
                previous, n = None, 2 * n
                continue
            if previous is not None:
                scales = Scales.of(out.trajectory, full.model.stat.extent)
                agreement = Errors.between(previous[1].trajectory, out.trajectory, scales).pose
                attempt["agreement_with_previous"] = agreement
                agreements.append(agreement)
            previous = (n, out)
            if agreements and agreements[-1] <= tol:
                ref.converged = True
                break
            n *= 2
        if previous is None:
            tried = "; ".join(f"h = {a['timestep']:.3g} s: {a['status']}" for a in ref.attempts)
            raise StudyError(
                f"the reference (RK4) did not run through at any step tried ({tried}). The scene diverges even at "
                "small steps: check the initial state, or start the reference lower with --reference-step."
            )
        n_ref, out = previous
        ref.timestep = plan.h(n_ref)
        ref.agreement = agreements[-1] if agreements else None
        ref.error_estimate = None if ref.agreement is None else ref.agreement / 15.0
        if len(agreements) >= 2 and agreements[-1] > 0:
            ref.observed_order = float(np.log2(agreements[-2] / agreements[-1]))
        if ref.agreement is None:
            self.result.notes.append(
                "the reference could not be verified (no second refinement ran through to compare it with); "
                "errors are measured against an RK4 run of unknown accuracy. Allow more refinements."
            )
        elif not ref.converged:
            self.result.notes.append(
                f"the reference did not converge to the requested tolerance (its last refinements agree to "
                f"{ref.agreement:.2g}); errors below that are not resolved. Shorten --duration or allow more "
                "refinements."
            )
        self._timed.append((ref, full, "rk4", None, ref.timestep, out))
        self.ref_traj = out.trajectory
        self.scales = Scales.of(out.trajectory, full.model.stat.extent)
        self.energy_limit = ENERGY_LIMIT_FACTOR * (float(np.max(np.abs(out.trajectory.energy))) + self.scales.energy)

    # ---------------------------------------------------------------- candidates

    def timing(self):
        """Time every run that went through: ``repeat`` interleaved rounds of one slice each.

        Each slice steps from the initial state for ``TIMING_SLICE`` seconds (at most the run's
        length) and is timed with both the wall clock and this thread's CPU clock; the medians
        per simulated second go into the rows (wall: the cost; CPU: a check on a loaded machine).
        """
        slices = [min(out.steps, max(1, int(TIMING_SLICE / max(out.wall / max(out.steps, 1), 1e-9))))
                  for *_, out in self._timed]  # fmt: skip
        samples = [[] for _ in self._timed]
        for _ in range(self.repeat):
            self.bar.set_description("timing (interleaved)")
            for (_, sim, integrator, method, h, _), steps, times in zip(self._timed, slices, samples, strict=True):
                out = run_sampled(sim, integrator, method, h, samples=1, every=steps)  # timed: only mj_step
                if out.ok:
                    times.append((out.wall / steps, out.cpu / steps))
            self.bar.update()
        for (row, *_, h, _), times in zip(self._timed, samples, strict=True):
            if times:
                wall, cpu = np.array(times).T / h
                row.wall_per_sim_s, row.cpu_per_sim_s = float(np.median(wall)), float(np.median(cpu))
                row.wall_range, row.repeats = (float(wall.min()), float(wall.max())), len(times)
                row.cost = row.cpu_per_sim_s if self.clock == "cpu" else row.wall_per_sim_s

    def frequencies(self, sim, method):
        key = (sim.name, tuple(method or m for m in sim.file_methods))
        if key not in self._freq:
            sim.configure("rk4", method, sim.model.opt.timestep)
            freq = linearized_frequencies(sim.model, sim.flex, sim.state["qpos"], ctrl=sim.state.get("ctrl"),
                                          act=sim.state.get("act")).elastic  # fmt: skip
            self._freq[key] = freq
            label = sim.name if method is None else f"{sim.name}/{method}"
            self.result.frequencies[label] = [float(f) for f in freq[: max(self.n_freq, 6)]]
        return self._freq[key]

    def candidate(self, sim, method, integrator, n, source="grid"):
        h = self.plan.h(n)
        out = self._run(sim, method, integrator, h, "", every=n)
        row = Row(sim.name, sim.methods_label(method), integrator, h, "ok", source=source)
        if out.divergence:
            row.status, row.divergence = "diverged", out.divergence
        elif out.skipped:
            row.status, row.note = "skipped", out.skipped
        if not out.ok:
            row.wall_per_sim_s, row.cpu_per_sim_s, row.repeats = out.wall / out.steps / h, out.cpu / out.steps / h, 1
            row.cost = row.cpu_per_sim_s if self.clock == "cpu" else row.wall_per_sim_s
            return row
        self._timed.append((row, sim, integrator, method, h, out))
        err = Errors.between(out.trajectory, self.ref_traj, self.scales)
        row.pose_error, row.position_error, row.rotation_error = err.pose, err.position, err.rotation
        row.energy_error = err.energy
        ref_freq, freq = self.frequencies(self.full, None), self.frequencies(sim, method)
        row.frequency_error = frequency_error(freq, ref_freq, self.n_freq)
        wanted = min(self.n_freq, len(ref_freq))
        if len(freq) < wanted:  # the frequency error covers only the modes it has
            row.note = f"has {len(freq)} of the reference's first {wanted} elastic modes"
        return row

    def group(self, sim, method, integrator, bisect, limit_rtol):
        """Grid runs of one (variant, method, integrator), then bisection of its stability limit.

        The bisection first halves the bracket between the largest stable and the smallest
        diverged grid step over divisors of the sample interval (those runs are full candidates,
        with errors); once neighbouring divisors are reached it goes on with arbitrary steps,
        checked for divergence only, until the bracket is within ``limit_rtol``.
        """
        runs = {n: self.candidate(sim, method, integrator, n) for n in self.plan.grid}
        ok = [n for n, r in runs.items() if r.status == "ok"]
        n_ok = min(ok) if ok else None
        bad = [n for n, r in runs.items() if r.status == "diverged" and (n_ok is None or n < n_ok)]
        n_bad = max(bad) if bad else None
        left = bisect if n_ok is not None and n_bad is not None else 0
        while left and n_ok - n_bad > 1:
            left -= 1
            mid = min(max(round(math.sqrt(n_ok * n_bad)), n_bad + 1), n_ok - 1)
            row = runs[mid] = self.candidate(sim, method, integrator, mid, source="bisection")
            if row.status == "skipped":
                left = 0
            n_ok, n_bad = (mid, n_bad) if row.status == "ok" else (n_ok, mid)
        if n_ok is not None and any(r.status == "diverged" for n, r in runs.items() if n > n_ok):
            who = f"{sim.name} {integrator} {sim.methods_label(method)}"
            self.result.notes.append(f"{who}: diverged at a step smaller than a stable one; the stability limit is "
                                     "not a single threshold")  # fmt: skip
        limit = Limit(sim.name, sim.methods_label(method), integrator,
                      None if n_ok is None else self.plan.h(n_ok), None if n_bad is None else self.plan.h(n_bad),
                      None if n_bad is None else runs[n_bad].divergence)  # fmt: skip
        if left and n_ok is not None and n_bad is not None:
            self._refine_limit(sim, method, integrator, limit, left, limit_rtol)
        self._check_limit(sim, method, integrator, limit, limit_rtol)
        return [runs[n] for n in sorted(runs)], limit

    def _check_limit(self, sim, method, integrator, limit, rtol):
        """The advised limit (mjflex.step_advice's), the mode it names, and the recommended step checked by perturbed
        runs (see _stability)."""
        guess = limit.largest_stable or limit.smallest_unstable
        if guess is None:
            return
        self.bar.set_description(f"{sim.name} {integrator} {sim.methods_label(method)} advised limit")
        limit.checked = True
        if sim.model.nv > MAX_NV:
            limit.linear_note = f"advised limit not computed (nv = {sim.model.nv} > {MAX_NV})"
        else:
            advice, last, none = advised_limit(sim, integrator, method, guess, rtol, self.plan.duration)
            if advice is not None:
                limit.linear_step, limit.linear_unstable = advice.limit, advice.unstable
                limit.linear_mode = limiting_mode(sim, advice)
            else:
                way = "down" if none == "unstable" else "up"
                limit.linear_note = f"the linearized model is {none} at every step {way} to {last:.3g} s"
        self._check_recommended(sim, method, integrator, limit, limit.linear_step, rtol)

    def _check_recommended(self, sim, method, integrator, limit, h_lin, rtol):
        """Perturbed runs at the smaller of the two limits (halved until one runs through) and at the measured one."""
        if limit.largest_stable is None:
            return
        dv = perturbation(sim, self.scales.energy)
        h = min(limit.largest_stable, h_lin or math.inf)
        for _ in range(MAX_HALVINGS + 1):
            out = self._perturbed_run(sim, method, integrator, h, dv, limit)
            if out.ok:
                limit.recommended = h
            if not out.divergence:
                break
            h *= 0.5
        if h_lin is not None and limit.largest_stable > h_lin * (1.0 + rtol):  # show what the scene hides
            self._perturbed_run(sim, method, integrator, limit.largest_stable, dv, limit)

    def _perturbed_run(self, sim, method, integrator, h, dv, limit):
        """The scene at step ``h`` with the velocity perturbation ``dv`` added; recorded in ``limit.checks``."""
        saved = sim.state["qvel"]
        sim.state["qvel"] = saved + dv
        try:
            out = self._run(sim, method, integrator, h, "perturbed ")
        finally:
            sim.state["qvel"] = saved
        status = "diverged" if out.divergence else ("skipped" if out.skipped else "ok")
        limit.checks.append({"timestep": h, "status": status, "time": out.divergence.time if out.divergence else None,
                             "divergence": out.divergence.text() if out.divergence else out.skipped})  # fmt: skip
        return out

    def _refine_limit(self, sim, method, integrator, limit, left, rtol):
        """Geometric bisection of ``limit``'s bracket with steps that need not divide the interval."""
        while left and limit.smallest_unstable / limit.largest_stable > 1.0 + rtol:
            left -= 1
            h = math.sqrt(limit.largest_stable * limit.smallest_unstable)
            out = self._run(sim, method, integrator, h, "limit ")
            if out.skipped:
                return
            if out.divergence:
                limit.smallest_unstable, limit.divergence = h, out.divergence
            else:
                limit.largest_stable = h


def _variant_sims(source, src, data0, items, frame, result, methods, entries):
    sims = []
    for entry in entries:
        try:
            variants = build_variant(entry, source)
        except VariantNotApplicableError as exc:
            result.notes.append(f"variant builder {getattr(entry, '__name__', entry)!r} does not apply: {exc}")
            continue
        except Exception as exc:  # a user's builder: report it and go on with the others
            result.notes.append(f"variant builder {getattr(entry, '__name__', entry)!r} failed: {exc}")
            continue
        for v in variants:
            if v.name == "full" or v.name in result.variants:
                result.notes.append(f"variant name {v.name!r} is reserved or repeated; that variant was left out")
                continue
            try:
                sim = Sim(v.name, v.model, v.body_map, variant_state(v, src, data0), items, frame, report=v.report,
                          spec=v.spec)  # fmt: skip
            except (ValueError, KeyError) as exc:
                result.notes.append(f"variant {v.name!r} left out: {exc}")
                continue
            problem = sim.method_switch_problem(methods)
            if problem:
                result.notes.append(f"variant {v.name!r} left out: {problem}")
                continue
            sims.append(sim)
            result.variants[v.name] = v.report
    return sims


def study(model, *, keyframe=None, qpos=None, qvel=None, duration=None, track=None, frame="auto",
          methods=METHODS, integrators=INTEGRATORS, steps=None, step_count=6, max_step=None, min_step=None,
          variants=None, repeat=3, bisect=8, limit_rtol=0.02, reference_tol=1e-6, max_refinements=5,
          reference_step=None, frequencies=3, samples=200, max_run_wall=120.0, targets=(0.1, 0.01, 1e-4),
          clock="cpu", out=None, progress=True) -> StudyResult:  # fmt: skip
    """Measure the speed-accuracy trade of simulating ``model``'s flexures; see the package docstring."""
    opts = {k: v for k, v in locals().items() if k not in ("model", "out", "progress")}
    check_options(opts, out)
    validation.check_flag(progress, "progress")
    label = os.fspath(model) if isinstance(model, str | os.PathLike) else "model"
    result = StudyResult(str(label), targets=tuple(targets), clock=clock,
                         date=datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"))  # fmt: skip
    started = time.perf_counter()
    with quiet_mujoco_warnings():
        scene = _scene(result, model, **opts)  # a StudyError here: nothing has run or been written
        bar = tqdm(total=max_refinements + 1, unit="run", disable=not progress, leave=False)
        try:
            _run(result, scene, bar, **opts)
        except StudyError as exc:  # stopped after runs began: what was measured goes beside earlier results
            result.message = str(exc)
            result.wall_s = time.perf_counter() - started
            exc.partial = result
            if out is not None:
                exc.paths = result.write(out, partial=True)
            raise
        finally:
            bar.close()
    result.wall_s = time.perf_counter() - started
    result.flag_beyond_limits()
    result.mark_pareto()
    swept = [r for r in result.rows if r.source != "model"]
    if swept and not any(r.status == "ok" for r in swept):
        how = "smaller --steps (steps=)" if steps else "--min-step/--max-step (min_step=, max_step=) or --steps"
        result.message = (
            "every candidate step diverged or was skipped (see the stability limits); the reference ran, so the scene "
            f"itself is fine: try smaller steps with {how}"
        )
    if out is not None:
        result.write(out)
    return result


def _scene(result, model, *, keyframe, qpos, qvel, duration, track, frame, steps, step_count, max_step, min_step,
           samples, frequencies, methods, **_):  # fmt: skip
    """Load and check the model, its initial state and tracked items, and plan the steps (nothing runs): the full
    model's :class:`Sim`, the :class:`Plan` and ``variant_sims(entries)``, run after the reference (:func:`_run`)."""
    src, result.model, source = load(model)
    flex = flexures_of(src, result.model)
    state, result.initial_state, data0 = initial_state(src, flex, result.model, keyframe=keyframe, qpos=qpos,
                                                       qvel=qvel)  # fmt: skip
    items, frame_body = tracked_items(src, flex, result.model, track, frame)
    result.frame, result.tracked = frame_body or "the world", [i.label for i in items]
    full = Sim("full", src, None, state, items, frame_body, spec=source_spec_of(source, flex))
    problem = full.method_switch_problem(methods)
    if problem:
        raise StudyError(problem)
    result.model_setting = {"integrator": integrator_label(src), "timestep": float(src.opt.timestep),
                            "method": full.methods_label(None)}  # fmt: skip
    lin = linearized_frequencies(full.model, full.flex, state["qpos"], ctrl=state["ctrl"], act=state["act"])
    freq, result.highest_frequency, result.fastest_rate = lin
    result.frequencies["full"] = [float(f) for f in freq[: max(frequencies, 6)]]
    plan = _plan(float(src.opt.timestep), freq, lin.rate, duration=duration, samples=samples,
                 steps=steps, step_count=step_count, max_step=max_step, min_step=min_step)  # fmt: skip
    result.duration, result.sample_interval = plan.duration, plan.interval
    if steps and any(abs(plan.h(round(plan.interval / h)) / h - 1) > 0.01 for h in steps):
        result.notes.append(f"steps were aligned to divisors of the sample interval: {[plan.h(n) for n in plan.grid]}")
    return full, plan, functools.partial(_variant_sims, source, src, data0, items, frame_body, result, methods)


def _run(result, scene, bar, *, methods, integrators, steps, variants, repeat, bisect, limit_rtol, reference_tol,
         max_refinements, reference_step, frequencies, max_run_wall, clock, **_):  # fmt: skip
    """The runs of :func:`study`, filling ``result`` as they go (so a failure leaves what was measured)."""
    full, plan, variant_sims = scene
    ctx = _Study(result, plan, full, repeat=max(1, repeat), max_run_wall=max_run_wall, frequencies=frequencies,
                 clock=clock, bar=bar)  # fmt: skip
    ctx.reference(tol=reference_tol, max_refinements=max_refinements, start_step=reference_step)
    sims = [full] + variant_sims(DEFAULT_VARIANTS if variants is None else variants)
    groups = sum(len(integrators) * (len(methods) if sim.has_flexures else 1) for sim in sims)
    bar.total = bar.n + groups * (len(plan.grid) + 5) + 1 + max(1, repeat)  # ~3 bisection, 2 perturbed runs a group
    bar.refresh()
    for sim in sims:
        for method in methods if sim.has_flexures else [None]:
            for integrator in integrators:
                rows, limit = ctx.group(sim, method, integrator, bisect, limit_rtol)
                limit.steps_given = bool(steps)  # what to widen: the given steps or the default range
                result.rows += rows
                result.limits.append(limit)
    _mark_model_setting(ctx, full, plan)
    ctx.timing()


def _mark_model_setting(ctx, full, plan):
    """Flag (running it if the sweep did not) the model file's own integrator, step and methods."""
    own = ("full", full.methods_label(None), ctx.result.model_setting["integrator"])
    row = next((r for r in ctx.result.rows if (r.variant, r.method, r.integrator) == own
                and math.isclose(r.timestep, plan.h(plan.unit), rel_tol=1e-9)), None)  # fmt: skip
    if row is None:
        row = ctx.candidate(full, None, own[2], plan.unit, source="model")
        ctx.result.rows.append(row)
    row.model_setting = True

"""Helpers of compare_alternatives.py and reduce_arcade.py: run a model (variant or not), find its stable step, time it.

A *case* is a compiled model, the Flexures of its elements (or None) and a function giving
its initial ``(qpos, qvel)``; cases are simulated with the same integrator and compared on
the source's named bodies.
"""

import time
from dataclasses import dataclass

import mujoco
import numpy as np
from _bench import compare, scale_times

import mjflex


@dataclass
class Case:
    name: str
    model: mujoco.MjModel
    flex: object  # mjflex.Flexures or None
    state: tuple  # (qpos, qvel) at t = 0
    report: str = ""
    last: tuple = None  # (qpos, qvel) at the end of the last simulate()
    constraints: str = "ignore"  # how normal_modes treats its equality constraints

    def data(self):
        d = mujoco.MjData(self.model)
        d.qpos[:], d.qvel[:] = self.state
        mujoco.mj_forward(self.model, d)
        return d


class _Null:
    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False


def flexures_or_none(model):
    flex = mjflex.Flexures(model)
    return flex if len(flex) else None


def source_case(name, model, key=0):
    d = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, d, key)
    mujoco.mj_forward(model, d)
    return Case(name, model, flexures_or_none(model), (d.qpos.copy(), d.qvel.copy()))


def variant_case(variant, source_model, source_state):
    d = mujoco.MjData(source_model)
    d.qpos[:], d.qvel[:] = source_state
    mujoco.mj_forward(source_model, d)
    return Case(variant.name, variant.model, flexures_or_none(variant.model), variant.state_from(source_model, d),
                variant.report, constraints=variant.details.get("constraints", "spring"))  # fmt: skip


def set_step(model, h, integrator=None):
    model.opt.timestep = h
    if integrator is not None:
        model.opt.integrator = getattr(mujoco.mjtIntegrator, f"mjINT_{integrator.upper()}")


def simulate(case, h, duration, probe, every=1, load=None, damping=None, state=None):
    """Samples ``probe(model, data)`` every ``every`` steps; None if the run diverged.

    ``load(model, data)``: sets ``qfrc_applied`` / ``xfrc_applied`` before every step (e.g. a
    dead load at a point); ``damping``: velocity factor applied after every step (dynamic
    relaxation); ``state``: ``(qpos, qvel)`` to start from instead of the case's.
    """
    m = case.model
    set_step(m, h)
    d = case.data()
    if state is not None:
        d.qpos[:], d.qvel[:] = state
        mujoco.mj_forward(m, d)
    out = []
    with case.flex if case.flex is not None else _Null():
        for i in range(max(1, round(duration / h))):
            if load is not None:
                load(m, d)
            mujoco.mj_step(m, d)
            if damping is not None:
                d.qvel[:] *= damping
            if d.warning[mujoco.mjtWarning.mjWARN_BADQACC].number or not np.isfinite(d.qvel).all():
                return None
            if (i + 1) % every == 0:
                out.append(probe(m, d))
    mujoco.mj_forward(m, d)
    case.last = (d.qpos.copy(), d.qvel.copy())
    return np.array(out)


def stable_step(case, h0, duration, probe, *, growth=2.0, bisections=4, limit=None):
    """Largest step (RK4 or the model's integrator) at which ``duration`` runs without diverging.

    The search stops at ``limit`` (default ``100 h0``): a model stable there is reported at it.

    Divergence: MuJoCo's bad-acceleration warning, a non-finite state, or a probe value 100x
    larger than at the smallest step (a blow-up that MuJoCo has not flagged yet).
    """
    ref = simulate(case, h0, duration, probe, every=max(1, round(duration / h0 / 50)))
    if ref is None:
        return 0.0
    bound = 100.0 * max(np.abs(ref).max(), 1e-12)

    def ok(h):
        x = simulate(case, h, duration, probe, every=max(1, round(duration / h / 50)))
        return x is not None and np.abs(x).max() < bound

    limit = 100.0 * h0 if limit is None else limit
    lo, hi = h0, h0 * growth
    while hi <= limit and ok(hi):
        lo, hi = hi, hi * growth
    for _ in range(bisections):
        mid = np.sqrt(lo * hi)
        lo, hi = (mid, hi) if ok(mid) else (lo, mid)
    set_step(case.model, h0)
    return lo


def step_costs(cases, baseline, h, *, steps=20, repeat=11):
    """Median wall time of one step at step ``h`` for each case, interleaved (ratios to ``baseline``)."""
    funcs = {}
    for c in cases:
        set_step(c.model, h)
        d = c.data()
        funcs[c.name] = (lambda m, dd: lambda: [mujoco.mj_step(m, dd) for _ in range(steps)])(c.model, d)
    for c in cases:
        if c.flex is not None:
            c.flex.install()
    try:
        rows = compare(funcs, baseline, repeat=repeat, target=0.05)
    finally:
        for c in cases:
            if c.flex is not None:
                c.flex.uninstall()
    for r in rows.values():
        scale_times(r, 1 / steps)
    return rows


def body_pose(model, data, name):
    i = model.body(name).id
    return data.xpos[i].copy(), data.xmat[i].reshape(3, 3).copy()


def rotation_angle(R):
    return float(np.arccos(np.clip((np.trace(R) - 1.0) / 2.0, -1.0, 1.0)))


def timed(fn):
    t0 = time.perf_counter()
    out = fn()
    return out, time.perf_counter() - t0


def costs_at_stable_steps(cases, h, repeat, probe, duration):
    """:func:`step_costs` at ``h`` plus each case's stable step and its speed-up over ``cases[0]``.

    The speed-up compares wall time per simulated second, each model at its own stable step:
    the same-repeat cost ratio times the ratio of the steps (so machine noise cancels).
    """
    rows = step_costs(cases, cases[0].name, h, repeat=repeat)
    for c in cases:
        r = rows[c.name]
        r["stable_step_s"] = stable_step(c, h, duration, probe)
        # stable_step searches up to 100 h: a model still stable there has a larger stable step (a lower bound)
        r["stable_step_is_search_limit"] = bool(r["stable_step_s"] >= 100.0 * h)
    return add_speedups(rows, cases[0].name)


def add_speedups(rows, baseline):
    """Each row's wall time per simulated second at its stable step and speed-up over ``rows[baseline]``.

    ``speedup_at_stable`` = (stable step / baseline's) / median same-repeat cost ratio, with its spread
    (``speedup_q1`` ... ``speedup_max``) from the ratio's. Recompute after pooling runs (scripts/_bench.py).
    """
    base = rows[baseline]["stable_step_s"]
    for r in rows.values():
        r["wall_per_sim_s_at_stable"] = r["median_s"] / r["stable_step_s"] if r["stable_step_s"] else float("inf")
        steps = r["stable_step_s"] / base if base else float("nan")
        r["speedup_at_stable"] = steps / r["ratio_median"]
        if "ratio_q1" in r:  # a larger cost ratio is a smaller speed-up
            for mine, theirs in (("q1", "q3"), ("q3", "q1"), ("min", "max"), ("max", "min")):
                r[f"speedup_{mine}"] = steps / r[f"ratio_{theirs}"]
    return rows


def print_costs(rows, h):
    """The cost table of the cases timed by costs_at_stable_steps (rows: name -> its costs), at the step h [s]."""
    print(f"\n{'model':<24} {'step [us]':>10} {'x mjflex':>9} {'stable h':>10} {'wall/sim s':>11} {'speed-up':>9}")
    print(f"{'':<24} {'at h=' + format(h, 'g'):>10} {'(median)':>9} {'[s]':>10} {'at stable':>11} {'at stable':>9}")
    for name, r in rows.items():
        print(f"{name:<24} {r['median_s'] * 1e6:>10.2f} {r['ratio_median']:>9.2f} {r['stable_step_s']:>10.2e} "
              f"{r['wall_per_sim_s_at_stable']:>11.3g} {r['speedup_at_stable']:>9.2f}")  # fmt: skip

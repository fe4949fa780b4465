"""The sweep's MuJoCo Warp executor (``mjflex.sweep(..., executor="warp")``): variants as the worlds of one batch.

Each part of the grid (at most ``part_size`` variants) is built as for the other executors, then
its variants are grouped: variants that differ only in what MuJoCo Warp can vary per world
share one MuJoCo Warp model and step together as its worlds. What can vary: the elements' K, B,
switches and end stops (:func:`mjflex.warp.set_parameters`), and any model array that MuJoCo Warp keeps per
world (masses, inertias, body poses, joint stiffness, geom sizes, ...: the fields it declares
batched, whose values it takes as they are from the ``MjModel``), and model arrays MuJoCo Warp
does not have (so does not read). Variants that differ in anything else, or in their options or
sizes, form groups of their own; each group is one MuJoCo Warp batch.

Initial states are each variant's own (keyframe or ``qpos0``), observed as they are; later
observations load the world's float32 state into a ``mujoco.MjData`` of the variant's own model
and run ``observe`` on it after ``mj_forward``, as the other executors do. A world whose
divergence watch fired (:func:`mjflex.warp.divergences`) or whose state is not finite is
flagged ``diverged``, with the element, the step and the world in its message, and is never
observed again.
"""

import dataclasses
import math

import mujoco
import numpy as np

from . import engine

WARP = "mujoco_warp"
#: Variants built and stepped at once: bounds the host memory of their models (ARCADE: ~2 MB each).
PART_SIZE = 512
# model arrays compared through the element tables, set per world from each variant, or not physics
_NOT_COMPARED = ("text_", "plugin", "key_", "name_", "names", "paths", "buffer", "signature")


def _arrays(model):
    names = [name for name in dir(model) if not name.startswith((*_NOT_COMPARED, "_"))]
    return {name: value for name in names if isinstance(value := getattr(model, name, None), np.ndarray)}


def _options(model):
    o = model.opt
    names = [a for a in dir(o) if not a.startswith("_") and not callable(getattr(o, a))]
    return tuple(np.asarray(getattr(o, a)).tobytes() for a in names)


def _element_structure(table):
    return (table.names, table.ints.tobytes(), np.float32(table.qa).tobytes(), np.float32(table.qb).tobytes(),
            np.float32(table.p0).tobytes(), table.exps.tobytes(), table.coefs.tobytes(), table.start.tobytes(),
            table.element.tobytes(), table.code.tobytes())  # fmt: skip


class _Group:
    """Variants that step together: the first one's model, the fields that vary per world."""

    def __init__(self, sims, mw):
        self.sims, self.ref = sims, sims[0]
        self.tables = [mw.element_table(s.model, s.flex) for s in sims]
        self.batched = set()

    def incompatible(self, i, mjw_model) -> str | None:
        """Why variant ``i`` cannot share the group's MuJoCo Warp model (None: it can)."""
        if _element_structure(self.tables[i]) != _element_structure(self.tables[0]):
            return "its flexure elements differ in more than K, B, switches and stops (sites, methods, terms, bodies)"
        ref, mine = _arrays(self.ref.model), _arrays(self.sims[i].model)
        for name, value in mine.items():
            if np.array_equal(value, ref[name]):
                continue
            field = getattr(mjw_model, name, None)
            if field is None:  # MuJoCo Warp has no such field (dof_M0, ...): its stepping does not read it
                continue
            if _batched_spec(name) is None or not _taken_as_is(field, ref[name]):
                first = self.ref.outcome.index
                return f"its model differs from variant {first}'s in {name}, which MuJoCo Warp cannot vary per world"
            self.batched.add(name)
        return None


def _batched_spec(name):
    from mujoco_warp._src import types  # late: the warp extra, for the warp executor only

    for f in dataclasses.fields(types.Model):
        if f.name == name:
            shape = getattr(f.type, "shape", ())
            return f.type if shape[:1] == ("*",) else None
    return None


def _taken_as_is(field, value) -> bool:
    """Whether MuJoCo Warp's array holds the MjModel's values as they are (so per-world values can be stacked)."""
    got = field.numpy()[0]
    want = np.asarray(value, dtype=got.dtype).reshape(got.shape) if np.asarray(value).size == got.size else None
    return want is not None and np.array_equal(got, want)


def _run_group(plan, group, progress, wp, mjw, mw):
    sims = group.sims
    n = len(sims)
    m = mw.put_model(group.ref.model, batch_sizes={name: n for name in group.batched})
    for name in sorted(group.batched):
        field = getattr(m, name)
        shape = field.shape[1:] + tuple(getattr(field.dtype, "_shape_", ()))
        field.assign(np.stack([np.asarray(getattr(s.model, name)).reshape(shape) for s in sims]))
    t = group.tables
    mw.set_parameters(m, K=np.stack([x.K for x in t]), B=np.stack([x.B for x in t]),
                      enabled=np.stack([x.enabled for x in t]), viscous=np.stack([x.viscous for x in t]),
                      stop_lower=np.stack([x.stop_lower for x in t]), stop_upper=np.stack([x.stop_upper for x in t]),
                      stop_stiffness=np.stack([x.stop_stiffness for x in t]))  # fmt: skip
    d = mjw.make_data(group.ref.model, nworld=n)
    starts = [s.initial_data() for s in sims]
    for name in ("qpos", "qvel", "act", "ctrl", "mocap_pos", "mocap_quat", "time"):
        if getattr(d, name).size:
            getattr(d, name).assign(np.stack([np.asarray(getattr(x, name), dtype=float) for x in starts]))
    if plan.samples is not None:
        for s, data in zip(sims, starts, strict=True):
            s.observe(plan.observe, data)
    alive = np.array([s.alive for s in sims])
    scratch = [mujoco.MjData(s.model) for s in sims]
    h = float(group.ref.model.opt.timestep)
    for _ in range(group.ref.blocks):
        if not alive.any():
            break
        for _ in range(group.ref.block):
            mjw.step(m, d)
        wp.synchronize_device(d.qpos.device)
        _flag_diverged(sims, alive, mw.divergences(m, d), d, h)
        host = {name: getattr(d, name).numpy() for name in ("qpos", "qvel", "act", "time")}
        for i in np.flatnonzero(alive):
            data = scratch[i]
            data.qpos[:], data.qvel[:], data.time = host["qpos"][i], host["qvel"][i], float(host["time"][i])
            if data.act.size:
                data.act[:] = host["act"][i]
            sims[i].observe(plan.observe, data)
        alive &= np.array([s.alive for s in sims])
        if progress:
            progress(int(alive.sum()))


def _flag_diverged(sims, alive, divergences, d, h):
    for div in divergences:
        if alive[div.world]:
            sim = sims[div.world]
            message = div.message.replace(f"world {div.world} ", f"world {div.world} (variant {sim.outcome.index}) ", 1)
            sim.diverge(message, div.element, div.step * h)
            alive[div.world] = False
    finite = np.isfinite(d.qpos.numpy()).all(1) & np.isfinite(d.qvel.numpy()).all(1)
    for i in np.flatnonzero(alive & ~finite):
        index = sims[i].outcome.index
        sims[i].diverge(f"mjflex.warp: world {int(i)} (variant {index})'s state became non-finite (no flexure was "
                        "found violent)", "", math.nan)  # fmt: skip
        alive[i] = False


def _groups(sims, mw):
    """Variants grouped so that each group can share one MuJoCo Warp model; incompatible ones get their own."""
    out, by_key = [], {}
    for s in sims:
        by_key.setdefault((*s.layout(), _options(s.model)), []).append(s)
    for members in by_key.values():
        while members:
            group = _Group(members, mw)
            rest, keep = [], [0]
            m_ref = mw.put_model(group.ref.model) if len(members) > 1 else None
            for i in range(1, len(members)):
                why = group.incompatible(i, m_ref)
                (rest if why else keep).append(i)
            group.sims = [members[i] for i in keep]
            group.tables = [group.tables[i] for i in keep]
            out.append(group)
            members = [members[i] for i in rest]
    return out


def run_part(plan, rows, progress, stats):
    """Build, group, step and observe the variants ``rows`` (a list of ``(index, params)``); their outcomes."""
    import mujoco_warp as mjw  # late: the warp extra, for the warp executor only
    import warp as wp  # late: the warp extra, for the warp executor only

    from ... import warp as mw  # late: imports warp (the warp extra)

    built = engine._build(plan, rows)
    sims = [s for s in built if isinstance(s, engine._Sim)]
    with engine.installed([s.flex for s in sims]):
        stepped = [s for s in sims if s.blocks]
        if len(stepped) < len(sims):
            engine._observe_initial(plan, [s for s in sims if not s.blocks], progress)
        for group in _groups(stepped, mw):
            try:
                _run_group(plan, group, progress, wp, mjw, mw)
                stats["stepping"].add(WARP)
                stats["warp_batches"] += 1
            except Exception as exc:  # MuJoCo Warp refused the model: every variant of the group failed
                message = f"MuJoCo Warp could not run the variant: {engine._exc_text(exc)}"
                for s in group.sims:
                    if s.alive:
                        s.fail(message)
    return [s.outcome if isinstance(s, engine._Sim) else s for s in built]

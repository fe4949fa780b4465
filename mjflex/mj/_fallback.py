"""The Python fallback of the per-step path, for an install without the native library (no C compiler).

Same results as the C loop (``mjflex/native/elements.c``) to round-off, from the core's batch
functions (:func:`mjflex.wrench_on_b`, :func:`mjflex.potential`, ...) and ``mujoco.mj_applyFT``,
and the same divergence rules (:mod:`mjflex.mj.divergence`), at Python speed: a development and
last-resort path, used only when :func:`mjflex.mj._native.lib` is None (it warns once).
"""

import math

import mujoco
import numpy as np

from ..core import dissipation_power, potential, twist_from_transform, wrench_on_b
from ..core.validation import METHOD_NAMES
from . import _native
from .divergence import Divergence, step_index, step_phrase

_CANDIDATE_ACCEL = 1e8  # a hundredth of MuJoCo's mjMAXVAL, as CANDIDATE_ACCEL in elements.c
_BAD = (mujoco.mjtWarning.mjWARN_BADQPOS, mujoco.mjtWarning.mjWARN_BADQVEL, mujoco.mjtWarning.mjWARN_BADQACC)
_BAD_NAMES = ("qpos", "qvel", "qacc")


def check_supported(tables) -> None:
    """Refuse, naming the element, what the fallback does not implement: end stops (they would be lost silently)."""
    from ._tables import model_error

    for name, rec in zip(tables.names, tables.records, strict=True):
        if rec.stops:
            why = _native.FORCE_FALLBACK["reason"] or _native._STATE.get("why") or "the native library is not loaded"
            raise model_error(
                name, f"it has end stops, which mjflex's Python fallback does not implement (the fallback runs: {why})",
                "Build the native library (install a C compiler, then reinstall mjflex: pip install --force-reinstall "
                "--no-deps <mjflex source>), or remove the element's stops",
            )  # fmt: skip


def _frame_b(row, R, p):
    if not row["offset"]:
        return R, p
    Rs = R @ row["R0"].reshape(3, 3).T
    return Rs, p - Rs @ row["p0"]


def _point_velocity(model, data, body, p):
    w, v = data.cvel[body, :3], data.cvel[body, 3:]
    c = data.subtree_com[model.body_rootid[body]]
    return w, v + np.cross(w, p - c)


def evaluate(model, data, tables, mode, *, qfrc=None, out6=None, out1=None, n=None, scan=None):
    """As ``mjfx_evaluate``: returns -1 or the index of the first element with a non-finite wrench."""
    spring = not model.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_SPRING
    damper = not model.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_DAMPER
    n = len(tables.names) if n is None else n
    check_supported(tables)
    for i in range(n):
        row, rec = tables.elements[i], tables.records[i]
        if not row["enabled"]:
            if mode & (_native.WRENCH | _native.COORDS):
                out6[i] = 0.0
            if mode & (_native.ENERGY | _native.POWER):
                out1[i] = 0.0
            continue
        Ra, pa = data.site_xmat[row["site_a"]].reshape(3, 3), data.site_xpos[row["site_a"]]
        Rb, pb = _frame_b(row, data.site_xmat[row["site_b"]].reshape(3, 3), data.site_xpos[row["site_b"]])
        if mode & _native.COORDS:
            out6[i] = twist_from_transform(Ra.T @ Rb, Ra.T @ (pb - pa), check=False)
            continue
        method = METHOD_NAMES[int(row["method"])]
        K = row["K"].reshape(6, 6) if spring else np.zeros((6, 6))
        terms = (
            rec.terms if spring and rec.terms is not None and len(rec.terms) and method == rec.terms.method else None
        )
        if mode & _native.ENERGY:
            out1[i] = potential(Ra, pa, Rb, pb, K, method=method, terms=terms, check=False)
            continue
        viscous = damper and bool(row["viscous"])
        B = row["B"].reshape(6, 6) if viscous else None
        vel = {}
        if viscous:
            wa, va = _point_velocity(model, data, row["body_a"], pa)
            wb, vb = _point_velocity(model, data, row["body_b"], pb)
            vel = {"w_WA": wa, "v_WA": va, "w_WB": wb, "v_WB": vb}
        W = wrench_on_b(Ra, pa, Rb, pb, K, method=method, B=B, terms=terms, check=False, **vel)
        power = float(dissipation_power(Ra, pa, Rb, pb, B, method=method, check=False, **vel)) if viscous else 0.0
        if not np.isfinite(W).all() or not math.isfinite(power):
            if scan is not None:
                scan["nonfinite"] = i
            return i
        if scan is not None:
            accel = max(np.abs(W[3:]).max() * row["inv_mass"], np.abs(W[:3]).max() * row["inv_inertia"])
            if accel > scan["accel"]:
                scan["accel"], scan["largest"] = accel, i
        if mode & _native.WRENCH:
            out6[i] = W
        if mode & _native.POWER:
            out1[i] = power
        if mode & _native.APPLY:
            mujoco.mj_applyFT(model, data, W[3:], W[:3], pb, int(row["body_b"]), qfrc)
            mujoco.mj_applyFT(model, data, -W[3:], -W[:3], pb, int(row["body_a"]), qfrc)
    return -1


class Watch:
    """The per-mjData divergence watch of ``elements.c`` (``mjfx_watch_*``), in Python."""

    def __init__(self, n):
        self.n, self.seen, self.started = n, [0, 0, 0], False
        self.last_time = self.step_start = 0.0
        self.cand = None  # (element, accel, time, step, resets)
        self.resets = 0  # resets seen: repeats at equal times are different events
        self.tally = {}  # element -> [count, first step, first verdict, (last step, resets)]

    def _recent(self, t, h):
        return self.cand is not None and t - 1.5 * h <= self.cand[2] <= t

    def _count(self, e, step, resets, verdict):
        entry = self.tally.get(e)
        first = entry is None
        if first:
            self.tally[e] = entry = [0, step, verdict, None]
        entry[0] += 1
        entry[3] = (step, resets)
        return first

    def _counted(self, e, step, resets):
        entry = self.tally.get(e)
        return entry is not None and entry[3] == (step, resets)

    def judge(self, model, data):
        """``[(element, first, verdict)]`` of a bad step MuJoCo found since the last look."""
        now = [int(data.warning[w].number) for w in _BAD]
        rose = next((i for i in range(3) if now[i] > self.seen[i]), None)
        out = []
        reset = self.started and data.time < self.last_time
        if reset and rose is None:
            rose = next((i for i in range(3) if now[i] > 0), None)
            if rose is None:
                resets = self.resets
                self.__init__(self.n)  # the user's reset: a new run
                self.resets = resets + 1
                return out
        if rose is not None and self._recent(self.last_time, model.opt.timestep):
            e, accel, _, step, resets = self.cand
            if not self._counted(e, step, resets):
                verdict = (math.isinf(accel), accel, step, rose)
                out.append((e, self._count(e, step, resets, verdict), verdict))
            self.cand = None
        self.seen = now
        self.resets += bool(reset)
        return out

    def record(self, model, data, scan):
        t, h = data.time, model.opt.timestep
        if not self.started or t < self.step_start or t >= self.step_start + (1 - 1e-9) * h:
            self.step_start = t
        self.started, self.last_time = True, t
        if self.cand is not None and not self._recent(t, h):
            self.cand = None
        e = scan["nonfinite"]
        if e >= 0:
            self.cand = (e, math.inf, t, self.step_start, self.resets)
            if self._counted(e, self.step_start, self.resets):
                return []
            verdict = (True, math.inf, self.step_start, -1)
            return [(e, self._count(e, self.step_start, self.resets, verdict), verdict)]
        big = scan["largest"] >= 0 and scan["accel"] > _CANDIDATE_ACCEL
        if big and (self.cand is None or scan["accel"] >= self.cand[1]):
            self.cand = (scan["largest"], scan["accel"], t, self.step_start, self.resets)
        return []


def report_text(model, element, verdict) -> str:
    """The report's text, as ``mjfx_report_text`` writes it."""
    nonfinite, accel, step, bad = verdict
    name = model.names[: model.names.index(b"\x00")].decode() or "unnamed"
    text = f"mjflex: flexure '{element}' of model '{name}' diverged in {step_phrase(step, model.opt.timestep)}: "
    if nonfinite:
        text += "its wrench is not finite (a NaN or infinite state, or forces beyond float64)."
    else:
        text += (
            f"MuJoCo found a bad {_BAD_NAMES[bad]}, and this element's force alone accelerates one of its bodies at "
            f"{accel:.3g} (m/s^2 or rad/s^2; MuJoCo's limit is 1e10)."
        )
    return text + (
        " Reduce the time step (mjflex.normal_modes gives the stiffest mode) or check the qpos/qvel "
        "you set. Later divergences of this element in this run (until mj_resetData) are counted, not printed: "
        "Flexures.divergences(data)."
    )


def apply_and_watch(flex, model, data):
    """The fallback dispatcher's work on a served model: watch, add the forces, report."""
    from ._callback import report_in_python

    watch = flex._watches.setdefault(data._address, Watch(flex._served))
    reports = watch.judge(model, data)
    scan = {"nonfinite": -1, "largest": -1, "accel": 0.0}
    bad = evaluate(model, data, flex._tables, _native.APPLY, qfrc=data.qfrc_passive, n=flex._served, scan=scan)
    if bad >= 0:
        data.qfrc_passive[:] = np.nan
    reports += watch.record(model, data, scan)
    for e, first, verdict in reports:
        report_in_python(model, report_text(model, flex.names[e], verdict), first)


def divergences(flex, data) -> dict[str, Divergence]:
    """:meth:`mjflex.Flexures.divergences` from the fallback's watch."""
    watch, h = flex._watches.get(data._address), flex.model.opt.timestep
    if watch is None:
        return {}
    out = {}
    for e, (count, step, verdict, _) in watch.tally.items():
        name = flex.names[e]
        out[name] = Divergence(name, count, step, step_index(step, h), report_text(flex.model, name, verdict))
    return out

"""Where a reduction looks at the scene, and what :func:`mjflex.reduce` checks of the model it made.

**The scene's states.** Each keyframe (its pose and controls), or ``qpos0`` with zero controls when the
model has none, under gravity and the applied loads: the model rests at their static equilibria
(:func:`mjflex.static_equilibrium`). A reduction, for a band or a time step, linearizes the full
model at the first of them (its modes are what the selection holds rigid or keeps) and compares the
reduced model's modes at its own rest there; for a time step it also asks the reduced model's step
advice (:func:`mjflex.step_advice`) at each of its own equilibria under the same
controls: the advice linearizes a rest, where the scene runs, not ``qpos0`` (which under gravity is
not at rest). Where no rest exists (a free body that nothing holds), the state is linearized at its
keyframe or ``qpos0`` without gravity, and the report says so.

**The checks** (``details``): the modes below the band against the full model's at the same state
(``"modes"``), the step advice at each state and the worst of them (``"step"``), and the statics under
the scene's loads, part by part (``"statics"``).
"""

import warnings
from dataclasses import dataclass

import mujoco
import numpy as np

from ..analysis.advice import step_advice
from ..analysis.linearize import NotAtRestWarning, normal_modes, state
from ..analysis.statics import static_equilibrium
from ..runtime.flexures import Flexures
from .reduce_choice import rigid_floor
from .variant import body_names

#: The static equilibria are solved to this fraction of the load: positions to far better than the 1 % compared.
STATICS_TOL = 1e-8
_NO_REST = (ValueError, RuntimeError, np.linalg.LinAlgError)  # static_equilibrium's failures: no rest found


@dataclass(frozen=True)
class SceneState:
    """One state of the scene: a keyframe (or None: ``qpos0``, zero controls) and where the model rests under it.

    ``qpos`` ``(nq,)``: the static equilibrium under gravity, the applied loads and the keyframe's controls, or
    None when there is none (``failed`` says why).
    """

    keyframe: int | None
    qpos: np.ndarray | None
    failed: str | None = None
    name: str = ""

    @property
    def label(self) -> str:
        """``"qpos0"``, ``"keyframe 'home'"`` or ``"keyframe 0"`` (unnamed)."""
        if self.keyframe is None:
            return "qpos0"
        return f"keyframe {self.name!r}" if self.name else f"keyframe {self.keyframe}"


def scene_states(model, flex) -> list[SceneState]:
    """The scene's states of ``model`` (module docstring), each with its static equilibrium or why it has none."""
    out = []
    for key in list(range(model.nkey)) or [None]:
        name = "" if key is None else mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_KEY, key) or ""
        try:
            out.append(SceneState(key, static_equilibrium(model, flex, keyframe=key, tol=STATICS_TOL), name=name))
        except _NO_REST as exc:
            out.append(SceneState(key, None, str(exc), name))
    return out


def modes_at(model, flex, at, actuator_stiffness=True):
    """Normal modes ``(freq (n,) [Hz], modes (nv, n))`` as :func:`mjflex.reduce` takes them: springs, actuators and
    equalities projected, at the :class:`SceneState` ``at`` under its load and controls (None: ``qpos0`` unloaded)."""
    constraints = "project" if model.neq else "ignore"
    if at is None or at.qpos is None:
        return normal_modes(model, flex, keyframe=None if at is None else at.keyframe, joint_springs=True,
                            actuator_stiffness=actuator_stiffness, constraints=constraints)  # fmt: skip
    return normal_modes(model, flex, keyframe=at.keyframe, qpos=at.qpos, gravity=True, joint_springs=True,
                        actuator_stiffness=actuator_stiffness, constraints=constraints)  # fmt: skip


def state_line(states, at):
    """Report line: where the full model was linearized."""
    if at is not None:
        controls = "zero controls" if at.keyframe is None else "its controls"
        return (f"linearized where the scene rests, as the step advice is asked: the static equilibrium from "
                f"{at.label} under gravity ({controls})")  # fmt: skip
    why = "; ".join(f"{s.label}: {s.failed.splitlines()[0][:160]}" for s in states)
    return f"linearized at qpos0 without the load: the scene has no rest ({why})"


def verify_modes(variant, freq, mask, at=None):
    """Compare the variant's modes with the kept modes of the full model (details and report), at the state ``at``
    (the variant's own equilibrium under its controls) or at ``qpos0`` unloaded."""
    flex = Flexures(variant.model) if variant.has_flexures else None
    f_var, _ = modes_at(variant.model, flex, at, variant.details.get("actuator_stiffness", False))
    full = freq[mask]
    reduced = f_var[f_var > rigid_floor(f_var)][: len(full)]
    n = min(len(full), len(reduced))
    err = np.abs(reduced[:n] - full[:n]) / full[:n] if n else np.zeros(0)
    variant.details["modes"] = {
        "full_hz": full.tolist(), "reduced_hz": reduced.tolist(), "max_relative_error": float(err.max(initial=0.0)),
        "highest_hz": float(f_var.max(initial=0.0)), "highest_full_hz": float(freq.max()),
        "state": "qpos0" if at is None or at.qpos is None else at.label,
    }  # fmt: skip
    first = ", ".join(f"{a:.4g}/{b:.4g}" for a, b in zip(full[:4], reduced[:4], strict=False))
    variant.report += (
        f"\nmodes below {variant.details['keep_below_hz']:g} Hz: {len(full)} in the full model, {len(reduced)} here; "
        f"largest relative change {100 * float(err.max(initial=0.0)):.3g} % (first, full/reduced Hz: {first}); "
        f"highest mode {f_var.max(initial=0.0):.4g} Hz (full model {freq.max():.4g} Hz)"
    )


def _advice(model, flex, at):
    """The step advice at a state (its equilibrium, or its keyframe / qpos0 unloaded): (StepAdvice or None, note)."""
    if at.qpos is not None:
        try:
            return step_advice(model, flex, keyframe=at.keyframe, qpos=at.qpos), None
        except ValueError as exc:  # no elastic mode at all: nothing limits the step
            return None, str(exc)
    with warnings.catch_warnings(record=True) as seen:  # said in the report, not printed: the state is not a rest
        warnings.simplefilter("always", NotAtRestWarning)
        try:
            advice, note = step_advice(model, flex, keyframe=at.keyframe, gravity=False), None
        except ValueError as exc:
            advice, note = None, str(exc)
    said = [str(w.message) for w in seen if issubclass(w.category, NotAtRestWarning)]
    return advice, "; ".join([f"asked at {at.label} without gravity: no rest ({at.failed.splitlines()[0][:160]})",
                              *said, *([note] if note else [])])  # fmt: skip


def verify_step(variant, plan, states, own):
    """The variant's step advice at each scene state (the worst kept), and its statics against the full model's
    (``states``, ``own``: the full model's and the variant's :class:`SceneState` lists): the largest error of a
    geom's centre (the parts, where they are: positions and rotations of the bodies that carry them) over the
    largest displacement of one from ``qpos0``."""
    model = variant.model
    flex = Flexures(model) if variant.has_flexures else None
    step = variant.details["step"] = dict(plan.details["step"])
    per_state, notes = [], []
    keys = ("advised_step", "advised_limit", "limiting_hz", "damping_ratio")
    for at in own:
        advice, note = _advice(model, flex, at)
        if note:
            notes.append(f"{at.label}: {note}")
        limit = (advice.recommended, advice.limit, advice.frequency, advice.damping_ratio) if advice else (
            float("inf"), float("inf"), 0.0, 0.0)  # fmt: skip
        per_state.append({"state": at.label, **dict(zip(keys, limit, strict=True)), "at_rest": at.qpos is not None})
    worst = min(per_state, key=lambda s: s["advised_step"])
    step.update({k: worst[k] for k in keys}, advice_state=worst["state"], advice_states=per_state)
    if notes:
        step["advice_note"] = " | ".join(notes)
    ok = step["advised_step"] >= step["timestep"] * (1.0 - 1e-9)
    where = "its rest" if worst["at_rest"] else "a state that is not a rest (advice_note)"
    variant.report += (
        f"\nat {step['timestep']:g} s: the reduced model's step advice {step['advised_step']:.3g} s "
        f"({'resolved' if ok else 'NOT resolved'}; limit {step['advised_limit']:.3g} s, mode "
        f"{step['limiting_hz']:.4g} Hz, damping ratio {abs(step['damping_ratio']):.2g}; at {worst['state']}, {where}"
        f"{f', the worst of {len(per_state)} states' if len(per_state) > 1 else ''})"
    )
    _statics(variant, plan.model, states, own)


def _statics(variant, src, states, own):
    """``details["statics"]``: per scene state, the parts' positions at the two models' equilibria compared."""
    failed = [f"{s.label}: {s.failed}" for s in (*states, *own) if s.qpos is None]
    if failed:  # a scene without a rest (a free body)
        variant.details["statics"] = {"failed": failed[0]}
        variant.report += f"\nstatics not compared: {failed[0]}"
        return
    src_names = body_names(src)
    ref = mujoco.MjData(src)
    mujoco.mj_kinematics(src, ref)
    errors = []
    for at, at_red in zip(states, own, strict=True):
        full, red = state(src, at.keyframe, at.qpos), state(variant.model, at_red.keyframe, at_red.qpos)
        mujoco.mj_kinematics(src, full)
        mujoco.mj_kinematics(variant.model, red)
        moved, err = 0.0, 0.0
        for g in range(src.ngeom):  # every part's centre (and so the bodies' rotations), where it is
            b = int(src.geom_bodyid[g])
            vb, X_VS = variant.body_map.get(src_names[b], (None, None)) if b and src_names[b] else (None, None)
            if vb is None:
                continue
            v = variant.model.body(vb).id
            r = full.xmat[b].reshape(3, 3).T @ (full.geom_xpos[g] - full.xpos[b])  # in the source body's frame
            point = red.xpos[v] + red.xmat[v].reshape(3, 3) @ (X_VS[:3, :3] @ r + X_VS[:3, 3])
            moved = max(moved, float(np.linalg.norm(full.geom_xpos[g] - ref.geom_xpos[g])))
            err = max(err, float(np.linalg.norm(point - full.geom_xpos[g])))
        scale = max(moved, 1e-9 * max(float(src.stat.extent), 1e-3))  # no load: judge against the model's size
        errors.append({"keyframe": at.keyframe, "moved": moved, "error": err, "relative": err / scale})
    variant.details["statics"] = errors
    worst = max(errors, key=lambda r: r["relative"])
    variant.report += (
        f"\nstatics under the scene's loads ({len(errors)} state(s): gravity and each keyframe's controls): largest "
        f"error of a part's position {worst['error']:.3g} m, {100 * worst['relative']:.3g} % of the largest "
        f"displacement {worst['moved']:.3g} m"
    )


__all__ = ["SceneState", "modes_at", "scene_states", "state_line", "verify_modes", "verify_step"]

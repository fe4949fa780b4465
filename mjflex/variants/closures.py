"""How far a model's equality constraints are from closed at the operating pose, before and after ``make_compliant``.

MuJoCo's equality constraints are soft: ``solref``'s time constant and damping ratio set how fast
a violation is removed, and the constraint's stiffness scales with the effective mass at the
constraint (the inverse of ``J M^-1 J^T``). A loop closed by a ``connect`` equality, tuned for
the joints' armature, opens further when the pivots it closes become an element's coordinates
with light added joints beside them: the same ``solref`` then holds the same load with less
stiffness. :func:`closures` measures it: each model is brought to rest at the operating pose
(:func:`mjflex.static_equilibrium` from the keyframe, its controls and gravity; free joints
held where the keyframe puts them, a floating base having no rest), and each equality's
violation there is read from MuJoCo's own constraint residual (``efc_pos``).
"""

import warnings
from dataclasses import dataclass

import mujoco
import numpy as np

from ..analysis.linearize import state
from ..analysis.statics import static_equilibrium
from ..mjcf.notices import warn_likely_mistake
from ..runtime.flexures import Flexures

#: A closure that opens more than this many times its rigid value is warned about.
GROWTH = 10.0
#: Violations below this (times the model's extent for lengths; rad for angles) are round-off and never warned about.
FLOOR = 1e-6
_EQ = mujoco.mjtEq
_TYPES = {int(_EQ.mjEQ_CONNECT): "connect", int(_EQ.mjEQ_WELD): "weld", int(_EQ.mjEQ_JOINT): "joint",
          int(_EQ.mjEQ_TENDON): "tendon"}  # fmt: skip


@dataclass(frozen=True)
class Closure:
    """One equality constraint's violation at the operating pose, in the rigid and in the compliant model.

    Attributes
    ----------
    equality : str
        Its name (``"#i"``, its id in the compliant model, when unnamed).
    type : str
        ``"connect"``, ``"weld"`` (its anchors' distance), ``"weld rotation"`` (its rotation),
        ``"joint"`` or ``"tendon"``.
    rigid, compliant : float
        The violation at rest: the distance between a ``connect``'s or a ``weld``'s two anchors [m],
        the angle of a weld's rotation error [rad], a joint or tendon equality's residual [rad or m].
    unit : str
        ``"m"`` or ``"rad"``.
    opened : bool
        Whether it opened more than ``GROWTH`` times, above the round-off ``FLOOR`` (warned about).

    Examples
    --------
    A four-bar's ``connect`` that held to 6.4 um and opens 0.70 mm once a pivot is an element's coordinate (the
    test ``tests/test_compliance_replace.py`` makes it):

    >>> import mjflex
    >>> loop = mjflex.Closure("loop", "connect", rigid=6.4e-6, compliant=7.0e-4, unit="m", opened=True)
    >>> print(f"{loop.equality}: {loop.growth:.0f} times the rigid model's opening")
    loop: 109 times the rigid model's opening
    """

    equality: str
    type: str
    rigid: float
    compliant: float
    unit: str
    opened: bool = False

    @property
    def growth(self) -> float:
        """``compliant / rigid`` (inf when the rigid model held it exactly)."""
        return self.compliant / self.rigid if self.rigid > 0 else (np.inf if self.compliant > 0 else 1.0)


def violations(model, data) -> dict[int, list[tuple[str, float, str]]]:
    """``{equality id: [(type, violation, unit), ...]}`` from ``data``'s constraint rows (after ``mj_forward``)."""
    rows: dict[int, list[float]] = {}
    for r in np.flatnonzero(data.efc_type[: data.nefc] == mujoco.mjtConstraint.mjCNSTR_EQUALITY):
        rows.setdefault(int(data.efc_id[r]), []).append(float(data.efc_pos[r]))
    out = {}
    for i, pos in rows.items():
        kind = _TYPES.get(int(model.eq_type[i]))
        if kind is None:
            continue
        if kind == "connect":
            out[i] = [(kind, float(np.linalg.norm(pos[:3])), "m")]
        elif kind == "weld":
            scale = model.eq_data[i][10]  # MuJoCo writes the rotation rows times the weld's torquescale
            out[i] = [(kind, float(np.linalg.norm(pos[:3])), "m")]
            if scale > 0 and len(pos) == 6:
                out[i].append(("weld rotation", float(np.linalg.norm(pos[3:]) / scale), "rad"))
        else:
            joint = kind == "joint" and model.jnt_type[model.eq_obj1id[i]] == mujoco.mjtJoint.mjJNT_SLIDE
            out[i] = [(kind, abs(pos[0]), "m" if kind == "tendon" or joint else "rad")]
    return out


def at_rest(model, keyframe=None) -> tuple[mujoco.MjData | None, str | None]:
    """``(data, None)`` after ``mj_forward`` at the model's rest from ``keyframe`` (free joints held), or
    ``(None, why)`` when it has none."""
    held = set()
    for j in np.flatnonzero(model.jnt_type == mujoco.mjtJoint.mjJNT_FREE):
        held |= set(range(model.jnt_dofadr[j], model.jnt_dofadr[j] + 6))
    dofs = [d for d in range(model.nv) if d not in held]
    with warnings.catch_warnings():  # contacts and advice are reported elsewhere, once
        warnings.simplefilter("ignore")
        flex = Flexures(model)
        try:
            qpos = static_equilibrium(model, flex if flex.names else None, keyframe=keyframe, dofs=dofs)
        except (RuntimeError, ValueError, np.linalg.LinAlgError) as exc:
            return None, str(exc)
    data = state(model, keyframe, qpos)
    with flex:
        mujoco.mj_forward(model, data)
    return data, None


def closures(rigid, compliant, matched, keyframe=None, element="", stacklevel=2):
    """``(closures, note)``: each matched equality's :class:`Closure` at rest, and why none were measured (or None).

    ``matched``: ``(rigid id, compliant id)`` pairs of the equalities to compare (those the
    replacement kept). Warns (:class:`mjflex.LikelyMistakeWarning`) for each that opens more than
    ``GROWTH`` times its rigid value, above the round-off ``FLOOR``.
    """
    active = [(a, b) for a, b in matched if rigid.eq_active0[a] and compliant.eq_active0[b]]
    if not active or rigid.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_EQUALITY:
        return (), None
    held = {}
    for which, model in (("rigid", rigid), ("compliant", compliant)):
        data, why = at_rest(model, keyframe)
        if data is None:
            return (), f"the {which} model has no rest at the operating pose to measure its closures at: {why}"
        held[which] = violations(model, data)
    out = []
    for a, b in active:
        name = mujoco.mj_id2name(compliant, mujoco.mjtObj.mjOBJ_EQUALITY, b) or f"#{b}"
        for (kind, before, unit), (_, after, _) in zip(held["rigid"].get(a, ()), held["compliant"].get(b, ()),
                                                        strict=False):  # fmt: skip
            floor = FLOOR * (rigid.stat.extent if unit == "m" else 1.0)
            out.append(Closure(name, kind, before, after, unit, after > floor and after > GROWTH * before))
    for c in out:
        if c.opened:
            warn_likely_mistake(
                f"flexure {element!r}: equality {c.equality!r} ({c.type}) is open {c.compliant:.3g} {c.unit} at the "
                f"operating pose, {c.growth:.3g} times the rigid model's {c.rigid:.3g} {c.unit}. Its solref sets a "
                "stiffness that scales with the effective mass at the constraint, which the replacement changed "
                "(light joints added beside the coordinates): shorten its time constant (solref) or raise its "
                "impedance (solimp) until it holds as before (Compliance.closures has the figures)",
                stacklevel=stacklevel + 1,
            )
    return tuple(out), None

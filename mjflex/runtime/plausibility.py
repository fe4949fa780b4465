"""Stiffness that cannot be meant: an element that would let the body it holds sag under gravity by more than the
body's size (:func:`implausible_stiffness`), most likely a K in N m/deg or N/mm given as SI.

Checked once per model, where :class:`mjflex.Flexures` reads it (both forms, any file), never in a step. The load is
the weight of what the element holds: the subtree of the body on its side (the child, where one body is in the
other's subtree; else the lighter one; never the world), at that subtree's centre of mass at ``qpos0``. Only bodies
free of their parent (six degrees of freedom of their own joints: free joints, or the coordinate joints of
``replace_joints``) are judged: a body on fewer joints is held by them too, and MuJoCo's constraints take the load
the element does not. The sag is the linear deflection ``K^+ w`` of the element alone (the whole weight on it, a
bound where several elements share a body), clipped to the element's end stops, carried to the centre of mass.
"""

import os
import sys
from typing import NamedTuple

import mujoco
import numpy as np

from ..core.stops import PLANAR_INDEX
from ..mjcf.schema import embed_planar
from .contacts import ancestors

_LINEAR = 6  # dofs a body needs of its own joints for the element to hold it alone


class Sag(NamedTuple):
    """How far an element lets the body it holds sag under gravity (:func:`sags`)."""

    element: str
    body: str  # the body held (the root of the subtree weighed)
    mass: float  # [kg]
    size: float  # [m]: the body's extent from its origin (its geoms; its radius of gyration without geoms)
    sag: float  # [m]: the displacement of the subtree's centre of mass
    coordinates: np.ndarray  # (6,) [rad; m]: the deflection [rotation vector; translation] in the element frame
    turning: bool  # True where the rotation moves the centre of mass more than the translation


def _size(model, body) -> float:
    """Extent of ``body`` from its origin [m]: its geoms' bounding spheres, else its radius of gyration."""
    geoms = np.flatnonzero(model.geom_bodyid == body)
    if geoms.size:
        return float(np.max(np.linalg.norm(model.geom_pos[geoms], axis=1) + model.geom_rbound[geoms]))
    mass = model.body_mass[body]
    return float(np.sqrt(2.5 * model.body_inertia[body].max() / mass)) if mass > 0 else 0.0


def _held(model, a, b):
    """``(body held, sign)``: the side the element holds against gravity (+1: body B, -1: body A), or None."""
    if a == 0 or a in ancestors(model, b):
        held, sign = b, 1.0
    elif b == 0 or b in ancestors(model, a):
        held, sign = a, -1.0
    else:
        held, sign = (b, 1.0) if model.body_subtreemass[b] <= model.body_subtreemass[a] else (a, -1.0)
    return (held, sign) if model.body_dofnum[held] >= _LINEAR else None


def _stop_range(stops):
    """``(lower, upper)`` ``(6,)`` of an element's stops, widened to include 0 (the load starts at rest)."""
    out = []
    for limits, fill in ((stops.lower, -np.inf), (stops.upper, np.inf)):
        v = np.full(6, fill)
        if limits is not None:
            given = np.asarray(limits, float)
            v[list(PLANAR_INDEX) if len(given) == 3 else slice(None)] = given
        out.append(np.minimum(v, 0) if fill < 0 else np.maximum(v, 0))
    return out


def sags(model, records, elements) -> list[Sag]:
    """The gravity sag of each element that holds a free body (module docstring), in element order.

    Parameters
    ----------
    model : mujoco.MjModel
    records : sequence of mjflex.FlexureRecord
        The elements' parameters (``K`` in the element frame, ``stops``).
    elements : ndarray
        The element table's rows (``mjflex.native.library.ELEMENT_DTYPE``: ``site_a``, ``body_a``, ``body_b``).

    Returns
    -------
    list of Sag
        Empty without gravity.
    """
    g = np.asarray(model.opt.gravity, float)
    if not np.any(g) or model.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_GRAVITY or not len(records):
        return []
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    mujoco.mj_comPos(model, data)
    out = []
    for record, row in zip(records, elements, strict=False):
        held = _held(model, int(row["body_a"]), int(row["body_b"]))
        mass = model.body_subtreemass[held[0]] if held else 0.0
        size = _size(model, held[0]) if held else 0.0
        if not held or mass <= 0 or size <= 0:
            continue
        body, sign = held
        R_WE, p_WE = data.site_xmat[row["site_a"]].reshape(3, 3), data.site_xpos[row["site_a"]]
        lever = R_WE.T @ (data.subtree_com[body] - p_WE)
        force = R_WE.T @ (mass * g)
        K = embed_planar(record.K) if record.planar else np.asarray(record.K, float)
        xi = sign * (np.linalg.pinv(K, hermitian=True) @ np.concatenate([np.cross(lever, force), force]))
        if record.stops is not None:
            xi = np.clip(xi, *_stop_range(record.stops))
        turn = np.cross(xi[:3], lever)
        sag = float(np.linalg.norm(xi[3:] + turn))
        out.append(Sag(record.name, mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, body) or f"#{body}",
                       float(mass), size, sag, xi, bool(np.linalg.norm(turn) >= np.linalg.norm(xi[3:]))))  # fmt: skip
    return out


_PACKAGE = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def outside_stacklevel() -> int:
    """The ``stacklevel`` (counted from the caller of this function, 1) of the first frame outside mjflex: a warning
    given where mjflex reads a model for its own purposes (``reduce``, the variants) is the user's call's, once."""
    frame, level = sys._getframe(1), 1
    while frame is not None and frame.f_code.co_filename.startswith(_PACKAGE + os.sep):
        frame, level = frame.f_back, level + 1
    return level


def implausible_stiffness(model, records, elements) -> list[str]:
    """A message for each element that lets the body it holds sag under gravity by more than the body's size.

    Parameters
    ----------
    model : mujoco.MjModel
    records : sequence of mjflex.FlexureRecord
    elements : ndarray
        The element table's rows (see :func:`sags`).

    Returns
    -------
    list of str
        One sentence per implausible element, naming it and suggesting :mod:`mjflex.units`.
    """
    out = []
    for s in sags(model, records, elements):
        if s.sag > s.size:
            part = (f"mostly a rotation of {np.degrees(np.linalg.norm(s.coordinates[:3])):.3g} deg" if s.turning
                    else f"mostly a translation of {np.linalg.norm(s.coordinates[3:]):.3g} m")  # fmt: skip
            out.append(
                f"flexure '{s.element}': its K lets body '{s.body}' ({s.mass:.3g} kg, {s.size:.3g} m from its origin) "
                f"sag {s.sag:.3g} m under gravity ({part}), more than its size: K is "
                "most likely not in SI units (N m/rad, N/rad, N/m). Convert numbers from papers and data sheets with "
                "mjflex.units, e.g. 2.0 * mjflex.units.N_m_per_deg, 500 * mjflex.units.N_per_mm; silence "
                "mjflex.LikelyMistakeWarning if this softness is meant"
            )
    return out

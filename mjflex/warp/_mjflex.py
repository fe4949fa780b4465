"""What mjflex.warp reads from the rest of mjflex: the one place that knows mjflex's element table.

The elements of a model are read by :class:`mjflex.Flexures` (both forms: text records and
``mjflex.flexure`` plugin instances, parsed and checked once), and laid out here as plain numpy
arrays for the Warp kernels. Everything the kernels derive (rest offsets folded into the site
orientations, lever arms, contributions to dofs) is computed here from the model, independently of
the C engine's own set-up.
"""

import dataclasses
from dataclasses import dataclass

import mujoco
import numpy as np

from ..core.series import series_coefficients
from ..mjcf import schema
from ..native import library
from ..runtime.flexures import Flexures
from . import _kernels as kn

#: Record fields the kernels implement, or that do not change the forces (reports, provenance; and the display
#: attributes of the schema table, schema.display_fields).
SUPPORTED_FIELDS = {
    "name", "method", "K", "B", "enabled", "viscous", "terms", "order", "strain_per_radian", "source", "site", "stops",
    "rest",
}  # fmt: skip
METHODS = {"twist": kn.TWIST, "dualquat": 1}


class UnsupportedElementError(NotImplementedError):
    """An element uses a feature of mjflex that the Warp kernels do not implement (the message names both)."""


@dataclass
class ElementTable:
    """The elements of one model as the Warp kernels read them: ``n`` elements, ``M`` polynomial terms.

    Made by :func:`mjflex.warp.element_table` (and by :func:`mjflex.warp.put_model`) from
    :class:`mjflex.Flexures`' reading of the model; everything the kernels derive from the model
    is computed here, independently of the C engine's own set-up. Matrices and 6-vectors are in
    the element frame, rows ``[rotation; translation]`` (planar elements embedded at rows
    ``[2, 3, 4]``), SI units.

    Attributes
    ----------
    names, kinds : tuple of str
        Element names; forms (``"record"`` or ``"plugin"``).
    records : list of mjflex.FlexureRecord
        Each element's parameters as written.
    instances : tuple of int
        Plugin instance id of each element, -1 for a text record.
    ints : ndarray of int32, shape (n, I_NCOL)
        Bodies, sites, method, roots, free-body flags and term ranges (the ``I_*`` columns of
        ``mjflex.warp._kernels``).
    qa, qb : ndarray, shape (n, 4)
        Orientation (w-first) of frame a in body A, and of frame b in body B times the rest offset's
        inverse (frame b*; the rest offset: the sites' rounding residual, then the rest pose).
    p0 : ndarray, shape (n, 3)
        Rest offset: position of frame b* in frame a at ``qpos0`` [m].
    lever_a, lever_b : ndarray, shape (n, 3)
        Origins of frames a and b* in their bodies [m].
    inv_mass, inv_inertia : ndarray, shape (n,)
        The bodies' largest inverse mass [1/kg] and inverse inertia [1/(kg m^2)] (divergence blame).
    K, B : ndarray, shape (n, 6, 6)
        Stiffness and damping (B zero without damping) [N m/rad, N/m; N m s/rad, N s/m].
    enabled, viscous : ndarray of bool, shape (n,)
        The element's switch; its damping's (the record's switch, and it has B).
    planar : ndarray of bool, shape (n,)
        Planar elements.
    stop_lower, stop_upper : ndarray, shape (n, 6)
        End stops' limits on ``[rx, ry, rz, x, y, z]`` [rad, m] (planar: at ``[2, 3, 4]``),
        ``-inf`` / ``+inf`` where a coordinate has none.
    stop_stiffness : ndarray, shape (n, 6)
        The stops' stiffness as the C engine reads it (given, or derived from K; 0 where no limit)
        [N m/rad, N/m].
    stop_derived : ndarray of bool, shape (n,)
        The stops' stiffness is derived from K (none given; or no stops).
    stop_damping : ndarray, shape (n, 6)
        The stops' damping as the C engine reads it (0 where none or no limit) [N m s/rad, N s/m].
    exps : ndarray of int32, shape (M, 8)
        Exponents of the polynomial terms.
    coefs : ndarray, shape (M,)
        Their coefficients [J].
    start : ndarray of int32, shape (nv + 1,)
        Contributions to dof ``j`` are ``start[j]:start[j + 1]`` of ``element`` and ``code``.
    element, code : ndarray of int32, shape (C,)
        Each contribution's element, and ``+-(1 + 4 kind + component)`` (``+``: body B, ``-``: A).
    series_c, series_g : ndarray, shape (NSERIES,)
        Coefficients of the twist map's scalars ``c`` and ``g`` in ``alpha^2``.
    joined_trees : dict
        Kinematic tree -> an element that joins it to another tree or a mocap body.

    Examples
    --------
    >>> import copy, mujoco
    >>> import mjflex.warp
    >>> from mjflex.mjcf.elements import EXAMPLE_MODEL
    >>> table = mjflex.warp.element_table(copy.copy(mujoco.MjModel.from_xml_string(EXAMPLE_MODEL)))
    >>> table.names, table.kinds, bool(table.stop_derived[0]), table.stop_upper[0]
    (('hinge',), ('record',), True, array([inf, inf, inf, inf, inf, inf]))
    """

    names: tuple[str, ...]
    kinds: tuple[str, ...]
    records: list
    instances: tuple[int, ...]
    ints: np.ndarray
    qa: np.ndarray
    qb: np.ndarray
    p0: np.ndarray
    lever_a: np.ndarray
    lever_b: np.ndarray
    inv_mass: np.ndarray
    inv_inertia: np.ndarray
    K: np.ndarray
    B: np.ndarray
    enabled: np.ndarray
    viscous: np.ndarray
    planar: np.ndarray
    stop_lower: np.ndarray
    stop_upper: np.ndarray
    stop_stiffness: np.ndarray
    stop_derived: np.ndarray
    stop_damping: np.ndarray
    exps: np.ndarray
    coefs: np.ndarray
    start: np.ndarray
    element: np.ndarray
    code: np.ndarray
    series_c: np.ndarray
    series_g: np.ndarray
    joined_trees: dict


def unsupported_features(record) -> list[str]:
    """Features of ``record`` (a FlexureRecord) that the Warp kernels do not implement, set to a non-default value."""
    found = []
    for f in dataclasses.fields(record):
        if f.name in SUPPORTED_FIELDS | schema.display_fields():
            continue
        default = f.default if f.default is not dataclasses.MISSING else None
        value = getattr(record, f.name)
        if value is not None and not _equal(value, default):
            found.append(f.name)
    if record.method not in METHODS:
        found.append(f"method {record.method!r}")
    return found


def _equal(a, b):
    try:
        return bool(np.all(np.asarray(a) == np.asarray(b))) and np.shape(a) == np.shape(b)
    except (TypeError, ValueError):
        return a is b


def element_table(model: mujoco.MjModel, flex: Flexures | None = None) -> ElementTable:
    """Lay out the elements of ``model`` (read by ``flex``: made if None) for the kernels, refusing what they lack."""
    flex = Flexures(model) if flex is None else flex  # reads and checks the elements (joined trees: sleep never)
    t = flex.element_table
    n = len(flex)
    for name, record in zip(t.names, t.records, strict=True):
        features = unsupported_features(record)
        if features:
            raise UnsupportedElementError(
                f"mjflex.warp: flexure '{name}' uses {', '.join(features)}, which the MuJoCo Warp kernels of mjflex "
                "do not implement (its force would be wrong or missing). Simulate this model with MuJoCo (the C "
                "engine: mujoco.mj_step, mujoco.rollout, Batch), or remove the feature from the element"
            )
    rows = t.elements[:n]
    ints = np.zeros((n, kn.I_NCOL), np.int32)
    qa, qb, p0 = np.zeros((n, 4)), np.zeros((n, 4)), np.zeros((n, 3))
    lever_a, lever_b = np.zeros((n, 3)), np.zeros((n, 3))
    contributions = [[] for _ in range(model.nv)]
    for e, row in enumerate(rows):
        sa, sb, ba, bb = (int(row[k]) for k in ("site_a", "site_b", "body_a", "body_b"))
        ints[e, [kn.I_SITE_A, kn.I_SITE_B, kn.I_BODY_A, kn.I_BODY_B]] = sa, sb, ba, bb
        ints[e, kn.I_METHOD] = METHODS[t.records[e].method]
        ints[e, kn.I_ROOT_A], ints[e, kn.I_ROOT_B] = model.body_rootid[ba], model.body_rootid[bb]
        ints[e, kn.I_FREE_A], ints[e, kn.I_FREE_B] = row["free_a"] >= 0, row["free_b"] >= 0
        ints[e, kn.I_LO], ints[e, kn.I_HI] = row["terms_lo"], row["terms_hi"]
        ints[e, kn.I_REST] = row["rest"]  # the rest pose is in R0, p0 (the C reader composed it)
        # frame b* = frame b times the rest offset's inverse: q_ab is the identity at qpos0
        q0, Rb, p0[e] = np.empty(4), np.empty(9), row["p0"]
        mujoco.mju_mat2Quat(q0, np.ascontiguousarray(row["R0"], dtype=float).ravel())
        q0 = q0 if q0[0] >= 0 else -q0
        qa[e] = model.site_quat[sa]
        mujoco.mju_mulQuat(qb[e], np.asarray(model.site_quat[sb], float), q0 * [1, -1, -1, -1])
        mujoco.mju_quat2Mat(Rb, qb[e])
        lever_a[e] = model.site_pos[sa]
        lever_b[e] = model.site_pos[sb] - Rb.reshape(3, 3) @ p0[e]
        for side, sign in (("b", 1), ("a", -1)):
            free = int(row[f"free_{side}"])
            if free >= 0:
                for k in range(3):
                    contributions[free + k].append((e, sign * (1 + 4 * kn.FORCE + k)))
                    contributions[free + 3 + k].append((e, sign * (1 + 4 * kn.MOMENT + k)))
            else:
                for j in t.chain[row[f"chain_{side}0"] : row[f"chain_{side}1"]]:
                    contributions[int(j)].append((e, sign * (1 + 4 * kn.CHAIN)))
    start = np.zeros(model.nv + 1, np.int32)
    start[1:] = np.cumsum([len(c) for c in contributions])
    flat = [c for dof in contributions for c in dof] or [(0, 0)]
    series = series_coefficients(kn.NSERIES)
    return ElementTable(
        names=t.names, kinds=t.kinds, records=list(t.records), instances=t.instances, ints=ints, qa=qa, qb=qb, p0=p0,
        lever_a=lever_a, lever_b=lever_b, inv_mass=rows["inv_mass"].copy(), inv_inertia=rows["inv_inertia"].copy(),
        K=rows["K"].reshape(n, 6, 6).copy(), B=rows["B"].reshape(n, 6, 6).copy(),
        enabled=rows["enabled"].astype(bool), viscous=rows["viscous"].astype(bool),
        planar=np.array([r.planar for r in t.records], bool),
        stop_lower=rows["stop_lo"].copy(), stop_upper=rows["stop_hi"].copy(), stop_stiffness=rows["stop_k"].copy(),
        stop_derived=np.array([r.stops is None or r.stops.stiffness is None for r in t.records], bool),
        stop_damping=rows["stop_b"].copy(),
        exps=t.exps.astype(np.int32), coefs=t.coefs.copy(), start=start,
        element=np.array([c[0] for c in flat], np.int32), code=np.array([c[1] for c in flat], np.int32),
        series_c=series["c"], series_g=series["g"], joined_trees=dict(t.joined_trees),
    )  # fmt: skip


def mjflex_instances(model: mujoco.MjModel) -> list[int]:
    """Ids of the model's ``mjflex.flexure`` plugin instances."""
    return library.plugin_instances(model)


#: The planar coordinates [theta_z; x; y] in the 6-vector, and the sleep policies mjflex writes.
PLANAR_INDEX = schema.PLANAR_INDEX

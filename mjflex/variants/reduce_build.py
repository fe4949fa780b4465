"""Build the model :func:`mjflex.reduce` planned: joints, merged bodies, restricted elements, loop closures.

``build`` turns a ``Plan`` into a :class:`mjflex.Variant` through
``mjflex.variants.assemble.assemble``; :func:`mjflex.variants.reduce.closure_singularity` measures whether loops closed
by constraints would lock the mechanism.
"""

from dataclasses import dataclass

import mujoco
import numpy as np

from ..mjcf import schema
from ..runtime.flexures import Flexures
from .assemble import assemble, hinge_closure, rigid_closure
from .planar import planar_record, plane_frame
from .reduce_choice import rigid_floor
from .reduce_edges import edge_result, rejoint, restricted_record
from .reduce_verify import modes_at
from .tree import free_world_bodies, joints_of, link_of
from .variant import body_names, equality_rows


def springless(joints):
    """``joints`` without stiffness or damping (the element, in the compliant directions only, holds them)."""
    for joint in joints:
        joint.stiffness = joint.damping = 0.0
    return joints


def record_text(rec, K=None, B=None, viscous=None):
    same = K is None  # the element stays whole: its polynomial terms too (restricted ones keep K's part only); the
    # rest pose always (a restricted one rests there in its compliant directions, and in its rigid ones it is zero)
    out = schema.FlexureRecord(rec.name, rec.method, rec.K if K is None else K, rec.B if B is None else B,
                               rec.enabled, rec.viscous if viscous is None else viscous, rec.strain_per_radian,
                               rec.source, rec.terms if same else None, rec.order if same else 2,
                               stops=rec.stops if same else None, rest=rec.rest)  # fmt: skip
    if out.B is None or not np.any(out.B):
        out.viscous = True  # nothing to switch off; keep the record minimal
    return out.to_text()


def step_line(d, rigid_dirs, reason, dropped, needs, e, target_hz):
    """Report line of one element at a time step: what went rigid and why (its local frequency), what is needed."""
    damp = "; damping dropped" if dropped else ""
    need = "; ".join(f"{d.labels[i]} needed by {', '.join(needs[e, i])}" for i in range(6) if (e, i) in needs)
    need = f" ({need})" if need else ""
    if reason is not None:
        return f"{d.element}: kept as an element ({reason}){need}{damp}"
    soft = ", ".join(f"{d.labels[i]} {d.local_hz[i]:.4g} Hz" for i in range(6) if not rigid_dirs[i]) or "none"
    held = ", ".join(f"{d.labels[i]} {d.local_hz[i]:.4g} Hz" for i in range(6) if rigid_dirs[i])
    return (f"{d.element}: compliant {soft}; rigid {held} (local frequencies; held so that no mode is left above "
            f"{target_hz:.4g} Hz){need}{damp}")  # fmt: skip


def element_line(d, rigid_dirs, reason, shares_peak, dropped):
    soft = [i for i in range(6) if not rigid_dirs[i]]
    local = ", ".join(f"{d.labels[i]} {d.local_hz[i]:.0f} Hz" for i in soft)
    held = ", ".join(f"{d.labels[i]} {100 * shares_peak[i]:.2g} %" for i in range(6) if rigid_dirs[i])
    damp = "; damping dropped" if dropped else ""
    if reason is not None:
        return f"{d.element}: kept as an element ({reason}){damp}"
    if not soft:
        return f"{d.element}: rigid, bodies merged (largest modal energy shares: {held}){damp}"
    kind = "joint" if len(soft) == 1 else "joints"
    return f"{d.element}: {len(soft)} {kind} ({local} local) ; rigid: {held or 'none'}{damp}"


@dataclass
class Plan:
    """What :func:`reduce` decided, before the variant is built."""

    spec: object
    model: object
    flex: object
    dirs: list
    freq: np.ndarray
    mask: np.ndarray
    reasons: list
    keep: list
    drop: np.ndarray
    report: list
    details: dict
    normal: np.ndarray | None
    edges: dict  # element index -> reduce_edges.Edge (reduced in place)
    restricted: np.ndarray  # (n_el,) free-body links nested with joints and kept in those directions only


def build(plan, loops, name):
    names = body_names(plan.model)
    links = []
    for e, d in enumerate(plan.dirs):
        if plan.reasons[e] is not None or e in plan.edges:
            continue
        soft = sorted(plan.keep[e])
        link = link_of(d, names, joints_of(d, soft, not plan.drop[e]))
        if plan.restricted[e]:  # joints without springs; the element acts in the compliant directions only
            springless(link.joints)
            link.info["record"] = restricted_record(plan.flex.records[e], d, soft, not plan.drop[e]).to_text()
        links.append(link)

    def in_place(tree):
        lines = []
        for e, edge in plan.edges.items():
            if plan.reasons[e] is not None:
                continue
            rec, d = plan.flex.records[e], plan.dirs[e]
            result = edge_result(plan.model, rec, d, edge, plan.keep[e], not plan.drop[e],
                                 lambda soft, d=d: springless(joints_of(d, soft, False)))  # fmt: skip
            lines += result.lines + rejoint(tree, plan.model, rec, edge, result, d.sites)
        return lines

    def kept_records(tree):
        data = mujoco.MjData(plan.model)
        mujoco.mj_kinematics(plan.model, data)
        for e, rec in enumerate(plan.flex.records):
            if plan.normal is not None:  # every record left (kept, or closing a loop) becomes planar
                try:
                    current = schema.parse_text(rec.name, tree.text(rec.name)[1].get("data"))
                except KeyError:
                    continue
                R_EF = plane_frame(data.site_xmat[plan.flex.site_ids[e, 0]].reshape(3, 3), plan.normal)
                flat = planar_record(current, R_EF)
                flat.viscous = flat.viscous and not plan.drop[e]
                tree.rewrite_element(rec.name, record_text(flat))
                tree.rotate_sites(plan.dirs[e].sites, R_EF)
            elif plan.reasons[e] is not None and plan.drop[e] and rec.B is not None and np.any(rec.B):
                tree.rewrite_element(rec.name, record_text(rec, viscous=False))

    def closer(tree, link):  # a loop that ``link`` closes: by a weld or a hinge's connects (``loops``), or its element
        e = plan.flex.index(link.element)
        rec, d = plan.flex.records[e], plan.dirs[e]
        if loops == "constraint" and not link.joints:
            rigid_closure(tree, link)
            return f"{link.element}: closes a loop as a hard weld"
        if loops == "constraint" and len(link.joints) == 1 and link.joints[0].kind == "hinge":
            hinge_closure(tree, link, link.joints[0], 0.1 * max(float(plan.model.stat.extent), 1e-3))
            i = d.labels.index(link.joints[0].label)
            K, B = d.restricted([i])
            tree.rewrite_element(link.element, record_text(rec, K, B, viscous=not plan.drop[e]))
            return f"{link.element}: closes a loop as a hinge (two connect constraints; spring {d.k[i]:.4g} kept as "\
                   "a one-direction element)"  # fmt: skip
        tree.rewrite_element(link.element, record_text(rec, viscous=False if plan.drop[e] else None))
        why = "loops='element'" if loops == "element" else "MuJoCo has no equality constraint for this joint"
        return f"{link.element}: closes a loop, kept as a full element ({why})"

    details = dict(plan.details, loops=loops, constraints="project")
    attached = {n for n in names[1:] if n} - free_world_bodies(plan.model)
    return assemble(plan.spec, plan.model, links, closer=closer, pre=kept_records, name=name, report=plan.report,
                    details=details, plane=plan.normal, fewest_joints=True, attached=attached,
                    inplace=in_place)  # fmt: skip


def closure_singularity(variant, count, amplitude=1e-3):
    """How far the variant's loop constraints are from moving along its first ``count`` modes.

    For each elastic mode ``u`` (scaled so that its largest joint coordinate is ``amplitude``
    rad or m) the configuration ``qpos0 + u`` violates the loop constraints at second order;
    the smallest correction ``w`` that restores them (least squares on their Jacobian) is
    small compared with ``u`` for a regular mechanism and large at a singular one (straight
    chains in toggle position, over-constrained loops, where only the stretch of stiff
    directions lets the full model move). Returns the largest ``|w| / |u|`` (0 without loops).
    """
    model = variant.model
    if model.neq == 0:
        return 0.0
    freq, modes = modes_at(model, Flexures(model) if variant.has_flexures else None, None, actuator_stiffness=False)
    data = mujoco.MjData(model)
    worst = 0.0
    for k in np.nonzero(freq > rigid_floor(freq))[0][:count]:
        u = modes[:, k] * amplitude / np.abs(modes[:, k]).max()
        data.qpos[:] = model.qpos0
        mujoco.mj_integratePos(model, data.qpos, u, 1.0)
        e, G = equality_rows(model, data)
        w = np.linalg.lstsq(G, -e, rcond=None)[0]
        worst = max(worst, float(np.linalg.norm(w) / np.linalg.norm(u)))
    return worst

"""Model only what a scene requires: a cheaper model that keeps the modes below a frequency.

:func:`reduce` takes a model with flexures and the frequency band the user wants to resolve,
and returns a :class:`~mjflex.variants.variant.Variant` in which

* an element's **principal directions** (:mod:`mjflex.analysis.directions`: rotations about and
  translations along the eigen-axes of its stiffness at its centre of stiffness) that the
  retained modes do not use are held **rigid**; the ones left become MuJoCo joints with the
  element's stiffness and damping in that direction (a notch hinge stiff in five directions
  becomes one hinge joint with its compliant stiffness);
* an element rigid in all six directions **merges** its two bodies (the child becomes a
  jointless body of the parent's tree);
* an element with more than ``max_joints`` compliant directions, coupled directions, a planar
  record or a body that is not a free body **stays** an mjflex element;
* **damping** is dropped where it is negligible for every elastic mode the reduced model keeps;
* a **planar scene** (``plane=``, checks in :mod:`mjflex.variants.planar`) puts the free bodies on
  planar joints, holds every out-of-plane direction rigid, drops the out-of-plane modes from
  the band, and turns the elements that stay into 3x3 planar records;
* **loops** (a closed chain cannot be one kinematic tree): the elements of a spanning forest
  with the fewest joints become the trees' joints (so the reduced model has the fewest degrees
  of freedom); each element left over closes a loop, either by equality
  constraints where MuJoCo can express its joint (rigid: a weld; one hinge: two ``connect``
  constraints on its axis, its spring carried by a one-direction mjflex element) or by staying
  a full element. ``loops="auto"`` (default) uses constraints unless they would lock the
  mechanism: ARCADE reduced to hinges is such a case (its straight legs sit at a toggle
  position, and its three plates over-constrain the cylinder at second order; the full model
  moves because its notches stretch), measured by :func:`closure_singularity`. The
  constraints are as stiff as the time step allows (MuJoCo's ``refsafe`` keeps their time
  constant at ``2 h``), so they cost a constraint solve but add no stiff mode.

How "stiff" is decided: the normal modes of the full model below ``keep_below_hz`` are
computed, and each direction's modal strain-energy share is measured. Holding a direction
rigid raises the square of a mode's frequency by about the share it stored there when it acts
in series (more when the mechanism stiffens it in parallel, as closed loops do), so the
shares only order the candidates: the longest prefix, smallest share first, whose exact
constrained eigenproblem (those directions held rigid in the full model's modal coordinates)
keeps every retained frequency within ``freq_tol`` is held rigid (an element that the prefix
leaves with more than ``max_joints`` compliant directions stays an element, inside the search).
The choice only grows with the tolerance: a looser ``freq_tol`` holds a superset of directions,
keeps fewer elements and, with trees of the fewest joints, never more degrees of freedom. The local frequency of each
direction (its stiffness against the apparent inertia of the two bodies) is reported
alongside as an intuition; it is not the criterion, because a direction's in-situ frequency
depends on the whole mechanism. The variant's own modes are computed and compared at the end
(``details["modes"]``), so the claim is checked, not assumed.

Linear modes cannot see what large motions need: a closed-loop mechanism at a large stroke may
stretch directions that no low mode uses (ARCADE's paper run does: :doc:`/howto/reduce_a_model`). With
``scene=(initial state, duration)`` the full model is simulated and directions that store a
noticeable part of that scene's strain energy stay compliant (:func:`scene_shares`).

Damping: the damping ratio each element adds to each elastic mode through its kept directions
(``phi^T B phi / 2 omega``) is measured, over all the full model's elastic modes, not only the
retained band: modes above the band stay in the reduced model wherever compliant directions
stay, and would ring undamped. Elements' damping is dropped, smallest first (mirror-equal
elements together), while every mode loses less than ``viscous_tol`` of damping ratio (or, with
``duration`` given, while the amplitude change ``zeta omega duration`` it causes stays below
``viscous_tol``).
"""

from dataclasses import dataclass

import mujoco
import numpy as np
import scipy.linalg

from ..analysis.directions import damping_ratios, element_directions, energy_shares
from ..analysis.linearize import normal_modes
from ..core import validation
from ..mjcf import schema
from ..mjcf.spec import compile_spec
from ..runtime.flexures import Flexures
from .assemble import assemble, hinge_closure, rigid_closure
from .planar import in_plane_modes, out_of_plane, planar_record, plane_frame, plane_of
from .tree import WORLD, Joint, Link, free_world_bodies
from .variant import (
    Variant,
    body_names,
    equality_rows,
    keeps_element_kinds,
    polynomial_terms_lines,
    source_spec,
    stops_lines,
)

COUPLING_TOL = 1e-3  # largest normalized stiffness coupling between the directions that become joint springs
#: Largest :func:`closure_singularity` (at 1e-3 amplitude) for which loops="auto" closes loops by
#: constraints. The ratio grows in proportion to the amplitude for a regular mechanism, so 0.1 means
#: that at 1e-2 rad or m the loop constraints, not the flexures, would decide the motion.
SINGULARITY_LIMIT = 0.1
LOOP_MODES = ("auto", "constraint", "element")


def _rigid_floor(freq):
    return max(1e-3, 1e-7 * float(np.max(freq, initial=0.0)))


def _candidates(model, flex, directions, planar_scene):
    """Per element: None if it can be reduced, else the reason it stays an element."""
    free = free_world_bodies(model)
    names = body_names(model)
    out = []
    for rec, d in zip(flex.records, directions, strict=True):
        bodies = [names[d.body_a] if d.body_a else WORLD, names[d.body_b] if d.body_b else WORLD]
        bad = [b for b in bodies if b != WORLD and b not in free]
        if rec.planar and not planar_scene:
            out.append("planar element in a non-planar scene (its out-of-plane directions are free)")
        elif bad:
            out.append(f"body {bad[0]!r} is not a free body of the world")
        else:
            out.append(None)
    return out


def _constrained_error(lam, rows, target, n_rigid, floor):
    """Largest relative change of the ``target`` frequencies [Hz] when ``rows @ eta = 0`` is imposed.

    In mass-normalized modal coordinates ``eta`` (``M -> I``, ``K -> diag(lam)``), so the
    constrained problem is a standard symmetric one on the null space of ``rows``.
    """
    if len(rows):
        Q, R, _ = scipy.linalg.qr(rows.T, pivoting=True)
        d = np.abs(np.diag(R))
        rank = int(np.sum(d > 1e-10 * d.max(initial=0.0))) if d.size else 0
        N = Q[:, rank:]
    else:
        N = np.eye(len(lam))
    count = min(n_rigid + len(target), N.shape[1])
    w2 = scipy.linalg.eigh((N.T * lam) @ N, eigvals_only=True, subset_by_index=[0, count - 1]) if count else []
    f = np.sqrt(np.maximum(w2, 0.0)) / (2.0 * np.pi)
    f = f[f > floor][: len(target)]  # constraints may remove rigid-body modes (planar joints), never add any
    if len(f) < len(target):
        return np.inf
    return float(np.max(np.abs(f - target) / target, initial=0.0))


def _held(n, cand, reducible, forced, max_joints, allowed=None):
    """Rigid directions (n_el, 6), reducible elements and the indices into ``cand`` held rigid, for the prefix ``n``.

    The first ``n`` candidates are held rigid (those ``allowed``, if given); elements then left
    with more than ``max_joints`` compliant directions stay elements, their directions released.
    """
    rigid = forced.copy()
    for e, i in cand[:n]:
        rigid[e, i] = allowed is None or allowed[e, i]
    active = reducible & ((~rigid).sum(axis=1) <= max_joints)
    return rigid, active, [k for k, (e, i) in enumerate(cand[:n]) if rigid[e, i] and active[e]]


def _choose_rigid(dirs, shares, freq, modes, mask, reducible, allowed, forced, freq_tol, max_joints):
    """Which principal directions to hold rigid (n_el, 6), which elements stay reducible, and the error.

    Every candidate direction (of a reducible element, not already forced) is ordered by its
    largest modal strain-energy share, an order that no tolerance changes. A prefix of that
    order is held rigid, except in elements it leaves with more than ``max_joints`` compliant
    directions: those stay elements, all their directions released. As the prefix grows the
    directions it holds only grow (an element leaves the released ones once enough of its
    directions are in the prefix, never the other way), so the retained frequencies only rise
    (constraints are added) and the longest prefix whose exact constrained eigenproblem keeps
    them within ``freq_tol`` is found by bisection. Directions the scene needs (not
    ``allowed``) count in that search as if rigid, then stay compliant; that only releases
    more, which lowers the frequencies back towards the full model's.

    Monotone by construction: a looser ``freq_tol`` gives a longer prefix and allows more
    directions (``allowed`` grows with it), hence a superset of rigid directions, fewer released
    elements and fewer coupled ones: a looser tolerance never keeps more. (Searching again after
    releasing elements, as this did before, made the result depend on which elements a
    tolerance released, and a looser one could keep more.)
    """
    lam = (2.0 * np.pi * freq) ** 2
    target = freq[mask]
    floor = _rigid_floor(freq)
    n_rigid = int(np.sum(freq <= floor))
    score = shares.max(axis=2, initial=0.0)
    reducible = np.array(reducible, dtype=bool)
    fixed = np.array([dirs[e].J[i] @ modes for e, i in zip(*np.nonzero(forced), strict=True)]).reshape(-1, len(lam))
    cand = [(e, i) for e in np.nonzero(reducible)[0] for i in range(6)
            if not forced[e, i] and np.isfinite(score[e, i])]  # fmt: skip
    cand.sort(key=lambda c: score[c])
    rows = np.array([dirs[e].J[i] @ modes for e, i in cand]).reshape(len(cand), len(lam))

    def error(held):
        return _constrained_error(lam, np.vstack([fixed, rows[held]]), target, n_rigid, floor)

    lo, hi = 0, len(cand)
    while lo < hi:  # largest n with error(n) <= freq_tol
        mid = (lo + hi + 1) // 2
        if error(_held(mid, cand, reducible, forced, max_joints)[2]) <= freq_tol:
            lo = mid
        else:
            hi = mid - 1
    rigid, active, held = _held(lo, cand, reducible, forced, max_joints, allowed)
    return rigid, active, error(held)


def scene_state(model, initial):
    """``(qpos, qvel)`` of a scene's start: a keyframe name or index, or the pair itself."""
    if isinstance(initial, str | int):
        key = initial if isinstance(initial, int) else mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, initial)
        if not 0 <= key < model.nkey:
            raise ValueError(f"scene: no keyframe {initial!r} in the model (it has {model.nkey})")
        return model.key_qpos[key].copy(), model.key_qvel[key].copy()
    qpos, qvel = (np.asarray(x, dtype=float) for x in initial)
    if qpos.shape != (model.nq,) or qvel.shape != (model.nv,):
        raise ValueError(f"scene: qpos must have shape ({model.nq},) and qvel ({model.nv},)")
    return qpos, qvel


def scene_shares(model, flex, dirs, scene):
    """Largest strain energy of each principal direction along a simulated scene, over the largest total (n_el, 6).

    ``scene = (initial, duration)``: ``initial`` is a keyframe name or index, or ``(qpos,
    qvel)``; the full model runs for ``duration`` s with its own integrator and step. A
    direction that stores a noticeable part of the scene's strain energy (a notch stretched by
    the stroke of a closed-loop mechanism, or by centrifugal loads) must stay compliant even
    if no retained normal mode uses it: linear modes cannot see second-order stiffening.
    """
    initial, duration = scene
    data = mujoco.MjData(model)
    data.qpos[:], data.qvel[:] = scene_state(model, initial)
    if not duration > 0:
        raise ValueError(f"scene: the duration must be positive [s]; got {duration!r}")
    T = np.stack([d.T for d in dirs])
    k = np.stack([d.k for d in dirs])
    steps = max(1, round(duration / model.opt.timestep))
    peak, total = np.zeros((len(dirs), 6)), 0.0
    with flex:
        for _ in range(steps):
            mujoco.mj_step(model, data)
            if data.warning[mujoco.mjtWarning.mjWARN_BADQACC].number or not np.isfinite(data.qvel).all():
                raise ValueError(f"scene: the full model diverged at t = {data.time:.3g} s; fix the scene or its step")
            # every step: the stiff directions this is for ring at the highest frequencies, whose peaks a
            # sparser sampling misses (every 10th step underestimated a 30 kHz axial ring by 2x); the
            # strain energy needs the poses only, so kinematics suffice
            mujoco.mj_kinematics(model, data)
            delta = np.einsum("eij,ej->ei", T, flex.displacements(data))
            peak = np.maximum(peak, 0.5 * k * delta**2)
            total = max(total, flex.potential_energy(data))
    return peak / max(total, 1e-300)


def _drop_damping(ratios, freq_sel, duration, tol, rtol=1e-6):
    """Elements whose damping can go: smallest effect first, within ``tol`` per mode.

    Elements whose effects are equal within ``rtol`` (mirror-symmetric ones, equal up to
    round-off) are dropped together or not at all, so a symmetric model stays symmetric.
    """
    effect = ratios * (2.0 * np.pi * freq_sel * duration) if duration is not None else ratios
    peak = effect.max(axis=1, initial=0.0)
    order = np.argsort(peak, kind="stable")
    used = np.zeros(effect.shape[1])
    drop = np.zeros(effect.shape[0], dtype=bool)
    start = 0
    while start < len(order):
        stop = start + 1
        while stop < len(order) and peak[order[stop]] <= peak[order[start]] * (1.0 + rtol) + 1e-300:
            stop += 1
        group = order[start:stop]
        total = effect[group].sum(axis=0)
        if np.all(used + total <= tol):
            drop[group] = True
            used += total
        start = stop
    return drop, float(used.max(initial=0.0))


def _joints(d, soft, keep_damping):
    return [Joint(d.kind(i), d.labels[i], d.axes_world[i], d.centre_world, float(d.k[i]),
                  float(d.b[i]) if keep_damping else 0.0) for i in soft]  # fmt: skip


def _record_text(rec, K=None, B=None, viscous=None):
    same = K is None  # the element stays whole: its polynomial terms too (restricted ones keep K's part only)
    out = schema.FlexureRecord(rec.name, rec.method, rec.K if K is None else K, rec.B if B is None else B,
                               rec.enabled, rec.viscous if viscous is None else viscous, rec.strain_per_radian,
                               rec.source, rec.terms if same else None, rec.order if same else 2,
                               stops=rec.stops if same else None, rest=rec.rest if same else None)  # fmt: skip
    if out.B is None or not np.any(out.B):
        out.viscous = True  # nothing to switch off; keep the record minimal
    return out.to_text()


def _element_line(d, rigid_dirs, reason, shares_peak, dropped):
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


class _Closer:
    """Loop closures for :func:`reduce`."""

    def __init__(self, loops, flex, dirs, drop, arm):
        self.loops, self.flex, self.dirs, self.drop, self.arm = loops, flex, dirs, drop, arm

    def __call__(self, tree, link):
        e = self.flex.index(link.element)
        rec, d = self.flex.records[e], self.dirs[e]
        if self.loops == "constraint" and not link.joints:
            rigid_closure(tree, link)
            return f"{link.element}: closes a loop as a hard weld"
        if self.loops == "constraint" and len(link.joints) == 1 and link.joints[0].kind == "hinge":
            hinge_closure(tree, link, link.joints[0], self.arm)
            i = d.labels.index(link.joints[0].label)
            K, B = d.restricted([i])
            tree.rewrite_element(link.element, _record_text(rec, K, B, viscous=not self.drop[e]))
            return f"{link.element}: closes a loop as a hinge (two connect constraints; spring {d.k[i]:.4g} kept as "\
                   "a one-direction element)"  # fmt: skip
        tree.rewrite_element(link.element, _record_text(rec, viscous=False if self.drop[e] else None))
        why = "loops='element'" if self.loops == "element" else "MuJoCo has no equality constraint for this joint"
        return f"{link.element}: closes a loop, kept as a full element ({why})"


@dataclass
class _Plan:
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


def _plane(model, flex, plane, scene):
    """Normal of the planar scene (or None) and the report line about it."""
    if plane is None:
        return None, None
    free = [model.body(b).id for b in free_world_bodies(model)]
    state = scene_state(model, scene[0]) if scene is not None else None
    normal, reason = plane_of(model, flex, free, plane, state)
    if normal is None and not isinstance(plane, str):
        raise ValueError(f"plane={plane!r}: the scene is not planar: {reason}")
    if normal is None:
        return None, f"not planar ({reason}): reduced in 3-D"
    how = "its initial state checked" if state is not None else "no scene given: the initial state is not checked"
    return normal, (
        f"planar scene, normal {np.round(normal, 6).tolist()} ({how}): free bodies move on planar joints, "
        "remaining elements become 3x3 planar records, out-of-plane directions and modes are dropped"
    )


def _plan(source, keep_below_hz, freq_tol, viscous_tol, duration, max_joints, scene, plane):
    spec = source_spec(source)
    model = compile_spec(spec, why=None)
    flex = Flexures(model)
    if not len(flex):
        raise ValueError("the model has no mjflex elements: there is nothing to reduce")
    freq, modes = normal_modes(model, flex, joint_springs=True, constraints="project" if model.neq else "ignore")
    mask = (freq > _rigid_floor(freq)) & (freq < keep_below_hz)
    normal, plane_line = _plane(model, flex, plane, scene)
    dirs = element_directions(model, flex, normal)
    forced = np.zeros((len(dirs), 6), dtype=bool)
    if normal is not None:
        forced = out_of_plane(dirs, normal)
        mask &= in_plane_modes(model, modes, normal)
    reasons = _candidates(model, flex, dirs, normal is not None)
    shares = energy_shares(dirs, freq, modes, mask)
    reducible = [r is None for r in reasons]
    used = scene_shares(model, flex, dirs, scene) if scene is not None else np.zeros((len(dirs), 6))
    order = np.argsort(used, axis=None, kind="stable")
    allowed = np.zeros(used.size, dtype=bool)
    allowed[order[np.cumsum(used.ravel()[order]) <= 2.0 * freq_tol]] = True  # smallest first, within the budget
    allowed = allowed.reshape(used.shape)
    rigid, active, predicted = _choose_rigid(dirs, shares, freq, modes, mask, reducible, allowed, forced, freq_tol,
                                             max_joints)  # fmt: skip
    for e in np.nonzero(~active & np.array(reducible))[0]:
        reasons[e] = f"more than {max_joints} compliant directions matter below {keep_below_hz:g} Hz"
    for e in np.nonzero(active)[0]:  # joint springs are independent: the compliant directions must not couple
        soft = np.nonzero(~rigid[e])[0]
        K = dirs[e].K_P[np.ix_(soft, soft)]
        c = np.abs(K - np.diag(np.diag(K))) / np.sqrt(np.outer(np.diag(K), np.diag(K)) + 1e-300)
        if len(soft) > 1 and c.max() > COUPLING_TOL:
            reasons[e] = f"its compliant directions are coupled ({c.max():.1e} > {COUPLING_TOL:g})"
    keep = [{i for i in range(6) if not forced[e, i] and (reasons[e] or not rigid[e, i])} for e in range(len(dirs))]
    # damping: judged on every elastic mode the kept directions still carry, not only the resolved band (modes
    # above it stay in the model and would ring undamped; the viscous part costs little to keep)
    elastic = freq > _rigid_floor(freq)
    if normal is not None:
        elastic &= in_plane_modes(model, modes, normal)
    ratios = damping_ratios(dirs, freq, modes, elastic, keep)
    drop, dropped = _drop_damping(ratios, freq[elastic], duration, viscous_tol)
    drop &= np.array([bool(np.any(d.B_P)) for d in dirs], dtype=bool)  # nothing to drop without damping
    peak = shares.max(axis=2, initial=0.0)
    report = [
        f"reduced for the {int(mask.sum())} modes of the full model below {keep_below_hz:g} Hz "
        f"(frequency tolerance {100 * freq_tol:g} %, damping tolerance {viscous_tol:g})",
        *(_element_line(d, rigid[e], reasons[e], peak[e], drop[e]) for e, d in enumerate(dirs)),
    ]
    report += polynomial_terms_lines(
        flex,
        "are kept if it stays a full 3-D element; as joints, welds, a one-direction spring or a planar record "
        "it holds its stiffness at rest K only (the modal analysis uses K in every case)",
    )
    report += stops_lines(
        flex, "are kept if it stays a full 3-D element; as joints, welds, a one-direction spring or a planar record "
        "it has no range (the joints get no limits)",
    )  # fmt: skip
    if plane_line:
        report.insert(1, plane_line)
    if scene is not None:
        held = [f"{d.element} {d.labels[i]} {100 * used[e, i]:.2g} %" for e, d in enumerate(dirs) for i in range(6)
                if not allowed[e, i] and rigid is not None]  # fmt: skip
        report.insert(1, f"scene {scene[0]!r} for {scene[1]:g} s: {len(held)} directions stay compliant because "
                         f"holding them rigid would remove more than {200 * freq_tol:g} % of its peak strain energy "
                         f"(largest first: {', '.join(sorted(held, key=lambda h: -float(h.split()[-2]))[:6])}"
                         f"{' ...' if len(held) > 6 else ''})")  # fmt: skip
    details = {
        "keep_below_hz": keep_below_hz, "freq_tol": freq_tol, "viscous_tol": viscous_tol, "modes_kept": int(mask.sum()),
        "damping_removed_max": dropped, "predicted_error": predicted,
        "elements": {d.element: {"soft": [d.labels[i] for i in sorted(keep[e])], "kept": reasons[e] is not None,
                                 "reason": reasons[e], "damping_dropped": bool(drop[e]),
                                 "local_hz": dict(zip(d.labels, np.round(d.local_hz, 3).tolist(), strict=True)),
                                 "max_share": dict(zip(d.labels, peak[e].tolist(), strict=True)),
                                 "scene_share": dict(zip(d.labels, used[e].tolist(), strict=True))}
                     for e, d in enumerate(dirs)},
    }  # fmt: skip
    details["plane"] = None if normal is None else normal.tolist()
    return _Plan(spec, model, flex, dirs, freq, mask, reasons, keep, drop, report, details, normal)


def _build(plan, loops, name):
    names = body_names(plan.model)
    links = [
        Link(d.element, *(names[b] if b else WORLD for b in (d.body_a, d.body_b)), d.sites,
             joints=_joints(d, sorted(plan.keep[e]), not plan.drop[e]))
        for e, d in enumerate(plan.dirs) if plan.reasons[e] is None
    ]  # fmt: skip

    def kept_records(tree):
        data = mujoco.MjData(plan.model)
        mujoco.mj_kinematics(plan.model, data)
        for e, rec in enumerate(plan.flex.records):
            if plan.normal is not None:  # every record left (kept, or closing a loop) becomes planar
                try:
                    current = schema.parse_text(rec.name, tree.element_text(rec.name))
                except KeyError:
                    continue
                R_EF = plane_frame(data.site_xmat[plan.flex.site_ids[e, 0]].reshape(3, 3), plan.normal)
                flat = planar_record(current, R_EF)
                flat.viscous = flat.viscous and not plan.drop[e]
                tree.rewrite_element(rec.name, _record_text(flat))
                tree.rotate_sites(plan.dirs[e].sites, R_EF)
            elif plan.reasons[e] is not None and plan.drop[e] and rec.B is not None and np.any(rec.B):
                tree.rewrite_element(rec.name, _record_text(rec, viscous=False))

    arm = 0.1 * max(float(plan.model.stat.extent), 1e-3)
    closer = _Closer(loops, plan.flex, plan.dirs, plan.drop, arm)
    details = dict(plan.details, loops=loops, constraints="project")
    return assemble(plan.spec, plan.model, links, closer=closer, pre=kept_records, name=name, report=plan.report,
                    details=details, plane=plan.normal, fewest_joints=True)  # fmt: skip


def _modes(variant):
    model = variant.model
    flex = Flexures(model) if variant.has_flexures else None
    return normal_modes(model, flex, joint_springs=True, constraints="project" if model.neq else "ignore")


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
    freq, modes = _modes(variant)
    data = mujoco.MjData(model)
    worst = 0.0
    for k in np.nonzero(freq > _rigid_floor(freq))[0][:count]:
        u = modes[:, k] * amplitude / np.abs(modes[:, k]).max()
        data.qpos[:] = model.qpos0
        mujoco.mj_integratePos(model, data.qpos, u, 1.0)
        e, G = equality_rows(model, data)
        w = np.linalg.lstsq(G, -e, rcond=None)[0]
        worst = max(worst, float(np.linalg.norm(w) / np.linalg.norm(u)))
    return worst


def _check_arguments(keep_below_hz, scene, plane, freq_tol, viscous_tol, duration, loops, max_joints, verify, name):
    """:func:`reduce`'s arguments, each checked before any work: TypeError / ValueError naming it."""
    validation.check_number(keep_below_hz, "keep_below_hz", above=0.0)
    validation.check_number(freq_tol, "freq_tol", above=0.0, below=0.5)
    validation.check_number(viscous_tol, "viscous_tol", at_least=0.0)
    if duration is not None:
        validation.check_number(duration, "duration", above=0.0)
    validation.check_number(max_joints, "max_joints", integer=True, at_least=1)
    validation.check_flag(verify, "verify")
    if not (isinstance(loops, str) and loops in LOOP_MODES):
        raise ValueError(f"loops must be one of {LOOP_MODES}; got {validation.shorten(loops)}")
    if name is not None and not isinstance(name, str):
        raise TypeError(f"name must be a str or None; got {type(name).__name__}")
    if scene is not None and not (isinstance(scene, tuple | list) and len(scene) == 2):
        raise TypeError(f"scene must be a pair (initial, duration) or None; got {validation.shorten(scene)}")
    if isinstance(plane, str):
        if plane != "auto":
            none = " (plane=None reduces in 3-D)" if plane.strip().lower() in ("none", "off", "no", "false", "") else ""
            raise ValueError(f"plane must be None, 'auto' or a normal vector (3,); got {plane!r}{none}")
    elif plane is not None:
        normal = validation.as_array(plane, "plane", (3,))
        if normal.shape != (3,) or not np.linalg.norm(normal) > 0:
            raise ValueError(
                f"plane must be None, 'auto' or a nonzero normal vector (3,); got {validation.shorten(plane)}"
            )


@keeps_element_kinds
def reduce(source, keep_below_hz=2000.0, *, scene=None, plane=None, freq_tol=0.01, viscous_tol=1e-3, duration=None,
           loops="auto", max_joints=3, verify=True, name=None) -> Variant:  # fmt: skip
    """A cheaper model of ``source`` that keeps its normal modes below ``keep_below_hz``.

    Parameters
    ----------
    source : str, os.PathLike, mujoco.MjSpec or mujoco.MjModel
        The full model (see :func:`mjflex.variants.variant.source_spec`); it is not modified.
    keep_below_hz : float
        Upper end of the band to resolve [Hz]: modes of the full model below it are kept.
    scene : tuple, optional
        ``(initial, duration)``: a keyframe name or index (or ``(qpos, qvel)``) and a duration
        [s]. The full model is simulated over it (:func:`scene_shares`); directions may be
        held rigid only while their summed share of its peak strain energy stays within
        ``2 freq_tol`` (smallest first).
    plane : None, "auto" or array_like (3,)
        Reduce to a planar model when the scene is planar (:mod:`mjflex.variants.planar`): with a
        normal vector the checks must pass (else ValueError saying which fails); ``"auto"``
        takes the element frames' common z axis and falls back to 3-D, saying why, when a
        check fails. The scene's initial state is checked when ``scene`` is given. None (the
        default) reduces in 3-D; any other string is refused.
    freq_tol : float
        Relative frequency change allowed to each kept mode (module docstring).
    viscous_tol : float
        Damping-ratio change allowed to each kept mode when damping is dropped (or amplitude
        change over ``duration``); 0 keeps all damping.
    duration : float, optional
        Length of the scenes to simulate [s], for the damping criterion.
    loops : {"auto", "constraint", "element"}
        How loops are closed (module docstring); ``"auto"`` uses constraints unless
        :func:`closure_singularity` exceeds ``SINGULARITY_LIMIT`` for the kept modes, then
        elements.
    max_joints : int
        Elements left with more compliant directions than this stay elements.
    verify : bool
        Compute the variant's normal modes and compare (``details["modes"]``).
    name : str, optional
        Label of the variant (default ``"reduced(<keep_below_hz> Hz)"``).

    Returns
    -------
    Variant
        With ``report`` (one line per element and per loop, numbers included) and ``details``.

    Examples
    --------
    A block on a leaf spring: below 15 Hz only its three rotations matter, which become three hinges; the stiff
    translations are held rigid.

    >>> import mujoco
    >>> import mjflex
    >>> spec = mujoco.MjSpec.from_string(
    ...     '<mujoco><worldbody><body name="block" pos="0 0 -0.1"><freejoint/>'
    ...     '<geom type="box" size="0.02 0.02 0.02" mass="0.5"/></body></worldbody></mujoco>'
    ... )
    >>> _ = mjflex.add_flexure(spec, "leaf", "world", "block", pos=[0, 0, -0.05], K=[2, 2, 1, 1e5, 1e5, 1e5])
    >>> reduced = mjflex.reduce(spec, keep_below_hz=15)
    >>> reduced.name, reduced.model.nv
    ('reduced(15 Hz)', 3)
    >>> print(reduced.report.splitlines()[1])
    leaf: 3 joints (rx 19 Hz, ry 19 Hz, rz 14 Hz local) ; rigid: x 0.65 %, y 0.65 %, z 0 %
    """
    _check_arguments(keep_below_hz, scene, plane, freq_tol, viscous_tol, duration, loops, max_joints, verify, name)
    plan = _plan(source, keep_below_hz, freq_tol, viscous_tol, duration, max_joints, scene, plane)
    name = name or f"reduced({keep_below_hz:g} Hz)"
    variant = _build(plan, "constraint" if loops == "auto" else loops, name)
    if loops == "auto" and variant.model.neq:
        ratio = closure_singularity(variant, max(int(plan.mask.sum()), 1))
        variant.details["closure_singularity"] = ratio
        if ratio > SINGULARITY_LIMIT:
            variant = _build(plan, "element", name)
            variant.details["closure_singularity"] = ratio
            variant.report += (
                f"\nloops kept as elements: closing them by constraints would need second-order corrections "
                f"{ratio:.3g} times the motion of the kept modes (a singular or over-constrained mechanism)"
            )
    if verify:
        _verify(variant, plan.freq, plan.mask)
    return variant


def _verify(variant, freq, mask):
    """Compare the variant's modes with the kept modes of the full model (details and report)."""
    f_var, _ = _modes(variant)
    full = freq[mask]
    reduced = f_var[f_var > _rigid_floor(f_var)][: len(full)]
    n = min(len(full), len(reduced))
    err = np.abs(reduced[:n] - full[:n]) / full[:n] if n else np.zeros(0)
    variant.details["modes"] = {
        "full_hz": full.tolist(), "reduced_hz": reduced.tolist(), "max_relative_error": float(err.max(initial=0.0)),
        "highest_hz": float(f_var.max(initial=0.0)), "highest_full_hz": float(freq.max()),
    }  # fmt: skip
    first = ", ".join(f"{a:.4g}/{b:.4g}" for a, b in zip(full[:4], reduced[:4], strict=False))
    variant.report += (
        f"\nmodes below {variant.details['keep_below_hz']:g} Hz: {len(full)} in the full model, {len(reduced)} here; "
        f"largest relative change {100 * float(err.max(initial=0.0)):.3g} % (first, full/reduced Hz: {first}); "
        f"highest mode {f_var.max(initial=0.0):.4g} Hz (full model {freq.max():.4g} Hz)"
    )


__all__ = ["closure_singularity", "reduce", "scene_shares", "scene_state"]

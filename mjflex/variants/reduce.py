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

**Any model.** Elements on a body's own joints (the body's parent is the element's other body, as
:func:`mjflex.make_compliant` makes them, ``replace_joints`` or not) are reduced in place
(:mod:`mjflex.variants.reduce_edges`): the joints the compliant directions need stay, with their names
and armature, and the element becomes MuJoCo's springs where they are exact, else the element in
fewer directions; a direction that an actuator, a tendon or an equality moves is never held rigid.
Free bodies nest under the model's own trees; elements between two bodies of the trees close loops.

**A time step** (``timestep=``, by default the file's own when no band is given): the directions
carrying the modes that the step and integrator do not resolve with the step advice's margin are held
rigid, the fewest that bring every mode below that band (:mod:`mjflex.variants.reduce_choice`); the
modes below the band are checked as in the band mode, and the reduced model's own step advice and its
statics against the full model's are reported.

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

import warnings

import mujoco
import numpy as np

from ..analysis.advice import SAFETY, mode_limit, step_advice
from ..analysis.directions import damping_ratios, element_directions, energy_shares
from ..analysis.linearize import normal_modes, state
from ..analysis.statics import static_equilibrium
from ..core import validation
from ..mjcf.spec import compile_spec
from ..runtime.flexures import Flexures
from .planar import in_plane_modes, out_of_plane, plane_of
from .reduce_build import Plan, build, closure_singularity, element_line, step_line, variant_modes
from .reduce_choice import (
    choose_for_step,
    choose_rigid,
    drop_damping,
    rigid_floor,
    scene_shares,
    scene_state,
    step_omega,
)
from .reduce_edges import edge_of, joint_users
from .tree import WORLD, free_world_bodies
from .variant import Variant, body_names, keeps_element_kinds, polynomial_terms_lines, source_spec, stops_lines

COUPLING_TOL = 1e-3  # largest normalized stiffness coupling between the directions that become joint springs
#: Largest :func:`closure_singularity` (at 1e-3 amplitude) for which loops="auto" closes loops by
#: constraints. The ratio grows in proportion to the amplitude for a regular mechanism, so 0.1 means
#: that at 1e-2 rad or m the loop constraints, not the flexures, would decide the motion.
SINGULARITY_LIMIT = 0.1
LOOP_MODES = ("auto", "constraint", "element")
_INTEGRATORS = {int(mujoco.mjtIntegrator.mjINT_RK4): "RK4", int(mujoco.mjtIntegrator.mjINT_IMPLICIT): "implicit",
                int(mujoco.mjtIntegrator.mjINT_IMPLICITFAST): "implicitfast"}  # fmt: skip


class ReductionWarning(UserWarning):
    """:func:`reduce` made a model, but not all that was asked: elements left whole, or a direction the band needs
    held rigid to reach a time step. The report says which, by name."""


def _classify(model, flex, dirs, planar_scene):
    """Per element: ``(kind, reason, edge)``; kind ``"edge"`` (on the body's own joints, reduced in place),
    ``"link"`` (re-rooted through the element graph, or closing a loop), or None with the reason it stays whole."""
    free = free_world_bodies(model)
    names = body_names(model)
    users = joint_users(model)
    out = []
    for rec, d in zip(flex.records, dirs, strict=True):
        bodies = [names[d.body_a] if d.body_a else WORLD, names[d.body_b] if d.body_b else WORLD]
        bad = [b for b in bodies if b != WORLD and b not in free]
        if rec.planar and not planar_scene:
            out.append((None, "planar element in a non-planar scene (its out-of-plane directions are free)", None))
        elif bad and planar_scene:
            out.append((None, f"body {bad[0]!r} is not a free body of the world (a planar scene reduces free bodies)",
                        None))  # fmt: skip
        elif "" in bodies:
            out.append((None, "one of its bodies has no name (name it to reduce the element)", None))
        else:
            edge = edge_of(model, d, users, names) if bad else None
            out.append(("edge", None, edge) if edge is not None else ("link", None, None))
    return out


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


def _coupling(d, soft):
    K = d.K_P[np.ix_(soft, soft)]
    c = np.abs(K - np.diag(np.diag(K))) / np.sqrt(np.outer(np.diag(K), np.diag(K)) + 1e-300)
    return float(c.max()) if len(soft) > 1 else 0.0


def _step_choice(model, dirs, freq, modes, reducible, needs, needed, forced, timestep, keep_below_hz, freq_tol):
    """The target-step selection (:func:`choose_for_step`): rigid directions, band mask, info; ValueError when
    no reduction reaches the step."""
    integrator = _INTEGRATORS.get(int(model.opt.integrator), "Euler")
    omega = step_omega(timestep, integrator)
    band_hz = keep_below_hz if keep_below_hz is not None else omega / (2.0 * np.pi)
    mask = (freq > rigid_floor(freq)) & (freq < band_hz)
    candidate = reducible[:, None] & ~forced & ~needed
    rigid, info = choose_for_step(dirs, freq, modes, candidate, omega, mask, freq_tol, forced, integrator)
    info.update(timestep=timestep, integrator=integrator, band_hz=float(band_hz))
    if not info["reached"]:
        lim = info["limit"]
        e, i = lim["index"]
        why = ("needed by " + ", ".join(needs[e, i])) if needed[e, i] else "its element cannot be reduced"
        largest = SAFETY * mode_limit(2 * np.pi * lim["frequency_hz"], 0.0, integrator)
        raise ValueError(
            f"timestep={timestep:g} s: no reduction reaches it with {integrator}: element {lim['element']!r}, "
            f"direction {lim['direction']} ({why}) keeps a mode at {lim['frequency_hz']:.4g} Hz, above the "
            f"{info['target_hz']:.4g} Hz "
            f"the step resolves; the largest step with it is about {largest:.3g} s"
        )
    return rigid, mask, info


def _plan(source, keep_below_hz, timestep, freq_tol, viscous_tol, duration, max_joints, scene, plane):
    spec = source_spec(source)
    model = compile_spec(spec, why=None)
    flex = Flexures(model)
    if not len(flex):
        raise ValueError("the model has no mjflex elements: there is nothing to reduce")
    if timestep == "file":
        timestep = float(model.opt.timestep)
    step_mode = timestep is not None
    freq, modes = normal_modes(model, flex, joint_springs=True, actuator_stiffness=True,
                               constraints="project" if model.neq else "ignore")  # fmt: skip
    normal, plane_line = _plane(model, flex, plane, scene)
    dirs = element_directions(model, flex, normal)
    n_el = len(dirs)
    forced = np.zeros((n_el, 6), dtype=bool) if normal is None else out_of_plane(dirs, normal)
    in_plane = True if normal is None else in_plane_modes(model, modes, normal)
    kinds = _classify(model, flex, dirs, normal is not None)
    reasons = [reason for _, reason, _ in kinds]
    edges = {e: edge for e, (kind, _, edge) in enumerate(kinds) if kind == "edge"}
    needs = {}
    for e, edge in edges.items():
        forced[e] |= ~edge.free  # directions its joints cannot move are rigid already
        for i, names in edge.needed.items():
            needs[e, i] = names
    needed = np.zeros((n_el, 6), dtype=bool)
    for e, i in needs:
        needed[e, i] = True
    reducible = np.array([r is None for r in reasons], dtype=bool)
    limit = np.array([6 if e in edges else max_joints for e in range(n_el)])  # in place, any number of joints
    used = scene_shares(model, flex, dirs, scene) if scene is not None else np.zeros((n_el, 6))
    order = np.argsort(used, axis=None, kind="stable")
    allowed = np.zeros(used.size, dtype=bool)
    allowed[order[np.cumsum(used.ravel()[order]) <= 2.0 * freq_tol]] = True  # smallest first, within the budget
    allowed = allowed.reshape(used.shape)
    step = None
    restricted = np.zeros(n_el, dtype=bool)
    if step_mode:
        rigid, mask, step = _step_choice(model, dirs, freq, modes, reducible, needs, needed, forced, timestep,
                                         keep_below_hz, freq_tol)  # fmt: skip
        keep_below_hz = step["band_hz"]
        mask &= in_plane
        active = reducible.copy()
        predicted = step["band_error"]
    else:
        mask = (freq > rigid_floor(freq)) & (freq < keep_below_hz) & in_plane
        shares = energy_shares(dirs, freq, modes, mask)
        rigid, active, predicted = choose_rigid(dirs, shares, freq, modes, mask, reducible, allowed, forced, freq_tol,
                                                limit, needed)  # fmt: skip
        for e in np.nonzero(~active & reducible)[0]:
            reasons[e] = f"more than {max_joints} compliant directions matter below {keep_below_hz:g} Hz"
    shares = energy_shares(dirs, freq, modes, mask)
    for e in np.nonzero(active)[0]:
        soft = np.nonzero(~rigid[e])[0]
        if e in edges:
            if not rigid[e][edges[e].free].any():
                reasons[e] = "none of its directions is held rigid: left as it is"
            continue
        if step_mode and (len(soft) > max_joints or _coupling(dirs[e], soft) > COUPLING_TOL):
            if len(soft) == 6 or not rigid[e].any():
                reasons[e] = "none of its directions is held rigid: left as it is"
            else:
                restricted[e] = True  # joints without springs, and the element in those directions only
            continue
        if _coupling(dirs[e], soft) > COUPLING_TOL:  # joint springs are independent: the directions must not couple
            reasons[e] = f"its compliant directions are coupled ({_coupling(dirs[e], soft):.1e} > {COUPLING_TOL:g})"
    keep = [{i for i in range(6) if not forced[e, i] and (reasons[e] or not rigid[e, i])} for e in range(n_el)]
    # damping: judged on every elastic mode the kept directions still carry, not only the resolved band (modes
    # above it stay in the model and would ring undamped; the viscous part costs little to keep)
    elastic = (freq > rigid_floor(freq)) & in_plane
    ratios = damping_ratios(dirs, freq, modes, elastic, keep)
    drop, dropped = drop_damping(ratios, freq[elastic], duration, viscous_tol)
    drop &= np.array([bool(np.any(d.B_P)) for d in dirs], dtype=bool)  # nothing to drop without damping
    peak = shares.max(axis=2, initial=0.0)
    if step_mode:
        head = (
            f"reduced for a {timestep:g} s step ({step['integrator']}, safety {SAFETY:g}): directions whose modes "
            f"lie above {step['target_hz']:.4g} Hz are held rigid (those carrying them first); the "
            f"{int(mask.sum())} modes of the full model below {keep_below_hz:.4g} Hz are checked (tolerance "
            f"{100 * freq_tol:g} %)"
        )
        lines = [step_line(d, rigid[e], reasons[e], drop[e], needs, e, step["target_hz"]) for e, d in enumerate(dirs)]
    else:
        head = (f"reduced for the {int(mask.sum())} modes of the full model below {keep_below_hz:g} Hz "
                f"(frequency tolerance {100 * freq_tol:g} %, damping tolerance {viscous_tol:g})")  # fmt: skip
        lines = [element_line(d, rigid[e], reasons[e], peak[e], drop[e]) for e, d in enumerate(dirs)]
    report = [head, *lines]
    report += polynomial_terms_lines(
        flex,
        "are kept if it stays a full 3-D element; as joints, welds, a one-direction spring or a planar record "
        "it holds its stiffness at rest K only (the modal analysis uses K in every case)",
    )
    report += stops_lines(
        flex, "are kept if it stays a full 3-D element or an element in fewer directions; as joints, welds, a "
        "one-direction spring or a planar record it has no range (the joints get no limits)",
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
                                 "in_place": e in edges, "restricted": bool(restricted[e]),
                                 "rigid": [d.labels[i] for i in range(6) if rigid[e, i] and not reasons[e]],
                                 "needed": {d.labels[i]: needs[e, i] for i in range(6) if (e, i) in needs},
                                 "local_hz": dict(zip(d.labels, np.round(d.local_hz, 3).tolist(), strict=True)),
                                 "max_share": dict(zip(d.labels, peak[e].tolist(), strict=True)),
                                 "scene_share": dict(zip(d.labels, used[e].tolist(), strict=True))}
                     for e, d in enumerate(dirs)},
    }  # fmt: skip
    details["plane"] = None if normal is None else normal.tolist()
    details["actuator_stiffness"] = True  # a robot's servos hold its mechanism: their modes are elastic
    if step is not None:
        details["step"] = {k: v for k, v in step.items() if k != "limit"}
    return Plan(spec, model, flex, dirs, freq, mask, reasons, keep, drop, report, details, normal, edges, restricted)


def _check_arguments(keep_below_hz, timestep, scene, plane, freq_tol, viscous_tol, duration, loops, max_joints, verify,
                     name):  # fmt: skip
    """:func:`reduce`'s arguments, each checked before any work: TypeError / ValueError naming it."""
    if keep_below_hz is not None:
        validation.check_number(keep_below_hz, "keep_below_hz", above=0.0)
    if timestep is not None:
        validation.check_number(timestep, "timestep", above=0.0)
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
def reduce(source, keep_below_hz=None, *, timestep=None, scene=None, plane=None, freq_tol=0.01, viscous_tol=1e-3,
           duration=None, loops="auto", max_joints=3, verify=True, name=None) -> Variant:  # fmt: skip
    """A cheaper model of ``source``: for a frequency band, or for a time step (by default the file's own).

    Parameters
    ----------
    source : str, os.PathLike, mujoco.MjSpec or mujoco.MjModel
        The full model (see :func:`mjflex.variants.variant.source_spec`); it is not modified.
    keep_below_hz : float, optional
        Upper end of the band to resolve [Hz]: modes of the full model below it are kept. Alone, it
        selects the band mode: everything the band does not need is held rigid.
    timestep : float, optional
        The step the reduced model must run at [s] (its ``opt.timestep``) with the source's integrator: directions whose
        modes the step does not resolve with the advice's margin (:func:`mjflex.step_advice`,
        ``SAFETY``) are held rigid, stiffest first, and nothing else; the modes below that band
        (or below ``keep_below_hz`` if given) are checked. When neither is given: the file's own
        ``opt.timestep``. ValueError naming the element and direction when no reduction reaches
        it; a :class:`mjflex.ReductionWarning` when it takes a direction the band's modes need (the
        report gives the largest step that keeps it).
    scene : tuple, optional
        ``(initial, duration)``: a keyframe name or index (or ``(qpos, qvel)``) and a duration
        [s]. The full model is simulated over it (:func:`scene_shares`); directions may be
        held rigid only while their summed share of its peak strain energy stays within
        ``2 freq_tol`` (smallest first). Band mode only.
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
        Elements between free bodies left with more compliant directions than this stay elements
        (at a time step: joints without springs, and the element in those directions only).
    verify : bool
        Compute the variant's normal modes and compare (``details["modes"]``); at a time step also
        its step advice (``details["step"]``) and its statics against the full model's
        (``details["statics"]``).
    name : str, optional
        Label of the variant (default ``"reduced(<keep_below_hz> Hz)"`` or ``"reduced(<step> s)"``).

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

    At the file's step (MuJoCo's default, 2 ms, Euler) the step resolves the rotations and the axial stretch (71 Hz
    local): only the two shear directions (229 Hz) are held rigid, and the four left are joints with the element in
    those four directions.

    >>> at_step = mjflex.reduce(spec)
    >>> at_step.name, at_step.model.nv, at_step.details["step"]["reached"]
    ('reduced(0.002 s)', 4, True)
    """
    _check_arguments(keep_below_hz, timestep, scene, plane, freq_tol, viscous_tol, duration, loops, max_joints, verify,
                     name)  # fmt: skip
    if timestep is None and keep_below_hz is None:
        timestep = "file"
    plan = _plan(source, keep_below_hz, timestep, freq_tol, viscous_tol, duration, max_joints, scene, plane)
    step = plan.details.get("step")
    name = name or (f"reduced({step['timestep']:g} s)" if step else f"reduced({keep_below_hz:g} Hz)")
    variant = build(plan, "constraint" if loops == "auto" else loops, name)
    if loops == "auto" and variant.model.neq > plan.model.neq:
        ratio = closure_singularity(variant, max(int(plan.mask.sum()), 1))
        variant.details["closure_singularity"] = ratio
        if ratio > SINGULARITY_LIMIT:
            variant = build(plan, "element", name)
            variant.details["closure_singularity"] = ratio
            variant.report += (
                f"\nloops kept as elements: closing them by constraints would need second-order corrections "
                f"{ratio:.3g} times the motion of the kept modes (a singular or over-constrained mechanism)"
            )
    if step:  # the reduced model runs at the step it was made for
        variant.model.opt.timestep = step["timestep"]
        if variant.spec is not None:
            variant.spec.option.timestep = step["timestep"]
    if verify:
        _verify(variant, plan.freq, plan.mask)
        if step:
            _verify_step(variant, plan)
    _warn(variant, plan)
    return variant


def _warn(variant, plan):
    """A :class:`mjflex.ReductionWarning` for elements that could not be reduced and for directions the band needs."""
    whole = [f"{d.element} ({r})" for d, r in zip(plan.dirs, plan.reasons, strict=True)
             if r and not r.startswith(("none of its directions", "more than"))]  # fmt: skip
    if whole:
        warnings.warn(f"mjflex.reduce: {len(whole)} element(s) stay whole: {'; '.join(whole)}; the model made is "
                      "the rest reduced (report)", ReductionWarning, stacklevel=3)  # fmt: skip
    needed = (plan.details.get("step") or {}).get("needed")
    if needed:
        warnings.warn(
            f"mjflex.reduce: the step {plan.details['step']['timestep']:g} s is reached only by holding rigid "
            f"{needed['element']} {needed['direction']}, which the modes below {plan.details['keep_below_hz']:.4g} Hz "
            f"need (their error {100 * plan.details['step']['band_error']:.3g} %); the largest step that keeps it is "
            f"{needed['largest_step']:.3g} s",
            ReductionWarning,
            stacklevel=3,
        )


def _statics(model, flex, keyframe):
    qpos = static_equilibrium(model, flex, keyframe=keyframe, tol=1e-8)  # positions to 1e-8 of the load: enough for 1 %
    data = state(model, keyframe, qpos)
    mujoco.mj_kinematics(model, data)
    return data


def _verify_step(variant, plan):
    """The variant's step advice, and its statics against the full model's under the scene's loads (each keyframe's
    controls and gravity, or gravity at ``qpos0``): the largest error of a geom's centre (the parts, where they are:
    positions and rotations of the bodies that carry them) over the largest displacement of one from ``qpos0``."""
    flex = Flexures(variant.model) if variant.has_flexures else None
    step = variant.details["step"] = dict(plan.details["step"])
    try:
        advice = step_advice(variant.model, flex)
        step.update(advised_step=advice.recommended, advised_limit=advice.limit, limiting_hz=advice.frequency)
    except ValueError as exc:  # no elastic mode at all: nothing limits the step
        step.update(advised_step=float("inf"), advised_limit=float("inf"), limiting_hz=0.0, advice_note=str(exc))
    ok = step["advised_step"] >= step["timestep"] * (1.0 - 1e-9)
    variant.report += (
        f"\nat {step['timestep']:g} s: the reduced model's step advice {step['advised_step']:.3g} s "
        f"({'resolved' if ok else 'NOT resolved'}; limit {step['advised_limit']:.3g} s, mode "
        f"{step['limiting_hz']:.4g} Hz)"
    )
    keys = list(range(plan.model.nkey)) or [None]
    src_names = body_names(plan.model)
    src = plan.model
    errors = []
    try:
        ref = mujoco.MjData(src)
        mujoco.mj_kinematics(src, ref)
        for key in keys:
            full = _statics(src, plan.flex, key)
            red = _statics(variant.model, flex, key)
            moved, err = 0.0, 0.0
            for g in range(src.ngeom):  # every part's centre (and so the bodies' rotations), where it is
                b = int(src.geom_bodyid[g])
                vb, X_VS = variant.body_map.get(src_names[b], (None, None)) if b and src_names[b] else (None, None)
                if vb is None:
                    continue
                v = variant.model.body(vb).id
                r = full.xmat[b].reshape(3, 3).T @ (full.geom_xpos[g] - full.xpos[b])  # in the source body's frame
                R_v = red.xmat[v].reshape(3, 3)
                point = red.xpos[v] + R_v @ (X_VS[:3, :3] @ r + X_VS[:3, 3])
                moved = max(moved, float(np.linalg.norm(full.geom_xpos[g] - ref.geom_xpos[g])))
                err = max(err, float(np.linalg.norm(point - full.geom_xpos[g])))
            scale = max(moved, 1e-9 * max(float(src.stat.extent), 1e-3))  # no load: judge against the model's size
            errors.append({"keyframe": key, "moved": moved, "error": err, "relative": err / scale})
    except (ValueError, RuntimeError, np.linalg.LinAlgError) as exc:  # a scene without a rest (a free body)
        variant.details["statics"] = {"failed": str(exc)}
        variant.report += f"\nstatics not compared: {exc}"
        return
    variant.details["statics"] = errors
    worst = max(errors, key=lambda r: r["relative"])
    variant.report += (
        f"\nstatics under the scene's loads ({len(errors)} state(s): gravity and each keyframe's controls): largest "
        f"error of a part's position {worst['error']:.3g} m, {100 * worst['relative']:.3g} % of the largest "
        f"displacement {worst['moved']:.3g} m"
    )


def _verify(variant, freq, mask):
    """Compare the variant's modes with the kept modes of the full model (details and report)."""
    f_var, _ = variant_modes(variant, variant.details.get("actuator_stiffness", False))
    full = freq[mask]
    reduced = f_var[f_var > rigid_floor(f_var)][: len(full)]
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


__all__ = ["ReductionWarning", "closure_singularity", "reduce", "scene_shares", "scene_state"]

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

**A time step** (``timestep=``, by default the file's own when no band is given): the full model is
linearized where the scene rests (:mod:`mjflex.variants.reduce_verify`: the static equilibrium under
gravity and the first keyframe's controls, as :func:`mjflex.step_advice` wants it), and the directions
carrying the modes that the step and integrator do not resolve with the step advice's margin are held
rigid, the fewest that bring every mode below that band (:mod:`mjflex.variants.reduce_choice`); the
modes below the band are checked as in the band mode, and the reduced model's own step advice (at its
rest under each keyframe's controls) and its statics against the full model's are reported. The band
is set by undamped modes with the equalities rigid; the advice counts what MuJoCo's step counts (the
damping, the constraints' softness, the actuators). Where the advice does not resolve the step, the
band is lowered below the mode it names and the model reduced again (``ADVICE_ROUNDS`` at most), so that
what stays compliant is what the step resolves as the advice says.

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
from dataclasses import dataclass

import numpy as np

from ..analysis.advice import SAFETY
from ..analysis.directions import damping_ratios, element_directions, energy_shares
from ..core import validation
from ..runtime.flexures import Flexures
from .planar import in_plane_modes, out_of_plane, plane_of
from .reduce_build import Plan, build, closure_singularity, element_line, step_line
from .reduce_choice import choose_rigid, drop_damping, rigid_floor, scene_shares, scene_state, step_choice
from .reduce_edges import edge_of, joint_users, preloaded
from .reduce_verify import SceneState, modes_at, scene_states, state_line, verify_modes, verify_step
from .tree import WORLD, free_world_bodies
from .variant import Variant, body_names, keeps_element_kinds, polynomial_terms_lines, source_elements, stops_lines

COUPLING_TOL = 1e-3  # largest normalized stiffness coupling between the directions that become joint springs
#: Largest :func:`closure_singularity` (at 1e-3 amplitude) for which loops="auto" closes loops by
#: constraints. The ratio grows in proportion to the amplitude for a regular mechanism, so 0.1 means
#: that at 1e-2 rad or m the loop constraints, not the flexures, would decide the motion.
SINGULARITY_LIMIT = 0.1
LOOP_MODES = ("auto", "constraint", "element")


#: Rounds of :func:`reduce` at a time step: each lowers the target to what the reduced model's step advice resolves.
ADVICE_ROUNDS = 4


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


@dataclass
class _Base:
    """What a reduction computes once, whatever its target: the source, where it is linearized (where the scene
    rests, :mod:`.reduce_verify`), its modes there, and the elements' principal directions at ``qpos0``
    (``dirs``: what the model is built from) and at that state (``seen``: what the selection reads with the
    modes)."""

    spec: object
    model: object
    flex: object
    timestep: float | None
    states: list | None
    at: SceneState | None
    freq: np.ndarray
    modes: np.ndarray
    normal: np.ndarray | None
    plane_line: str | None
    dirs: list
    seen: list


def _base(source, timestep, scene, plane):
    spec, model, flex = source_elements(source, "reduce")
    if timestep == "file":
        timestep = float(model.opt.timestep)
    states = scene_states(model, flex)  # linearized where the scene rests, as the step advice is asked
    at = next((s for s in states if s.qpos is not None), None)
    freq, modes = modes_at(model, flex, at)
    normal, plane_line = _plane(model, flex, plane, scene)
    dirs = element_directions(model, flex, normal)
    seen = dirs if at is None else element_directions(model, flex, normal, qpos=at.qpos)
    return _Base(spec, model, flex, timestep, states, at, freq, modes, normal, plane_line, dirs, seen)


def _plan(base, keep_below_hz, freq_tol, viscous_tol, duration, max_joints, scene, cap_hz=None, timestep=None):
    spec, model, flex, freq, modes = base.spec, base.model, base.flex, base.freq, base.modes
    timestep = base.timestep if timestep is None else timestep
    normal, plane_line, dirs = base.normal, base.plane_line, base.seen
    step_mode = timestep is not None
    n_el = len(dirs)
    forced = np.zeros((n_el, 6), dtype=bool) if normal is None else out_of_plane(base.dirs, normal)
    in_plane = True if normal is None else in_plane_modes(model, modes, normal)
    kinds = _classify(model, flex, base.dirs, normal is not None)
    reasons = [reason for _, reason, _ in kinds]
    edges = {e: edge for e, (kind, _, edge) in enumerate(kinds) if kind == "edge"}
    needs = {}
    for e, edge in edges.items():
        forced[e] |= ~edge.free  # directions its joints cannot move are rigid already
        for i, names in edge.needed.items():
            needs[e, i] = names
    extent = float(model.stat.extent)
    for e, rec in enumerate(flex.records):  # a rest pose away from the compiled one: not held rigid there
        for i in preloaded(rec, base.dirs[e], extent):
            if not forced[e, i]:
                needs.setdefault((e, i), []).append("its rest pose")
    needed = np.zeros((n_el, 6), dtype=bool)
    for e, i in needs:
        needed[e, i] = True
    reducible = np.array([r is None for r in reasons], dtype=bool)
    limit = np.array([6 if e in edges else max_joints for e in range(n_el)])  # in place, any number of joints
    used = scene_shares(model, flex, base.dirs, scene) if scene is not None else np.zeros((n_el, 6))
    order = np.argsort(used, axis=None, kind="stable")
    allowed = np.zeros(used.size, dtype=bool)
    allowed[order[np.cumsum(used.ravel()[order]) <= 2.0 * freq_tol]] = True  # smallest first, within the budget
    allowed = allowed.reshape(used.shape)
    step = None
    restricted = np.zeros(n_el, dtype=bool)
    if step_mode:
        rigid, mask, step = step_choice(model, dirs, freq, modes, reducible, needs, needed, forced, timestep,
                                         keep_below_hz, freq_tol, cap_hz)  # fmt: skip
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
        elif flex.records[e].rest is not None and len(soft) and rigid[e].any():
            restricted[e] = True  # new joints rest at the compiled pose: the element keeps its rest pose (a preload)
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
        flex, "are kept if it stays a full 3-D element, an element in fewer directions or a planar record (where they "
        "fit the plane); as joints, welds or a one-direction spring it has no range (the joints get no limits)",
        "is kept: the directions it moves stay compliant (all six unless it lies along one principal direction or "
        "along translations); as MuJoCo's springs, their springref; else the element keeps it",
    )  # fmt: skip
    if plane_line:
        report.insert(1, plane_line)
    report.insert(1, state_line(base.states, base.at))
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
    return Plan(
        spec, model, flex, base.dirs, freq, mask, reasons, keep, drop, report, details, normal, edges, restricted
    )


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
        Upper end of the band to resolve [Hz]: modes of the full model below it are kept (its modes
        where the scene rests, as for a time step). Alone, it selects the band mode: everything the
        band does not need is held rigid.
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
    >>> print(reduced.report.splitlines()[2])
    leaf: 3 joints (rx 19 Hz, ry 19 Hz, rz 14 Hz local) ; rigid: x 0.56 %, y 0.56 %, z 0 %

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
    base = _base(source, timestep, scene, plane)
    args = (keep_below_hz, freq_tol, viscous_tol, duration, max_joints, scene)
    cap, rounds, plan, variant = None, [], None, None
    while True:  # at a time step: until the reduced model's own step advice resolves it (module docstring)
        tried = _plan(base, *args, cap)
        if plan is not None and _held(tried) == _held(plan):
            break  # the lower target holds nothing more rigid: the last model stands
        plan, variant = tried, _made(tried, loops, name, keep_below_hz, verify, base)
        step = variant.details.get("step")
        if step is None:
            break
        resolved = verify and step["advised_step"] >= step["timestep"] * (1.0 - 1e-9)
        if not step["reached"] and not resolved:  # every candidate held, and the step still not resolved
            largest = (
                f"{step['advised_step']:.3g} s (the step advice of the model with every other direction held "
                f"rigid, at {step['advice_state']})"
                if verify
                else f"about {step['undamped_largest']:.3g} s"
            )
            raise ValueError(step["unreachable"] + largest)
        if resolved or not verify or len(rounds) == ADVICE_ROUNDS or not step["limiting_hz"] > 0:
            break
        cap = min(step["target_hz"] * step["advised_step"] / step["timestep"], step["limiting_hz"], step["top_hz"])
        cap *= 1.0 - 1e-3  # below the mode the advice found, as the selection sees it: one more direction each round
        rounds.append(f"the step advice of the model reduced for {step['target_hz']:.4g} Hz did not resolve the step "
                      f"({step['advised_step']:.3g} s; its mode {step['limiting_hz']:.4g} Hz, damping ratio "
                      f"{abs(step['damping_ratio']):.2g}): reduced again for {cap:.4g} Hz")  # fmt: skip
    step = variant.details.get("step") or {}
    if step and not step["reached"]:  # and yet resolved (else raised above)
        rounds.append(f"every direction that may go rigid is held, and a mode at {step['top_hz']:.4g} Hz is left "
                      f"above the {step['target_hz']:.4g} Hz an undamped mode needs; the step advice, which counts "
                      "its damping, resolves the step")  # fmt: skip
    if rounds:
        lines = variant.report.split("\n")
        variant.report = "\n".join([lines[0], *rounds, *lines[1:]])
        variant.details["step"]["advice_rounds"] = rounds
    needed = (variant.details.get("step") or {}).get("needed")
    if needed and verify and np.isfinite(needed["largest_step"]):  # the step that keeps it, as the advice says
        needed["largest_step"] = _largest_keeping(base, args, loops, name, keep_below_hz, needed["largest_step"])
    _warn(variant, plan)
    return variant


def _largest_keeping(base, args, loops, name, keep_below_hz, h):
    """The largest step at which the model reduced for it (one round: the direction the band needs kept) is resolved
    by its own step advice: from the undamped modes' step ``h`` down to each model's advised step until one holds."""
    for _ in range(ADVICE_ROUNDS):
        advised = _made(_plan(base, *args, timestep=h), loops, name, keep_below_hz, True, base).details["step"]
        if advised["advised_step"] >= h * (1.0 - 1e-9):
            break
        h = advised["advised_step"]
    return h


def _held(plan):
    """What a plan holds rigid and keeps whole, per element."""
    return {e: (tuple(d["soft"]), d["kept"]) for e, d in plan.details["elements"].items()}


def _made(plan, loops, name, keep_below_hz, verify, base):
    """The variant of ``plan``: built, its loops checked, at its step, and verified (``verify``)."""
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
    if not verify:
        return variant
    own = scene_states(variant.model, Flexures(variant.model) if variant.has_flexures else None)
    index = base.states.index(base.at) if base.at is not None else None
    verify_modes(variant, plan.freq, plan.mask, None if index is None else own[index])  # where each rests
    if step:
        verify_step(variant, plan, base.states, own)
    return variant


def _warn(variant, plan):
    """A :class:`mjflex.ReductionWarning` for elements that could not be reduced, for directions the band needs, and
    for a step the reduced model's advice does not resolve."""
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
    step = variant.details.get("step") or {}
    if step.get("advised_step", np.inf) < step.get("timestep", 0.0) * (1.0 - 1e-9):
        warnings.warn(f"mjflex.reduce: the reduced model's step advice {step['advised_step']:.3g} s does not resolve "
                      f"the step {step['timestep']:g} s at {step['advice_state']} (its mode {step['limiting_hz']:.4g} "
                      f"Hz, damping ratio {abs(step['damping_ratio']):.2g}) (report)", ReductionWarning,
                      stacklevel=3)  # fmt: skip


__all__ = ["ReductionWarning", "closure_singularity", "reduce", "scene_shares", "scene_state"]

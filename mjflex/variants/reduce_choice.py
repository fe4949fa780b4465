"""Which principal directions a reduction holds rigid: the band's modes, a simulated scene, the damping, a time step.

The selection of :func:`mjflex.reduce` (its module docstring says why each criterion), on the full
model's normal modes in mass-normalized modal coordinates: holding directions rigid is a set of
linear constraints on them, so each candidate set is judged by an exact constrained
eigenproblem, cheap next to building a model.
"""

import mujoco
import numpy as np
import scipy.linalg

from ..analysis.advice import SAFETY, integrator_name, mode_limit
from ..analysis.directions import energy_shares

_CAPPED = " (lowered by the reduced model's step advice, which counts the damping, constraints and actuators)"


def rigid_floor(freq):
    """Frequency [Hz] below which a mode counts as a rigid-body mode: 1e-3 Hz, or 1e-6 of the highest.

    The eigensolver leaves a zero ``omega^2`` at about ``n eps`` times the largest (1e-14 for a notch-hinge gripper,
    nv 33: a free box came out at 1e-7 of the highest frequency); 1e-12 of it (1e-6 in frequency) is clear of that.
    """
    return max(1e-3, 1e-6 * float(np.max(freq, initial=0.0)))


def _null_space(rows, n):
    """Orthonormal basis ``(n, k)`` of the null space of ``rows`` (pivoted QR; ``I`` without rows)."""
    if not len(rows):
        return np.eye(n)
    Q, R, _ = scipy.linalg.qr(rows.T, pivoting=True)
    d = np.abs(np.diag(R))
    return Q[:, int(np.sum(d > 1e-10 * d.max(initial=0.0))) :]


def constrained_error(lam, rows, target, n_rigid, floor):
    """Largest relative change of the ``target`` frequencies [Hz] when ``rows @ eta = 0`` is imposed.

    In mass-normalized modal coordinates ``eta`` (``M -> I``, ``K -> diag(lam)``), so the
    constrained problem is a standard symmetric one on the null space of ``rows``.
    """
    N = _null_space(rows, len(lam))
    count = min(n_rigid + len(target), N.shape[1])
    w2 = scipy.linalg.eigh((N.T * lam) @ N, eigvals_only=True, subset_by_index=[0, count - 1]) if count else []
    f = np.sqrt(np.maximum(w2, 0.0)) / (2.0 * np.pi)
    f = f[f > floor][: len(target)]  # constraints may remove rigid-body modes (planar joints), never add any
    if len(f) < len(target):
        return np.inf
    return float(np.max(np.abs(f - target) / target, initial=0.0))


def modal_rows(dirs, modes, pairs) -> np.ndarray:
    """``(len(pairs), n)``: the principal velocity of each ``(element, direction)`` of ``pairs`` in the modes."""
    return np.array([dirs[e].J[i] @ modes for e, i in pairs]).reshape(len(pairs), modes.shape[1])


def held_prefix(n, cand, reducible, forced, max_joints, allowed=None):
    """Rigid directions (n_el, 6), reducible elements and the indices into ``cand`` held rigid, for the prefix ``n``.

    The first ``n`` candidates are held rigid (those ``allowed``, if given); elements then left
    with more than ``max_joints`` compliant directions stay elements, their directions released.
    """
    rigid = forced.copy()
    for e, i in cand[:n]:
        rigid[e, i] = allowed is None or allowed[e, i]
    active = reducible & ((~rigid).sum(axis=1) <= max_joints)
    return rigid, active, [k for k, (e, i) in enumerate(cand[:n]) if rigid[e, i] and active[e]]


def choose_rigid(dirs, shares, freq, modes, mask, reducible, allowed, forced, freq_tol, max_joints, needed=None):
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
    elements and fewer coupled ones: a looser tolerance never keeps more. Directions ``needed``
    (n_el, 6; by an actuator, a tendon or an equality on the joint that moves them) are never candidates.
    ``max_joints`` may be one number or one per element. (Searching again after
    releasing elements, as this did before, made the result depend on which elements a
    tolerance released, and a looser one could keep more.)
    """
    lam = (2.0 * np.pi * freq) ** 2
    target = freq[mask]
    floor = rigid_floor(freq)
    n_rigid = int(np.sum(freq <= floor))
    score = shares.max(axis=2, initial=0.0)
    reducible = np.array(reducible, dtype=bool)
    fixed = modal_rows(dirs, modes, list(zip(*np.nonzero(forced), strict=True)))
    needed = np.zeros_like(forced) if needed is None else needed
    cand = [(e, i) for e in np.nonzero(reducible)[0] for i in range(6)
            if not forced[e, i] and not needed[e, i] and np.isfinite(score[e, i])]  # fmt: skip
    cand.sort(key=lambda c: score[c])
    rows = modal_rows(dirs, modes, cand)

    def error(held):
        return constrained_error(lam, np.vstack([fixed, rows[held]]), target, n_rigid, floor)

    lo, hi = 0, len(cand)
    while lo < hi:  # largest n with error(n) <= freq_tol
        mid = (lo + hi + 1) // 2
        if error(held_prefix(mid, cand, reducible, forced, max_joints)[2]) <= freq_tol:
            lo = mid
        else:
            hi = mid - 1
    rigid, active, held = held_prefix(lo, cand, reducible, forced, max_joints, allowed)
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


def drop_damping(ratios, freq_sel, duration, tol, rtol=1e-6):
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


def step_omega(timestep, integrator) -> float:
    """Highest angular frequency [rad/s] a step resolves with the advice's margin (``advice.SAFETY``).

    The undamped limit of :func:`mjflex.analysis.advice.mode_limit` is ``c / omega`` (``c = 2`` for Euler and
    the implicit integrators, ``2 sqrt 2`` for RK4); a mode is resolved when ``SAFETY`` times its
    limit is at least ``timestep``.
    """
    return mode_limit(1.0, 0.0, integrator) * SAFETY / timestep


def top_omega2(lam, rows) -> tuple[float, np.ndarray]:
    """Largest ``omega^2`` with ``rows @ eta = 0`` imposed in modal coordinates, and its mode ``eta`` (n,)."""
    N = _null_space(rows, len(lam))
    if N.shape[1] == 0:
        return 0.0, np.zeros(len(lam))
    w2, v = scipy.linalg.eigh((N.T * lam) @ N, subset_by_index=[N.shape[1] - 1, N.shape[1] - 1])
    return float(max(w2[0], 0.0)), N @ v[:, 0]


def _first(n_max, bad):
    """Smallest ``n`` in ``[0, n_max]`` with ``bad(n)`` (monotone), or ``n_max + 1``."""
    lo, hi = 0, n_max + 1
    while lo < hi:
        mid = (lo + hi) // 2
        if bad(mid):
            hi = mid
        else:
            lo = mid + 1
    return lo


def choose_for_step(dirs, freq, modes, candidate, omega_band, band_mask, freq_tol, forced, integrator):
    """Hold rigid the fewest directions that bring every mode to the step's band: those that carry the modes above it
    first (their largest strain-energy share there, then their local frequency).

    Parameters
    ----------
    dirs : list of Directions
    freq, modes : ndarray
        The full model's frequencies [Hz] and mass-normalized modes (nv, n).
    candidate : ndarray of bool (n_el, 6)
        Directions that may be held rigid (reducible elements, not needed by an actuator,
        tendon or equality, not already rigid).
    omega_band : float
        :func:`step_omega` [rad/s].
    band_mask : ndarray of bool (n,)
        The full model's modes that must stay within ``freq_tol`` (below the band).
    forced : ndarray of bool (n_el, 6)
        Directions rigid whatever the step (a planar scene's out-of-plane ones).
    integrator : str
        MuJoCo's name of the integrator (for the largest step that keeps a needed direction).

    Returns
    -------
    rigid : ndarray of bool (n_el, 6)
    info : dict
        ``target_hz`` (the band, or the rigid model's own highest mode if higher), ``reached``,
        ``top_hz`` (highest mode left), ``limit`` (the element, direction and frequency that set
        it when not reached), ``needed`` (the first held direction that the band's modes need,
        with the largest step that keeps it) and ``band_error``.

    Holding a direction rigid is a linear constraint in modal coordinates; the highest
    frequency of the constrained problem only falls as constraints are added (interlacing), and
    the band's frequencies only rise, so both prefixes of the stiffest-first order are found by
    bisection. The target never goes below the model with every element direction rigid (the
    rigid robot): a mode of the file's own that the step does not resolve is the author's
    choice, not the elements'. A candidate that the held directions and the equalities already hold
    (its modal row in their span: a notch's twist in a four-bar closed by a ``connect``) is held
    too (``info["implied"]``): it changes no mode, and left compliant it would be held by the
    equalities' softness alone.
    """
    lam = (2.0 * np.pi * freq) ** 2
    floor = rigid_floor(freq)
    n_rigid = int(np.sum(freq <= floor))
    every = [(e, i) for e in range(len(dirs)) for i in range(6)]
    target2 = max(omega_band**2, top_omega2(lam, modal_rows(dirs, modes, every))[0] * (1.0 + 1e-9))
    fixed = modal_rows(dirs, modes, list(zip(*np.nonzero(forced), strict=True)))
    above = freq**2 * (2.0 * np.pi) ** 2 > target2
    share = energy_shares(dirs, freq, modes, above).max(axis=2, initial=0.0)  # in the modes the step cannot take
    cand = [(e, i) for e, i in every if candidate[e, i]]
    cand.sort(key=lambda c: (-share[c], -dirs[c[0]].local_hz[c[1]]))
    rows = modal_rows(dirs, modes, cand)

    def top(n):
        return top_omega2(lam, np.vstack([fixed, rows[:n]]))

    n = _first(len(cand), lambda k: top(k)[0] <= target2)
    info = {"target_hz": float(np.sqrt(target2) / (2 * np.pi)), "reached": n <= len(cand), "limit": None,
            "needed": None}  # fmt: skip
    n = min(n, len(cand))
    w2, eta = top(n)
    info["top_hz"] = float(np.sqrt(w2) / (2 * np.pi))
    if not info["reached"]:  # which direction left compliant carries the limiting mode
        shares = [(dirs[e].k[i] * float(dirs[e].J[i] @ modes @ eta) ** 2, e, i) for e, i in every
                  if not candidate[e, i] and not forced[e, i]]  # fmt: skip
        _, e, i = max(shares) if shares else (0.0, 0, 0)
        info["limit"] = {"element": dirs[e].element, "direction": dirs[e].labels[i], "index": (int(e), int(i)),
                         "frequency_hz": info["top_hz"]}  # fmt: skip
    target = freq[band_mask]

    def band_error(k):
        return constrained_error(lam, np.vstack([fixed, rows[:k]]), target, n_rigid, floor)

    info["band_error"] = band_error(n) if len(target) else 0.0
    if info["band_error"] > freq_tol:
        n0 = _first(n, lambda k: band_error(k) > freq_tol)
        e, i = cand[n0 - 1]
        keep2 = top(n0 - 1)[0]
        info["needed"] = {"element": dirs[e].element, "direction": dirs[e].labels[i],
                          "largest_step": float(SAFETY * mode_limit(np.sqrt(keep2), 0.0, integrator))
                          if keep2 > 0 else float("inf")}  # fmt: skip
    rigid = forced.copy()
    for e, i in cand[:n]:
        rigid[e, i] = True
    held = np.vstack([fixed, rows[:n]])
    info["implied"] = []
    for k in range(n, len(cand)):  # directions the held ones and the equalities already hold: held too
        if _implied(rows[k], held):
            e, i = cand[k]
            rigid[e, i] = True
            info["implied"].append(f"{dirs[e].element} {dirs[e].labels[i]}")
    return rigid, info


def _implied(row, held, rtol=1e-6) -> bool:
    """Whether the modal row of a direction lies in the span of ``held`` (the rows held rigid): the loop's
    equalities and those directions then hold it too, so holding it changes no mode. Left compliant, only the
    equalities' softness would hold it (a stiff mode the step advice counts and the projected modes do not)."""
    norm = float(np.linalg.norm(row))
    if not len(held) or norm == 0.0:
        return norm == 0.0
    x = np.linalg.lstsq(held.T, row, rcond=None)[0]
    return float(np.linalg.norm(held.T @ x - row)) <= rtol * norm


def step_choice(model, dirs, freq, modes, reducible, needs, needed, forced, timestep, keep_below_hz, freq_tol,
                cap_hz=None):  # fmt: skip
    """The target-step selection of :func:`mjflex.reduce` (:func:`choose_for_step`): rigid directions, band mask,
    info (``"unreachable"``: why no reduction reaches the step, every candidate then held). ``cap_hz``: a lower
    target [Hz] than the undamped modes' (the step advice of an earlier round did not resolve the step)."""
    integrator = integrator_name(None, model).replace("discrete", "Euler")  # the advice's name; discrete as Euler
    omega = step_omega(timestep, integrator)
    if cap_hz is not None:
        omega = min(omega, 2.0 * np.pi * cap_hz)
    band_hz = keep_below_hz if keep_below_hz is not None else omega / (2.0 * np.pi)
    mask = (freq > rigid_floor(freq)) & (freq < band_hz)
    candidate = reducible[:, None] & ~forced & ~needed
    rigid, info = choose_for_step(dirs, freq, modes, candidate, omega, mask, freq_tol, forced, integrator)
    info.update(timestep=timestep, integrator=integrator, band_hz=float(band_hz))
    if not info["reached"]:
        lim = info["limit"]
        e, i = lim["index"]
        why = ("needed by " + ", ".join(needs[e, i])) if needed[e, i] else "its element cannot be reduced"
        info["unreachable"] = (
            f"timestep={timestep:g} s: no reduction reaches it with {integrator}: element {lim['element']!r}, "
            f"direction {lim['direction']} ({why}) keeps a mode at {lim['frequency_hz']:.4g} Hz, above the "
            f"{info['target_hz']:.4g} Hz the step resolves{_CAPPED if cap_hz is not None else ''}; the largest step "
            "with it is "
        )
        info["undamped_largest"] = SAFETY * mode_limit(2 * np.pi * lim["frequency_hz"], 0.0, integrator)
    return rigid, mask, info

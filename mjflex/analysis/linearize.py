"""Linearization of a model with flexures: mass and stiffness matrices and normal modes.

By default only the flexures' forces are differentiated (the behaviour since the first
release). Models that also carry MuJoCo's own elasticity — the variants of
:mod:`mjflex.variants.reduce` and :mod:`mjflex.variants.alternatives` — ask for it with ``joint_springs=True``
(joint and tendon springs, ``qfrc_spring``) and ``constraints=``:

* ``"spring"``: equality constraints are soft springs (welds matched to a stiffness): their
  constraint force at rest is differentiated like any other force;
* ``"project"``: equality constraints are (nearly) rigid loop closures: the eigenproblem is
  solved on the null space ``N`` of their Jacobian, ``N^T K N psi = omega^2 N^T M N psi``.

At the operating pose
---------------------
Frequencies rise away from the unloaded reference: a preloaded, bent element has a larger
tangent stiffness (the finite-twist maps stiffen with the rotation), loads add their own
stiffness (gravity's, a dead load's ``J^T f`` turning with the body), and actuators hold joints
like springs (a position servo's ``kp``). Linearize where the model runs: at its static
equilibrium under the load (:func:`static_equilibrium`), with the load (``gravity``,
``xfrc_applied``, ``qfrc_applied``), the actuators (``actuator_stiffness``) and the equalities
(``constraints``); :func:`mjflex.step_advice` does so by default.
"""

import mujoco
import numpy as np
import scipy.linalg

CONSTRAINT_MODES = ("ignore", "spring", "project")


def check_constraints(constraints):
    if constraints not in CONSTRAINT_MODES:
        raise ValueError(f"constraints={constraints!r}: use one of {CONSTRAINT_MODES}")


def keyframe_id(model, keyframe) -> int:
    """Index of ``keyframe`` (a name or an index) of ``model``; raises ValueError naming the keyframes."""
    if isinstance(keyframe, str):
        i = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, keyframe)
    elif isinstance(keyframe, int | np.integer) and not isinstance(keyframe, bool):
        i = int(keyframe) if 0 <= keyframe < model.nkey else -1
    else:
        raise TypeError(f"keyframe must be a keyframe's name or index; got {keyframe!r}")
    if i < 0:
        names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_KEY, k) or str(k) for k in range(model.nkey)]
        raise ValueError(f"keyframe {keyframe!r} is not in the model (its keyframes: {names or 'none'})")
    return i


def state(model, keyframe=None, qpos=None) -> mujoco.MjData:
    """An ``MjData`` at rest (``qvel = 0``) in the configuration to linearize at.

    ``keyframe`` (name or index) sets ``qpos``, ``act``, ``ctrl`` and the mocap poses from that
    keyframe (``mj_resetDataKeyframe``); ``qpos`` (nq,) then overrides the configuration.
    Default: ``qpos0``, zero controls.
    """
    data = mujoco.MjData(model)
    if keyframe is not None:
        mujoco.mj_resetDataKeyframe(model, data, keyframe_id(model, keyframe))
    if qpos is not None:
        q = np.asarray(qpos, dtype=float)
        if q.shape != (model.nq,) or not np.isfinite(q).all():
            raise ValueError(f"qpos must be {model.nq} finite numbers (the model's nq); got shape {q.shape}")
        data.qpos[:] = q
    data.qvel[:] = 0.0
    return data


def loads(model, xfrc_applied=None, qfrc_applied=None):
    """``(xfrc (nbody, 6), qfrc (nv,))`` checked, or None when neither is given: applied loads that the linearization
    holds fixed (dead loads: ``xfrc_applied`` is a world-frame wrench ``[force; torque]`` at each body's centre of
    mass, MuJoCo's layout)."""
    if xfrc_applied is None and qfrc_applied is None:
        return None
    x = np.zeros((model.nbody, 6)) if xfrc_applied is None else np.asarray(xfrc_applied, dtype=float)
    q = np.zeros(model.nv) if qfrc_applied is None else np.asarray(qfrc_applied, dtype=float)
    if x.shape != (model.nbody, 6) or not np.isfinite(x).all():
        raise ValueError(
            f"xfrc_applied must be ({model.nbody}, 6) finite numbers (nbody rows of [force; torque] at each body's "
            f"centre of mass, world axes, as data.xfrc_applied); got shape {x.shape}"
        )
    if q.shape != (model.nv,) or not np.isfinite(q).all():
        raise ValueError(f"qfrc_applied must be {model.nv} finite numbers (the model's nv); got shape {q.shape}")
    return x, q


def _forces(model, data, flex, options):
    """Generalized forces at the configuration in ``data.qpos``, zero velocity; and equality residuals."""
    joint_springs, constraints, actuators, gravity, load = options
    data.qvel[:] = 0.0
    if constraints == "ignore":
        mujoco.mj_fwdPosition(model, data)
        mujoco.mj_fwdVelocity(model, data)
        if actuators:
            mujoco.mj_fwdActuation(model, data)
    else:
        mujoco.mj_forward(model, data)
    f = np.zeros(model.nv) if flex is None else flex.generalized_forces(data)
    if joint_springs:
        f = f + data.qfrc_spring
    if actuators:
        f = f + data.qfrc_actuator
    if gravity:  # at zero velocity qfrc_bias is the gravity term; gravity compensation offsets it
        f = f - data.qfrc_bias + data.qfrc_gravcomp
    if load is not None:  # dead loads: J(q)^T f with f fixed in the world
        applied = load[1].copy()
        for b in np.nonzero(np.any(load[0] != 0, axis=1))[0]:
            mujoco.mj_applyFT(model, data, load[0][b, :3], load[0][b, 3:], data.xipos[b], int(b), applied)
        f = f + applied
    residual = np.zeros(0)
    if constraints != "ignore":
        eq = data.efc_type[: data.nefc] == mujoco.mjtConstraint.mjCNSTR_EQUALITY
        residual = data.efc_pos[: data.nefc][eq].copy()
        if constraints == "spring":
            f = f + data.qfrc_constraint
    return f, residual


def jacobians(model, flex, base, step, options):
    """Central differences of the forces (stiffness, sign flipped) and of the equality residuals about ``base``."""
    q0 = base.qpos.copy()
    data = mujoco.MjData(model)
    data.ctrl[:], data.act[:] = base.ctrl, base.act
    data.mocap_pos[:], data.mocap_quat[:] = base.mocap_pos, base.mocap_quat
    K = np.zeros((model.nv, model.nv))
    G = None
    for i in range(model.nv):
        out = []
        for sign in (1.0, -1.0):
            dq = np.zeros(model.nv)
            dq[i] = sign * step
            data.qpos[:] = q0
            mujoco.mj_integratePos(model, data.qpos, dq, 1.0)
            out.append(_forces(model, data, flex, options))
        K[:, i] = -(out[0][0] - out[1][0]) / (2.0 * step)
        if G is None:
            G = np.zeros((len(out[0][1]), model.nv))
        if len(out[0][1]) != len(out[1][1]) or len(out[0][1]) != G.shape[0]:
            raise ValueError("the number of equality-constraint rows changes with the configuration; cannot linearize")
        G[:, i] = (out[0][1] - out[1][1]) / (2.0 * step)
    return K, (np.zeros((0, model.nv)) if G is None else G)


def stiffness_matrix(model, flex, qpos=None, *, keyframe=None, step=1e-6, joint_springs=False, constraints="ignore",
                     actuator_stiffness=False, gravity=False, xfrc_applied=None, qfrc_applied=None):  # fmt: skip
    """Tangent stiffness ``K = -d(qfrc)/dq`` ``(nv, nv)`` at ``qpos`` or ``keyframe`` (default ``qpos0``).

    Central differences of the generalized forces at zero velocity along each tangent
    direction of the configuration (``mj_integratePos``, so free and ball joints are
    differentiated on their rotation manifold). The forces are the flexures'
    (:meth:`Flexures.generalized_forces`; ``flex`` may be None for a model without elements),
    plus MuJoCo's joint and tendon springs if ``joint_springs``, plus equality-constraint forces
    if ``constraints="spring"``, plus the actuators' forces at fixed controls and activations if
    ``actuator_stiffness`` (a position actuator adds its ``kp`` times the square of its moment
    arm; any length-dependent actuator force counts), plus gravity (net of gravity
    compensation) if ``gravity``, plus the load stiffness of dead loads ``xfrc_applied`` (nbody, 6)
    and ``qfrc_applied`` (nv,) (:func:`loads`). ``keyframe`` (name or index) takes the configuration, controls,
    activations and mocap poses of that keyframe; ``qpos`` then overrides the configuration.
    ``step`` [m or rad]: the forces are smooth and nearly linear near the reference, so 1e-6
    gives ~1e-9 relative accuracy. At the unstressed reference (``qpos0``, no keyframe) the result
    is symmetric up to round-off and returned symmetrized; elsewhere it is returned as computed
    (a stressed tangent stiffness need not be symmetric).
    """
    check_constraints(constraints)
    options = (joint_springs, constraints, actuator_stiffness, gravity, loads(model, xfrc_applied, qfrc_applied))
    K, _ = jacobians(model, flex, state(model, keyframe, qpos), step, options)
    unstressed = qpos is None and keyframe is None and not gravity and options[4] is None
    return 0.5 * (K + K.T) if unstressed else K


def mass_matrix(model, qpos=None, *, keyframe=None):
    """Joint-space inertia ``M`` ``(nv, nv)`` at ``qpos`` or ``keyframe`` (default ``qpos0``)."""
    data = state(model, keyframe, qpos)
    mujoco.mj_fwdPosition(model, data)
    M = np.zeros((model.nv, model.nv))
    mujoco.mj_fullM(model, data, M)
    return M


def null_space(G, nv):
    if G.shape[0] == 0:
        return np.eye(nv)
    _, s, Vt = np.linalg.svd(G)
    rank = int(np.sum(s > 1e-9 * max(s.max(), 1e-300)))
    return Vt[rank:].T


def normal_modes(model, flex, *, keyframe=None, qpos=None, actuator_stiffness=False, gravity=False, step=1e-6,
                 joint_springs=False, constraints="ignore", xfrc_applied=None, qfrc_applied=None):  # fmt: skip
    """Undamped normal modes ``K phi = omega^2 M phi`` about a configuration: ``qpos0`` by default,
    or a keyframe, or a given ``qpos``.

    Both matrices are taken at that configuration: ``M`` is MuJoCo's joint-space inertia there,
    ``K`` the tangent stiffness there (:func:`stiffness_matrix`, symmetrized). Which forces make
    ``K`` is explicit: the flexures always; MuJoCo's joint and tendon springs with
    ``joint_springs``; the actuators with ``actuator_stiffness`` (a position actuator holds its
    joint like a spring of stiffness ``kp``: the derivative of ``qfrc_actuator`` at the
    keyframe's fixed controls); gravity's load stiffness with ``gravity`` (a pendulum's
    ``m g l``; it matters for soft elements far from their equilibrium). Without them, a joint
    that no element or spring holds is a free, zero-frequency mode.

    At the operating pose (module docstring): pass the loaded configuration (``qpos``, e.g. from
    :func:`static_equilibrium`), the load (``gravity``, ``xfrc_applied``, ``qfrc_applied``), the
    actuators and the constraints. Preload, bending and actuator stiffness raise the frequencies;
    the unloaded reference underestimates the stiffest mode (by 1.6-2x for a loaded spine).

    Parameters
    ----------
    model : mujoco.MjModel
    flex : Flexures or None
        The model's elements (None: no elements).
    keyframe : str or int, optional
        Linearize at this keyframe (its ``qpos``, and the ``ctrl``, ``act`` and mocap poses that
        the actuator and element forces see). Default: ``qpos0`` with zero controls.
    qpos : array_like, shape (nq,), optional
        Linearize at this configuration (overrides the keyframe's).
    actuator_stiffness, gravity : bool
        Include the actuators' stiffness, gravity's (see above). Default: neither.
    step : float
        Finite-difference step [m or rad] (see :func:`stiffness_matrix`).
    joint_springs : bool
        Include MuJoCo's joint and tendon springs.
    constraints : {"ignore", "spring", "project"}
        How equality constraints enter (module docstring).
    xfrc_applied : array_like, shape (nbody, 6), optional
        Dead loads at the bodies' centres of mass, ``[force; torque]`` in world axes (MuJoCo's
        ``data.xfrc_applied`` layout): their load stiffness enters ``K``.
    qfrc_applied : array_like, shape (nv,), optional
        Generalized loads held fixed.

    Returns
    -------
    freq : ndarray, shape (n,)
        Natural frequencies [Hz], ascending (rigid-body modes ~0; tiny negative eigenvalues
        from round-off are reported as 0). ``n = nv`` unless constraints are projected out
        (then ``nv`` minus the rank of the equality Jacobian).
    modes : ndarray, shape (nv, n)
        Mass-normalized mode shapes as columns, in ``qvel`` coordinates.

    Examples
    --------
    A block hanging from a leaf spring: six elastic modes, and the explicit time-step limits of the stiffest one:

    >>> import mujoco
    >>> import numpy as np
    >>> import mjflex
    >>> spec = mujoco.MjSpec.from_string(
    ...     '<mujoco><worldbody><body name="block" pos="0 0 -0.1"><freejoint/>'
    ...     '<geom type="box" size="0.02 0.02 0.02" mass="0.5"/></body></worldbody></mujoco>'
    ... )
    >>> _ = mjflex.add_flexure(spec, "leaf", "world", "block", pos=[0, 0, -0.05], K=[2, 2, 1, 1e4, 1e4, 1e4])
    >>> model = spec.compile()
    >>> freq, modes = mjflex.normal_modes(model, mjflex.Flexures(model))
    >>> print(np.round(freq, 1), modes.shape)
    [ 5.9  5.9 13.8 22.5 74.8 74.8] (6, 6)
    >>> omega_max = 2 * np.pi * freq[-1]
    >>> print(f"RK4 stable below {2.8 / omega_max:.1e} s, Euler below {2 / omega_max:.1e} s")
    RK4 stable below 6.0e-03 s, Euler below 4.3e-03 s
    """
    check_constraints(constraints)
    options = (joint_springs, constraints, actuator_stiffness, gravity, loads(model, xfrc_applied, qfrc_applied))
    K, G = jacobians(model, flex, state(model, keyframe, qpos), step, options)
    K = 0.5 * (K + K.T)
    M = mass_matrix(model, qpos, keyframe=keyframe)
    N = null_space(G, model.nv) if constraints == "project" else np.eye(model.nv)
    Kr, Mr = N.T @ K @ N, N.T @ M @ N
    lam, psi = scipy.linalg.eigh(0.5 * (Kr + Kr.T), 0.5 * (Mr + Mr.T))
    return np.sqrt(np.maximum(lam, 0.0)) / (2.0 * np.pi), N @ psi


def static_equilibrium(model, flex=None, *, keyframe=None, qpos=None, xfrc_applied=None, qfrc_applied=None, dofs=None,
                       tol=1e-10, max_iterations=60, step=1e-7) -> np.ndarray:  # fmt: skip
    """The configuration ``(nq,)`` where the model rests under its loads: zero acceleration at zero velocity.

    Newton's method on MuJoCo's own residual ``M qacc = qfrc_smooth + qfrc_constraint`` of
    ``mj_forward`` at zero velocity: gravity, joint and tendon springs, the actuators at the
    keyframe's controls, the elements (plugin instances; text records through ``flex``, installed
    for the solve), equality constraints (MuJoCo's soft constraints: they hold to their
    impedance), limits, contacts and the applied loads. Friction loss is disabled for the solve
    (dry friction makes the equilibrium a set; this is its frictionless point). Its Jacobian is
    taken by central differences on the configuration manifold, and each step is halved until the
    residual falls.

    Parameters
    ----------
    model : mujoco.MjModel
    flex : Flexures, optional
        The model's provider: needed for text-record elements (plugin elements act by
        themselves).
    keyframe : str or int, optional
        Start from this keyframe (its ``qpos``, ``ctrl``, ``act``, mocap poses). Default ``qpos0``.
    qpos : array_like, shape (nq,), optional
        Start from this configuration (overrides the keyframe's).
    xfrc_applied : array_like, shape (nbody, 6), optional
        Loads ``[force; torque]`` at the bodies' centres of mass, world axes (MuJoCo's layout).
    qfrc_applied : array_like, shape (nv,), optional
        Generalized loads.
    dofs : array_like of int, optional
        The dofs that move (default all); the others stay where they start.
    tol : float
        Converged when the residual is below ``tol`` times the larger of its start and of the
        gravity and spring forces there.
    max_iterations : int
        Newton iterations before giving up (RuntimeError).
    step : float
        Finite-difference step [m or rad].

    Returns
    -------
    qpos : ndarray, shape (nq,)
        The equilibrium configuration (linearize there: :func:`normal_modes`,
        :func:`mjflex.step_advice`).

    Examples
    --------
    A 0.5 kg block on a leaf spring under gravity: it sags ``m g / k`` = 0.49 mm.

    >>> import mujoco
    >>> import mjflex
    >>> spec = mujoco.MjSpec.from_string(
    ...     '<mujoco><worldbody><body name="block" pos="0 0 -0.1"><freejoint/>'
    ...     '<geom type="box" size="0.02 0.02 0.02" mass="0.5"/></body></worldbody></mujoco>'
    ... )
    >>> _ = mjflex.add_flexure(spec, "leaf", "world", "block", pos=[0, 0, -0.1], K=[2, 2, 1, 1e4, 1e4, 1e4])
    >>> model = spec.compile()
    >>> qpos = mjflex.static_equilibrium(model)
    >>> print(f"sag {(-0.1 - qpos[2]) * 1e3:.3f} mm")
    sag 0.490 mm
    """
    load = loads(model, xfrc_applied, qfrc_applied)
    data = state(model, keyframe, qpos)
    if load is not None:
        data.xfrc_applied[:], data.qfrc_applied[:] = load
    moving = np.arange(model.nv) if dofs is None else np.asarray(dofs, dtype=int)
    flags = model.opt.disableflags
    model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_FRICTIONLOSS

    def residual(q):
        data.qpos[:], data.qvel[:] = q, 0.0
        if flex is not None:
            with flex:
                mujoco.mj_forward(model, data)
        else:
            mujoco.mj_forward(model, data)
        return (data.qfrc_smooth + data.qfrc_constraint)[moving].copy(), np.abs(data.qfrc_bias).max()

    try:
        q = data.qpos.copy()
        r, bias = residual(q)
        scale = max(np.abs(r).max(), bias, 1e-300)
        for _ in range(max_iterations):
            if np.abs(r).max() <= tol * scale:
                return q
            G = np.zeros((len(moving), len(moving)))
            for j, dof in enumerate(moving):
                cols = []
                for sign in (1.0, -1.0):
                    qq, dq = q.copy(), np.zeros(model.nv)
                    dq[dof] = sign * step
                    mujoco.mj_integratePos(model, qq, dq, 1.0)
                    cols.append(residual(qq)[0])
                G[:, j] = (cols[0] - cols[1]) / (2.0 * step)
            dq = np.zeros(model.nv)
            dq[moving] = -np.linalg.lstsq(G, r, rcond=None)[0]
            for _ in range(30):  # halve the step until the residual falls
                qq = q.copy()
                mujoco.mj_integratePos(model, qq, dq, 1.0)
                rr, _ = residual(qq)
                if np.abs(rr).max() < np.abs(r).max() or np.abs(rr).max() <= tol * scale:
                    break
                dq *= 0.5
            q, r = qq, rr
        if np.abs(r).max() <= tol * scale:
            return q
        raise RuntimeError(
            f"static_equilibrium did not converge in {max_iterations} iterations: residual {np.abs(r).max():.3g} "
            f"(tolerance {tol * scale:.3g}); the load may exceed what the model can hold at rest, or a dof is free "
            "(no element, spring or actuator holds it: pass dofs= without it)"
        )
    finally:
        model.opt.disableflags = flags

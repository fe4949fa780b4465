"""Linearization of a model with flexures: mass and stiffness matrices and normal modes.

One routine differentiates everything here, :func:`central_differences`: the forces for the
stiffness and damping matrices, an element's twist (:mod:`.damping`), the residual of the statics
(:mod:`mjflex.analysis.statics`) and MuJoCo's step itself (:mod:`.advice`, and the study through
it). It moves ``qpos`` along its tangent space (``mj_integratePos``), so free and ball joints are
differentiated on their rotation manifold.

The forces are MuJoCo's own, ``qfrc_smooth`` of ``mj_forward`` at zero velocity with the elements
installed; the options choose what they hold (default: the flexures only, the behaviour since the
first release). Models that carry MuJoCo's own elasticity, such as the variants of
:mod:`mjflex.variants.reduce` and :mod:`mjflex.variants.alternatives`, ask for it with
``joint_springs=True`` (joint and tendon springs) and ``constraints=``:

* ``"spring"``: MuJoCo's constraints as its solver applies them, soft by their ``solref`` /
  ``solimp`` (at the model's ``timestep``, which MuJoCo's ``refsafe`` clamps a time constant to):
  equalities, joint limits and contacts engaged at the pose; their force is differentiated like any
  other (welds matched to a stiffness are springs this way);
* ``"project"``: equality constraints are rigid loop closures: the eigenproblem is solved on the
  null space ``N`` of their Jacobian, ``N^T K N psi = omega^2 N^T M N psi``.

Dry friction (``frictionloss``) is left out: sliding, it is a constant force that neither
stiffens nor damps (at rest it holds the joint: :mod:`mjflex.analysis.statics` takes the
frictionless point too).

At the operating pose
---------------------
Frequencies rise away from the unloaded reference: a preloaded, bent element has a larger
tangent stiffness (the finite-twist maps stiffen with the rotation), loads add their own
stiffness (gravity's, a dead load's ``J^T f`` turning with the body), and actuators hold joints
like springs (a position servo's ``kp``, a muscle's force-length slope at its activation).
Linearize where the model runs: at its static equilibrium under the load and the actuator commands
(:func:`mjflex.static_equilibrium`, ``ctrl=``), with the load (``gravity``, ``xfrc_applied``,
``qfrc_applied``), the actuators (``actuator_stiffness``) and the constraints; :func:`mjflex.step_advice`
does so by default. A state where the forces counted do not balance is not at rest: the functions
here say so (:class:`NotAtRestWarning`, with the residual force and where it acts).
"""

import contextlib
import warnings
from typing import NamedTuple

import mujoco
import numpy as np
import scipy.linalg

CONSTRAINT_MODES = ("ignore", "spring", "project")
#: A state is at rest when its residual force (the forces counted, at zero velocity) is below this fraction of the
#: largest force acting there: the finite-difference linearization (1e-6 steps) is ~1e-9 accurate, so a residual
#: 1e-6 of the forces moves a mode by less than the accuracy its callers state, and a state off its equilibrium by
#: more than that is an error worth naming.
REST_RTOL = 1e-6
#: Finite-difference step [m, rad, m/s or rad/s]: the forces are smooth and nearly linear near a state, so 1e-6
#: gives ~1e-9 relative accuracy.
STEP = 1e-6
_D = mujoco.mjtDisableBit
_STATE = mujoco.mjtState.mjSTATE_INTEGRATION


class NotAtRestWarning(UserWarning):
    """The forces at a state do not balance: a linearization there describes a moment of a motion, not a rest."""


class Options(NamedTuple):
    """What the forces of a linearization hold (module docstring): MuJoCo's springs, the constraints (one of
    ``CONSTRAINT_MODES``), the actuators, gravity, and checked dead loads ``(xfrc (nbody, 6), qfrc (nv,))``."""

    joint_springs: bool = False
    constraints: str = "ignore"
    actuators: bool = False
    gravity: bool = False
    load: tuple | None = None


class Linearization(NamedTuple):
    """A model linearized at a state (:func:`linearize`), ``(nv, nv)`` matrices in ``qvel`` coordinates.

    ``M`` the joint-space inertia, ``K = -d f / d q`` the tangent stiffness, ``C = -d f / d qvel`` the damping
    (None unless asked for), ``G`` ``(neq, nv)`` the Jacobian of the equality constraints' residuals, ``force``
    ``(nv,)`` the forces counted at the state (their residual: zero at rest) [N, N m] and ``scale`` the largest
    force acting there [N or N m] (its yardstick).
    """

    M: np.ndarray
    K: np.ndarray
    C: np.ndarray | None
    G: np.ndarray
    force: np.ndarray
    scale: float


def check_constraints(constraints, allowed=CONSTRAINT_MODES):
    if constraints not in allowed:
        raise ValueError(f"constraints={constraints!r}: use one of {allowed}")


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


def checked_ctrl(model, ctrl) -> np.ndarray:
    """``ctrl`` as ``(nu,)`` finite floats; raises ValueError naming the actuators when it is not."""
    try:
        c = np.asarray(ctrl, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"ctrl must be {model.nu} numbers (one per actuator); got {ctrl!r}") from None
    if c.shape != (model.nu,):
        names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_ACTUATOR, i) or f"#{i}" for i in range(model.nu)]
        raise ValueError(f"ctrl must be {model.nu} numbers, one per actuator {names} in this order; got shape "
                         f"{c.shape}")  # fmt: skip
    if not np.isfinite(c).all():
        bad = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_ACTUATOR, int(i)) or f"#{i}" for i in np.nonzero(
            ~np.isfinite(c))[0]]  # fmt: skip
        raise ValueError(f"ctrl must be finite; it is {c[~np.isfinite(c)].tolist()} for actuator(s) {bad}")
    return c


def _steady_activations(model, data):
    """Activations at their steady state under ``data.ctrl``: ``act = ctrl`` (clamped as MuJoCo clamps them) for
    first-order filters and muscles; integrators and user dynamics keep theirs."""
    Dyn = mujoco.mjtDyn
    for i in range(model.nu):
        adr, dyn = model.actuator_actadr[i], int(model.actuator_dyntype[i])
        if adr < 0 or dyn not in (int(Dyn.mjDYN_FILTER), int(Dyn.mjDYN_FILTEREXACT), int(Dyn.mjDYN_MUSCLE)):
            continue
        u = data.ctrl[i]
        if model.actuator_ctrllimited[i] and not model.opt.disableflags & _D.mjDSBL_CLAMPCTRL:
            u = np.clip(u, *model.actuator_ctrlrange[i])
        if dyn == int(Dyn.mjDYN_MUSCLE):
            u = np.clip(u, 0.0, 1.0)
        if model.actuator_actlimited[i]:
            u = np.clip(u, *model.actuator_actrange[i])
        data.act[adr + model.actuator_actnum[i] - 1] = u


def state(model, keyframe=None, qpos=None, ctrl=None, load=None) -> mujoco.MjData:
    """An ``MjData`` at rest (``qvel = 0``) in the configuration to linearize at.

    ``keyframe`` (name or index) sets ``qpos``, ``act``, ``ctrl`` and the mocap poses from that
    keyframe (``mj_resetDataKeyframe``); ``qpos`` (nq,) then overrides the configuration and ``ctrl``
    (nu,) the actuator commands, with the activations of filters and muscles at their steady state
    under it (``act = ctrl``). ``load``: checked dead loads (:func:`loads`), set as the data's
    ``xfrc_applied`` and ``qfrc_applied``. Default: ``qpos0``, zero controls.
    """
    data = mujoco.MjData(model)
    if keyframe is not None:
        mujoco.mj_resetDataKeyframe(model, data, keyframe_id(model, keyframe))
    if qpos is not None:
        q = np.asarray(qpos, dtype=float)
        if q.shape != (model.nq,) or not np.isfinite(q).all():
            raise ValueError(f"qpos must be {model.nq} finite numbers (the model's nq); got shape {q.shape}")
        data.qpos[:] = q
    if ctrl is not None:
        data.ctrl[:] = checked_ctrl(model, ctrl)
        _steady_activations(model, data)
    if load is not None:
        data.xfrc_applied[:], data.qfrc_applied[:] = load
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


_SPRINGS = ("jnt_stiffness", "jnt_stiffnesspoly", "tendon_stiffness", "tendon_stiffnesspoly")


@contextlib.contextmanager
def evaluating(model, flex, options=None, *, timestep=None, integrator=None, disable=0):
    """The model set up to evaluate ``options``' forces (restored afterwards): what they leave out disabled
    (gravity, actuation, constraints; MuJoCo's springs set to zero), dry friction off, ``discrete``'s step map
    replaced by the continuous dynamics unless ``integrator`` is given, and the elements installed."""
    opt = model.opt
    saved = (opt.disableflags, opt.timestep, opt.integrator)
    springs = {} if options is None or options.joint_springs else {n: getattr(model, n).copy() for n in _SPRINGS
                                                                      if hasattr(model, n)}  # fmt: skip
    flags = disable | _D.mjDSBL_FRICTIONLOSS
    if options is not None:
        flags |= (0 if options.gravity else _D.mjDSBL_GRAVITY) | (0 if options.actuators else _D.mjDSBL_ACTUATION)
        flags |= _D.mjDSBL_CONSTRAINT if options.constraints == "ignore" else 0
    try:
        opt.disableflags |= flags
        opt.timestep = opt.timestep if timestep is None else timestep
        if integrator is not None:
            opt.integrator = integrator
        elif int(opt.integrator) == int(mujoco.mjtIntegrator.mjINT_DISCRETE):
            opt.integrator = mujoco.mjtIntegrator.mjINT_EULER
        for name in springs:
            getattr(model, name)[:] = 0.0
        with flex if flex is not None else contextlib.nullcontext():
            yield
    finally:
        opt.disableflags, opt.timestep, opt.integrator = saved
        for name, value in springs.items():
            getattr(model, name)[:] = value


def central_differences(model, data, evaluate, *, wrt="qpos", dofs=None, step=STEP) -> np.ndarray:
    """``(m, n)``: the derivative of ``evaluate(data)`` (a vector ``(m,)``) along each dof of ``dofs``.

    ``wrt="qpos"`` moves the configuration along the tangent direction of each dof
    (``mj_integratePos``), ``wrt="qvel"`` the velocity; ``dofs`` (default all ``nv``) are the
    columns. Before each evaluation the whole integration state of ``data`` (``mj_getState``:
    positions, velocities, activations, controls, loads, warm start) is put back as it was on entry,
    and it is left so. Central differences with ``step``: error O(step^2).
    """
    if wrt not in ("qpos", "qvel"):
        raise ValueError(f"wrt={wrt!r}: use 'qpos' or 'qvel'")
    cols = np.arange(model.nv) if dofs is None else np.asarray(dofs, dtype=int)
    saved, out = saved_state(model, data), None
    try:
        for j, dof in enumerate(cols):
            pair = []
            for sign in (1.0, -1.0):
                mujoco.mj_setState(model, data, saved, _STATE)
                if wrt == "qpos":
                    dq = np.zeros(model.nv)
                    dq[dof] = sign * step
                    mujoco.mj_integratePos(model, data.qpos, dq, 1.0)
                else:
                    data.qvel[dof] += sign * step
                pair.append(np.asarray(evaluate(data), dtype=float))
            if len(pair[0]) != len(pair[1]) or (out is not None and len(pair[0]) != out.shape[0]):
                raise ValueError(f"the quantity differentiated changes size with the {wrt} of dof {dof} (constraint "
                                 "rows that appear or vanish there); cannot linearize at this state")  # fmt: skip
            if out is None:
                out = np.zeros((len(pair[0]), len(cols)))
            out[:, j] = (pair[0] - pair[1]) / (2.0 * step)
    finally:
        mujoco.mj_setState(model, data, saved, _STATE)
    return np.zeros((0, len(cols))) if out is None else out


def forces(model, data, constraints):
    """``(f (nv,), equality residuals)`` at the state in ``data`` (set up by :func:`evaluating`): MuJoCo's
    ``qfrc_smooth`` (the elements, springs, actuators, gravity and applied loads that are on), plus the
    constraint force with ``constraints="spring"``."""
    mujoco.mj_forward(model, data)
    f = data.qfrc_smooth.copy()
    if constraints == "spring":
        f += data.qfrc_constraint
    if constraints == "ignore":
        return f, np.zeros(0)
    eq = data.efc_type[: data.nefc] == mujoco.mjtConstraint.mjCNSTR_EQUALITY
    return f, data.efc_pos[: data.nefc][eq].copy()


def _scale(data, f):
    """The largest force acting at the state [N or N m]: each of MuJoCo's terms, and their residual."""
    parts = (data.qfrc_passive, data.qfrc_actuator, data.qfrc_bias, data.qfrc_applied, data.qfrc_constraint, f)
    return max(float(np.abs(p).max(initial=0.0)) for p in parts)


def saved_state(model, data) -> np.ndarray:
    """``data``'s integration state (``mj_getState``, ``mjSTATE_INTEGRATION``), to start copies from."""
    out = np.empty(mujoco.mj_stateSize(model, _STATE))
    mujoco.mj_getState(model, data, out, _STATE)
    return out


def data_at(model, base, load=None) -> mujoco.MjData:
    """A fresh ``MjData`` of ``model`` in the integration state of ``base`` (another ``MjData``) at zero velocity,
    with the checked dead loads ``load`` (:func:`loads`) when given."""
    data = mujoco.MjData(model)
    mujoco.mj_setState(model, data, saved_state(model, base), _STATE)
    data.qvel[:] = 0.0
    if load is not None:
        data.xfrc_applied[:], data.qfrc_applied[:] = load
    return data


def mass_at(model, data) -> np.ndarray:
    """Joint-space inertia ``(nv, nv)`` at ``data``'s configuration (``mj_fwdPosition`` run here)."""
    mujoco.mj_fwdPosition(model, data)
    M = np.zeros((model.nv, model.nv))
    mujoco.mj_fullM(model, data, M)
    return M


def linearize(model, flex, base, options, *, step=STEP, damping=False, dynamics=False) -> Linearization:
    """The model linearized at the configuration of ``base`` (an ``MjData``: its ``qpos``, controls, activations,
    mocap poses and applied loads; zero velocity), with the forces of ``options`` (:class:`Options`), by
    :func:`central_differences`; ``damping``: also ``C``. ``dynamics``: differentiate the accelerations instead,
    ``K = -M d qacc / d q`` and ``C = -M d qacc / d qvel`` (``M`` at ``base``): the same at rest, and away from it
    the motion's own linearization (the inertia changing with the configuration, ``(dM/dq) qacc``, counts)."""
    data = data_at(model, base, options.load)
    with evaluating(model, flex, options):
        f, _ = forces(model, data, options.constraints)
        scale = _scale(data, f)
        M = mass_at(model, data)

        def evaluate(d):
            f, residual = forces(model, d, options.constraints)
            return np.concatenate([M @ d.qacc if dynamics else f, residual])

        KG = central_differences(model, data, evaluate, step=step)
        C = (
            -central_differences(model, data, lambda d: evaluate(d)[: model.nv], wrt="qvel", step=step)
            if damping
            else None
        )
    return Linearization(M, -KG[: model.nv], C, KG[model.nv :], f, scale)


def dof_name(model, dof) -> str:
    """A dof in words, with the unit of its generalized force: ``"joint 'j3' (hinge of body 'link3'; N m)"``."""
    j, b = int(model.dof_jntid[dof]), int(model.dof_bodyid[dof])
    kind = mujoco.mjtJoint(model.jnt_type[j])
    name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j) or f"#{j}"
    body = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b) or f"#{b}"
    k = dof - int(model.jnt_dofadr[j])
    if kind == mujoco.mjtJoint.mjJNT_FREE:
        part, unit = (f"translation {'xyz'[k]}", "N") if k < 3 else (f"rotation {'xyz'[k - 3]}", "N m")
        return f"free joint {name!r} of body {body!r}, {part} ({unit})"
    if kind == mujoco.mjtJoint.mjJNT_BALL:
        return f"ball joint {name!r} of body {body!r}, rotation {'xyz'[k]} (N m)"
    unit = "N" if kind == mujoco.mjtJoint.mjJNT_SLIDE else "N m"
    return f"joint {name!r} ({kind.name[6:].lower()} of body {body!r}; {unit})"


def warn_state(model, lin, lam, who, *, always=False, stacklevel=3):
    """Say what is wrong with the state of ``lin`` (``lam``: its undamped ``omega^2``): not at rest (a
    :class:`NotAtRestWarning` naming the largest residual force and its dof; with ``always`` whether or not modes
    came out of negative stiffness, else only then), or at rest but not a stable equilibrium (a UserWarning)."""
    negative = lam < -1e-9 * max(np.abs(lam).max(initial=0.0), 1e-300)
    r = np.abs(lin.force)
    resting = not model.nv or r.max() <= REST_RTOL * max(lin.scale, 1e-300)
    if not resting and (always or negative.any()):
        dof = int(np.argmax(r))
        also = f" ({int(negative.sum())} of {len(lam)} modes come out of negative stiffness)" if negative.any() else ""
        warnings.warn(
            f"{who}: the state is not at rest: the forces counted leave {lin.force[dof]:.3g} on "
            f"{dof_name(model, dof)}, {100 * r[dof] / lin.scale:.3g} % of the largest force acting there "
            f"({lin.scale:.3g}). A linearization here describes a moment of a motion, not a rest{also}; linearize "
            "where the model rests: mjflex.static_equilibrium(...) with the same load and ctrl",
            NotAtRestWarning,
            stacklevel=stacklevel,
        )
    elif resting and negative.any():
        rate = np.sqrt(-lam[negative].min())
        warnings.warn(
            f"{who}: {int(negative.sum())} of {len(lam)} modes have negative stiffness at this state (the fastest "
            f"grows at {rate:.3g} 1/s): it is not a stable equilibrium, so a run from it leaves it at any time step. "
            "Check the state (static_equilibrium can find a saddle; an element loaded hard across a soft direction "
            "can buckle); the frequencies and the advice cover the stable modes only",
            UserWarning,
            stacklevel=stacklevel,
        )


def stiffness_matrix(model, flex, qpos=None, *, keyframe=None, ctrl=None, step=STEP, joint_springs=False,
                     constraints="ignore", actuator_stiffness=False, gravity=False, xfrc_applied=None,
                     qfrc_applied=None):  # fmt: skip
    """Tangent stiffness ``K = -d(qfrc)/dq`` ``(nv, nv)`` at ``qpos`` or ``keyframe`` (default ``qpos0``).

    Central differences (:func:`central_differences`) of the generalized forces at zero velocity
    along each tangent direction of the configuration. The forces (module docstring) are the
    flexures' (plugin instances, and text records through ``flex``; it may be None for a model
    without them), plus MuJoCo's joint and tendon springs if ``joint_springs``, plus the constraint
    forces if ``constraints="spring"``, plus the actuators' forces at fixed controls and activations
    if ``actuator_stiffness`` (a position actuator adds its ``kp`` times the square of its moment
    arm; a muscle its force-length slope; any length-dependent actuator force counts), plus gravity
    (net of gravity compensation) if ``gravity``, plus the load stiffness of dead loads
    ``xfrc_applied`` (nbody, 6) and ``qfrc_applied`` (nv,) (:func:`loads`). ``keyframe`` (name or
    index) takes the configuration, controls, activations and mocap poses of that keyframe; ``qpos``
    then overrides the configuration and ``ctrl`` (nu,) the controls (:func:`state`). ``step`` [m or
    rad]. At the unstressed reference (``qpos0``, no keyframe) the result is symmetric up to
    round-off and returned symmetrized; elsewhere it is returned as computed (a stressed tangent
    stiffness need not be symmetric).
    """
    check_constraints(constraints)
    options = Options(joint_springs, constraints, actuator_stiffness, gravity, loads(model, xfrc_applied, qfrc_applied))
    K = linearize(model, flex, state(model, keyframe, qpos, ctrl), options, step=step).K
    unstressed = qpos is None and keyframe is None and ctrl is None and not gravity and options.load is None
    return 0.5 * (K + K.T) if unstressed else K


def mass_matrix(model, qpos=None, *, keyframe=None):
    """Joint-space inertia ``M`` ``(nv, nv)`` at ``qpos`` or ``keyframe`` (default ``qpos0``)."""
    return mass_at(model, state(model, keyframe, qpos))


def null_space(G, nv):
    if G.shape[0] == 0:
        return np.eye(nv)
    _, s, Vt = np.linalg.svd(G)
    rank = int(np.sum(s > 1e-9 * max(s.max(), 1e-300)))
    return Vt[rank:].T


def normal_modes(model, flex, *, keyframe=None, qpos=None, ctrl=None, actuator_stiffness=False, gravity=False,
                 step=STEP, joint_springs=False, constraints="ignore", xfrc_applied=None,
                 qfrc_applied=None):  # fmt: skip
    """Undamped normal modes ``K phi = omega^2 M phi`` about a configuration: ``qpos0`` by default,
    or a keyframe, or a given ``qpos``.

    Both matrices are taken at that configuration: ``M`` is MuJoCo's joint-space inertia there,
    ``K`` the tangent stiffness there (:func:`stiffness_matrix`; symmetrized, or the eigenvalues of
    ``M^-1 K`` where soft constraints make it asymmetric: :func:`modes_of`). Which forces make
    ``K`` is explicit: the flexures always; MuJoCo's joint and tendon springs with
    ``joint_springs``; the actuators with ``actuator_stiffness`` (a position actuator holds its
    joint like a spring of stiffness ``kp``, a muscle with its force-length slope: the derivative
    of their force at fixed controls and activations); gravity's load stiffness with ``gravity``
    (a pendulum's ``m g l``; it matters for soft elements far from their equilibrium); MuJoCo's soft
    constraints with ``constraints="spring"`` (equalities, limits and contacts engaged at the pose,
    by their ``solref``/``solimp``). Without them, a joint that no element or spring holds is a
    free, zero-frequency mode. Modes of negative stiffness (reported as 0 Hz) are said: at a state
    where the forces counted do not balance, a :class:`NotAtRestWarning` gives the residual force
    and where it acts; at rest, the equilibrium is unstable.

    At the operating pose (module docstring): pass the loaded configuration (``qpos``, e.g. from
    :func:`static_equilibrium`), the load (``gravity``, ``xfrc_applied``, ``qfrc_applied``), the
    actuators and their commands (``ctrl``) and the constraints. Preload, bending and actuator
    stiffness raise the frequencies; the unloaded reference underestimates the stiffest mode (by
    1.6-2x for a loaded spine). The damping, and which of it the integrator treats implicitly, set
    the stable time step too: :func:`mjflex.step_advice`.

    Parameters
    ----------
    model : mujoco.MjModel
    flex : Flexures or None
        The model's elements (None: plugin elements only, or none).
    keyframe : str or int, optional
        Linearize at this keyframe (its ``qpos``, and the ``ctrl``, ``act`` and mocap poses that
        the actuator and element forces see). Default: ``qpos0`` with zero controls.
    qpos : array_like, shape (nq,), optional
        Linearize at this configuration (overrides the keyframe's).
    ctrl : array_like, shape (nu,), optional
        The actuator commands (override the keyframe's); filter and muscle activations are taken at
        their steady state under them (``act = ctrl``).
    actuator_stiffness, gravity : bool
        Include the actuators' stiffness, gravity's (see above). Default: neither.
    step : float
        Finite-difference step [m or rad] (see :func:`stiffness_matrix`).
    joint_springs : bool
        Include MuJoCo's joint and tendon springs.
    constraints : {"ignore", "spring", "project"}
        How constraints enter (module docstring).
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
    options = Options(joint_springs, constraints, actuator_stiffness, gravity, loads(model, xfrc_applied, qfrc_applied))
    lin = linearize(model, flex, state(model, keyframe, qpos, ctrl), options, step=step)
    if constraints == "project":  # the rigid constraints' forces, in the row space of G, hold the rest
        N = null_space(lin.G, model.nv)
        lin = lin._replace(force=N @ (N.T @ lin.force))
    lam, phi = modes_of(lin, project=constraints == "project")
    warn_state(model, lin, lam, "mjflex.normal_modes")
    return np.sqrt(np.maximum(lam, 0.0)) / (2.0 * np.pi), phi


#: ``K`` more asymmetric than this (relative to its largest entry) takes the general eigenproblem: MuJoCo's soft
#: constraints couple through the inertia (their force answers ``M^-1`` of the others), ~1 % on the spine tutorial's
#: equalities, where the symmetric part has spurious negative modes. A conservative ``K`` at rest is symmetric to
#: the differences' ~1e-9.
ASYMMETRY_RTOL = 1e-6


def modes_of(lin, project=False):
    """``(omega^2 (n,), phi (nv, n))``: the undamped modes of ``lin``, mass-normalized, ascending, on the null space
    of the equality constraints with ``project``. ``K`` symmetrized, unless more asymmetric than ``ASYMMETRY_RTOL``:
    then the eigenvalues of ``M^-1 K`` (real parts; modes normalized to ``phi^T M phi = 1``)."""
    nv = lin.M.shape[0]
    N = null_space(lin.G, nv) if project else np.eye(nv)
    Kr, Mr = N.T @ lin.K @ N, 0.5 * (N.T @ lin.M @ N + (N.T @ lin.M @ N).T)
    if np.abs(Kr - Kr.T).max(initial=0.0) <= ASYMMETRY_RTOL * np.abs(Kr).max(initial=0.0):
        lam, psi = scipy.linalg.eigh(0.5 * (Kr + Kr.T), Mr)
        return lam, N @ psi
    lam, psi = scipy.linalg.eig(Kr, Mr)
    order = np.argsort(lam.real)
    lam, psi = lam.real[order], psi[:, order]
    psi = (psi * np.exp(-1j * np.angle(psi[np.abs(psi).argmax(axis=0), range(psi.shape[1])]))).real
    psi /= np.sqrt(np.maximum(np.einsum("ik,ij,jk->k", psi, Mr, psi), 1e-300))
    return lam, N @ psi

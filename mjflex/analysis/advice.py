"""The time step a run can take at the state the model runs in: MuJoCo's own step, linearized.

A step is stable when the one-step map of the state, ``(dq, dv) -> (dq+, dv+)``, does not grow: its
spectral radius is at most 1. :func:`step_advice` differentiates MuJoCo's ``mj_step`` itself at
the state (:func:`.linearize.central_differences`, at each trial step ``h``) and bisects ``h`` to
the largest stable one. So the advice counts what the step counts, as the step counts it:

* the elements, their stops engaged at the pose and their damping, explicitly (MuJoCo takes no
  plugin derivatives into its implicit updates, mujoco#2433);
* the actuators' force derivatives in position and velocity: position servos (``kp``, ``kv``),
  velocity servos and dampers, muscles (force-length and force-velocity at their activation);
* the integrator's implicit treatment. ``Euler`` integrates joint damping (``dof_damping``) implicitly
  (unless the ``eulerdamp`` flag is off); ``implicit`` and ``implicitfast`` the velocity derivatives of
  the passive forces (joint and tendon damping, fluid drag) and of the actuators (the ``kv`` of affine
  gains and biases, dampers, muscles' force-velocity; not an actuator saturated by its force range),
  ``implicit`` also the Coriolis terms (zero at rest); ``discrete`` in addition the position stiffness
  of MuJoCo's springs and actuators and the constraint rows. None of them treats the elements or the
  constraint forces implicitly, except ``discrete`` the latter; ``RK4`` nothing (MuJoCo's manual,
  "Numerical integration"). A term integrated implicitly does not limit the step;
* soft equality constraints, joint limits and contacts by their ``solref``/``solimp`` at the step
  (``refsafe`` clamps a time constant below ``2 h``), the load (gravity, applied loads) and the
  springs.

Dry friction (``frictionloss``) is left out (:mod:`.linearize`), and actuator activations are held
(their own limit, about twice an activation time constant, is far longer than a mechanical one).

The model linearized in continuous time (:func:`.linearize.linearize`: stiffness and damping with
the same forces) names what sets the limit: the eigenvalue ``lambda`` of its first-order system
closest to the map's growing mode (its natural frequency ``|lambda| / 2 pi`` and damping ratio
``-Re lambda / |lambda|``), and it gives the bisection its first guess (``2 / |lambda|`` for the
single-step integrators, ``2 sqrt(2) / |lambda|`` for RK4: the limits of an undamped mode).

Where to linearize matters more than the formula: preload, bending and the actuators' stiffness
raise the frequencies. Ask at the state the model runs in (:func:`mjflex.static_equilibrium` under
the same load and ``ctrl``): a state that is not at rest is said (:class:`.linearize.NotAtRestWarning`,
with the residual force and where it acts). The recommendation is ``safety`` times the limit: a run
that bends further, engages a stop or meets a contact reaches states the linearization did not see.
Check a recommendation with a run that does not diverge.
"""

import math
from dataclasses import dataclass, field

import mujoco
import numpy as np

from ..runtime.flexures import Flexures
from .linearize import (
    STEP,
    Options,
    central_differences,
    check_constraints,
    data_at,
    evaluating,
    linearize,
    loads,
    modes_of,
    state,
    warn_state,
)

_I = mujoco.mjtIntegrator
#: MuJoCo's integrators by their MJCF names.
INTEGRATORS = {"Euler": _I.mjINT_EULER, "RK4": _I.mjINT_RK4, "implicit": _I.mjINT_IMPLICIT,
               "implicitfast": _I.mjINT_IMPLICITFAST, "discrete": _I.mjINT_DISCRETE}  # fmt: skip
#: Safety factor of the recommendation (the measured example in the docs: a loaded spine).
SAFETY = 0.5
#: A one-step map whose spectral radius ``rho`` satisfies ``ln rho <= growth h + max(ln 2 h / horizon, NOISE_TOL)`` is
#: stable: beyond the model's own physical growth rate ``growth`` (0 at a stable equilibrium) it may grow by 2x over
#: ``horizon`` (when one is given) or by its finite-difference noise per step, ~1e-6 on models/two_body.xml (a
#: rigid-body mode's double eigenvalue 1 splits by the square root of the noise). Past a sharp explicit limit the
#: radius rises steeply (RK4 by ~2.5 per unit of omega h, symplectic Euler by the square root of the excess), so the
#: threshold hardly moves it.
NOISE_TOL = 2e-5
#: The bisection's relative bracket of the limit.
RTOL = 1e-3


@dataclass(frozen=True)
class StepAdvice:
    """The stable time step of a model at a state, and the step to take (:func:`step_advice`).

    Attributes
    ----------
    integrator : str
        The integrator the limit is for (MuJoCo's name: ``"Euler"``, ``"RK4"``, ...).
    limit : float
        Largest stable step of MuJoCo's step at the state [s]: the bisection's stable end, less its relative
        width ``rtol`` (at the exact limit a mode is marginal: a knock grows there, linearly in time).
    recommended : float
        ``safety * limit`` [s].
    safety : float
        The factor taken.
    frequency : float
        ``|lambda| / 2 pi`` [Hz] of the eigenvalue that sets the limit: the natural frequency of an
        underdamped mode (a damping-limited, real ``lambda``: its rate over ``2 pi``).
    damping_ratio : float
        That eigenvalue's damping ratio ``-Re lambda / |lambda|`` (all damping, explicit and implicit); 0 where
        ``|Re lambda|`` is within the eigensolver's round-off, ``2 nv eps max|lambda|``.
    freq : ndarray, shape (n,)
        All natural frequencies at the state [Hz], ascending (undamped; constraints as counted).
    mode : ndarray, shape (nv,)
        The limiting mode's shape (the position part of its eigenvector, mass-normalized, ``qvel``
        coordinates).
    unstable : float
        The bisection's first unstable step [s] (within ``2 rtol`` above ``limit``).
    residual : float
        The largest residual force at the state [N or N m]: 0 at rest (a warning says where when not).
    eigenvalue : complex
        The limiting eigenvalue ``lambda`` of the continuous linearization [1/s].

    Examples
    --------
    >>> import mujoco
    >>> import mjflex
    >>> spec = mujoco.MjSpec.from_string(
    ...     '<mujoco><option integrator="RK4"/><worldbody><body name="block" pos="0 0 -0.1"><freejoint/>'
    ...     '<geom type="box" size="0.02 0.02 0.02" mass="0.5"/></body></worldbody></mujoco>'
    ... )
    >>> _ = mjflex.add_flexure(spec, "leaf", "world", "block", pos=[0, 0, -0.05], K=[2, 2, 1, 1e4, 1e4, 1e4])
    >>> model = spec.compile()
    >>> print(mjflex.step_advice(model, gravity=False))
    RK4: stable below 6.01 ms at this state (limiting mode 74.8 Hz, damping ratio 0); take 3 ms (safety 0.5)
    """

    integrator: str
    limit: float
    recommended: float
    safety: float
    frequency: float
    damping_ratio: float
    freq: np.ndarray
    mode: np.ndarray
    unstable: float = math.nan
    residual: float = 0.0
    eigenvalue: complex = field(default=0j, repr=False)

    def __str__(self):
        return (
            f"{self.integrator}: stable below {self.limit * 1e3:.3g} ms at this state (limiting mode "
            f"{self.frequency:.3g} Hz, damping ratio {abs(self.damping_ratio):.2g}); take "
            f"{self.recommended * 1e3:.3g} ms (safety {self.safety:.3g})"
        )


def integrator_name(integrator, model) -> str:
    """MuJoCo's name of ``integrator`` (any case; None: the model's); ValueError naming the choices."""
    if integrator is None:
        return next(k for k, v in INTEGRATORS.items() if int(v) == int(model.opt.integrator))
    names = {k.lower(): k for k in INTEGRATORS}
    if not isinstance(integrator, str) or integrator.lower() not in names:
        raise ValueError(f"integrator={integrator!r}: use one of {tuple(INTEGRATORS)} (MuJoCo's names)")
    return names[integrator.lower()]


def one_step_map(model, flex, base, h, integrator, options, step=STEP) -> np.ndarray:
    """``(2 nv, 2 nv)``: the Jacobian of one ``mj_step`` of ``h`` [s] with ``integrator`` over ``(qpos tangent,
    qvel)`` at the state of ``base`` (its velocity taken as zero; activations, controls, mocap poses held), with the
    forces of ``options`` (:func:`.linearize.evaluating`)."""
    data = data_at(model, base, options.load)
    q0, nv = data.qpos.copy(), model.nv

    def after_step(d):
        mujoco.mj_step(model, d)
        out = np.empty(2 * nv)
        mujoco.mj_differentiatePos(model, out[:nv], 1.0, q0, d.qpos)
        out[nv:] = d.qvel
        return out

    with evaluating(model, flex, options, timestep=h, integrator=INTEGRATORS[integrator]):
        return np.hstack([central_differences(model, data, after_step, wrt=w, step=step) for w in ("qpos", "qvel")])


def _stable(T, h, growth, horizon, noise):
    if not np.isfinite(T).all():  # the step itself overflowed
        return False
    rho = float(np.max(np.abs(np.linalg.eigvals(T)), initial=0.0)) if len(T) else 0.0
    allowance = max(math.log(2.0) * h / horizon, noise) if horizon else noise
    return math.log(max(rho, 1e-300)) <= growth * h + allowance


def stable_step(step_map, guess, growth=0.0, *, rtol=RTOL, horizon=None, factor=1.25, expand=60, noise=NOISE_TOL):
    """``(largest stable step or None, first unstable step or None, the map there or None, last step tried)``.

    ``step_map(h)``: the one-step map of a step ``h`` [s]. From ``guess`` the step is multiplied or divided by
    ``factor`` (at most ``expand`` times) until the limit is bracketed, then bisected geometrically to ``rtol``.
    Stable means ``ln rho <= growth h + max(ln 2 h / horizon, noise)`` (``growth`` [1/s]: the model's own
    fastest physical growth, 0 at a stable equilibrium; ``noise``: the map's, default ``NOISE_TOL``). None where
    the map is stable (or unstable) at every step tried.
    """
    lo = hi = T_hi = None
    h = guess
    for _ in range(expand + 1):
        T = step_map(h)
        if _stable(T, h, growth, horizon, noise):
            lo, h = h, h * factor
        else:
            hi, T_hi, h = h, T, h / factor
        if lo is not None and hi is not None:
            break
    if lo is None or hi is None:
        return lo, hi, T_hi, (hi if lo is None else lo)
    while hi / lo > 1.0 + rtol:
        h = math.sqrt(lo * hi)
        T = step_map(h)
        if _stable(T, h, growth, horizon, noise):
            lo = h
        else:
            hi, T_hi = h, T
    return lo, hi, T_hi, hi


def mode_limit(omega, zeta, integrator) -> float:
    """Largest step [s] at which one mode (``omega`` [rad/s], damping ratio ``zeta``, both explicit) stays stable:
    the bisection of :func:`stable_step` on its one-step map (symplectic Euler's for the single-step integrators,
    ``R(h lambda)`` for RK4); ``2 / omega`` and ``2 sqrt(2) / omega`` undamped. ``inf`` when none limits it."""
    a = np.array([[0.0, 1.0], [-(omega**2), -2.0 * zeta * omega]])

    def step_map(h):
        if integrator == "RK4":
            z = h * a
            return np.eye(2) + z + z @ z / 2 + z @ z @ z / 6 + z @ z @ z @ z / 24
        c = 1.0 - 2.0 * zeta * omega * h
        return np.array([[1.0 - (h * omega) ** 2, h * c], [-h * omega**2, c]])

    guess = (2.0 * math.sqrt(2.0) if integrator == "RK4" else 2.0) / omega
    lo, hi, _, _ = stable_step(step_map, guess, rtol=1e-12, expand=40, noise=1e-14)  # an exact map: no noise
    return math.inf if hi is None else float(lo)


def first_order(lin):
    """Eigenvalues ``(2 nv,)`` and eigenvectors ``(2 nv, 2 nv)`` of ``[[0, I], [-M^-1 K, -M^-1 C]]`` of ``lin``."""
    nv = lin.M.shape[0]
    A, D = np.linalg.solve(lin.M, lin.K), np.linalg.solve(lin.M, lin.C)
    return np.linalg.eig(np.block([[np.zeros((nv, nv)), np.eye(nv)], [-A, -D]]))


def _limiting(T, lam, vec, M):
    """The continuous eigenvalue and real, mass-normalized mode shape closest to ``T``'s growing mode."""
    nv = M.shape[0]
    mu, X = np.linalg.eig(T)
    x = X[:, int(np.argmax(np.abs(mu)))]
    c = np.linalg.lstsq(vec, x, rcond=None)[0]  # x in the eigenbasis of the continuous system
    j = int(np.argmax(np.abs(c) * np.linalg.norm(vec, axis=0)))
    v = vec[:nv, j]
    v = (v * np.exp(-1j * np.angle(v[int(np.argmax(np.abs(v)))]))).real
    return lam[j], v / math.sqrt(max(float(v @ M @ v), 1e-300))


def advise(model, flex, base, integrator, options, *, safety=SAFETY, step=STEP, rtol=RTOL, horizon=None,
           guess=None, factor=1.25, expand=60, warn=True, margin=True):  # fmt: skip
    """:func:`step_advice` at the state of ``base`` (an ``MjData``) with the forces of ``options``.

    Returns ``(StepAdvice or None, last step tried, where none: "stable" or "unstable")``: None where the map
    is stable at every step tried (nothing at this state limits the step) or unstable at every one. ``guess`` [s]
    starts the bracketing (default: the continuous linearization's). ``warn``: say when the state is not at rest
    or not a stable equilibrium. ``margin``: the limit one ``rtol`` below the bisection's stable end (else that
    end itself, the bracket ``[limit, unstable]``).
    """
    lin = linearize(model, flex, base, options, step=step, damping=True, dynamics=True)
    lam, vec = first_order(lin)
    w2, _ = modes_of(lin)
    if warn:
        warn_state(model, lin, w2, "mjflex.step_advice", always=True, stacklevel=4)
    fastest = float(np.max(np.abs(lam), initial=0.0))
    if guess is None:  # the undamped limits of the fastest eigenvalue (the model's step when nothing moves)
        guess = (2.0 * math.sqrt(2.0) if integrator == "RK4" else 2.0) / fastest if fastest > 0 else model.opt.timestep
    growth = max(0.0, float(np.max(lam.real, initial=0.0)))
    lo, hi, T, last = stable_step(lambda h: one_step_map(model, flex, base, h, integrator, options, step), guess,
                                  growth, rtol=rtol, horizon=horizon, factor=factor, expand=expand)  # fmt: skip
    if lo is None or hi is None:
        return None, last, "unstable" if lo is None else "stable"
    eigenvalue, mode = _limiting(T, lam, vec, lin.M)
    size = abs(eigenvalue)
    if abs(eigenvalue.real) <= lam.size * np.finfo(float).eps * fastest:  # the eigensolver's round-off: undamped
        eigenvalue = complex(0.0, eigenvalue.imag)
    lo = lo * (1.0 - rtol) if margin else lo
    return StepAdvice(integrator, float(lo), float(safety * lo), float(safety), float(size / (2.0 * np.pi)),
                      float(-eigenvalue.real / size) if size > 0 else 0.0,
                      np.sqrt(np.maximum(w2, 0.0)) / (2.0 * np.pi), mode, float(hi),
                      float(np.abs(lin.force).max(initial=0.0)), complex(eigenvalue)), last, None  # fmt: skip


def step_advice(model, flex=None, *, integrator=None, keyframe=None, qpos=None, ctrl=None, xfrc_applied=None,
                qfrc_applied=None, gravity=True, actuator_stiffness=True, joint_springs=True, constraints="spring",
                safety=SAFETY, step=STEP, rtol=RTOL, horizon=None) -> StepAdvice:  # fmt: skip
    """The largest stable time step of ``model`` at a state, and the step to take.

    MuJoCo's step is linearized at the state (``keyframe``, ``qpos``, ``ctrl``; default ``qpos0``)
    with the load, the springs, the actuators and the constraints that hold it there, and the
    largest step at which it does not grow is bisected (module docstring: what it counts, and what
    each integrator treats implicitly). Linearize where the model runs: at its loaded equilibrium
    (:func:`mjflex.static_equilibrium` with the same load and ``ctrl``), not at the unloaded
    reference, whose frequencies are lower; a state that is not at rest is said (a
    :class:`~mjflex.analysis.linearize.NotAtRestWarning` with its residual force), a stable
    equilibrium that buckles too.

    Parameters
    ----------
    model : mujoco.MjModel
    flex : Flexures, optional
        The model's elements (built here if not given).
    integrator : str, optional
        ``"Euler"``, ``"RK4"``, ``"implicit"``, ``"implicitfast"`` or ``"discrete"`` (any case; default:
        the model's).
    keyframe : str or int, optional
        The state: this keyframe's configuration, controls and activations.
    qpos : array_like, shape (nq,), optional
        The configuration (overrides the keyframe's), e.g. from :func:`mjflex.static_equilibrium`.
    ctrl : array_like, shape (nu,), optional
        The actuator commands (override the keyframe's); filter and muscle activations at their
        steady state under them (``act = ctrl``).
    xfrc_applied : array_like, shape (nbody, 6), optional
        Dead loads ``[force; torque]`` at the bodies' centres of mass, world axes.
    qfrc_applied : array_like, shape (nv,), optional
        Generalized loads.
    gravity, actuator_stiffness, joint_springs : bool
        Count gravity, the actuators, MuJoCo's joint and tendon springs (all by default; leaving one
        out asks what the limit would be without it).
    constraints : {"spring", "ignore"}
        MuJoCo's constraints as its solver applies them, soft by their ``solref``/``solimp`` at the
        step (default), or none.
    safety : float
        The recommendation's fraction of the limit, in (0, 1].
    step : float
        Finite-difference step [m, rad, m/s, rad/s].
    rtol : float
        The bisection's relative bracket of the limit.
    horizon : float, optional
        Stable means: grows by at most 2x over this time [s] beyond the model's physical growth
        (default: by the map's noise, ``NOISE_TOL``, per step).

    Returns
    -------
    StepAdvice
        The limit, the recommendation and the mode that sets them.

    Examples
    --------
    A block on a leaf spring, under RK4: the stiffest mode (75 Hz) sets 6 ms; half of it is recommended.

    >>> import mujoco
    >>> import mjflex
    >>> spec = mujoco.MjSpec.from_string(
    ...     '<mujoco><option integrator="RK4"/><worldbody><body name="block" pos="0 0 -0.1"><freejoint/>'
    ...     '<geom type="box" size="0.02 0.02 0.02" mass="0.5"/></body></worldbody></mujoco>'
    ... )
    >>> _ = mjflex.add_flexure(spec, "leaf", "world", "block", pos=[0, 0, -0.05], K=[2, 2, 1, 1e4, 1e4, 1e4])
    >>> model = spec.compile()
    >>> advice = mjflex.step_advice(model, qpos=mjflex.static_equilibrium(model))
    >>> print(f"{advice.limit * 1e3:.2f} ms, take {advice.recommended * 1e3:.2f} ms")
    5.99 ms, take 2.99 ms
    """
    check_constraints(constraints, ("spring", "ignore"))
    if not 0.0 < safety <= 1.0:
        raise ValueError(f"safety={safety!r}: the recommendation's fraction of the limit, in (0, 1]")
    integrator = integrator_name(integrator, model)
    flex = Flexures(model) if flex is None else flex
    load = loads(model, xfrc_applied, qfrc_applied)
    options = Options(joint_springs, constraints, actuator_stiffness, gravity, load)
    advice, last, none = advise(model, flex, state(model, keyframe, qpos, ctrl, load), integrator, options,
                                safety=safety, step=step, rtol=rtol, horizon=horizon)  # fmt: skip
    if advice is None:
        where = (f"down to {last:.3g} s: the state itself runs away (check it)" if none == "unstable" else
                 f"up to {last:.3g} s: nothing at this state limits the step")  # fmt: skip
        raise ValueError(
            f"mjflex.step_advice: MuJoCo's {integrator} step is {none} at this state at every step {where}"
        )
    return advice

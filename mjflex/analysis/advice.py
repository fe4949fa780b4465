"""The time step an explicit integration of the elements needs, at the state the model runs in.

MuJoCo integrates the elements' forces explicitly, whatever the integrator (it takes no plugin
derivatives into its implicit updates), so the time step must resolve the stiffest mode of the
linearized model. For an undamped mode of angular frequency ``omega`` the limits are
``h < 2 / omega`` for MuJoCo's semi-implicit Euler (and ``implicit``, ``implicitfast``, whose
implicit part sees MuJoCo's own damping only) and ``h < 2 sqrt(2) / omega`` for RK4. Explicit
damping moves them: :func:`step_advice` takes each mode's damping ratio ``zeta`` (from the
elements' damping, and for RK4 also MuJoCo's joint damping and the actuators' velocity terms,
which RK4 integrates explicitly) and finds the largest step at which the one-step map of that
mode has spectral radius at most 1: for Euler ``v+ = v + h a``, ``x+ = x + h v+`` with
``a = -omega^2 x - 2 zeta omega v``; for RK4 ``|R(h lambda)| <= 1`` with
``R(z) = 1 + z + z^2/2 + z^3/6 + z^4/24`` at the mode's eigenvalues.

Where to linearize matters more than the formula: preload, bending and the actuators'
stiffness raise the frequencies (:mod:`mjflex.analysis.linearize`). By default :func:`step_advice`
linearizes at the given state with everything that holds the model there: the load (gravity and
the applied loads), MuJoCo's springs, the actuators and the equality constraints (projected).
The recommendation is ``safety`` times the limit: the limit is that of the linearized model at
that state, and a run that bends further (or is loaded harder) reaches higher frequencies.
Check a recommendation with a run that does not diverge.
"""

import warnings
from dataclasses import dataclass

import mujoco
import numpy as np
import scipy.linalg

from ..runtime.flexures import Flexures
from .linearize import check_constraints, jacobians, loads, mass_matrix, null_space, state

_EULER_LIKE = ("Euler", "implicit", "implicitfast")
_I = mujoco.mjtIntegrator
#: MuJoCo's integrators by their MJCF names (``discrete`` steps the forces like Euler).
_INTEGRATORS = {int(_I.mjINT_EULER): "Euler", int(_I.mjINT_RK4): "RK4", int(_I.mjINT_IMPLICIT): "implicit",
                int(_I.mjINT_IMPLICITFAST): "implicitfast"}  # fmt: skip
#: Safety factor of the recommendation (the measured example in the docs: a loaded spine).
SAFETY = 0.5


@dataclass(frozen=True)
class StepAdvice:
    """The stable time step of a model at a state, and the step to take (:func:`step_advice`).

    Attributes
    ----------
    integrator : str
        The integrator the limit is for (MuJoCo's name: ``"Euler"``, ``"RK4"``, ...).
    limit : float
        Largest stable step of the linearized model [s].
    recommended : float
        ``safety * limit`` [s].
    safety : float
        The factor taken.
    frequency : float
        Natural frequency of the mode that sets the limit [Hz].
    damping_ratio : float
        That mode's damping ratio (the explicit part).
    freq : ndarray, shape (n,)
        All natural frequencies at the state [Hz], ascending.
    mode : ndarray, shape (nv,)
        The limiting mode's shape (mass-normalized, ``qvel`` coordinates).

    Examples
    --------
    >>> import mujoco
    >>> import mjflex
    >>> spec = mujoco.MjSpec.from_string(
    ...     '<mujoco><option integrator="RK4"/><worldbody><body name="block" pos="0 0 -0.1"><freejoint/>'
    ...     '<geom type="box" size="0.02 0.02 0.02" mass="0.5"/></body></worldbody></mujoco>'
    ... )
    >>> _ = mjflex.add_flexure(spec, "leaf", "world", "block", pos=[0, 0, -0.05], K=[2, 2, 1, 1e4, 1e4, 1e4])
    >>> advice = mjflex.step_advice(spec.compile())
    >>> print(advice)
    RK4: stable below 6.01 ms at this state (stiffest mode 74.8 Hz, damping ratio 0); take 3.01 ms (safety 0.5)
    """

    integrator: str
    limit: float
    recommended: float
    safety: float
    frequency: float
    damping_ratio: float
    freq: np.ndarray
    mode: np.ndarray

    def __str__(self):
        return (
            f"{self.integrator}: stable below {self.limit * 1e3:.3g} ms at this state (stiffest mode "
            f"{self.frequency:.3g} Hz, damping ratio {self.damping_ratio:.3g}); take {self.recommended * 1e3:.3g} ms "
            f"(safety {self.safety:.3g})"
        )


def _euler_radius(h, omega, zeta):
    c = 1.0 - 2.0 * zeta * omega * h
    A = np.array([[1.0 - (h * omega) ** 2, h * c], [-h * omega**2, c]])
    return np.abs(np.linalg.eigvals(A)).max()


def _rk4_radius(h, omega, zeta):
    root = np.sqrt(complex(zeta**2 - 1.0))
    lam = omega * np.array([-zeta + root, -zeta - root])
    z = h * lam
    return np.abs(1 + z + z**2 / 2 + z**3 / 6 + z**4 / 24).max()


def mode_limit(omega, zeta, integrator) -> float:
    """Largest step [s] at which one mode (``omega`` [rad/s], damping ratio ``zeta``) stays stable."""
    radius = _rk4_radius if integrator == "RK4" else _euler_radius
    guess = (2.0 * np.sqrt(2.0) if integrator == "RK4" else 2.0) / omega
    lo, hi = 0.0, guess
    while radius(hi, omega, zeta) <= 1.0 + 1e-12:  # damping can also extend the range
        lo, hi = hi, 2.0 * hi
        if hi > 1e3 * guess:
            return np.inf
    n = 400  # the first unstable step on a fine grid, then bisection (the stable set is an interval here)
    grid = np.linspace(lo, hi, n + 1)[1:]
    first = next(i for i, h in enumerate(grid) if radius(h, omega, zeta) > 1.0 + 1e-12)
    lo, hi = (grid[first - 1] if first else lo), grid[first]
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if radius(mid, omega, zeta) <= 1.0 + 1e-12 else (lo, mid)
    return lo


def _damping_matrix(model, flex, base, integrator, step=1e-6):
    """``C = -d qfrc / d qvel`` of the forces integrated explicitly: the elements' damping; under RK4 also
    MuJoCo's joint damping and the actuators' velocity terms."""
    data = mujoco.MjData(model)
    data.qpos[:], data.ctrl[:], data.act[:] = base.qpos, base.ctrl, base.act
    data.mocap_pos[:], data.mocap_quat[:] = base.mocap_pos, base.mocap_quat
    C = np.zeros((model.nv, model.nv))
    for i in range(model.nv):
        out = []
        for sign in (1.0, -1.0):
            data.qvel[:] = 0.0
            data.qvel[i] = sign * step
            mujoco.mj_fwdPosition(model, data)
            mujoco.mj_fwdVelocity(model, data)
            f = np.zeros(model.nv) if flex is None else flex.generalized_forces(data)
            if integrator == "RK4":
                mujoco.mj_fwdActuation(model, data)
                f = f + data.qfrc_damper + data.qfrc_actuator
            out.append(f)
        C[:, i] = -(out[0] - out[1]) / (2.0 * step)
    return 0.5 * (C + C.T)


def _warn_unstable(lam, n):
    """A warning when the state is not a stable equilibrium: modes of negative stiffness grow at any step."""
    negative = lam < -1e-9 * max(np.abs(lam).max(initial=0.0), 1e-300)
    if negative.any():
        rate = np.sqrt(-lam[negative].min())
        warnings.warn(
            f"mjflex.step_advice: {int(negative.sum())} of {n} modes have negative stiffness at this state (the "
            f"fastest grows at {rate:.3g} 1/s): it is not a stable equilibrium, so a run from it leaves it at any "
            "time step. Check the state (static_equilibrium can find a saddle; an element loaded hard across a soft "
            "direction can buckle); the advice covers the stable modes only",
            UserWarning,
            stacklevel=3,
        )


def step_advice(model, flex=None, *, integrator=None, keyframe=None, qpos=None, xfrc_applied=None, qfrc_applied=None,
                gravity=True, actuator_stiffness=True, joint_springs=True, constraints="project", safety=SAFETY,
                step=1e-6) -> StepAdvice:  # fmt: skip
    """The largest stable time step of ``model`` at a state, and the step to take.

    The model is linearized at the state (``keyframe``, ``qpos``; default ``qpos0``) with the
    load, the springs, the actuators and the equality constraints that hold it there
    (:func:`mjflex.normal_modes` with all of them on by default); each mode's limit follows from
    its frequency and explicit damping ratio (module docstring), and the smallest is the model's.
    Linearize where the model runs: at its loaded equilibrium (:func:`mjflex.static_equilibrium`),
    not at the unloaded reference, whose frequencies are lower.

    Parameters
    ----------
    model : mujoco.MjModel
    flex : Flexures, optional
        The model's elements (built here if not given).
    integrator : str, optional
        ``"Euler"``, ``"RK4"``, ``"implicit"`` or ``"implicitfast"`` (default: the model's).
    keyframe : str or int, optional
        The state: this keyframe's configuration, controls and activations.
    qpos : array_like, shape (nq,), optional
        The configuration (overrides the keyframe's), e.g. from :func:`mjflex.static_equilibrium`.
    xfrc_applied : array_like, shape (nbody, 6), optional
        Dead loads ``[force; torque]`` at the bodies' centres of mass, world axes.
    qfrc_applied : array_like, shape (nv,), optional
        Generalized loads.
    gravity, actuator_stiffness, joint_springs : bool
        Include gravity's load stiffness, the actuators' stiffness, MuJoCo's springs (all by
        default).
    constraints : {"project", "spring", "ignore"}
        How equality constraints enter (:mod:`mjflex.analysis.linearize`); default: rigid, projected.
    safety : float
        The recommendation's fraction of the limit, in (0, 1].
    step : float
        Finite-difference step [m or rad].

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
    5.99 ms, take 3.00 ms
    """
    check_constraints(constraints)
    if not 0.0 < safety <= 1.0:
        raise ValueError(f"safety={safety!r}: the recommendation's fraction of the limit, in (0, 1]")
    integrator = _INTEGRATORS.get(int(model.opt.integrator), "Euler") if integrator is None else integrator
    if integrator not in ("RK4", *_EULER_LIKE):
        raise ValueError(f"integrator={integrator!r}: use one of {('RK4', *_EULER_LIKE)} (MuJoCo's names)")
    flex = Flexures(model) if flex is None else flex
    base = state(model, keyframe, qpos)
    options = (joint_springs, constraints, actuator_stiffness, gravity, loads(model, xfrc_applied, qfrc_applied))
    K, G = jacobians(model, flex, base, step, options)
    M = mass_matrix(model, base.qpos)
    N = null_space(G, model.nv) if constraints == "project" else np.eye(model.nv)
    Kr, Mr = N.T @ (0.5 * (K + K.T)) @ N, N.T @ M @ N
    lam, psi = scipy.linalg.eigh(0.5 * (Kr + Kr.T), 0.5 * (Mr + Mr.T))
    phi = N @ psi
    _warn_unstable(lam, psi.shape[0])
    C = _damping_matrix(model, flex, base, integrator, step)
    omega = np.sqrt(np.maximum(lam, 0.0))
    limits = np.full(len(lam), np.inf)
    zetas = np.zeros(len(lam))
    for k in np.nonzero(omega > 1e-9 * max(omega.max(initial=0.0), 1e-300))[0]:
        zetas[k] = max(float(phi[:, k] @ C @ phi[:, k]) / (2.0 * omega[k]), 0.0)
        limits[k] = mode_limit(omega[k], zetas[k], integrator)
    if not np.isfinite(limits).any():
        raise ValueError("the model has no elastic mode at this state: nothing limits the step")
    k = int(np.argmin(limits))
    freq = omega / (2.0 * np.pi)
    return StepAdvice(integrator, float(limits[k]), float(safety * limits[k]), float(safety), float(freq[k]),
                      float(zetas[k]), freq, phi[:, k].copy())  # fmt: skip

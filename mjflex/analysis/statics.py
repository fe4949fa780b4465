"""Where a model rests under its loads and actuator commands: :func:`static_equilibrium`.

Newton's method on MuJoCo's own residual, its Jacobian by :func:`.linearize.central_differences`.
The residual cannot fall below the noise of what computes it, and the convergence test accepts a
residual within ``NOISE_FACTOR`` of that noise:

* the constraint solver stops at its ``tolerance`` (MuJoCo's ``opt.tolerance``, 1e-8 by default,
  relative to its own cost), so that the constraint forces of two solves at one configuration differ
  by that much; measured at the configuration reached (the residual from a cold start against the
  residual warm-started from the last solve);
* round-off: the world positions that the forces are computed from carry a rounding error of about
  ``eps`` times the model's size (``model.stat.extent``), and a stiff element turns it into force,
  ``eps * sum_j |G_ij| s_j`` on dof ``i`` (``G``: the residual's Jacobian, ``s_j``: the extent for a
  translation, 1 rad for a rotation). Notch hinges of 1e8 N/m in a model of 0.1 m: ~1e-9 N.
"""

import mujoco
import numpy as np

from .linearize import central_differences, dof_name, evaluating, loads, state

#: A residual within this factor of its measured noise is converged (the noise is one sample of a spread).
NOISE_FACTOR = 10.0


def _residual(model, data, moving):
    mujoco.mj_forward(model, data)
    return (data.qfrc_smooth + data.qfrc_constraint)[moving].copy()


def _noise(model, data, moving, r):
    """The residual's spread at ``data``'s configuration: ``r`` (warm-started) against a cold start's."""
    if not data.nefc:
        return 0.0
    warm = data.qacc_warmstart.copy()
    data.qacc_warmstart[:] = 0.0
    flags = model.opt.disableflags
    model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_WARMSTART
    try:
        cold = _residual(model, data, moving)
    finally:
        model.opt.disableflags = flags
        data.qacc_warmstart[:] = warm
    return float(np.abs(cold - r).max(initial=0.0))


def static_equilibrium(model, flex=None, *, keyframe=None, qpos=None, ctrl=None, xfrc_applied=None,
                       qfrc_applied=None, dofs=None, tol=1e-10, max_iterations=60,
                       step=1e-7) -> np.ndarray:  # fmt: skip
    """The configuration ``(nq,)`` where the model rests under its loads: zero acceleration at zero velocity.

    Newton's method on MuJoCo's own residual ``M qacc = qfrc_smooth + qfrc_constraint`` of
    ``mj_forward`` at zero velocity: gravity, joint and tendon springs, the actuators at the
    keyframe's controls or ``ctrl``, the elements (plugin instances; text records through ``flex``,
    installed for the solve), equality constraints (MuJoCo's soft constraints: they hold to their
    impedance), limits, contacts and the applied loads. Friction loss is disabled for the solve
    (dry friction makes the equilibrium a set; this is its frictionless point). Its Jacobian is
    taken by central differences on the configuration manifold, and each step is halved until the
    residual falls. Converged when the residual is below ``tol`` times the force scale, or within
    ``NOISE_FACTOR`` of its noise where MuJoCo's constraint solver makes that larger (module
    docstring).

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
    ctrl : array_like, shape (nu,), optional
        The actuator commands (override the keyframe's); filter and muscle activations at their
        steady state under them (``act = ctrl``).
    xfrc_applied : array_like, shape (nbody, 6), optional
        Loads ``[force; torque]`` at the bodies' centres of mass, world axes (MuJoCo's layout).
    qfrc_applied : array_like, shape (nv,), optional
        Generalized loads.
    dofs : array_like of int, optional
        The dofs that move (default all); the others stay where they start.
    tol : float
        Converged when the residual is below ``tol`` times the larger of its start and of the
        gravity and spring forces there (or within ``NOISE_FACTOR`` of the solver's noise).
    max_iterations : int
        Newton iterations before giving up (RuntimeError: by how much, and on which dof).
    step : float
        Finite-difference step [m or rad].

    Returns
    -------
    qpos : ndarray, shape (nq,)
        The equilibrium configuration (linearize there: :func:`mjflex.normal_modes`,
        :func:`mjflex.step_advice`, with the same load and ``ctrl``).

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
    data = state(model, keyframe, qpos, ctrl, loads(model, xfrc_applied, qfrc_applied))
    moving = np.arange(model.nv) if dofs is None else np.asarray(dofs, dtype=int)
    with evaluating(model, flex):
        r = _residual(model, data, moving)
        scale = max(np.abs(r).max(initial=0.0), np.abs(data.qfrc_bias).max(initial=0.0), 1e-300)
        kind = model.jnt_type[model.dof_jntid]
        k = np.arange(model.nv) - model.jnt_dofadr[model.dof_jntid]
        translation = (kind == mujoco.mjtJoint.mjJNT_SLIDE) | ((kind == mujoco.mjtJoint.mjJNT_FREE) & (k < 3))
        scales = np.where(translation, max(float(model.stat.extent), 1e-300), 1.0)[moving]  # s_j (module docstring)
        noise, roundoff = 0.0, np.zeros(len(moving))  # no G yet
        for iteration in range(max_iterations + 1):
            noise = _noise(model, data, moving, r)
            bound = np.maximum(max(tol * scale, NOISE_FACTOR * noise), NOISE_FACTOR * roundoff)
            if np.all(np.abs(r) <= bound):
                return data.qpos.copy()
            if iteration == max_iterations:
                break
            G = central_differences(model, data, lambda d: _residual(model, d, moving), dofs=moving, step=step)
            roundoff = np.finfo(float).eps * (np.abs(G) @ scales)  # eps |G| s (module docstring), of the next iterate
            dq = np.zeros(model.nv)
            dq[moving] = -np.linalg.lstsq(G, r, rcond=None)[0]
            q0 = data.qpos.copy()
            for _halving in range(30):  # halve the step until the residual falls
                data.qpos[:] = q0
                mujoco.mj_integratePos(model, data.qpos, dq, 1.0)
                rr = _residual(model, data, moving)
                if np.abs(rr).max() < np.abs(r).max() or np.abs(rr).max() <= tol * scale:
                    break
                dq *= 0.5
            r = rr
    i = int(np.argmax(np.abs(r) / bound))
    raise RuntimeError(
        f"static_equilibrium did not converge in {max_iterations} iterations: the residual force farthest above its "
        f"tolerance is {r[i]:.3g} on {dof_name(model, int(moving[i]))}, {abs(r[i]) / bound[i]:.3g} times the "
        f"tolerance {bound[i]:.3g} (tol {tol:g} of the force scale {scale:.3g}; the constraint solver's noise "
        f"there {noise:.3g}, the forces' round-off {roundoff[i]:.3g}). Either nothing holds that "
        "dof against the load (no element, spring, actuator or constraint stiffens it: leave it out with dofs=), or "
        "the load exceeds what the model can hold at rest there"
    )

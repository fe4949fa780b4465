"""Linearization of a model with flexures: mass and stiffness matrices and normal modes.

By default only the flexures' forces are differentiated (the behaviour since the first
release). Models that also carry MuJoCo's own elasticity — the variants of
:mod:`mjflex.mj.reduce` and :mod:`mjflex.mj.native` — ask for it with ``joint_springs=True``
(joint and tendon springs, ``qfrc_spring``) and ``constraints=``:

* ``"spring"``: equality constraints are soft springs (welds matched to a stiffness): their
  constraint force at rest is differentiated like any other force;
* ``"project"``: equality constraints are (nearly) rigid loop closures: the eigenproblem is
  solved on the null space ``N`` of their Jacobian, ``N^T K N psi = omega^2 N^T M N psi``.
"""

import mujoco
import numpy as np
import scipy.linalg

CONSTRAINT_MODES = ("ignore", "spring", "project")


def _check_constraints(constraints):
    if constraints not in CONSTRAINT_MODES:
        raise ValueError(f"constraints={constraints!r}: use one of {CONSTRAINT_MODES}")


def _forces(model, data, flex, joint_springs, constraints):
    """Generalized forces at the configuration in ``data.qpos``, zero velocity; and equality residuals."""
    data.qvel[:] = 0.0
    if constraints == "ignore":
        mujoco.mj_fwdPosition(model, data)
        mujoco.mj_fwdVelocity(model, data)
    else:
        mujoco.mj_forward(model, data)
    f = np.zeros(model.nv) if flex is None else flex.generalized_forces(data)
    if joint_springs:
        f = f + data.qfrc_spring
    residual = np.zeros(0)
    if constraints != "ignore":
        eq = data.efc_type[: data.nefc] == mujoco.mjtConstraint.mjCNSTR_EQUALITY
        residual = data.efc_pos[: data.nefc][eq].copy()
        if constraints == "spring":
            f = f + data.qfrc_constraint
    return f, residual


def _jacobians(model, flex, qpos, step, joint_springs, constraints):
    """Central differences of the forces (stiffness, sign flipped) and of the equality residuals."""
    q0 = model.qpos0.copy() if qpos is None else np.asarray(qpos, dtype=float)
    data = mujoco.MjData(model)
    K = np.zeros((model.nv, model.nv))
    G = None
    for i in range(model.nv):
        out = []
        for sign in (1.0, -1.0):
            dq = np.zeros(model.nv)
            dq[i] = sign * step
            data.qpos[:] = q0
            mujoco.mj_integratePos(model, data.qpos, dq, 1.0)
            out.append(_forces(model, data, flex, joint_springs, constraints))
        K[:, i] = -(out[0][0] - out[1][0]) / (2.0 * step)
        if G is None:
            G = np.zeros((len(out[0][1]), model.nv))
        if len(out[0][1]) != len(out[1][1]) or len(out[0][1]) != G.shape[0]:
            raise ValueError("the number of equality-constraint rows changes with the configuration; cannot linearize")
        G[:, i] = (out[0][1] - out[1][1]) / (2.0 * step)
    return K, (np.zeros((0, model.nv)) if G is None else G)


def stiffness_matrix(model, flex, qpos=None, *, step=1e-6, joint_springs=False, constraints="ignore"):
    """Tangent stiffness ``K = -d(qfrc)/dq`` ``(nv, nv)`` at ``qpos`` (default ``qpos0``).

    Central differences of the generalized forces at zero velocity along each tangent
    direction of the configuration (``mj_integratePos``, so free and ball joints are
    differentiated on their rotation manifold). The forces are the flexures'
    (:meth:`Flexures.generalized_forces`; ``flex`` may be None for a model without elements),
    plus MuJoCo's joint and tendon springs if ``joint_springs``, plus equality-constraint forces
    if ``constraints="spring"``. ``step`` [m or rad]: the forces are smooth and nearly linear
    near the reference, so 1e-6 gives ~1e-9 relative accuracy. At an unstressed configuration
    (``qpos0``) the result is symmetric up to round-off; it is returned symmetrized there.
    """
    _check_constraints(constraints)
    K, _ = _jacobians(model, flex, qpos, step, joint_springs, constraints)
    return 0.5 * (K + K.T) if qpos is None else K


def mass_matrix(model, qpos=None):
    """Joint-space inertia ``M`` ``(nv, nv)`` at ``qpos`` (default ``qpos0``)."""
    data = mujoco.MjData(model)
    data.qpos[:] = model.qpos0 if qpos is None else qpos
    mujoco.mj_fwdPosition(model, data)
    M = np.zeros((model.nv, model.nv))
    mujoco.mj_fullM(model, data, M)
    return M


def _null_space(G, nv):
    if G.shape[0] == 0:
        return np.eye(nv)
    _, s, Vt = np.linalg.svd(G)
    rank = int(np.sum(s > 1e-9 * max(s.max(), 1e-300)))
    return Vt[rank:].T


def normal_modes(model, flex, *, step=1e-6, joint_springs=False, constraints="ignore"):
    """Undamped normal modes about ``qpos0``: ``K phi = omega^2 M phi``.

    Parameters
    ----------
    model : mujoco.MjModel
    flex : Flexures or None
        The model's elements (None: no elements).
    step : float
        Finite-difference step [m or rad] (see :func:`stiffness_matrix`).
    joint_springs : bool
        Include MuJoCo's joint and tendon springs.
    constraints : {"ignore", "spring", "project"}
        How equality constraints enter (module docstring).

    Returns
    -------
    freq : ndarray, shape (n,)
        Natural frequencies [Hz], ascending (rigid-body modes ~0; tiny negative eigenvalues
        from round-off are reported as 0). ``n = nv`` unless constraints are projected out
        (then ``nv`` minus the rank of the equality Jacobian).
    modes : ndarray, shape (nv, n)
        Mass-normalized mode shapes as columns, in ``qvel`` coordinates.
    """
    _check_constraints(constraints)
    K, G = _jacobians(model, flex, None, step, joint_springs, constraints)
    K = 0.5 * (K + K.T)
    M = mass_matrix(model)
    N = _null_space(G, model.nv) if constraints == "project" else np.eye(model.nv)
    Kr, Mr = N.T @ K @ N, N.T @ M @ N
    lam, psi = scipy.linalg.eigh(0.5 * (Kr + Kr.T), 0.5 * (Mr + Mr.T))
    return np.sqrt(np.maximum(lam, 0.0)) / (2.0 * np.pi), N @ psi

"""Linearization of a model with flexures: mass and stiffness matrices and normal modes."""

import mujoco
import numpy as np
import scipy.linalg


def stiffness_matrix(model, flex, qpos=None, *, step=1e-6):
    """Tangent stiffness ``K = -d(qfrc_flexures)/dq`` ``(nv, nv)`` of the elements at ``qpos``.

    Central differences of :meth:`Flexures.generalized_forces` (at zero velocity) along each
    tangent direction of the configuration (``mj_integratePos``, so free and ball joints are
    differentiated on their rotation manifold). ``step`` [m or rad]: the forces are smooth
    and nearly linear near the reference, so 1e-6 gives ~1e-9 relative accuracy. At an
    unstressed configuration (``qpos0``) the result is symmetric up to round-off; it is
    returned symmetrized there. MuJoCo's own joint springs are not included.
    """
    q0 = model.qpos0.copy() if qpos is None else np.asarray(qpos, dtype=float)
    data = mujoco.MjData(model)
    K = np.zeros((model.nv, model.nv))
    for i in range(model.nv):
        cols = []
        for sign in (1.0, -1.0):
            dq = np.zeros(model.nv)
            dq[i] = sign * step
            data.qpos[:] = q0
            mujoco.mj_integratePos(model, data.qpos, dq, 1.0)
            data.qvel[:] = 0.0
            mujoco.mj_fwdPosition(model, data)
            mujoco.mj_fwdVelocity(model, data)
            cols.append(flex.generalized_forces(data))
        K[:, i] = -(cols[0] - cols[1]) / (2.0 * step)
    return 0.5 * (K + K.T) if qpos is None else K


def mass_matrix(model, qpos=None):
    """Joint-space inertia ``M`` ``(nv, nv)`` at ``qpos`` (default ``qpos0``)."""
    data = mujoco.MjData(model)
    data.qpos[:] = model.qpos0 if qpos is None else qpos
    mujoco.mj_fwdPosition(model, data)
    M = np.zeros((model.nv, model.nv))
    mujoco.mj_fullM(model, data, M)
    return M


def normal_modes(model, flex, *, step=1e-6):
    """Undamped normal modes about ``qpos0``: ``K phi = omega^2 M phi``.

    Returns
    -------
    freq : ndarray, shape (nv,)
        Natural frequencies [Hz], ascending (rigid-body modes ~0; tiny negative eigenvalues
        from round-off are reported as 0).
    modes : ndarray, shape (nv, nv)
        Mass-normalized mode shapes as columns, in ``qvel`` coordinates.
    """
    K = stiffness_matrix(model, flex, step=step)
    M = mass_matrix(model)
    lam, modes = scipy.linalg.eigh(K, M)
    return np.sqrt(np.maximum(lam, 0.0)) / (2.0 * np.pi), modes

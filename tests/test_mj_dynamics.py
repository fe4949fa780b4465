"""The whole pipeline against independent references: Newton-Euler with scipy, energy, momentum, integrators."""

import mujoco
import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation

import mjflex
from tests.models import B_DEMO, K_DEMO, hinge_chain_spec, two_body_spec

W0 = {
    "A": (np.array([0.1, -0.2, 0.3]), np.array([1.0, -2.0, 0.5])),
    "B": (np.array([-0.2, 0.1, 0.0]), np.array([0.0, 1.5, 20.0])),
}


def _start(model, data):
    for i, name in enumerate("AB"):
        data.qvel[6 * i : 6 * i + 3], data.qvel[6 * i + 3 : 6 * i + 6] = W0[name]
    mujoco.mj_forward(model, data)


def _quat_mul(a, b):
    w1, x1, y1, z1 = a
    w2, x2, y2, z2 = b
    return np.array([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                     w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2])  # fmt: skip


def newton_euler_reference(model, method, B, t_eval):
    """Integrate the two free bodies with scipy, using only mjflex.wrench_on_b for the element.

    State per body: position, quaternion (w-first), world linear velocity, body angular velocity:
    the same coordinates as MuJoCo's free joint, so trajectories compare directly.
    """
    mass = model.body_mass[1:3]
    inertia = model.body_inertia[1:3]
    site_pos, site_quat = model.site_pos, model.site_quat
    K = mjflex.Flexures(model).records[0].K

    def rhs(_, y):
        p, q, v, w = [], [], [], []
        for i in range(2):
            s = y[13 * i : 13 * i + 13]
            p.append(s[:3]), q.append(s[3:7] / np.linalg.norm(s[3:7])), v.append(s[7:10]), w.append(s[10:13])
        R = [Rotation.from_quat(qi, scalar_first=True).as_matrix() for qi in q]
        R_site = [R[i] @ Rotation.from_quat(site_quat[i], scalar_first=True).as_matrix() for i in range(2)]
        p_site = [p[i] + R[i] @ site_pos[i] for i in range(2)]
        w_world = [R[i] @ w[i] for i in range(2)]
        v_site = [v[i] + np.cross(w_world[i], p_site[i] - p[i]) for i in range(2)]
        vel = {"w_WA": w_world[0], "v_WA": v_site[0], "w_WB": w_world[1], "v_WB": v_site[1]} if B is not None else {}
        W = mjflex.wrench_on_b(R_site[0], p_site[0], R_site[1], p_site[1], K, method=method, B=B, **vel)
        m_b, f_b = W[:3], W[3:]
        wrench = [(-m_b - np.cross(p_site[1] - p[0], f_b), -f_b), (m_b + np.cross(p_site[1] - p[1], f_b), f_b)]
        out = []
        for i in range(2):
            tau = R[i].T @ wrench[i][0]
            wdot = (tau - np.cross(w[i], inertia[i] * w[i])) / inertia[i]
            qdot = 0.5 * _quat_mul(q[i], np.r_[0.0, w[i]])
            out += [v[i], qdot, wrench[i][1] / mass[i], wdot]
        return np.concatenate(out)

    data = mujoco.MjData(model)
    _start(model, data)
    y0 = np.concatenate([np.r_[data.qpos[7 * i : 7 * i + 7], data.qvel[6 * i : 6 * i + 6]] for i in range(2)])
    sol = solve_ivp(rhs, (0.0, t_eval[-1]), y0, method="DOP853", rtol=1e-12, atol=1e-13, t_eval=t_eval)
    assert sol.success
    ys = sol.y.T
    qpos = np.concatenate([ys[:, 0:7], ys[:, 13:20]], axis=1)
    qvel = np.concatenate([ys[:, 7:13], ys[:, 20:26]], axis=1)
    return qpos, qvel


def simulate(model, steps, flex=None):
    data = mujoco.MjData(model)
    _start(model, data)
    qpos, qvel = [data.qpos.copy()], [data.qvel.copy()]
    with flex or mjflex.Flexures(model):
        for _ in range(steps):
            mujoco.mj_step(model, data)
            qpos.append(data.qpos.copy())
            qvel.append(data.qvel.copy())
    return np.array(qpos), np.array(qvel)


def _relative_error(got, ref):
    """Max deviation over the trajectory relative to how far the reference moves."""
    return np.abs(got - ref).max() / np.abs(ref - ref[0]).max()


@pytest.mark.parametrize("method", ["twist", "dualquat"])
@pytest.mark.parametrize("damped", [False, True])
def test_rk4_matches_independent_newton_euler(method, damped):
    B = B_DEMO if damped else None
    model = two_body_spec(method=method, B=B, timestep=1e-3).compile()
    steps = 1500
    qpos, qvel = simulate(model, steps)
    t = model.opt.timestep * np.arange(steps + 1)
    ref_qpos, ref_qvel = newton_euler_reference(model, method, B, t)
    assert _relative_error(qpos, ref_qpos) <= 1e-6
    assert _relative_error(qvel, ref_qvel) <= 1e-6
    # the motion really is large: the relative rotation of the element exceeds 1 rad
    data = mujoco.MjData(model)
    flex = mjflex.Flexures(model)
    angles = []
    for q in qpos[::50]:
        data.qpos[:] = q
        mujoco.mj_kinematics(model, data)
        angles.append(np.linalg.norm(flex.displacements(data)[0, :3]))
    assert max(angles) > 1.0


def _energy(model, data, flex):
    mujoco.mj_forward(model, data)
    return data.energy[1] + flex.potential_energy(data)


def test_energy_is_conserved_without_damping():
    model = two_body_spec(B=None, timestep=5e-4).compile()
    model.opt.enableflags |= mujoco.mjtEnableBit.mjENBL_ENERGY
    data = mujoco.MjData(model)
    _start(model, data)
    flex = mjflex.Flexures(model)
    E0 = _energy(model, data, flex)
    drift = 0.0
    with flex:
        for _ in range(10):
            for _ in range(1000):
                mujoco.mj_step(model, data)
            drift = max(drift, abs(_energy(model, data, flex) - E0) / E0)
    assert flex.potential_energy(data) > 0.05 * E0  # energy is really exchanged with the element
    assert drift <= 1e-6


@pytest.mark.parametrize("method", ["twist", "dualquat"])
def test_damping_never_adds_energy_and_matches_dissipation_power(method):
    model = two_body_spec(method=method, B=B_DEMO, timestep=5e-4).compile()
    model.opt.enableflags |= mujoco.mjtEnableBit.mjENBL_ENERGY
    data = mujoco.MjData(model)
    _start(model, data)
    flex = mjflex.Flexures(model)
    E, P = [_energy(model, data, flex)], [flex.dissipation_power(data)]
    with flex:
        for _ in range(2000):
            mujoco.mj_step(model, data)
            E.append(_energy(model, data, flex))
            P.append(flex.dissipation_power(data))
    E, P = np.array(E), np.array(P)
    assert np.all(np.diff(E) <= 1e-12 * E[0])
    assert np.all(P >= 0)
    h = model.opt.timestep
    lost = E[0] - E
    dissipated = np.concatenate([[0.0], np.cumsum(0.5 * h * (P[1:] + P[:-1]))])
    assert lost[-1] > 0.1 * E[0]
    assert np.abs(lost - dissipated).max() <= 1e-5 * lost[-1]


def test_momentum_of_isolated_pair_is_conserved():
    model = two_body_spec(B=B_DEMO, timestep=1e-3).compile()
    data = mujoco.MjData(model)
    _start(model, data)
    mass = model.body_mass[1:3]

    def linear_momentum():
        return mass[0] * data.qvel[0:3] + mass[1] * data.qvel[6:9]

    P0 = linear_momentum()
    flex = mjflex.Flexures(model)
    with flex:
        for _ in range(1000):
            mujoco.mj_step(model, data)
            # net force of the element on the pair is zero in every evaluation
            g = flex.generalized_forces(data)
            assert np.linalg.norm(g[0:3] + g[6:9]) <= 1e-12 * np.linalg.norm(g[6:9])
    assert np.linalg.norm(linear_momentum() - P0) <= 1e-12 * np.linalg.norm(P0)


# --------------------------------------------------------------------------- integrators


def _trajectory(integrator, timestep, T=0.4, method="twist"):
    model = two_body_spec(method=method, B=B_DEMO, integrator=integrator, timestep=timestep).compile()
    qpos, _ = simulate(model, round(T / timestep))
    return qpos[-1]


@pytest.mark.parametrize(
    "integrator, order",
    [("Euler", 1), ("implicit", 1), ("implicitfast", 1), ("discrete", 1), ("RK4", 4)],
)
def test_every_integrator_converges_at_its_order(integrator, order):
    """Halving the step divides the error by ~2**order: the flexure forces enter every integrator consistently."""
    reference = _trajectory("RK4", 1.25e-4)
    errors = [np.abs(_trajectory(integrator, h) - reference).max() for h in (4e-3, 2e-3, 1e-3)]
    ratios = [errors[0] / errors[1], errors[1] / errors[2]]
    assert all(0.6 * 2**order <= r <= 1.6 * 2**order for r in ratios), (errors, ratios)


def test_hinge_chain_conserves_energy_with_rk4():
    model = hinge_chain_spec(n=4, K=K_DEMO * 0.1, timestep=2e-4).compile()
    model.opt.enableflags |= mujoco.mjtEnableBit.mjENBL_ENERGY
    data = mujoco.MjData(model)
    rng = np.random.default_rng(1)
    data.qvel[:] = 2.0 * rng.normal(size=model.nv)
    flex = mjflex.Flexures(model)
    E0 = _energy(model, data, flex)
    with flex:
        for _ in range(5000):
            mujoco.mj_step(model, data)
    E1 = _energy(model, data, flex)
    assert flex.potential_energy(data) > 0
    assert abs(E1 - E0) <= 1e-6 * E0

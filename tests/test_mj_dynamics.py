"""The whole pipeline against independent references: Newton-Euler with scipy, energy, momentum, integrators."""

import mujoco
import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation

import mjflex
from tests.helpers import random_spd
from tests.models import B_DEMO, K_DEMO, hinge_chain_spec, two_body_spec
from tests.reference_element import quat_mul, reference_wrench, rotation_matrix

W0 = {
    "A": (np.array([0.1, -0.2, 0.3]), np.array([1.0, -2.0, 0.5])),
    "B": (np.array([-0.2, 0.1, 0.0]), np.array([0.0, 1.5, 20.0])),
}


def _start(model, data):
    for i, name in enumerate("AB"):
        data.qvel[6 * i : 6 * i + 3], data.qvel[6 * i + 3 : 6 * i + 6] = W0[name]
    mujoco.mj_forward(model, data)


def newton_euler_reference(model, method, K, B, t_eval):
    """Integrate the two free bodies with scipy, the element wrench from :mod:`tests.reference_element`.

    State per body: position, quaternion (w-first), world linear velocity, body angular velocity:
    the same coordinates as MuJoCo's free joint, so trajectories compare directly. Only masses,
    inertias and site placements are read from the MuJoCo model; nothing calls mjflex.
    """
    mass = model.body_mass[1:3]
    inertia = model.body_inertia[1:3]
    site_pos, site_quat = model.site_pos, model.site_quat
    B = np.zeros((6, 6)) if B is None else B

    def rhs(_, y):
        p, q, v, w = [], [], [], []
        for i in range(2):
            s = y[13 * i : 13 * i + 13]
            p.append(s[:3]), q.append(s[3:7] / np.linalg.norm(s[3:7])), v.append(s[7:10]), w.append(s[10:13])
        R = [rotation_matrix(qi) for qi in q]
        q_site = [quat_mul(q[i], site_quat[i]) for i in range(2)]
        p_site = [p[i] + R[i] @ site_pos[i] for i in range(2)]
        R_site = [rotation_matrix(qs) for qs in q_site]
        w_world = [R[i] @ w[i] for i in range(2)]
        v_site = [v[i] + np.cross(w_world[i], p_site[i] - p[i]) for i in range(2)]
        V = [np.r_[R_site[i].T @ w_world[i], R_site[i].T @ v_site[i]] for i in range(2)]  # site-frame twists
        W = reference_wrench(method, q_site[0], p_site[0], q_site[1], p_site[1], V[0], V[1], K, B)
        m_b, f_b = W[:3], W[3:]
        wrench = [(-m_b - np.cross(p_site[1] - p[0], f_b), -f_b), (m_b + np.cross(p_site[1] - p[1], f_b), f_b)]
        out = []
        for i in range(2):
            tau = R[i].T @ wrench[i][0]
            wdot = (tau - np.cross(w[i], inertia[i] * w[i])) / inertia[i]
            qdot = 0.5 * quat_mul(q[i], np.r_[0.0, w[i]])
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


@pytest.mark.parametrize("method", ["twist", "dualquat"])
def test_reference_wrench_agrees_with_mjflex(method):
    """The reference and mjflex agree on random states, rotations from 1e-9 to 3 rad, with damping."""
    rng = np.random.default_rng(0)
    errors = []
    for k in range(40):
        q_a = Rotation.random(random_state=rng).as_quat(scalar_first=True)
        angle = (1e-9, 1e-4, 0.3, 1.5, 3.0)[k % 5]
        q_b = quat_mul(q_a, Rotation.from_rotvec(angle * _unit(rng)).as_quat(scalar_first=True))
        p_a = rng.normal(size=3)
        p_b = p_a + 0.1 * rng.normal(size=3)
        K, B = random_spd(rng), 0.01 * random_spd(rng)
        V_a, V_b = rng.normal(size=6), rng.normal(size=6)
        R_a, R_b = rotation_matrix(q_a), rotation_matrix(q_b)
        got = mjflex.wrench_on_b(R_a, p_a, R_b, p_b, K, method=method, B=B, w_WA=R_a @ V_a[:3],
                                 v_WA=R_a @ V_a[3:], w_WB=R_b @ V_b[:3], v_WB=R_b @ V_b[3:])  # fmt: skip
        ref = reference_wrench(method, q_a, p_a, q_b, p_b, V_a, V_b, K, B)
        errors.append(np.linalg.norm(got - ref) / np.linalg.norm(ref))
    assert max(errors) <= 1e-13  # achieved 5e-15: round-off of two independent evaluations


def _unit(rng):
    v = rng.normal(size=3)
    return v / np.linalg.norm(v)


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
    ref_qpos, ref_qvel = newton_euler_reference(model, method, K_DEMO, B, t)
    # achieved 3e-10 (damped) to 9e-9 (undamped): RK4's truncation error at h = 1e-3, the reference being
    # converged to 1e-12; an inconsistent force (wrong frame, sign, offset) gives errors of 1e-3 and more
    assert _relative_error(qpos, ref_qpos) <= 5e-8
    assert _relative_error(qvel, ref_qvel) <= 5e-8
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
    assert drift <= 1e-9  # achieved 5e-11 (RK4, h = 5e-4, 1e4 steps)


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
            # exactly zero here (free joints take +-f as computed); the bound is round-off of other dof paths
            assert np.linalg.norm(g[0:3] + g[6:9]) <= 1e-12 * np.linalg.norm(g[6:9])
    assert np.linalg.norm(linear_momentum() - P0) <= 1e-13 * np.linalg.norm(P0)  # achieved 3e-15 over 1000 steps


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
    assert abs(E1 - E0) <= 2e-11 * E0  # achieved 1.4e-12 (RK4, h = 2e-4, 5000 steps)

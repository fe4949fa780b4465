"""Stability and accuracy at the extremes, against closed-form and independent references.

Relative rotations near 0 and through pi, stiffness ratios of 1e9 across one model, mass ratios
of 1e4 and the paper's 1000 rpm spin. (Steps past the stability limit: tests/test_study.py; the
paper's ARCADE run: ``python -m mjflex study models/arcade.xml``; 1e6-step energy drift per
integrator: ``python scripts/long_run.py``.)
"""

import mujoco
import numpy as np
import pytest
import scipy.linalg
from scipy.integrate import quad

import mjflex
from mjflex.analysis.linearize import normal_modes
from mjflex.app.study._metrics import linearized_frequencies
from tests.models import _block, _start_spec

METHODS = ("twist", "dualquat")


def _rotor(method, *, k=0.5, inertia=1e-3, timestep=1e-4):
    """A free rotor whose centre of mass is tied to the world by an element soft only about z."""
    spec = _start_spec("rotor", timestep=timestep)
    rotor = _block(spec.worldbody, "rotor", [0.3, 0.2, 0.1], 0.2, [2e-3, 3e-3, inertia])
    rotor.add_freejoint()
    mjflex.add_flexure(spec, "torsion", "world", "rotor", pos=[0.3, 0.2, 0.1], K=[50, 50, k, 1e5, 1e5, 1e5],
                       method=method)  # fmt: skip
    model = spec.compile()
    model.opt.enableflags |= mujoco.mjtEnableBit.mjENBL_ENERGY
    return model


def _spin_about_z(model, w0, steps):
    """Unwrapped rotation angle about z [rad] after every step, and the largest relative energy error."""
    flex = mjflex.Flexures(model)
    data = mujoco.MjData(model)
    data.qvel[5] = w0
    mujoco.mj_forward(model, data)
    E0 = data.energy[1] + flex.potential_energy(data)
    angle, previous, worst = np.zeros(steps + 1), 0.0, 0.0
    with flex:
        for i in range(1, steps + 1):
            mujoco.mj_step(model, data)
            q = data.qpos[3:7]
            now = 2.0 * np.arctan2(q[3], q[0])
            angle[i] = angle[i - 1] + (now - previous + np.pi) % (2 * np.pi) - np.pi
            previous = now
            if i % 20 == 0:
                mujoco.mj_forward(model, data)
                worst = max(worst, abs(data.energy[1] + flex.potential_energy(data) - E0) / E0)
    assert np.abs(data.qvel[:5]).max() < 1e-9 * w0  # the motion stays a pure rotation about z
    return angle, worst


@pytest.mark.parametrize("method", METHODS)
def test_tiny_rotations_keep_full_relative_precision(method):
    """1e-7 rad of torsion: the harmonic solution theta = (w0 / wn) sin(wn t) to 1e-6 relative.

    Both potentials are k theta^2 / 2 to O(theta^4) here. RK4 at 400 steps per period errs by
    ~(wn h)^4 wn t / 120 ~ 1e-10; the quaternion stores 1e-7 rad with ~1e-9 relative round-off, so
    a log map that lost digits near 0 (acos of the trace loses half of them) fails by orders.
    Measured: 1.6e-8 for both methods.
    """
    k, inertia = 0.5, 1e-3
    wn = np.sqrt(k / inertia)
    model = _rotor(method, k=k, inertia=inertia, timestep=2 * np.pi / wn / 400)
    amplitude = 1e-7
    angle, _ = _spin_about_z(model, amplitude * wn, 800)
    t = np.arange(801) * model.opt.timestep
    assert np.max(np.abs(angle - amplitude * np.sin(wn * t))) <= 1e-6 * amplitude


@pytest.mark.parametrize("method", METHODS)
def test_rotation_through_pi(method):
    """A rotor with enough energy to turn over: revolution time against the closed form, energy.

    Twist potential ``k theta^2 / 2`` on ``theta`` in (-pi, pi] (a cusp at pi: the torque
    reverses, the spring "snaps through"): revolution time ``2 sqrt(I/k) asin(pi sqrt(k/I) / w0)``.
    Dual quaternion: ``U = 2 k sin^2(theta/2) = k (1 - cos theta)``, smooth: time by quadrature.
    RK4 is 4th order for the smooth potential (agreement ~1e-13 measured) but drops to first order
    at each crossing of the twist's cusp (measured: 1e-4 period and 3e-4 energy error at 2000
    steps per revolution when a step starts on the cusp, 2e-8 when the cusp falls mid-step),
    hence the twist tolerances.
    """
    k, inertia = 0.5, 1e-3
    wn = np.sqrt(k / inertia)
    if method == "twist":
        w0 = 1.3 * np.pi * wn
        period = 2.0 * np.sqrt(inertia / k) * np.arcsin(np.pi * wn / w0)
        tol_period, tol_energy = 1e-3, 1e-3
    else:
        w0 = 2.6 * wn
        period = quad(lambda th: 1.0 / np.sqrt(w0**2 - 2.0 * wn**2 * (1.0 - np.cos(th))), 0.0, 2 * np.pi,
                      epsabs=1e-15, epsrel=1e-13)[0]  # fmt: skip
        tol_period, tol_energy = 1e-9, 1e-10
    model = _rotor(method, k=k, inertia=inertia, timestep=period / 2000)
    angle, energy_error = _spin_about_z(model, w0, 4200)
    t = np.arange(len(angle)) * model.opt.timestep
    crossings = np.interp([2 * np.pi, 4 * np.pi], angle, t)  # the angle increases monotonically
    assert angle[-1] > 4 * np.pi  # two full turns, through pi four times
    np.testing.assert_allclose(crossings, [period, 2 * period], rtol=tol_period)
    assert energy_error <= tol_energy


def _slide_chain(k, x0=1.0, gap=0.1, mass=1.0):
    """Blocks on slide joints along x at ``x0 + i gap`` tied world-b0-b1-... by elements of stiffness ``k[i]``."""
    spec = _start_spec("chain", timestep=1e-6)
    for i in range(len(k)):
        block = _block(spec.worldbody, f"b{i}", [x0 + i * gap, 0, 0], mass, [1e-3, 1e-3, 1e-3])
        block.add_joint(type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[1, 0, 0])
    for i, ki in enumerate(k):
        a = "world" if i == 0 else f"b{i - 1}"
        mjflex.add_flexure(spec, f"e{i}", a, f"b{i}", pos=[x0 + (i - 0.5) * gap, 0, 0], K=[ki] * 6)
    model = spec.compile()
    K = np.diag(np.r_[k[:-1] + k[1:], k[-1]]) - np.diag(k[1:], 1) - np.diag(k[1:], -1)
    return model, K, mass * np.eye(len(k))


def test_stiffness_ratio_1e9_in_one_model():
    """Elements from 1 to 1e9 N/m in one chain: frequencies and the soft mode's motion.

    Reference: ``eigh`` of the assembled spring chain (exact for pure translation, both methods).
    Frequencies: the study's linearization (FD of qacc) and normal_modes agree to 1e-6 (measured
    1.2e-7 and 4e-8: FD round-off amplified by the conditioning 1e9 of the soft eigenvalue).
    Motion: started in the soft mode alone, the blocks must follow ``phi sin(w t)``: the stiff
    element then carries forces from sub-nanometre stretches between bodies 1 m from the origin,
    where world-coordinate round-off (1e-16 m) could give relative force errors up to ~1e-7. Measured
    1.4e-10 of the amplitude after 20000 steps; the bound 1e-8 leaves room for other platforms.
    """
    k = np.array([1.0, 1e9, 3e4])
    model, K, M = _slide_chain(k)
    lam, phi = scipy.linalg.eigh(K, M)
    exact = np.sqrt(lam) / (2 * np.pi)
    flex = mjflex.Flexures(model)
    np.testing.assert_allclose(normal_modes(model, flex)[0], exact, rtol=1e-6)
    np.testing.assert_allclose(linearized_frequencies(model, flex, model.qpos0)[0], exact, rtol=1e-6)
    w_soft, w_max = np.sqrt(lam[0]), np.sqrt(lam[-1])
    model.opt.timestep = 0.5 / w_max  # RK4 stable below 2.8 / w_max
    data = mujoco.MjData(model)
    amplitude = 1e-3  # m
    data.qvel[:] = amplitude * w_soft * phi[:, 0] / np.abs(phi[:, 0]).max()
    steps = 20000
    with flex:
        for _ in range(steps):
            mujoco.mj_step(model, data)
    expected = model.qpos0 + amplitude * phi[:, 0] / np.abs(phi[:, 0]).max() * np.sin(w_soft * data.time)
    assert np.abs(data.qpos - expected).max() <= 1e-8 * amplitude


@pytest.mark.parametrize("method", METHODS)
def test_mass_ratio_1e4(method):
    """Bodies of 10 kg and 1 g (inertias 1e4 apart): relative oscillation ``v / w sin(w t)``.

    ``w = sqrt(k / mu)`` with the reduced mass ``mu``; pure translation, so both methods are
    exactly linear. RK4 at 400 steps per period over two periods: truncation ~(w h)^4 w t / 120 ~ 7e-9
    relative.
    """
    m_a, m_b, k = 10.0, 1e-3, 1e3
    spec = _start_spec("dumbbell")
    for name, pos, mass, inertia in (("A", -0.05, m_a, 0.1), ("B", 0.05, m_b, 1e-5)):
        _block(spec.worldbody, name, [pos, 0, 0], mass, [inertia] * 3).add_freejoint()
    mjflex.add_flexure(spec, "link", "A", "B", pos=[0, 0, 0], K=[1.0, 1.0, 1.0, k, 2 * k, 3 * k], method=method)
    model = spec.compile()
    mu = m_a * m_b / (m_a + m_b)
    w = np.sqrt(k / mu)
    flex = mjflex.Flexures(model)
    freq = linearized_frequencies(model, flex, model.qpos0)[0]
    assert np.min(np.abs(freq - w / (2 * np.pi))) <= 1e-8 * w
    model.opt.timestep = 2 * np.pi / w / 400
    data = mujoco.MjData(model)
    v = 0.01
    data.qvel[0], data.qvel[6] = -m_b / (m_a + m_b) * v, m_a / (m_a + m_b) * v  # zero momentum
    relative = []
    with flex:
        for _ in range(800):
            mujoco.mj_step(model, data)
            relative.append(data.qpos[7] - data.qpos[0] - 0.1)
    t = model.opt.timestep * np.arange(1, 801)
    assert np.max(np.abs(np.array(relative) - v / w * np.sin(w * t))) <= 1e-7 * v / w


@pytest.mark.parametrize("method", METHODS)
def test_1000_rpm_spin_is_a_relative_equilibrium(method):
    """Two bodies spinning at 1000 rpm (the paper's run) about their common centre of mass.

    Exact steady state: the element stretched by ``delta = m W^2 d / (k_x - m W^2 / 2)`` along the
    line of centres, both bodies turning at ``W``. Over one revolution the element's relative pose
    must stay ``(0, delta e_x)``, and with damping on the energy must not change: a damping force
    that were not frame-indifferent would brake the spin (relative twist rate 0 here). Measured:
    stretch within 3.5e-8 of delta, relative rotation 6e-16 rad, energy 1e-13 relative (RK4 at
    6000 steps per revolution); the bounds leave 30x or more.
    """
    m, d, k_x, spin = 0.5, 0.05, 1e6, 1000 * 2 * np.pi / 60
    delta = m * spin**2 * d / (k_x - m * spin**2 / 2)
    spec = _start_spec("spinner", timestep=1e-5)
    for name, x in (("A", -d), ("B", d)):
        _block(spec.worldbody, name, [x, 0, 0], m, [1e-4, 2e-4, 3e-4]).add_freejoint()
    K = np.array([5.0, 6.0, 7.0, k_x, 2 * k_x, 3 * k_x])
    mjflex.add_flexure(spec, "link", "A", "B", pos=[0, 0, 0], K=K, B=1e-3 * K, method=method)
    model = spec.compile()
    model.opt.enableflags |= mujoco.mjtEnableBit.mjENBL_ENERGY
    flex = mjflex.Flexures(model)
    data = mujoco.MjData(model)
    r = d + delta / 2
    data.qpos[0], data.qpos[7] = -r, r
    data.qvel[:6] = [0, -r * spin, 0, 0, 0, spin]
    data.qvel[6:] = [0, r * spin, 0, 0, 0, spin]
    mujoco.mj_forward(model, data)
    E0 = data.energy[1] + flex.potential_energy(data)
    worst = np.zeros(2)
    with flex:
        for _ in range(round(2 * np.pi / spin / model.opt.timestep)):
            mujoco.mj_step(model, data)
            twist = flex.displacements(data)[0]
            worst = np.maximum(worst, [np.abs(twist[3:] - [delta, 0, 0]).max() / delta, np.abs(twist[:3]).max()])
    mujoco.mj_forward(model, data)
    assert worst[0] <= 1e-6 and worst[1] <= 1e-9
    assert abs(data.energy[1] + flex.potential_energy(data) - E0) <= 1e-9 * E0

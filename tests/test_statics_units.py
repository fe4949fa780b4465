"""The small helpers of issue 24 item 5: an element's static deflection under a wrench at its frame, and units.

The exact deflection is checked against an independent equilibrium: the minimum of the core's energy minus the
work of a dead force (Newton's method on its gradient, taken by central differences on the energy alone, never the
wrench code), for both element methods and a deflection of 0.3 rad; and against MuJoCo itself: a body held by the
element and loaded through xfrc_applied at its centre of mass (the wrench moved to frame b first) comes to rest
where the helper says.
"""

import math

import mujoco
import numpy as np
import pytest
import scipy.spatial.transform

import mjflex
from mjflex import units

#: A leaf-spring-like element: bending soft about x, translation coupled to it (K about a point 20 mm off).
K_LEAF = mjflex.stiffness_in_frame(np.diag([2.0, 40.0, 30.0, 5e4, 800.0, 6e4]), np.eye(3), [0.0, 0.0, 0.02])


def _energy_minimum(K, force, method):
    """Frame b's twist where U(twist) - force . p(twist) is stationary: the root of its gradient (fourth-order
    central differences of the energy, a step per coordinate scaled to its size) by Newton's method from the linear
    answer (scipy's hybr stalled at a residual of 6e-6 on some CPUs: its own finite-difference Jacobian)."""

    def energy(xi):
        R, p = mjflex.transform_from_twist(xi)
        return mjflex.potential(np.eye(3), np.zeros(3), R, p, K, method=method) - force @ p

    start = np.linalg.solve(K, np.concatenate([np.zeros(3), force]))
    h = 1e-3 * np.maximum(np.abs(start), 1e-3 * np.abs(start).max())

    def gradient(xi):
        g = np.empty(6)
        for i, e in enumerate(np.eye(6) * h[:, None]):
            g[i] = (-energy(xi + 2 * e) + 8 * energy(xi + e) - 8 * energy(xi - e) + energy(xi - 2 * e)) / (12 * h[i])
        return g

    x = start
    for _ in range(4):  # Newton on the central differences of that gradient: 3 steps reach its round-off (~1e-9)
        H = np.column_stack(
            [(gradient(x + e) - gradient(x - e)) / (2 * h[i]) for i, e in enumerate(np.eye(6) * h[:, None])]
        )
        x = x - np.linalg.solve((H + H.T) / 2, gradient(x))
    assert np.abs(gradient(x)).max() < 1e-8 * np.abs(force).max()  # the balance [N m, N], to round-off
    return x


@pytest.mark.parametrize("method", ["twist", "dualquat"])
def test_the_exact_deflection_is_the_energy_minimum_at_large_deflection(method):
    force = np.array([0.0, 30.0, 0.0])  # 30 N along y: 0.25 rad about x through the coupling
    d = mjflex.static_deflection(K_LEAF, np.concatenate([np.zeros(3), force]), method=method)
    reference = _energy_minimum(K_LEAF, force, method)
    R, p = mjflex.transform_from_twist(reference)
    assert abs(d.coordinates[0]) > 0.2  # a large deflection
    np.testing.assert_allclose(d.p, p, rtol=1e-6, atol=1e-8 * np.abs(p).max())  # the reference root: ~1e-9
    np.testing.assert_allclose(d.R, R, atol=1e-7)
    np.testing.assert_allclose(d.twist, mjflex.twist_from_transform(d.R, d.p), atol=1e-12)
    rotation = scipy.spatial.transform.Rotation.from_matrix(d.R).as_rotvec()  # the stops' coordinates
    np.testing.assert_allclose(d.coordinates, [*rotation, *d.p], atol=1e-12)
    assert d.residual < 1e-9 * np.abs(force).max()
    linear = mjflex.static_deflection(K_LEAF, np.concatenate([np.zeros(3), force]), method=method, exact=False)
    assert np.abs(linear.coordinates - d.coordinates).max() > 0.01  # the linear answer is visibly off here
    small = mjflex.static_deflection(K_LEAF, np.concatenate([np.zeros(3), 1e-4 * force]), method=method)
    linear_small = np.linalg.solve(K_LEAF, np.concatenate([np.zeros(3), 1e-4 * force]))
    # and agrees when small, to second order (the rotation times the translation)
    np.testing.assert_allclose(small.coordinates, linear_small, rtol=1e-3, atol=1e-5 * np.abs(linear_small).max())


def test_a_follower_moment_about_one_axis_is_the_dead_one_and_differs_with_a_force():
    K = np.diag([2.0, 3.0, 4.0, 1e3, 1e3, 1e3])
    moment = [0.0, 0.0, 1.2]
    dead, follower = (mjflex.static_deflection(K, [*moment, 0, 0, 0], follower=f) for f in (False, True))
    np.testing.assert_allclose(dead.coordinates, [0, 0, 0.3, 0, 0, 0], atol=1e-12)
    np.testing.assert_allclose(follower.coordinates, dead.coordinates, atol=1e-12)
    wrench = [*moment, 20.0, 0.0, 0.0]  # a force along x turns with b in the follower case
    dead, follower = (mjflex.static_deflection(K, wrench, follower=f) for f in (False, True))
    assert np.abs(dead.p - follower.p).max() > 1e-3


def test_a_load_at_the_centre_of_mass_is_a_different_wrench_at_the_element_frame():
    """A 0.5 kg block held 80 mm below a leaf spring, loaded through xfrc_applied at its centre of mass: MuJoCo's
    equilibrium is static_deflection of the wrench moved to frame b (not of the same numbers at frame b)."""
    spec = mujoco.MjSpec.from_string(
        '<mujoco><option gravity="0 0 0"/><worldbody><body name="block" pos="0 0 -0.08"><freejoint/>'
        '<geom type="box" size="0.02 0.02 0.02" mass="0.5"/></body></worldbody></mujoco>'
    )
    mjflex.add_flexure(spec, "leaf", "world", "block", pos=[0, 0, 0], K=K_LEAF)
    model = spec.compile()
    flex = mjflex.Flexures(model)
    xfrc = np.zeros((model.nbody, 6))
    xfrc[1] = [3.0, 0.0, -2.0, 0.0, 0.05, 0.0]  # [force; torque] at the centre of mass, world axes
    qpos = mjflex.static_equilibrium(model, flex, xfrc_applied=xfrc)
    data = mujoco.MjData(model)
    data.qpos[:] = qpos
    mujoco.mj_kinematics(model, data)
    twist = flex.displacements(data)[0]
    # moved to frame b: b's origin is where the block's centre of mass was at rest, 80 mm above it; dead load
    p_com, p_b = data.xipos[1], data.site_xpos[flex.site_ids[0, 1]]
    moment = xfrc[1, 3:] + np.cross(p_com - p_b, xfrc[1, :3])
    d = mjflex.static_deflection(K_LEAF, [*moment, *xfrc[1, :3]])
    np.testing.assert_allclose(twist, d.twist, rtol=1e-6, atol=1e-9 * np.abs(d.twist).max())
    naive = mjflex.static_deflection(K_LEAF, [*xfrc[1, 3:], *xfrc[1, :3]])
    assert np.abs(naive.twist - twist).max() > 0.1 * np.abs(twist).max()  # the mistake of the issue, measured


def test_static_deflection_refuses_a_singular_stiffness_by_name():
    with pytest.raises(ValueError, match="K is singular"):
        mjflex.static_deflection([1, 1, 0, 1e3, 1e3, 1e3], [0, 0, 1, 0, 0, 0])


def test_units_are_the_si_values_of_the_literatures_units():
    assert units.N_m_per_deg == pytest.approx(math.degrees(1.0), rel=1e-15)  # 1 N m/deg = 57.3 N m/rad
    assert units.deg == math.radians(1.0) and units.mm == 1e-3 and units.N_per_mm == 1e3 and units.N_per_um == 1e6
    assert units.N_mm_per_deg == pytest.approx(1e-3 * math.degrees(1.0), rel=1e-15)
    assert units.N_m_s_per_deg == units.N_m_per_deg and units.N_s_per_mm == units.N_per_mm  # damping: the same factors
    K = 2.5 * units.N_m_per_deg
    assert K / units.N_m_per_deg == pytest.approx(2.5, rel=1e-15)
    assert 10.7 * units.deg == pytest.approx(0.18675, rel=1e-4)

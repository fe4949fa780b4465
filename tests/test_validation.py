"""Every argument check of the core raises a ValueError that names the argument and the fix."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import mjflex
from tests.helpers import hat, random_rotation, random_spd

I3, Z3 = np.eye(3), np.zeros(3)
K6 = np.diag([1.0, 1.0, 1.0, 1e3, 1e3, 1e3])


def _wrench(**kw):
    args = {"R_WA": I3, "p_WA": Z3, "R_WB": I3, "p_WB": Z3, "K": K6}
    args.update(kw)
    return mjflex.wrench_on_b(
        args.pop("R_WA"), args.pop("p_WA"), args.pop("R_WB"), args.pop("p_WB"), args.pop("K"), **args
    )


def test_wrong_shape_of_K():
    with pytest.raises(ValueError, match=r"K must have shape \(\.\.\., 6, 6\); got shape \(5, 5\)"):
        _wrench(K=np.eye(5))


def test_non_symmetric_K_names_entries_and_fix():
    K = K6.copy()
    K[0, 4] = 3.0
    with pytest.raises(ValueError, match=r"K is not symmetric: K\[0, 4\] = 3 but K\[4, 0\] = 0.*\(M \+ M\.T\) / 2"):
        _wrench(K=K)


def test_asymmetry_tolerance_is_relative_to_the_entries_scale():
    K = K6.copy() * 1e9  # scaled units: round-off asymmetry must still pass
    K[0, 4] = K[4, 0] = 1e9
    K[0, 4] *= 1 + 1e-12
    _wrench(K=K)
    K[0, 4] *= 1 + 1e-6
    with pytest.raises(ValueError, match="not symmetric"):
        _wrench(K=K)


def test_indefinite_K_reports_eigenvalue_and_fix():
    K = K6.copy()
    K[2, 2] = -0.5
    with pytest.raises(
        ValueError,
        match=r"K is not positive semi-definite: its smallest eigenvalue is -0\.5.*clip negative eigenvalues",
    ):
        _wrench(K=K)


def test_indefinite_coupling_is_caught():
    K = K6.copy()
    K[0, 3] = K[3, 0] = 40.0  # |K_c| > sqrt(K_o K_t) = 31.6
    with pytest.raises(ValueError, match=r"not positive semi-definite.*coupling block K_c"):
        _wrench(K=K)


def test_batched_K_error_names_the_element():
    K = np.stack([K6] * 4)
    K[2, 1, 1] = -1.0
    with pytest.raises(ValueError, match=r"K\[2\] is not positive semi-definite"):
        mjflex.potential(I3, Z3, I3, Z3, K)


def test_singular_psd_K_is_accepted():
    K = np.zeros((6, 6))
    K[2, 2] = 1.0
    R = random_rotation(np.random.default_rng(0))
    tau_z = Rotation.from_matrix(R).as_rotvec()[2]  # the twist of a pure rotation is its rotation vector
    assert mjflex.potential(I3, Z3, R, Z3, K) == pytest.approx(0.5 * tau_z**2, rel=1e-13)


def test_damping_with_indefinite_symmetric_part():
    B = np.diag([1.0, 1, 1, 1, 1, -1e-3])
    with pytest.raises(ValueError, match=r"B is not positive semi-definite.*generates energy"):
        _wrench(B=B, w_WB=[1, 0, 0])


def test_non_symmetric_B():
    B = np.eye(6)
    B[1, 3] = 0.5
    with pytest.raises(ValueError, match=r"B is not symmetric: B\[1, 3\]"):
        _wrench(B=B)


def test_non_finite_K():
    K = K6.copy()
    K[1, 1] = np.nan
    with pytest.raises(ValueError, match=r"K contains a non-finite value \(nan at index \[1, 1\]\)"):
        _wrench(K=K)


def test_non_orthonormal_rotation():
    R = I3.copy()
    R[0, 0] = 1.001
    with pytest.raises(
        ValueError, match=r"R_WB is not a rotation matrix: max \|R\^T R - I\| = 0\.002.*Rotation\.from_matrix"
    ):
        _wrench(R_WB=R)


def test_reflection_is_not_a_rotation():
    with pytest.raises(ValueError, match=r"R_WA has determinant -1.*reflection"):
        _wrench(R_WA=np.diag([1.0, 1.0, -1.0]))


def test_batched_rotation_error_names_index():
    R = np.stack([I3] * 3)
    R[1] *= 2
    with pytest.raises(ValueError, match=r"R_WA\[1\] is not a rotation matrix"):
        _wrench(R_WA=R)


def test_nan_state():
    with pytest.raises(ValueError, match=r"p_WB contains a non-finite value \(nan.*simulation diverged"):
        _wrench(p_WB=[0.0, np.nan, 0.0])
    with pytest.raises(ValueError, match=r"w_WB contains a non-finite value"):
        _wrench(B=np.eye(6), w_WB=[np.inf, 0, 0])


def test_wrong_position_shape():
    with pytest.raises(ValueError, match=r"p_WA must have shape \(\.\.\., 3\); got shape \(2,\)"):
        _wrench(p_WA=[0.0, 0.0])


def test_unknown_method():
    with pytest.raises(ValueError, match=r"method must be 'twist' or 'dualquat'; got 'quaternion'"):
        _wrench(method="quaternion")


def test_velocities_without_damping():
    with pytest.raises(ValueError, match=r"velocities \['w_WB'\] were given but B is None"):
        _wrench(w_WB=[1.0, 0, 0])


def test_dissipation_needs_B():
    with pytest.raises(ValueError, match="B is required"):
        mjflex.dissipation_power(I3, Z3, I3, Z3, None)


def test_planar_validation():
    with pytest.raises(ValueError, match=r"K must have shape \(\.\.\., 3, 3\); got shape \(6, 6\)"):
        mjflex.planar_wrench_on_b(0.0, [0, 0], 0.1, [0, 0], np.eye(6))
    with pytest.raises(ValueError, match=r"theta_WB contains a non-finite value"):
        mjflex.planar_potential(0.0, [0, 0], np.nan, [0, 0], np.eye(3))
    with pytest.raises(ValueError, match=r"p_WA must have shape \(\.\.\., 2\)"):
        mjflex.planar_potential(0.0, [0, 0, 0], 0.0, [0, 0], np.eye(3))


def test_dual_quaternion_must_be_unit():
    q = np.array([1.0, 0, 0, 0, 0, 0.1, 0, 0])
    mjflex.transform_from_dual_quaternion(q)
    with pytest.raises(ValueError, match=r"q is not a unit dual quaternion.*dual_quaternion_from_transform"):
        mjflex.transform_from_dual_quaternion(q * 2)
    with pytest.raises(ValueError, match=r"q is not a unit dual quaternion"):
        mjflex.transform_from_dual_quaternion(np.array([1.0, 0, 0, 0, 0.1, 0, 0, 0]))


def test_check_false_skips_validation():
    K = np.diag([1.0, 1.0, 1.0, 1e3, 2e3, 3e3])
    K[0, 4] = 3.0  # not symmetric: accepted unchecked (caller's responsibility)
    t = np.array([2e-4, -1e-3, 5e-4])
    W = mjflex.wrench_on_b(I3, Z3, I3, t, K, check=False)
    # K used as given: at zero rotation the twist is [0; t] and Gamma = [[I, -t^/2], [0, I]] (eqs 43, 46, 49)
    Kxi = K @ np.r_[Z3, t]
    assert np.abs(W + np.r_[Kxi[:3] - 0.5 * hat(t) @ Kxi[3:], Kxi[3:]]).max() <= 1e-14 * np.abs(W).max()
    symmetrized = mjflex.wrench_on_b(I3, Z3, I3, t, 0.5 * (K + K.T), check=False)
    assert abs(W[0] - symmetrized[0]) > 0.1 * abs(W[0])


def test_stiffness_utilities_validate():
    with pytest.raises(ValueError, match=r"K_A is not symmetric"):
        K = random_spd(np.random.default_rng(0))
        K[0, 1] += 1.0
        mjflex.stiffness_in_frame(K, I3, Z3)
    with pytest.raises(ValueError, match=r"R_AB is not a rotation matrix"):
        mjflex.adjoint_from_transform(2 * I3, Z3)

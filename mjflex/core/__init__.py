"""Screw-theory core: finite twists, dual quaternions and visco-elastic element wrenches.

Pure numerical code (numpy, with numba-compiled kernels); it never imports mujoco.
See the :mod:`mjflex` package docstring for the conventions.
"""

from . import units  # noqa: F401  (mjflex.units: conversions to SI)
from .elements import (
    dissipation_power,
    planar_dissipation_power,
    planar_potential,
    planar_wrench_on_b,
    potential,
    wrench_on_b,
)
from .identification import FitWarning, PotentialFit, fit_potential, potential_in_frame
from .polynomial import PolynomialTerms, polynomial_basis, workless_generalized_forces
from .statics import Deflection, static_deflection
from .stiffness import adjoint_from_transform, centre_of_stiffness, stiffness_in_frame
from .stops import (
    derived_stop_stiffness,
    planar_stop_potential,
    planar_stop_wrench_on_b,
    stop_coordinates,
    stop_dissipation_power,
    stop_potential,
    stop_wrench_on_b,
)
from .transforms import (
    dual_quaternion_from_transform,
    transform_from_dual_quaternion,
    transform_from_twist,
    twist_from_transform,
)

__all__ = [
    "Deflection",
    "FitWarning",
    "PolynomialTerms",
    "PotentialFit",
    "adjoint_from_transform",
    "centre_of_stiffness",
    "derived_stop_stiffness",
    "dissipation_power",
    "dual_quaternion_from_transform",
    "fit_potential",
    "planar_dissipation_power",
    "planar_potential",
    "planar_stop_potential",
    "planar_stop_wrench_on_b",
    "planar_wrench_on_b",
    "polynomial_basis",
    "potential",
    "potential_in_frame",
    "static_deflection",
    "stiffness_in_frame",
    "stop_coordinates",
    "stop_dissipation_power",
    "stop_potential",
    "stop_wrench_on_b",
    "transform_from_dual_quaternion",
    "transform_from_twist",
    "twist_from_transform",
    "workless_generalized_forces",
    "wrench_on_b",
]

"""Screw-theory core: finite twists, dual quaternions and visco-elastic element wrenches.

Pure numerical code (numpy, with numba-compiled kernels); it never imports mujoco.
See the :mod:`mjflex` package docstring for the conventions.
"""

from .elements import (
    dissipation_power,
    planar_dissipation_power,
    planar_potential,
    planar_wrench_on_b,
    potential,
    wrench_on_b,
)
from .stiffness import adjoint_from_transform, centre_of_stiffness, stiffness_in_frame
from .transforms import (
    dual_quaternion_from_transform,
    transform_from_dual_quaternion,
    transform_from_twist,
    twist_from_transform,
)

__all__ = [
    "adjoint_from_transform",
    "centre_of_stiffness",
    "dissipation_power",
    "dual_quaternion_from_transform",
    "planar_dissipation_power",
    "planar_potential",
    "planar_wrench_on_b",
    "potential",
    "stiffness_in_frame",
    "transform_from_dual_quaternion",
    "transform_from_twist",
    "twist_from_transform",
    "wrench_on_b",
]

"""Stiffness from geometry: notch hinges and leaf springs (numpy/scipy; no mujoco)."""

from .hinges import (
    bending_strain_per_radian,
    leaf_spring_stiffness,
    notch_hinge_stiffness,
    notch_hinge_thickness,
    rectangle_torsion_constant,
)

__all__ = [
    "bending_strain_per_radian",
    "leaf_spring_stiffness",
    "notch_hinge_stiffness",
    "notch_hinge_thickness",
    "rectangle_torsion_constant",
]

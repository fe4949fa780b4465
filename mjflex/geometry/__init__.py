"""Stiffness from geometry: notch hinges and leaf springs, and a large-deflection leaf model (no mujoco)."""

from .hinges import (
    bending_strain_per_radian,
    leaf_spring_stiffness,
    notch_hinge_stiffness,
    notch_hinge_thickness,
    rectangle_torsion_constant,
)
from .rod import LeafChain, rod_segment_stiffness

__all__ = [
    "LeafChain",
    "bending_strain_per_radian",
    "leaf_spring_stiffness",
    "notch_hinge_stiffness",
    "notch_hinge_thickness",
    "rectangle_torsion_constant",
    "rod_segment_stiffness",
]

"""Stiffness from geometry: notch hinges and leaf springs, and a large-deflection leaf model (no mujoco).

``notch_hinge_stiffness`` and ``leaf_spring_stiffness`` return the 6x6 at the centre of
stiffness from stored 3-D finite-element tables (:mod:`.tables`, default), from finite
elements of the given geometry (:mod:`.fe`, scikit-fem, ``method="fe"``) or from the beam
formulas (``method="beam"``). Error bands per entry: :func:`.tables.error_bands`.
"""

from .hinges import (
    bending_strain_per_radian,
    leaf_spring_stiffness,
    notch_hinge_stiffness,
    notch_hinge_thickness,
)
from .rod import LeafChain, rod_segment_stiffness
from .sections import rectangle_torsion_constant

__all__ = [
    "LeafChain",
    "bending_strain_per_radian",
    "leaf_spring_stiffness",
    "notch_hinge_stiffness",
    "notch_hinge_thickness",
    "rectangle_torsion_constant",
    "rod_segment_stiffness",
]

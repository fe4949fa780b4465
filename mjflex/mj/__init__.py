"""MuJoCo layer: flexure elements in MJCF (text records or engine-plugin instances), model building with MjSpec,
the passive-force provider, divergence reports (:mod:`mjflex.mj.divergence`), and the cheaper or MuJoCo-native
variants of a model (:func:`reduce`, :mod:`mjflex.mj.native`)."""

from .build import FlexureHandle, add_flexure, add_flexure_in_body_frame, reference_body_poses
from .native import bushing_variant, pseudo_rigid_body_variant, weld_variant
from .provider import Flexures, ModelError
from .reduce import reduce
from .schema import FlexureRecord
from .variant import Variant, VariantNotApplicableError

__all__ = [
    "FlexureHandle",
    "FlexureRecord",
    "Flexures",
    "ModelError",
    "Variant",
    "VariantNotApplicableError",
    "add_flexure",
    "add_flexure_in_body_frame",
    "bushing_variant",
    "pseudo_rigid_body_variant",
    "reduce",
    "reference_body_poses",
    "weld_variant",
]

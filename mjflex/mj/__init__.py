"""MuJoCo layer: flexure elements in MJCF (text records or engine-plugin instances), model building with MjSpec
(compliant parts in existing models, welded or on joints: :func:`make_compliant`, :mod:`mjflex.mj.replace`), the
passive-force provider, divergence reports (:mod:`mjflex.mj.divergence`), linearization at an operating pose
(:func:`static_equilibrium`, :func:`normal_modes`, damping from ratios, :func:`step_advice`), and the cheaper or
MuJoCo-native variants of a model (:func:`reduce`, :mod:`mjflex.mj.native`)."""

from .advice import StepAdvice, step_advice
from .build import FlexureHandle, add_flexure, add_flexure_in_body_frame, reference_body_poses, remove_flexure
from .compliance import Compliance, make_compliant, make_rigid
from .convert import attach, convert_model, copy_spec, edit_elements
from .damping import damping_from_ratios
from .divergence import DivergenceWarning, divergence_warnings
from .file_convert import ConversionError, convert_file
from .linearize import normal_modes, static_equilibrium
from .native import bushing_variant, pseudo_rigid_body_variant, weld_variant
from .notices import LikelyMistakeWarning
from .provider import Flexures, ModelError
from .reduce import reduce
from .replace import Replacement
from .schema import FlexureRecord
from .stops import Stops
from .variant import Variant, VariantNotApplicableError

__all__ = [
    "Compliance",
    "ConversionError",
    "DivergenceWarning",
    "FlexureHandle",
    "FlexureRecord",
    "Flexures",
    "LikelyMistakeWarning",
    "ModelError",
    "Replacement",
    "StepAdvice",
    "Stops",
    "Variant",
    "VariantNotApplicableError",
    "add_flexure",
    "add_flexure_in_body_frame",
    "attach",
    "bushing_variant",
    "convert_file",
    "convert_model",
    "copy_spec",
    "damping_from_ratios",
    "divergence_warnings",
    "edit_elements",
    "make_compliant",
    "make_rigid",
    "normal_modes",
    "pseudo_rigid_body_variant",
    "reduce",
    "reference_body_poses",
    "remove_flexure",
    "static_equilibrium",
    "step_advice",
    "weld_variant",
]

"""MuJoCo layer: flexure elements in MJCF, model building with MjSpec, the passive-force provider."""

from .build import FlexureHandle, add_flexure, add_flexure_in_body_frame, reference_body_poses
from .provider import Flexures, ModelError
from .schema import FlexureRecord

__all__ = [
    "FlexureHandle",
    "FlexureRecord",
    "Flexures",
    "ModelError",
    "add_flexure",
    "add_flexure_in_body_frame",
    "reference_body_poses",
]

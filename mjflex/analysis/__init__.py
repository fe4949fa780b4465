"""A compiled model linearized at an operating pose: statics, modes, damping and the time step.

:mod:`.linearize` (the one central-difference routine, :func:`normal_modes`, stiffness and mass
matrices, constraints), :mod:`mjflex.analysis.statics` (:func:`static_equilibrium`), :mod:`.damping`
(damping matrices from modal ratios), :mod:`.advice` (the time step that a run can take: MuJoCo's
step, linearized) and :mod:`.directions` (each element's principal directions and their share of
the modes). Imports :mod:`mjflex.core`, :mod:`mjflex.mjcf` and :mod:`mjflex.runtime`.
"""

from .advice import StepAdvice, step_advice
from .damping import damping_from_ratios
from .linearize import normal_modes
from .statics import static_equilibrium

__all__ = ["StepAdvice", "damping_from_ratios", "normal_modes", "static_equilibrium", "step_advice"]

"""A cheaper or different model of the same scene, and how its states map to the original's.

:class:`Variant` is what every model transformation of mjflex returns (fidelity reduction in
:mod:`mjflex.mj.reduce`, MuJoCo-native alternatives such as welds or joint springs) and what
the speed/accuracy study compares against the full model. The study only relies on the fields
below, so any user-built variant can be compared too.
"""

from collections.abc import Callable
from dataclasses import dataclass, field

import mujoco
import numpy as np


@dataclass
class Variant:
    """A model of the same scene as a source model, with the maps that relate the two.

    Attributes
    ----------
    name : str
        Short label for tables and plots, e.g. ``"weld"`` or ``"reduced(2000 Hz)"``.
    model : mujoco.MjModel
        The compiled variant. It may hold mjflex elements (the study then builds a
        :class:`mjflex.Flexures` for it) or none.
    report : str
        What was changed, and what the variant cannot represent (one line per change).
    body_map : dict[str, tuple[str, numpy.ndarray]]
        For every named body of the source model: ``(name of the variant body that carries
        it, X_VS)`` where ``X_VS`` is the 4x4 homogeneous pose of the source body's frame in
        that variant body's frame (identity for bodies kept as they are; a fixed offset for
        bodies merged into another one).
    state_from : callable
        ``state_from(source_model, source_data) -> (qpos, qvel)``: the variant's state that
        puts its bodies at the source's body poses and velocities (read from ``source_data``
        after ``mj_forward``), so both can start from the same initial condition.
    """

    name: str
    model: mujoco.MjModel
    report: str
    body_map: dict[str, tuple[str, np.ndarray]]
    state_from: Callable[[mujoco.MjModel, mujoco.MjData], tuple[np.ndarray, np.ndarray]]
    details: dict = field(default_factory=dict)  # machine-readable counterpart of ``report``

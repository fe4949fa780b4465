"""Warnings about what is legal but likely a mistake (said once, where the user made it)."""

import warnings

__all__ = ["LikelyMistakeWarning", "warn_likely_mistake"]


class LikelyMistakeWarning(UserWarning):
    """Something legal that is likely a mistake: a damping ratio above 1, an element between bodies that joints
    already join (or that nothing lets move apart).

    Silence one on purpose with ``warnings.filterwarnings("ignore", category=mjflex.LikelyMistakeWarning)``;
    ``strict=True`` (where offered) turns it into a ValueError.

    Examples
    --------
    ``damping_ratio=10`` meant as 10 %:

    >>> import warnings
    >>> import mujoco
    >>> import mjflex
    >>> model = mujoco.MjModel.from_xml_string(mjflex.mjcf.elements.EXAMPLE_MODEL)  # one element, "hinge"
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     B = mjflex.damping_from_ratios(model, "hinge", 10)
    >>> print(caught[0].category.__name__, str(caught[0].message)[:70])
    LikelyMistakeWarning damping_ratio = [10.0, 10.0, 10.0, 10.0, 10.0, 10.0]: a ratio above 1
    """


def warn_likely_mistake(message, stacklevel=2) -> None:
    """Warn ``message`` as a :class:`LikelyMistakeWarning`, attributed ``stacklevel`` frames up from the caller."""
    warnings.warn(message, LikelyMistakeWarning, stacklevel=stacklevel + 1)

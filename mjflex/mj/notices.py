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
    >>> import warnings
    >>> import mjflex
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     _ = mjflex.damping_from_ratios  # a ratio of 10 to damping_from_ratios or make_compliant warns
    ...     mjflex.mj.notices.warn_likely_mistake("example", stacklevel=1)
    >>> caught[0].category.__name__
    'LikelyMistakeWarning'
    """


def warn_likely_mistake(message, stacklevel=2) -> None:
    """Warn ``message`` as a :class:`LikelyMistakeWarning`, attributed ``stacklevel`` frames up from the caller."""
    warnings.warn(message, LikelyMistakeWarning, stacklevel=stacklevel + 1)

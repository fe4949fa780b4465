"""End stops as a property of an element in a model: :class:`Stops`, and how both element forms store them.

The math (coordinates, energy, wrench) is :mod:`mjflex.core.stops`; the C engine evaluates the same in every
path (engine plugin, ``mjcb_passive`` dispatcher, Python's queries). Stored forms and their rules are rows of the
schema table (:mod:`mjflex.mjcf.schema`): the record's ``"stops"`` object ``{"lower", "upper", "stiffness",
"damping"}`` (``null`` where a coordinate has no stop), the plugin's ``stop_lower``, ``stop_upper``,
``stop_stiffness``, ``stop_damping`` (``-inf`` / ``inf`` where a coordinate has no stop). The C library checks
them: a :class:`Stops` on its own when it is made (the rules that need no element), and with the element's ``K``
when the element is written or read, where it also derives the stiffness not given (``100 K_ii``; what
:meth:`Stops.stiffness_for` reads back). A range need not contain the rest pose: the element is then pressed
against its stop at rest (a preload).
"""

import math
from dataclasses import dataclass

import numpy as np

from ..core import validation
from ..core.stops import PLANAR_INDEX
from ..core.validation import MAX_MATRIX_ENTRY, shorten
from . import schema

#: Largest magnitude of a rotation limit [rad]: pi, with room for the round-off of pi written in any way.
MAX_ROTATION_LIMIT = math.pi * (1.0 + 1e-12)
#: Largest stop stiffness (and damping): the limit of K's entries.
MAX_STIFFNESS = MAX_MATRIX_ENTRY
_FIELDS = ("lower", "upper", "stiffness", "damping")


def _argument(value, key):
    """An argument as the numbers the table takes (limits: None entries for no stop); None when not given."""
    if value is None:
        return None
    if isinstance(value, str | bytes | dict) or (key in ("lower", "upper") and not hasattr(value, "__len__")):
        raise ValueError(f"{key} must be a list of numbers (None where a coordinate has no stop); got {shorten(value)}")
    if key in ("lower", "upper"):
        value = [(-math.inf if key == "lower" else math.inf) if v is None else v for v in value]
    a = validation.numeric_array(value, key)
    return float(a) if a.ndim == 0 else tuple(float(v) for v in a.ravel())


@dataclass(frozen=True)
class Stops:
    """End stops of an element: one-sided limits on its coordinates (:mod:`mjflex.core.stops`).

    Pass to :func:`mjflex.add_flexure` as ``stops=``. Beyond a limit, the stop stores
    ``k / 2 * overshoot**2``: a stiff, energy-conserving force, continuous at the limit, that is
    minus the gradient of that energy. The coordinates are the same for both methods: the
    rotation vector of frame b relative to frame a (about one axis, the angle) and the position
    of frame b's origin in frame a (the translation along each axis of frame a).

    Parameters
    ----------
    lower, upper : sequence of float or None, optional
        Limits per coordinate, angular first: ``[rx, ry, rz, x, y, z]`` [rad, m] for a spatial
        element, ``[theta, x, y]`` for a planar one. ``None`` (or ``-inf`` / ``+inf``) for a
        coordinate without a stop; the whole argument None for no lower (upper) stop at all.
        Rotation limits lie in ``[-pi, pi]``; ``lower <= upper``.
    stiffness : float or sequence of float, optional
        The stops' stiffness [N m/rad, N/m]: one number for every coordinate, or one per
        coordinate. None (default): derived from the element's own stiffness,
        ``STIFFNESS_FACTOR * K_ii`` = 100 times the diagonal entry of ``K`` of each coordinate
        (:func:`mjflex.derived_stop_stiffness`), which cuts an overshoot 101-fold and raises the
        frequency of a mode that the coordinate dominates up to 10-fold while the stop is
        engaged (take the time step there: :func:`mjflex.step_advice` at an engaged pose).
    damping : float or sequence of float, optional
        The stops' damping [N m s/rad, N s/m], active beyond a limit only: one number, or one per
        coordinate. None (default): conservative stops.

    Attributes
    ----------
    lower, upper : tuple of float or None
        The limits as given, ``-inf`` / ``+inf`` where a coordinate has none (None: no finite
        limit at all).
    stiffness, damping : float, tuple of float or None
        As given (None: derived stiffness, no damping).

    Raises
    ------
    ValueError
        The C library's message when a rule of the stops is broken (:mod:`mjflex.mjcf.schema`).

    Examples
    --------
    A disc that bends forward at most 0.19 rad (about its x axis) and backward 0.08 rad:

    >>> import numpy as np
    >>> import mjflex
    >>> stops = mjflex.Stops(lower=[-0.08, None, None, None, None, None], upper=[0.19, None, None, None, None, None])
    >>> stops.stiffness_for(np.diag([2.0, 2.0, 1.0, 1e5, 1e5, 1e5]))  # derived: 100 K_ii where there is a limit
    array([200.,   0.,   0.,   0.,   0.,   0.])
    """

    lower: tuple | None = None
    upper: tuple | None = None
    stiffness: float | tuple | None = None
    damping: float | tuple | None = None

    def __post_init__(self):
        given = {k: _argument(getattr(self, k), k) for k in _FIELDS}
        config = schema.group_config("stops", given)
        if config:
            schema.read_values("", config, "arguments")  # the C library's rules of stops without an element
        self._set(given)

    def _set(self, values):
        for key in _FIELDS:
            value = values.get(key)
            if key in ("lower", "upper") and value is not None and not np.isfinite(value).any():
                value = None  # no finite limit: no stop
            object.__setattr__(self, key, value)

    @classmethod
    def checked(cls, **values) -> "Stops":
        """Stops from values the C library has checked (:func:`mjflex.mjcf.schema.record_from_values`)."""
        stops = object.__new__(cls)
        stops._set({k: (tuple(v) if isinstance(v, np.ndarray) else v) for k, v in values.items()})
        return stops

    @property
    def size(self) -> int | None:
        """Coordinates the limits are given for: 6 (spatial), 3 (planar), or None without any limit."""
        given = self.lower if self.lower is not None else self.upper
        return None if given is None else len(given)

    def __bool__(self) -> bool:
        """Whether any coordinate has a limit."""
        return self.size is not None

    def limits_for(self, n: int) -> tuple[np.ndarray, np.ndarray]:
        """``(lower, upper)`` as float arrays of ``n`` entries, ``-inf`` / ``+inf`` where there is no stop."""
        lower = np.full(n, -math.inf) if self.lower is None else np.array(self.lower)
        upper = np.full(n, math.inf) if self.upper is None else np.array(self.upper)
        return lower, upper

    def stiffness_for(self, K) -> np.ndarray:
        """The stops' stiffness per coordinate for an element of stiffness ``K`` (6x6, or 3x3 planar).

        Given, or derived (``STIFFNESS_FACTOR * K_ii``), as the C library lays out the element;
        zero on coordinates without a limit. Raises ValueError (the C library's message) when the
        limits do not fit ``K``'s size or a limited coordinate gets no stiffness.

        Parameters
        ----------
        K : array_like, shape (6, 6) or (3, 3)
            The element's stiffness in its frame [N m/rad, N/m].

        Returns
        -------
        k : ndarray, shape (6,) or (3,)
            Stiffness of each coordinate's stops [N m/rad, N/m].
        """
        K = schema.matrix_value(K, "K")
        row = schema.read_values("", {**self.config(), "K": schema.text_of("K", K)}, "arguments")[-1]
        return row["stop_k"][list(PLANAR_INDEX)] if len(K) == 3 else row["stop_k"].copy()

    # ------------------------------------------------------------------ stored forms

    def _given(self) -> dict:
        return {k: getattr(self, k) for k in _FIELDS if getattr(self, k) is not None}

    def to_dict(self) -> dict:
        """The record's ``"stops"`` object (``null`` where a coordinate has no stop)."""
        return schema.group_json("stops", self._given())

    @classmethod
    def from_dict(cls, data) -> "Stops":
        """The stops of a record's ``"stops"`` object; ValueError naming the problem."""
        config = schema.config_from_payload({"mjflex": schema.SCHEMA_VERSION, "stops": data})
        return cls.from_config(config)

    def config(self) -> dict[str, str]:
        """The plugin attributes ``stop_lower``, ``stop_upper``, ``stop_stiffness``, ... (lossless text)."""
        return schema.group_config("stops", self._given())

    @classmethod
    def from_config(cls, config: dict) -> "Stops | None":
        """The stops of a plugin configuration (attribute name -> text), or None without any stop attribute."""
        given = {a.key: config[a.key] for a in schema.attributes() if a.field == "stops" and config.get(a.key)}
        values = schema.group_values("stops", *schema.read_values("", given, "arguments")[:4]) if given else {}
        return cls.checked(**values) if values else None

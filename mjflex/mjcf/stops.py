"""End stops as a property of an element in a model: :class:`Stops`, and how both element forms store them.

The math (coordinates, energy, wrench) is :mod:`mjflex.core.stops`; the C engine evaluates the same in every
path (engine plugin, ``mjcb_passive`` dispatcher, Python's queries). Stored forms and their rules are rows of the
schema table (:mod:`mjflex.mjcf.schema`): the record's ``"stops"`` object ``{"lower", "upper", "stiffness",
"damping"}`` (``null`` where a coordinate has no stop), the plugin's ``stop_lower``, ``stop_upper``,
``stop_stiffness``, ``stop_damping`` (``-inf`` / ``inf`` where a coordinate has no stop). The C library checks
them: a :class:`Stops` on its own when it is made (the rules that need no element), and with the element's ``K``
when the element is written or read, where it also derives the stiffness not given (``100 K_ii``; what
:meth:`Stops.stiffness_for` reads back). A range need not contain the rest pose: the element is then pressed
against its stop at rest (a preload). A damping ratio or a time constant (:class:`Stops`) is no attribute of the
file: it is turned into numbers where the model is known (:func:`mjflex.add_flexure`, :func:`resolved`), and the
file stores the stiffness and damping.
"""

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from ..core import validation
from ..core.stops import PLANAR_COORDINATES, PLANAR_INDEX, SPATIAL_COORDINATES
from ..core.validation import MAX_MATRIX_ENTRY, shorten
from . import schema

#: Largest magnitude of a rotation limit [rad]: pi, with room for the round-off of pi written in any way.
MAX_ROTATION_LIMIT = math.pi * (1.0 + 1e-12)
#: Largest stop stiffness (and damping): the limit of K's entries.
MAX_STIFFNESS = MAX_MATRIX_ENTRY
_FIELDS = ("lower", "upper", "stiffness", "damping")  # the table's rows (stops.*)
_DERIVING = ("damping_ratio", "time_constant")  # turned into stiffness and damping where the model is known


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


def _deriving(value, key, n):
    """A damping ratio (``>= 0``) or time constant (``> 0``): a float, or a tuple of ``n`` (None: any) floats."""
    if value is None:
        return None
    a = validation.numeric_array(value, key)
    if a.ndim and n is not None and a.size != n:
        raise ValueError(f"{key} has {a.size} entries; give one number, or one per coordinate ({n})")
    low = (a > 0) if key == "time_constant" else (a >= 0)
    if not (np.isfinite(a).all() and low.all() and (a <= MAX_STIFFNESS).all()):
        raise ValueError(f"{key} must be finite, {'> 0' if key == 'time_constant' else '>= 0'} and at most "
                         f"{MAX_STIFFNESS:g}; got {shorten(value)}")  # fmt: skip
    return float(a) if a.ndim == 0 else tuple(float(v) for v in a.ravel())


@dataclass(frozen=True)
class Stops:
    """End stops of an element: one-sided limits on its coordinates (:mod:`mjflex.core.stops`).

    Pass to :func:`mjflex.add_flexure` as ``stops=``. Beyond a limit, the stop stores
    ``k / 2 * overshoot**2``: a stiff force, continuous at the limit, that is minus the gradient
    of that energy; with damping, ``b`` times the coordinate's rate is added beyond the limit,
    clamped so that the stop never pulls the body back in. The coordinates are the same for both
    methods: the rotation vector of frame b relative to frame a (about one axis, the angle) and
    the position of frame b's origin in frame a (the translation along each axis of frame a),
    counted from the element's rest pose.

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
        The stops' damping [N m s/rad, N s/m], ``>= 0``, active beyond a limit only: one number, or
        one per coordinate. None (default): conservative stops (bounces lose no energy).
    damping_ratio : float or sequence of float, optional
        Instead of ``damping``: the ratio ``zeta`` of the damping to the critical damping of each
        coordinate's stop, ``b = 2 zeta sqrt(k m)`` with ``m`` the coordinate's effective mass
        (inertia) at ``qpos0`` (``1 / (J M^-1 J^T)``, what MuJoCo's constraints use). It is
        turned into a damping where the model is known (:func:`mjflex.add_flexure`), and the
        file stores the damping. 1 is critically damped: a body that hits the stop keeps about
        13 % of its speed.
    time_constant : float or sequence of float, optional
        Instead of ``stiffness`` and ``damping``: MuJoCo's ``solref`` time constant ``tau`` [s]
        (with ``damping_ratio`` ``zeta``, default 1), mapped as MuJoCo maps a joint limit's
        ``solref``: ``k = m / (tau zeta)^2``, ``b = 2 m / tau`` (``m`` as above), so that the stop
        bounces like a MuJoCo joint limit with ``solref="tau zeta"``. Explicit element forces
        need ``tau`` of at least about 2 time steps (MuJoCo's own advice for ``solref``); a
        shorter one is stiffer than the step can hold (:func:`mjflex.step_advice`).

    Attributes
    ----------
    lower, upper : tuple of float or None
        The limits as given, ``-inf`` / ``+inf`` where a coordinate has none (None: no finite
        limit at all).
    stiffness, damping, damping_ratio, time_constant : float, tuple of float or None
        As given (stiffness None: derived; damping None: none).

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

    The same stops, bouncing like a MuJoCo joint limit with ``solref="0.004 1"`` (a 2 ms step):
    ``add_flexure`` turns them into a stiffness and a damping from the disc's inertia.

    >>> stops = mjflex.Stops(lower=[-0.08] + [None] * 5, upper=[0.19] + [None] * 5, time_constant=0.004)
    """

    lower: tuple | None = None
    upper: tuple | None = None
    stiffness: float | tuple | None = None
    damping: float | tuple | None = None
    damping_ratio: float | tuple | None = None
    time_constant: float | tuple | None = None

    def __post_init__(self):
        given = {k: _argument(getattr(self, k), k) for k in _FIELDS}
        config = schema.group_config("stops", given)
        if config:
            schema.read_values("", config, "arguments")  # the C library's rules of stops without an element
        size = next((len(given[k]) for k in ("lower", "upper") if given[k] is not None), None)
        for key in _DERIVING:  # no attributes of the file: their rules are here
            given[key] = _deriving(getattr(self, key), key, size)
            if given[key] is not None and size is None:
                raise ValueError(f"{key} is given but there is no stop: give lower= or upper= limits (or drop the "
                                 f"{key})")  # fmt: skip
        for a, b in (("damping", "damping_ratio"), ("stiffness", "time_constant"), ("damping", "time_constant")):
            if given[a] is not None and given[b] is not None:
                raise ValueError(f"give {a} or {b}, not both ({b} derives the {a})")
        self._set(given)

    def _set(self, values):
        for key in _FIELDS + _DERIVING:
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

    @property
    def needs_model(self) -> bool:
        """Whether a damping ratio or a time constant waits for the model's effective masses (:func:`resolved`)."""
        return self.damping_ratio is not None or self.time_constant is not None

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
        return self._row("stop_k", len(K), {"K": schema.text_of("K", K)})

    def damping_for(self, n: int) -> np.ndarray:
        """The stops' damping per coordinate [N m s/rad, N s/m] as the C library lays it out for an element of ``n``
        coordinates (6, or 3 planar): zero without damping or a limit."""
        return self._row("stop_b", n, {})

    def _row(self, field, n, more) -> np.ndarray:
        """Field ``field`` of the element row the C library makes of the stops (and ``more`` attributes)."""
        row = schema.read_values("", {**self.config(), **more}, "arguments")[-1]
        return row[field][list(PLANAR_INDEX)] if n == 3 else row[field].copy()

    # ------------------------------------------------------------------ stored forms

    def _given(self) -> dict:
        if self.needs_model:
            key = "damping_ratio" if self.damping_ratio is not None else "time_constant"
            raise ValueError(f"{key} is turned into a damping where the model is known: pass the stops to "
                             "mjflex.add_flexure (or mjflex.mjcf.stops.resolved)")  # fmt: skip
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


def coordinate_masses(model, data, body_a: int, body_b: int, p_WE, R_WE, n: int = 6) -> np.ndarray:
    """The effective mass (inertia) of each stop coordinate of an element at ``data``'s state: ``1 / (J M^-1 J^T)``.

    ``J`` is the row of the coordinate's rate in the relative velocity of the bodies' points at
    the element frame's origin ``p_WE`` (world [m]), in its axes ``R_WE`` (3x3): what MuJoCo's
    constraints weigh their ``solref`` with. ``data`` holds ``mj_forward``'s kinematics and mass
    matrix. A coordinate that no degree of freedom moves gets ``inf``.

    Returns
    -------
    m : ndarray, shape (n,)
        [kg m^2] for rotations, [kg] for translations; ``n`` 3 (planar: ``rz, x, y``) or 6.
    """
    J = np.zeros((6, model.nv))
    for body, sign in ((body_b, 1.0), (body_a, -1.0)):
        if body == 0:
            continue
        jacp, jacr = np.zeros((3, model.nv)), np.zeros((3, model.nv))
        mujoco.mj_jac(model, data, jacp, jacr, np.asarray(p_WE, dtype=float), body)
        J += sign * np.vstack([R_WE.T @ jacr, R_WE.T @ jacp])
    J = np.ascontiguousarray(J[list(PLANAR_INDEX)] if n == 3 else J)
    x = np.zeros_like(J)
    if model.nv:
        mujoco.mj_solveM(model, data, x, J)
    inv = np.einsum("ij,ij->i", J, x)
    tol = 1e-9 * max(1.0, np.abs(J).max(initial=0.0))
    with np.errstate(divide="ignore"):
        return np.where((np.abs(J).max(axis=1, initial=0.0) <= tol) | (inv <= 0), np.inf, 1.0 / inv)


def resolved(stops, K, masses, element: str):
    """``stops`` with a damping ratio or time constant turned into numbers for an element of stiffness ``K``.

    ``masses``: the coordinates' effective masses (:func:`coordinate_masses`). A time constant
    ``tau`` and ratio ``zeta`` give ``k = m / (tau zeta)^2`` and ``b = 2 m / tau`` (MuJoCo's map of a
    ``solref``); a ratio alone gives ``b = 2 zeta sqrt(k m)`` for the given or derived stiffness (the
    C library's). A coordinate that nothing moves (``m`` infinite) never engages its stop's damping: it
    gets 0 (and, for a time constant, the derived stiffness). Returns Stops whose stiffness and damping
    are numbers (per coordinate), or ``stops`` itself when it needs no model.
    """
    if stops is None or not stops.needs_model:
        return stops
    K = schema.matrix_value(K, "K")
    n, m = len(K), np.asarray(masses, dtype=float)
    lower, upper = stops.limits_for(stops.size)
    limited, moves = np.isfinite(lower) | np.isfinite(upper), np.isfinite(m)
    zeta = np.broadcast_to(np.asarray(1.0 if stops.damping_ratio is None else stops.damping_ratio, float), (n,))
    try:  # the stiffness of the limits on K (C's: its count checked, derived where not given)
        given = stops.stiffness if stops.time_constant is None else 1.0
        k = Stops(stops.lower, stops.upper, given).stiffness_for(K)
        if stops.time_constant is not None and (limited & ~moves).any():
            k = Stops(stops.lower, stops.upper).stiffness_for(K)
    except ValueError as exc:
        raise ValueError(f"flexure {element!r}: {exc}") from None
    if stops.time_constant is not None:
        tau = np.broadcast_to(np.asarray(stops.time_constant, float), (n,))
        with np.errstate(invalid="ignore", divide="ignore"):
            k = np.where(moves, m / (tau * zeta) ** 2, k)
            b = np.where(moves, 2.0 * m / tau, 0.0)
        stiffness = tuple(float(v) for v in np.where(limited, k, 0.0))
    else:
        with np.errstate(invalid="ignore"):
            b = np.where(moves, 2.0 * zeta * np.sqrt(k * np.where(moves, m, 0.0)), 0.0)
        stiffness = stops.stiffness
    bad = limited & ~(np.isfinite(b) & (b <= MAX_STIFFNESS) & np.isfinite(k) & (k <= MAX_STIFFNESS))
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        names = SPATIAL_COORDINATES if n == 6 else PLANAR_COORDINATES
        raise ValueError(f"flexure {element!r}: the stop on {names[i]} gets stiffness {k[i]:g} and damping {b[i]:g} "
                         f"from its effective mass {m[i]:g}; check the time constant and the masses")  # fmt: skip
    return Stops(stops.lower, stops.upper, stiffness, tuple(float(v) for v in np.where(limited, b, 0.0)))

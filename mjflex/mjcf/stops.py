"""End stops as a property of an element in a model: :class:`Stops`, and how both element forms store them.

The math (coordinates, energy, wrench, the derived stiffness) is :mod:`mjflex.core.stops`; the C
engine evaluates the same in every path (engine plugin, ``mjcb_passive`` dispatcher, Python's
queries). Stored forms:

* text record: the key ``"stops"``, an object ``{"lower": [...], "upper": [...], "stiffness": ...,
  "damping": ...}`` whose lists have one entry per coordinate, ``null`` where a coordinate has no
  stop (JSON has no infinity); ``"stiffness"`` is ``null``/absent (derived), a number (every
  coordinate) or a list; ``"damping"`` is ``null``/absent (conservative stops), a number or a list;
* plugin instance: the attributes ``stop_lower``, ``stop_upper`` (one number per coordinate,
  ``-inf`` / ``inf`` where a coordinate has no stop), ``stop_stiffness`` (absent: derived; one
  number, or one per coordinate) and ``stop_damping`` (absent: none; one number, or one per
  coordinate).

A damping ratio or a time constant (:class:`Stops`) is turned into numbers where the model is
known (:func:`mjflex.add_flexure`, :func:`resolved`): the file stores the stiffness and damping.

Rules (the record's and the plugin's, the same): one limit per coordinate, ``[rx, ry, rz, x, y,
z]`` for a spatial element and ``[theta, x, y]`` for a planar one (as many as ``K`` has rows); no
NaN; no lower limit of ``+inf`` or upper limit of ``-inf``; rotation limits within ``[-pi, pi]``
(the rotation vector's components never leave it, so a stop beyond could never act: a limit in
degrees is the usual cause); ``lower <= upper``; stiffness finite, ``>= 0``, at most
``MAX_MATRIX_ENTRY``, and positive on every coordinate with a limit (given, or derived as
``STIFFNESS_FACTOR * K_ii``, which needs ``K_ii > 0``); a stiffness without any limit is refused;
damping finite, ``>= 0``, at most ``MAX_MATRIX_ENTRY``, refused without any limit.
A range need not contain the rest pose: the element is then pressed against its stop at rest (a
preload).
"""

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from ..core import validation
from ..core.stops import PLANAR_COORDINATES, PLANAR_INDEX, SPATIAL_COORDINATES, derived_stop_stiffness
from ..core.validation import MAX_MATRIX_ENTRY, shorten

#: Largest magnitude of a rotation limit [rad]: pi, with room for the round-off of pi written in any way.
MAX_ROTATION_LIMIT = math.pi * (1.0 + 1e-12)
#: Largest stop stiffness: the limit of K's entries.
MAX_STIFFNESS = MAX_MATRIX_ENTRY
#: Keys of a record's ``"stops"`` object and the plugin attributes that hold the same.
KEYS = ("lower", "upper", "stiffness", "damping")
ATTRIBUTES = ("stop_lower", "stop_upper", "stop_stiffness", "stop_damping")


def _coordinates(n):
    return SPATIAL_COORDINATES if n == 6 else PLANAR_COORDINATES


def _limits(value, key):
    """A limits vector as a tuple of floats (None entries: no stop), or None when it has no finite limit."""
    if value is None:
        return None
    if isinstance(value, str | bytes | dict) or not hasattr(value, "__len__"):
        raise ValueError(f"{key} must be a list of {len(SPATIAL_COORDINATES)} (or 3, planar) limits; got "
                         f"{shorten(value)}")  # fmt: skip
    fill = -math.inf if key == "lower" else math.inf
    entries = [fill if v is None else v for v in value]
    a = validation.numeric_array(entries, key)
    if a.ndim != 1 or len(a) not in (6, 3):
        raise ValueError(
            f"{key} must have one limit per coordinate: 6 [rx, ry, rz, x, y, z] for a spatial element, 3 [theta, x, "
            f"y] for a planar one; got {shorten(value)}"
        )
    names = _coordinates(len(a))
    for i, v in enumerate(a):
        if math.isnan(v):
            raise ValueError(f"{key} of {names[i]} is NaN; use None (or {fill}) for a coordinate without a stop")
        if v == -fill:
            raise ValueError(f"{key} of {names[i]} is {v}, a stop that would push at every pose; use None (or "
                             f"{fill}) for a coordinate without a stop")  # fmt: skip
        rotation = i < 3 if len(a) == 6 else i == 0
        if rotation and math.isfinite(v) and abs(v) > MAX_ROTATION_LIMIT:
            raise ValueError(
                f"{key} of {names[i]} is {v:g} rad, beyond pi: a rotation coordinate (a component of the rotation "
                "vector) lies in [-pi, pi], so this stop could never act. Give radians (not degrees) in [-pi, pi], "
                "or None for no stop"
            )
    return tuple(float(v) for v in a) if np.isfinite(a).any() else None


def _per_coordinate(value, key, n, *, positive=False):
    """A scalar or per-coordinate value checked (finite, ``>= 0`` or ``> 0``, at most ``MAX_STIFFNESS``): a float or
    a tuple of ``n`` floats (``n`` None: any length), or None."""
    if value is None:
        return None
    scalar = not hasattr(value, "__len__") or (isinstance(value, np.ndarray) and value.ndim == 0)
    a = validation.numeric_array(value, key).reshape(-1)
    if not scalar and n is not None and len(a) != n:
        raise ValueError(f"{key} has {len(a)} entries; give one number, or one per coordinate ({n})")
    low = (a > 0) if positive else (a >= 0)
    if not (np.isfinite(a).all() and low.all() and (a <= MAX_STIFFNESS).all()):
        raise ValueError(f"{key} must be finite, {'> 0' if positive else '>= 0'} and at most {MAX_STIFFNESS:g}; got "
                         f"{shorten(value)}")  # fmt: skip
    return float(a[0]) if scalar else tuple(float(v) for v in a)


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
        engaged (take the time step there: :func:`mjflex.normal_modes` at an engaged pose).
    damping : float or sequence of float, optional
        The stops' damping [N m s/rad, N s/m], ``>= 0``: one number, or one per coordinate.
        None (default): conservative stops (bounces lose no energy).
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
        lower, upper = _limits(self.lower, "lower"), _limits(self.upper, "upper")
        n = {len(x) for x in (self.lower, self.upper) if x is not None}
        if len(n) > 1:
            raise ValueError(f"lower and upper have different lengths ({sorted(n)}); give one limit per coordinate "
                             "to both")  # fmt: skip
        if lower is not None and upper is not None:
            names = _coordinates(len(lower))
            for i, (lo, hi) in enumerate(zip(lower, upper, strict=True)):
                if lo > hi:
                    raise ValueError(f"lower of {names[i]} ({lo:g}) is above upper ({hi:g}); a range needs lower <= "
                                     "upper")  # fmt: skip
        object.__setattr__(self, "lower", lower)
        object.__setattr__(self, "upper", upper)
        size = n.pop() if n else None
        given = [k for k in ("stiffness", "damping", "damping_ratio", "time_constant") if getattr(self, k) is not None]
        if given and lower is None and upper is None:
            raise ValueError(f"{given[0]} is given but there is no stop: give lower= or upper= limits (or drop the "
                             f"{given[0]})")  # fmt: skip
        for a, b in (("damping", "damping_ratio"), ("stiffness", "time_constant"), ("damping", "time_constant")):
            if a in given and b in given:
                raise ValueError(f"give {a} or {b}, not both ({b} derives the {a.replace('_', ' ')})")
        for key in ("stiffness", "damping", "damping_ratio", "time_constant"):
            object.__setattr__(self, key, _per_coordinate(getattr(self, key), key, size,
                                                          positive=key == "time_constant"))  # fmt: skip

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

        Given, or derived (``STIFFNESS_FACTOR * K_ii``); zero on coordinates without a limit.
        Raises ValueError when the limits do not fit ``K``'s size or a limited coordinate gets
        no stiffness.

        Parameters
        ----------
        K : array_like, shape (6, 6) or (3, 3)
            The element's stiffness in its frame [N m/rad, N/m].

        Returns
        -------
        k : ndarray, shape (6,) or (3,)
            Stiffness of each coordinate's stops [N m/rad, N/m].
        """
        K = np.asarray(K, dtype=float)
        n = K.shape[0]
        if self.size is not None and self.size != n:
            kind = "spatial (6x6 K)" if n == 6 else "planar (3x3 K)"
            raise ValueError(
                f"the stops give {self.size} limits but the element is {kind}: give {n}, one per coordinate "
                f"{list(_coordinates(n))}"
            )
        lower, upper = self.limits_for(n)
        limited = np.isfinite(lower) | np.isfinite(upper)
        if self.time_constant is not None:
            return np.zeros(n)  # set by resolved() from the model's effective masses
        derived = self.stiffness is None
        k = derived_stop_stiffness(K) if derived else np.broadcast_to(np.asarray(self.stiffness, float), (n,)).copy()
        names = _coordinates(n)
        for i in np.flatnonzero(limited & ~(k > 0)):
            if derived:
                raise ValueError(f"the stop on {names[i]} needs a stiffness: K[{i}, {i}] is 0, so none can be "
                                 f"derived from it (100 x K_ii); give Stops(stiffness=...)")  # fmt: skip
            raise ValueError(f"the stiffness of the stop on {names[i]} is 0, so it would do nothing; give it a "
                             "positive stiffness or drop the limit")  # fmt: skip
        return np.where(limited, k, 0.0)

    def damping_for(self, n: int) -> np.ndarray:
        """The stops' damping per coordinate [N m s/rad, N s/m] as stored: zero without damping or a limit."""
        if self.needs_model:
            raise ValueError(f"{'damping_ratio' if self.damping_ratio is not None else 'time_constant'} is turned into "
                             "a damping where the model is known: pass the stops to mjflex.add_flexure (or "
                             "mjflex.mjcf.stops.resolved)")  # fmt: skip
        lower, upper = self.limits_for(n)
        b = np.zeros(n) if self.damping is None else np.broadcast_to(np.asarray(self.damping, float), (n,))
        return np.where(np.isfinite(lower) | np.isfinite(upper), b, 0.0)

    # ------------------------------------------------------------------ stored forms

    def _stored(self):
        if self.needs_model:
            self.damping_for(self.size or 6)  # raises: a ratio is not stored
        return {key: getattr(self, key) for key in ("stiffness", "damping") if getattr(self, key) is not None}

    def to_dict(self) -> dict:
        """The record's ``"stops"`` object (``null`` where a coordinate has no stop)."""
        out = {}
        for key in ("lower", "upper"):
            values = getattr(self, key)
            if values is not None:
                out[key] = [v if math.isfinite(v) else None for v in values]
        for key, value in self._stored().items():
            out[key] = list(value) if isinstance(value, tuple) else value
        return out

    @classmethod
    def from_dict(cls, data) -> "Stops":
        """The stops of a record's ``"stops"`` object; ValueError naming the problem."""
        if not isinstance(data, dict):
            raise ValueError(f'"stops" must be an object with the keys {list(KEYS)}; got {shorten(data)}')
        unknown = sorted(set(data) - set(KEYS))
        if unknown:
            raise ValueError(f'"stops" has unknown key(s) {shorten(unknown)}; the allowed keys are {list(KEYS)}')
        for key in ("lower", "upper"):
            if data.get(key) is not None and not isinstance(data[key], list):
                raise ValueError(f'"stops" "{key}" must be a list (null where there is no stop); got '
                                 f"{shorten(data[key])}")  # fmt: skip
        try:
            return cls(data.get("lower"), data.get("upper"), data.get("stiffness"), data.get("damping"))
        except (TypeError, ValueError) as exc:
            raise ValueError(f'"stops": {exc}') from None

    def config(self) -> dict[str, str]:
        """The plugin attributes ``stop_lower``, ``stop_upper``, ``stop_stiffness``, ``stop_damping`` (lossless)."""
        out = {}
        for key, attribute in zip(("lower", "upper"), ATTRIBUTES, strict=False):
            values = getattr(self, key)
            if values is not None:
                out[attribute] = " ".join(repr(float(v)) for v in values)
        for key, value in self._stored().items():
            out[f"stop_{key}"] = " ".join(repr(float(v)) for v in (value if isinstance(value, tuple) else (value,)))
        return out

    @classmethod
    def from_config(cls, config: dict) -> "Stops | None":
        """The stops of a plugin configuration (attribute name -> text), or None without any stop attribute."""
        text = {a: str(config.get(a, "")).strip() for a in ATTRIBUTES}
        if not any(text.values()):
            return None
        values = {}
        for attribute, key in zip(ATTRIBUTES, KEYS, strict=True):
            if text[attribute]:
                try:
                    values[key] = [float(t) for t in text[attribute].split()]
                except ValueError:
                    raise ValueError(f"{attribute} must be numbers separated by spaces; got "
                                     f"{text[attribute][:40]!r}") from None  # fmt: skip
        for key in ("stiffness", "damping"):
            if values.get(key) is not None and len(values[key]) == 1:
                values[key] = values[key][0]
        try:
            return cls(values.get("lower"), values.get("upper"), values.get("stiffness"), values.get("damping"))
        except (TypeError, ValueError) as exc:
            raise ValueError(f"stop attributes: {exc}") from None


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
    ``solref``); a ratio alone gives ``b = 2 zeta sqrt(k m)`` for the given or derived stiffness. A
    coordinate that nothing moves (``m`` infinite) never engages its stop's damping: it gets 0 (and,
    for a time constant, the derived stiffness). Returns Stops whose stiffness and damping are
    numbers (per coordinate), or ``stops`` itself when it needs no model.
    """
    if stops is None or not stops.needs_model:
        return stops
    K = np.asarray(K, dtype=float)
    n = K.shape[0]
    m = np.asarray(masses, dtype=float)
    lower, upper = stops.limits_for(n)
    limited = np.isfinite(lower) | np.isfinite(upper)
    moves = np.isfinite(m)
    zeta = np.broadcast_to(np.asarray(1.0 if stops.damping_ratio is None else stops.damping_ratio, float), (n,))
    if stops.time_constant is not None:
        tau = np.broadcast_to(np.asarray(stops.time_constant, float), (n,))
        with np.errstate(invalid="ignore", divide="ignore"):
            k = np.where(moves, m / (tau * zeta) ** 2, derived_stop_stiffness(K))
            b = np.where(moves, 2.0 * m / tau, 0.0)
        stiffness = tuple(float(v) for v in np.where(limited, k, 0.0))
    else:
        k = Stops(stops.lower, stops.upper, stops.stiffness).stiffness_for(K)
        with np.errstate(invalid="ignore"):
            b = np.where(moves, 2.0 * zeta * np.sqrt(k * np.where(moves, m, 0.0)), 0.0)
        stiffness = stops.stiffness
    bad = limited & ~(np.isfinite(b) & (b <= MAX_STIFFNESS) & np.isfinite(k) & (k <= MAX_STIFFNESS))
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise ValueError(f"flexure {element!r}: the stop on {_coordinates(n)[i]} gets stiffness {k[i]:g} and "
                         f"damping {b[i]:g} from its effective mass {m[i]:g}; check the time constant and the "
                         "masses")  # fmt: skip
    return Stops(stops.lower, stops.upper, stiffness, tuple(float(v) for v in np.where(limited, b, 0.0)))


def checked(stops, K, element: str):
    """``stops`` (a :class:`Stops` or None) checked against the element's ``K``; None when it has no limit.

    Raises TypeError for anything but a Stops, ValueError naming the element otherwise.
    """
    if stops is None:
        return None
    if not isinstance(stops, Stops):
        raise TypeError(f"flexure {element!r}: stops must be a mjflex.Stops (or None); got {type(stops).__name__}")
    if not stops:
        return None
    try:
        stops.stiffness_for(K)
    except ValueError as exc:
        raise ValueError(f"flexure {element!r}: {exc}") from None
    return stops

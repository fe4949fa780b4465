"""End stops as per-world parameters of the Warp kernels: their limits and stiffness, checked once at the boundary;
their damping, the model's.

The rules are those of an element's stops in a model (:mod:`mjflex.mjcf.stops`), applied to every
world: limits on ``[rx, ry, rz, x, y, z]`` (a planar element's on ``rz, x, y``, the rows of
``PLANAR_INDEX``), ``-inf`` / ``+inf`` where a coordinate has no stop, no NaN, rotation limits
within ``[-pi, pi]``, ``lower <= upper``; a stiffness finite, ``>= 0`` and positive on every
coordinate with a limit. A stop whose stiffness the model derives from ``K``
(``STIFFNESS_FACTOR * K_ii``, no stiffness written) keeps deriving it from each world's ``K``,
as editing ``K`` in the model would, until a stiffness is set.
"""

import numpy as np
import warp as wp

from ..core import validation
from ..core.stops import SPATIAL_COORDINATES, STIFFNESS_FACTOR
from ..mjcf.stops import MAX_ROTATION_LIMIT, MAX_STIFFNESS
from ._mjflex import PLANAR_INDEX

NAMES = ("stop_lower", "stop_upper", "stop_stiffness")
_OFF_PLANE = [i for i in range(6) if i not in PLANAR_INDEX]


def vectors(name, value, n) -> np.ndarray:
    """``value`` as a float array ``(worlds, n, 6)``; ValueError naming ``name`` and the shape it needs."""
    a = np.asarray(validation.numeric_array(value, name), dtype=float)
    if a.ndim == 2:
        a = a[None]
    if a.ndim != 3 or a.shape[1:] != (n, 6):
        raise ValueError(
            f"{name} must have shape ({n}, 6) or (worlds, {n}, 6): one value per stop coordinate "
            f"{list(SPATIAL_COORDINATES)} of each element (planar elements at {list(PLANAR_INDEX)}: theta, x, y); "
            f"got {np.shape(value)}"
        )
    if np.isnan(a).any():
        raise ValueError(f"{name} has NaN; use -inf (lower) or +inf (upper) for a coordinate without a stop")
    return a


def stiffness(table, K, given) -> np.ndarray:
    """The stiffness the kernels read before the limits are applied: ``given`` ``(worlds, n, 6)``, or the model's:
    as written, or for the elements that derive it, the C library's (``stop_k``) where a world keeps the model's
    ``K_ii`` and limit, else derived from the world's ``K`` ``(worlds, n, 6, 6)`` as the C library derives it."""
    if given is not None:
        return given
    diag = np.diagonal(K, axis1=-2, axis2=-1)
    model = (diag == np.diagonal(table.K, axis1=-2, axis2=-1)[None]) & (table.stop_stiffness[None] > 0)
    derived = np.where(model, table.stop_stiffness[None], STIFFNESS_FACTOR * diag)
    return np.where(table.stop_derived[None, :, None], derived, table.stop_stiffness[None])


def effective(names, planar, lower, upper, k, precision_max) -> np.ndarray:
    """Check the stops of every world and element; the stiffness as the kernels read it (0 where no limit).

    ``lower``, ``upper``, ``k``: ``(worlds or 1, n, 6)`` each; ``precision_max``: the largest entry the
    kernels' precision holds. Raises ValueError naming the element, the coordinate and the world.
    """
    try:
        shape = np.broadcast_shapes(lower.shape, upper.shape, k.shape)
    except ValueError:
        sizes = ", ".join(f"{name} {a.shape[0]}" for name, a in zip(NAMES, (lower, upper, k), strict=True))
        raise ValueError(f"the stops' per-world parameters have different numbers of worlds ({sizes}; the stiffness "
                         "follows K where derived): give 1 or the same number of worlds to each") from None  # fmt: skip
    lower, upper, k = (np.broadcast_to(a, shape) for a in (lower, upper, k))
    limited = np.isfinite(lower) | np.isfinite(upper)
    size = np.maximum(
        np.abs(np.where(np.isfinite(lower), lower, 0.0)), np.abs(np.where(np.isfinite(upper), upper, 0.0))
    )
    rotation = np.arange(6) < 3
    off_plane = planar[None, :, None] & np.isin(np.arange(6), _OFF_PLANE)
    in_plane = [SPATIAL_COORDINATES[i] for i in PLANAR_INDEX]
    problems = (
        (lower == np.inf, "stop_lower is +inf, a stop that would push at every pose; use -inf for no stop"),
        (upper == -np.inf, "stop_upper is -inf, a stop that would push at every pose; use +inf for no stop"),
        (lower > upper, "stop_lower is above stop_upper; a range needs lower <= upper"),
        (off_plane & limited, f"the element is planar: only {in_plane} (theta, x, y) may have stops"),
        (
            rotation & (size > MAX_ROTATION_LIMIT),
            "a rotation limit is beyond pi: the rotation vector's components lie in [-pi, pi], so this stop could "
            "never act (give radians, not degrees)",
        ),
        (size > precision_max, "a limit is beyond float32's range: use precision='float64', or check the units"),
        (~np.isfinite(k) | (k < 0) | (k > MAX_STIFFNESS), f"stop_stiffness must be finite, >= 0, <= {MAX_STIFFNESS:g}"),
        (limited & (k > precision_max), "stop_stiffness is beyond float32's range: use precision='float64'"),
        (
            limited & ~(k > 0),
            "the stop has no stiffness (0, or derived from a zero K_ii): give stop_stiffness > 0 "
            "(mjflex.derived_stop_stiffness) or drop the limit",
        ),
    )
    for bad, why in problems:
        if bad.any():
            w, e, i = (int(x) for x in np.argwhere(bad)[0])
            world = f" (world {w})" if shape[0] > 1 else ""
            got = f"lower {lower[w, e, i]:g}, upper {upper[w, e, i]:g}, stiffness {k[w, e, i]:g}"
            raise ValueError(f"end stop on {SPATIAL_COORDINATES[i]} of flexure '{names[e]}'{world}: {why}; got {got}")
    return np.where(limited, k, 0.0)


def flags(lower, upper) -> np.ndarray:
    """``(n,)`` int32: 1 for an element with a stop in some world (the kernels' per-element flag)."""
    return (np.isfinite(lower) | np.isfinite(upper)).any(axis=(0, 2)).astype(np.int32)


def set_damping(params, table, V6, real, device) -> None:
    """Put the model's stop damping (``table.stop_damping``, shared by every world) and its per-element flag into the
    kernels' parameters. The damping acts only where a limit is engaged, so limits set per world find it on the
    coordinates the model damps."""
    b = table.stop_damping if len(table.names) else np.zeros((1, 6))
    params.stop_b = wp.array(np.ascontiguousarray(b[None], real), dtype=V6, device=device)
    params.stop_damped = wp.array((b > 0).any(axis=1).astype(np.int32), dtype=wp.int32, device=device)

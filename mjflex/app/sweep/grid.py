"""The parameter grid of a sweep: a full factorial product, or explicit rows."""

import keyword
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

RESERVED = ("variant", "time", "status", "error", "element", "time_diverged")


@dataclass
class Grid:
    """Parameter sets of a sweep and the dimensions the result is laid out on.

    ``rows[i]`` is the keyword arguments of variant ``i`` (plain Python scalars). For a
    product grid ``dims`` are the parameter names and ``shape`` the number of values of each;
    variants are numbered in C order (last parameter fastest). For explicit rows there is one
    dimension ``variant`` and each parameter is a coordinate along it.
    """

    rows: list
    names: tuple
    dims: tuple
    shape: tuple
    coords: dict  # name -> (dims, values)

    def __len__(self):
        return len(self.rows)


def _scalar(value, where):
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, bool | int | float | str):
        if isinstance(value, float) and not np.isfinite(value):
            raise ValueError(f"{where} is {value!r}; parameters must be finite")
        return value
    raise TypeError(f"{where} is {value!r} ({type(value).__name__}); parameters must be numbers, booleans or strings")


def _check_name(name, where="grid"):
    if not isinstance(name, str) or not name.isidentifier() or keyword.iskeyword(name):
        raise ValueError(
            f"{where} parameter name {name!r} must be a Python identifier (it is passed to edit(**params))"
        )
    if name in RESERVED:
        raise ValueError(f"{where} parameter name {name!r} is reserved for the result; rename it")


def _product(grid: Mapping) -> Grid:
    axes = {}
    for name, values in grid.items():
        _check_name(name)
        arr = np.asarray(values)
        if arr.ndim != 1 or arr.size == 0:
            raise ValueError(f"grid[{name!r}] must be a non-empty 1-D sequence of values; got shape {arr.shape}")
        vals = [_scalar(v, f"grid[{name!r}][{i}]") for i, v in enumerate(arr.tolist())]
        if len(set(vals)) != len(vals):
            dup = sorted({v for v in vals if vals.count(v) > 1}, key=str)
            raise ValueError(f"grid[{name!r}] repeats {dup}; give each value once (the result is indexed by them)")
        axes[name] = vals
    names = tuple(axes)
    shape = tuple(len(v) for v in axes.values())
    rows = [{n: axes[n][i] for n, i in zip(names, index, strict=True)} for index in np.ndindex(*shape)]
    return Grid(rows, names, names, shape, {n: ((n,), np.asarray(axes[n])) for n in names})


def _rows(grid: Sequence) -> Grid:
    rows = []
    names = None
    for i, row in enumerate(grid):
        if not isinstance(row, Mapping):
            raise TypeError(f"grid row {i} is {type(row).__name__}; rows must be dicts of parameter values")
        if names is None:
            names = tuple(row)
            for name in names:
                _check_name(name)
        elif set(row) != set(names):
            raise ValueError(f"grid row {i} has parameters {sorted(row)}; row 0 has {sorted(names)} (all rows must)")
        rows.append({n: _scalar(row[n], f"grid row {i} {n!r}") for n in names})
    if not rows:
        raise ValueError("grid has no rows; give at least one dict of parameter values")
    coords = {n: (("variant",), np.asarray([r[n] for r in rows])) for n in names}
    coords["variant"] = (("variant",), np.arange(len(rows)))
    return Grid(rows, names, ("variant",), (len(rows),), coords)


def make_grid(grid) -> Grid:
    """Parse ``grid``: a dict of 1-D value arrays (product), a sequence of dicts (rows), or None (one variant)."""
    if grid is None or (isinstance(grid, Mapping) and not grid):
        return Grid([{}], (), (), (), {})
    if isinstance(grid, Mapping):
        return _product(grid)
    if isinstance(grid, Sequence) and not isinstance(grid, str | bytes):
        return _rows(grid)
    raise TypeError(
        f"grid must be a dict of value arrays (every combination) or a list of dicts (one per variant); got "
        f"{type(grid).__name__}"
    )

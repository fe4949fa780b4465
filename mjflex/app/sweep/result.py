"""The labelled result of a sweep: an ``xarray.Dataset`` over the grid, with a status per variant."""

import numpy as np
import xarray as xr

STATUS_DOC = (
    "ok: ran for the whole duration; diverged: MuJoCo or a flexure reported a non-finite or huge state (see "
    "error, element, time_diverged); failed: building the variant or observe raised (see error). Observed "
    "values of a variant that is not ok are NaN."
)


def schema_of(values: dict) -> dict:
    """``{name: (dims or None, shape, dtype)}`` of one ``observe`` result (as the engine stores it)."""
    return {name: (dims, arr.shape, np.complex128 if arr.dtype.kind == "c" else np.float64)
            for name, (dims, arr) in values.items()}  # fmt: skip


def _check(outcome, schema):
    """Mark ``outcome`` failed if its observed values do not match ``schema``."""
    for k, sample in enumerate(outcome.values):
        got = {name: (dims, arr.shape) for name, (dims, arr) in sample.items()}
        want = {name: (dims, shape) for name, (dims, shape, _) in schema.items()}
        if got != want:
            outcome.status = "failed"
            outcome.error = (
                f"observe returned {got} at sample {k}; the first variant returned {want} (names, dims and shapes "
                "must be the same for every variant and time)"
            )
            outcome.values = []
            return


def assemble(grid, outcomes, schema, times, attrs) -> xr.Dataset:
    """Lay ``outcomes`` (one per grid row, in order) out on the grid's dimensions.

    ``times`` are the sample times [s] (a ``time`` dimension), or None for one observation at
    the end of the run.
    """
    n = len(grid)
    lead = (n,) if times is None else (n, len(times))
    lead_dims = ("time",) if times is not None else ()
    data_vars = {}
    for o in outcomes:
        if o.status == "ok":
            _check(o, schema)
    for name, (dims, shape, dtype) in schema.items():
        arr = np.full(lead + shape, np.nan, dtype=dtype)
        for i, o in enumerate(outcomes):
            if o.status == "ok":
                stacked = np.stack([sample[name][1] for sample in o.values])
                arr[i] = stacked if times is not None else stacked[-1]
        extra = dims if dims is not None else tuple(f"{name}_{j}" for j in range(len(shape)))
        data_vars[name] = (grid.dims + lead_dims + extra, arr.reshape(grid.shape + arr.shape[1:]))
    text = {key: np.array([getattr(o, key) for o in outcomes], dtype=str).reshape(grid.shape)
            for key in ("status", "error", "element")}  # fmt: skip
    data_vars["status"] = (grid.dims, text["status"], {"description": STATUS_DOC})
    data_vars["error"] = (grid.dims, text["error"], {"description": "why a variant is not ok; '' if it is"})
    data_vars["element"] = (grid.dims, text["element"], {"description": "flexure that reported the divergence"})
    diverged = np.array([o.time_diverged for o in outcomes]).reshape(grid.shape)
    data_vars["time_diverged"] = (grid.dims, diverged, {"units": "s", "description": "start of the failing step"})
    coords = dict(grid.coords)
    if times is not None:
        coords["time"] = (("time",), np.asarray(times), {"units": "s"})
    return xr.Dataset(data_vars, coords=coords, attrs=attrs)


def summary_line(ds: xr.Dataset) -> str:
    """``'3 of 20 variants diverged, 1 failed'`` (empty when all are ok)."""
    status = np.asarray(ds["status"]).ravel()
    parts = [f"{int((status == s).sum())} {s}" for s in ("diverged", "failed") if (status == s).any()]
    return f"{', '.join(parts)} of {status.size} variants" if parts else ""

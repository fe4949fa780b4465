"""Broadcasting of batch-first arguments onto the flat ``(n, *core)`` layout of the kernels.

This sits on the per-call path of the public functions, so it avoids general machinery
(``np.broadcast_arrays`` copies) in the common cases: all batch shapes equal, or some
arguments unbatched (one K shared by all elements, omitted velocities).
"""

import math

import numpy as np


def flatten(arrays, leading, names):
    """Broadcast the leading (batch) axes of several arrays and flatten them.

    Parameters
    ----------
    arrays : sequence of ndarray
        The arguments, C-contiguous float64; their batch axes broadcast against each other.
    leading : sequence of tuple
        The batch (leading) shape of each array; the remaining axes are its core shape.
    names : iterable of str
        Argument names, for the error message when batch shapes do not broadcast.

    Returns
    -------
    batch_shape : tuple
        The broadcast batch shape.
    flat : list of ndarray
        Each array as C-contiguous float64 of shape ``(n, *core)`` with
        ``n = prod(batch_shape)``, or ``(1, *core)`` where its batch shape has a single
        element (the kernels broadcast a leading 1, so shared parameters are not copied).
    """
    distinct = {s for s in leading if s != ()}
    if len(distinct) <= 1:
        batch = distinct.pop() if distinct else ()
    else:
        try:
            batch = np.broadcast_shapes(*leading)
        except ValueError:
            listing = ", ".join(f"{name} {s}" for name, s in zip(names, leading, strict=True))
            raise ValueError(f"batch shapes do not broadcast: {listing}") from None
    n = batch[0] if len(batch) == 1 else math.prod(batch)
    flat = []
    for a, s in zip(arrays, leading, strict=True):
        if s == batch:
            if len(s) != 1:
                a = a.reshape((n, *a.shape[len(s) :]))
        elif math.prod(s) == 1:
            a = a.reshape((1, *a.shape[len(s) :]))
        else:
            a = np.ascontiguousarray(np.broadcast_to(a, batch + a.shape[len(s) :]).reshape((n, *a.shape[len(s) :])))
        flat.append(a)
    return batch, flat

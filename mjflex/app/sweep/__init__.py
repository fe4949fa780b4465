"""Sweeps over model variants: :func:`sweep` and :class:`Recipe` (also ``mjflex.sweep``, ``mjflex.Recipe``).

A sweep builds every variant of a :class:`Recipe` (a model file or text plus a module-level
``edit(spec, **params)``) over a grid of parameters, simulates it and calls
``observe(model, flex, data)``; the result is an ``xarray.Dataset`` over the grid with a status
per variant. Where the variants run:

* this process (default): parts of up to 256 variants stepped by MuJoCo's
  ``mujoco.batch.Batch`` (one model per variant, ``set_models``) on ``threads`` threads,
  bit-identical to a serial loop;
* any ``concurrent.futures`` executor: a spawn ``ProcessPoolExecutor``, or Dask's
  ``Client.get_executor()`` (``pip install "mjflex[dask]"``) from a laptop to a cluster; the
  recipe travels, models are built on the workers.

Modules: :mod:`.recipe` (the picklable model family), :mod:`.grid` (parameter grids),
:mod:`.engine` (one process's share: build, step, detect divergence, observe), :mod:`.result`
(the Dataset), :mod:`.api` (:func:`sweep`), :mod:`.arcade` (the ARCADE sweep of the command
line ``python -m mjflex sweep``).
"""

from ...mjcf.elements import edit_flexure, flexure_matrices
from .api import sweep
from .recipe import Recipe

__all__ = ["Recipe", "edit_flexure", "flexure_matrices", "sweep"]

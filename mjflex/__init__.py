"""mjflex: visco-elastic flexure elements for MuJoCo.

Two rigid bodies joined by a compliant part (notch hinge, leaf spring, bushing, disc) are
modelled by a full 6x6 stiffness ``K`` and damping ``B`` acting on their relative
displacement, written exactly as a finite twist or as a unit dual quaternion (E. D. Fasse,
*Some applications of screw theory to lumped-parameter modeling of visco-elastically coupled
rigid bodies*).

Layers (the path of an element; docs/reference/layout.md)
-----------------------------------------------------------
``mjflex.core``
    Screw theory in numpy (numba-compiled kernels); never imports mujoco. The independent
    reference the C library is tested against (and the batched API for users).
``mjflex.geometry``
    Stiffness of notch hinges and leaf springs from geometry and material; never imports
    mujoco.
``mjflex.native``
    The C library: the element math, the engine plugin ``mjflex.flexure`` (loaded by ``import
    mujoco`` itself, through the ``mujoco.plugins`` entry point ``mjflex_plugin``), the reader
    of both element forms and the ``mjcb_passive`` dispatcher; built by ``pip install``; its
    ctypes bindings (:mod:`mjflex.native.library`). Every force comes from it.
``mjflex.mjcf``
    An element in an MJCF file or an ``MjSpec``: the text record and the plugin configuration
    (:mod:`mjflex.mjcf.schema`, :mod:`mjflex.mjcf.config`), ``add_flexure``, editing and
    converting elements, joints replaced by an element.
``mjflex.runtime``
    The compiled model: its element table, :class:`Flexures` (the passive-force provider and
    every per-element query), the ``mjcb_passive`` registry, divergence reports, file conversion.
``mjflex.analysis``
    Linearization at an operating pose: statics, modes, damping from ratios, step advice.
``mjflex.variants``
    Other models of the mechanism: compliant parts, reduced models, MuJoCo-native alternatives.
``mjflex.app``
    Applications on top: the ARCADE model, simulation runs, rendering, the speed-accuracy study
    (``mjflex.study``, :mod:`mjflex.app.study`), parameter sweeps (``mjflex.sweep`` and
    ``mjflex.Recipe``, :mod:`mjflex.app.sweep`) and the command line (``python -m mjflex``).
    The study and the sweeps are imported on first use, so ``import mjflex`` stays light.

``import mjflex`` works without the C library; the first use of the runtime raises
``mjflex_plugin.NativeLibraryError``, saying how to install it. ``mjflex.mj``, the old flat
MuJoCo layer, is a deprecated alias (:mod:`mjflex.mj`).

Conventions (used everywhere in the package)
--------------------------------------------
* SI units: m, kg, s, rad, N, N m, J, W.
* 6-vectors are angular first: twists ``[omega; v]`` / ``[tau; t]``, wrenches
  ``[moment; force]``, as in the paper and in MuJoCo's ``cvel`` / ``cfrc``. 6x6 stiffness
  and damping matrices use the same order: ``K = [[K_o, K_c], [K_c^T, K_t]]``.
  Planar 3-vectors are ``[theta; x; y]`` and planar wrenches ``[moment; fx; fy]``.
* Quaternions are w-first ``(w, x, y, z)``, as in MuJoCo; dual quaternions are
  ``(w, x, y, z, w', x', y', z')`` (real part, then dual part).
* Arrays are batch-first and broadcast: ``(..., 3)``, ``(..., 6)``, ``(..., 3, 3)``,
  ``(..., 6, 6)``. Every function takes any number of leading axes.
* Frames are named in monogram style: ``R_WB`` is the orientation of frame B in frame W
  (columns are B's axes in W coordinates), ``p_WB`` the position of B's origin in W
  coordinates, ``X_AB = (R_AB, p_AB)`` the pose of B in A, so ``x_A = R_AB x_B + p_AB``.
  ``W`` is the world frame; lower-case ``a``, ``b`` are the two frames of an element.

Importing mjflex has no side effects on the environment: ``MUJOCO_GL`` is chosen only when
mjflex is asked to render and the user has not chosen (see :mod:`mjflex.app.render`). It puts a
log handler in front of MuJoCo's, which passes every message on unchanged and raises
:class:`mjflex.DivergenceWarning` beside mjflex's divergence reports (:mod:`mjflex.runtime.divergence`;
``mjflex.divergence_warnings(False)`` takes it out).
"""

import importlib
import sys

from . import analysis, core, geometry, mjcf, runtime, variants
from .analysis import *  # noqa: F403  (linearization at an operating pose, listed in analysis.__all__)
from .core import *  # noqa: F403  (the public functions of the core, listed in core.__all__)
from .core import units  # mjflex.units: conversions to SI (import mjflex.units: sys.modules below)
from .mjcf import *  # noqa: F403  (elements in MJCF and MjSpec, listed in mjcf.__all__)
from .runtime import *  # noqa: F403  (the compiled model's elements and forces, listed in runtime.__all__)
from .variants import *  # noqa: F403  (other models of the mechanism, listed in variants.__all__)

__version__ = "1.0.0"

sys.modules[f"{__name__}.units"] = units  # import mjflex.units: the same module as mjflex.core.units

#: The names of the MuJoCo layers, in one sorted list (as the old flat layer ``mjflex.mj`` listed them).
_LAYERS = sorted([*mjcf.__all__, *runtime.__all__, *analysis.__all__, *variants.__all__])
__all__ = ["geometry", *core.__all__, *_LAYERS]  # mjflex.units is a module of constants (reference: modules)

#: Imported on first use: name -> its module under mjflex.app.
_LAZY = {"study": "study", "sweep": "sweep", "Recipe": "sweep"}


def __getattr__(name):
    if name in _LAZY:  # xarray, tqdm: loaded when the study or the sweeps are first used
        return getattr(importlib.import_module(f".app.{_LAZY[name]}", __name__), name)
    if name == "mj":  # the old flat MuJoCo layer: a deprecated alias that warns (mjflex.mj's docstring)
        return importlib.import_module(".mj", __name__)
    raise AttributeError(f"module 'mjflex' has no attribute {name!r}")


def __dir__():
    return sorted([*globals(), *_LAZY])

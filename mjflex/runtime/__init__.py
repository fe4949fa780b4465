"""The compiled model's elements and their forces: the second stage of an element's path.

:mod:`.tables` reads every element of an ``MjModel`` once, through the C library (one row per
element, both forms), :mod:`.flexures` is the provider built on that table (:class:`Flexures`:
queries, run-time switches, serving copies), :mod:`.registry` the process-global
``mjcb_passive`` registry for text records (engine-plugin elements need none), :mod:`.divergence`
the divergence reports and warnings, :mod:`.contacts` MuJoCo's contact rules as the checks at rest
see them, and :mod:`.files` the conversion of a model file, checked through the compiled model's
table. Imports :mod:`mjflex.core`, :mod:`mjflex.native.library` and :mod:`mjflex.mjcf`.
"""

from .divergence import DivergenceWarning, divergence_warnings
from .files import ConversionError, convert_file
from .flexures import Flexures
from .tables import ModelError

__all__ = ["ConversionError", "DivergenceWarning", "Flexures", "ModelError", "convert_file", "divergence_warnings"]

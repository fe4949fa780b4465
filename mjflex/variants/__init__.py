"""Other models of the same mechanism, built from a source model.

A compliant part in a rigid model (:mod:`.compliance`: :func:`make_compliant`, :func:`make_rigid`;
:mod:`.placement`, :mod:`.closures`: what it places, the equality closures it reports),
a reduced model (:mod:`.reduce`: stiff directions become joints or constraints), and the
alternatives written with MuJoCo's own elements only (:mod:`.alternatives`: welds, joint springs,
tendons), with what they share (:mod:`.variant`: :class:`Variant`, sources, pose fits;
:mod:`.tree`, :mod:`.assemble`, :mod:`.planar`). Imports every layer below:
:mod:`mjflex.core`, :mod:`mjflex.native.library`, :mod:`mjflex.mjcf`, :mod:`mjflex.runtime` and
:mod:`mjflex.analysis`.
"""

from .alternatives import bushing_variant, pseudo_rigid_body_variant, weld_variant
from .closures import Closure
from .compliance import Compliance, make_compliant, make_rigid
from .reduce import ReductionWarning, reduce
from .variant import Variant, VariantNotApplicableError

__all__ = [
    "Closure",
    "Compliance",
    "ReductionWarning",
    "Variant",
    "VariantNotApplicableError",
    "bushing_variant",
    "make_compliant",
    "make_rigid",
    "pseudo_rigid_body_variant",
    "reduce",
    "weld_variant",
]

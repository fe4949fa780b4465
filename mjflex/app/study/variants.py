"""The model variants a study compares by default: the one place to plug in new ones.

Each entry is a :class:`mjflex.variants.variant.Variant` or a builder ``source -> Variant`` (or a list
of them, or None when the builder does not apply to the model), called with the study's source:
the MJCF path or ``MjSpec`` it was given, else its ``MjModel``. :func:`mjflex.app.study.study`
runs every entry of :data:`DEFAULT_VARIANTS` unless it is given ``variants=`` (``[]`` for none;
``python -m mjflex study --no-variants``). A builder that raises (e.g. a weld variant of a model
given as a compiled ``MjModel`` that MuJoCo cannot write back to XML) is reported in the study's
notes and skipped; the others still run.

Each is swept over the same integrators and steps as the full model, so each adds about the
cost of one element method to a study.
"""

import warnings

from ...variants.alternatives import pseudo_rigid_body_variant, weld_variant
from ...variants.reduce import ReductionWarning, reduce
from ...variants.variant import VariantNotApplicableError

#: Upper end of the band the default reduction keeps [Hz] (the issue's example figure).
REDUCE_KEEP_BELOW_HZ = 2000.0


def _unchanged(variant):
    """Whether a reduction kept every element whole, damping included (its rows would repeat the full model's)."""
    return all(e["kept"] and not e["damping_dropped"] for e in variant.details["elements"].values())


def reduced_variant(source):
    """:func:`mjflex.reduce` of the source, keeping its modes below :data:`REDUCE_KEEP_BELOW_HZ`.

    Raises :class:`VariantNotApplicableError` when the reduction changes nothing (it would only repeat the
    full model's rows).
    """
    variant = reduce(source, REDUCE_KEEP_BELOW_HZ)  # the band: what the band needs, whatever the step
    if _unchanged(variant):
        reasons = sorted({e["reason"] for e in variant.details["elements"].values()})
        raise VariantNotApplicableError(f"nothing to reduce below {REDUCE_KEEP_BELOW_HZ:g} Hz ({'; '.join(reasons)})")
    return variant


def reduced_at_file_step(source):
    """:func:`mjflex.reduce` of the source at the file's own step (``opt.timestep``, with its integrator).

    Raises :class:`VariantNotApplicableError` when the step holds nothing rigid (the full model runs there already),
    or when no reduction reaches it (the message names the element and direction).
    """
    try:
        with warnings.catch_warnings():  # a ReductionWarning is in the variant's report, which the study shows
            warnings.simplefilter("ignore", ReductionWarning)
            variant = reduce(source)
    except ValueError as exc:
        raise VariantNotApplicableError(str(exc)) from None
    if _unchanged(variant):
        raise VariantNotApplicableError(
            f"the file's step {variant.details['step']['timestep']:g} s holds nothing rigid"
        )
    variant.name = "reduced(file step)"
    return variant


#: Builders (or variants) every study compares with the full model unless told otherwise.
DEFAULT_VARIANTS: list = [reduced_variant, reduced_at_file_step, weld_variant, pseudo_rigid_body_variant]

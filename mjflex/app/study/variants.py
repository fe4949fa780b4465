"""The model variants a study compares by default: the one place to plug in new ones.

Each entry is a :class:`mjflex.mj.variant.Variant` or a builder ``model -> Variant`` (or a list
of them, or None when the builder does not apply to the model). :func:`mjflex.app.study.study`
runs every entry of :data:`DEFAULT_VARIANTS` unless it is given ``variants=`` (``[]`` for none;
``python -m mjflex study --no-variants``). A builder that raises is reported in the study's notes
and skipped; the others still run.

To add a builder for every study, append it here (one line), e.g.
``DEFAULT_VARIANTS.append(mjflex.reduce.reduced_builder(keep_below_hz=2000))``.
"""

#: Builders (or variants) every study compares with the full model unless told otherwise.
DEFAULT_VARIANTS: list = []

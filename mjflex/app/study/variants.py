"""The model variants a study compares by default: the one place to plug in new ones.

Each entry is a :class:`mjflex.mj.variant.Variant` or a builder ``model -> Variant`` (or a list
of them, or None when the builder does not apply to the model). :func:`mjflex.app.study.study`
runs every entry of :data:`DEFAULT_VARIANTS` unless it is given ``variants=`` (``[]`` for none;
``python -m mjflex study --no-variants``). A builder that raises is reported in the study's notes
and skipped; the others still run.

To add a builder for every study, list it here (one line per builder), e.g.
``DEFAULT_VARIANTS = [weld_variant, joint_spring_variant]`` with functions ``model -> Variant``.
Each is swept over the same integrators and steps as the full model, so each adds about the
cost of one element method to a study.
"""

#: Builders (or variants) every study compares with the full model unless told otherwise.
DEFAULT_VARIANTS: list = []

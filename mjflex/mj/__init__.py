"""Deprecated: ``mjflex.mj`` was the MuJoCo layer in one flat package, until its modules moved into layers (issue 25).

Every public name is on ``mjflex`` itself (``mjflex.Flexures``, ``mjflex.add_flexure``, ...),
and the modules are where an element's data path goes (:doc:`/reference/layout`):
:mod:`mjflex.mjcf` (an element in MJCF or an ``MjSpec``), :mod:`mjflex.runtime` (the compiled
model's elements and forces), :mod:`mjflex.analysis` (linearization, damping, step advice),
:mod:`mjflex.variants` (compliant parts, reduced and MuJoCo-only models) and
:mod:`mjflex.native.library` (the C library's bindings). ``MOVED`` maps each old module to its new
one. ``mjflex.mj.NAME`` and ``import mjflex.mj.MODULE`` keep working for now: each warns once
(``DeprecationWarning``) naming the new path, and gives the same object.
"""

import importlib
import importlib.abc
import importlib.util
import sys
import warnings

#: Old module -> the modules its names are in now (the first: where the module itself went).
MOVED = {
    "mjflex.mj._native": ("mjflex.native.library",),
    "mjflex.mj.schema": ("mjflex.mjcf.schema", "mjflex.mjcf.config"),
    "mjflex.mj.stops": ("mjflex.mjcf.stops",),
    "mjflex.mj.naming": ("mjflex.mjcf.naming",),
    "mjflex.mj.notices": ("mjflex.mjcf.notices",),
    "mjflex.mj.build": ("mjflex.mjcf.build", "mjflex.mjcf.spec", "mjflex.mjcf.elements"),
    "mjflex.mj.convert": ("mjflex.mjcf.convert", "mjflex.mjcf.elements", "mjflex.mjcf.spec", "mjflex.mjcf.schema"),
    "mjflex.mj.replace": ("mjflex.mjcf.joints",),
    "mjflex.mj.keyframes": ("mjflex.mjcf.keyframes",),
    "mjflex.mj._tables": ("mjflex.runtime.tables", "mjflex.runtime.contacts", "mjflex.mjcf.schema"),
    "mjflex.mj._contacts": ("mjflex.runtime.contacts",),
    "mjflex.mj._callback": ("mjflex.runtime.registry",),
    "mjflex.mj.divergence": ("mjflex.runtime.divergence",),
    "mjflex.mj.provider": ("mjflex.runtime.flexures", "mjflex.runtime.tables", "mjflex.runtime.divergence"),
    "mjflex.mj.file_convert": ("mjflex.runtime.files",),
    "mjflex.mj.linearize": ("mjflex.analysis.linearize", "mjflex.analysis.statics"),
    "mjflex.mj.damping": ("mjflex.analysis.damping",),
    "mjflex.mj.advice": ("mjflex.analysis.advice",),
    "mjflex.mj._directions": ("mjflex.analysis.directions",),
    "mjflex.mj.variant": ("mjflex.variants.variant", "mjflex.mjcf.spec"),
    "mjflex.mj.reduce": ("mjflex.variants.reduce",),
    "mjflex.mj.native": ("mjflex.variants.alternatives",),
    "mjflex.mj._assemble": ("mjflex.variants.assemble",),
    "mjflex.mj._tree": ("mjflex.variants.tree",),
    "mjflex.mj._planar": ("mjflex.variants.planar",),
    "mjflex.mj.compliance": ("mjflex.variants.compliance",),
}
#: The names ``mjflex.mj`` exported (all on ``mjflex`` now).
NAMES = (
    "Compliance", "ConversionError", "DivergenceWarning", "FlexureHandle", "FlexureRecord", "Flexures",
    "LikelyMistakeWarning", "ModelError", "Replacement", "StepAdvice", "Stops", "Variant", "VariantNotApplicableError",
    "add_flexure", "add_flexure_in_body_frame", "attach", "bushing_variant", "convert_file", "convert_model",
    "copy_spec", "damping_from_ratios", "divergence_warnings", "edit_elements", "make_compliant", "make_rigid",
    "normal_modes", "pseudo_rigid_body_variant", "reduce", "reference_body_poses", "remove_flexure",
    "static_equilibrium", "step_advice", "weld_variant",
)  # fmt: skip
_WARNED = set()


def _warn(old, new, stacklevel):
    if old not in _WARNED:
        _WARNED.add(old)
        warnings.warn(f"{old} is deprecated; use {new}", DeprecationWarning, stacklevel=stacklevel + 1)


def __getattr__(name):
    if name in NAMES:
        _warn(f"mjflex.mj.{name}", f"mjflex.{name}", 2)
        return getattr(importlib.import_module("mjflex"), name)
    if f"{__name__}.{name}" in MOVED:
        return importlib.import_module(f"{__name__}.{name}")  # through the finder below (it warns)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__():
    return sorted([*globals(), *NAMES, *(m.rpartition(".")[2] for m in MOVED)])


def _forward(old, homes):
    """The ``__getattr__`` of alias ``old``: a name from ``homes`` (where it is defined, else the first that has it)."""

    def get(name):
        found = [h for h in homes if hasattr(importlib.import_module(h), name)]
        if not found:
            raise AttributeError(f"module {old!r} has no attribute {name!r} (it moved: {', '.join(homes)})")
        value = getattr(importlib.import_module(found[0]), name)
        home = next((h for h in found if getattr(value, "__module__", None) == h), found[0])
        _warn(f"{old}.{name}", f"{home}.{name}", 2)
        return value

    return get


class _Moved(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """``import mjflex.mj.X``: a module that forwards every attribute to X's new modules (and warns once)."""

    def find_spec(self, fullname, path, target=None):
        return importlib.util.spec_from_loader(fullname, self) if fullname in MOVED else None

    def exec_module(self, module):
        homes = MOVED[module.__name__]
        _warn(module.__name__, " and ".join(homes), 4)
        module.__getattr__ = _forward(module.__name__, homes)
        module.__dir__ = lambda: sorted({n for h in homes for n in dir(importlib.import_module(h))})
        module.__doc__ = f"Deprecated: moved to {', '.join(homes)}."


if not any(isinstance(finder, _Moved) for finder in sys.meta_path):
    sys.meta_path.insert(0, _Moved())

"""The elements of a ``mujoco.MjSpec`` in either form: find, read, edit and write them in place.

An element is written in a model either as a text record with two sites ``E/a``, ``E/b``
(forces added by :class:`mjflex.Flexures` through ``mjcb_passive``) or as an instance of the
engine plugin ``mjflex.flexure`` (forces that belong to the model); :mod:`mjflex.mjcf.schema`
describes both. The functions here read and edit elements of a spec whatever their form, and
keep each element in the form it has, so that code built on them (the sweep's edits, the
command line's ``--method`` and ``--no-damping``, the study's method switch, the variants)
works on both:

* :func:`spec_elements`, :func:`find_element`, :func:`element_record`, :func:`flexure_matrices`
  read;
* :func:`write_record`, :func:`edit_elements` (method and switches) and :func:`edit_flexure`
  (``K`` and ``B``) change parameters in place;
* :func:`add_plugin_element`, :func:`detach_instance` write and unhook plugin instances
  (:mod:`mjflex.mjcf.convert` turns one form into the other).
"""

from dataclasses import dataclass

import mujoco
import numpy as np

from ..core import validation
from ..native import library
from . import naming, schema
from .config import config_from_record, config_sites, record_from_config
from .schema import PLUGIN, RECORD
from .spec import check_spec

#: A small model with one text-record element ``hinge`` (the examples' model).
EXAMPLE_MODEL = """<mujoco>
  <worldbody>
    <body name="A"><freejoint/><geom size="0.01" contype="0" conaffinity="0"/><site name="hinge/a"/></body>
    <body name="B"><freejoint/><geom size="0.01" contype="0" conaffinity="0"/><site name="hinge/b"/></body>
  </worldbody>
  <custom><text name="mjflex:hinge" data='{"mjflex": 1, "K": [0.3, 40, 0.25, 5e6, 3e5, 1.5e6]}'/></custom>
</mujoco>
"""


@dataclass
class SpecElement:
    """One element of a spec: its name, form, site names and the spec object that holds its parameters."""

    name: str
    kind: str  # RECORD or PLUGIN
    site_a: str
    site_b: str
    holder: "mujoco.MjsText | mujoco.MjsPlugin"
    complete: bool = True  # both sites exist in the spec

    def record(self) -> schema.FlexureRecord:
        """Its parameters; raises ValueError naming the element and what to fix."""
        if self.kind == RECORD:
            return schema.parse_text(self.name, self.holder.data)
        return record_from_config(self.name, dict(self.holder.config))


def spec_elements(spec) -> list[SpecElement]:
    """The elements of ``spec``: text records first (in file order), then plugin instances.

    A record whose sites are missing is listed with the canonical site names (``E/a``, ``E/b``);
    :class:`mjflex.Flexures` reports it when the model is built.
    """
    check_spec(spec)
    sites = _site_names(spec)
    records = (_record_element(text, sites) for text in spec.texts)
    return [e for e in records if e is not None] + [_plugin_element(p, sites) for p in flexure_instances(spec)]


def _site_names(spec):
    return {s.name for s in spec.sites if s.name}


def _record_element(text, sites):
    """The element that text ``text`` records, or None when it is not an element's record."""
    match = naming.match_record(text.name, sites)
    return None if match is None else SpecElement(match[0], RECORD, match[1], match[2], text, match[3])


def _plugin_element(plugin, sites):
    """The element of ``mjflex.flexure`` instance ``plugin`` (its sites resolved as under ``MjSpec.attach``)."""
    a, b = config_sites(dict(plugin.config), plugin.name, sites)
    return SpecElement(plugin.name, PLUGIN, a, b, plugin, a in sites and b in sites)


def _named_element(spec, name):
    """The element ``name`` found by its own record or instance name (no scan of every element), or None."""
    text = spec.text(schema.PREFIX + name)
    plugins = [p for p in spec.plugins if p.name == name and p.plugin_name == schema.PLUGIN_NAME]
    if (text is None) == (not plugins):  # none, or both forms (spec_elements lists both): the full scan says
        return None
    sites = _site_names(spec)
    return _record_element(text, sites) if text is not None else _plugin_element(plugins[0], sites)


def find_element(spec, name) -> SpecElement:
    """The element ``name`` of ``spec``; KeyError naming close matches."""
    check_spec(spec)
    found = _named_element(spec, name) if isinstance(name, str) else None
    if found is not None:  # the usual case, in O(1) spec look-ups: editing every element stays linear
        return found
    elements = spec_elements(spec)
    for e in elements:
        if e.name == name:
            return e
    names = [e.name for e in elements]
    hint = naming.suggestion(name, names, "flexures")
    raise KeyError(f"no flexure {name!r} in the spec (neither a text record nor a {schema.PLUGIN_NAME} instance){hint}")


def element_record(spec, name) -> schema.FlexureRecord:
    """The parameters of element ``name`` of ``spec`` as a :class:`~mjflex.mjcf.schema.FlexureRecord` (either form)."""
    return find_element(spec, name).record()


def write_record(spec, name, record: schema.FlexureRecord) -> None:
    """Replace the parameters of element ``name`` by ``record``, in the element's own form.

    The record is checked first, once, by the C library in the element's form (ValueError naming the
    element); the sites are not touched.
    """
    element = find_element(spec, name)
    record = schema.FlexureRecord(**{**record.__dict__, "name": element.name})
    # the site names as the element's configuration writes them (an instance's: unprefixed under attach)
    sites = element.site_a, element.site_b
    if element.kind == PLUGIN:
        sites = tuple(dict(element.holder.config).get(k, s) for k, s in zip(("site_a", "site_b"), sites, strict=True))
    config = config_from_record(record, *sites)
    schema.read_config(element.name, config, element.kind)
    if element.kind == RECORD:
        element.holder.data = record.to_text()
    else:
        element.holder.config = config


def edit_elements(spec, names=None, *, method=None, enabled=None, viscous=None) -> list[str]:
    """Set the method and run-time switches of elements of ``spec`` (either form) before it is compiled.

    What :meth:`mjflex.Flexures.set_method` & co. do at run time for text records, written into
    the spec instead, which is the only way for plugin elements (their parameters are the
    model's). Returns the names of the elements edited.

    Parameters
    ----------
    spec : mujoco.MjSpec
    names : iterable of str, optional
        The elements to edit (default: all).
    method : {"twist", "dualquat"}, optional
        Refused for an element whose polynomial terms are in the other method's coordinates.
    enabled, viscous : bool, optional
        ``viscous=True`` is refused for an element without damping ``B``.

    Examples
    --------
    >>> import mujoco, mjflex
    >>> spec = mujoco.MjSpec.from_string(mjflex.mjcf.elements.EXAMPLE_MODEL)
    >>> _ = mjflex.convert_model(spec, to="plugin")
    >>> mjflex.edit_elements(spec, method="dualquat", enabled=False)
    ['hinge']
    >>> flex = mjflex.Flexures(spec.compile())
    >>> flex.methods, flex.enabled.tolist()
    (('dualquat',), [False])
    """
    if method is not None:
        validation.method_code(method)
    for flag, what in ((enabled, "enabled"), (viscous, "viscous")):
        if flag is not None:
            validation.check_flag(flag, what)
    chosen = chosen_elements(spec, names)
    for element in chosen:
        record = element.record()
        if method is not None:
            if record.terms is not None and record.terms.method != method:
                raise ValueError(
                    f"flexure {element.name!r} has polynomial terms in {record.terms.method} coordinates, which do "
                    f"not carry over to {method}: fit (mjflex.fit_potential) or write terms for {method} instead"
                )
            record.method = method
        if enabled is not None:
            record.enabled = bool(enabled)
        if viscous is not None:
            if viscous and record.B is None:
                raise ValueError(f"flexure {element.name!r} has no damping matrix B; viscous=True needs one")
            record.viscous = bool(viscous)
        write_record(spec, element.name, record)
    return [e.name for e in chosen]


def chosen_elements(spec, names):
    elements = spec_elements(spec)
    if names is None:
        return elements
    if isinstance(names, str):
        raise TypeError(f"names must be a list of element names, not one str; use [{names!r}]")
    by_name = {e.name: e for e in elements}
    out = []
    for name in names:
        if name not in by_name:
            find_element(spec, name)  # raises with close matches
        out.append(by_name[name])
    return out


def flexure_instances(spec):
    return [p for p in spec.plugins if p.plugin_name == schema.PLUGIN_NAME and p.name]


def detach_instance(spec, name) -> None:
    """Drop the references of bodies to the ``mjflex.flexure`` instance ``name`` (before it is deleted)."""
    for body in spec.bodies:
        if body.plugin.name == name and body.plugin.plugin_name == schema.PLUGIN_NAME:
            body.plugin.active, body.plugin.name, body.plugin.plugin_name = False, "", ""


def require_native_library(element=None) -> None:
    """:class:`mjflex.native.library.NativeLibraryError` saying how to install it, unless the C library loads.

    ``element``: the name of the element being added, for the message.
    """
    try:
        library.lib()
    except library.NativeLibraryError as exc:
        who = f"flexure {element!r}: " if element else ""
        raise library.NativeLibraryError(
            f"{who}flexure elements need mjflex's native library, the engine plugin {schema.PLUGIN_NAME}: {exc}"
        ) from None


def activate_plugin(spec, element=None) -> None:
    """Let ``spec`` use the engine plugin ``mjflex.flexure`` (:func:`require_native_library` first)."""
    require_native_library(element)
    spec.activate_plugin(schema.PLUGIN_NAME)  # idempotent


def add_plugin_element(spec, record, site_a: str, site_b: str):
    """Add ``record`` to ``spec`` as an instance of ``mjflex.flexure`` between two existing sites; returns it.

    The instance is named after the element and attached to no body (MuJoCo computes it anyway).
    """
    activate_plugin(spec, record.name)
    plugin = spec.add_plugin(name=record.name, plugin_name=schema.PLUGIN_NAME, active=True)
    plugin.config = config_from_record(record, site_a, site_b)
    return plugin


def edit_flexure(spec: mujoco.MjSpec, element: str, *, K=None, B=None) -> None:
    """Replace the stiffness and/or damping of element ``element`` in ``spec`` (for ``edit`` functions).

    Parameters
    ----------
    spec : mujoco.MjSpec
        A spec holding the element, as a text record or an ``mjflex.flexure`` plugin instance
        (it stays in its form).
    element : str
        The element's name.
    K, B : array_like, optional
        New 6x6 (or 3x3 planar) matrices, or their diagonals, in the element frame, rows
        ``[rotation; translation]``, SI units; checked here by the record's rules (ValueError
        naming the element). ``B`` may be 0-size (``[]``) to remove damping.

    Examples
    --------
    >>> import mujoco
    >>> from mjflex.mjcf.elements import EXAMPLE_MODEL, edit_flexure, flexure_matrices
    >>> spec = mujoco.MjSpec.from_string(EXAMPLE_MODEL)  # one element, "hinge"
    >>> K, _ = flexure_matrices(spec, "hinge")
    >>> edit_flexure(spec, "hinge", K=2 * K, B=1e-4 * K)  # twice as stiff, Rayleigh damping
    >>> K2, B2 = flexure_matrices(spec, "hinge")
    >>> print(K2[2, 2], B2[2, 2])
    0.5 2.5e-05
    """
    record = element_record(spec, element)  # KeyError naming close matches
    if K is not None:
        record.K = schema.matrix_value(K, f"K of flexure {element!r}")
    if B is not None:
        empty = np.size(B) == 0
        record.B = None if empty else schema.matrix_value(B, f"B of flexure {element!r}")
        record.viscous = True if empty else record.viscous
    write_record(spec, element, record)


def flexure_matrices(spec: mujoco.MjSpec, element: str) -> tuple[np.ndarray, np.ndarray | None]:
    """``(K, B)`` of element ``element`` as written in ``spec`` (6x6 or 3x3; ``B`` None without damping).

    Parameters
    ----------
    spec : mujoco.MjSpec
        A spec that holds the element as a text record or an ``mjflex.flexure`` plugin instance.
    element : str
        The element's name.

    Returns
    -------
    K : ndarray, shape (6, 6) or (3, 3)
        Stiffness in the element frame, rows ``[rotation; translation]`` (N m/rad, N/m).
    B : ndarray, shape (6, 6) or (3, 3), or None
        Damping, the layout of ``K``; None without damping.

    Examples
    --------
    >>> import mujoco
    >>> from mjflex.mjcf.elements import EXAMPLE_MODEL, flexure_matrices
    >>> K, B = flexure_matrices(mujoco.MjSpec.from_string(EXAMPLE_MODEL), "hinge")
    >>> print(K.diagonal(), B)
    [3.0e-01 4.0e+01 2.5e-01 5.0e+06 3.0e+05 1.5e+06] None
    """
    record = element_record(spec, element)  # KeyError naming close matches
    return record.K, record.B

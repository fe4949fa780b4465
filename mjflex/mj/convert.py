"""The elements of an ``mujoco.MjSpec`` in either form, and conversion between the forms.

An element is written in a model either as a text record with two sites ``E/a``, ``E/b``
(forces added by :class:`mjflex.Flexures` through ``mjcb_passive``) or as an instance of the
engine plugin ``mjflex.flexure`` (forces that belong to the model); :mod:`mjflex.mj.schema`
describes both. The functions here read and edit elements of a spec whatever their form, and
keep each element in the form it has, so that code built on them (the sweep's edits, the
command line's ``--method`` and ``--no-damping``, the study's method switch, the variants)
works on both:

* :func:`spec_elements`, :func:`element_record` read; :func:`write_record` and
  :func:`edit_elements` change parameters in place;
* :func:`convert_model` turns every element into one form (:func:`records_to_plugins`,
  :func:`plugins_to_records`), losslessly: the parameters carry over bit for bit
  (configurations hold the shortest text that reads back to each double, records the JSON
  of the same doubles), the sites are not touched. :func:`mjflex.convert_file` does the same
  for a model file without rewriting the rest of the file.

Sleeping: MuJoCo ignores forces on sleeping trees, and a plugin cannot change the model's
sleep policies at run time, so :func:`keep_joined_trees_awake` writes ``sleep="never"`` on the
root bodies of the trees that an element joins to another tree or to a mocap body (what
:class:`mjflex.Flexures` does in the compiled model for text records). :func:`mjflex.add_flexure`
and :func:`convert_model` write it for every plugin element, whether the spec enables sleeping
or not: a flag that is switched on later (in the viewer's physics panel, or
``model.opt.enableflags``) then finds the trees awake.
"""

import difflib
import warnings
from dataclasses import dataclass

import mujoco

from ..core import validation
from . import schema
from .build import add_plugin_element, detach_instance

RECORD, PLUGIN = "record", "plugin"
KINDS = (PLUGIN, RECORD)

#: A small model with one text-record element ``hinge`` (the examples' model).
EXAMPLE_MODEL = """<mujoco>
  <worldbody>
    <body name="A"><freejoint/><geom size="0.01" contype="0" conaffinity="0"/><site name="hinge/a"/></body>
    <body name="B"><freejoint/><geom size="0.01" contype="0" conaffinity="0"/><site name="hinge/b"/></body>
  </worldbody>
  <custom><text name="mjflex:hinge" data='{"mjflex": 1, "K": [0.3, 40, 0.25, 5e6, 3e5, 1.5e6]}'/></custom>
</mujoco>
"""

_NEVER = mujoco.mjtSleepPolicy.mjSLEEP_NEVER
_CHOSEN = (mujoco.mjtSleepPolicy.mjSLEEP_ALLOWED, mujoco.mjtSleepPolicy.mjSLEEP_INIT)


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
        try:
            if self.kind == RECORD:
                return schema.parse_text(self.name, self.holder.data)
            return schema.record_from_config(self.name, dict(self.holder.config))
        except ValueError as exc:
            where = "text record" if self.kind == RECORD else f"{schema.PLUGIN_NAME} configuration"
            raise ValueError(f"flexure {self.name!r}: its {where} is malformed: {exc}") from None


def spec_elements(spec) -> list[SpecElement]:
    """The elements of ``spec``: text records first (in file order), then plugin instances.

    A record whose sites are missing is listed with the canonical site names (``E/a``, ``E/b``);
    :class:`mjflex.Flexures` reports it when the model is built.
    """
    _check_spec(spec)
    sites = _site_names(spec)
    records = (_record_element(text, sites) for text in spec.texts)
    return [e for e in records if e is not None] + [_plugin_element(p, sites) for p in _instances(spec)]


def _site_names(spec):
    return {s.name for s in spec.sites if s.name}


def _record_element(text, sites):
    """The element that text ``text`` records, or None when it is not an element's record."""
    match = schema.match_record(text.name, sites)
    return None if match is None else SpecElement(match[0], RECORD, match[1], match[2], text, match[3])


def _plugin_element(plugin, sites):
    """The element of ``mjflex.flexure`` instance ``plugin`` (its sites resolved as under ``MjSpec.attach``)."""
    a, b = schema.config_sites(dict(plugin.config), plugin.name, sites)
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
    _check_spec(spec)
    found = _named_element(spec, name) if isinstance(name, str) else None
    if found is not None:  # the usual case, in O(1) spec look-ups: editing every element stays linear
        return found
    elements = spec_elements(spec)
    for e in elements:
        if e.name == name:
            return e
    names = [e.name for e in elements]
    close = difflib.get_close_matches(str(name), names, n=3)
    hint = f"; did you mean {close}?" if close else (f"; its flexures are {names[:10]}" if names else "")
    raise KeyError(f"no flexure {name!r} in the spec (neither a text record nor a {schema.PLUGIN_NAME} instance){hint}")


def element_record(spec, name) -> schema.FlexureRecord:
    """The parameters of element ``name`` of ``spec`` as a :class:`~mjflex.mj.schema.FlexureRecord` (either form)."""
    return find_element(spec, name).record()


def write_record(spec, name, record: schema.FlexureRecord) -> None:
    """Replace the parameters of element ``name`` by ``record``, in the element's own form.

    The record is checked by the schema's rules first (ValueError naming the element); the
    sites are not touched.
    """
    element = find_element(spec, name)
    record = schema.FlexureRecord(**{**record.__dict__, "name": element.name})
    text = record.to_text()
    try:
        schema.parse_text(element.name, text)
    except ValueError as exc:
        raise ValueError(f"flexure {element.name!r}: {exc}") from None
    if element.kind == RECORD:
        element.holder.data = text
    else:
        element.holder.config = schema.config_from_record(record, *_config_sites(element))


def _config_sites(element):
    """The site names as the instance's configuration writes them (unprefixed under attach)."""
    config = dict(element.holder.config)
    return config.get("site_a", element.site_a), config.get("site_b", element.site_b)


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
    >>> spec = mujoco.MjSpec.from_string(mjflex.mj.convert.EXAMPLE_MODEL)
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
    chosen = _chosen(spec, names)
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


def _chosen(spec, names):
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


# ----------------------------------------------------------------------------- copies and composition


def _instances(spec):
    return [p for p in spec.plugins if p.plugin_name == schema.PLUGIN_NAME and p.name]


def _restore_instances(target, instances, prefix="", suffix=""):
    """Add to ``target`` the instances (name, config) it lacks, named ``prefix + name + suffix``."""
    present = {p.name for p in target.plugins}
    added = []
    for name, config in instances:
        new = prefix + name + suffix
        if new not in present:
            target.activate_plugin(schema.PLUGIN_NAME)
            plugin = target.add_plugin(name=new, plugin_name=schema.PLUGIN_NAME, active=True)
            plugin.config = config
            added.append(new)
    return added


def copy_spec(spec) -> "mujoco.MjSpec":
    """``spec.copy()`` that keeps the ``mjflex.flexure`` instances.

    MuJoCo 4.0's ``MjSpec.copy`` (and ``MjSpec.attach``) copies only the plugin instances that a
    body, geom, mesh, actuator or sensor references; an element's instance is referenced by none
    (a body holds one plugin, and a body may join many elements), so the copy would silently lose
    every element. This copies and adds them back, configuration strings unchanged.

    Parameters
    ----------
    spec : mujoco.MjSpec
        The spec to copy (not modified).

    Examples
    --------
    >>> import mujoco, mjflex
    >>> spec = mujoco.MjSpec.from_string(mjflex.mj.convert.EXAMPLE_MODEL)
    >>> _ = mjflex.convert_model(spec, to="plugin")
    >>> len(spec.copy().plugins), len(mjflex.copy_spec(spec).plugins)
    (0, 1)
    """
    _check_spec(spec)
    kept = [(p.name, dict(p.config)) for p in _instances(spec)]
    copy = spec.copy()
    _restore_instances(copy, kept)
    return copy


def attach(parent, child, *, prefix="", suffix="", **where):
    """Attach ``child`` to ``parent`` as ``MjSpec.attach`` does, keeping the child's plugin elements.

    ``MjSpec.attach`` prefixes and suffixes every name of the child, its text records and plugin
    instances too, but (MuJoCo 4.0) drops the plugin instances no body references, i.e. the
    child's ``mjflex.flexure`` elements (:func:`copy_spec` says why). This attaches, then adds
    them back as ``prefix + name + suffix`` with their configurations unchanged: the plugin and
    :class:`mjflex.Flexures` find their sites ``prefix + site + suffix`` by the instance's name.
    Returns what ``MjSpec.attach`` returns. For several copies of one child, attach a copy each
    time (:func:`copy_spec`; MuJoCo attaches a spec once by reference) with different prefixes.

    Parameters
    ----------
    parent, child : mujoco.MjSpec
        The spec attached to (modified) and the one attached.
    prefix, suffix : str
        Added to every name of the child (MuJoCo's rule).
    **where
        ``frame=`` (an ``MjsFrame`` of the parent) or ``site=`` (an ``MjsSite``), as for ``MjSpec.attach``.

    Examples
    --------
    >>> import mujoco, mjflex
    >>> child = mujoco.MjSpec.from_string(mjflex.mj.convert.EXAMPLE_MODEL)
    >>> _ = mjflex.convert_model(child, to="plugin")
    >>> parent = mujoco.MjSpec()
    >>> for prefix in ("left-", "right-"):
    ...     _ = mjflex.attach(parent, mjflex.copy_spec(child), prefix=prefix, frame=parent.worldbody.add_frame())
    >>> mjflex.Flexures(parent.compile()).names
    ('left-hinge', 'right-hinge')
    """
    _check_spec(parent)
    _check_spec(child)
    kept = [(p.name, dict(p.config)) for p in _instances(child)]
    out = parent.attach(child, prefix=prefix, suffix=suffix, **where)
    _restore_instances(parent, kept, prefix, suffix)
    return out


# ----------------------------------------------------------------------------- conversion


def records_to_plugins(spec, names=None) -> list[str]:
    """Turn text-record elements of ``spec`` (all, or ``names``) into ``mjflex.flexure`` instances, in place.

    The parameters carry over exactly (:func:`mjflex.mj.schema.config_from_record`), the sites
    stay where they are, and the trees the elements join get ``sleep="never"``
    (:func:`keep_joined_trees_awake`). Returns the converted elements' names.
    """
    chosen = [e for e in _chosen(spec, names) if e.kind == RECORD]
    for e in chosen:
        if not e.complete:
            raise ValueError(f"flexure {e.name!r}: its text record has no sites {e.site_a!r} and {e.site_b!r} in the "
                             "spec; add them (mjflex.add_flexure writes both) or remove the record")  # fmt: skip
    records = [e.record() for e in chosen]
    for element, record in zip(chosen, records, strict=True):
        spec.delete(element.holder)
        add_plugin_element(spec, record, element.site_a, element.site_b)
    if chosen:
        keep_joined_trees_awake(spec, [(e.name, e.site_a, e.site_b) for e in chosen])
    return [e.name for e in chosen]


def plugins_to_records(spec, names=None) -> list[str]:
    """Turn ``mjflex.flexure`` instances of ``spec`` (all, or ``names``) into text records, in place.

    A text record finds its sites by the element's name, so the instance's sites must be named
    ``E/a`` and ``E/b`` (or ``E.a``, ``E.b``; under ``MjSpec.attach`` with the instance's prefix
    and suffix): ValueError naming the element otherwise, before anything is changed. Bodies
    that referenced the instance (``<plugin instance="E"/>``) lose the reference. The
    ``<extension>`` declaration of the plugin stays in the spec (MjSpec cannot remove it), so
    ``spec.to_xml()`` still names it; :func:`mjflex.convert_file` removes it from files.
    Returns the converted elements' names.
    """
    chosen = [e for e in _chosen(spec, names) if e.kind == PLUGIN]
    plan = [(e, e.record(), record_text_name(e.name, e.site_a, e.site_b)) for e in chosen]
    for element, _, text_name in plan:
        if spec.text(text_name) is not None:
            raise ValueError(f"flexure {element.name!r}: the spec already has a text {text_name!r}; remove it first")
    for element, record, text_name in plan:
        detach_instance(spec, element.name)
        spec.delete(element.holder)
        spec.add_text(name=text_name, data=record.to_text())
    return [e.name for e, *_ in plan]


def record_text_name(element: str, site_a: str, site_b: str) -> str:
    """The text record's name of an element ``P + E + S`` with sites ``P + E + "/a" + S`` (``"." `` too).

    Raises ValueError naming the element and the fix when the sites are not named that way.
    """
    n = len(element)
    for i in range(n + 1):  # the longest E first, as schema.match_record reads it back
        for j in range(n, i - 1, -1):
            head, core, tail = element[:i], element[i:j], element[j:]
            for sep in schema.SITE_SEPARATORS:
                if (site_a, site_b) == (head + core + sep + "a" + tail, head + core + sep + "b" + tail):
                    return head + schema.PREFIX + core + tail
    raise ValueError(
        f"flexure {element!r}: its sites are {site_a!r} and {site_b!r}, but a text record finds its sites by the "
        f"element's name ({element + schema.SITE_A_SUFFIX!r} and {element + schema.SITE_B_SUFFIX!r}); rename the "
        "sites, or keep the element a plugin instance"
    )


def convert_model(spec, to=PLUGIN) -> list[str]:
    """Write every element of ``spec`` in one form, in place; returns the names of the elements converted.

    Parameters
    ----------
    spec : mujoco.MjSpec
    to : {"plugin", "record"}
        ``"plugin"``: instances of the engine plugin ``mjflex.flexure`` (:func:`records_to_plugins`;
        needs mjflex's native library); ``"record"``: text records (:func:`plugins_to_records`).

    Raises ValueError when the spec holds no element, or every element is in that form already.

    Examples
    --------
    >>> import mujoco, mjflex
    >>> spec = mujoco.MjSpec.from_string(mjflex.mj.convert.EXAMPLE_MODEL)  # one text record, "hinge"
    >>> mjflex.convert_model(spec, to="plugin")
    ['hinge']
    >>> [p.name for p in spec.plugins], len(spec.texts)
    (['hinge'], 0)
    >>> mjflex.convert_model(spec, to="record")
    ['hinge']
    >>> mjflex.Flexures(spec.compile()).kinds
    ('record',)
    """
    if to not in KINDS:
        raise ValueError(f'to must be "plugin" or "record"; got {validation.shorten(to)}')
    elements = spec_elements(spec)
    if not elements:
        raise ValueError(
            f"the spec holds no mjflex elements (text records {schema.PREFIX}E with sites E/a, E/b, or "
            f"{schema.PLUGIN_NAME} instances); there is nothing to convert"
        )
    if all(e.kind == to for e in elements):
        raise ValueError(f"every element of the spec ({len(elements)}) is already {_form(to)}; nothing to convert")
    return records_to_plugins(spec) if to == PLUGIN else plugins_to_records(spec)


def _form(kind):
    return f"an {schema.PLUGIN_NAME} plugin instance" if kind == PLUGIN else "a text record"


# ----------------------------------------------------------------------------- sleeping


def _moves(body):
    return len(body.joints) > 0


def _tree_root(spec, body):
    """The root body of the kinematic tree that moves ``body`` (the topmost body with joints above it), or None."""
    root = None
    while body is not None and body is not spec.worldbody and body.name != "world":
        if _moves(body):
            root = body
        body = body.parent
    return root


def _mocap(body):
    return bool(getattr(body, "mocap", False))


def keep_joined_trees_awake(spec, elements) -> list[str]:
    """Write ``sleep="never"`` on the root body of every tree an element joins to another tree or a mocap body.

    ``elements``: ``(name, site a, site b)`` of the elements. A root whose sleep policy the model
    chose explicitly (``allowed`` or ``init``) is kept, with a warning naming the element (the
    element's force is lost while its tree sleeps). Returns the names of the bodies set.
    """
    changed, kept = [], []
    for name, site_a, site_b in elements:
        bodies = [spec.site(s).parent if spec.site(s) is not None else None for s in (site_a, site_b)]
        if any(b is None for b in bodies):
            continue
        roots = [_tree_root(spec, b) for b in bodies]
        if roots[0] is roots[1] and roots[0] is not None:
            continue  # one tree: the force is internal to it
        mocap = any(_mocap(b) for b in bodies)
        if all(r is None for r in roots) or (None in roots and not mocap):
            continue  # grounded to a static body: the tree may sleep in balance
        for root in roots:
            if root is None:
                continue
            if root.sleep in _CHOSEN:
                kept.append((name, root.name or "(unnamed)", root.sleep))
            elif root.sleep != _NEVER:
                root.sleep = _NEVER
                changed.append(root.name)
    if kept:
        name, body, policy = kept[0]
        warnings.warn(
            f"mjflex: flexure {name!r} joins the tree of body {body!r}, whose sleep policy "
            f"{mujoco.mjtSleepPolicy(policy).name} lets it sleep (and {len(kept) - 1} more): MuJoCo ignores forces on "
            'sleeping trees, so the element\'s force is lost while it sleeps. Set sleep="never" (or "auto") on the '
            "tree's root body, or keep sleeping disabled.",
            UserWarning,
            stacklevel=3,
        )
    return changed


def _check_spec(spec):
    if not isinstance(spec, mujoco.MjSpec):
        raise TypeError(f"spec must be a mujoco.MjSpec; got {type(spec).__name__}")


__all__ = [
    "EXAMPLE_MODEL",
    "KINDS",
    "PLUGIN",
    "RECORD",
    "SpecElement",
    "attach",
    "convert_model",
    "copy_spec",
    "edit_elements",
    "element_record",
    "find_element",
    "keep_joined_trees_awake",
    "plugins_to_records",
    "record_text_name",
    "records_to_plugins",
    "spec_elements",
    "write_record",
]

"""Converting the elements of a ``mujoco.MjSpec`` between the two forms, and composing specs that hold them.

* :func:`convert_model` turns every element into one form (:func:`records_to_plugins`,
  :func:`plugins_to_records`), losslessly: the parameters carry over bit for bit
  (configurations hold the shortest text that reads back to each double, records the JSON
  of the same doubles), the sites are not touched. :func:`mjflex.convert_file` does the same
  for a model file without rewriting the rest of the file.
* :func:`copy_spec` and :func:`attach` are ``MjSpec.copy`` and ``MjSpec.attach`` that keep the
  plugin instances (MuJoCo 4.0 drops the unreferenced ones); :func:`spec_xml` is ``MjSpec.to_xml``
  without a declaration of the plugin that no instance uses (MjSpec cannot take one back).

Reading and editing elements in place: :mod:`mjflex.mjcf.elements`.
"""

import re

import mujoco

from ..core import validation
from . import schema
from .elements import add_plugin_element, chosen_elements, detach_instance, flexure_instances, spec_elements
from .schema import KINDS, PLUGIN, RECORD
from .spec import check_spec, keep_joined_trees_awake

# ----------------------------------------------------------------------------- copies and composition


#: The configuration keys that name sites: MjSpec.attach renames the sites, so attach renames these with them
SITE_KEYS = ("site_a", "site_b", "site")


def _restore_instances(target, instances, prefix="", suffix=""):
    """Add to ``target`` the instances (name, config) it lacks, named ``prefix + name + suffix``, their site names
    (:data:`SITE_KEYS`) as attached too."""
    present = {p.name for p in target.plugins}
    added = []
    for name, config in instances:
        new = prefix + name + suffix
        if new not in present:
            target.activate_plugin(schema.PLUGIN_NAME)
            plugin = target.add_plugin(name=new, plugin_name=schema.PLUGIN_NAME, active=True)
            renamed = {k: prefix + config[k].strip() + suffix for k in SITE_KEYS if config.get(k, "").strip()}
            plugin.config = config | renamed
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
    >>> spec = mujoco.MjSpec.from_string(mjflex.mjcf.elements.EXAMPLE_MODEL)
    >>> _ = mjflex.convert_model(spec, to="plugin")
    >>> len(spec.copy().plugins), len(mjflex.copy_spec(spec).plugins)
    (0, 1)
    """
    check_spec(spec)
    kept = [(p.name, dict(p.config)) for p in flexure_instances(spec)]
    copy = spec.copy()
    _restore_instances(copy, kept)
    return copy


def attach(parent, child, *, prefix="", suffix="", **where):
    """Attach ``child`` to ``parent`` as ``MjSpec.attach`` does, keeping the child's plugin elements.

    ``MjSpec.attach`` prefixes and suffixes every name of the child, its text records and plugin
    instances too, but (MuJoCo 4.0) drops the plugin instances no body references, i.e. the
    child's ``mjflex.flexure`` elements (:func:`copy_spec` says why). This attaches, then adds
    them back as ``prefix + name + suffix``, their configurations naming the sites as attached
    (``prefix + site + suffix``). A configuration that mjflex 1.0 attached (its site names as the
    child wrote them) still reads: the plugin and :class:`mjflex.Flexures` find those sites under the
    instance's own prefix and suffix (:func:`mjflex.mjcf.config.attached_names`).
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
    >>> child = mujoco.MjSpec.from_string(mjflex.mjcf.elements.EXAMPLE_MODEL)
    >>> _ = mjflex.convert_model(child, to="plugin")
    >>> parent = mujoco.MjSpec()
    >>> for prefix in ("left-", "right-"):
    ...     _ = mjflex.attach(parent, mjflex.copy_spec(child), prefix=prefix, frame=parent.worldbody.add_frame())
    >>> mjflex.Flexures(parent.compile()).names
    ('left-hinge', 'right-hinge')
    """
    check_spec(parent)
    check_spec(child)
    kept = [(p.name, dict(p.config)) for p in flexure_instances(child)]
    out = parent.attach(child, prefix=prefix, suffix=suffix, **where)
    _restore_instances(parent, kept, prefix, suffix)
    return out


# ----------------------------------------------------------------------------- conversion


#: The ``<plugin plugin="mjflex.flexure"/>`` that MuJoCo's writer gives a declaration without instances, and an
#: ``<extension>`` left empty (with the blank line after it), as ``MjSpec.to_xml`` writes them.
_UNUSED = re.compile(r'^[ \t]*<plugin plugin="' + re.escape(schema.PLUGIN_NAME) + r'"\s*/>[ \t]*\n', re.MULTILINE)
_EMPTY = re.compile(r"^[ \t]*<extension>\s*</extension>[ \t]*\n(?:[ \t]*\n)?", re.MULTILINE)


def spec_xml(spec) -> str:
    """``spec.to_xml()`` without a declaration of the engine plugin ``mjflex.flexure`` that no instance uses.

    MuJoCo's ``MjSpec`` cannot take back a plugin declaration: after the last plugin element of a
    spec is removed (:func:`mjflex.make_rigid`, :func:`mjflex.remove_flexure`,
    :func:`mjflex.convert_model` to records), ``spec.to_xml()`` still writes
    ``<extension><plugin plugin="mjflex.flexure"/></extension>``, and a MuJoCo without mjflex
    refuses to load that file ("plugin mjflex.flexure not found"). This writes the same text
    without it (and without an ``<extension>`` left empty); a declaration that instances use is
    kept, and nothing else changes.

    Parameters
    ----------
    spec : mujoco.MjSpec
        The spec to write (not modified).

    Returns
    -------
    str
        The MJCF text.

    Examples
    --------
    >>> import mujoco, mjflex
    >>> spec = mujoco.MjSpec.from_string(mjflex.mjcf.elements.EXAMPLE_MODEL)
    >>> _ = mjflex.convert_model(spec, to="plugin")  # its element "hinge" as a plugin instance
    >>> mjflex.remove_flexure(spec, "hinge")
    >>> "mjflex.flexure" in spec.to_xml(), "mjflex.flexure" in mjflex.spec_xml(spec)
    (True, False)
    """
    check_spec(spec)
    return _EMPTY.sub("", _UNUSED.sub("", spec.to_xml()))


def records_to_plugins(spec, names=None) -> list[str]:
    """Turn text-record elements of ``spec`` (all, or ``names``) into ``mjflex.flexure`` instances, in place.

    The parameters carry over exactly (:func:`mjflex.mjcf.config.config_from_record`), the sites
    stay where they are, and the trees the elements join get ``sleep="never"``
    (:func:`keep_joined_trees_awake`). Returns the converted elements' names.
    """
    chosen = [e for e in chosen_elements(spec, names) if e.kind == RECORD]
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
    chosen = [e for e in chosen_elements(spec, names) if e.kind == PLUGIN]
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
    for i in range(n + 1):  # the longest E first, as naming.match_record reads it back
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
    >>> spec = mujoco.MjSpec.from_string(mjflex.mjcf.elements.EXAMPLE_MODEL)  # one text record, "hinge"
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
        form = f"an {schema.PLUGIN_NAME} plugin instance" if to == PLUGIN else "a text record"
        raise ValueError(f"every element of the spec ({len(elements)}) is already {form}; nothing to convert")
    return records_to_plugins(spec) if to == PLUGIN else plugins_to_records(spec)


__all__ = ["attach", "convert_model", "copy_spec", "plugins_to_records", "record_text_name", "records_to_plugins"]

"""Convert a model file between text records and ``mjflex.flexure`` plugin instances, and nothing else.

:func:`convert_file` edits the MJCF document itself (Python's ``xml.etree``, comments kept), not a
``mujoco.MjSpec``: ``MjSpec.to_xml()`` would write every other number of the file with 6
significant digits and inline its includes. Only the elements' records or instances change
(and ``sleep="never"`` on the trees plugin elements join, see :mod:`mjflex.mjcf.convert`); the
text before the ``<mujoco>`` tag is kept verbatim, every other element and attribute keeps its
value. The result is checked before it replaces the target: the converted file is compiled,
and every element must hold exactly the parameters it had (every double bit for bit, the
source text verbatim) in the new form.
"""

import os
import re
import tempfile
import warnings
import xml.etree.ElementTree as ET

import mujoco

from ..core.validation import shorten
from ..mjcf import naming, schema
from ..mjcf.config import config_from_record, record_from_config
from ..mjcf.convert import record_text_name
from ..mjcf.schema import KINDS, PLUGIN, RECORD
from ..native import library
from .tables import derive, names

_ROOT = re.compile(r"<mujoco[\s>/]")
_CDATA = "mjflex-cdata-{}-placeholder"
_EMPTY = re.compile(r"(<[^<>!?]*?) />")  # ElementTree writes <a />; MJCF files (MuJoCo's and ours) write <a/>


class ConversionError(ValueError):
    """A model file cannot be converted; the message (one line) names the file or element and the fix."""


def convert_file(source, target, to=PLUGIN) -> list[str]:
    """Write the model file ``source`` to ``target`` with every element in one form; returns the converted names.

    Parameters
    ----------
    source, target : str or os.PathLike
        MJCF files; ``target`` may be ``source`` (converted in place). Only the elements written
        in ``source`` itself are converted (not those of an ``<include>``\\ d or attached file).
    to : {"plugin", "record"}
        ``"plugin"``: instances of the engine plugin ``mjflex.flexure`` (needs mjflex's native
        library); ``"record"``: text records (works without it; every instance's sites must be
        named ``E/a``, ``E/b``).

    Raises :class:`ConversionError` (a ValueError) with a one-line message for a file that is
    missing or not MJCF, a model MuJoCo or mjflex refuses, a file without elements, one whose
    elements are all in the target form already, and a target that cannot be written. A model
    holding both forms has the others converted.

    Examples
    --------
    >>> import os, tempfile, mjflex
    >>> folder = tempfile.mkdtemp()
    >>> source, out = os.path.join(folder, "record.xml"), os.path.join(folder, "plugin.xml")
    >>> with open(source, "w") as f:
    ...     _ = f.write(mjflex.mjcf.elements.EXAMPLE_MODEL)  # one text record, "hinge"
    >>> mjflex.convert_file(source, out, to="plugin")
    ['hinge']
    >>> mjflex.convert_file(out, out, to="record")  # and back, in place
    ['hinge']
    """
    if to not in KINDS:
        raise ConversionError(f'to must be "plugin" or "record"; got {shorten(to)}')
    source, target = os.fspath(source), os.fspath(target)
    _check_target(target)
    prefix, root = _read(source)
    records, instances = _record_nodes(root), _instance_nodes(root)
    if not records and not instances:
        raise ConversionError(
            f"{source} holds no mjflex elements (text records {schema.PREFIX}E in <custom>, or instances of "
            f"{schema.PLUGIN_NAME} in <extension>); there is nothing to convert"
        )
    if to == PLUGIN:
        if not records:
            raise ConversionError(f"every element of {source} is already an {schema.PLUGIN_NAME} plugin instance; "
                                  "nothing to convert (--to record converts back)")  # fmt: skip
        expected = _to_plugins(source, root, records)
    else:
        if not instances:
            raise ConversionError(f"every element of {source} is already a text record; nothing to convert "
                                  "(--to plugin converts them)")  # fmt: skip
        expected = _to_records(source, root, instances)
    _write_checked(source, target, prefix + _serialize(root) + "\n", expected, to)
    return list(expected)


# ----------------------------------------------------------------------------- reading


def _check_target(target):
    folder = os.path.dirname(os.path.abspath(target))
    if os.path.isdir(target):
        raise ConversionError(f"the output {target!r} is a folder; give a file name")
    if not os.path.isdir(folder):
        raise ConversionError(f"cannot write {target!r}: the folder {folder!r} does not exist")
    if not os.access(folder, os.W_OK) or (os.path.exists(target) and not os.access(target, os.W_OK)):
        raise ConversionError(f"cannot write {target!r}: permission denied; choose another output file")


def _read(source):
    if not os.path.isfile(source):
        raise ConversionError(f"model file {source!r} not found")
    try:
        with open(source, encoding="utf-8") as f:
            text = f.read()
    except (OSError, UnicodeDecodeError) as exc:
        raise ConversionError(f"cannot read {source!r} as an MJCF (UTF-8 XML) file: {exc}") from None
    parser = ET.XMLParser(target=ET.TreeBuilder(insert_comments=True))
    try:
        root = ET.fromstring(text, parser=parser)
    except ET.ParseError as exc:
        raise ConversionError(f"{source} is not an MJCF file: it is not well-formed XML ({exc})") from None
    match = _ROOT.search(text)
    if root.tag != "mujoco" or match is None:
        raise ConversionError(f"{source} is not an MJCF file: its root element is <{root.tag}>, not <mujoco>")
    return text[: match.start()], root


def _record_nodes(root):
    """``[(custom, text node, name, data)]`` of the ``mjflex:`` text records written in this file."""
    out = []
    for custom in root.findall("custom"):
        for node in custom.findall("text"):
            name = node.get("name", "")
            if schema.PREFIX in name:
                data = node.get("data")
                out.append((custom, node, name, data if data is not None else (node.text or "")))
    return out


def _instance_nodes(root):
    """``[(plugin node, instance node, name, config)]`` of the ``mjflex.flexure`` instances of this file."""
    out = []
    for extension in root.findall("extension"):
        for plugin in extension.findall("plugin"):
            if plugin.get("plugin") != schema.PLUGIN_NAME:
                continue
            for node in plugin.findall("instance"):
                config = {c.get("key", ""): c.get("value", "") for c in node.findall("config")}
                out.append((plugin, node, node.get("name", ""), config))
    return out


def _compile(path, what):
    try:
        model = mujoco.MjModel.from_xml_path(path)
    except ValueError as exc:
        raise ConversionError(f"MuJoCo cannot load {what}: {_one_line(exc)}") from None
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # contacts and misspelt records: reported when the model is used
            return model, derive(model)
    except ValueError as exc:
        raise ConversionError(f"{what}: {_one_line(exc)}") from None


def _one_line(exc):
    return " ".join(str(exc).split())


# ----------------------------------------------------------------------------- the two directions


def _to_plugins(source, root, records):
    try:
        library.lib()
    except library.NativeLibraryError as exc:
        raise ConversionError(f"plugin elements need mjflex's native library: {_one_line(exc)}") from None
    model, tables = _compile(source, source)
    sites = set(names(model, mujoco.mjtObj.mjOBJ_SITE, model.nsite)) - {""}
    expected, plugin, unit = {}, None, _unit(root)
    for custom, node, name, data in records:
        try:
            match = naming.match_record(name, sites)
        except ValueError as exc:
            raise ConversionError(f"text record {name!r}: {exc}") from None
        element, site_a, site_b, _ = match
        record = schema.parse_text(element, data)  # valid: the model compiled and was read above
        plugin = plugin if plugin is not None else _plugin_node(root, unit)
        instance = ET.Element("instance", {"name": element})
        for key, value in config_from_record(record, site_a, site_b).items():
            instance.append(ET.Element("config", {"key": key, "value": value}))
        _remove(custom, node)
        _append(plugin, instance, 3, unit)
        expected[element] = record
    for custom in root.findall("custom"):
        if not len(custom):
            _remove(root, custom)
    _keep_awake(root, model, tables, set(expected))
    return expected


def _to_records(source, root, instances):
    planned = []
    for plugin, node, name, config in instances:
        if not name:
            raise ConversionError(f"{source}: an instance of {schema.PLUGIN_NAME} has no name; name it")
        try:
            record = record_from_config(name, config)
            text_name = record_text_name(name, config.get("site_a", ""), config.get("site_b", ""))
        except ValueError as exc:
            raise ConversionError(f"flexure {name!r}: {_one_line(exc)}") from None
        planned.append((plugin, node, name, record, text_name))
    custom, unit = root.find("custom"), _unit(root)
    if custom is None:  # where MuJoCo's writer puts it: before the keyframes
        custom, children = ET.Element("custom"), list(root)
        at = next((i for i, c in enumerate(children) if c.tag == "keyframe"), len(children))
        _insert(root, at, custom, 1, unit)
    expected = {}
    for plugin, node, name, record, text_name in planned:
        _remove(plugin, node)
        refs = [(parent, ref) for parent in root.iter() for ref in parent.findall("plugin")]
        for parent, ref in [(p, r) for p, r in refs if r.get("instance") == name]:
            _remove(parent, ref)
        text = ET.Element("text", {"name": text_name})
        text.text = record.to_text()
        _append(custom, text, 2, unit)
        expected[name] = record
    for extension in root.findall("extension"):
        for plugin in extension.findall("plugin"):
            if plugin.get("plugin") == schema.PLUGIN_NAME and not plugin.findall("instance"):
                _remove(extension, plugin)
        if not len(extension):
            _remove(root, extension)
    return expected


def _plugin_node(root, unit):
    """The ``<plugin plugin="mjflex.flexure">`` of ``<extension>``, created (before ``<worldbody>``) if missing."""
    for extension in root.findall("extension"):
        for plugin in extension.findall("plugin"):
            if plugin.get("plugin") == schema.PLUGIN_NAME:
                return plugin
    extension = root.find("extension")
    if extension is None:
        extension = ET.Element("extension")
        children = list(root)
        at = next((i for i, c in enumerate(children) if c.tag == "worldbody"), len(children))
        _insert(root, at, extension, 1, unit)
    plugin = ET.Element("plugin", {"plugin": schema.PLUGIN_NAME})
    _append(extension, plugin, 2, unit)
    return plugin


def _keep_awake(root, model, tables, converted):
    """``sleep="never"`` on the root bodies of the trees the converted elements join (module docstring)."""
    bodies = {b.get("name"): b for b in root.iter("body") if b.get("name")}
    trees = {}
    for e, element in enumerate(tables.names):
        if element not in converted:
            continue
        ends = [int(b) for b in tables.elements[e][["body_a", "body_b"]].tolist()]
        found = [int(model.body_treeid[b]) for b in ends]
        mocap = any(model.body_mocapid[b] >= 0 for b in ends)
        if found[0] != found[1] and (min(found) >= 0 or mocap):
            trees.update({t: element for t in found if t >= 0 and t not in trees})
    for tree, element in sorted(trees.items()):
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, int(model.tree_bodyadr[tree])) or ""
        node = bodies.get(name)
        if node is None:
            warnings.warn(f"mjflex: flexure {element!r} joins the tree of body {name or '(unnamed)'!r}, which is not "
                          'written in this file: give its root body sleep="never" where it is written, or keep '
                          "sleeping disabled", UserWarning, stacklevel=4)  # fmt: skip
        elif node.get("sleep") in ("allowed", "init"):
            warnings.warn(f"mjflex: flexure {element!r} joins the tree of body {name!r}, whose sleep policy "
                          f"{node.get('sleep')!r} lets it sleep, and MuJoCo ignores forces on sleeping trees: set "
                          'sleep="never" on it, or keep sleeping disabled', UserWarning, stacklevel=4)  # fmt: skip
        elif node.get("sleep") in (None, "auto"):
            node.set("sleep", "never")


# ----------------------------------------------------------------------------- writing


def _unit(root):
    """The document's indentation step (the white space before the first child of ``<mujoco>``)."""
    text = root.text or ""
    return text[text.rindex("\n") + 1 :] if "\n" in text and text[text.rindex("\n") + 1 :].strip() == "" else "  "


def _append(parent, child, depth, unit):
    """Append ``child`` (at ``depth``: 1 under ``<mujoco>``) with the document's indentation."""
    _insert(parent, len(parent), child, depth, unit)


def _insert(parent, at, child, depth, unit):
    ET.indent(child, space=unit, level=depth)
    inner, close = "\n" + unit * depth, "\n" + unit * (depth - 1)
    if not len(parent):
        parent.text, child.tail = inner, close
    elif at >= len(parent):  # the separation the document uses between siblings (MuJoCo's writer: a blank line)
        children = list(parent)
        between = children[-2].tail if len(children) > 1 and (children[-2].tail or "").strip() == "" else inner
        child.tail, children[-1].tail = close, between
    else:  # the separation the document uses before the next sibling (MuJoCo's writer: a blank line)
        child.tail = (list(parent)[at - 1].tail if at > 0 else parent.text) or inner
    parent.insert(at, child)


def _remove(parent, child):
    """Remove ``child`` with the whitespace before it, keeping the parent's closing indentation."""
    children = list(parent)
    i = children.index(child)
    if i == len(children) - 1 and i > 0:
        children[i - 1].tail = child.tail
    elif i == len(children) - 1:
        parent.text = None if not (child.tail or "").strip() else child.tail
    parent.remove(child)


def _serialize(root):
    """The document, with ``<text>`` content written as CDATA (MuJoCo reads it only so, or from ``data``)."""
    contents = []
    for custom in root.findall("custom"):
        for node in custom.findall("text"):
            if node.text and node.text.strip() and node.get("data") is None and "]]>" not in node.text:
                contents.append(node.text)
                node.text = _CDATA.format(len(contents) - 1)
    out = _EMPTY.sub(r"\1/>", ET.tostring(root, encoding="unicode"))
    for i, content in enumerate(contents):
        out = out.replace(_CDATA.format(i), f"<![CDATA[{content}]]>", 1)
    return out


def _write_checked(source, target, text, expected, to):
    """Write ``text`` next to ``source`` (its relative paths resolve there), compile and compare, then move it."""
    folder = os.path.dirname(os.path.abspath(source))
    try:
        handle, temporary = tempfile.mkstemp(suffix=".xml", prefix=".mjflex-convert-", dir=folder)
    except OSError:
        handle, temporary = tempfile.mkstemp(suffix=".xml", prefix=".mjflex-convert-",
                                             dir=os.path.dirname(os.path.abspath(target)))  # fmt: skip
    try:
        with os.fdopen(handle, "w", encoding="utf-8") as f:
            f.write(text)
        _, tables = _compile(temporary, "the converted model")
        _check_same(tables, expected, to)
        os.replace(temporary, target)
    except OSError as exc:
        raise ConversionError(f"cannot write {target!r}: {exc.strerror or exc}") from None
    finally:
        if os.path.exists(temporary):
            os.remove(temporary)


def _check_same(tables, expected, to):
    """Every converted element holds exactly its old parameters, in the new form (else ConversionError)."""
    found = {n: (k, r) for n, k, r in zip(tables.names, tables.kinds, tables.records, strict=True)}
    for name, record in expected.items():
        kind, got = found.get(name, (None, None))
        if kind != (PLUGIN if to == PLUGIN else RECORD) or not same_record(got, record):
            raise ConversionError(f"flexure {name!r} did not convert losslessly; nothing was written (please report "
                                  "this as a bug)")  # fmt: skip


def same_record(a, b) -> bool:
    """Whether two records hold the same parameters, every number bit for bit (their JSON texts are equal: each
    number written as the shortest text of its double; NaN never occurs in a record)."""
    return a is not None and b is not None and a.name == b.name and a.to_text() == b.to_text()


__all__ = ["ConversionError", "convert_file", "same_record"]

"""How a flexure element is stored in an MJCF model file: the two forms, read and written from one table.

An element named ``E`` (any text) is two sites at the same world pose in the model's reference configuration
(``qpos0``), on body A and body B, and its parameters in one of two forms:

* a custom text record ``<text name="mjflex:E" data="{...}"/>`` whose data is a JSON object: ``"mjflex": 1`` (the
  schema version) and the record's keys; its sites are ``E/a`` and ``E/b`` (or ``E.a``, ``E.b``: dm_control's
  ``mjcf`` rejects ``/`` in names);
* an instance named ``E`` of mjflex's engine plugin ``mjflex.flexure`` (:mod:`mjflex.mjcf.config`), whose
  ``<config>`` attributes hold the same parameters as text and name its sites.

Each attribute of an element, in both forms (the plugin's key and the record's JSON key), its type and shape,
default, units, meaning and checks is one row of the C library's table (``MJFX_SCHEMA``,
``mjflex/native/schema.c``), read here through ctypes (:func:`attributes`) and rendered on the schema page
(``docs/reference/mjcf_schema.md``, :func:`schema_page`). Everything follows from it:

* a record's JSON becomes the configuration strings it is equal to (:func:`config_from_payload`), and a
  :class:`FlexureRecord` becomes either form (:func:`config_of`, :meth:`FlexureRecord.to_text`), every
  number as the shortest text that reads back to the same double (lossless);
* the C library checks a configuration, once, by the table's rules and those across attributes, in the words of
  the element's form, and gives back what it read (:func:`read_config`), of which the :class:`FlexureRecord` is
  made. Python adds only what the JSON form alone has: strict JSON (no key twice, no ``NaN``/``Infinity``), the
  version, known keys, and JSON types (``true`` is not a number, ``"0.3"`` is not a number).

Units are SI and the rows of ``K`` and ``B`` ``[rotation; translation]``. A text record rather than ``<numeric>``
keeps every digit: MuJoCo writes numeric data with 6 significant digits but text verbatim. Site poses do get
rounded to 6 digits by those writers; the element takes the measured residual as its rest offset.

Composed models: ``MjSpec.attach(child, prefix=P, suffix=S)`` renames the child's records to
``P + "mjflex:" + E + S`` and its sites to ``P + E + "/a" + S``; such a record is matched to its sites by the name
around ``mjflex:`` (:func:`mjflex.mjcf.naming.match_record`), and the element is called ``P + E + S``.

Example (hand-written)::

    <site name="hinge/a" pos="0 0 0.1"/>           <!-- in body A -->
    <site name="hinge/b" pos="0 0 -0.05"/>         <!-- in body B, same world point -->
    <custom>
      <text name="mjflex:hinge" data='{"mjflex": 1, "method": "twist",
            "K": [2.0, 40, 40, 1e6, 1e6, 3e6], "B": [1e-4, 0, 0, 0, 0, 0]}'/>
    </custom>
"""

import dataclasses
import functools
import json
from typing import NamedTuple

import numpy as np

from ..core import validation
from ..core.polynomial import PolynomialTerms
from ..core.stops import PLANAR_INDEX
from ..core.validation import shorten
from ..native import library

#: The two forms an element is written in: a text record, or an instance of the engine plugin.
RECORD, PLUGIN = "record", "plugin"
KINDS = (PLUGIN, RECORD)
#: Name of mjflex's engine plugin (:mod:`mjflex.mjcf.config` reads and writes its configuration).
PLUGIN_NAME = "mjflex.flexure"
PREFIX = "mjflex:"
SITE_A_SUFFIX = "/a"
SITE_B_SUFFIX = "/b"
#: Separators between an element's name and the ``a`` / ``b`` of its sites, in order of preference.
SITE_SEPARATORS = ("/", ".")
SCHEMA_VERSION = 1
#: The types of the table's rows (``MJFX_TYPE_*``, in their order).
TYPES = ("name", "choice", "bool", "int", "real", "matrix", "vector", "limits", "per coordinate", "ints", "numbers",
         "json")  # fmt: skip
_REQUIRED, _WRITTEN, _DISPLAY = 1, 2, 4  # flags of a row (MJFX_REQUIRED, ...)


class Attribute(NamedTuple):
    """One row of the C library's table of element attributes (``MJFX_SCHEMA``)."""

    key: str  # the plugin's <config> key
    json: str  # the record's JSON key ("stops.lower": key "lower" of object "stops"); "" for none
    type: str  # one of TYPES
    flags: int
    count: int  # numbers of a vector
    lo: float
    hi: float
    fallback: str  # the default as config text ("" for none)
    choices: tuple
    shape: str
    units: str
    meaning: str
    rules: str

    @property
    def field(self) -> str:
        """The :class:`FlexureRecord` attribute that holds it (the JSON key's head)."""
        return self.json.partition(".")[0]


@functools.cache
def attributes() -> tuple[Attribute, ...]:
    """The rows of the C library's table, in the order MuJoCo stores an instance's values."""
    native, out, i = library.lib(), [], 0
    while (key := native.mjfx_schema_text(i, b"key")) is not None:
        text = {f: native.mjfx_schema_text(i, f.encode()).decode() for f in ("json", "fallback", "choices", "shape",
                                                                             "units", "meaning", "rules")}  # fmt: skip
        number = {f: native.mjfx_schema_number(i, f.encode()) for f in ("type", "flags", "count", "lo", "hi")}
        out.append(Attribute(key.decode(), text["json"], TYPES[int(number["type"])], int(number["flags"]),
                             int(number["count"]), number["lo"], number["hi"], text["fallback"],
                             tuple(text["choices"].split("|")) if text["choices"] else (), text["shape"],
                             text["units"], text["meaning"], text["rules"]))  # fmt: skip
        i += 1
    return tuple(out)


@functools.cache
def record_fields() -> tuple[str, ...]:
    """The attributes of a :class:`FlexureRecord` after ``name``: the record's JSON keys, in the table's order."""
    return tuple(dict.fromkeys(a.field for a in attributes() if a.json))


def display_fields() -> set[str]:
    """The record's fields that only the drawing reads (``MJFX_DISPLAY``): they never change the forces."""
    return {a.field for a in attributes() if a.flags & _DISPLAY}


def keys() -> tuple[str, ...]:
    """The keys a record's JSON object may have: ``"mjflex"`` (the version) and :func:`record_fields`."""
    return ("mjflex", *record_fields())


def _group(field) -> list[Attribute]:
    return [a for a in attributes() if a.field == field]


def _members(field) -> tuple[str, ...]:
    """The keys of a JSON object field (``stops``: ``lower``, ``upper``, ...); () for a plain field."""
    return tuple(a.json.partition(".")[2] for a in _group(field) if "." in a.json)


# ------------------------------------------------------------------------------ values: Python, text, JSON


def _numbers(value, where) -> np.ndarray:
    """The numbers of a value (any nesting) as float64, by the core's rules: no booleans, text or None."""
    try:
        return validation.numeric_array(value, where)
    except TypeError as exc:
        raise ValueError(str(exc)) from None


def matrix_value(value, key: str) -> np.ndarray:
    """A K or B argument as its matrix: a diagonal (1-D) or a square matrix of numbers (their types checked here,
    their rules by the C library); ValueError naming ``key`` otherwise."""
    a = _numbers(value, key)
    if a.ndim == 1:
        return np.diag(a)
    if a.ndim != 2 or a.shape[0] != a.shape[1]:
        raise ValueError(f"{key} must be a list of numbers (the diagonal) or a square matrix; got shape {a.shape}")
    return a


def _text_of(a: Attribute, value) -> str:
    """The configuration text of a Python value of attribute ``a`` (numbers: the shortest text of each double)."""
    if a.type in ("name", "choice"):
        return str(value)
    if a.type == "bool":
        return "true" if value else "false"
    if a.type == "int":
        return str(int(value))
    if a.type == "json":
        return json.dumps(value)
    if a.type == "ints":
        return " ".join(str(int(v)) for v in np.ravel(value))
    x = np.asarray(value, dtype=float)
    if a.type == "matrix" and not x[~np.eye(len(x), dtype=bool)].any():
        x = np.diagonal(x)  # the diagonal of a diagonal matrix
    return " ".join(repr(float(v)) for v in np.ravel(x))


def _json_of(a: Attribute, value):
    """The JSON value of a Python value of attribute ``a`` (limits without a stop: null)."""
    if a.type in ("matrix", "ints"):
        return np.asarray(value).tolist()
    if a.type in ("numbers", "vector", "limits"):
        return [float(v) if np.isfinite(v) else None for v in np.ravel(value)]
    if a.type == "per coordinate":
        return list(value) if isinstance(value, tuple) else float(value)
    return float(value) if a.type == "real" else value


def _leaves(value):
    """The entries of a nested list, row-major."""
    for v in value:
        yield from _leaves(v) if isinstance(v, list) else (v,)


def _from_json(a: Attribute, value) -> str:
    """The configuration text of a JSON value of attribute ``a``, each number as written (an integer in its
    digits); ValueError naming its JSON type problem."""
    where, key = a.json, f'"{a.json}"'  # numbers: K[0]; the value: "K"
    if a.type in ("name", "choice"):
        if not isinstance(value, str):
            raise ValueError(f"{key} must be a string; got {shorten(value)}")
        return value
    if a.type == "bool" and not isinstance(value, bool):
        raise ValueError(f"{key} must be true or false; got {shorten(value)}")
    if a.type == "int" and (not isinstance(value, int) or isinstance(value, bool)):
        raise ValueError(f"{key} must be an integer; got {shorten(value)} (an integer is needed)")
    if a.type == "json" and not isinstance(value, dict):
        raise ValueError(f"{key} must be a JSON object; got {shorten(value)}")
    if a.type in ("bool", "int", "json"):
        return _text_of(a, value)
    if not isinstance(value, list) and a.type not in ("real", "per coordinate"):
        raise ValueError(f"{key} must be a list; got {shorten(value)}")
    if a.type == "matrix" and any(isinstance(v, list) for v in value):
        if not all(isinstance(v, list) and len(v) == len(value) for v in value):
            raise ValueError(f"{key} must be a list of numbers (the diagonal) or a square nested list; got "
                             f"{shorten(value)}")  # fmt: skip
    entries = list(_leaves(value)) if isinstance(value, list) else [value]
    if a.type == "limits":
        entries = [a.lo if v is None else v for v in entries]  # lo: the limit of a coordinate without a stop
    _numbers(value if a.type != "limits" else entries, where)  # JSON numbers only (no true, "0.3", null)
    whole = a.type == "ints"  # exponents: 2 or 2.0 (else C refuses the text)
    return " ".join(str(int(v)) if type(v) is int or (whole and float(v).is_integer()) else repr(float(v))
                    for v in entries)  # fmt: skip


def _value(a: Attribute, text: bytes, count: int, first: int, num) -> object:
    """The Python value of attribute ``a`` from what C read of it (count, first, num; text: its string)."""
    if a.type in ("name", "json"):
        given = text[first : first + count].decode("utf-8")
        return json.loads(given) if a.type == "json" else given
    x = num[first : first + count]
    if a.type == "choice":
        return a.choices[int(x[0])]
    if a.type == "bool":
        return bool(x[0])
    if a.type == "int":
        return int(x[0])
    if a.type == "real" or (a.type == "per coordinate" and count == 1):
        return float(x[0])
    if a.type == "matrix":
        n = round(count**0.5)
        return np.array(x, dtype=float).reshape(n, n)
    if a.type == "ints":
        return np.array(x, dtype=np.int64)
    return np.array(x, dtype=float) if a.type == "numbers" else tuple(float(v) for v in x)


def _default(a: Attribute):
    """The Python value of attribute ``a``'s default (None where it has none)."""
    if not a.fallback:
        return None
    return {"bool": a.fallback == "true", "int": int(a.fallback) if a.type == "int" else 0}.get(a.type, a.fallback)


# ------------------------------------------------------------------------------ groups of attributes


def _group_values(field, value) -> dict:
    """The members of a group field's Python value (``terms``, ``stops``, ``rest``, another: a dict)."""
    if field == "terms":
        return {"exponents": value.exponents, "coefficients": value.coefficients} if len(value) else {}
    if field == "stops":
        return {k: getattr(value, k) for k in _members(field) if getattr(value, k) is not None} if value else {}
    if field == "rest":
        return dict(zip(_members(field), value, strict=True))
    return dict(value)


def _group_of(field, members: dict, method: str):
    """A group field's Python value from its members' values (checked by C), or None when it has none."""
    if not members:
        return None
    if field == "terms":
        coefs = members.get("coefficients", np.zeros(0))
        exps = members.get("exponents", np.zeros(0, np.int64)).reshape(len(coefs), -1)
        return PolynomialTerms.checked(method, exps, coefs)
    if field == "stops":
        from .stops import Stops  # late: stops.py reads and writes its attributes through this module

        return Stops.checked(**members)
    if field == "rest":  # (pos, quat), the identity's part where one is not given
        return members.get("pos", (0.0, 0.0, 0.0)), members.get("quat", (1.0, 0.0, 0.0, 0.0))
    return members


def _rows_of(record) -> dict:
    """``{attribute key: Python value}`` of a record's given values (those to write)."""
    out = {}
    for field in record_fields():
        value, group = getattr(record, field), _group(field)
        if value is None:
            continue
        if _members(field):
            members = _group_values(field, value)
            out.update({a.key: members[a.json.partition(".")[2]] for a in group if a.json.partition(".")[2] in members})
            continue
        a = group[0]
        default = _default(a)
        if a.flags & _WRITTEN or default is None or isinstance(value, np.ndarray) or value != default:
            out[a.key] = value
    return out


# ------------------------------------------------------------------------------ the record


class FlexureRecord:
    """The parameters of one element as stored in the model file (either form).

    Its attributes are the element's ``name`` and then one per key of the record, in the order of the schema
    table (:func:`record_fields`; ``docs/reference/mjcf_schema.md``): ``method``, ``K``, ``B``, ``enabled``,
    ``viscous``, ... They may be given by position in that order, or by name; one not given holds its default
    (None where the table has none). ``K`` and ``B`` are 6x6 (spatial) or 3x3 (planar) arrays in the element frame, rows
    ``[rotation; translation]`` (N m/rad, N/rad, N/m; damping per unit rate), ``B`` None without damping;
    ``terms`` a :class:`mjflex.PolynomialTerms` (None: quadratic potential), ``stops`` a :class:`mjflex.Stops`,
    ``rest`` the rest pose ``((x, y, z), (w, x, y, z))`` as written (None: the frames coincide).
    Nothing is checked here: the C library checks a record when it is written to a spec or read from a model.
    A :class:`mjflex.Flexures` holds one per element, in ``flex.records``.

    Parameters
    ----------
    name : str
        The element's name.
    *args
        Its attributes by position, in the order of :func:`record_fields` (``method``, ``K``, ``B``, ...).
    **kwargs
        Its attributes by name; ``K`` (6x6 or 3x3 array) is required.

    Examples
    --------
    >>> import mujoco
    >>> import mjflex
    >>> model = mujoco.MjModel.from_xml_string(mjflex.mjcf.elements.EXAMPLE_MODEL)  # one element, "hinge"
    >>> record = mjflex.Flexures(model).records[0]
    >>> print(record.name, record.method, record.K.shape, f"{record.K[3, 3]:g} N/m", record.planar)
    hinge twist (6, 6) 5e+06 N/m False
    """

    def __init__(self, name, *args, **kwargs):
        fields = record_fields()
        if len(args) > len(fields):
            raise TypeError(f"FlexureRecord takes at most {len(fields) + 1} values by position; got {len(args) + 1}")
        given = dict(zip(fields, args, strict=False))
        for key, value in kwargs.items():
            if key not in fields or key in given:
                why = "is given twice" if key in given else f"is not an attribute of a record ({list(fields)})"
                raise TypeError(f"FlexureRecord: {key!r} {why}")
            given[key] = value
        if "K" not in given:
            raise TypeError("FlexureRecord needs K, the element's stiffness")
        self.name = name
        for field in fields:
            group = _group(field)
            setattr(self, field, given.get(field, None if _members(field) else _default(group[0])))

    class _Dataclass:
        """Its ``__dataclass_fields__`` and ``__dataclass_params__``, made from the table on first use: the functions
        of ``dataclasses`` take a record, and a dataclass may derive from it."""

        def __set_name__(self, owner, name):
            self.name = name

        def __get__(self, record, cls=None):
            return getattr(_dataclass(), self.name)

    __dataclass_fields__ = _Dataclass()
    __dataclass_params__ = _Dataclass()

    @property
    def planar(self) -> bool:
        """True for a planar element (3×3 ``K`` over ``[theta; x; y]``), False for a spatial one (6×6)."""
        return np.shape(self.K) == (3, 3)

    def to_text(self) -> str:
        """JSON data of the ``<text>`` record (full float precision)."""
        payload, rows = {"mjflex": SCHEMA_VERSION}, _rows_of(self)
        for a in attributes():
            value = rows.get(a.key)
            if value is None or not a.json:
                continue
            head, _, leaf = a.json.partition(".")
            (payload.setdefault(head, {}) if leaf else payload)[leaf or head] = _json_of(a, value)
        return json.dumps(payload)

    def __eq__(self, other):
        return isinstance(other, FlexureRecord) and self.name == other.name and self.to_text() == other.to_text()

    def __repr__(self):
        shown = ", ".join(
            f"{f}={shorten(getattr(self, f), 40)}" for f in record_fields() if getattr(self, f) is not None
        )
        return f"FlexureRecord(name={self.name!r}, {shown})"


@functools.cache
def _dataclass():
    """A dataclass with the fields of :class:`FlexureRecord` and their defaults (its ``__dataclass_fields__``)."""
    defaults = {f: None if _members(f) else _default(_group(f)[0]) for f in record_fields()}
    fields = [(f, object, dataclasses.field(default=d)) for f, d in defaults.items()]
    return dataclasses.make_dataclass("FlexureRecord", [("name", str), *fields])


def config_of(record: FlexureRecord) -> dict[str, str]:
    """The configuration strings of a record's given values (lossless: the shortest text of every double, the
    source verbatim); :func:`mjflex.mjcf.config.config_from_record` adds its sites."""
    rows = _rows_of(record)
    return {a.key: _text_of(a, rows[a.key]) for a in attributes() if a.key in rows}


def config_from_payload(payload) -> dict[str, str]:
    """The configuration strings equal to a record's JSON object; ValueError for what only JSON can get wrong.

    The version, known keys (and members of the objects ``"terms"``, ``"stops"``, ...) and the JSON type of
    each value; the rules on the values are the C library's (:func:`read_config`).
    """
    if not isinstance(payload, dict):
        raise ValueError(f'its data must be a JSON object such as {{"mjflex": 1, "K": [...]}}; got {shorten(payload)}')
    unknown = sorted(set(payload) - set(keys()))
    if unknown:
        raise ValueError(f"unknown key(s) {shorten(unknown)}; the allowed keys are {list(keys())}")
    version = payload.get("mjflex")
    if type(version) is not int or version != SCHEMA_VERSION:
        raise ValueError(f'"mjflex" must be the schema version {SCHEMA_VERSION}; got {shorten(version)} (an integer '
                         "is needed)")  # fmt: skip
    config = {}
    for field in record_fields():
        value, members = payload.get(field), _members(field)
        if value is None:
            continue
        if members and not isinstance(value, dict):
            raise ValueError(f'"{field}" must be an object with the keys {list(members)}; got {shorten(value)}')
        if members and set(value) - set(members):
            unknown = sorted(set(value) - set(members))
            raise ValueError(f'"{field}" has unknown key(s) {shorten(unknown)}; the allowed keys are {list(members)}')
        for a in _group(field):
            x = value.get(a.json.partition(".")[2]) if members else value
            if x is not None:
                config[a.key] = _from_json(a, x)
    return config


def read_values(element: str, config: dict, form: str):
    """What the C library reads of a configuration (attribute -> text) written in ``form`` (``RECORD``, ``PLUGIN``
    or ``"arguments"``): ``(strings, count, first, num, row)`` (:func:`mjflex.native.library.parse_values`); its
    checks fail with its message, naming the element in the words of the form (ValueError)."""
    strings = [str(config.get(a.key, "")) for a in attributes()]
    return strings, *library.parse_values(element, form, strings)


def read_config(element: str, config: dict, form: str) -> FlexureRecord:
    """The record of element ``element`` from its configuration strings (attribute -> text), written in ``form``
    (``RECORD`` or ``PLUGIN``), checked by the C library (ValueError with its message)."""
    return record_from_values(element, *read_values(element, config, form)[:4])


def text_of(key: str, value) -> str:
    """The configuration text of a Python value of attribute ``key`` (lossless)."""
    return _text_of(next(a for a in attributes() if a.key == key), value)


def group_config(field: str, members: dict) -> dict[str, str]:
    """The configuration strings of the given members of an object field (``stops``: ``lower`` -> ``stop_lower``)."""
    return {a.key: _text_of(a, members[leaf]) for a in _group(field)
            if members.get(leaf := a.json.partition(".")[2]) is not None}  # fmt: skip


def group_json(field: str, members: dict) -> dict:
    """The JSON object of the given members of an object field (as in a record)."""
    return {leaf: _json_of(a, members[leaf]) for a in _group(field)
            if members.get(leaf := a.json.partition(".")[2]) is not None}  # fmt: skip


def group_values(field: str, strings, count, first, num) -> dict:
    """``{member: Python value}`` of an object field from what the C library read (:func:`read_values`)."""
    return {a.json.partition(".")[2]: _value(a, strings[i].encode(), int(count[i]), int(first[i]), num)
            for i, a in enumerate(attributes()) if a.field == field and count[i] >= 0}  # fmt: skip


def record_from_values(element: str, strings, count, first, num) -> FlexureRecord:
    """A record from what the C library read of a configuration (``strings``: its values in table order)."""
    fields, groups = {}, {}
    for i, a in enumerate(attributes()):
        if count[i] < 0 or not a.json:
            continue
        value = _value(a, strings[i].encode("utf-8"), int(count[i]), int(first[i]), num)
        head, _, leaf = a.json.partition(".")
        (groups.setdefault(head, {}) if leaf else fields)[leaf or head] = value
    method = fields.get("method", "twist")
    fields.update({field: _group_of(field, members, method) for field, members in groups.items()})
    return FlexureRecord(element, **fields)


class _Constant(str):
    """A ``NaN``/``Infinity``/``-Infinity`` read by ``json``: kept as a marker to report with its key."""


def _find_constant(value, path=""):
    """The JSON path (``"K"[0][1]``, ``"source"["E"]``) and text of the first NaN or Infinity in ``value``, or None."""
    items = value.items() if isinstance(value, dict) else enumerate(value) if isinstance(value, list) else ()
    for key, v in items:
        where = (f'"{key}"' if not path else f'{path}["{key}"]') if isinstance(value, dict) else f"{path}[{key}]"
        found = (where, str(v)) if isinstance(v, _Constant) else _find_constant(v, where)
        if found:
            return found
    return None


def load_json(data: str):
    """The JSON value of a record's data, strict (RFC 8259): no key twice in an object, no NaN or Infinity."""

    def strict(pairs):
        out = {}
        for key, value in pairs:
            if key in out:
                raise ValueError(f"the key {shorten(key, 40)} is given twice in one object; keep one")
            out[key] = value
        return out

    try:
        payload = json.loads(data, object_pairs_hook=strict, parse_constant=_Constant)
        found = (("its data", str(payload)) if isinstance(payload, _Constant) else None) or _find_constant(payload)
    except json.JSONDecodeError as exc:
        raise ValueError(f"its data is not valid JSON ({exc.msg} at character {exc.pos})") from None
    except RecursionError:
        raise ValueError("its data nests JSON arrays or objects too deeply to be a flexure record") from None
    if found:
        raise ValueError(f"{found[0]} is {found[1]}, which is not a JSON number (strict JSON has no NaN or Infinity); "
                         "every number of a record must be finite")  # fmt: skip
    return payload


def record_config(element: str, data: str) -> dict[str, str]:
    """The configuration strings a text record's JSON data is equal to; ValueError for what only JSON can get
    wrong (:func:`config_from_payload`), or an empty element name."""
    if not element:
        raise ValueError(
            f'the element name is empty (the record is named "{PREFIX}" with nothing after it); name the '
            f'element: <text name="{PREFIX}NAME"> with sites NAME/a and NAME/b'
        )
    return config_from_payload(load_json(data))


def parse_text(element: str, data: str) -> FlexureRecord:
    """The record of a text record's JSON data; ValueError saying what to fix (the C library's rules on the
    values: its message names the element)."""
    try:
        config = record_config(element, data)
    except ValueError as exc:  # what only JSON can get wrong: with the head of the C library's messages
        raise ValueError(f"flexure '{element}': {exc}") from None
    return read_config(element, config, RECORD)


def embed_planar(M: np.ndarray) -> np.ndarray:
    """A planar 3x3 matrix ``[theta_z; x; y]`` as the 6x6 matrix of the same element."""
    out = np.zeros((6, 6))
    out[np.ix_(PLANAR_INDEX, PLANAR_INDEX)] = M
    return out


# ------------------------------------------------------------------------------ the schema page


def schema_page() -> str:
    """The table of attributes in Markdown, as ``docs/reference/mjcf_schema.md`` shows it (a test compares)."""
    lines = [
        "| plugin key | record key | value | default | units | meaning | checks |",
        "|---|---|---|---|---|---|---|",
    ]
    for a in attributes():
        record = f"`{a.json}`" if a.json else "(the sites' names)"
        default = f"`{a.fallback}`" if a.fallback else ("required" if a.flags & _REQUIRED else "none")
        cells = (f"`{a.key}`", record, a.shape, default, a.units, a.meaning, a.rules)
        lines.append("| " + " | ".join(c.replace("|", "\\|") for c in cells) + " |")
    return "\n".join(lines) + "\n"

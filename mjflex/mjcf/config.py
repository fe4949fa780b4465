"""An element as an instance of the engine plugin ``mjflex.flexure``: its configuration attributes, read and written.

mjflex's engine plugin ``mjflex.flexure`` (``PLUGIN_NAME``, compiled C, registered by
``import mujoco``) holds one element per instance: its forces belong to the model, so the file
runs in any MuJoCo program (viewer, ``Batch``, ``rollout``) without mjflex's Python layer. The
instance's name is the element's name; its ``<config>`` attributes (``PLUGIN_ATTRIBUTES``) hold
the record's content, each value a string:

- ``site_a``, ``site_b``: the names of the two sites (any names; required). Unlike a text record,
  the element does not find its sites by its name;
- ``method``: ``twist`` (default) or ``dualquat``;
- ``K``: 6 numbers (the diagonal) or 36 (the 6x6 matrix, row-major); 3 or 9 for a planar
  element (required);
- ``B``: as ``K``, the same size family (optional);
- ``order``, ``exponents``, ``coefficients``: the polynomial terms: ``exponents`` holds the rows
  of 6 (twist) or 8 (dual quaternion) integers one after the other, ``coefficients`` one number
  per row, ``order`` as in the record;
- ``enabled``, ``viscous``: ``true`` (default) or ``false``;
- ``strain_per_radian``, ``strain_scale``: a number each (optional);
- ``source``: the record's ``"source"`` object as JSON text, verbatim (optional);
- ``stop_lower``, ``stop_upper``: the record's ``"stops"`` limits, one number per coordinate,
  ``-inf`` / ``inf`` where a coordinate has no stop; ``stop_stiffness``: absent (derived), one
  number, or one per coordinate; ``stop_damping``: absent (none), one number, or one per
  coordinate (optional; the record's rules);
- ``rest_pos``, ``rest_quat``: the record's ``"rest"``, 3 numbers [m] and 4 (a unit quaternion
  ``w x y z``) (optional; either alone leaves the other at the identity).

Numbers are separated by white space and written as the shortest text that reads back to the same double by
:func:`config_from_record`, so the conversion is lossless. Every value is validated when MuJoCo
compiles the model, by the record's rules: a bad one is a compile error naming the element and
the fix. A model must not hold one element both ways (a compile error as well). Example::

    <extension>
      <plugin plugin="mjflex.flexure">
        <instance name="hinge">
          <config key="site_a" value="hinge/a"/>
          <config key="site_b" value="hinge/b"/>
          <config key="K" value="2 40 40 1e6 1e6 3e6"/>
          <config key="B" value="1e-4 0 0 0 0 0"/>
        </instance>
      </plugin>
    </extension>

An instance need not be attached to a body (MuJoCo computes unattached instances too).
"""

import json

import numpy as np

from ..core.polynomial import PolynomialTerms
from ..native import library
from .schema import FlexureRecord
from .stops import Stops

#: The plugin's configuration attributes, in the order MuJoCo stores their values (the C library's
#: ``MJFX_ATTRIBUTES``; tests/test_native_constants.py holds them equal).
PLUGIN_ATTRIBUTES = ("site_a", "site_b", "method", "K", "B", "order", "exponents", "coefficients", "enabled",
                     "viscous", "strain_per_radian", "strain_scale", "source", "stop_lower", "stop_upper",
                     "stop_stiffness", "stop_damping", "rest_pos", "rest_quat", "site")  # fmt: skip


def _numbers(text: str) -> list[float]:
    return [float(t) for t in text.split()]


def _matrix(text: str) -> np.ndarray:
    """A K or B given as 3, 6, 9 or 36 numbers (checked by the C library) as its 3x3 or 6x6 matrix."""
    values = np.array(_numbers(text))
    n = {3: 3, 6: 6, 9: 3, 36: 6}[len(values)]
    return np.diag(values) if len(values) == n else values.reshape(n, n)


def record_from_config(element: str, config: dict) -> FlexureRecord:
    """The record of a plugin instance from its configuration strings; raises ValueError saying what to fix.

    ``config`` maps attribute names (``PLUGIN_ATTRIBUTES``) to their values; missing ones are
    empty. The configuration is checked by the native library's reader of configurations (the
    plugin's own rules and messages, ``mjflex/native/config.c``: one implementation of them), then
    decoded into the record.
    """

    get = {a: str(config.get(a, "")).strip() for a in PLUGIN_ATTRIBUTES}
    library.check_config(element, get)
    method = get["method"] or "twist"
    terms, order = None, int(get["order"]) if get["order"] else 2
    if get["exponents"]:
        cols = 6 if method == "twist" else 8
        flat = [int(t) for t in get["exponents"].split()]
        rows = [flat[i : i + cols] for i in range(0, len(flat), cols)]
        terms = PolynomialTerms.from_dict({"method": method, "exponents": rows,
                                           "coefficients": _numbers(get["coefficients"])})  # fmt: skip
    flags = {key: get[key] != "false" for key in ("enabled", "viscous")}
    strain = {key: float(get[key]) if get[key] else None for key in ("strain_per_radian", "strain_scale")}
    return FlexureRecord(
        element, method, _matrix(get["K"]), _matrix(get["B"]) if get["B"] else None, **flags,
        strain_per_radian=strain["strain_per_radian"], source=json.loads(get["source"]) if get["source"] else None,
        terms=terms, order=order, site=get["site"] or None, strain_scale=strain["strain_scale"],
        stops=Stops.from_config(get) or None, rest=_rest(get),
    )  # fmt: skip


def _rest(get) -> tuple | None:
    """The rest pose of checked configuration strings, as the record holds it (None: none given)."""
    if not get["rest_pos"] and not get["rest_quat"]:
        return None
    pos = _numbers(get["rest_pos"]) if get["rest_pos"] else [0.0, 0.0, 0.0]
    quat = _numbers(get["rest_quat"]) if get["rest_quat"] else [1.0, 0.0, 0.0, 0.0]
    return tuple(pos), tuple(quat)


def _number_text(values) -> str:
    return " ".join(repr(float(v)) for v in np.ravel(values))


def attached_name(value: str, element: str, names) -> str | None:
    """The site name a plugin configuration's ``value`` stands for among ``names``, or None.

    ``value`` itself, or, in a model composed with ``MjSpec.attach`` (which prefixes and suffixes
    every name but leaves configuration strings as written), ``P + value + S`` where the
    instance's name ``element`` is ``P + E + S``. The plugin's ``init`` applies the same rule.
    """
    names = names if isinstance(names, set | frozenset | dict) else set(names)
    if value in names or not value:
        return value if value in names else None
    for name in sorted(n for n in names if value in n):
        at = name.find(value)
        while at >= 0:
            pre, suf = name[:at], name[at + len(value) :]
            if len(pre) + len(suf) < len(element) and element.startswith(pre) and element.endswith(suf):
                return name
            at = name.find(value, at + 1)
    return None


def config_sites(config: dict, element: str, names) -> tuple[str, str]:
    """The names of a plugin instance's two sites among ``names`` (:func:`attached_name`), else as written."""
    return tuple(attached_name(config.get(k, ""), element, names) or config.get(k, "") for k in ("site_a", "site_b"))


def config_from_record(record: FlexureRecord, site_a: str, site_b: str) -> dict[str, str]:
    """The plugin configuration of a record (lossless: 17 significant digits, the source verbatim)."""
    config = {"site_a": site_a, "site_b": site_b, "method": record.method, "K": _number_text(_compact(record.K))}
    if record.B is not None:
        config["B"] = _number_text(_compact(record.B))
    if record.terms is not None and len(record.terms):
        config["order"] = str(int(record.order))
        config["exponents"] = " ".join(str(int(v)) for v in record.terms.exponents.ravel())
        config["coefficients"] = _number_text(record.terms.coefficients)
    if not record.enabled:
        config["enabled"] = "false"
    if not record.viscous:
        config["viscous"] = "false"
    if record.strain_per_radian is not None:
        config["strain_per_radian"] = repr(float(record.strain_per_radian))
    if record.strain_scale is not None:
        config["strain_scale"] = repr(float(record.strain_scale))
    if record.source is not None:
        config["source"] = json.dumps(record.source)
    if record.site is not None:
        config["site"] = record.site
    if record.stops:
        config.update(record.stops.config())
    if record.rest is not None:
        config["rest_pos"], config["rest_quat"] = _number_text(record.rest[0]), _number_text(record.rest[1])
    return config


def _compact(M: np.ndarray) -> np.ndarray:
    """The diagonal of a diagonal matrix, else the matrix."""
    return np.diagonal(M) if not M[~np.eye(len(M), dtype=bool)].any() else M


def config_text(config: dict) -> str:
    """One string of a configuration (its attributes in order), to compare two instances."""
    return "\n".join(f"{a}={config.get(a, '')}" for a in PLUGIN_ATTRIBUTES)

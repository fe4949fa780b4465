"""An element as an instance of the engine plugin ``mjflex.flexure``: its configuration attributes, read and written.

mjflex's engine plugin ``mjflex.flexure`` (``PLUGIN_NAME``, compiled C, registered by
``import mujoco``) holds one element per instance: its forces belong to the model, so the file
runs in any MuJoCo program (viewer, ``Batch``, ``rollout``) without mjflex's Python layer. The
instance's name is the element's name; its ``<config>`` attributes hold
the record's content, each value a string: the attributes of the C library's table (:mod:`mjflex.mjcf.schema`,
``docs/reference/mjcf_schema.md``), and ``site_a``, ``site_b``, the names of the two sites (unlike a text record,
the element does not find its sites by its name).

Numbers are separated by white space and written as the shortest text that reads back to the same double by
:func:`config_from_record`, so the conversion is lossless. Every value is checked when MuJoCo compiles the model,
by the same C code as a record's: a bad one is a compile error naming the element and the fix. A model must not
hold one element both ways (a compile error as well). Example::

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

from . import schema
from .schema import PLUGIN, FlexureRecord


def record_from_config(element: str, config: dict) -> FlexureRecord:
    """The record of a plugin instance from its configuration strings (attribute -> text; missing ones empty),
    checked by the C library (the plugin's own rules and messages); raises ValueError saying what to fix."""
    return schema.read_config(element, config, PLUGIN)


def config_from_record(record: FlexureRecord, site_a: str, site_b: str) -> dict[str, str]:
    """The plugin configuration of a record between sites ``site_a`` and ``site_b`` (lossless)."""
    return {"site_a": site_a, "site_b": site_b} | schema.config_of(record)


def attached_names(values, element: str, names) -> tuple[str, ...] | None:
    """The site names that a plugin configuration's ``values`` (``""``: none given) stand for among ``names``.

    The names themselves when all exist (:func:`mjflex.attach` writes the attached names). Else, for a
    configuration that mjflex 1.0's ``attach`` wrote (names as the child wrote them, the instance renamed
    ``P + E + S``), ``P + value + S`` for the affix of ``element`` under which all exist: the longest ``P + S``
    first, then the longest ``P`` (nested attaches). None when no affix binds them all. The plugin's ``init``
    applies the same rule (``config_site_ids`` in ``native/instances.c``).
    """
    names = names if isinstance(names, set | frozenset | dict) else set(names)
    n = len(element)
    for pre, suf in [(0, 0)] + [(p, t - p) for t in range(n - 1, 0, -1) for p in range(t, -1, -1)]:
        found = tuple(element[:pre] + v + element[n - suf :] if v else "" for v in values)
        if all(f in names for f, v in zip(found, values, strict=True) if v):
            return found
    return None


def config_sites(config: dict, element: str, names) -> tuple[str, str]:
    """The names of a plugin instance's two sites among ``names`` (:func:`attached_names`, with its frame site as the
    plugin reads them), else as written."""
    written = tuple(config.get(k, "") for k in ("site_a", "site_b", "site"))
    found = attached_names(written, element, names) or attached_names(written[:2], element, names)
    return found[:2] if found else written[:2]


def config_text(config: dict) -> str:
    """One string of a configuration (its attributes in order), to compare two instances."""
    return "\n".join(f"{a.key}={config.get(a.key, '')}" for a in schema.attributes())

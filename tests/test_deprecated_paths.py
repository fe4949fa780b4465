"""The old flat MuJoCo layer ``mjflex.mj`` still answers, for now: every name and module it had gives the object at
its new path, with one ``DeprecationWarning`` that names the new path (each old path once per process). Run in a
subprocess: the warnings are once per process, and this suite imports only the new paths."""

import subprocess
import sys

import mjflex

CODE = r"""
import warnings
warnings.simplefilter("always")
import mjflex
from mjflex.mjcf import config, elements, schema, spec
from mjflex.runtime import tables

with warnings.catch_warnings(record=True) as caught:
    warnings.simplefilter("always")
    assert mjflex.mj.Flexures is mjflex.Flexures
    assert mjflex.mj.Flexures is mjflex.Flexures  # a second look: no second warning
    import mjflex.mj.schema as old_schema
    from mjflex.mj.convert import EXAMPLE_MODEL, edit_elements
    from mjflex.mj.build import compile_spec
    from mjflex.mj.provider import ModelError
    import mjflex.mj._native
    assert old_schema.FlexureRecord is schema.FlexureRecord
    assert old_schema.config_from_record is config.config_from_record
    assert EXAMPLE_MODEL is elements.EXAMPLE_MODEL and edit_elements is elements.edit_elements
    assert compile_spec is spec.compile_spec and ModelError is tables.ModelError
    assert mjflex.mj._native.lib is __import__("mjflex.native.library", fromlist=["lib"]).lib
    try:
        mjflex.mj.convert.no_such_name
    except AttributeError as exc:
        print("missing:", exc)
for w in caught:
    print(w.category.__name__, w.message)
"""


def test_old_paths_give_the_new_objects_and_warn_once_naming_the_new_path():
    done = subprocess.run([sys.executable, "-c", CODE], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    warned = [line for line in lines if line.startswith("DeprecationWarning")]
    assert "DeprecationWarning mjflex.mj.Flexures is deprecated; use mjflex.Flexures" in warned
    assert sum("mjflex.mj.Flexures" in line for line in warned) == 1  # once
    assert "DeprecationWarning mjflex.mj.schema is deprecated; use mjflex.mjcf.schema and mjflex.mjcf.config" in warned
    for old, new in (("mjflex.mj.convert.EXAMPLE_MODEL", "mjflex.mjcf.elements.EXAMPLE_MODEL"),
                     ("mjflex.mj.build.compile_spec", "mjflex.mjcf.spec.compile_spec"),
                     ("mjflex.mj.schema.config_from_record", "mjflex.mjcf.config.config_from_record"),
                     ("mjflex.mj.provider.ModelError", "mjflex.runtime.tables.ModelError")):  # fmt: skip
        assert f"DeprecationWarning {old} is deprecated; use {new}" in warned, (old, warned)
    assert any(line.startswith("missing: module 'mjflex.mj.convert' has no attribute 'no_such_name'") for line in lines)


def test_every_old_public_name_is_on_mjflex():
    """The names mjflex.mj exported are all in mjflex.__all__ (none was dropped or deprecated without a warning)."""
    import importlib

    shim = importlib.import_module("mjflex.mj")
    assert set(shim.NAMES) <= set(mjflex.__all__)
    for homes in shim.MOVED.values():
        for home in homes:
            importlib.import_module(home)  # every new home exists

"""Every ``mjflex.x.y`` name the sources and the docs mention resolves (issue 30, "the rest").

The renames of issue 25 left stale references behind (``mjflex.core._series``, ``mjflex.runtime.table``,
``mjflex.mjcf.config_from_record``, ``mjflex.mj.stops`` in C comments, ...). Here every dotted name that starts
with ``mjflex.`` in the package (Python and C), the scripts, the README, CONTRIBUTING, the changelog and the pages
is imported (the longest module prefix) and its attributes are looked up; a name reached only through a deprecated
alias (``mjflex.mj``) is stale too, except where the deprecation itself is documented.
"""

import glob
import importlib
import os
import re
import warnings

import pytest

ROOT = os.path.join(os.path.dirname(__file__), "..")
#: ``mjflex.a.b`` not inside a longer dotted name or a path.
NAME = re.compile(r"(?<![\w./-])mjflex(?:\.[A-Za-z_]\w*)+")
#: Names that are not Python names: the engine plugin's.
NOT_PYTHON = {"mjflex.flexure": "the engine plugin's name (MJCF's <plugin plugin=...>)",
              "mjflex.css": "the site's style sheet (docs/_static)"}  # fmt: skip
#: Placeholders in prose (``mjflex.NAME``, ``import mjflex.mj.MODULE``).
PLACEHOLDERS = {"NAME", "MODULE", "X"}
#: Where an old name is written on purpose: the alias itself and the record of the renames.
DEPRECATIONS_DOCUMENTED = {"mjflex/mj/__init__.py", "CHANGELOG.md"}


def _files():
    patterns = ["README.md", "CONTRIBUTING.md", "CHANGELOG.md", "mjflex_plugin.py", "docs/**/*.md", "docs/**/*.py",
                "docs/**/*.rst", "mjflex/**/*.py", "mjflex/native/*.[ch]", "scripts/*.py"]  # fmt: skip
    out = []
    for pattern in patterns:
        out += glob.glob(os.path.join(ROOT, pattern), recursive=True)
    generated = ("_generated", "auto_tutorials", os.path.join("reference", "api"))  # the docs build writes these
    return sorted({os.path.relpath(f, ROOT) for f in out if not any(g in f for g in generated)})


def mentions():
    """``{name: [file:line, ...]}`` of every ``mjflex.`` name mentioned."""
    found = {}
    for path in _files():
        with open(os.path.join(ROOT, path), encoding="utf-8") as f:
            for number, line in enumerate(f, 1):
                for name in NAME.findall(line):
                    if name not in NOT_PYTHON and not PLACEHOLDERS & set(name.split(".")):
                        found.setdefault(name, []).append(f"{path}:{number}")
    return found


def resolve(name):
    """The object ``name`` names: its longest importable module prefix, then attributes (AttributeError if none)."""
    parts = name.split(".")
    for n in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:n]))
        except ModuleNotFoundError as exc:
            if exc.name != ".".join(parts[:n]) and not ".".join(parts[:n]).startswith(exc.name or "\0"):
                raise  # a module that exists but cannot import: not a stale name, a broken one
            continue
        for p in parts[n:]:
            obj = getattr(obj, p)
        return obj
    raise ModuleNotFoundError(name)


def deprecated(name) -> bool:
    """A name of a deprecated path: the old flat layer ``mjflex.mj``, or a ``WarpFlexures`` method that became one of
    ``mjflex.warp``'s functions."""
    from mjflex.warp._forces import DEPRECATED_METHODS

    parts = name.split(".")
    old_layer = parts[:2] == ["mjflex", "mj"] and len(parts) > 2
    return old_layer or ("WarpFlexures" in parts[:-1] and parts[-1] in DEPRECATED_METHODS)


def problem(name, where=()):
    """Why ``name`` is stale (it does not resolve, or only through a deprecated path), or None."""
    if deprecated(name) and not all(w.rpartition(":")[0] in DEPRECATIONS_DOCUMENTED for w in where):
        return "a deprecated path: name the new one"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        try:
            resolve(name)
        except (AttributeError, ModuleNotFoundError) as exc:
            return f"{type(exc).__name__}: {exc}"
    return None


def test_every_mentioned_name_resolves():
    found = mentions()
    assert len(found) > 200 and "mjflex.Flexures" in found and "mjflex.warp.put_model" in found
    stale = [f"{name} ({', '.join(where[:3])}): {problem(name, where)}"
             for name, where in sorted(found.items()) if problem(name, where)]  # fmt: skip
    assert not stale, "\n".join(stale)


@pytest.mark.parametrize(
    ("text", "stale"),
    [("see mjflex.core._series", True), ("mjflex.runtime.table", True), ("mjflex.mj.stops", True),
     ("mjflex.runtime.tables.derive", False), ("{func}`mjflex.normal_modes`", False),
     ("mjflex.warp.WarpFlexures.wrenches", True), ("mjflex.warp.WarpFlexures.parameters", False)],
)  # fmt: skip
def test_the_check_finds_a_planted_stale_name(text, stale):
    (name,) = NAME.findall(text)
    assert (problem(name, ["docs/page.md:1"]) is not None) == stale


#: A file of the repository named in text: ``mjflex/native/plugin.c``, ``tests/spine.py``, ``docs/results/x.json``.
PATH = re.compile(r"(?<![\w/.-])(?:mjflex|tests|scripts|docs|models)/[\w./-]+\.(?:py|c|h|md|xml|json|png)\b")


def test_every_mentioned_file_exists():
    """``mjflex/mj/_callback.py`` (a C comment) named a file the renames removed: every path of the repository that
    the sources and pages name exists (``NAME`` is a placeholder)."""
    missing = []
    for path in _files():
        with open(os.path.join(ROOT, path), encoding="utf-8") as f:
            for number, line in enumerate(f, 1):
                for named in PATH.findall(line):
                    if "NAME" not in named and not os.path.exists(os.path.join(ROOT, named)):
                        missing.append(f"{path}:{number}: {named}")
    assert not missing, "\n".join(missing)


# ----------------------------------------------------------------------------- one meaning per word


def test_the_renamed_words_warn_once_and_give_the_same_answers(monkeypatch):
    """A variant is a mjflex.Variant (what study(variants=...) compares), so sweep's model family is recipe=; a
    "table" is the element table (Flexures.element_table, mjflex.warp.element_table), so the per-element results
    are Flexures.results. The old names still work, warn once (DeprecationWarning naming the new) and agree."""
    import mujoco
    import numpy as np

    import mjflex
    from mjflex.app.sweep import api
    from mjflex.runtime import flexures
    from tests.sweep_recipes import hinge_state, scale_hinge

    monkeypatch.setattr(api, "_WARNED", set())
    monkeypatch.setattr(flexures, "_WARNED", set())
    recipe = mjflex.Recipe("models/two_body.xml", scale_hinge, keyframe="swing")
    grid = {"k_scale": [0.5, 2.0]}
    new = mjflex.sweep(recipe=recipe, grid=grid, duration=0.001, observe=hinge_state, progress=False)
    with pytest.warns(DeprecationWarning, match=r"sweep\(variants=\.\.\.\) is deprecated; use mjflex\.sweep\(recipe="):
        old = mjflex.sweep(variants=recipe, grid=grid, duration=0.001, observe=hinge_state, progress=False)
    with warnings.catch_warnings():
        warnings.simplefilter("error", DeprecationWarning)
        again = mjflex.sweep(variants=recipe, grid=grid, duration=0.001, observe=hinge_state, progress=False)
    for ds in (old, again):
        assert list(ds.data_vars) == list(new.data_vars)
        for name in new.data_vars:
            np.testing.assert_array_equal(ds[name].values, new[name].values)
    with pytest.raises(TypeError, match="both recipe and variants"):
        mjflex.sweep(recipe, variants=recipe)
    model = mujoco.MjModel.from_xml_path("models/two_body.xml")
    flex = mjflex.Flexures(model)
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, 0)
    mujoco.mj_forward(model, data)
    with pytest.warns(DeprecationWarning, match=r"Flexures\.table is deprecated; use Flexures\.results"):
        table = flex.table(data)
    with warnings.catch_warnings():
        warnings.simplefilter("error", DeprecationWarning)
        flex.table(data)
    results = flex.results(data)
    assert table.dtype == results.dtype and all(np.array_equal(table[f], results[f]) for f in ("wrench", "energy"))

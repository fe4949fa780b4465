"""Write the intersphinx inventories the documentation links MuJoCo's, numpy's and scipy's pages through.

Usage::

    python scripts/docs_inventories.py [--out docs/_inventories] [--check]

The site is built offline (CI and the build machines reach no documentation server), so the inventories are
files of the repository (``docs/_inventories/{mujoco,numpy,scipy,python}.inv``, Sphinx's format 2), read by
``intersphinx_mapping`` in ``docs/conf.py``: a build never fetches one, and the links go to the published pages.

* **mujoco**: from the documentation sources that the installed ``mujoco`` wheel ships (``mujoco/doc``, of the
  pinned version): every label of its pages (``std:label``; an included file's labels on the including page), the
  Python names that the pages document (``mujoco.MjModel`` -> the ``mjModel`` type, ``mujoco.mj_step`` -> the
  ``mj_step`` function, ``mujoco.FatalError``, ``mujoco.rollout``, ``mujoco.viewer``), and ``mujoco_warp``'s public
  names (its API page is ``automodule:: mujoco_warp``, where each has the anchor of its full name).
* **numpy**, **scipy**: the objects mjflex's pages and docstrings name (``NAMES`` below), at the addresses their
  published references give every object (``reference/generated/<name>.html#<name>``, a module's
  ``#module-<name>``); **python**: the builtins that numpydoc links in Parameters and Returns.

``--check`` compares the files with what this would write now (exit 1 if they differ); a new mujoco pin is the
usual reason to write them again.
"""

import argparse
import importlib.util
import os
import re
import sys
import zlib

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), ".."))
OUT = os.path.join(ROOT, "docs", "_inventories")

#: numpy and scipy: (name, domain:role, page relative to the documentation root; None: reference/generated/NAME.html).
NAMES = {
    "numpy": [
        ("numpy", "py:module", "reference/index.html"),
        ("numpy.ndarray", "py:class", None),
        ("numpy.dtype", "py:class", None),
        ("numpy.typing.ArrayLike", "py:data", "reference/typing.html"),
        ("numpy.random.Generator", "py:class", "reference/random/generator.html"),
        ("numpy.random.RandomState", "py:class", "reference/random/legacy.html"),
        ("numpy.random.default_rng", "py:function", "reference/random/generator.html"),
        ("numpy.inf", "py:data", "reference/constants.html"),
        ("numpy.nan", "py:data", "reference/constants.html"),
        ("array_like", "std:term", "glossary.html#term-array_like"),
        ("arrays.scalars", "std:label", "reference/arrays.scalars.html#arrays-scalars"),
    ],
    # the links numpydoc writes for the builtins in Parameters / Returns (numpydoc.xref.DEFAULT_LINKS)
    "python": [
        ("False", "py:data", "library/constants.html"),
        ("True", "py:data", "library/constants.html"),
        ("None", "py:data", "library/constants.html"),
        ("bltin-boolean-values", "std:label", "library/stdtypes.html#bltin-boolean-values"),
        ("callable", "py:function", "library/functions.html"),
        ("float", "py:class", "library/functions.html"),
        ("int", "py:class", "library/functions.html"),
        ("dict", "py:class", "library/stdtypes.html"),
        ("list", "py:class", "library/stdtypes.html"),
        ("str", "py:class", "library/stdtypes.html"),
        ("tuple", "py:class", "library/stdtypes.html"),
        ("contextlib.contextmanager", "py:function", "library/contextlib.html"),
        ("collections.namedtuple", "py:function", "library/collections.html"),
        ("generator", "std:term", "glossary.html#term-generator"),
        ("iterable", "std:term", "glossary.html#term-iterable"),
        ("sequence", "std:term", "glossary.html#term-sequence"),
    ],
    "scipy": [
        ("scipy.linalg", "py:module", "reference/linalg.html"),
        ("scipy.sparse", "py:module", "reference/sparse.html"),
        ("scipy.linalg.eigh", "py:function", None),
        ("scipy.linalg.qr", "py:function", None),
        ("scipy.linalg.block_diag", "py:function", None),
        ("scipy.spatial.transform.Rotation", "py:class", None),
        ("scipy.spatial.transform.Rotation.from_matrix", "py:method", None),
    ],
}
VERSIONS = {"numpy": "stable", "scipy": "stable", "python": "3"}
#: mujoco's Python names documented on a labelled section of python.rst (the rest follow the C names).
MUJOCO_PYTHON = {
    ("mujoco", "py:module"): "PyUsage",
    ("mujoco.FatalError", "py:exception"): "PyError",
    ("mujoco.rollout", "py:module"): "PyRollout",
    ("mujoco.viewer", "py:module"): "PyViewer",
    ("mujoco.set_mjcb_passive", "py:function"): "PyCallbacks",
}
LABEL = re.compile(r"^\.\. _([^:`]+):\s*$")
INCLUDE = re.compile(r"^\.\. include:: (\S+)\s*$")


def anchor(label):
    """The HTML id Sphinx gives a label: docutils' ``make_id``."""
    return re.sub(r"[^a-z0-9]+", "-", label.lower()).strip("-")


def _labels(doc):
    """``{label: page.html}`` of the rst sources below ``doc`` (labels of included files on the including page)."""
    pages, included = {}, {}
    for folder, _, files in os.walk(doc):
        for name in files:
            if name.endswith(".rst"):
                path = os.path.join(folder, name)
                with open(path, encoding="utf-8") as f:
                    lines = f.read().splitlines()
                rel = os.path.relpath(path, doc)[:-4].replace(os.sep, "/")
                pages[rel] = [m[1] for m in map(LABEL.match, lines) if m]
                for m in filter(None, map(INCLUDE.match, lines)):
                    target = os.path.normpath(os.path.join(os.path.dirname(rel), m[1]))[:-4].replace(os.sep, "/")
                    included[target] = rel
    out = {}
    for rel, labels in pages.items():
        page = rel
        while page in included:
            page = included[page]
        for label in labels:
            out.setdefault(label, f"{page}.html")
    return out


def mujoco_entries():
    """``[(name, domain:role, uri, display)]`` of MuJoCo's documentation, from the installed wheel's sources."""
    import mujoco

    doc = os.path.join(os.path.dirname(mujoco.__file__), "doc")
    labels = _labels(doc)
    entries = [(label.lower(), "std:label", f"{page}#{anchor(label)}", label) for label, page in labels.items()]
    by_lower = {label.lower(): label for label in labels}
    for name in sorted(dir(mujoco)):
        obj = getattr(mujoco, name)
        if name.startswith("Mj") and isinstance(obj, type):
            label = by_lower.get("mj" + name[2:].lower())  # MjModel -> mjModel, MjsBody -> mjsBody
            role = "py:class"
        elif re.match(r"mj[a-z]*_\w+$", name) and callable(obj):
            label, role = by_lower.get(name.lower()), "py:function"
        else:
            continue
        if label:
            entries.append((f"mujoco.{name}", role, f"{labels[label]}#{anchor(label)}", "-"))
    for (name, role), label in MUJOCO_PYTHON.items():
        entries.append((name, role, f"{labels[label]}#{anchor(label)}", "-"))
    if importlib.util.find_spec("mujoco_warp") is not None and "MJW" in labels:
        import mujoco_warp

        for name in sorted(n for n in dir(mujoco_warp) if not n.startswith("_")):
            obj = getattr(mujoco_warp, name)
            role = "py:class" if isinstance(obj, type) else "py:function" if callable(obj) else None
            if role:
                entries.append((f"mujoco_warp.{name}", role, f"mjwarp/api.html#mujoco_warp.{name}", "-"))
    return sorted(set(entries)), mujoco.__version__


def curated_entries(project):
    out = []
    for name, role, page in NAMES[project]:
        if "#" in (page or ""):  # a label or a term: its anchor given
            out.append((name, role, page, name))
            continue
        page = page or f"reference/generated/{name}.html"
        out.append((name, role, f"{page}#{'module-' if role == 'py:module' else ''}{name}", "-"))
    return sorted(out), VERSIONS[project]


def inventory(project, version, entries) -> bytes:
    """Sphinx's inventory format 2: a header, then zlib-compressed ``name domain:role priority uri display`` lines."""
    header = (f"# Sphinx inventory version 2\n# Project: {project}\n# Version: {version}\n"
              "# The remainder of this file is compressed using zlib.\n")  # fmt: skip
    body = "".join(f"{name} {role} 1 {uri} {display}\n" for name, role, uri, display in entries)
    return header.encode() + zlib.compress(body.encode(), 9)


def inventories():
    """``{file name: bytes}`` of the three inventories."""
    mujoco_items, version = mujoco_entries()
    out = {"mujoco.inv": inventory("MuJoCo", version, mujoco_items)}
    for project in ("numpy", "scipy", "python"):
        items, version = curated_entries(project)
        out[f"{project}.inv"] = inventory(project, version, items)
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default=OUT)
    ap.add_argument("--check", action="store_true", help="compare the files with what would be written (exit 1)")
    args = ap.parse_args(argv)
    stale = []
    for name, data in inventories().items():
        path = os.path.join(args.out, name)
        if args.check:
            with open(path, "rb") as f:
                if f.read() != data:
                    stale.append(path)
            continue
        os.makedirs(args.out, exist_ok=True)
        with open(path, "wb") as f:
            f.write(data)
        print(f"wrote {path} ({len(data)} bytes)")
    if stale:
        print(f"stale: {stale}; write them again: python scripts/docs_inventories.py", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())

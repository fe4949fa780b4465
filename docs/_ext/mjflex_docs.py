"""Sphinx extension of the mjflex documentation.

* Writes ``reference/api.rst`` (ignored by git) from ``mjflex.__all__`` before autosummary
  reads the sources, so every public name gets a reference page without a hand-kept list: a
  name added to ``__all__`` (or to a public subpackage's ``__all__``) appears in the next build,
  and a public object without a docstring is a build warning (an error in strict mode).
* Resolves cross-references written with a defining module (``mjflex.mj.variant.Variant``) to
  the public name documented for the same object (``mjflex.Variant``).
* ``reset_mujoco``: run by sphinx-gallery around each tutorial, so that no tutorial inherits
  another's passive-force callback.
"""

import importlib
import inspect
import os

from docutils import nodes
from sphinx.util import logging
from sphinx.util.docutils import SphinxDirective

logger = logging.getLogger(__name__)

HERE = os.path.dirname(os.path.abspath(__file__))
API_PAGE = os.path.join(HERE, "..", "reference", "api.rst")

#: Sections of the API page, by the module that defines an object (first match wins).
SECTIONS = (
    ("mjflex.core", "Screw-theory core", "Twists, dual quaternions, element wrenches and potentials (no MuJoCo)."),
    ("mjflex.mj", "MuJoCo layer", "Elements in MJCF models, the passive-force provider, model variants."),
    ("mjflex.geometry", "Stiffness from geometry", "Notch hinges, leaf springs and rods (no MuJoCo)."),
    ("mjflex.app", "Studies and sweeps", "Speed against accuracy, and sweeps over model variants."),
    ("", "Other", ""),
)
#: Public subpackages whose own ``__all__`` is documented under ``mjflex.<name>.``.
SUBPACKAGES = ("geometry",)
#: Names of ``mjflex.app.sweep.__all__`` documented beside ``mjflex.sweep`` (the recipe helpers).
EXTRA = ("mjflex.app.sweep.edit_flexure", "mjflex.app.sweep.flexure_matrices")


def _resolve(qualified):
    module, _, name = qualified.rpartition(".")
    return getattr(importlib.import_module(module), name)


def public_names():
    """Every documented public name, fully qualified, in ``mjflex.__all__`` order, then the lazy
    ones (``mjflex.study``, ``sweep``, ``Recipe``), then the subpackages' names and ``EXTRA``."""
    import mjflex

    names = []
    for name in [*mjflex.__all__, *sorted(mjflex._LAZY)]:
        if name in SUBPACKAGES:
            sub = getattr(mjflex, name)
            names += [f"mjflex.{name}.{n}" for n in sub.__all__]
        else:
            names.append(f"mjflex.{name}")
    return [*names, *EXTRA]


def sections():
    """``[(title, intro, [qualified names])]`` of the API page."""
    grouped = {title: [] for _, title, _ in SECTIONS}
    for qualified in public_names():
        module = getattr(_resolve(qualified), "__module__", "") or ""
        title = next(t for prefix, t, _ in SECTIONS if module.startswith(prefix))
        grouped[title].append(qualified)
    return [(title, intro, grouped[title]) for _, title, intro in SECTIONS if grouped[title]]


def api_page():
    """The reStructuredText of ``reference/api.rst``."""
    lines = [
        ".. This file is written by docs/_ext/mjflex_docs.py from mjflex.__all__ at every build: do not edit.",
        "",
        ".. currentmodule:: mjflex",
        "",
        "API",
        "===",
        "",
        "Every public name of :mod:`mjflex`, generated from the docstrings. ``import mjflex`` gives the names "
        "below as ``mjflex.NAME`` (``mjflex.geometry.NAME`` for stiffness from geometry). Units are SI; "
        "arrays batch-first, 6-vectors angular first (:doc:`conventions`).",
        "",
    ]
    for title, intro, names in sections():
        lines += [title, "-" * len(title), "", intro, "", ".. autosummary::", "   :toctree: api", ""]
        lines += [f"   {name.removeprefix('mjflex.')}" for name in names]
        lines.append("")
    return "\n".join(lines)


def write_api_page(app, config=None):
    text = api_page()
    old = open(API_PAGE).read() if os.path.exists(API_PAGE) else None
    if text != old:  # unchanged: leave its time stamp, so Sphinx does not re-read it
        with open(API_PAGE, "w") as f:
            f.write(text)
    stubs = os.path.join(os.path.dirname(API_PAGE), "api")
    if os.path.isdir(stubs):  # a name no longer public: its old stub would be an orphan page
        for stub in os.listdir(stubs):
            if stub.endswith(".rst") and stub[:-4] not in public_names():
                os.remove(os.path.join(stubs, stub))
    for qualified in public_names():
        obj = _resolve(qualified)
        if not inspect.getdoc(obj):
            logger.warning(f"public name {qualified} has no docstring: write one (numpydoc)", type="mjflex")


def _find(qualified):
    """The module or object ``qualified`` names, or None."""
    try:
        return importlib.import_module(qualified)
    except ImportError:
        pass
    try:
        module, _, name = qualified.rpartition(".")
        owner = _find(module) if module else None
        return getattr(owner, name) if owner is not None else None
    except AttributeError:
        return None


def _candidates(node):
    """Full names a ``py`` reference may mean: as written, in the current module and class, under mjflex."""
    target = node.get("reftarget", "").lstrip(".~")
    module, cls = node.get("py:module") or "", node.get("py:class") or ""
    names = [target]
    if module:
        names += [f"{module}.{cls}.{target}" if cls else None, f"{module}.{target}"]
        parent = module.rpartition(".")[0]
        names.append(f"{parent}.{target}" if parent else None)
    page = node.get("refdoc", "").rpartition("/")[2]  # reference/api/mjflex.NAME: the object's defining module
    documented = _find(page) if page.startswith("mjflex.") else None
    if documented is not None and getattr(documented, "__module__", None):
        names.append(f"{documented.__module__}.{target}")
    names.append(f"mjflex.{target}")
    return [n for n in dict.fromkeys(names) if n and n.startswith("mjflex")]


def resolve_alias(app, env, node, contnode):
    """Resolve a ``py`` reference that Sphinx did not find, to mjflex objects only.

    A reference to an object documented under its public name (``mjflex.mj.variant.Variant``,
    ``wrench_on_b`` inside a module of the core) links to that entry. A reference to an existing
    internal module or helper that has no entry is shown as code without a link. A reference to
    nothing that exists stays unresolved: a warning, an error in strict mode.
    """
    if node.get("refdomain") != "py":
        return None
    domain = env.get_domain("py")
    for candidate in _candidates(node):
        obj = _find(candidate)
        if obj is None:
            continue
        for qualified in [candidate, *public_names()]:
            if qualified == candidate or _find(qualified) is obj:
                for role in ("obj", "mod") if inspect.ismodule(obj) else ("obj",):
                    new = node.deepcopy()
                    new["reftarget"] = qualified
                    found = domain.resolve_xref(env, node["refdoc"], app.builder, role, qualified, new, contnode)
                    if found is not None:
                        return found
        return contnode  # exists, but has no entry: code without a link
    return None


ENTRIES = (
    ("rot_x", "torsion rot_x"),
    ("rot_y", "out-of-plane bending rot_y"),
    ("rot_z", "compliant rotation rot_z"),
    ("x", "axial x"),
    ("y", "in-plane shear y"),
    ("z", "out-of-plane shear z"),
)


def _table(header, rows):
    """A docutils table (works in reStructuredText and MyST pages alike)."""
    table, group = nodes.table(), nodes.tgroup(cols=len(header))
    table += group
    group += [nodes.colspec(colwidth=1) for _ in header]

    def row(cells):
        out = nodes.row()
        for cell in cells:
            out += nodes.entry("", nodes.paragraph(text=cell))
        return out

    group += nodes.thead("", row(header))
    group += nodes.tbody("", *(row(r) for r in rows))
    return table


class ErrorBands(SphinxDirective):
    """``mjflex-error-bands``: the stored error bands of the stiffness tables (package data), as a table."""

    def run(self):
        import mjflex.geometry
        from mjflex.geometry.tables import error_bands

        data = os.path.join(os.path.dirname(mjflex.geometry.__file__), "data")
        for name in ("notch_hinge.json", "leaf_spring.json"):
            self.env.note_dependency(os.path.join(data, name))  # re-read the page when a table changes
        bands = {kind: error_bands(kind) for kind in ("notch", "leaf")}
        parts = (("interpolation", "interpolation"), ("discretisation", "mesh"), ("total", "total"))
        header = ["entry"] + [f"{kind}: {label}" for kind in ("notch hinge", "leaf spring") for _, label in parts]
        rows = [
            [label] + [f"{100 * bands[kind][key][part]:.2g} %" for kind in ("notch", "leaf") for part, _ in parts]
            for key, label in ENTRIES
        ]
        return [_table(header, rows)]


def reset_mujoco(gallery_conf, fname, when=None):
    """sphinx-gallery ``reset_modules`` entry: no passive-force callback survives a tutorial."""
    import mujoco

    try:
        from mjflex.mj import _callback

        _callback.uninstall_all()
    finally:
        mujoco.set_mjcb_passive(None)


def setup(app):
    app.connect("config-inited", write_api_page)  # before Sphinx lists the sources and autosummary reads them
    app.connect("missing-reference", resolve_alias)
    app.add_directive("mjflex-error-bands", ErrorBands)
    return {"parallel_read_safe": True, "parallel_write_safe": True, "version": "1"}


__all__ = ["api_page", "public_names", "reset_mujoco", "sections", "setup"]

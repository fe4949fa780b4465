"""Sphinx extension of the mjflex documentation.

* Writes ``reference/api.rst`` (ignored by git) from ``mjflex.__all__`` before autosummary
  reads the sources, so every public name gets a reference page without a hand-kept list: a
  name added to ``__all__`` (or to a public subpackage's ``__all__``) appears in the next build,
  and a public object without a docstring is a build warning (an error in strict mode).
* Optional subpackages (``OPTIONAL``: ``mjflex.warp``, whose dependencies are the ``warp``
  extra, which the ``docs`` extra leaves out) are documented from their ``__all__`` too: where
  their dependencies are not installed, the build imports them with those mocked (autodoc's
  mock, :func:`missing_dependencies`; ``docs/conf.py`` passes the same to
  ``autodoc_mock_imports``), so their pages come from their docstrings alone.
* Resolves cross-references written with a defining module (``mjflex.variants.variant.Variant``) to
  the public name documented for the same object (``mjflex.Variant``).
* ``reset_mujoco``: run by sphinx-gallery before and after each tutorial, so that no tutorial
  inherits another's passive-force callback, and a tutorial's output is a result: a warning that
  MuJoCo printed (its log ``MUJOCO_LOG.TXT``: how a diverged run shows) or that Python printed (mjflex's
  or any library's) during a tutorial is a build warning, an error in strict mode. A tutorial that shows
  a warning on purpose catches it (``warnings.catch_warnings``, ``mujoco.set_mju_user_warning``).
* Leaks: a built page that holds the path of the source checkout or of the Python environment
  (a warning's file name, a default argument) is a build warning too; the site must read the same
  wherever it was built.
"""

import importlib
import importlib.util
import inspect
import os
import re
import sys
import sysconfig

from docutils import nodes
from sphinx.util import logging
from sphinx.util.docutils import SphinxDirective

logger = logging.getLogger(__name__)

HERE = os.path.dirname(os.path.abspath(__file__))
API_PAGE = os.path.join(HERE, "..", "reference", "api.rst")

#: The names a model with elements starts from: the API page opens with them.
START = ("mjflex.add_flexure", "mjflex.make_compliant", "mjflex.Flexures")
START_TITLE = ("Start here", "Add an element to a spec, or make a body of a robot compliant; then read the compiled "
               "model's elements and forces.")  # fmt: skip
#: Sections of the API page after ``START``, by the module that defines an object (first match wins): from what a
#: user calls to the low-level screw theory.
SECTIONS = (
    ("mjflex.mjcf", "Elements in MJCF and MjSpec", "Adding, editing and converting elements in a spec or a file."),
    ("mjflex.runtime", "The compiled model", "The passive-force provider, divergence reports, file conversion."),
    ("mjflex.analysis", "Linearization", "Statics, modes, damping from ratios and step advice at an operating pose."),
    ("mjflex.variants", "Model variants", "Compliant parts, reduced models and MuJoCo-native alternatives."),
    ("mjflex.app", "Studies and sweeps", "Speed against accuracy, and sweeps over model variants."),
    ("mjflex.geometry", "Stiffness from geometry", "Notch hinges, leaf springs and rods (no MuJoCo)."),
    ("mjflex.core", "Screw-theory core", "Twists, dual quaternions, element wrenches and potentials (no MuJoCo)."),
    (
        "mjflex.warp",
        "MuJoCo Warp",
        "The element forces of many worlds per step on MuJoCo Warp: "
        "``import mjflex.warp`` (the ``warp`` extra, :doc:`../howto/mujoco_warp`).",
    ),
    ("", "Other", ""),
)
#: Public subpackages whose own ``__all__`` is documented under ``mjflex.<name>.``.
SUBPACKAGES = ("geometry",)
#: Optional subpackages documented the same way, not in ``mjflex.__all__`` (``import mjflex`` does not import them),
#: with the modules they need that an extra installs (``pip install "mjflex[warp]"``), not the docs extra: where
#: those are missing, the build imports the subpackage with them mocked.
OPTIONAL = {"warp": ("warp", "mujoco_warp")}
#: Names documented beside the lazy ``mjflex.sweep`` and ``mjflex.study``: the recipe helpers, and what a study
#: returns and raises.
EXTRA = (
    "mjflex.app.sweep.edit_flexure",
    "mjflex.app.sweep.flexure_matrices",
    "mjflex.app.study.StudyResult",
    "mjflex.app.study.Row",
    "mjflex.app.study.Limit",
    "mjflex.app.study.Reference",
    "mjflex.app.study.StudyError",
)


def missing_dependencies():
    """The optional subpackages' dependencies that are not installed here: the build mocks them (sorted)."""
    return sorted(m for deps in OPTIONAL.values() for m in deps if importlib.util.find_spec(m) is None)


def optional_subpackage(name):
    """``mjflex.<name>`` of ``OPTIONAL``, imported as the build imports it: its missing dependencies mocked."""
    from sphinx.ext.autodoc.mock import mock

    with mock(missing_dependencies()):
        return importlib.import_module(f"mjflex.{name}")


def _resolve(qualified):
    module, _, name = qualified.rpartition(".")
    return getattr(importlib.import_module(module), name)


def public_names():
    """Every documented public name, fully qualified, in ``mjflex.__all__`` order, then the lazy
    ones (``mjflex.study``, ``sweep``, ``Recipe``), then the subpackages' names, ``EXTRA`` and the
    optional subpackages' names (``mjflex.warp.put_model``, ...)."""
    import mjflex

    names = []
    for name in [*mjflex.__all__, *sorted(mjflex._LAZY)]:
        if name in SUBPACKAGES:
            sub = getattr(mjflex, name)
            names += [f"mjflex.{name}.{n}" for n in sub.__all__]
        else:
            names.append(f"mjflex.{name}")
    optional = [f"mjflex.{name}.{n}" for name in OPTIONAL for n in optional_subpackage(name).__all__]
    return [*names, *EXTRA, *optional]


def public_members(cls):
    """The public methods and properties of class ``cls`` that its page documents, in definition order.

    Its own and those inherited from mjflex classes (not from Python's builtins: an exception's ``with_traceback``):
    functions, class and static methods and properties whose name has no leading underscore. Data fields (a data
    class's, a named tuple's) are described in the class docstring's Attributes section instead.
    """
    names = []
    for owner in reversed(cls.__mro__):
        if not (getattr(owner, "__module__", "") or "").startswith("mjflex"):
            continue
        for name, value in vars(owner).items():
            if name.startswith("_") or name in names:
                continue
            if inspect.isfunction(value) or isinstance(value, classmethod | staticmethod | property):
                names.append(name)
    return names


def sections():
    """``[(title, intro, [qualified names])]`` of the API page: ``START`` first, then ``SECTIONS``."""
    grouped = {title: [] for _, title, _ in SECTIONS}
    for qualified in public_names():
        if qualified in START:
            continue
        module = getattr(_resolve(qualified), "__module__", "") or ""
        title = next(t for prefix, t, _ in SECTIONS if module.startswith(prefix))
        grouped[title].append(qualified)
    first = (*START_TITLE, [name for name in START if name in public_names()])
    return [first, *((title, intro, grouped[title]) for _, title, intro in SECTIONS if grouped[title])]


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
        "below as ``mjflex.NAME`` (``mjflex.geometry.NAME`` for stiffness from geometry); ``import mjflex.warp`` "
        "gives ``mjflex.warp.NAME`` (MuJoCo Warp, an optional extra). Units are SI; arrays batch-first, 6-vectors "
        "angular first (:doc:`conventions`).",
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
        if isinstance(obj, type):  # autodoc skips a member without a docstring: its class page would not list it
            for name in public_members(obj):
                if not inspect.getdoc(getattr(obj, name)):
                    logger.warning(f"public member {qualified}.{name} has no docstring: write one (or make it "
                                   "private with a leading underscore)", type="mjflex")  # fmt: skip


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

    A reference to an object documented under its public name (``mjflex.variants.variant.Variant``,
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


STUDY = os.path.join(HERE, "..", "study")
#: A study report's first line (the writer of ``mjflex study``, :meth:`mjflex.app.study.StudyResult.to_markdown`).
STUDY_TITLE = "# Speed-accuracy study:"
#: Sections of a study report kept whole on its page; the others are summed up there (the full report, with every run,
#: is a page of its own, written at each build into ``study/full/``, ignored by git).
STUDY_KEPT = ("Recommendation", "Which choice for which need", "Largest stable step", "At the model file's step")


def study_reports():
    """``{docname: path}`` of the study reports under ``docs/study`` (``study/study_arcade``)."""
    out = {}
    for name in sorted(os.listdir(STUDY)) if os.path.isdir(STUDY) else []:
        path = os.path.join(STUDY, name)
        if name.endswith(".md") and os.path.isfile(path):
            with open(path, encoding="utf-8") as f:
                if f.readline().startswith(STUDY_TITLE):
                    out[f"study/{name[:-3]}"] = path
    return out


def summarize_study(text, full_doc):
    """A study report (Markdown) as its page shows it: the sections of ``STUDY_KEPT`` whole, each variant's first line,
    and the runs counted, with a link to the full report (``full_doc``, a docname) for the per-element reports and the
    table of every run (hundreds of rows, messages of a few hundred characters)."""
    head, *sections = text.split("\n## ")
    link = f"{{doc}}`the full report </{full_doc}>`"
    out = [head.rstrip() + f"\n- every run, the variants' reports element by element: {link}\n"]
    for section in sections:
        title, _, body = section.partition("\n")
        if title in STUDY_KEPT:
            out.append(f"## {title}\n{body.rstrip()}\n")
        elif title == "Variants":
            firsts = [line for line in body.splitlines() if line.startswith("- **")]
            out.append("## Variants\n\n" + "\n".join(firsts) + f"\n\nWhat became of each element: {link}.\n")
        elif title == "Candidates":
            rows = [line for line in body.splitlines() if line.startswith("| ") and not line.startswith("| variant")]
            status = {}
            for row in rows:
                cells = [c.strip() for c in row.strip("|").split("|")]
                if len(cells) > 4:  # variant, method, integrator, h, status, ...
                    status[cells[4]] = status.get(cells[4], 0) + 1
            counts = ", ".join(f"{n} {s}" for s, n in sorted(status.items()))
            out.append(f"## Candidates\n\n{len(rows)} runs ({counts}): each with its errors, cost and what stopped "
                       f"it, in {link}.\n")  # fmt: skip
        else:
            out.append(f"## {title}\n\nIn {link}.\n")
    return "\n".join(out)


def write_full_studies(app, config=None):
    """``study/full/<stem>.md``: each study report whole (not in a toctree: the summary links it)."""
    folder = os.path.join(STUDY, "full")
    for path in study_reports().values():
        with open(path, encoding="utf-8") as f:
            text = f.read()
        title, _, rest = text.partition("\n")
        page = f"---\norphan: true\n---\n\n{title} (full report)\n{rest}"
        target = os.path.join(folder, os.path.basename(path))
        os.makedirs(folder, exist_ok=True)
        if not os.path.exists(target) or open(target, encoding="utf-8").read() != page:
            with open(target, "w", encoding="utf-8") as f:
                f.write(page)


def summarize_studies(app, docname, source):
    """``source-read``: a study report's page is its summary (:func:`summarize_study`)."""
    if docname in study_reports():
        source[0] = summarize_study(source[0], f"study/full/{docname.rpartition('/')[2]}")


def outdated_studies(app, env, added, changed, removed):
    """``env-get-outdated``: the study pages are read at every build (their summary is made when read)."""
    return [docname for docname in study_reports() if docname in env.found_docs]


MUJOCO_LOG = "MUJOCO_LOG.TXT"
#: Python's ``warnings.formatwarning`` in a tutorial's captured output: ``path:line: Category: message``.
PYTHON_WARNING = re.compile(r":\d+: (?P<category>\w*Warning): (?P<text>.*)$", re.M)
_log_sizes = {}  # MuJoCo log -> its size before the tutorial ran


def _mujoco_logs(gallery_conf):
    """MuJoCo writes its log in the working folder: the tutorials' (sphinx-gallery runs them there), or the build's."""
    folders = [os.path.join(gallery_conf["src_dir"], d) for d in gallery_conf["examples_dirs"]] + [os.getcwd()]
    return sorted({os.path.join(os.path.abspath(f), MUJOCO_LOG) for f in folders})


def _new_log_entries(log):
    size = os.path.getsize(log) if os.path.exists(log) else 0
    if size <= _log_sizes.get(log, 0):
        return []
    with open(log, encoding="utf-8", errors="replace") as f:
        f.seek(_log_sizes.get(log, 0))
        return [line.strip() for line in f if line.strip()]


def tutorial_problems(output, log_entries):
    """Why a tutorial's run is not a result: ``output`` its generated page (reST with the captured output),
    ``log_entries`` what MuJoCo wrote to its log meanwhile. Empty: nothing."""
    found = [f"MuJoCo warned (its log): {entry}" for entry in log_entries]
    found += [f"{m['category']} printed: {m['text']}" for m in PYTHON_WARNING.finditer(output)]
    return found


def reset_mujoco(gallery_conf, fname, when=None):
    """sphinx-gallery ``reset_modules`` entry, before and after each tutorial: no passive-force callback or
    MuJoCo warning handler survives a tutorial, and a warning printed during one is reported (module docstring)."""
    import mujoco

    try:
        from mjflex.runtime import registry

        registry.uninstall_all()
    finally:
        mujoco.set_mjcb_passive(None)
        mujoco.set_mju_user_warning(None)  # MuJoCo's own handler: prints, and writes its log
    if fname is None:
        return
    logs = _mujoco_logs(gallery_conf)
    if when != "after":
        _log_sizes.update({log: os.path.getsize(log) if os.path.exists(log) else 0 for log in logs})
        return
    stem = os.path.splitext(os.path.basename(str(fname)))[0]
    pages = [os.path.join(gallery_conf["src_dir"], d, stem + ".rst") for d in gallery_conf["gallery_dirs"]]
    output = ""
    for page in pages:
        if os.path.exists(page):
            with open(page, encoding="utf-8") as f:
                output += f.read()
    for problem in tutorial_problems(output, [entry for log in logs for entry in _new_log_entries(log)]):
        logger.warning(f"tutorial {stem}: {problem}: a tutorial's run must be a result (catch a warning shown on "
                       "purpose)", type="mjflex")  # fmt: skip


def leaked_paths():
    """Paths of this machine that must not appear in a built page: the source checkout, the Python environment."""
    root = os.path.dirname(os.path.dirname(HERE))
    paths = {root, sys.prefix, sys.base_prefix, sysconfig.get_paths()["purelib"]}
    return sorted(p for p in paths if p and len(p) > 1)


def check_leaks(app, exception):
    """``build-finished``: warn about every built page holding a path of this machine (:func:`leaked_paths`)."""
    if exception is not None or app.builder.format != "html":
        return
    paths = leaked_paths()
    for folder, _, files in os.walk(app.outdir):
        for name in files:
            if not name.endswith((".html", ".txt", ".js")):
                continue
            path = os.path.join(folder, name)
            with open(path, encoding="utf-8", errors="replace") as f:
                text = f.read()
            for leak in (p for p in paths if p in text):
                at = text.index(leak)
                context = text[max(0, at - 80) : at + len(leak) + 40].replace("\n", " ")
                logger.warning(f"{os.path.relpath(path, app.outdir)} shows the local path {leak!r}: ...{context}...",
                               type="mjflex")  # fmt: skip


def setup(app):
    from pygments.lexers.special import TextLexer

    app.add_lexer("output", TextLexer)  # what a code block prints: a fence of language "output" right after it
    app.connect("config-inited", write_api_page)  # before Sphinx lists the sources and autosummary reads them
    app.connect("config-inited", write_full_studies)
    app.connect("source-read", summarize_studies)
    app.connect("env-get-outdated", outdated_studies)
    app.connect("missing-reference", resolve_alias)
    app.connect("build-finished", check_leaks)
    app.add_directive("mjflex-error-bands", ErrorBands)
    return {"parallel_read_safe": True, "parallel_write_safe": True, "version": "1"}


__all__ = [
    "api_page",
    "check_leaks",
    "leaked_paths",
    "missing_dependencies",
    "optional_subpackage",
    "public_members",
    "public_names",
    "reset_mujoco",
    "sections",
    "setup",
    "study_reports",
    "summarize_study",
    "tutorial_problems",
]

"""Sphinx configuration of the mjflex documentation (build: ``python -m mjflex docs``).

Pages are Markdown (MyST); the API reference is generated from the docstrings (numpydoc) of every
public name (``docs/_ext/mjflex_docs.py`` writes the autosummary page from ``mjflex.__all__``);
tutorials are sphinx-gallery scripts in ``docs/tutorials/``, executed by the build, which draws
their figures. Links to MuJoCo's, numpy's and scipy's documentation (intersphinx) go through
inventories kept in the repository (``docs/_inventories``, written by
``scripts/docs_inventories.py``): the build needs no network. Third-party types without an
inventory are listed in ``nitpick_ignore_regex`` below.
"""

import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "_ext"))
sys.path.insert(0, os.path.dirname(HERE))  # the source checkout's mjflex, also without an install

if sys.platform.startswith("linux") and not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
    os.environ.setdefault("MUJOCO_GL", "egl")  # tutorials that render, headless (MUJOCO_GL=osmesa elsewhere)

import mjflex_docs  # noqa: E402

import mjflex  # noqa: E402

project = "mjflex"
author = "the mjflex developers"
copyright = "the mjflex developers; Apache-2.0"
release = version = mjflex.__version__

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.intersphinx",
    "sphinx.ext.mathjax",
    "sphinx.ext.viewcode",  # [source] links: the package's code, highlighted, beside its reference
    "numpydoc",
    "myst_parser",
    "sphinx_gallery.gen_gallery",
    "sphinxarg.ext",
    "sphinx_copybutton",
    "mjflex_docs",
]

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
templates_path = ["_templates"]
# results/ and study/ hold recorded measurements that scripts read; sphinx-gallery writes its
# outputs under _generated/ (ignored by git), as does mjflex_docs (the API page)
exclude_patterns = ["_build", "_generated", "results", "study/*.json", "tutorials/GALLERY_HEADER.rst"]

# ----------------------------------------------------------------------------- strict references
nitpicky = True
#: Types from packages without a local inventory (no intersphinx: the build must work offline).
nitpick_ignore_regex = [
    ("py:class", r"(numpy|np|mujoco|xarray|scipy|concurrent|multiprocessing|distributed|os)(\..*)?"),
    ("py:class", r"(ndarray|array_like|optional|callable|MjModel|MjData|MjSpec|Dataset|Executor)"),
    ("py:class", r"(pathlib\.)?Path|os\.PathLike|collections\.abc\..*|typing\..*|dataclasses\..*"),
    ("py:(class|exc)", r"(Warning|UserWarning|ValueError|TypeError|Exception|RuntimeError)"),
]

# ----------------------------------------------------------------------------- links out
#: MuJoCo's, numpy's and scipy's pages, through inventories of the repository (no download at build time; see the
#: module docstring): ``{class}`mujoco.MjModel``` and the types of the numpydoc sections link there.
INVENTORIES = os.path.join(HERE, "_inventories")
intersphinx_mapping = {
    "mujoco": ("https://mujoco.readthedocs.io/en/stable/", os.path.join(INVENTORIES, "mujoco.inv")),
    "numpy": ("https://numpy.org/doc/stable/", os.path.join(INVENTORIES, "numpy.inv")),
    "scipy": ("https://docs.scipy.org/doc/scipy/", os.path.join(INVENTORIES, "scipy.inv")),
    "python": ("https://docs.python.org/3/", os.path.join(INVENTORIES, "python.inv")),  # numpydoc's builtins
}

# ----------------------------------------------------------------------------- API reference
autosummary_generate = True
# mjflex.warp needs the warp extra (warp-lang, mujoco-warp: 149 MB), which the docs extra leaves out: where they are
# not installed, autodoc and autosummary import it with them mocked, as mjflex_docs does (mjflex_docs.OPTIONAL)
autodoc_mock_imports = mjflex_docs.missing_dependencies()
autosummary_imported_members = True
# class pages: the template (_templates/autosummary/class.rst) documents every public method and property, own or
# inherited from an mjflex base class, in source order; mjflex_docs.public_members says which must have an entry
autodoc_default_options = {"member-order": "bysource"}
autodoc_typehints = "none"  # the numpydoc sections state types, shapes and units
numpydoc_show_class_members = False  # the class template lists the members
numpydoc_class_members_toctree = False
# the types of Parameters / Returns link where they name a documented third-party type; other words stay text
numpydoc_xref_param_type = True
numpydoc_xref_ignore = "all"
numpydoc_xref_aliases = {
    "numpy.ndarray": "numpy.ndarray",
    **{name: f":class:`{name}`" for name in (
        "mujoco.MjModel", "mujoco.MjData", "mujoco.MjSpec", "mujoco.MjsBody", "mujoco.MjsSite", "mujoco.MjsText",
        "mujoco.MjsPlugin", "mujoco_warp.Model", "mujoco_warp.Data",
    )},
}  # fmt: skip

# ----------------------------------------------------------------------------- Markdown
myst_enable_extensions = ["colon_fence", "dollarmath", "deflist"]
myst_heading_anchors = 3
# quotes and ellipses typeset, dashes not: `--out` in prose stays two hyphens (an en dash pasted into a shell fails)
smartquotes_action = "qe"

# ----------------------------------------------------------------------------- tutorials
sphinx_gallery_conf = {
    "examples_dirs": ["tutorials"],
    "gallery_dirs": ["auto_tutorials"],
    "filename_pattern": r"/plot_",  # every tutorial runs at build time,
    "run_stale_examples": True,  # every build, also when a script is unchanged (the code it calls may not be)
    "within_subsection_order": "FileNameSortKey",
    "download_all_examples": False,
    "remove_config_comments": True,
    "abort_on_example_error": False,  # report every failing tutorial; -W fails the build
    "only_warn_on_example_error": False,
    "matplotlib_animations": False,
    "image_scrapers": ("matplotlib",),
    "reset_modules": ("matplotlib", "mjflex_docs.reset_mujoco"),
    "reset_modules_order": "both",  # after each tutorial too: mjflex_docs reports the warnings it printed
    "show_memory": False,
    "min_reported_time": 0,
    "capture_repr": (),  # printed output only, not the value of a block's last expression
    "example_extensions": {".py"},
}

# ----------------------------------------------------------------------------- HTML
html_theme = "furo"
html_title = f"mjflex {release}"
html_static_path = ["_static"]
html_css_files = ["mjflex.css"]  # code blocks fit the content column (a wider column on wide screens, long lines wrap)
# the copy button on code, not on what it prints (output blocks, mjflex_docs) nor on prompts
copybutton_selector = "div:not(.highlight-output) > div.highlight pre"
copybutton_exclude = ".linenos, .gp"
html_show_sourcelink = False
suppress_warnings = []

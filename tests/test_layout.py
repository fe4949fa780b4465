"""The package's layout holds: the layers import only downwards, no import circles, nothing private crosses a module.

The layers (docs/reference/layout.md) are the path of an element: ``mjflex.core`` (the screw-theory reference),
``mjflex.geometry`` and ``mjflex.native`` (the C library's bindings) at the bottom; ``mjflex.mjcf`` (an element in
MJCF or an MjSpec); ``mjflex.runtime`` (the compiled model's elements and forces); ``mjflex.analysis``
(linearization); ``mjflex.variants`` and ``mjflex.warp`` (other models, other engines); ``mjflex.app`` on top. A
module may import its own package and any package of a lower rank, never one of its rank or above.

The imports are read from the sources (``ast``), those inside functions too. A circle is refused unless an import
that closes it is inside a function and says on its line why it is late (a comment: a heavy or optional dependency
kept out of ``import mjflex``). The C library (``mjflex/native``) is held to the same: no include circles between
its modules (a ``.c`` and its ``.h`` are one module, and a header alone is one) and the same length limit. Each
check runs on the package, and on a small package with one planted violation that it must find.
"""

import ast
import os
import re
import textwrap

import pytest

import mjflex

#: The package that runs: the checkout's, or the installed wheel's where the tree has no sources (build_release.py).
ROOT = os.path.dirname(os.path.abspath(mjflex.__file__))

#: Rank of each package: a module imports its own package or lower ranks only.
LAYERS = {
    "mjflex.core": 0,
    "mjflex.geometry": 1,
    "mjflex.native": 1,
    "mjflex.mjcf": 2,
    "mjflex.runtime": 3,
    "mjflex.analysis": 4,
    "mjflex.variants": 5,
    "mjflex.warp": 5,
    "mjflex.app": 6,
    "mjflex.mj": 7,  # the deprecated alias of the old flat layer (imports by name, at run time)
    "mjflex": 8,  # the facade: mjflex/__init__.py and __main__.py
}
#: Most lines of a module (the aim is ~600; a module that grows past this is split).
MAX_LINES = 650


def modules(root):
    """``{module name: path}`` of the package below ``root`` (a folder named like its package)."""
    out = {}
    for folder, _, files in os.walk(root):
        for f in files:
            if f.endswith(".py"):
                rel = os.path.relpath(os.path.join(folder, f), os.path.dirname(root))[:-3]
                out[rel.replace(os.sep, ".").removesuffix(".__init__")] = os.path.join(folder, f)
    return out


def imports(root):
    """``[(importer, imported module, imported name or None, lazy, line text)]`` of the package below ``root``."""
    mods = modules(root)
    found = []
    for name, path in mods.items():
        with open(path, encoding="utf-8") as f:
            text = f.read()
        lines = text.splitlines()
        package = name if path.endswith("__init__.py") else name.rpartition(".")[0]
        tree = ast.parse(text)
        top_level = {id(n) for n in tree.body} | {
            id(c) for n in tree.body if isinstance(n, ast.If | ast.Try) for c in ast.walk(n)
        }  # fmt: skip
        for node in ast.walk(tree):
            lazy = id(node) not in top_level
            line = lines[node.lineno - 1] if hasattr(node, "lineno") else ""
            if isinstance(node, ast.ImportFrom):
                if node.level:
                    base = package.split(".")[: len(package.split(".")) - node.level + 1]
                    source = ".".join(base + ([node.module] if node.module else []))
                else:
                    source = node.module
                for alias in node.names:
                    if f"{source}.{alias.name}" in mods:
                        found.append((name, f"{source}.{alias.name}", None, lazy, line))
                    elif source in mods:
                        found.append((name, source, alias.name, lazy, line))
            elif isinstance(node, ast.Import):
                for alias in node.names:
                    if alias.name in mods:
                        found.append((name, alias.name, None, lazy, line))
    return found


def _layer(module):
    parts = module.split(".")
    for n in range(len(parts), 0, -1):
        if ".".join(parts[:n]) in LAYERS:
            return ".".join(parts[:n])
    return None


def layer_violations(root, layers=LAYERS):
    """Imports of a package of the same or a higher rank than the importer's own."""
    out = []
    for importer, module, _, _, line in imports(root):
        mine, theirs = _layer(importer), _layer(module)
        if mine is None or theirs is None or mine == theirs:
            continue
        if layers[theirs] >= layers[mine]:
            out.append(f"{importer} (rank {layers[mine]}) imports {module} (rank {layers[theirs]}): {line.strip()}")
    return out


def circles(root):
    """The import circles (strongly connected components of more than one module): late imports with a comment on
    their line (why they are late) do not count."""
    graph = {}
    for importer, module, _, lazy, line in imports(root):
        if importer == module or (lazy and "#" in line):
            continue
        graph.setdefault(importer, set()).add(module)
    return _components(graph)


_COMMENT = re.compile(r"//[^\n]*|/\*.*?\*/", re.DOTALL)
_PROTOTYPE = re.compile(r"^[A-Za-z_][^#;{}()]*?\b(mjfx_\w+)\s*\([^;{}]*\)\s*;", re.MULTILINE)
_DEFINITION = re.compile(r"^[A-Za-z_][^#;{}()]*?\b(mjfx_\w+)\s*\([^;{}]*\)\s*\{", re.MULTILINE)


def c_includes(native):
    """``{module: modules it needs}`` of the C sources in ``native`` (``x.c`` and ``x.h`` are module ``x``): the
    modules of the headers it includes, and those whose ``.c`` defines a function its header declares (a header
    declares its own module's functions; another's make the module depend on that one)."""
    texts = {}
    for f in sorted(os.listdir(native)):
        if f.endswith((".c", ".h")):
            with open(os.path.join(native, f), encoding="utf-8") as source:
                texts[f] = _COMMENT.sub("", source.read())
    defined = {name: f[:-2] for f, text in texts.items() if f.endswith(".c") for name in _DEFINITION.findall(text)}
    graph = {}
    for f, text in texts.items():
        needs = set(re.findall(r'^\s*#\s*include\s+"([^"]+)\.h"', text, flags=re.MULTILINE))
        if f.endswith(".h"):
            needs |= {defined[name] for name in _PROTOTYPE.findall(text) if name in defined}
        graph.setdefault(f[:-2], set()).update(m for m in needs if m != f[:-2])
    return graph


def c_circles(native):
    """The include circles between the C library's modules."""
    return _components(c_includes(native))


def long_c_files(native, limit=MAX_LINES):
    files = sorted(f for f in os.listdir(native) if f.endswith((".c", ".h")))
    with_lines = {f: sum(1 for _ in open(os.path.join(native, f), encoding="utf-8")) for f in files}
    return [f"{f}: {n} lines" for f, n in with_lines.items() if n > limit]


def _components(graph):
    """The strongly connected components of more than one node of ``graph`` (Tarjan), each sorted."""
    index, low, stack, on, out, counter = {}, {}, [], set(), [], [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in graph.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                out.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def private_imports(root):
    """Private names imported from another module, and private modules imported from outside their package."""
    out = []
    for importer, module, name, _, line in imports(root):
        if name is not None and name.startswith("_") and not name.startswith("__") and module != importer:
            out.append(f"{importer} imports the private name {name} of {module}: {line.strip()}")
        private = [i for i, part in enumerate(module.split(".")) if part.startswith("_") and not part.startswith("__")]
        if private:
            owner = ".".join(module.split(".")[: private[0]])
            if not (importer == owner or importer.startswith(owner + ".")):
                out.append(f"{importer} imports {module}, private to {owner}: {line.strip()}")
    return out


def late_imports_without_reason(root):
    """Imports inside a function (or a class) with no comment on their lines: docs/reference/layout.md asks each late
    import to say why it is late (a heavy or optional dependency kept out of ``import mjflex``); any import counts,
    of mjflex or not."""
    out = []
    for name, path in modules(root).items():
        with open(path, encoding="utf-8") as f:
            text = f.read()
        lines, tree = text.splitlines(), ast.parse(text)
        top_level = {id(n) for n in tree.body} | {
            id(c) for n in tree.body if isinstance(n, ast.If | ast.Try) for c in ast.walk(n)
        }  # fmt: skip
        for node in ast.walk(tree):
            if isinstance(node, ast.Import | ast.ImportFrom) and id(node) not in top_level:
                if not any("#" in line for line in lines[node.lineno - 1 : node.end_lineno]):
                    out.append(f"{name}:{node.lineno}: {lines[node.lineno - 1].strip()}")
    return out


def long_modules(root, limit=MAX_LINES):
    with_lines = {name: sum(1 for _ in open(path, encoding="utf-8")) for name, path in modules(root).items()}
    return [f"{name}: {n} lines" for name, n in sorted(with_lines.items()) if n > limit]


# ----------------------------------------------------------------------------- the package


def test_each_layer_imports_only_the_layers_below():
    assert layer_violations(ROOT) == []


def test_no_import_circles():
    assert circles(ROOT) == []


def test_nothing_private_is_imported_across_modules():
    assert private_imports(ROOT) == []


def test_every_late_import_says_why_on_its_line():
    assert late_imports_without_reason(ROOT) == []


def test_the_c_library_has_no_include_circles_and_short_files():
    native = os.path.join(ROOT, "native")
    if not any(f.endswith(".c") for f in os.listdir(native)):  # an installed wheel: the library, not its sources
        return
    assert {"schema", "config", "instances", "plugin", "flexure_kernel"} <= set(c_includes(native))
    assert c_circles(native) == []
    assert long_c_files(native) == []


def test_every_package_module_is_in_a_layer_and_short():
    assert {"mjflex.core.elements", "mjflex.runtime.flexures", "mjflex.app.cli"} <= set(modules(ROOT)), ROOT
    unplaced = [m for m in modules(ROOT) if _layer(m) is None]
    assert unplaced == []
    assert long_modules(ROOT) == []


# ----------------------------------------------------------------------------- the checks find planted violations


def _package(tmp_path, files):
    root = tmp_path / "mjflex"
    for rel, text in {**files, "__init__.py": ""}.items():
        path = root / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        for parent in path.relative_to(root).parents:
            (root / parent / "__init__.py").touch()
        path.write_text(textwrap.dedent(text))
    return str(root)


@pytest.mark.parametrize(
    "files, check, expected",
    [
        ({"mjcf/build.py": "from ..runtime import flexures\n", "runtime/flexures.py": ""}, layer_violations,
         "mjflex.mjcf.build (rank 2) imports mjflex.runtime.flexures (rank 3)"),
        ({"warp/a.py": "from ..variants import b\n", "variants/b.py": ""}, layer_violations, "rank 5) imports"),
        ({"app/a.py": "from . import b\n", "app/b.py": "def f():\n    from . import a\n"}, circles,
         ["mjflex.app.a", "mjflex.app.b"]),
        ({"core/a.py": "from .b import _helper\n", "core/b.py": "def _helper(): pass\n"}, private_imports,
         "imports the private name _helper of mjflex.core.b"),
        ({"app/a.py": "from ..core import _kernels\n", "core/_kernels.py": ""}, private_imports,
         "imports mjflex.core._kernels, private to mjflex.core"),
        ({"app/a.py": "x = 1\n" * (MAX_LINES + 1)}, long_modules, f"mjflex.app.a: {MAX_LINES + 1} lines"),
        ({"app/a.py": "def f():\n    import json  # stdlib: fine late, with a reason\n    import xarray\n"},
         late_imports_without_reason, "mjflex.app.a:3: import xarray"),
    ],
    ids=["layer order", "same rank", "circle", "private name", "private module", "long module", "late import"],
)  # fmt: skip
def test_a_planted_violation_is_found(tmp_path, files, check, expected):
    found = check(_package(tmp_path, files))
    if isinstance(expected, list):
        assert expected in found
    else:
        assert any(expected in f for f in found), found


@pytest.mark.parametrize(
    "files, check, expected",
    [
        ({"a.c": '#include "a.h"\n#include "b.h"\n', "a.h": "", "b.c": '#include "a.h"\n', "b.h": ""}, c_circles,
         ["a", "b"]),
        ({"k.h": '#include "m.h"\n', "m.c": '#include "k.h"\n', "m.h": ""}, c_circles, ["k", "m"]),
        ({"i.h": "int mjfx_slot(void);\n", "i.c": '#include "i.h"\n',
          "p.c": '#include "i.h"\nint mjfx_slot(void) {}\n'}, c_circles, ["i", "p"]),
        ({"a.c": "int x;\n" * (MAX_LINES + 1)}, long_c_files, f"a.c: {MAX_LINES + 1} lines"),
    ],
    ids=["c circle", "a header and a source above and below it", "a function declared here, defined there",
         "long c file"],
)  # fmt: skip
def test_a_planted_c_violation_is_found(tmp_path, files, check, expected):
    for name, text in files.items():
        (tmp_path / name).write_text(text)
    found = check(str(tmp_path))
    assert expected in found if isinstance(expected, list) else any(expected in f for f in found), found


def test_a_late_import_that_says_why_closes_no_circle(tmp_path):
    files = {"app/a.py": "from . import b\n", "app/b.py": "def f():\n    from . import a  # heavy: late\n"}
    assert circles(_package(tmp_path, files)) == []

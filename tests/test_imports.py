"""The import graph of ``pipeline/rockdove/``: no cycle, no edge against the data flow, no private name across packages.

The graph is read from the source with :mod:`ast` (nothing is imported), with module-level and
function-level imports, absolute and relative. An edge ``a -> b`` means module ``a`` names module ``b`` in an
import statement:

- ``import rockdove.x.y`` and ``from rockdove.x.y import name`` give ``a -> rockdove.x.y``;
- ``from rockdove.x import y`` gives ``a -> rockdove.x.y`` when ``y`` is a submodule (the statement imports
  that module), else ``a -> rockdove.x`` (the name comes from the package's ``__init__``);
- a package ``__init__`` re-exporting its submodules has edges to them like any other module, so a submodule
  that imports a name from its own package ``__init__`` closes a cycle.

The implicit import of every parent package when a submodule loads is not an edge (it is what makes a package
at all). The ``rockdove`` package is cut at its first level: ``rockdove.lut.bake`` belongs to package ``lut``,
``rockdove.films`` to ``films``, ``pipeline/rockdove/__init__.py`` to ``rockdove``.
"""

from __future__ import annotations

import ast
import collections
import functools
from pathlib import Path

import rockdove

ROOT = Path(rockdove.__file__).resolve().parent

# The data flow, low to high (docs/design.md, /work/shared/ARCHITECTURE.md): a module may import modules of its
# own layer or of lower layers only. Packages within one layer may import each other, but only one way.
LAYERS = [
    ({"rockdove", "errors", "_compat", "resources", "config", "sources", "png", "digest", "cache"},
     "foundations: the version, error types, optional-import shims, data-file lookup, the checked config, "
     "the digest of the code a callable can execute, the one PNG writer, the content digest helper and the "
     "content-addressed store the build's stages and the verification's items share"),
    ({"films", "optics", "spectral", "srgb"},
     "physics: film model -> Airy reflectance -> spectrum to colour; knows nothing of tables, meshes or USD"),
    ({"lut"},
     "the thin-film colour table baked from the physics, its exact reference and its files"),
    ({"geometry"},
     "the bird's meshes and film-thickness field as numpy values, ranges from the config; knows nothing of USD"),
    ({"rig"},
     "the skeleton, skin weights and motions as numpy values, placed from the geometry; knows nothing of USD"),
    ({"textures"},
     "images derived from the LUT and the geometry (feather base, mask, body colour)"),
    ({"usd"},
     "authoring the asset: layers, material networks, schema, usdz and the validator over them"),
    ({"render"},
     "reads a written USD back: scene, views, our GL renderer, images"),
    ({"web", "hosts"},
     "host adapters at the edge: each reads the written asset and renders it in one host"),
    ({"verify"},
     "compares every host's render with the exact reference and writes the report"),
    ({"graph"},
     "the build graph: runs the stages above (verification included) into the output folder and publishes atomically"),
    ({"api"},
     "the library API: configuration, build and verification as typed values (what the commands call)"),
    ({"bench", "commands"},
     "benchmarks and one module per CLI command, calling the stages"),
    ({"cli"},
     "parses arguments and dispatches to commands; nothing imports it"),
]
LAYER_OF = {package: rank for rank, (packages, _reason) in enumerate(LAYERS) for package in packages}


def package_of(module: str) -> str:
    """``rockdove.lut.bake`` -> ``lut``; ``rockdove`` -> ``rockdove``."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else parts[0]


def is_private(name: str) -> bool:
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


@functools.cache
def modules() -> dict[str, Path]:
    """Dotted module name -> source file, for every module of the installed ``rockdove`` package."""
    found = {}
    for path in sorted(ROOT.rglob("*.py")):
        rel = path.relative_to(ROOT.parent).with_suffix("")
        if "node_modules" in rel.parts:
            continue
        parts = list(rel.parts)
        if parts[-1] == "__init__":
            parts.pop()
        found[".".join(parts)] = path
    return found


@functools.cache
def tree(module: str) -> ast.Module:
    path = modules()[module]
    return ast.parse(path.read_text(), str(path))


def _from_target(package: str, node: ast.ImportFrom) -> str:
    """The absolute module a ``from ... import`` statement in ``package`` names (``..films`` -> rockdove.films)."""
    if not node.level:
        return node.module or ""
    parts = package.split(".")
    return ".".join(parts[: len(parts) - node.level + 1] + ([node.module] if node.module else []))


@functools.cache
def imports() -> tuple[tuple[str, str, int, tuple[str, ...]], ...]:
    """Every import of a ``rockdove`` module: (importer, imported module, line, names taken from it)."""
    mods = modules()
    rows = []
    for module, path in mods.items():
        package = module if path.name == "__init__.py" else module.rpartition(".")[0]
        for node in ast.walk(tree(module)):
            if isinstance(node, ast.Import):
                for alias in node.names:
                    if alias.name in mods:
                        rows.append((module, alias.name, node.lineno, ()))
            elif isinstance(node, ast.ImportFrom):
                target = _from_target(package, node)
                if target != "rockdove" and not target.startswith("rockdove."):
                    continue
                from_package = []
                for alias in node.names:
                    submodule = f"{target}.{alias.name}"
                    if submodule in mods:
                        rows.append((module, submodule, node.lineno, ()))
                    else:
                        from_package.append(alias.name)
                if from_package:
                    assert target in mods, f"{module}:{node.lineno} imports from {target}, which is not a module"
                    rows.append((module, target, node.lineno, tuple(from_package)))
    return tuple(rows)


def edges() -> dict[str, set[str]]:
    graph = collections.defaultdict(set)
    for importer, imported, _line, _names in imports():
        if importer != imported:
            graph[importer].add(imported)
    return graph


def cycles() -> list[list[tuple[str, str]]]:
    """The strongly connected components of the module graph with more than one module, as their edges."""
    graph = edges()
    index, low, stack, on_stack, found = {}, {}, [], set(), []

    def visit(v):  # Tarjan (1972)
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = set()
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.add(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted((a, b) for a in component for b in graph[a] if b in component))

    for v in sorted(modules()):
        if v not in index:
            visit(v)
    return found


def layer_violations() -> list[tuple[str, str, str]]:
    """Edges from a lower layer to a higher one, and packages missing from LAYERS: (importer, imported, why)."""
    bad = []
    for module in sorted(modules()):
        if package_of(module) not in LAYER_OF:
            bad.append((module, "", f"package {package_of(module)!r} is in no layer of LAYERS"))
    for a, targets in sorted(edges().items()):
        for b in sorted(targets):
            pa, pb = package_of(a), package_of(b)
            if pa != pb and pa in LAYER_OF and pb in LAYER_OF and LAYER_OF[pa] < LAYER_OF[pb]:
                bad.append((a, b, f"{pa} (layer {LAYER_OF[pa]}) imports {pb} (layer {LAYER_OF[pb]})"))
    return bad


def same_layer_two_way() -> list[tuple[str, str, str]]:
    """Module edges between two packages of one layer that import each other both ways (across layers, the
    edge going up is already a layer violation)."""
    by_pair = collections.defaultdict(list)
    for a, targets in edges().items():
        for b in targets:
            pa, pb = package_of(a), package_of(b)
            if pa != pb:
                by_pair[pa, pb].append((a, b))
    bad = []
    for (pa, pb), pairs in sorted(by_pair.items()):
        if pa < pb and (pb, pa) in by_pair and LAYER_OF.get(pa, -1) == LAYER_OF.get(pb, -2):
            bad += [(a, b, f"{pa} and {pb} import each other") for a, b in sorted(pairs + by_pair[pb, pa])]
    return bad


def private_violations() -> list[tuple[str, str, str]]:
    """Private names (``_x``) that cross packages, by ``from m import _x`` or by ``alias._x`` on an imported
    module: (importer, imported module, name with line)."""
    mods = modules()
    bad = []
    for importer, imported, line, names in imports():
        if package_of(importer) != package_of(imported):
            bad += [(importer, imported, f"{name} (line {line})") for name in names if is_private(name)]
    for module, path in mods.items():
        bound = {}  # local name -> module it refers to, for module objects bound by an import statement
        package = module if path.name == "__init__.py" else module.rpartition(".")[0]
        for node in ast.walk(tree(module)):
            if isinstance(node, ast.Import):
                for alias in node.names:
                    if alias.asname and alias.name in mods:
                        bound[alias.asname] = alias.name
            elif isinstance(node, ast.ImportFrom):
                target = _from_target(package, node)
                for alias in node.names:
                    if f"{target}.{alias.name}" in mods:
                        bound[alias.asname or alias.name] = f"{target}.{alias.name}"
        for node in ast.walk(tree(module)):
            if (isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and node.value.id in bound
                    and is_private(node.attr) and package_of(bound[node.value.id]) != package_of(module)):
                bad.append((module, bound[node.value.id], f"{node.value.id}.{node.attr} (line {node.lineno})"))
    return bad


def _lines(rows) -> str:
    return "\n".join("  " + "  ".join(str(part) for part in row if part) for row in rows)


def test_the_graph_sees_the_imports_it_should():
    """Negative control for the parser: known edges of each kind are found (else the tests below pass on an
    empty graph)."""
    graph = edges()
    assert "rockdove.lut.table" in graph["rockdove.lut.bake"]          # relative, module level
    assert "rockdove.films" in graph["rockdove.lut.bake"]              # relative to the parent package
    assert "rockdove.lut.bake" in graph["rockdove.lut"]                # a package __init__ re-exporting
    assert "rockdove.lut.exr" in graph["rockdove.usd.textures_io"]     # absolute, inside a function
    assert len(modules()) > 60


def test_no_import_cycle_among_modules():
    found = cycles()
    assert not found, "import cycles (each block is one cycle's edges, importer -> imported):\n" + "\n\n".join(
        "\n".join(f"  {a} -> {b}" for a, b in component) for component in found)


def test_imports_follow_the_data_flow_between_packages():
    bad = layer_violations() + same_layer_two_way()
    assert not bad, "imports against the data flow (LAYERS in tests/test_imports.py):\n" + _lines(bad)


def test_no_private_name_is_imported_across_packages():
    bad = private_violations()
    assert not bad, "private names used across packages (make them public or move them):\n" + _lines(bad)


def test_no_docstring_or_comment_cites_an_issue_or_a_file_outside_the_repository():
    """A reader of the package has the repository, not the tracker or the team's shared folder."""
    import re

    cites = re.compile(r"\b[Ii]ssues? #?\d+|method\.md|\.\./shared/")
    found = [f"{p.relative_to(ROOT)}:{n}" for p in sorted(ROOT.rglob("*.py"))
             for n, line in enumerate(p.read_text().splitlines(), 1) if cites.search(line)]
    assert found == []

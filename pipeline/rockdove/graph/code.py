"""What code a stage can execute, derived from the source: the digest that enters its cache key.

Nothing is listed by hand. A stage's callables (``run``, ``item_plan``, ``items``, ``combine`` and its codecs'
``save``/``load``) are followed by name through the module that defines them (the wiring module,
:mod:`rockdove.graph.stages`): the top-level functions, classes and constants they name, and the modules those
import (at module level or inside a function, absolute or relative, as :mod:`ast` reads them, the way
``tests/test_imports.py`` walks the package). From each module reached, its whole import closure inside the
``rockdove`` package, with the ``__init__`` of every package on the way (it runs on import). A string naming a
module (``"rockdove.hosts.glsl"``) or an f-string naming a package's modules by prefix
(``f"rockdove.geometry.{name}"``) is an import too: registries that import by name are followed.

The digest is the sha256 of the files reached (the wiring module whole, so its constants count) and of the data
files the stage declares (``Stage.data``). A callable defined outside the package (a test's stand-in) keys on its
own file and the closure of what it imports.

Cost: parsing is memoised by the file's content (sha256) in this process and on disk
(:func:`rockdove.resources.user_cache_dir` ``code/``), so a new process pays one read and hash of each file; a
digest is memoised per process until a file it read or a folder it listed changes (mtime and size).
"""

from __future__ import annotations

import ast
import functools
import hashlib
import inspect
import json
import os
from pathlib import Path

from .. import resources

SCANNER_VERSION = 2  # bump when what _scan records changes


# ----------------------------------------------------------------------------------------------- files
def files_of(path: Path, pattern: str = "*", seen: dict | None = None) -> list[Path]:
    """The files under ``path`` (or ``path`` itself) whose names match ``pattern``, sorted; ``seen`` receives the
    (mtime, size) of every folder listed, taken before it is listed. ``__pycache__`` and ``node_modules`` (npm
    packages installed beside data files, keyed by their pinned versions in package-lock.json) are skipped, and
    links to folders are not followed."""
    import fnmatch

    if path.is_dir():
        found, todo = [], [str(path)]
        while todo:
            folder = todo.pop()
            if seen is not None:
                st = os.stat(folder)
                seen[folder] = (st.st_mtime_ns, st.st_size)
            with os.scandir(folder) as entries:
                for e in entries:
                    if e.is_dir():
                        if not e.is_symlink() and e.name not in ("__pycache__", "node_modules"):
                            todo.append(e.path)
                    elif fnmatch.fnmatchcase(e.name, pattern):
                        found.append(Path(e.path))
        return sorted(p for p in found if p.is_file())
    return [path] if path.is_file() else []


@functools.lru_cache(maxsize=4096)
def _bytes(path: Path, mtime_ns: int, size: int) -> bytes:
    """A source or data file's bytes, read once per process and version of the file."""
    return path.read_bytes()


def read(path: Path, seen: dict | None = None) -> bytes:
    st = path.stat()
    if seen is not None:
        seen[str(path)] = (st.st_mtime_ns, st.st_size)
    return _bytes(path, st.st_mtime_ns, st.st_size)


_MODULES: dict = {}  # package root -> (its folders' (mtime, size), the modules found)


def _modules(seen: dict) -> dict[str, Path]:
    """Dotted name -> file of every module of the package (``rockdove.x`` for ``x/__init__.py``); listed again
    only when one of the package's folders changed."""
    root = resources.package_root().resolve()
    hit = _MODULES.get(root)
    if hit is not None:
        try:
            if all((st.st_mtime_ns, st.st_size) == stamp for st, stamp in
                   zip(map(os.stat, hit[0]), hit[0].values())):
                seen.update(hit[0])
                return hit[1]
        except OSError:
            pass
    folders: dict = {}
    out = {}
    for p in files_of(root, "*.py", folders):
        parts = list(p.relative_to(root.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts.pop()
        out[".".join(parts)] = p
    _MODULES[root] = (folders, out)
    seen.update(folders)
    return out


# ----------------------------------------------------------------------------------------------- scanning
def _imports(node) -> list:
    """Every import under ``node``: ``[level, module, [names]]``; strings naming rockdove modules: ``[-1, s, []]``
    (``s`` ending in ``.`` for an f-string's constant prefix)."""
    out = []
    for n in ast.walk(node):
        if isinstance(n, ast.Import):
            out += [[0, a.name, []] for a in n.names]
        elif isinstance(n, ast.ImportFrom):
            out.append([n.level, n.module or "", [a.name for a in n.names]])
        elif isinstance(n, ast.Constant) and isinstance(n.value, str) and n.value.startswith("rockdove.") \
                and not n.value.endswith("."):  # a whole name ("rockdove.x" or "rockdove.x:attr"), not a prefix
            out.append([-1, n.value.split(":")[0], []])
        elif isinstance(n, ast.JoinedStr) and n.values and isinstance(n.values[0], ast.Constant) \
                and str(n.values[0].value).startswith("rockdove."):
            out.append([-1, n.values[0].value, []])
    return out


def _scan(source: bytes) -> dict:
    """``{"imports": every import of the file, "top": {name: {"refs", "imports"}}, "bound": {name: import}}``:
    per top-level definition the names it uses and the imports inside it; per name a module-level import binds,
    that import."""
    tree = ast.parse(source)
    top, bound = {}, {}
    for stmt in tree.body:
        if isinstance(stmt, ast.Import):
            for alias in stmt.names:
                bound[alias.asname or alias.name.split(".")[0]] = [0, alias.name, []]
            continue
        if isinstance(stmt, ast.ImportFrom):
            for alias in stmt.names:
                bound[alias.asname or alias.name] = [stmt.level, stmt.module or "", [alias.name]]
            continue
        if isinstance(stmt, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            names = [stmt.name]
        elif isinstance(stmt, (ast.Assign, ast.AnnAssign)):
            targets = stmt.targets if isinstance(stmt, ast.Assign) else [stmt.target]
            names = [n.id for t in targets for n in ast.walk(t) if isinstance(n, ast.Name)]
        else:
            continue
        entry = {"refs": sorted({n.id for n in ast.walk(stmt) if isinstance(n, ast.Name)}), "imports": _imports(stmt)}
        for name in names:
            top[name] = entry
    return {"imports": _imports(tree), "top": top, "bound": bound}


_SCANS: dict = {}


def scan(path: Path, seen: dict) -> dict:
    """:func:`_scan` of ``path``, memoised in this process by the file's path, mtime and size, and in the user cache
    by its content's sha256."""
    data = read(path, seen)
    stamp = (str(path), *seen[str(path)])
    if stamp in _SCANS:
        return _SCANS[stamp]
    sha = hashlib.sha256(data).hexdigest()
    disk = resources.user_cache_dir("code", f"scan-v{SCANNER_VERSION}", f"{sha}.json")
    try:
        found = json.loads(disk.read_text())
    except (OSError, ValueError):
        found = _scan(data)
        resources.write_cached(disk, json.dumps(found).encode())
    _SCANS[stamp] = found
    return found


def _targets(imp: list, package: str, mods: dict) -> set[str]:
    """The package modules one import record names (``package``: the importing module's package)."""
    level, module, names = imp
    if level == -1:  # a string: a module, or a prefix naming every module under it
        return {m for m in mods if m.startswith(module)} if module.endswith(".") else ({module} & mods.keys())
    if level:
        parts = package.split(".")
        module = ".".join(parts[:len(parts) - level + 1] + ([module] if module else []))
    if module != "rockdove" and not module.startswith("rockdove."):
        return set()
    subs = {f"{module}.{n}" for n in names} & mods.keys()
    return ({module} & mods.keys()) | subs


def _package(module: str, path: Path) -> str:
    return module if path.name == "__init__.py" else module.rpartition(".")[0]


_EDGES: dict = {}  # (module, its file's stamp, the modules listed) -> the modules it names and its parents


def _edges(m: str, mods: dict, seen: dict) -> tuple:
    info = scan(mods[m], seen)  # also records the file's stamp in seen
    key = (m, seen[str(mods[m])], id(mods))
    if key not in _EDGES:
        out = {".".join(m.split(".")[:i]) for i in range(1, m.count(".") + 1)}  # the parents' __init__
        for imp in info["imports"]:
            out |= _targets(imp, _package(m, mods[m]), mods)
        _EDGES[key] = tuple(out)
    return _EDGES[key]


def closure(start: set[str], mods: dict, seen: dict) -> set[str]:
    """``start`` and every package module it imports, transitively, with each one's parent packages."""
    done, todo = set(), list(start)
    while todo:
        m = todo.pop()
        if m in done or m not in mods:
            continue
        done.add(m)
        todo += _edges(m, mods, seen)
    return done


def entry_modules(fn, mods: dict, seen: dict) -> tuple[set[Path], set[str]]:
    """The files ``fn`` is written in and the package modules it reaches from them: by name through its module's
    top-level definitions when it is one of them, else (a lambda, a callable outside the package) through every
    import of its file."""
    path = Path(inspect.getsourcefile(fn) or "").resolve()
    module = next((m for m, p in mods.items() if p == path), None)
    if not path.is_file():
        raise ValueError(f"{fn!r} has no source file; a stage's code must be keyed by its source")
    info = scan(path, seen)
    package = _package(module, path) if module else ""
    outer = getattr(fn, "__qualname__", "").split(".")[0]
    if module is None or outer not in info["top"]:
        reached = {t for imp in info["imports"] for t in _targets(imp, package, mods)}
        return {path}, reached | ({module} if module else set())
    reached, names, todo = {m for m in [package] if m}, set(), [outer]
    while todo:
        name = todo.pop()
        if name in names:
            continue
        names.add(name)
        if name in info["top"]:
            entry = info["top"][name]
            todo += entry["refs"]
            reached |= {t for imp in entry["imports"] for t in _targets(imp, package, mods)}
        elif name in info["bound"]:
            reached |= _targets(info["bound"][name], package, mods)
    return {path}, reached


def callables(stage, inputs=()) -> list:
    """The stage's code: its functions and its codecs', and the loaders of the stages it reads (``inputs``:
    their Stage objects), whose values' methods it calls."""
    fns = [stage.run, stage.item_plan, stage.items, stage.combine, stage.codec.save, stage.codec.load,
           stage.item_codec.save, stage.item_codec.load, *(s.codec.load for s in inputs)]
    return [f for f in fns if f is not None]


def code_files(stage, inputs=(), seen: dict | None = None) -> list[Path]:
    """Every source file the stage can execute (see the module docstring), with the build graph's own engine,
    sorted."""
    seen = {} if seen is None else seen
    mods = _modules(seen)
    files, reached = set(), {"rockdove.graph.engine"}
    for fn in callables(stage, inputs):
        f, r = entry_modules(fn, mods, seen)
        files |= f
        reached |= r
    return sorted(files | {mods[m] for m in closure(reached, mods, seen)})

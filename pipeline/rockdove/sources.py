"""What code can execute, read from its source (nothing listed by hand): the digest that keys the build graph's
stages and the user cache's folders.

A callable is followed by name through its module's top-level definitions and the modules those import (as
:mod:`ast` reads them; a string or f-string prefix naming ``rockdove.`` modules is an import too), then through
each reached module's whole import closure inside the package. A module named at run time (``import_module(x)``,
``__import__``, ``find_spec``, ``run_module`` or ``run_path`` of anything but a literal) cannot be followed: the
digest warns (:class:`DynamicImportWarning`) naming the file and line. A lambda, or a callable outside the package,
keys on its whole file and every import in it. Third-party code enters as the whole environment (the
``*.dist-info`` names on ``sys.path``, and Python's version): it runs code rockdove never names (trimesh calls
scipy, USD loads plugins), and mapping imports to distributions took 1.1 s per process against ~1 ms to list
``sys.path``. A digest is memoised per process until a file it read or a folder it listed changes (mtime, size)."""

from __future__ import annotations

import ast
import fnmatch
import functools
import hashlib
import inspect
import json
import os
import re
import sys
import warnings
from pathlib import Path

from . import resources
from .errors import UsageError

#: The file in each user-cache folder that records what keyed it (:func:`stale` reads it).
KEY_FILE = "key.json"
#: Calls that import (or run) a module named by their first argument.
DYNAMIC_IMPORTS = ("import_module", "__import__", "find_spec", "run_module", "run_path", "spec_from_file_location")


class DynamicImportWarning(UserWarning):
    """Code a digest reaches imports a module named at run time, which the digest cannot follow."""


def files_of(path: Path, pattern: str = "*", seen: dict | None = None) -> list[Path]:
    """The files under ``path`` (or ``path`` itself) matching ``pattern``, sorted, links to folders not followed,
    ``__pycache__`` and ``node_modules`` (keyed by package-lock.json) skipped; ``seen`` gets each folder's stamp."""
    if not path.is_dir():
        return [path] if path.is_file() else []
    found, todo = [], [str(path)]
    while todo:
        folder = todo.pop()
        if seen is not None:
            _stamp(folder, seen)
        with os.scandir(folder) as entries:
            for e in entries:
                if e.is_dir():
                    if not e.is_symlink() and e.name not in ("__pycache__", "node_modules"):
                        todo.append(e.path)
                elif fnmatch.fnmatchcase(e.name, pattern):
                    found.append(Path(e.path))
    return sorted(p for p in found if p.is_file())


def _stamp(path, seen: dict) -> tuple:
    st = os.stat(path)
    seen[str(path)] = (st.st_mtime_ns, st.st_size)
    return seen[str(path)]


@functools.lru_cache(maxsize=4096)
def _bytes(path: Path, mtime_ns: int, size: int) -> bytes:
    return path.read_bytes()


def read(path: Path, seen: dict) -> bytes:
    return _bytes(path, *_stamp(path, seen))


def _python() -> str:
    return ".".join(map(str, sys.version_info[:3]))


def environment(seen: dict) -> str:
    """sha256 of the metadata folder names on ``sys.path``, but rockdove's own (its code is keyed by its source; a
    checkout's ``rockdove.egg-info`` is on ``sys.path`` under pytest, not in the installed command)."""
    names = []
    for entry in sys.path:
        if entry and os.path.isdir(entry):
            _stamp(entry, seen)
            names += sorted(n for n in os.listdir(entry) if n.endswith((".dist-info", ".egg-info"))
                            and not re.match(r"rockdove[-.]", n, re.IGNORECASE))
    return hashlib.sha256("\n".join(names).encode()).hexdigest()


def _modules(seen: dict) -> dict[str, Path]:
    """Dotted name -> file of every module of the package (``rockdove.x`` for ``x/__init__.py``)."""
    root = resources.package_root().resolve()
    out = {}
    for p in files_of(root, "*.py", seen):
        parts = list(p.relative_to(root.parent).with_suffix("").parts)
        out[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = p
    return out


def _unchanged(stamps: dict) -> bool:
    try:
        return all((st.st_mtime_ns, st.st_size) == s for st, s in zip(map(os.stat, stamps), stamps.values()))
    except OSError:
        return False


# ----------------------------------------------------------------------------------------------- scanning
def _literal(arg) -> bool:
    return isinstance(arg, ast.Constant) and isinstance(arg.value, str) or isinstance(arg, ast.JoinedStr) and bool(
        arg.values) and isinstance(arg.values[0], ast.Constant) and str(arg.values[0].value).startswith("rockdove.")


def _imports(node) -> list:
    """Every import under ``node``: ``[level, module, [names]]``, a string naming rockdove modules ``[-1, s, []]``
    (``s`` ending in ``.``: an f-string's prefix), a module named at run time ``[-2, "line N", []]``."""
    out = []
    for n in ast.walk(node):
        if isinstance(n, ast.Call) and getattr(n.func, "attr", getattr(n.func, "id", None)) in DYNAMIC_IMPORTS \
                and not (n.args and _literal(n.args[0])):
            out.append([-2, f"line {n.lineno}", []])
        if isinstance(n, ast.Import):
            out += [[0, a.name, []] for a in n.names]
        elif isinstance(n, ast.ImportFrom):
            out.append([n.level, n.module or "", [a.name for a in n.names]])
        elif isinstance(n, ast.Constant) and isinstance(n.value, str) and n.value.startswith("rockdove.") \
                and not n.value.endswith("."):  # a whole name ("rockdove.x" or "rockdove.x:attr"), not a prefix
            out.append([-1, n.value.split(":")[0], []])
        elif isinstance(n, ast.JoinedStr) and _literal(n):  # an f-string's "rockdove." prefix
            out.append([-1, n.values[0].value, []])
    return out


def _scan(source: bytes) -> dict:
    """``{"imports": every import, "top": {definition: {"refs": names it uses, "imports"}}, "bound": {name: the
    module-level import binding it}}``."""
    tree = ast.parse(source)
    top, bound = {}, {}
    for stmt in tree.body:
        if isinstance(stmt, ast.Import):
            bound.update({a.asname or a.name.split(".")[0]: [0, a.name, []] for a in stmt.names})
        elif isinstance(stmt, ast.ImportFrom):
            bound.update({a.asname or a.name: [stmt.level, stmt.module or "", [a.name]] for a in stmt.names})
        elif isinstance(stmt, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef, ast.Assign, ast.AnnAssign)):
            targets = stmt.targets if isinstance(stmt, ast.Assign) else [getattr(stmt, "target", None)]
            names = [n.id for t in targets if t for n in ast.walk(t) if isinstance(n, ast.Name)]
            entry = {"refs": sorted({n.id for n in ast.walk(stmt) if isinstance(n, ast.Name)}),
                     "imports": _imports(stmt)}
            top.update({name: entry for name in names or [getattr(stmt, "name", "")]})
    return {"imports": _imports(tree), "top": top, "bound": bound}


@functools.lru_cache(maxsize=1)
def scan_dir() -> Path:
    """The user-cache folder of parsed files, keyed by this module's source and Python's version."""
    files = {"rockdove/sources.py": hashlib.sha256(Path(__file__).read_bytes()).hexdigest()}
    return _keyed_dir("code", {"python": _python(), "files": files})


_SCANS: dict = {}


def scan(path: Path, seen: dict) -> dict:
    """:func:`_scan` of ``path``, memoised by its stamp in this process and by its sha256 in the user cache."""
    data = read(path, seen)
    stamp = (str(path), *seen[str(path)])
    if stamp not in _SCANS:
        disk = scan_dir() / f"{hashlib.sha256(data).hexdigest()}.json"
        try:
            _SCANS[stamp] = json.loads(disk.read_text())
        except (OSError, ValueError):
            _SCANS[stamp] = _scan(data)
            resources.write_cached(disk, json.dumps(_SCANS[stamp]).encode())
    return _SCANS[stamp]


def _targets(imp: list, package: str, mods: dict) -> set[str]:
    """The package modules one import record names (``package``: the importing module's package)."""
    level, module, names = imp
    if level == -2:  # a module named at run time: warned about by code_files
        return set()
    if level == -1:  # a string: a module, or a prefix naming every module under it
        return {m for m in mods if m.startswith(module)} if module.endswith(".") else ({module} & mods.keys())
    if level:
        parts = package.split(".")
        module = ".".join(parts[:len(parts) - level + 1] + ([module] if module else []))
    if module != "rockdove" and not module.startswith("rockdove."):
        return set()
    return ({module} | {f"{module}.{n}" for n in names}) & mods.keys()


def _package(module: str, path: Path) -> str:
    return module if path.name == "__init__.py" else module.rpartition(".")[0]


def closure(start: set[str], mods: dict, seen: dict) -> set[str]:
    """``start`` and every package module it imports, transitively, with each one's parent packages."""
    done, todo = set(), list(start)
    while todo:
        m = todo.pop()
        if m in done or m not in mods:
            continue
        done.add(m)
        todo += [".".join(m.split(".")[:i]) for i in range(1, m.count(".") + 1)]  # the parents' __init__
        for imp in scan(mods[m], seen)["imports"]:
            todo += _targets(imp, _package(m, mods[m]), mods)
    return done


def entry_modules(fn, mods: dict, seen: dict) -> tuple[Path, set[str]]:
    """The file ``fn`` is written in and the package modules it reaches from it (module docstring)."""
    path = Path(inspect.getsourcefile(fn) or "").resolve()
    if not path.is_file():
        raise UsageError(f"{fn!r} has no source file; a stage's code must be keyed by its source")
    module = next((m for m, p in mods.items() if p == path), None)
    info = scan(path, seen)
    package = _package(module, path) if module else ""
    outer = getattr(fn, "__qualname__", "").split(".")[0]
    if module is None or outer not in info["top"]:
        return path, {t for imp in info["imports"] for t in _targets(imp, package, mods)} | {module} - {None}
    reached, names, todo = {package} - {""}, set(), [outer]
    while todo:
        name = todo.pop()
        if name in names:
            continue
        names.add(name)
        if name in info["top"]:
            todo += info["top"][name]["refs"]
            reached |= {t for imp in info["top"][name]["imports"] for t in _targets(imp, package, mods)}
        elif name in info["bound"]:
            reached |= _targets(info["bound"][name], package, mods)
    return path, reached


def code_files(fns, seen: dict, modules=()) -> list[Path]:
    """Every source file ``fns`` can execute (module docstring), with the closure of ``modules``, sorted."""
    mods = _modules(seen)
    files, reached = set(), set(modules)
    for fn in fns:
        f, r = entry_modules(fn, mods, seen)
        files.add(f)
        reached |= r
    found = sorted(files | {mods[m] for m in closure(reached, mods, seen)})
    for path in found:
        for _, where, _ in (imp for imp in scan(path, seen)["imports"] if imp[0] == -2):
            warnings.warn(f"{path} {where} imports a module named at run time, which the cache key cannot follow; "
                          "name it with a literal ('rockdove.x')", DynamicImportWarning, stacklevel=3)
    return found


# ----------------------------------------------------------------------------------------------- digests
#: (callables, data, modules) -> ({path read or listed: its (mtime, size)}, (digest, record))
_MEMO: dict = {}


def digest(fns, data=(), modules=()) -> tuple[str, dict]:
    """``(sha256, record)`` of what ``fns`` can execute (:func:`code_files`), the ``data`` files or folders, the
    environment and Python; ``record`` holds each file's sha256."""
    root = resources.package_root().resolve()
    memo_key = (str(root), tuple((f.__code__.co_filename, f.__qualname__) if hasattr(f, "__code__") else f
                                 for f in fns), tuple(data), tuple(modules))
    hit = _MEMO.get(memo_key)
    if hit is not None and _unchanged(hit[0]):
        return hit[1]
    seen: dict = {}
    labelled = [(str(p.relative_to(root.parent)) if p.is_relative_to(root.parent) else str(p), p)
                for p in code_files(fns, seen, modules)]
    for d in data:
        top = resources.path(d)
        found = files_of(top, seen=seen)
        if not found:  # an empty data folder would key the stage on nothing
            raise UsageError(f"data {d!r}: {top} holds no files, so it cannot be keyed (reinstall rockdove)")
        labelled += [(f"{d}/{p.relative_to(top)}" if top.is_dir() else d, p) for p in found]
    record = {"python": _python(), "environment": environment(seen),
              "files": {label: hashlib.sha256(read(p, seen)).hexdigest() for label, p in labelled}}
    result = hashlib.sha256(json.dumps(record, sort_keys=True).encode()).hexdigest(), record
    _MEMO[memo_key] = (seen, result)
    return result


# ----------------------------------------------------------------------------------------------- user cache
def _keyed_dir(name: str, record: dict) -> Path:
    key = hashlib.sha256(json.dumps(record, sort_keys=True).encode()).hexdigest()
    folder = resources.user_cache_dir(f"{name}-{key[:16]}")
    if not (folder / KEY_FILE).is_file():
        resources.write_cached(folder / KEY_FILE, json.dumps(record, indent=1, sort_keys=True).encode())
    return folder


def cache_dir(name: str, fn) -> Path:
    """The user-cache folder ``<name>-<key>`` for values that ``fn`` computes, keyed by :func:`digest` of ``fn``."""
    return _keyed_dir(name, digest([fn])[1])


def stale(folder: Path) -> str | None:
    """Why a user-cache folder can no longer be read (what derived it changed since), or None while it is current."""
    try:
        record = json.loads((folder / KEY_FILE).read_text())
    except (OSError, ValueError):
        return f"no {KEY_FILE}: written by an older rockdove"
    if record.get("python") != _python():
        return f"written by Python {record.get('python')}"
    if record.get("environment") not in (None, environment({})):
        return "the installed distributions changed"
    root = resources.package_root().resolve().parent
    for label, sha in record.get("files", {}).items():
        try:
            if hashlib.sha256((root / label).read_bytes()).hexdigest() == sha:  # (a label may be absolute)
                continue
        except OSError:
            pass
        return f"{label} changed"
    return None

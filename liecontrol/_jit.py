"""The compiler behind the per-step kernels: numba when it works, plain Python otherwise.

Every per-step formula (rigid-body and actuator dynamics, the RKMK4 step, steering laws, the
geometric PD family, chart conversions) is written once as a scalar kernel in the numba-compatible
subset of Python and decorated with :func:`njit`. With numba installed, kernels are compiled on
first call and cached to disk, so a second process loads machine code instead of recompiling.
Without numba — or when ``LIECONTROL_DISABLE_JIT=1`` is set, or when numba fails to compile on
the platform — the same functions run as ordinary Python: identical results, slower, and one
:class:`RuntimeWarning` says so.

Kernels never validate: the public numpy API validates at the boundary and hands kernels finite
float64 arrays of the right shapes.

The on-disk cache cannot go stale. numba's own ``cache=True`` checks only the source file of the
function it loads, but a compiled kernel contains the code of every kernel it calls (and the
module constants it reads): after an edit of a shared helper, numba would keep loading its
callers with the old helper compiled in, and after reverting the edit, with the edited one.
Here every cached kernel lives in a directory named after a hash of **all** kernel sources it
can depend on — every module of its top-level package and of :mod:`liecontrol` that mentions
numba or ``njit``, with the modules those import at module level (their constants are frozen
into the machine code) — so any edit of any of them selects a fresh directory and everything is
recompiled from the current sources; reverting the edit selects the old directory again.
Where the directory is (first that is writable):

1. ``$NUMBA_CACHE_DIR/<package>-<hash>/`` when ``NUMBA_CACHE_DIR`` is set;
2. ``<package>/__pycache__/numba-<hash>/`` inside the installed (or checked-out) package;
3. ``<user cache dir>/liecontrol/<package>-<hash>/`` (e.g. ``~/.cache/liecontrol``) when the
   package directory is read-only.

Only the most recent :data:`KEEP_CACHES` hash directories of a package are kept.
:func:`cache_dir` says where the cache is and :func:`clear_cache` deletes it (so does deleting
the ``numba-*`` directories, or the ``__pycache__`` directories).
"""

from __future__ import annotations

import ast
import hashlib
import os
import shutil
import sys
import threading
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

__all__ = [
    "JIT_ENABLED",
    "njit",
    "prange",
    "cache_dir",
    "clear_cache",
    "kernel_sources",
    "sources_hash",
]

#: hash directories of one package kept on disk (older ones are deleted when a new one appears)
KEEP_CACHES = 6
#: length of the hex hash in directory names
_HASH_CHARS = 16
#: a module that mentions none of these cannot define kernels (it is not parsed)
_MARKERS = (b"njit", b"import numba", b"from numba")


def _numba() -> Any:
    if os.environ.get("LIECONTROL_DISABLE_JIT", "").strip() not in ("", "0"):
        return None
    try:
        import numba
    except Exception as exc:  # ImportError, or a broken llvmlite on an unsupported platform
        warnings.warn(
            f"liecontrol: numba is unavailable ({exc.__class__.__name__}: {exc}); the per-step "
            "kernels run as plain Python (same results, slower); pip install numba to compile.",
            RuntimeWarning,
            stacklevel=3,
        )
        return None
    return numba


_NUMBA = _numba()

#: True when kernels are compiled by numba; False on the pure-Python fallback.
JIT_ENABLED: bool = _NUMBA is not None


# ------------------------------------------------------------------- the kernel-source hash
_LIECONTROL_ROOT = Path(__file__).resolve().parent


def _root_of(module: str, py_file: str) -> tuple[str, Path]:
    """``(name, directory)`` of the top-level package that holds ``module`` (defined in
    ``py_file``); a module outside any package is its own root (``name``, the file)."""
    top = module.split(".", 1)[0]
    pkg = sys.modules.get(top)
    paths = list(getattr(pkg, "__path__", None) or [])
    if paths:
        return top, Path(paths[0]).resolve()
    return Path(py_file).stem, Path(py_file).resolve()


def _module_files(root: Path) -> list[Path]:
    if root.is_file():
        return [root]
    return sorted(p for p in root.rglob("*.py") if "__pycache__" not in p.parts)


def _module_level_imports(tree: ast.Module) -> list[ast.Import | ast.ImportFrom]:
    """Import statements executed when the module is imported (not those inside functions or
    classes, which no kernel can see)."""
    out: list[ast.Import | ast.ImportFrom] = []
    todo: list[ast.stmt] = list(tree.body)
    while todo:
        node = todo.pop()
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            out.append(node)
        elif isinstance(node, (ast.If, ast.Try, ast.With)):
            for name in ("body", "orelse", "finalbody", "handlers"):
                todo.extend(getattr(node, name, []) or [])
        elif isinstance(node, ast.ExceptHandler):
            todo.extend(node.body)
    return out


def _resolve(name: str, roots: dict[str, Path]) -> Path | None:
    """The source file of the dotted module ``name`` inside one of ``roots``, else ``None``."""
    parts = name.split(".")
    root = roots.get(parts[0])
    if root is None or root.is_file():
        return root if root is not None and len(parts) == 1 else None
    base = root.joinpath(*parts[1:])
    for cand in (base.with_suffix(".py"), base / "__init__.py"):
        if cand.is_file():
            return cand
    return None


_TREES: dict[tuple[Path, int, int], ast.Module | None] = {}


def _parse(path: Path) -> ast.Module | None:
    """The module's syntax tree (memoised per file version), ``None`` if it does not parse."""
    st = path.stat()
    key = (path, st.st_mtime_ns, st.st_size)
    if key not in _TREES:
        try:
            _TREES[key] = ast.parse(path.read_bytes())
        except (SyntaxError, ValueError):
            _TREES[key] = None
    return _TREES[key]


def _imports_of(path: Path, module: str, is_pkg: bool, roots: dict[str, Path]) -> set[Path]:
    tree = _parse(path)
    if tree is None:
        return set()
    found: set[Path] = set()
    for node in _module_level_imports(tree):
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        else:
            if node.level:
                pkg = module.split(".") if is_pkg else module.split(".")[:-1]
                pkg = pkg[: len(pkg) - (node.level - 1)] if node.level > 1 else pkg
                base = ".".join(pkg + ([node.module] if node.module else []))
            else:
                base = node.module or ""
            # `from X import y`: the submodule X.y, else the module X (y one of its names)
            names = []
            for a in node.names:
                names.append(f"{base}.{a.name}" if _resolve(f"{base}.{a.name}", roots) else base)
        for n in names:
            p = _resolve(n, roots)
            if p is not None:
                found.add(p)
    return found


def _defines_kernels(tree: ast.Module) -> bool:
    """Whether a module compiles code: it imports numba, or decorates or calls ``njit``."""
    for node in ast.walk(tree):
        if isinstance(node, ast.Import) and any(
            a.name == "numba" or a.name.startswith("numba.") for a in node.names
        ):
            return True
        if isinstance(node, ast.ImportFrom) and (node.module or "").split(".")[0] == "numba":
            return True
        if isinstance(node, ast.Name) and node.id == "njit" and isinstance(node.ctx, ast.Load):
            return True
    return False


def kernel_sources(roots: dict[str, Path]) -> list[tuple[str, Path]]:
    """The kernel sources of the packages ``roots`` (name → directory, or a single file):
    every module that imports numba or uses ``njit``, and, transitively, the modules of these
    packages that they import at module level. Sorted ``(label, path)`` pairs."""
    files: dict[Path, str] = {}
    for root in roots.values():
        for p in _module_files(root):
            rel = p.relative_to(root.parent) if root.is_dir() else Path(p.name)
            files[p] = rel.as_posix()
    todo = []
    for p in files:
        if any(m in p.read_bytes() for m in _MARKERS):
            tree = _parse(p)
            # one that does not parse is hashed as it is: fixing it changes the hash
            if tree is None or _defines_kernels(tree):
                todo.append(p)
    chosen: set[Path] = set()
    while todo:
        p = todo.pop()
        if p in chosen:
            continue
        chosen.add(p)
        rel = files.get(p)
        if rel is None:
            continue
        parts = rel[:-3].split("/")
        is_pkg = parts[-1] == "__init__"
        module = ".".join(parts[:-1] if is_pkg else parts)
        todo.extend(q for q in _imports_of(p, module, is_pkg, roots) if q not in chosen)
    return sorted((files.get(p, p.name), p) for p in chosen)


_HASHES: dict[tuple[str, Path], str] = {}
_LOCK = threading.Lock()


def _roots_for(name: str, root: Path) -> dict[str, Path]:
    roots = {"liecontrol": _LIECONTROL_ROOT}
    roots[name] = root
    return roots


def sources_hash(roots: dict[str, Path]) -> str:
    """Hex hash of the :func:`kernel_sources` of ``roots`` (their paths inside the packages and
    their contents) and of the numba version."""
    d = hashlib.sha256()
    d.update(f"numba {getattr(_NUMBA, '__version__', '-')}\0".encode())
    for label, p in kernel_sources(roots):
        d.update(label.encode() + b"\0" + hashlib.sha256(p.read_bytes()).digest())
    return d.hexdigest()[:_HASH_CHARS]


def _tree_hash(name: str, root: Path) -> str:
    """:func:`sources_hash` of the package ``name`` and of :mod:`liecontrol` (computed once per
    process and package)."""
    key = (name, root)
    with _LOCK:
        h = _HASHES.get(key)
        if h is None:
            h = _HASHES[key] = sources_hash(_roots_for(name, root))
    return h


# ------------------------------------------------------------------------ the cache locator
def _user_cache_base() -> Path:
    try:
        from numba.misc.appdirs import AppDirs

        return Path(AppDirs(appname="liecontrol", appauthor=False).user_cache_dir)
    except Exception:  # noqa: BLE001 - numba's helper moved: the XDG default
        xdg = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
        return Path(xdg) / "liecontrol"


def _candidates(name: str, root: Path, h: str) -> list[tuple[Path, str]]:
    """``(directory, prefix of its sibling hash directories)`` in order of preference (an
    unwritable ``NUMBA_CACHE_DIR`` falls back to the other two)."""
    out: list[tuple[Path, str]] = []
    numba_dir = getattr(getattr(_NUMBA, "config", None), "CACHE_DIR", "") if _NUMBA else ""
    if numba_dir:
        out.append((Path(numba_dir) / f"{name}-{h}", f"{name}-"))
    pyc = (root if root.is_dir() else root.parent) / "__pycache__"
    out.append((pyc / f"numba-{h}", "numba-"))
    out.append((_user_cache_base() / f"{name}-{h}", f"{name}-"))
    return out


_PRUNED: set[Path] = set()


def _is_hash_dir(p: Path, prefix: str) -> bool:
    """Whether ``p`` is one of this module's hash directories (``prefix`` + the hex hash)."""
    tail = p.name[len(prefix) :]
    return (
        p.name.startswith(prefix)
        and len(tail) == _HASH_CHARS
        and all(ch in "0123456789abcdef" for ch in tail)
        and p.is_dir()
    )


def _prune(container: Path, prefix: str, keep: Path) -> None:
    """Delete all but the newest :data:`KEEP_CACHES` hash directories beside ``keep``."""
    if container in _PRUNED:
        return
    _PRUNED.add(container)
    try:
        dirs = [p for p in container.iterdir() if _is_hash_dir(p, prefix)]
        dirs.sort(key=lambda p: p.stat().st_mtime, reverse=True)
    except OSError:
        return
    for old in [p for p in dirs if p != keep][KEEP_CACHES - 1 :]:
        shutil.rmtree(old, ignore_errors=True)


def _writable(path: Path) -> bool:
    try:
        path.mkdir(parents=True, exist_ok=True)
        import tempfile

        tempfile.TemporaryFile(dir=path).close()
    except OSError:
        return False
    return True


def cache_dir(package: str = "liecontrol") -> Path | None:
    """The directory that holds the compiled kernels of the top-level ``package`` now (created
    if needed), or ``None`` without numba or without a writable place."""
    if _NUMBA is None:
        return None
    import importlib

    mod = importlib.import_module(package)
    name, root = _root_of(package, getattr(mod, "__file__", "") or "")
    return _choose(name, root)


_CHOSEN: dict[tuple[str, Path, str], Path | None] = {}


def _choose(name: str, root: Path) -> Path | None:
    h = _tree_hash(name, root)
    key = (name, root, str(getattr(getattr(_NUMBA, "config", None), "CACHE_DIR", "")))
    if key in _CHOSEN and (_CHOSEN[key] is None or _CHOSEN[key].is_dir()):
        return _CHOSEN[key]
    chosen = None
    for path, prefix in _candidates(name, root, h):
        fresh = not path.exists()
        if _writable(path):
            if fresh:
                _prune(path.parent, prefix, path)
            chosen = path
            break
    _CHOSEN[key] = chosen
    return chosen


def clear_cache(packages: tuple[str, ...] = ("liecontrol", "spacecraft")) -> list[Path]:
    """Delete every hash directory of the compiled kernels of ``packages`` (default: the
    packages of this distribution) in the places listed in the module docstring; returns the
    directories deleted. Run it in a fresh process: ``python -c "import liecontrol._jit as j;
    print(j.clear_cache())"``."""
    import importlib

    places = []
    for package in packages:  # import first: importing compiles nothing but may create dirs
        mod = importlib.import_module(package)
        name, root = _root_of(package, getattr(mod, "__file__", "") or "")
        places.extend(_candidates(name, root, "x"))
    gone = []
    for path, prefix in places:
        try:
            for p in path.parent.iterdir():
                if _is_hash_dir(p, prefix):
                    shutil.rmtree(p, ignore_errors=True)
                    gone.append(p)
        except OSError:
            pass
    _CHOSEN.clear()
    return gone


def _tree_cache_class() -> Any:
    """numba's per-function disk cache with the locator of the module docstring."""
    from numba.core.caching import (
        CompileResultCacheImpl,
        FunctionCache,
        _CacheLocator,
        _SourceFileBackedLocatorMixin,
    )

    class KernelTreeLocator(_SourceFileBackedLocatorMixin, _CacheLocator):
        """``<hash directory>/<the module's directory inside its package>``."""

        def __init__(self, py_func: Any, py_file: str, path: Path) -> None:
            self._py_file = py_file
            self._lineno = py_func.__code__.co_firstlineno
            self._cache_path = str(path)

        def get_cache_path(self) -> str:
            return self._cache_path

        @classmethod
        def from_function(cls, py_func: Any, py_file: str) -> Any:
            if not os.path.exists(py_file):
                return None
            name, root = _root_of(py_func.__module__, py_file)
            base = _choose(name, root)
            if base is None:
                return None
            sub = Path(py_file).resolve().parent
            rel = sub.relative_to(root) if root.is_dir() and sub.is_relative_to(root) else None
            path = base if rel is None else base.joinpath(*rel.parts)
            self = cls(py_func, py_file, path)
            try:
                self.ensure_cache_path()
            except OSError:
                return None
            return self

    class KernelTreeImpl(CompileResultCacheImpl):
        _locator_classes = [KernelTreeLocator, *CompileResultCacheImpl._locator_classes]

    class KernelTreeCache(FunctionCache):
        _impl_class = KernelTreeImpl

    return KernelTreeCache


_CACHE_CLASS: Any = None


def _enable_cache(dispatcher: Any) -> None:
    global _CACHE_CLASS
    try:
        if _CACHE_CLASS is None:
            _CACHE_CLASS = _tree_cache_class()
        dispatcher._cache = _CACHE_CLASS(dispatcher.py_func)
    except (ImportError, AttributeError, TypeError) as exc:  # numba internals moved: no cache
        warnings.warn(
            f"liecontrol: cannot key the kernel cache by the kernel sources with this numba "
            f"({exc.__class__.__name__}: {exc}); kernels are compiled in every process.",
            RuntimeWarning,
            stacklevel=4,
        )


def njit(*args: Any, **kwargs: Any) -> Callable[..., Any]:
    """``numba.njit(…)`` with the disk cache of the module docstring when numba is available,
    else the identity decorator.

    Used bare (``@njit``), with options (``@njit(parallel=True)``) or with signatures (compiled
    at decoration, as numba does); ``cache`` defaults to True, ``error_model`` to ``"numpy"``.
    """
    if _NUMBA is None:
        if len(args) == 1 and callable(args[0]) and not kwargs:
            return args[0]
        return lambda f: f
    cache = kwargs.pop("cache", True)
    kwargs.setdefault("error_model", "numpy")  # x/0 -> inf/nan (checked by callers), not a raise
    func = args[0] if len(args) == 1 and callable(args[0]) else None
    sigs = None if func is not None or not args else args[0]
    if sigs is not None and not isinstance(sigs, (list, tuple)):
        sigs = [sigs]

    def decorate(f: Callable[..., Any]) -> Any:
        disp = _NUMBA.njit(**kwargs)(f)
        if cache:
            _enable_cache(disp)
        if sigs is not None:
            for sig in sigs:
                disp.compile(sig)
            disp.disable_compile()
        return disp

    return decorate(func) if func is not None else decorate


prange = range if _NUMBA is None else _NUMBA.prange


def max_threads() -> int | None:
    """The most threads numba's parallel regions may use (``NUMBA_NUM_THREADS``), or ``None``
    without numba. (Modules that only ask this do not import numba themselves, so editing them
    does not invalidate the kernel cache, :func:`kernel_sources`.)"""
    return None if _NUMBA is None else int(_NUMBA.config.NUMBA_NUM_THREADS)

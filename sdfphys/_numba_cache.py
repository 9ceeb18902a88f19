"""Numba's on-disk cache, invalidated when a kernel's module or anything it imports changes.

Numba keys a cached kernel on its own source file only (``numba.core.caching``: the
index stores a hash of the file the function is defined in). Kernels here call njit
functions of other files, which numba compiles into them, or call a shared kernel by
name with the signature its file declares (``_shared_kernel``): the collision kernels
of ``sdfphys.collide`` run ``sdf.compiled``'s field programs, so after an edit of
``sdf/compiled.py`` a kernel of ``collide/`` would load machine code built from the old
one and compute wrong contacts without an error (it happened during development).

:class:`ModuleStampLocator` wraps the locator numba would have chosen for a function
defined in this package (same cache directory, same file names) and adds to its stamp
a hash of the function's module and of every sdfphys module that module imports,
transitively (``dependency_stamp``: the import statements, read as text; an njit
function can only call what its module's globals reach, and those come from its
imports). An edit recompiles the kernels of the modules that import the edited file,
and only those: an edit of ``sdf/compiled.py`` recompiles the collision kernels, not
the solver's. Functions outside the package keep numba's own locators. ``install``
puts it first in numba's locator list; ``NUMBA_CACHE_DIR`` is honoured as before (the
wrapped locator is numba's choice).

Stale indexes. Numba unpickles a kernel's index (its stamp and the signatures it holds)
before it compares the stamp, so an index written by another version of this package
that names a class this one no longer has (a bundle's StructRef type) raised
AttributeError out of the first call of that kernel: a traceback after an upgrade.
``install`` makes an index that does not unpickle a miss, as numba already treats an
index of another numba version: the kernel compiles and a fresh index replaces it.

First run. Compiling every kernel a scene needs takes seconds to a minute on a cold
cache; ``install`` also registers a listener of numba's compile events that says so on
stderr at the first compilation of an sdfphys kernel ("compiling kernels for this
machine, first run only") and, once compilation has gone on for ``NOTICE_AFTER`` s, how
many kernels are compiled so far, every ``NOTICE_EVERY`` s (half that on a terminal).
``SDFPHYS_COMPILE_NOTICE=0`` in the environment silences it (the test suite does, so
that a test reading stderr does not depend on what an earlier test compiled).
"""

from __future__ import annotations

import hashlib
import os
import pickle
import re
import sys
import time
from pathlib import Path

from numba.core import caching, event

__all__ = ["ModuleStampLocator", "dependency_stamp", "imported_files", "install",
           "load_index_or_miss"]

#: The directory of the sdfphys package.
PACKAGE = Path(__file__).resolve().parent

#: Numba's base of cache implementations, which holds the locator list (``CacheImpl``
#: in recent numba, ``_CacheImpl`` in older ones).
_CACHE_IMPL = getattr(caching, "CacheImpl", None) or getattr(caching, "_CacheImpl")

#: ``import a.b`` and ``from .a import b, c`` statements (any indentation).
_IMPORT = re.compile(r"^[ \t]*(?:from[ \t]+(\.*)([\w.]*)[ \t]+import[ \t]+"
                     r"(?:\(([\w\s,]+)\)|([\w \t,]+))|import[ \t]+([\w.]+))", re.MULTILINE)

#: Seconds of compilation before progress shows, and between two lines off a terminal.
NOTICE_AFTER = 3.0
NOTICE_EVERY = 10.0


def _module_file(parts: tuple[str, ...], root: Path) -> Path | None:
    """The source file of module ``parts`` (first part: the package's name) under root."""
    base = root.parent.joinpath(*parts)
    for candidate in (base.with_suffix(".py"), base / "__init__.py"):
        if candidate.is_file():
            return candidate
    return None


def imported_files(path: Path, root: Path = PACKAGE) -> set[Path]:
    """The package's source files that the module at ``path`` imports (not transitively):
    ``from X import y`` counts submodule X.y if it is a file, else X itself."""
    name = root.name
    package = path.relative_to(root.parent).with_suffix("").parts[:-1]
    found: set[Path] = set()
    for dots, source, listed, names, plain in _IMPORT.findall(path.read_text()):
        names = listed or names
        if plain:
            modules = [tuple(plain.split("."))]
        else:
            base = package[:len(package) - len(dots) + 1] if dots else ()
            target = base + (tuple(source.split(".")) if source else ())
            modules = []
            for item in (n.strip() for n in names.split(",")):
                if item:
                    sub = _module_file(target + (item,), root) if target[:1] == (name,) else None
                    modules.append(target + (item,) if sub is not None else target)
        for module in modules:
            if module[:1] == (name,):
                file = _module_file(module, root)
                if file is not None and file != path:
                    found.add(file)
    return found


_STAMPS: dict[Path, str] = {}


def dependency_stamp(path: Path, root: Path = PACKAGE) -> str:
    """sha256 (hex) of the relative path and bytes of ``path`` and of every package file
    it imports, transitively, in sorted order (computed once per file and process)."""
    path = Path(path).resolve()
    stamp = _STAMPS.get(path)
    if stamp is None:
        closure, todo = {path}, [path]
        while todo:
            for file in imported_files(todo.pop(), root):
                if file not in closure:
                    closure.add(file)
                    todo.append(file)
        digest = hashlib.sha256()
        for file in sorted(closure):
            digest.update(file.relative_to(root).as_posix().encode() + b"\0")
            digest.update(file.read_bytes() + b"\0")
        stamp = _STAMPS[path] = digest.hexdigest()
    return stamp


def _default_locators() -> list[type]:
    """Numba's locators, in its order, without this one."""
    return [c for c in _CACHE_IMPL._locator_classes if c is not ModuleStampLocator]


class ModuleStampLocator(caching._CacheLocator):
    """Numba's own locator for a function of this package, its source stamp extended by
    :func:`dependency_stamp` of the function's file."""

    def __init__(self, inner: caching._CacheLocator, py_file: str):
        self._inner = inner
        self._module = Path(py_file).resolve()

    def __getattr__(self, name: str):
        # numba reads the inner locator's _py_file (warnings); never recurse on _inner.
        if name == "_inner":
            raise AttributeError(name)
        return getattr(self._inner, name)

    def ensure_cache_path(self) -> None:
        self._inner.ensure_cache_path()

    def get_cache_path(self) -> str:
        return self._inner.get_cache_path()

    def get_source_stamp(self):
        return self._inner.get_source_stamp(), dependency_stamp(self._module)

    def get_disambiguator(self) -> str:
        return self._inner.get_disambiguator()

    @classmethod
    def from_function(cls, py_func, py_file):
        try:
            Path(py_file).resolve().relative_to(PACKAGE)
        except (ValueError, OSError):
            return None
        for locator in _default_locators():
            inner = locator.from_function(py_func, py_file)
            if inner is not None:
                return cls(inner, py_file)
        return None


class _CompileNotice(event.Listener):
    """Says on stderr that kernels are being compiled (first run), then how many so far:
    a line every ``NOTICE_EVERY`` s (half that on a terminal)."""

    def __init__(self) -> None:
        self.count = 0
        self.first: float | None = None
        self.next_line = 0.0

    def on_start(self, ev: event.Event) -> None:
        if self.first is None and _ours(ev):
            self.first = time.monotonic()
            self.next_line = self.first + NOTICE_AFTER
            print("sdfphys: compiling kernels for this machine, first run only",
                  file=sys.stderr, flush=True)

    def on_end(self, ev: event.Event) -> None:
        if self.first is None or not _ours(ev):
            return
        self.count += 1
        now = time.monotonic()
        if now >= self.next_line:
            every = NOTICE_EVERY / 2 if sys.stderr.isatty() else NOTICE_EVERY
            self.next_line = now + every
            print(f"sdfphys: {self.count} kernels compiled in {now - self.first:.0f} s",
                  file=sys.stderr, flush=True)


def _ours(ev: event.Event) -> bool:
    """Whether a compile event is for a function of this package (and the notice is on:
    ``SDFPHYS_COMPILE_NOTICE=0`` in the environment turns it off)."""
    if os.environ.get("SDFPHYS_COMPILE_NOTICE", "1") == "0":
        return False
    dispatcher = ev.data.get("dispatcher") if isinstance(ev.data, dict) else None
    module = getattr(getattr(dispatcher, "py_func", None), "__module__", "") or ""
    return module.split(".")[0] == PACKAGE.name


_NOTICE = _CompileNotice()


#: Numba's index loader, which ``load_index_or_miss`` wraps.
_NUMBA_LOAD_INDEX = caching.IndexDataCacheFile._load_index


def load_index_or_miss(self: caching.IndexDataCacheFile) -> dict:
    """Numba's ``_load_index``, with an index that does not unpickle (it names a class or
    module this version lacks, or is cut short) read as empty (module docstring)."""
    try:
        return _NUMBA_LOAD_INDEX(self)
    except (AttributeError, ImportError, EOFError, pickle.UnpicklingError):
        return {}


def install() -> None:
    """Put ModuleStampLocator first in numba's locator list, read stale indexes as
    misses (``load_index_or_miss``) and register the first-run notice (idempotent). A
    locator list the user chose (NUMBA_CACHE_LOCATOR_CLASSES, numba >= 0.61) replaces
    numba's and so this one too."""
    caching.IndexDataCacheFile._load_index = load_index_or_miss
    locators = _CACHE_IMPL._locator_classes
    if ModuleStampLocator not in locators:
        locators.insert(0, ModuleStampLocator)
        event.register("numba:compile", _NOTICE)

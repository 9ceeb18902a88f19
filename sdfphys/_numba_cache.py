"""Numba's on-disk cache, invalidated when any sdfphys source file changes.

Numba keys a cached kernel on its own source file only (``numba.core.caching``: the
index stores a hash of the file the function is defined in). Kernels here call njit
functions of other files, which numba compiles into them: the collision kernels of
``sdfphys.collide`` run ``sdf.compiled.run``'s field programs, so after an edit of
``sdf/compiled.py`` a kernel of ``collide/`` would load machine code built from the old
one and compute wrong contacts without an error (it happened during development).

:class:`PackageStampLocator` wraps the locator numba would have chosen for a function
defined in this package (same cache directory, same file names) and adds a hash of
every sdfphys source file to its stamp: any change to the package recompiles each
sdfphys kernel once, on first use. Functions outside the package keep numba's own
locators. ``install`` puts it first in numba's locator list; ``NUMBA_CACHE_DIR`` is
honoured as before (the wrapped locator is numba's choice).
"""

from __future__ import annotations

import hashlib
from pathlib import Path

from numba.core import caching

__all__ = ["PackageStampLocator", "install", "package_stamp"]

#: The directory of the sdfphys package.
PACKAGE = Path(__file__).resolve().parent

_STAMP: str | None = None

#: Numba's base of cache implementations, which holds the locator list (``CacheImpl``
#: in recent numba, ``_CacheImpl`` in older ones).
_CACHE_IMPL = getattr(caching, "CacheImpl", None) or getattr(caching, "_CacheImpl")


def package_stamp(root: Path = PACKAGE) -> str:
    """sha256 (hex) of the relative path and the bytes of every ``.py`` file below
    ``root``, in sorted order (about 1 ms for this package)."""
    digest = hashlib.sha256()
    for path in sorted(root.rglob("*.py")):
        digest.update(path.relative_to(root).as_posix().encode() + b"\0")
        digest.update(path.read_bytes() + b"\0")
    return digest.hexdigest()


def _stamp() -> str:
    """This process's package stamp (computed once)."""
    global _STAMP
    if _STAMP is None:
        _STAMP = package_stamp()
    return _STAMP


def _default_locators() -> list[type]:
    """Numba's locators, in its order, without this one."""
    return [c for c in _CACHE_IMPL._locator_classes if c is not PackageStampLocator]


class PackageStampLocator(caching._CacheLocator):
    """Numba's own locator for a function of this package, its source stamp extended by
    :func:`package_stamp`."""

    def __init__(self, inner: caching._CacheLocator):
        self._inner = inner

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
        return self._inner.get_source_stamp(), _stamp()

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
                return cls(inner)
        return None


def install() -> None:
    """Put PackageStampLocator first in numba's locator list (idempotent). A list the
    user chose (NUMBA_CACHE_LOCATOR_CLASSES, numba >= 0.61) replaces numba's and so
    this one too."""
    locators = _CACHE_IMPL._locator_classes
    if PackageStampLocator not in locators:
        locators.insert(0, PackageStampLocator)

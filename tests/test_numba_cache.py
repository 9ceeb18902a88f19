"""sdfphys._numba_cache: a cached kernel follows its module and everything it imports.

Numba alone keys a kernel's cache on its own file; a kernel that inlines another
file's njit function (the collision kernels run sdf.compiled's programs) would
otherwise load stale machine code after that file changes. Kernels of modules that do
not import the edited file keep their cache.
"""

import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from numba import njit

import sdfphys
import sdfphys.solver.substeps as solver
from sdfphys import _numba_cache


def make_package(root: Path) -> Path:
    """pkg/a.py imports b and, relatively, sub.c; d.py is imported by nobody."""
    pkg = root / "pkg"
    (pkg / "sub").mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "sub" / "__init__.py").write_text("from .c import z\n")
    (pkg / "a.py").write_text("import pkg.b\nfrom .sub import c\nx = 1\n")
    (pkg / "b.py").write_text("y = 2\n")
    (pkg / "sub" / "c.py").write_text("from ..b import y\nz = 3\n")
    (pkg / "d.py").write_text("w = 4\n")
    return pkg


def stamp(pkg: Path, name: str) -> str:
    _numba_cache._STAMPS.clear()
    return _numba_cache.dependency_stamp(pkg / name, pkg)


def test_imports_are_read_absolute_relative_and_from_packages(tmp_path):
    pkg = make_package(tmp_path)
    assert _numba_cache.imported_files(pkg / "a.py", pkg) == {pkg / "b.py",
                                                              pkg / "sub" / "c.py"}
    assert _numba_cache.imported_files(pkg / "sub" / "c.py", pkg) == {pkg / "b.py"}
    assert _numba_cache.imported_files(pkg / "sub" / "__init__.py", pkg) == {
        pkg / "sub" / "c.py"}


def test_the_stamp_follows_the_module_and_its_imports_only(tmp_path):
    pkg = make_package(tmp_path)
    first = stamp(pkg, "a.py")
    assert stamp(pkg, "a.py") == first
    os.utime(pkg / "b.py", (0, 0))                        # touched, same bytes
    assert stamp(pkg, "a.py") == first
    (pkg / "d.py").write_text("w = 5\n")                  # nobody imports it
    assert stamp(pkg, "a.py") == first
    (pkg / "b.py").write_text("y = 3\n")                  # a dependency's edit
    edited = stamp(pkg, "a.py")
    assert edited != first
    (pkg / "sub" / "c.py").write_text("from ..b import y\nz = 4\n")   # transitively
    assert stamp(pkg, "a.py") not in (first, edited)
    assert stamp(pkg, "d.py") != stamp(pkg, "b.py")


def test_sdfphys_kernels_use_the_module_stamp_and_numba_s_directory():
    solver._any_below(np.zeros(1), 0.0)
    locator = solver._any_below._cache._impl.locator
    assert isinstance(locator, _numba_cache.ModuleStampLocator)
    assert locator.get_source_stamp()[1] == _numba_cache.dependency_stamp(
        Path(solver.__file__))
    assert locator.get_cache_path() == locator._inner.get_cache_path()
    assert locator._py_file == solver.__file__


@njit(cache=True)
def _outside(x):
    return x + 1


def test_functions_outside_the_package_keep_numba_s_locators():
    assert _outside(1) == 2
    assert not isinstance(_outside._cache._impl.locator, _numba_cache.ModuleStampLocator)


SCRIPT = """
import numpy as np
import sdfphys.solver.substeps as s
from sdfphys.collide import _compiled_descent as d
s._any_below(np.zeros(1), 0.0)
d.merge_minima(np.zeros((1, 2, 2)), 1e-6)
for k in (s._any_below, d.merge_minima):
    print(sum(k.stats.cache_hits.values()), sum(k.stats.cache_misses.values()))
print(s.__file__)
"""


@pytest.mark.slow        # three processes on a copy of the package: about 5 s
def test_an_edit_recompiles_the_kernels_that_import_the_file_and_only_those(tmp_path):
    """A copy of the package and one cache, three processes: the second loads the first's
    kernels; after an edit of sdf/compiled.py, which the descent kernels import (numba
    alone would load their old code) and the solver does not, the third recompiles the
    descent's kernel and loads the solver's; the first run says it compiles, the
    second says nothing."""
    shutil.copytree(Path(sdfphys.__file__).parent, tmp_path / "pkg" / "sdfphys",
                    ignore=shutil.ignore_patterns("__pycache__"))
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"),
               PYTHONPATH=str(tmp_path / "pkg"), SDFPHYS_COMPILE_NOTICE="1")

    def run():
        done = subprocess.run([sys.executable, "-c", SCRIPT], env=env, check=True,
                              capture_output=True, text=True, cwd=tmp_path)
        out = done.stdout.split("\n")
        assert out[2].startswith(str(tmp_path))
        return [tuple(map(int, line.split())) for line in out[:2]], done.stderr

    counts, err = run()
    assert counts == [(0, 1), (0, 1)]
    assert "compiling kernels for this machine, first run only" in err
    counts, err = run()
    assert counts == [(1, 0), (1, 0)]
    assert "compiling" not in err
    with open(tmp_path / "pkg" / "sdfphys" / "sdf" / "compiled.py", "a") as f:
        f.write("\n# edited\n")
    counts, _ = run()
    assert counts == [(1, 0), (0, 1)]
    env["SDFPHYS_COMPILE_NOTICE"] = "0"                   # the notice can be silenced
    with open(tmp_path / "pkg" / "sdfphys" / "sdf" / "compiled.py", "a") as f:
        f.write("\n# edited again\n")
    counts, err = run()
    assert counts == [(1, 0), (0, 1)] and "compiling" not in err


class _Gone:
    """Stands for a class an older version of the package pickled into a cache index."""


def test_an_index_naming_a_class_this_version_lacks_is_a_miss(tmp_path, monkeypatch):
    """Numba unpickles a kernel's index before it compares its stamp: an index written by
    a version whose bundle type this one no longer has (the joints' StructRef, removed)
    raised AttributeError out of the kernel's first call. Read through
    ``load_index_or_miss`` it is empty (numba compiles and writes a fresh one), and a
    save over it works; a readable index loads as before."""
    from numba.core import caching

    from sdfphys.solver import joints

    monkeypatch.setattr(_Gone, "__module__", joints.__name__)
    monkeypatch.setattr(joints, "_Gone", _Gone, raising=False)
    cache = caching.IndexDataCacheFile(str(tmp_path), "kernel-1.py311", "stamp")
    cache._save_index({("signature",): _Gone()})
    monkeypatch.delattr(joints, "_Gone")
    with pytest.raises(AttributeError):
        _numba_cache._NUMBA_LOAD_INDEX(cache)
    assert caching.IndexDataCacheFile._load_index is _numba_cache.load_index_or_miss
    assert cache._load_index() == {}
    cache.save(("signature",), b"machine code")
    assert list(cache._load_index()) == [("signature",)]
    (tmp_path / "kernel-1.py311.nbi").write_bytes(
        (tmp_path / "kernel-1.py311.nbi").read_bytes()[:-3])          # cut short
    assert cache._load_index() == {}

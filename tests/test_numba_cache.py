"""sdfphys._numba_cache: cached kernels follow every sdfphys source file.

Numba alone keys a kernel's cache on its own file; a kernel that inlines another
file's njit function (the collision kernels run sdf.compiled's programs) would
otherwise load stale machine code after that file changes.
"""

import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
from numba import njit

import sdfphys
import sdfphys.solver as solver
from sdfphys import _numba_cache


def test_the_stamp_follows_every_file_s_bytes_and_name(tmp_path):
    (tmp_path / "sub").mkdir()
    (tmp_path / "a.py").write_text("x = 1\n")
    (tmp_path / "sub" / "b.py").write_text("y = 2\n")
    first = _numba_cache.package_stamp(tmp_path)
    assert _numba_cache.package_stamp(tmp_path) == first
    os.utime(tmp_path / "a.py", (0, 0))                  # touched, same bytes
    assert _numba_cache.package_stamp(tmp_path) == first
    (tmp_path / "sub" / "b.py").write_text("y = 3\n")   # a dependency's edit
    edited = _numba_cache.package_stamp(tmp_path)
    assert edited != first
    (tmp_path / "sub" / "b.py").rename(tmp_path / "sub" / "c.py")
    assert _numba_cache.package_stamp(tmp_path) not in (first, edited)


def test_sdfphys_kernels_use_the_package_stamp_and_numba_s_directory():
    solver._any_below(np.zeros(1), 0.0)
    locator = solver._any_below._cache._impl.locator
    assert isinstance(locator, _numba_cache.PackageStampLocator)
    assert locator.get_source_stamp()[1] == _numba_cache.package_stamp()
    assert locator.get_cache_path() == locator._inner.get_cache_path()
    assert locator._py_file == solver.__file__


@njit(cache=True)
def _outside(x):
    return x + 1


def test_functions_outside_the_package_keep_numba_s_locators():
    assert _outside(1) == 2
    assert not isinstance(_outside._cache._impl.locator, _numba_cache.PackageStampLocator)


def test_an_edit_of_another_sdfphys_file_recompiles_a_cached_kernel(tmp_path):
    """A copy of the package and one cache, three processes: the second loads the first's
    solver kernel; after an edit of sdf/compiled.py (not solver.py, so numba alone would
    load the old kernel) the third recompiles it."""
    shutil.copytree(Path(sdfphys.__file__).parent, tmp_path / "pkg" / "sdfphys",
                    ignore=shutil.ignore_patterns("__pycache__"))
    script = ("import numpy as np, sdfphys.solver as s; s._any_below(np.zeros(1), 0.0); "
              "print(sum(s._any_below.stats.cache_hits.values()), "
              "sum(s._any_below.stats.cache_misses.values()), s.__file__)")
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"),
               PYTHONPATH=str(tmp_path / "pkg"))

    def run():
        out = subprocess.run([sys.executable, "-c", script], env=env, check=True,
                             capture_output=True, text=True, cwd=tmp_path).stdout.split()
        assert out[2].startswith(str(tmp_path))
        return int(out[0]), int(out[1])

    assert run() == (0, 1)
    assert run() == (1, 0)
    with open(tmp_path / "pkg" / "sdfphys" / "sdf" / "compiled.py", "a") as f:
        f.write("\n# edited\n")
    assert run() == (0, 1)

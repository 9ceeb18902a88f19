"""Processes on one numba cache compile each kernel once (``sdfphys._compile_lock``)."""

from __future__ import annotations

import os
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
from numba.core import types

from sdfphys import _compile_lock
from sdfphys.sorting import stable_argsort

WAITER = """
import sys
import numpy as np
from numba.core import types
from sdfphys.sorting import stable_argsort
print("ready", flush=True)
stable_argsort(np.arange(5, dtype=np.int64))
stats = stable_argsort.stats
print(sum(stats.cache_hits.values()), sum(stats.cache_misses.values()), flush=True)
"""


def _dead_pid() -> int:
    child = subprocess.Popen([sys.executable, "-c", "pass"])
    child.wait()
    return child.pid


def test_a_lock_held_by_a_live_process_is_waited_for(tmp_path):
    path = str(tmp_path / "kernel.nbi.lock")
    Path(path).write_text(str(os.getppid()))
    threading.Timer(0.4, os.unlink, args=(path,)).start()
    t0 = time.monotonic()
    assert _compile_lock._acquire(path)
    assert time.monotonic() - t0 >= 0.4
    assert Path(path).read_text() == str(os.getpid())
    _compile_lock._release(path)
    assert not os.path.exists(path)


def test_jobs_run_once_each_while_waiting_and_not_inside_a_held_lock(tmp_path):
    """While another live process holds the lock, the waiting process runs its jobs in
    order, each once; a job that fails is dropped; a job that meets a lock another
    process holds stops at once (``KernelBusy``) and is dropped, running no other job;
    none runs while this process holds a lock of its own (a callee's wait)."""
    path, other = str(tmp_path / "kernel.nbi.lock"), str(tmp_path / "callee.nbi.lock")
    ran = []

    def nested():
        ran.append("nested")
        Path(other).write_text(str(os.getppid()))
        t0 = time.monotonic()
        try:
            _compile_lock._acquire(other)        # held elsewhere: no wait, no other job
        except _compile_lock.KernelBusy:
            ran.append(f"busy {time.monotonic() - t0 < 0.1}")
            raise
        finally:
            os.unlink(other)

    def fails():
        ran.append("fails")
        raise RuntimeError("a job that fails is dropped")

    def last():
        ran.append("last")
        os.unlink(path)                          # the other process is done

    _compile_lock.while_waiting([nested, fails, last, lambda: ran.append("never")])
    try:
        Path(path).write_text(str(os.getppid()))
        assert _compile_lock._acquire(path)
        assert ran == ["nested", "busy True", "fails", "last"]
        _compile_lock._release(path)
        held = str(tmp_path / "held.nbi.lock")
        assert _compile_lock._acquire(held)
        Path(path).write_text(str(os.getppid()))
        threading.Timer(0.3, os.unlink, args=(path,)).start()
        assert _compile_lock._acquire(path)      # waits, holding `held`: no job
        assert ran == ["nested", "busy True", "fails", "last"]
        _compile_lock._release(path)
        _compile_lock._release(held)
    finally:
        _compile_lock.while_waiting(())


def test_a_lock_whose_owner_died_is_taken_over_at_once(tmp_path):
    path = str(tmp_path / "kernel.nbi.lock")
    Path(path).write_text(str(_dead_pid()))
    t0 = time.monotonic()
    assert _compile_lock._acquire(path)
    assert time.monotonic() - t0 < 1.0
    _compile_lock._release(path)
    assert not os.path.exists(path)


def test_held_elsewhere_tells_a_live_other_owner_from_this_process_and_the_dead(
        monkeypatch, tmp_path):
    """``held_elsewhere``: True while another live process holds a kernel's lock; False
    without a lock file, for a lock this process holds, and for a dead owner's."""
    path = str(tmp_path / "kernel.nbi.lock")
    monkeypatch.setattr(_compile_lock, "lock_path", lambda kernel: path)
    assert not _compile_lock.held_elsewhere(stable_argsort)
    Path(path).write_text(str(os.getppid()))
    assert _compile_lock.held_elsewhere(stable_argsort)
    Path(path).write_text(str(_dead_pid()))
    assert not _compile_lock.held_elsewhere(stable_argsort)
    os.unlink(path)
    assert _compile_lock._acquire(path)
    assert not _compile_lock.held_elsewhere(stable_argsort)
    _compile_lock._release(path)


def test_the_lock_is_reentrant_within_a_process(tmp_path):
    path = str(tmp_path / "kernel.nbi.lock")
    assert _compile_lock._acquire(path) and _compile_lock._acquire(path)
    _compile_lock._release(path)
    assert Path(path).read_text() == str(os.getpid())
    _compile_lock._release(path)
    assert not os.path.exists(path)


def test_numba_compiles_under_the_kernels_lock(monkeypatch):
    """The lock file exists, with this pid, while numba looks up the cache and compiles;
    it is gone afterwards; a signature already compiled takes no lock."""
    seen = []

    def numba_compile(kernel, sig):
        path = _compile_lock.lock_path(kernel)
        seen.append(os.path.exists(path) and Path(path).read_text() == str(os.getpid()))

    stable_argsort(np.zeros(3))
    compiled = next(s for s in stable_argsort.signatures if s[0].dtype == types.float64)
    monkeypatch.setattr(_compile_lock, "_NUMBA_COMPILE", numba_compile)
    _compile_lock._locked_compile(stable_argsort, compiled)
    assert seen == [False]                              # compiled already: no lock
    _compile_lock._locked_compile(stable_argsort, (types.Array(types.int16, 1, "C"),))
    assert seen == [False, True]
    assert not os.path.exists(_compile_lock.lock_path(stable_argsort))


def test_two_processes_waiting_on_one_kernel_compile_it_once(tmp_path):
    """Both wait behind a held lock; once it is released one compiles and saves, the
    other loads what it saved (without the lock both would compile)."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path), "SDFPHYS_COMPILE_NOTICE": "0"}
    probe = subprocess.run([sys.executable, "-c",
                            "from sdfphys import _compile_lock\n"
                            "from sdfphys.sorting import stable_argsort as k\n"
                            "k._cache._impl.locator.ensure_cache_path()\n"
                            "print(_compile_lock.lock_path(k))"],
                           capture_output=True, text=True, env=env, check=True)
    path = probe.stdout.strip()
    Path(path).write_text(str(os.getpid()))
    waiters = [subprocess.Popen([sys.executable, "-c", WAITER], env=env, text=True,
                                stdout=subprocess.PIPE) for _ in range(2)]
    try:
        for w in waiters:
            assert w.stdout.readline().strip() == "ready"
        time.sleep(1.0)
        assert all(w.poll() is None for w in waiters)   # both wait for the lock
        os.unlink(path)
        counts = [tuple(int(v) for v in w.communicate(timeout=120)[0].split())
                  for w in waiters]
    finally:
        for w in waiters:
            w.kill()
    assert sorted(counts) == [(0, 1), (1, 0)]
    assert not os.path.exists(path)

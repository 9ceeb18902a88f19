"""Processes sharing a numba cache compile each kernel once: one compiles, the others wait.

Numba's on-disk cache is safe to read while another process writes it only for one
function at a time: ``IndexDataCacheFile.save`` names a new data file after the count of
entries in the index it has just read, so two processes saving two signatures of one
function at once can write the same ``.nbc`` file, and the index then points a signature
at the other's machine code; and a process that compiles what another is compiling at the
same moment only doubles the work. Both happen on a cold start, where ``sdfphys._warm``'s
child compiles beside the parent, and in any set of processes started together on an
empty cache (sweep workers, parallel test runs).

``install`` routes numba's ``Dispatcher.compile`` for this package's kernels through a
lock file per kernel (its cache index's name plus ``.lock``, beside it in the cache
directory; created with ``O_EXCL``, holding the owner's pid). A process takes the lock,
then lets numba look up its cache and, on a miss, compile and save, and then removes
the lock. A process that finds the lock taken waits (polling every ``POLL_SECONDS``)
and then looks the kernel up itself, so it loads what the other saved instead of
compiling it again. Every read and write of a kernel's cache files happens under its
lock. The lock is re-entrant within a process (compiling a kernel may compile another
signature of it). A lock whose owner has died (no such pid; not asked on Windows, where
``os.kill`` ends a process) or that is older than ``STALE_SECONDS`` is taken over. Where
no lock file can be made (a read-only cache), numba compiles unlocked, as without this
module.

No deadlock: a process waits for a kernel only while compiling a caller of it (numba
compiles a callee while typing its caller), so two processes waiting for each other
would need a cycle of calls between kernels, which an njit call graph without recursion
between kernels does not have.

Work while waiting (``while_waiting``): a process may leave jobs (callables that
compile kernels it will need later) to run, one at a time and each once, whenever it
finds a kernel's lock held by another process while it holds none itself (a kernel it
calls, not a callee of one it is compiling), instead of sleeping. A job never waits:
where it meets a kernel another process is compiling it stops (``KernelBusy``) and is
dropped, and that kernel compiles, or loads, at its first real call. (A job that waited
there kept the parent of a box stack's cold start idle for the 8 s the child spent
compiling the field evaluator after the kernel the parent had been waiting for.) A job
holds locks only of kernels it compiles and their callees, as any caller does, so the
argument above still holds. The parent of a cold start leaves its step's last stages
there (``sdfphys._warm``), so that it compiles them while the compiling child holds a
kernel it needs.
"""

from __future__ import annotations

import os
import threading
import time
from collections.abc import Callable, Iterable
from pathlib import Path

from numba.core import dispatcher, sigutils

__all__ = ["POLL_SECONDS", "STALE_SECONDS", "KernelBusy", "held_elsewhere", "install",
           "lock_path", "while_waiting"]

#: Seconds between two looks at a lock another process holds.
POLL_SECONDS = 0.02
#: A lock older than this is an abandoned one (the longest kernel compiles in ~20 s on a
#: 2-core machine; its pid may have been reused).
STALE_SECONDS = 600.0

#: Numba's ``Dispatcher.compile``, wrapped by ``_locked_compile``.
_NUMBA_COMPILE = dispatcher.Dispatcher.compile

#: The package whose kernels compile under a lock.
_PACKAGE = __name__.split(".")[0]

#: Lock files this process holds -> how many nested compilations hold each.
_held: dict[str, int] = {}

#: Jobs to run while waiting for another process's kernel (``while_waiting``), in order.
_jobs: list[Callable[[], None]] = []
#: Held while a job runs: one job at a time, none inside another.
_job_running = threading.Lock()
#: The thread running a job, if any (its waits stop the job instead: ``KernelBusy``).
_job_thread: list[int] = []


class KernelBusy(Exception):
    """A job met a kernel another process is compiling: the job stops and is dropped."""


def while_waiting(jobs: Iterable[Callable[[], None]]) -> None:
    """Replace the jobs left to run while this process waits for a kernel another
    process is compiling (module docstring); an empty iterable clears them."""
    _jobs[:] = list(jobs)


def _run_a_job() -> bool:
    """Run the next job, if any, none is running and this process holds no kernel's
    lock (it waits for a kernel it calls, not for a callee of one it is compiling, which
    a job might call again); whether one ran. A job that fails is dropped: it only
    compiles ahead, and the kernel it aimed at compiles at its first real call
    instead."""
    if not _jobs or _held or not _job_running.acquire(blocking=False):
        return False
    try:
        if not _jobs:
            return False
        job = _jobs.pop(0)
        _job_thread.append(threading.get_ident())
        try:
            job()
        except Exception:
            pass
        finally:
            _job_thread.clear()
        return True
    finally:
        _job_running.release()


def lock_path(kernel) -> str | None:
    """The lock file of a dispatcher's cache (None: not cached, or not this package's)."""
    module = getattr(kernel.py_func, "__module__", "") or ""
    cache = getattr(kernel, "_cache", None)
    index = getattr(getattr(cache, "_cache_file", None), "_index_path", None)
    if module.split(".")[0] != _PACKAGE or index is None:
        return None
    return index + ".lock"


def held_elsewhere(kernel) -> bool:
    """Whether another live process holds a dispatcher's lock now (it is compiling the
    kernel): a process with other work may do that first instead of waiting."""
    path = lock_path(kernel)
    return (path is not None and path not in _held and os.path.exists(path)
            and not _stale(path))


def _stale(path: str) -> bool:
    """Whether the lock at ``path`` is abandoned: its owner is gone or it is too old."""
    try:
        age = time.time() - os.stat(path).st_mtime
        text = Path(path).read_text()
    except OSError:
        return False                                # gone meanwhile: take it next time
    if age > STALE_SECONDS:
        return True
    if not text.strip().isdigit():
        return age > 5.0                            # being written, or garbage
    if os.name == "nt":
        return False            # os.kill(pid, 0) would terminate the process there
    try:
        os.kill(int(text), 0)
    except ProcessLookupError:
        return True
    except OSError:
        pass                                        # alive, someone else's
    return False


def _acquire(path: str) -> bool:
    """Take the lock at ``path``, waiting while another live process holds it. False if
    no lock file can be made there (then compile without one)."""
    if path in _held:
        _held[path] += 1
        return True
    while True:
        try:
            fd = os.open(path, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
        except FileExistsError:
            if _stale(path):
                try:
                    os.unlink(path)
                except OSError:
                    pass
            elif threading.get_ident() in _job_thread:
                raise KernelBusy(path)
            elif not _run_a_job():
                time.sleep(POLL_SECONDS)
            continue
        except OSError:
            return False
        with os.fdopen(fd, "w") as f:
            f.write(str(os.getpid()))
        _held[path] = 1
        return True


def _release(path: str) -> None:
    _held[path] -= 1
    if _held[path] == 0:
        del _held[path]
        try:
            os.unlink(path)
        except OSError:
            pass


def _locked_compile(self, sig):
    """``Dispatcher.compile`` under the kernel's lock file (see the module doc)."""
    path = lock_path(self)
    if path is None or tuple(sigutils.normalize_signature(sig)[0]) in self.overloads:
        return _NUMBA_COMPILE(self, sig)
    try:
        self._cache._impl.locator.ensure_cache_path()
    except OSError:
        return _NUMBA_COMPILE(self, sig)
    if not _acquire(path):
        return _NUMBA_COMPILE(self, sig)
    try:
        return _NUMBA_COMPILE(self, sig)
    finally:
        _release(path)


def install() -> None:
    """Route numba's ``Dispatcher.compile`` through ``_locked_compile`` (idempotent)."""
    dispatcher.Dispatcher.compile = _locked_compile

"""A second process compiles the solver's kernels while the first compiles the collisions'.

Numba compiles one kernel at a time under a process-wide lock, so a cold first step is
serial: the collision kernels (stage 1, most of it for fields: the descents) and then
the solver's (stages 2-6, most of it for a scene of boxes). On a machine with two cores
or more, the first step of the first world of a process whose solver kernels are not yet
in the on-disk cache forks a child (``start``): it runs the stages after the contact
rows' preparation on no contacts, last stage first (``world_stages.compile_ahead``), which
compiles the same kernels with the same argument types into the same cache, and exits.
The parent goes on with the collisions and the preparation, then waits for the child
(``join``, at most JOIN_SECONDS) and loads the rest instead of compiling it (numba
checks the cache before compiling, and writes a cache file under a temporary name and
renames it, so a reader never sees half of one). The trajectory is the same either
way, only the wait shorter. Racing the child instead of waiting for it compiled much of
the substep kernels twice, in both processes at once; running the collision stage's
pair groups in reverse in the child gained nothing on the showcase: the groups share
the descent's kernels.

The child writes nothing but cache files: its standard streams go to the null device,
it closes every other inherited descriptor (a video encoder's pipe must see its end of
file when the parent closes it), takes the default action on SIGINT and SIGTERM, ends
itself after CHILD_SECONDS, keeps the compile notice quiet, and leaves with
``os._exit`` (no atexit handler, no flush of the parent's buffers). ``SDFPHYS_WARM=0``
in the environment turns it off.
"""

from __future__ import annotations

import os
import pickle
import signal
import threading
from typing import Any

__all__ = ["CHILD_SECONDS", "JOIN_SECONDS", "join", "start"]

_started = False
#: Set while no child runs (``join``).
_done = threading.Event()
_done.set()
#: The child ends itself after this long whatever it is doing (SIGALRM's default
#: action): a lock another thread of the parent held at the fork cannot keep it alive.
CHILD_SECONDS = 900
#: The parent waits at most this long for the child, then compiles what is left itself
#: (a child several times slower than the joint scenes' 45 s on this machine).
JOIN_SECONDS = 240


def _cold() -> bool:
    """Whether the substep kernel has no entry for this source in the on-disk cache
    (numba's index for it is missing or stale). Any failure to tell: False."""
    from .solver import substeps

    try:
        return not substeps._substeps_kernel._cache._cache_file._load_index()
    except (AttributeError, OSError, ImportError, EOFError, pickle.UnpicklingError):
        return False            # another numba's layout, an unreadable index: no fork


def start(world: Any) -> int | None:
    """Fork the compiling child for ``world`` if this process has not yet, the machine has
    two cores or more, the platform forks, it is not turned off and the cache is cold.
    Returns the child's pid (None: no child)."""
    global _started
    if _started:
        return None
    _started = True
    if (os.environ.get("SDFPHYS_WARM", "1") == "0" or not hasattr(os, "fork")
            or (os.cpu_count() or 1) < 2 or not _cold()):
        return None
    pid = os.fork()
    if pid == 0:                                    # the child
        try:
            signal.signal(signal.SIGINT, signal.SIG_DFL)
            signal.signal(signal.SIGTERM, signal.SIG_DFL)
            signal.alarm(CHILD_SECONDS)
            null = os.open(os.devnull, os.O_RDWR)
            for fd in (0, 1, 2):
                os.dup2(null, fd)
            os.closerange(3, 1 << 16)
            os.environ["SDFPHYS_COMPILE_NOTICE"] = "0"
            from .world_stages import compile_ahead

            compile_ahead(world)
        finally:
            os._exit(0)
    _done.clear()
    threading.Thread(target=_reap, args=(pid,), daemon=True).start()
    return pid


def _reap(pid: int) -> None:
    """Wait for the child (no zombie is left), then let ``join`` return."""
    try:
        os.waitpid(pid, 0)
    finally:
        _done.set()


def join(timeout: float = JOIN_SECONDS) -> None:
    """Wait until the child (if any) has exited, at most ``timeout`` s: the parent calls
    it where it would start compiling what the child compiles (``World.step``, before
    the substeps)."""
    _done.wait(timeout)

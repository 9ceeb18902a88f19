"""SIGINT and SIGTERM during a command: exit 130 or 143 with one line, nothing left behind.

``handled()`` installs, for the duration of a command, a handler that turns the first
SIGINT or SIGTERM into ``Interrupted`` (a KeyboardInterrupt) wherever the program is,
so that the ``except BaseException`` cleanups of the output writers run; further
signals are ignored while they do. ``received()`` tells the command line which signal
came, whatever exception it finally sees (an exception raised inside a compiled
kernel's call can surface as another one, e.g. numba's SystemError).

``deferred()`` holds the two signals back during a few lines that create or remove a
temporary file (``pthread_sigmask``): a signal is never handled between creating a
file and recording its name for the cleanup.
"""

from __future__ import annotations

import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager

__all__ = ["SIGNALS", "Interrupted", "deferred", "exit_status", "handled", "received"]

#: The signals handled.
SIGNALS = (signal.SIGINT, signal.SIGTERM)

_received: int | None = None


class Interrupted(KeyboardInterrupt):
    """Raised by the handler of ``handled()``; ``signum`` is the signal's number."""

    def __init__(self, signum: int):
        super().__init__(signal.Signals(signum).name)
        self.signum = signum


def _handler(signum: int, frame) -> None:
    global _received
    if _received is not None:
        return                  # the cleanup of the first one is running: let it finish
    _received = signum
    raise Interrupted(signum)


def _main_thread() -> bool:
    return threading.current_thread() is threading.main_thread()


@contextmanager
def handled() -> Iterator[None]:
    """Handle SIGINT and SIGTERM as ``Interrupted`` inside the block (main thread only;
    elsewhere the block runs unchanged). The previous handlers are restored after."""
    global _received
    _received = None
    if not _main_thread():
        yield
        return
    previous = {s: signal.signal(s, _handler) for s in SIGNALS}
    try:
        yield
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)


def received() -> int | None:
    """The signal number handled by the current (or last) ``handled()`` block, if any."""
    return _received


def exit_status(signum: int) -> int:
    """The shell's exit status for a process ended by ``signum``: 128 + its number."""
    return 128 + int(signum)


@contextmanager
def deferred() -> Iterator[None]:
    """SIGINT and SIGTERM held back inside the block and handled when it ends (POSIX;
    a no-op elsewhere or off the main thread). Keep such blocks short."""
    if not hasattr(signal, "pthread_sigmask") or not _main_thread():
        yield
        return
    old = signal.pthread_sigmask(signal.SIG_BLOCK, SIGNALS)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)

"""SIGINT and SIGTERM during a command: exit 130 or 143 with one line, nothing left behind.

``handled()`` installs, for the duration of a command, a handler that turns the first
SIGINT or SIGTERM into ``Interrupted`` (a KeyboardInterrupt) wherever the program is,
so that the ``except BaseException`` cleanups of the output writers run; further
signals are ignored while they do. ``received()`` tells the command line which signal
came, whatever exception it finally sees (an exception raised inside a compiled
kernel's call can surface as another one, e.g. numba's SystemError).

A handler runs at whatever Python line the main thread is on, and an exception raised
where Python cannot propagate it (a ``__del__``, a garbage-collector or C-library
callback, of which numba's compiler runs many) is printed as "Exception ignored" and
dropped: the command would go on with the signal marked handled and further signals
ignored. Inside ``handled()`` such a dropped ``Interrupted`` is not printed
(``sys.unraisablehook``; other dropped exceptions are, as before), and the long loops
(``run``'s and ``record``'s steps, the bench's runs) call ``check()`` after each step,
which raises ``Interrupted`` again for a signal whose exception never left that spot.

``deferred()`` holds the two signals back during a few lines that create or remove a
temporary file (``pthread_sigmask``): a signal is never handled between creating a
file and recording its name for the cleanup.
"""

from __future__ import annotations

import signal
import sys
import threading
from collections.abc import Iterator
from contextlib import contextmanager

__all__ = ["SIGNALS", "Interrupted", "check", "deferred", "exit_status", "handled",
           "quiet_finalizers", "received"]

#: The signals handled.
SIGNALS = (signal.SIGINT, signal.SIGTERM)

_received: int | None = None
#: Inside ``handled()`` (main thread): ``check`` may raise.
_active = False


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
    global _received, _active
    _received = None
    if not _main_thread():
        yield
        return
    previous = {s: signal.signal(s, _handler) for s in SIGNALS}
    previous_hook = sys.unraisablehook

    def unraisable(report) -> None:
        if not isinstance(report.exc_value, Interrupted):
            previous_hook(report)

    sys.unraisablehook = unraisable
    _active = True
    try:
        yield
    finally:
        _active = False
        sys.unraisablehook = previous_hook
        for s, handler in previous.items():
            signal.signal(s, handler)


def check() -> None:
    """Raise ``Interrupted`` if, inside ``handled()``, a signal was handled whose
    exception was dropped (module doc); nothing otherwise. Call it from the main loops
    only, not from the cleanups that an ``Interrupted`` runs."""
    if _active and _received is not None:
        raise Interrupted(_received)


def quiet_finalizers() -> None:
    """Report no exception that a finalizer drops from now on. For a process that ends
    on a signal: the objects of work it cut short (a kernel half compiled by numba and
    llvmlite) may fail to close at exit, which says nothing to the user."""
    sys.unraisablehook = lambda report: None


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

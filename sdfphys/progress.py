"""Progress of long command-line runs: a bar on a terminal, a line every ``INTERVAL`` s
otherwise (a CI log, a file, ``nohup``), so no run of more than a few seconds is silent.

Both go to stderr (stdout keeps the summary); the bar redraws one line in place with
the steps done, the elapsed time and an estimate of the time left.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from typing import TextIO

__all__ = ["INTERVAL", "Progress"]

#: Seconds between two progress lines when stderr is not a terminal.
INTERVAL = 10.0


class Progress:
    """Progress of ``total`` units of work (``what``: "steps", "frames", ...).

    ``update(done)`` after each unit; ``close()`` at the end. ``stream`` defaults to
    stderr; ``tty`` (default: ``stream.isatty()``) chooses the bar or the lines;
    ``clock`` (s, monotonic) is for tests.
    """

    def __init__(self, total: int, what: str = "steps", label: str = "sdfphys",
                 stream: TextIO | None = None, tty: bool | None = None,
                 clock: Callable[[], float] = time.monotonic):
        self.total = max(1, int(total))
        self.what = what
        self.label = label
        self.stream = sys.stderr if stream is None else stream
        self.tty = self.stream.isatty() if tty is None else tty
        self.clock = clock
        self.start = clock()
        self._next_line = self.start + INTERVAL
        self._last = (-1, -1)
        self._drawn = False

    def update(self, done: int) -> None:
        """``done`` units of ``total`` are finished."""
        now = self.clock()
        elapsed = now - self.start
        percent = min(100, 100 * done // self.total)
        left = elapsed * (self.total - done) / done if done else float("nan")
        if self.tty:
            shown = (percent, int(elapsed))
            if shown != self._last:
                self._last = shown
                bar = "#" * (percent // 4)
                eta = f", {left:.0f} s left" if done else ""
                self.stream.write(f"\r[{bar:<25}] {percent:3d}% ({done:,}/{self.total:,} "
                                  f"{self.what}, {elapsed:.0f} s{eta})  ")
                self.stream.flush()
                self._drawn = True
        elif now >= self._next_line:
            self._next_line = now + INTERVAL
            eta = f", about {left:.0f} s left" if done else ""
            self.stream.write(f"{self.label}: {done:,}/{self.total:,} {self.what} "
                              f"({percent}%), {elapsed:.0f} s{eta}\n")
            self.stream.flush()

    def close(self) -> None:
        """End the bar's line (nothing to do for the lines)."""
        if self._drawn:
            self.stream.write("\n")
            self.stream.flush()
            self._drawn = False

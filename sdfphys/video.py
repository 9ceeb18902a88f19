"""Frame sinks: write pygame Surfaces to ``.mp4``, ``.gif`` or a folder of numbered ``.png``.

``open_sink(path, size, fps)`` picks the sink from the path and returns an object
with ``write(surface)``, ``close()`` and ``abort()``; it is a context manager that
closes on success and aborts on an exception::

    with open_sink("out.mp4", (960, 540), 60) as sink:
        for ...:
            renderer.draw(surface, world)
            sink.write(surface)

- ``.mp4``: H.264 (libx264), yuv420p, through the ffmpeg executable bundled with
  imageio-ffmpeg (no system ffmpeg needed).
- ``.gif``: the same ffmpeg, a palette per frame (no whole-video buffering). GIF
  delays are whole 1/100 s and viewers slow down delays under 2/100 s, so frame
  rates above 50 are reduced by keeping every k-th frame (k = ceil(fps / 50)):
  60 frames/s is written as 30.
- a directory (a path ending in ``/``, an existing directory or a path without an
  extension): ``frame_00000.png``, ``frame_00001.png``, ... An existing directory
  is replaced only if it holds nothing but such frames. (The command line asks for
  the ``/``: ``output_error``.)

Frame sizes are even (H.264 in yuv420p needs it; every sink does the same so the
outputs agree): an odd width or height is rounded up by repeating the last column
or row of pixels. ``sink.size`` is the size written, ``sink.frame_size`` the size
``write`` expects.

Nothing half-written is left behind: output goes to a hidden temporary name in
the target directory and is renamed onto the target by ``close()``; ``abort()``
(or an exception inside the ``with`` block, a SIGINT or SIGTERM under
``interrupt.handled()``, or an encoder failure) deletes it. ffmpeg runs in a session
of its own, so a Ctrl-C at the terminal reaches this process only, which ends it.
"""

from __future__ import annotations

import math
import os
import re
import shutil
import subprocess
import tempfile
from fractions import Fraction
from pathlib import Path
from types import TracebackType
from typing import Self

os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
import pygame

from .errors import SpecError
from .interrupt import deferred

__all__ = ["GIF_MAX_FPS", "FrameSink", "PngFolderSink", "VideoSink", "even_size", "open_sink",
           "output_error"]

#: Highest frame rate the GIF sink writes (see the module docstring).
GIF_MAX_FPS = 50
_FRAME_NAME = re.compile(r"frame_\d{5,}\.png")


def even_size(size: tuple[int, int]) -> tuple[int, int]:
    """``size`` (width, height) with odd components rounded up to the next even number."""
    w, h = int(size[0]), int(size[1])
    return w + w % 2, h + h % 2


class FrameSink:
    """Base of the sinks: size checks, padding to even sizes, the temporary-name protocol.

    Subclasses implement ``_write_frame(surface)`` (an even-sized Surface),
    ``_finish()`` (complete the temporary output) and ``_discard()``.
    """

    def __init__(self, path: str | os.PathLike, size: tuple[int, int], fps: float):
        self.path = Path(path)
        w, h = size
        if not (isinstance(w, int) and isinstance(h, int) and w > 0 and h > 0):
            raise ValueError(f"frame size must be two positive integers, got {size!r}")
        if not (isinstance(fps, (int, float)) and math.isfinite(fps) and fps > 0):
            raise ValueError(f"fps must be a positive number, got {fps!r}")
        parent = self.path.parent
        if not parent.is_dir():
            raise SpecError("", f"cannot write here: no such directory {str(parent)!r}",
                            str(path))
        self.frame_size = (w, h)
        self.size = even_size(self.frame_size)
        self.fps = fps
        self.frames = 0
        self.closed = False

    @property
    def frames_written(self) -> int:
        """Frames in the output (``frames`` received, fewer where frames are dropped)."""
        return self.frames

    @property
    def fps_written(self) -> float:
        """Frame rate of the output, frames/s."""
        return self.fps

    def write(self, surface: pygame.Surface) -> None:
        """Append one frame; ``surface`` must have ``frame_size`` (or the even ``size``)."""
        if self.closed:
            raise ValueError(f"{self.path}: sink is closed")
        if surface.get_size() not in (self.frame_size, self.size):
            raise ValueError(f"{self.path}: frame is {surface.get_size()}, "
                             f"the sink was opened for {self.frame_size}")
        try:
            self._write_frame(self._padded(surface))
        except BaseException:
            self.abort()
            raise
        self.frames += 1

    def close(self) -> None:
        """Finish the output and move it onto ``path`` (idempotent)."""
        if self.closed:
            return
        try:
            self._finish()
        except BaseException:
            self.abort()
            raise
        self.closed = True

    def abort(self) -> None:
        """Stop and delete everything written so far (idempotent; signals wait for it)."""
        if not self.closed:
            self.closed = True
            with deferred():
                self._discard()

    def __enter__(self) -> Self:
        return self

    def __exit__(self, kind: type[BaseException] | None, value: BaseException | None,
                 traceback: TracebackType | None) -> None:
        if kind is None:
            self.close()
        else:
            self.abort()

    def _padded(self, surface: pygame.Surface) -> pygame.Surface:
        """``surface`` itself if its size is even, else a copy with the last column and/or
        row repeated."""
        w, h = surface.get_size()
        if (w, h) == self.size:
            return surface
        out = pygame.Surface(self.size)
        out.blit(surface, (0, 0))
        if w % 2:
            out.blit(surface, (w, 0), pygame.Rect(w - 1, 0, 1, h))
        if h % 2:
            out.blit(out.subsurface(pygame.Rect(0, h - 1, self.size[0], 1)).copy(), (0, h))
        return out

    def _write_frame(self, surface: pygame.Surface) -> None:
        raise NotImplementedError

    def _finish(self) -> None:
        raise NotImplementedError

    def _discard(self) -> None:
        raise NotImplementedError


class VideoSink(FrameSink):
    """``.mp4`` (H.264, yuv420p) or ``.gif`` through imageio-ffmpeg's bundled ffmpeg.

    Raw RGB frames are piped to one ffmpeg process that writes a hidden temporary
    file next to ``path``; ``close()`` waits for ffmpeg and renames the file. An
    ffmpeg failure raises ``RuntimeError`` with ffmpeg's last message line.
    """

    def __init__(self, path: str | os.PathLike, size: tuple[int, int], fps: float):
        super().__init__(path, size, fps)
        import imageio_ffmpeg

        self.format = self.path.suffix.lower()[1:]
        self.frame_step = math.ceil(fps / GIF_MAX_FPS) if self.format == "gif" else 1
        rate = Fraction(fps).limit_denominator(1001) / self.frame_step
        if self.format == "mp4":
            output = ["-c:v", "libx264", "-pix_fmt", "yuv420p", "-preset", "veryfast",
                      "-crf", "20", "-movflags", "+faststart", "-f", "mp4"]
        else:
            output = ["-filter_complex",
                      "split[a][b];[a]palettegen=stats_mode=single[p];[b][p]paletteuse=new=1",
                      "-f", "gif"]
        w, h = self.size
        executable = imageio_ffmpeg.get_ffmpeg_exe()
        self._temporary: Path | None = None
        self._process: subprocess.Popen | None = None
        self._log = tempfile.TemporaryFile()  # noqa: SIM115  (ffmpeg writes it until close)
        try:
            with deferred():         # the file and the process exist only once recorded
                handle, temporary = tempfile.mkstemp(prefix=f".{self.path.name}.",
                                                     suffix=".partial", dir=self.path.parent)
                os.close(handle)
                self._temporary = Path(temporary)
                command = [executable, "-y", "-loglevel", "error", "-nostdin", "-f",
                           "rawvideo", "-pix_fmt", "rgb24", "-s", f"{w}x{h}", "-r",
                           str(rate), "-i", "-", "-an", *output, str(self._temporary)]
                self._process = subprocess.Popen(command, stdin=subprocess.PIPE,
                                                 stdout=subprocess.DEVNULL, stderr=self._log,
                                                 start_new_session=True)
        except BaseException:
            self.abort()
            raise
        self._received = 0

    def _write_frame(self, surface: pygame.Surface) -> None:
        self._received += 1
        if (self._received - 1) % self.frame_step:
            return
        try:
            self._process.stdin.write(pygame.image.tobytes(surface, "RGB"))
        except (BrokenPipeError, OSError):
            self._process.wait()
            raise RuntimeError(self._failure()) from None

    @property
    def frames_written(self) -> int:
        """Frames in the output: every ``frame_step``-th frame received."""
        return -(-self._received // self.frame_step)

    @property
    def fps_written(self) -> float:
        """Frame rate of the output: ``fps / frame_step``, frames/s."""
        return self.fps / self.frame_step

    def _finish(self) -> None:
        self._process.stdin.close()
        status = self._process.wait()
        if self._received == 0:
            raise RuntimeError(f"{self.path}: no frames were written")
        if status != 0:
            raise RuntimeError(self._failure())
        with deferred():
            _public(self._temporary, 0o666)
            os.replace(self._temporary, self.path)
            self._temporary = None
        self._log.close()

    def _discard(self) -> None:
        process = self._process
        if process is not None:
            if process.poll() is None:
                process.kill()
            process.wait()
            if process.stdin and not process.stdin.closed:
                try:
                    process.stdin.close()
                except OSError:
                    pass
        if self._temporary is not None:
            self._temporary.unlink(missing_ok=True)
        self._log.close()

    def _failure(self) -> str:
        self._log.seek(0)
        lines = self._log.read().decode(errors="replace").strip().splitlines()
        last = lines[-1] if lines else "no message"
        return f"{self.path}: ffmpeg failed (exit {self._process.returncode}): {last}"


class PngFolderSink(FrameSink):
    """A directory of ``frame_00000.png``, ``frame_00001.png``, ... (one per ``write``).

    Frames go to a hidden temporary directory next to ``path``, renamed onto it by
    ``close()``. An existing ``path`` must be a directory holding only frame files
    (from an earlier run); it is replaced.
    """

    def __init__(self, path: str | os.PathLike, size: tuple[int, int], fps: float):
        super().__init__(Path(path), size, fps)
        if self.path.exists():
            if not self.path.is_dir():
                raise SpecError("", "exists and is not a directory", str(path))
            others = [p.name for p in self.path.iterdir() if not _FRAME_NAME.fullmatch(p.name)]
            if others:
                raise SpecError("", f"directory holds other files than frames "
                                f"(e.g. {others[0]!r}); choose an empty or new directory",
                                str(path))
        self._temporary: Path | None = None
        try:
            with deferred():
                self._temporary = Path(tempfile.mkdtemp(prefix=f".{self.path.name}.",
                                                        suffix=".partial",
                                                        dir=self.path.parent))
        except BaseException:
            self.abort()
            raise

    def _write_frame(self, surface: pygame.Surface) -> None:
        pygame.image.save(surface, str(self._temporary / f"frame_{self.frames:05d}.png"))

    def _finish(self) -> None:
        with deferred():
            if self.path.exists():
                for old in self.path.iterdir():
                    if _FRAME_NAME.fullmatch(old.name):
                        old.unlink()
                self.path.rmdir()
            _public(self._temporary, 0o777)
            os.replace(self._temporary, self.path)
            self._temporary = None

    def _discard(self) -> None:
        if self._temporary is not None:
            shutil.rmtree(self._temporary, ignore_errors=True)


def _public(path: Path, mode: int) -> None:
    """Give ``path`` (created private by ``tempfile``) the permissions of a new file."""
    umask = os.umask(0)
    os.umask(umask)
    path.chmod(mode & ~umask)


def output_error(text: str) -> str | None:
    """Why the command line refuses ``-o text``, or None: a name with another extension
    than .mp4 or .gif, or none without a trailing ``/`` (``-o movie`` is more likely a
    forgotten ``.mp4`` than a folder) that is not an existing directory."""
    target = Path(text)
    if text.endswith(("/", os.sep)) or target.is_dir():
        return None
    suffix = target.suffix.lower()
    if suffix in (".mp4", ".gif"):
        return None
    what = f"unsupported output type {suffix!r}" if suffix else "no output type"
    return f"{what}: use .mp4, .gif or a directory (a path ending in '/') for PNG frames"


def open_sink(path: str | os.PathLike, size: tuple[int, int], fps: float) -> FrameSink:
    """The sink for ``path``: ``.mp4``, ``.gif``, or a directory of PNG frames (a path
    ending in ``/``, an existing directory, or a path without an extension).

    ``size`` is the frame (width, height) in pixels, ``fps`` frames per second.
    Any other extension raises ``SpecError`` (one line, naming the path).
    """
    text = os.fspath(path)
    target = Path(text)
    if text.endswith(("/", os.sep)) or target.is_dir() or not target.suffix:
        return PngFolderSink(target, size, fps)
    suffix = target.suffix.lower()
    if suffix in (".mp4", ".gif"):
        return VideoSink(target, size, fps)
    raise SpecError("", output_error(text), text)

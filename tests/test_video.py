"""Frame sinks: frame counts, even sizes, and nothing half-written on failure."""

import os

import imageio_ffmpeg
import numpy as np
import pytest

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
import pygame

from sdfphys.errors import SpecError
from sdfphys.video import GIF_MAX_FPS, PngFolderSink, VideoSink, even_size, open_sink


def frame(size, k):
    """A frame whose colour encodes ``k``, with a marker in the last column and row."""
    surface = pygame.Surface(size)
    surface.fill((10 * k % 256, 80, 160))
    surface.fill((250, 20, 20), pygame.Rect(size[0] - 1, 0, 1, size[1]))
    surface.fill((20, 250, 20), pygame.Rect(0, size[1] - 1, size[0], 1))
    return surface


def write(path, size, fps, count):
    with open_sink(path, size, fps) as sink:
        for k in range(count):
            sink.write(frame(size, k))
    return sink


def video_size(path):
    reader = imageio_ffmpeg.read_frames(str(path))
    meta = next(reader)
    reader.close()
    return tuple(meta["size"])


def leftovers(directory):
    return sorted(p.name for p in directory.iterdir() if p.name.startswith("."))


def test_even_size_rounds_odd_components_up():
    assert even_size((961, 540)) == (962, 540)
    assert even_size((4, 7)) == (4, 8)


def test_mp4_has_every_frame(tmp_path):
    path = tmp_path / "out.mp4"
    sink = write(path, (64, 48), 30, 17)
    assert isinstance(sink, VideoSink) and sink.frames == 17
    frames, seconds = imageio_ffmpeg.count_frames_and_secs(str(path))
    assert frames == 17
    assert seconds == pytest.approx(17 / 30, abs=0.05)
    assert video_size(path) == (64, 48)
    assert leftovers(tmp_path) == []


def test_mp4_odd_size_is_made_even(tmp_path):
    path = tmp_path / "odd.mp4"
    sink = write(path, (33, 21), 24, 5)
    assert sink.size == (34, 22) and sink.frame_size == (33, 21)
    assert video_size(path) == (34, 22)
    assert imageio_ffmpeg.count_frames_and_secs(str(path))[0] == 5


def test_mp4_is_h264_yuv420p(tmp_path):
    path = tmp_path / "out.mp4"
    write(path, (32, 32), 30, 3)
    reader = imageio_ffmpeg.read_frames(str(path))
    meta = next(reader)
    reader.close()
    assert meta["codec"] == "h264"
    assert meta["pix_fmt"].startswith("yuv420p")


def test_gif_has_every_frame_up_to_50_fps(tmp_path):
    path = tmp_path / "out.gif"
    write(path, (40, 30), 25, 12)
    assert imageio_ffmpeg.count_frames_and_secs(str(path))[0] == 12
    assert video_size(path) == (40, 30)


def test_gif_above_50_fps_keeps_every_kth_frame(tmp_path):
    path = tmp_path / "fast.gif"
    sink = write(path, (40, 30), 60, 12)
    assert sink.frame_step == 2 and 60 / sink.frame_step <= GIF_MAX_FPS
    frames, seconds = imageio_ffmpeg.count_frames_and_secs(str(path))
    assert frames == 6
    assert seconds == pytest.approx(12 / 60, abs=0.05)


def test_png_folder_numbered_frames_padded_to_even(tmp_path):
    path = tmp_path / "frames"
    sink = write(str(path) + "/", (7, 5), 30, 3)
    assert isinstance(sink, PngFolderSink)
    assert sorted(p.name for p in path.iterdir()) == [
        "frame_00000.png", "frame_00001.png", "frame_00002.png"]
    image = pygame.surfarray.array3d(pygame.image.load(str(path / "frame_00002.png")))
    assert image.shape == (8, 6, 3)
    assert tuple(image[0, 0]) == (20, 80, 160)                 # frame 2's colour
    np.testing.assert_array_equal(image[7], image[6])          # last column repeated
    np.testing.assert_array_equal(image[:, 5], image[:, 4])    # last row repeated
    assert leftovers(tmp_path) == []


def test_png_folder_replaces_earlier_frames_but_not_other_files(tmp_path):
    path = tmp_path / "frames"
    write(path, (4, 4), 30, 3)
    write(path, (4, 4), 30, 2)
    assert sorted(p.name for p in path.iterdir()) == ["frame_00000.png", "frame_00001.png"]
    (path / "notes.txt").write_text("mine")
    with pytest.raises(SpecError, match="other files"):
        open_sink(path, (4, 4), 30)
    assert (path / "notes.txt").read_text() == "mine"


def test_unsupported_extension_is_one_clear_line(tmp_path):
    with pytest.raises(SpecError) as info:
        open_sink(tmp_path / "out.avi", (10, 10), 30)
    message = str(info.value)
    assert "\n" not in message and "out.avi" in message and ".mp4" in message
    assert list(tmp_path.iterdir()) == []


def test_gif_reports_the_frames_and_rate_it_wrote(tmp_path):
    sink = write(tmp_path / "out.gif", (16, 16), 60, 13)
    assert (sink.frames, sink.frames_written, sink.fps_written) == (13, 7, 30)
    frames, _ = imageio_ffmpeg.count_frames_and_secs(str(tmp_path / "out.gif"))
    assert frames == 7
    sink = write(tmp_path / "out.mp4", (16, 16), 60, 13)
    assert (sink.frames_written, sink.fps_written) == (13, 60)


def test_missing_parent_directory_is_reported(tmp_path):
    with pytest.raises(SpecError, match="no such directory"):
        open_sink(tmp_path / "nowhere" / "out.mp4", (10, 10), 30)


@pytest.mark.parametrize("name", ["out.mp4", "out.gif", "frames/"])
def test_exception_inside_with_leaves_nothing(tmp_path, name):
    with pytest.raises(KeyError), open_sink(tmp_path / name, (16, 16), 30) as sink:
        sink.write(frame((16, 16), 0))
        raise KeyError("boom")
    assert list(tmp_path.iterdir()) == []


def test_failure_keeps_the_earlier_output(tmp_path):
    path = tmp_path / "out.mp4"
    write(path, (16, 16), 30, 4)
    before = path.read_bytes()
    with pytest.raises(RuntimeError), open_sink(path, (16, 16), 30) as sink:
        sink.write(frame((16, 16), 0))
        raise RuntimeError("simulation blew up")
    assert path.read_bytes() == before
    assert leftovers(tmp_path) == []


def test_encoder_death_raises_and_cleans_up(tmp_path):
    path = tmp_path / "out.mp4"
    sink = open_sink(path, (16, 16), 30)
    sink.write(frame((16, 16), 0))
    sink._process.kill()
    sink._process.wait()
    with pytest.raises(RuntimeError, match="ffmpeg failed"):
        for k in range(50):      # the pipe may buffer a few frames before it breaks
            sink.write(frame((16, 16), k))
        sink.close()
    assert list(tmp_path.iterdir()) == []


def test_wrong_frame_size_aborts(tmp_path):
    with (pytest.raises(ValueError, match="opened for"),
          open_sink(tmp_path / "out.mp4", (16, 16), 30) as sink):
        sink.write(pygame.Surface((20, 16)))
    assert list(tmp_path.iterdir()) == []


def test_closed_sink_refuses_frames(tmp_path):
    sink = write(tmp_path / "f", (4, 4), 30, 1)
    with pytest.raises(ValueError, match="closed"):
        sink.write(frame((4, 4), 0))


def test_zero_frames_is_an_error_and_leaves_nothing(tmp_path):
    with pytest.raises(RuntimeError, match="no frames"):
        open_sink(tmp_path / "out.mp4", (16, 16), 30).close()
    assert list(tmp_path.iterdir()) == []

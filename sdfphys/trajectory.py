"""Trajectories: record a scene's body states step by step, save, load, compare.

A trajectory file is an ``.npz`` (DESIGN.md contract), one frame per step, frame 0
the initial state, bodies in scene order, then the bodies added during the run (the
pieces a carve cuts off a dynamic body, ``sdfphys.pieces``) in the order they appeared,
their values NaN in the frames before; a body removed during the run (carved to
nothing) is NaN in the frames after:

    t                 (F,)      s, frame k at k * dt
    position          (F, B, 2) m, each body's user frame origin
    angle             (F, B)    rad, counter-clockwise
    velocity          (F, B, 2) m/s, of the centre of mass
    angular_velocity  (F, B)    rad/s, counter-clockwise
    name              (B,)      unicode body names
    meta              ()        a JSON string: scene (the path recorded), scene_digest
                                (``Scene.digest``), overrides and quality (as given to
                                ``read_scene``), settings, sdfphys_version,
                                numpy_version, seconds, steps (F = steps + 1)

Replaying the same scene with the same settings on the same machine is bit-identical
(tests/test_golden.py checks it across processes; one known exception: SDF bodies'
mass properties depend in their last bits on the number of BLAS threads, see
BLAS_THREAD_DEPENDENT there). ``compare`` measures the worst deviation against
per-quantity tolerances that absorb another machine's floating-point differences
(libm, SIMD width, BLAS) over the short horizons of regression tests.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import tempfile
import zipfile
import zlib
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from . import __version__
from .errors import SpecError
from .interrupt import check as check_interrupt
from .interrupt import deferred
from .limits import check_steps
from .scene import read_scene

__all__ = ["QUANTITIES", "TOLERANCES", "Deviation", "Trajectory", "compare", "load",
           "match_bodies", "record"]

#: The compared quantities, their unit, and their trailing shape after (F, B).
QUANTITIES: dict[str, tuple[str, tuple[int, ...]]] = {
    "position": ("m", (2,)),
    "angle": ("rad", ()),
    "velocity": ("m/s", (2,)),
    "angular_velocity": ("rad/s", ()),
}

#: Default tolerances of ``compare``: the largest accepted deviation per quantity
#: (Euclidean norm of the difference for vectors). A replay on the recording machine
#: deviates by exactly 0; these absorb the last-bit differences of other machines as
#: contacts amplify them over a short horizon, and stay far below anything visible
#: (a nanometre, a nanoradian). Velocities get 10x: a velocity difference dv moves a
#: body by only h dv in a substep of h seconds, so velocities differ more than poses.
TOLERANCES: dict[str, float] = {
    "position": 1e-9,
    "angle": 1e-9,
    "velocity": 1e-8,
    "angular_velocity": 1e-8,
}

_META_TYPES: dict[str, tuple[type, ...]] = {
    "scene": (str,),
    "scene_digest": (str,),
    "overrides": (list,),
    "quality": (str, type(None)),
    "settings": (dict,),
    "sdfphys_version": (str,),
    "numpy_version": (str,),
    "seconds": (int, float),
    "steps": (int,),
}


@dataclass(frozen=True)
class Trajectory:
    """Body states of one recorded run (shapes in the module docstring)."""

    t: np.ndarray
    position: np.ndarray
    angle: np.ndarray
    velocity: np.ndarray
    angular_velocity: np.ndarray
    name: np.ndarray
    meta: dict[str, Any]

    @property
    def frames(self) -> int:
        """F: the number of frames (steps + 1)."""
        return len(self.t)

    @property
    def bodies(self) -> int:
        """B: the number of bodies."""
        return len(self.name)

    def arrays(self) -> dict[str, np.ndarray]:
        """The numeric arrays and names by file key (``meta`` excluded)."""
        return {key: getattr(self, key) for key in ("t", *QUANTITIES, "name")}

    def save(self, path: str | os.PathLike) -> None:
        """Write the ``.npz`` atomically: a hidden temporary file next to ``path``,
        renamed onto it once complete (nothing half-written is ever at ``path``)."""
        target = Path(path)
        temporary = None
        try:
            with deferred():     # a signal never comes between creating and naming it
                handle, temporary = tempfile.mkstemp(prefix=f".{target.name}.",
                                                     suffix=".partial", dir=target.parent)
            with os.fdopen(handle, "wb") as stream:
                np.savez_compressed(stream, **self.arrays(),
                                    meta=np.array(json.dumps(self.meta, sort_keys=True)))
            umask = os.umask(0)
            os.umask(umask)
            os.chmod(temporary, 0o666 & ~umask)
            with deferred():
                os.replace(temporary, target)
                temporary = None
        except BaseException:
            if temporary is not None:
                with deferred():
                    Path(temporary).unlink(missing_ok=True)
            raise


def record(scene: str | os.PathLike | Mapping, seconds: float | None = None,
           overrides: Sequence[str] = (), quality: str | None = None, *,
           max_steps: int | None = None,
           progress: Callable[[int], None] | None = None) -> Trajectory:
    """Simulate a scene and return every step's body states.

    scene: a scene file path or a dict shaped like one; overrides (``KEY=VALUE``) and
    quality are applied as by ``read_scene`` and stored in ``meta`` so that a check
    can rebuild the same scene. seconds: simulated time (default: the scene's
    ``sim.duration``); steps = max(1, round(seconds / dt)), at most ``max_steps``
    (default ``limits.MAX_STEPS``; the frames are kept in memory). progress: called
    with the number of steps done after each step. Bad scenes raise SpecError.
    """
    parsed = read_scene(scene, overrides, quality=quality)
    seconds = parsed.duration if seconds is None else seconds
    if not (isinstance(seconds, (int, float)) and math.isfinite(seconds) and seconds > 0):
        raise ValueError(f"seconds must be a positive number, got {seconds!r}")
    steps = max(1, round(seconds / parsed.settings.dt))
    check_steps(steps, "steps", max_steps)
    world = parsed.build()
    # A column per body ever seen, by creation number (uid): the scene's bodies, then
    # those added during the run (a carved body's pieces), NaN while a body is absent.
    seen = world._view("uid").copy()
    names = list(world.names)
    arrays = {key: np.full((steps + 1, len(seen), *tail), np.nan)
              for key, (_, tail) in QUANTITIES.items()}
    for k in range(steps + 1):
        if k:
            world.step()
            check_interrupt()
            if progress is not None:
                progress(k)
        uid = world._view("uid")
        new = np.flatnonzero(uid > seen[-1]) if len(seen) else np.arange(len(uid))
        if len(new):
            seen = np.concatenate([seen, uid[new]])
            names += [world.names[i] for i in new]
            for key, array in arrays.items():
                grown = np.full((steps + 1, len(new), *array.shape[2:]), np.nan)
                arrays[key] = np.concatenate([array, grown], axis=1)
        column = np.searchsorted(seen, uid)
        for key in arrays:
            arrays[key][k, column] = getattr(world, key)
    meta = {
        "scene": parsed.source,
        "scene_digest": parsed.digest,
        "overrides": list(overrides),
        "quality": quality,
        "settings": dataclasses.asdict(parsed.settings),
        "sdfphys_version": __version__,
        "numpy_version": np.__version__,
        "seconds": float(seconds),
        "steps": steps,
    }
    return Trajectory(np.arange(steps + 1) * parsed.settings.dt, arrays["position"],
                      arrays["angle"], arrays["velocity"], arrays["angular_velocity"],
                      np.array(names, dtype=str), meta)


def load(path: str | os.PathLike) -> Trajectory:
    """Read and validate a trajectory file (never unpickles).

    Every problem (missing or unreadable file, not an ``.npz``, a missing or unknown
    array, a wrong dtype or shape, bad ``meta``) raises one SpecError naming the file
    and the array: ``x.npz: position: must have shape (F, B, 2) = (31, 4, 2), got (31, 4)``.
    """
    source = os.fspath(path)
    try:
        with open(source, "rb") as stream:
            if stream.read(4) != b"PK\x03\x04":
                raise SpecError("", "not a trajectory file (.npz): not a zip archive", source)
        with np.load(source, allow_pickle=False) as archive:
            data = {key: _member(archive, key, source) for key in archive.files}
    except SpecError:
        raise
    except FileNotFoundError:
        raise SpecError("", "no such trajectory file", source) from None
    except IsADirectoryError:
        raise SpecError("", "is a directory, not a trajectory file", source) from None
    except (OSError, ValueError, EOFError, zipfile.BadZipFile) as err:
        raise SpecError("", f"not a readable trajectory file (.npz): {_reason(err)}",
                        source) from None
    try:
        return _validated(data)
    except SpecError as err:
        raise err.in_file(source) from None


def _member(archive: np.lib.npyio.NpzFile, key: str, source: str) -> np.ndarray:
    """One array of the archive; a corrupt or pickled member raises SpecError naming it."""
    try:
        return archive[key]
    except (OSError, ValueError, EOFError, zipfile.BadZipFile, zlib.error) as err:
        raise SpecError(key, f"cannot be read: {_reason(err)}", source) from None


def _reason(err: BaseException) -> str:
    """An exception's message on one line (its type name if it has none)."""
    return " ".join(str(err).split()) or type(err).__name__


def _validated(data: dict[str, np.ndarray]) -> Trajectory:
    expected = ("t", *QUANTITIES, "name", "meta")
    for key in data:
        if key not in expected:
            raise SpecError(key, "unknown array in a trajectory file")
    for key in expected:
        if key not in data:
            raise SpecError(key, "missing array")
    meta = _meta(data["meta"])
    t, name = data["t"], data["name"]
    if t.dtype != np.float64 or t.ndim != 1:
        raise SpecError("t", f"must be float64 of shape (F,), got {t.dtype} {t.shape}")
    if name.dtype.kind != "U" or name.ndim != 1 or len(name) == 0:
        raise SpecError("name", f"must be a non-empty unicode array of shape (B,), "
                        f"got {name.dtype} {name.shape}")
    frames, bodies = len(t), len(name)
    if frames != meta["steps"] + 1:
        raise SpecError("t", f"has {frames} frames, meta.steps = {meta['steps']} needs "
                        f"{meta['steps'] + 1}")
    for key, (_, tail) in QUANTITIES.items():
        array = data[key]
        want = (frames, bodies, *tail)
        if array.dtype != np.float64:
            raise SpecError(key, f"must be float64, got {array.dtype}")
        if array.shape != want:
            letters = ", ".join(("F", "B", *map(str, tail)))
            raise SpecError(key, f"must have shape ({letters}) = {want}, got {array.shape}")
    return Trajectory(t, data["position"], data["angle"], data["velocity"],
                      data["angular_velocity"], name, meta)


def _meta(array: np.ndarray) -> dict[str, Any]:
    if array.dtype.kind != "U" or array.shape != ():
        raise SpecError("meta", f"must be a JSON string, got {array.dtype} {array.shape}")
    try:
        meta = json.loads(str(array))
    except json.JSONDecodeError as err:
        raise SpecError("meta", f"not valid JSON: {err}") from None
    if not isinstance(meta, dict):
        raise SpecError("meta", f"must be a JSON object, got {type(meta).__name__}")
    for key, types in _META_TYPES.items():
        if key not in meta:
            raise SpecError(f"meta.{key}", "is missing")
        value = meta[key]
        if not isinstance(value, types) or isinstance(value, bool):
            raise SpecError(f"meta.{key}", f"has the wrong type: {value!r}")
    if meta["steps"] < 1 or not meta["seconds"] > 0:
        raise SpecError("meta", f"steps {meta['steps']} and seconds {meta['seconds']} "
                        "must be positive")
    if not all(isinstance(item, str) for item in meta["overrides"]):
        raise SpecError("meta.overrides", f"must be KEY=VALUE strings, got {meta['overrides']!r}")
    return meta


@dataclass(frozen=True)
class Deviation:
    """The worst deviation of a replay from a reference, relative to its tolerance.

    quantity: a key of QUANTITIES; body: index (scene order) and name; frame: index
    and time t (s); value: |replay - reference| (Euclidean norm for vectors, in the
    quantity's unit; inf where exactly one of the two is NaN); tolerance: the one
    that applied. ``identical``: every array bit-for-bit equal.
    """

    quantity: str
    body: int
    name: str
    frame: int
    time: float
    value: float
    tolerance: float
    identical: bool

    @property
    def ok(self) -> bool:
        """Whether the deviation is within its tolerance."""
        return self.value <= self.tolerance

    def __str__(self) -> str:
        unit = QUANTITIES[self.quantity][0]
        if self.identical:
            return "bit-identical: every frame of every body equals the recording"
        verdict = "within" if self.ok else "exceeds"
        return (f"worst deviation: {self.quantity} of body {self.body} {self.name!r} at "
                f"frame {self.frame} (t = {self.time:.6f} s): {self.value:.3e} {unit} "
                f"{verdict} the tolerance {self.tolerance:.1e} {unit}")


def compare(reference: Trajectory, replay: Trajectory,
            tolerances: Mapping[str, float] | None = None) -> Deviation:
    """The worst deviation of ``replay`` from ``reference`` over every frame and body.

    "Worst" is the largest ratio deviation / tolerance across the quantities of
    QUANTITIES; ``tolerances`` overrides the TOLERANCES defaults per quantity.
    Trajectories of different bodies (count, names or order) or frame counts raise
    SpecError: they are not two runs of one scene.
    """
    limits = dict(TOLERANCES)
    for key, value in (tolerances or {}).items():
        if key not in limits:
            raise ValueError(f"unknown quantity {key!r}; expected one of {', '.join(limits)}")
        if not (math.isfinite(value) and value >= 0):
            raise ValueError(f"tolerance of {key} must be finite and >= 0, got {value}")
        limits[key] = value
    match_bodies(reference.name, replay.name)
    if reference.frames != replay.frames:
        raise SpecError("t", f"{reference.frames} frames recorded, {replay.frames} replayed")

    identical = all(np.array_equal(getattr(reference, key), getattr(replay, key), equal_nan=True)
                    for key in ("t", *QUANTITIES))
    worst: Deviation | None = None
    for key, (_, tail) in QUANTITIES.items():
        deviation = _deviation(getattr(reference, key), getattr(replay, key), len(tail))
        frame, body = np.unravel_index(int(np.argmax(deviation)), deviation.shape)
        value = float(deviation[frame, body])
        candidate = Deviation(key, int(body), str(reference.name[body]), int(frame),
                              float(reference.t[frame]), value, limits[key], identical)
        if worst is None or _ratio(candidate) > _ratio(worst):
            worst = candidate
    return worst


def match_bodies(recorded: Sequence[str], replayed: Sequence[str],
                 appended: bool = False) -> None:
    """Raise SpecError unless the two body name lists are equal (count, names, order).
    appended: ``replayed`` are a scene's bodies, which ``recorded`` may follow with the
    bodies added during its run (the pieces of a carve)."""
    if len(recorded) != len(replayed) and not (appended and len(recorded) > len(replayed)):
        raise SpecError("name", f"{len(recorded)} bodies recorded, the scene has "
                        f"{len(replayed)}")
    for index, (a, b) in enumerate(zip(recorded, replayed)):
        if a != b:
            raise SpecError(f"name[{index}]", f"body {str(a)!r} recorded, the scene has "
                            f"{str(b)!r}")


def _deviation(a: np.ndarray, b: np.ndarray, vector: int) -> np.ndarray:
    """(F, B) |a - b|, the norm over a trailing (2,) axis if ``vector``; equal values
    (NaN equal to NaN) deviate by 0, and a NaN against a number by inf."""
    same = (a == b) | (np.isnan(a) & np.isnan(b))
    with np.errstate(invalid="ignore", over="ignore"):
        difference = np.where(same, 0.0, np.abs(a - b))
        if vector:
            difference = np.hypot(difference[..., 0], difference[..., 1])
    return np.where(np.isnan(difference), np.inf, difference)


def _ratio(d: Deviation) -> float:
    if d.value == 0.0:
        return 0.0
    return d.value / d.tolerance if d.tolerance > 0 else math.inf

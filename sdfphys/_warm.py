"""A second process compiles half of a cold first step's kernels while the first compiles the rest.

Numba compiles one kernel at a time under a process-wide lock, so a cold start is
serial: the field evaluator for the first frame, the collision kernels (most of them
for fields: the descents), then the solver's. On a machine with two cores or more, the
first world a process steps or simulates forks a child (``start``) when the solver's
kernels are not yet in the on-disk cache. The child works through the first step's
kernels from the other end (``world_stages.compile_ahead``: the substep kernel, the
collisions' pair groups that are no closed form in the reverse of their order in a step,
then the other stages after the contact rows' preparation, last stage first), calling
them on its copy of the world with the same argument types, which compiles them into the
same cache, and exits. The parent goes on as without it. Each kernel is compiled once: a
process that reaches a kernel the other is compiling waits for it and loads it
(``sdfphys._compile_lock``), so the two meet somewhere in the middle; while the parent
waits it compiles its step's last stages (``world_stages.compile_behind``, run by
``_compile_lock.while_waiting``). At the end of its first step the parent has
everything that step needed; the child goes on with what later steps may call
(``compile_ahead``: the field evaluator where fields will be evaluated, the pairs that
meet later, the stages of the steps after the first) and exits when done, or when the
parent exits (``stop``, at exit), and the parent keeps its jobs for its later waits:
a scene whose bodies meet after the first step no longer compiles their contacts in
one process. The trajectory is the same either way, only the wait shorter.

The child writes nothing but cache files: its standard streams go to the null device,
it closes every other inherited descriptor (a video encoder's pipe must see its end of
file when the parent closes it), takes the default action on SIGINT, leaves on SIGTERM
by unwinding (a kernel it was compiling releases its lock and leaves no temporary file
behind), ends itself after CHILD_SECONDS, keeps the compile notice quiet, and exits with
``os._exit`` (no atexit handler, no flush of the parent's buffers). ``SDFPHYS_WARM=0``
in the environment turns it off.
"""

from __future__ import annotations

import atexit
import os
import pickle
import signal
import threading
from collections.abc import Callable
from typing import Any

import numpy as np

__all__ = ["CHILD_SECONDS", "STOP_SECONDS", "placeholder_world", "start", "start_early", "stop"]

_started = False
#: Whether the parent's own share (``start``) has been handed to ``_compile_lock``.
_behind = False
#: The child's pid while it may run (``stop``).
_child: int | None = None
#: Set while no child runs.
_done = threading.Event()
_done.set()
#: The child ends itself after this long whatever it is doing (SIGALRM's default
#: action): a lock another thread of the parent held at the fork cannot keep it alive.
CHILD_SECONDS = 900
#: How long ``stop`` waits for the child to unwind after SIGTERM.
STOP_SECONDS = 30.0


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
    While a child runs (this one, or ``start_early``'s), the parent's own share: the
    step's last stages, compiled whenever it would wait for a kernel the child holds
    (``world_stages.compile_behind``). Returns the child's pid (None: no child)."""
    global _behind
    pid = _fork(lambda: world, early=False)
    if _child is not None and not _done.is_set() and not _behind:
        from . import _compile_lock
        from .world_stages import compile_behind

        _behind = True
        _compile_lock.while_waiting(compile_behind(world))
    return pid


def start_early(scene: Any) -> int | None:
    """Fork the compiling child before ``scene`` builds its world, when some of its SDF
    bodies will integrate their mass properties then (``start``'s conditions apply).

    That quadrature evaluates the fields, so the parent compiles the field evaluator
    (``sdf.compiled.run`` and its primitive kernels, about 8 s) while it builds the
    world, before ``start`` would fork. The child builds its own world with placeholder
    masses (``placeholder_world``) and compiles ahead as ``start``'s does, while the
    parent compiles the evaluator."""
    from .shapes import SdfShape

    if not any(isinstance(b.shape, SdfShape) and b.shape.bounded
               and "_mass" not in b.shape.__dict__ for b in scene.bodies):
        return None
    return _fork(lambda: placeholder_world(scene), early=True)


def placeholder_world(scene: Any) -> Any:
    """``scene``'s world with no field evaluated: its SDF shapes' mass properties and its
    SDF and mesh shapes' core radii set from their bounds' boxes (the kernels' argument
    types are the same; their values do not matter to the compiling child). The values
    stay on the scene's shapes, which equal specs share: only for a process that
    leaves after (the child)."""
    from .shapes import SdfShape, TriangleMesh

    for shape in {id(b.shape): b.shape for b in scene.bodies}.values():
        if isinstance(shape, SdfShape) and shape.bounded and "_mass" not in shape.__dict__:
            x0, y0, x1, y1 = shape._user_bounds
            w, h = x1 - x0, y1 - y0
            shape.__dict__["_mass"] = (w * h, np.array([0.5 * (x0 + x1), 0.5 * (y0 + y1)]),
                                       w * h * (w * w + h * h) / 12.0)
        if isinstance(shape, (SdfShape, TriangleMesh)) and shape.bounded:
            x0, y0, x1, y1 = shape.bounds()
            shape.__dict__["core_radius"] = 0.5 * min(x1 - x0, y1 - y0)
    return scene.build()


def _fork(make_world: Callable[[], Any], early: bool) -> int | None:
    """``start``'s fork: the child compiles ahead for ``make_world()``, its own world
    (early: forked by ``start_early``, the parent compiling the field evaluator); the
    parent stops it at exit (``stop``) if it still runs."""
    global _started, _child
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
            signal.signal(signal.SIGTERM, _leave)
            signal.alarm(CHILD_SECONDS)
            null = os.open(os.devnull, os.O_RDWR)
            for fd in (0, 1, 2):
                os.dup2(null, fd)
            os.closerange(3, 1 << 16)
            os.environ["SDFPHYS_COMPILE_NOTICE"] = "0"
            from .world_stages import compile_ahead

            compile_ahead(make_world(), early)
        finally:
            os._exit(0)
    _child = pid
    _done.clear()
    threading.Thread(target=_reap, args=(pid,), daemon=True).start()
    atexit.register(stop)
    return pid


def _leave(signum: int, frame: Any) -> None:
    """The child's SIGTERM handler: unwind from wherever it is (``start``'s ``finally``
    then exits)."""
    raise SystemExit(0)


def _reap(pid: int) -> None:
    """Wait for the child (no zombie is left), then mark it done."""
    try:
        os.waitpid(pid, 0)
    finally:
        _done.set()


def stop() -> None:
    """The parent, at exit (or whenever it must not leave the child running): ask the
    child (if it still runs) to leave and wait until it has, at most STOP_SECONDS, and
    drop the parent's jobs left (``start``); a kernel the child was compiling is left
    for whoever needs it next."""
    global _child
    if _child is not None and not _done.is_set():
        try:
            os.kill(_child, signal.SIGTERM)
        except OSError:
            pass
        _done.wait(STOP_SECONDS)
    _child = None
    if _behind:
        from . import _compile_lock

        _compile_lock.while_waiting(())

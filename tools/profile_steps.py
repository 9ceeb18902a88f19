"""Where a step's time goes inside numba's kernels: perf's samples, named by kernel.

perf (Linux) samples any process, but the machine code numba makes has no symbols:
its samples show as bare addresses. This tool runs a scene in a process of its own with
numba's cache in a new temporary folder and the cold start's compiling child off
(``SDFPHYS_WARM=0``), so that every kernel is compiled in that process and its LLVM
module is at hand (a kernel loaded from the cache has none). After the warm-up steps it
writes ``/tmp/perf-PID.map``, perf's map of JIT code (start, size and name per line),
naming every function of every sdfphys kernel's library: the kernel, the njit functions
compiled into it that were not inlined, and numba's ``NRT_incref`` / ``NRT_decref``
(the reference counts of arrays, views and structrefs). Then it runs ``perf record -e
cpu-clock`` on itself over the timed steps and prints the top symbols of ``perf
report``. cpu-clock is a software event: no hardware counters are needed. A function's
size in the map is the distance to the next function's start (numba does not say), so
code placed after a library's last function is charged to it.

Reading it: a share for ``NRT_incref`` / ``NRT_decref`` means views or arrays passed
through calls in a loop (docs/performance.md, "2026-11-28, later"); Python's own
symbols (``_PyEval_EvalFrameDefault``, numpy's) are the glue between kernels.

Reference counts by caller (``--refcounts``): perf cannot say who calls NRT_incref /
NRT_decref (numba's code keeps no frame pointers), so gdb counts them. It attaches to
the process, breaks on both functions and on libc's ``getpid``, which the process calls
between two steps, reads each call's return address (the top of the stack: both are
leaves) and looks it up in the map, and detaches after ``--steps`` steps (default 3
with this option: each call stops the process, about 30 us). Printed: the calls a
step, and per function of the map the calls a step its code made. Needs gdb on the
PATH and permission to attach (``/proc/sys/kernel/yama/ptrace_scope`` 0, or root).
Found so: ``polygons.clip_pair``'s 269,100 calls a step of the base-100 pyramid
(docs/performance.md, "2026-11-28, session 26").

Kernels against Python by stage (``--glue``; no perf, no gdb): every sdfphys kernel
called from Python is timed (the outermost call: a kernel's calls of others are
compiled code), and so are the stages ``World.step`` runs (``world_stages``,
``world_sleep``), the predicted contacts (``collide._with_predicted``) and each pair
function by kind (``collide.narrowphase.PAIR_FUNCTIONS``; ``BATCH_FUNCTIONS``: one call
for all the pairs of a kind), each exclusive of the stages it calls. Printed: per stage
its calls, milliseconds a step in all, in kernels and in
Python (the rest: numpy and the interpreter), then the kernels' own table. Python's
share is what batching work into fewer calls can save; a kernel's share is arithmetic
(perf's report) or reference counts (``--refcounts``). Found so: the showcase's 6.3
ms, half of it Python over ~16 pair-function calls a step (docs/performance.md,
"2026-11-28, session 28"). Timers cost about a microsecond a call; the kernels come from
the usual cache.

A phase of a run (``--skip N``): the timed world first runs N steps untimed, so that
``--steps`` times steps N to N + steps (the showcase's tumbling steps 60-150 against
its resting 240-300: docs/performance.md, "2026-11-29, session 33").

Usage: python tools/profile_steps.py SCENE [--steps 300] [--warm 300] [--skip 0] [--top 30]
    [--set KNOB=VALUE ...] [--frequency 4000] [--refcounts | --glue]
SCENE: a ``tools/bench_vs_peers.py`` scene (pile2000, pyramid20, showcase, ...) or a
scene file (``--set`` then sets its [sim] keys). Needs ``perf`` on the PATH and
permission to record the process (``/proc/sys/kernel/perf_event_paranoid`` at most 2);
``--map-only`` writes the map after the warm-up, prints its path and leaves it (for a
``perf record -p`` of your own).
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
_CHILD = "SDFPHYS_PROFILE_STEPS_CHILD"


def short_name(symbol: str) -> str:
    """A readable name for numba's mangled symbol: its module and function
    (``_ZN7sdfphys6solver8substeps6_solveB2v5...`` -> ``sdfphys.solver.substeps._solve``);
    other symbols as they are."""
    match = re.match(r"_ZN(?:7cpython)?((?:\d+[A-Za-z_][A-Za-z_0-9]*)+)", symbol)
    if not match:
        return symbol
    parts, rest = [], match.group(1)
    while rest:
        head = re.match(r"(\d+)", rest)
        if not head:
            break
        size = int(head.group(1))
        start = len(head.group(1))
        parts.append(rest[start:start + size])
        rest = rest[start + size:]
    name = ".".join(parts)
    return "cpython:" + name if symbol.startswith("_ZN7cpython") else name


def map_entries() -> list[tuple[int, str]]:
    """(address, name) of every function defined in the library of every overload of
    every sdfphys kernel compiled in this process, sorted by address."""
    import importlib
    import pkgutil

    from numba.core.registry import CPUDispatcher

    import sdfphys

    entries: set[tuple[int, str]] = set()
    seen: set[int] = set()
    for info in pkgutil.walk_packages(sdfphys.__path__, "sdfphys."):
        if info.name.endswith("__main__"):
            continue
        module = importlib.import_module(info.name)
        for value in vars(module).values():
            if not isinstance(value, CPUDispatcher) or id(value) in seen:
                continue
            seen.add(id(value))
            for result in value.overloads.values():
                library = result.library
                try:
                    functions = [f.name for f in library._final_module.functions
                                 if not f.is_declaration]
                except Exception:                # loaded from a cache: no module
                    continue
                for name in functions:
                    address = library.get_pointer_to_function(name)
                    if address:
                        entries.add((address, short_name(name)))
    return sorted(entries)


def write_map(path: Path, entries: list[tuple[int, str]]) -> None:
    """perf's JIT map: one ``START SIZE NAME`` line (hex) per function, the size up to
    the next function's start (at most 1 MiB)."""
    with open(path, "w") as out:
        for k, (address, name) in enumerate(entries):
            end = entries[k + 1][0] if k + 1 < len(entries) else address + 4096
            out.write(f"{address:x} {min(end - address, 1 << 20):x} {name}\n")


def make_world(scene: str, knobs: list[str]):
    """A fresh world of a bench_vs_peers scene name or a scene file."""
    sys.path.insert(0, str(ROOT / "tools"))
    import bench_vs_peers as bench

    if Path(scene).suffix == ".toml":
        import sdfphys

        return sdfphys.load_scene(scene, [f"sim.{k}" for k in knobs])
    kind, size = bench.parse_scene(scene)
    return bench.sdfphys_world(bench.make_layout(kind, size),
                               bench.sdfphys_settings(knobs, False))


#: gdb's side of ``--refcounts``: counts return addresses into NRT_incref / NRT_decref
#: between step marks (getpid), writes {"steps": n, "calls": {address: count}} as JSON.
_GDB_SCRIPT = """
import gdb, json
incref, decref, mark, steps, out = {args}
state = {{"steps": -1, "calls": {{}}}}


class Count(gdb.Breakpoint):
    def stop(self):
        if state["steps"] >= 0:
            ret = int(gdb.parse_and_eval("*(unsigned long *)$sp"))
            state["calls"][ret] = state["calls"].get(ret, 0) + 1
        return False


class Mark(gdb.Breakpoint):
    def stop(self):
        state["steps"] += 1
        return state["steps"] >= steps


Count("*" + hex(incref))
Count("*" + hex(decref))
Mark("*" + hex(mark))
gdb.execute("continue")
with open(out, "w") as f:
    json.dump({{"steps": state["steps"], "calls": state["calls"]}}, f)
gdb.execute("detach")
"""


def callers(entries: list[tuple[int, str]], calls: dict[int, int]) -> dict[str, int]:
    """Calls per function of the map: each return address charged to the function whose
    start is the last one at or below it (``entries`` sorted by address); addresses
    below every start as ``?``."""
    import bisect

    starts = [address for address, _ in entries]
    total: dict[str, int] = {}
    for address, count in calls.items():
        k = bisect.bisect_right(starts, int(address)) - 1
        name = entries[k][1] if k >= 0 else "?"
        total[name] = total.get(name, 0) + count
    return total


def count_refcounts(world, entries: list[tuple[int, str]], steps: int, top: int) -> int:
    """``--refcounts``: gdb counts NRT_incref / NRT_decref calls by caller over ``steps``
    steps of ``world`` (module docstring)."""
    import ctypes
    import json

    names = {name: address for address, name in entries}
    if "NRT_incref" not in names or "NRT_decref" not in names:
        print("profile_steps: no NRT_incref / NRT_decref in the map", file=sys.stderr)
        return 2
    libc = ctypes.CDLL(None)
    mark = ctypes.cast(libc.getpid, ctypes.c_void_p).value
    with tempfile.TemporaryDirectory(prefix="sdfphys-refcounts-") as folder:
        out = Path(folder) / "calls.json"
        script = Path(folder) / "count.py"
        script.write_text(_GDB_SCRIPT.format(args=repr(
            (names["NRT_incref"], names["NRT_decref"], mark, steps, str(out)))))
        gdb = subprocess.Popen(["gdb", "-p", str(os.getpid()), "-batch", "-nx", "-iex",
                                "set auto-solib-add off", "-x", str(script)],
                               stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        while not out.exists() and gdb.poll() is None:
            libc.getpid()
            world.step()
        _, error = gdb.communicate(timeout=120)
        if not out.exists():
            print(f"profile_steps: gdb counted nothing: {error.strip()[-300:]}",
                  file=sys.stderr)
            return 2
        result = json.loads(out.read_text())
    n = max(result["steps"], 1)
    calls = {int(address): count for address, count in result["calls"].items()}
    print(f"{sum(calls.values()) / n:,.0f} NRT_incref / NRT_decref calls a step "
          f"({n} steps counted)")
    ranked = sorted(callers(entries, calls).items(), key=lambda item: -item[1])
    for name, count in ranked[:top]:
        print(f"{count / n:12,.0f} {name[:100]}")
    return 0


class _Timers:
    """``--glue``'s clocks: the kernels' seconds (outermost calls: ``kernel_total``, and
    per kernel [calls, seconds]) and per stage [calls, seconds, kernel seconds], both
    exclusive of the stages it ran (``open`` holds, per stage running, the seconds and
    kernel seconds of the stages it ran so far)."""

    def __init__(self) -> None:
        self.kernel_total = 0.0
        self.kernels: dict[str, list[float]] = {}
        self.stages: dict[str, list[float]] = {}
        self.inside = 0
        self.open: list[list[float]] = []

    def kernel(self, dispatcher, name: str):
        def call(*args, **kwargs):
            if self.inside:
                return dispatcher(*args, **kwargs)
            self.inside += 1
            start = time.perf_counter()
            try:
                return dispatcher(*args, **kwargs)
            finally:
                spent = time.perf_counter() - start
                self.inside -= 1
                self.kernel_total += spent
                entry = self.kernels.setdefault(name, [0, 0.0])
                entry[0] += 1
                entry[1] += spent
        return call

    def stage(self, function, name: str):
        def call(*args, **kwargs):
            start, kernels = time.perf_counter(), self.kernel_total
            self.open.append([0.0, 0.0])              # nested stages' seconds, kernels
            try:
                return function(*args, **kwargs)
            finally:
                nested, nested_kernels = self.open.pop()
                spent = time.perf_counter() - start
                in_kernels = self.kernel_total - kernels
                entry = self.stages.setdefault(name, [0, 0.0, 0.0])
                entry[0] += 1
                entry[1] += spent - nested
                entry[2] += in_kernels - nested_kernels
                if self.open:
                    self.open[-1][0] += spent
                    self.open[-1][1] += in_kernels
        return call


def install_glue_timers() -> _Timers:
    """Wrap every sdfphys kernel that a module holds (by any name) and the stages
    ``--glue`` reports (module docstring) in ``_Timers``' clocks."""
    from numba.core.registry import CPUDispatcher

    import sdfphys.collide as collide
    import sdfphys.world_sleep as world_sleep
    import sdfphys.world_stages as world_stages
    from sdfphys.collide.narrowphase import BATCH_FUNCTIONS, PAIR_FUNCTIONS

    timers = _Timers()
    wrapped: dict[int, object] = {}
    for name, module in list(sys.modules.items()):
        if module is None or not name.startswith("sdfphys"):
            continue
        for attribute, value in list(vars(module).items()):
            if isinstance(value, CPUDispatcher):
                if id(value) not in wrapped:
                    function = value.py_func
                    wrapped[id(value)] = timers.kernel(
                        value, f"{function.__module__}.{function.__name__}")
                setattr(module, attribute, wrapped[id(value)])
    for module, names in ((world_stages, ("body_state", "collide", "prepare", "substeps",
                                          "restitution", "time_of_impact", "store_impulses",
                                          "record")),
                          (world_sleep, ("active", "wake_reached", "awake", "fall_asleep")),
                          (collide, ("_with_predicted",))):
        for name in names:
            setattr(module, name, timers.stage(getattr(module, name),
                                               f"{module.__name__.split('.')[-1]}.{name}"))
    for kinds, function in list(PAIR_FUNCTIONS.items()):
        PAIR_FUNCTIONS[kinds] = timers.stage(function, "pair " + "-".join(kinds))
    for kinds, function in list(BATCH_FUNCTIONS.items()):
        BATCH_FUNCTIONS[kinds] = timers.stage(function, "batch " + "-".join(kinds))
    return timers


def glue_report(world, steps: int, top: int, scene: str) -> int:
    """``--glue``: ``steps`` steps of ``world`` split into kernels and Python, by stage."""
    timers = install_glue_timers()
    start = time.perf_counter()
    first = round(world.time / world.settings.dt)         # the steps ``--skip`` ran
    for _ in range(steps):
        world.step()
    seconds = time.perf_counter() - start
    n = max(steps, 1)
    ms = 1e3 / n
    print(f"{scene}: {ms * seconds:.3f} ms a step: kernels {ms * timers.kernel_total:.3f}, "
          f"Python {ms * (seconds - timers.kernel_total):.3f} ({steps} steps"
          + (f", from step {first})" if first else ")"))
    print(f"{'stage (exclusive of the stages it runs)':44s} {'calls':>7s} {'ms':>7s} "
          f"{'kernels':>8s} {'Python':>7s}")
    staged = sum(entry[1] for entry in timers.stages.values())
    staged_kernels = sum(entry[2] for entry in timers.stages.values())
    rows = [(name, *entry) for name, entry in timers.stages.items()]
    rows.append(("(the step's own)", n, seconds - staged, timers.kernel_total - staged_kernels))
    for name, calls, spent, kernels in sorted(rows, key=lambda row: -row[2]):
        print(f"{name:44s} {calls / n:7.2f} {ms * spent:7.3f} {ms * kernels:8.3f} "
              f"{ms * (spent - kernels):7.3f}")
    print(f"{'kernel':60s} {'calls':>7s} {'ms':>7s} {'us a call':>10s}")
    for name, (calls, spent) in sorted(timers.kernels.items(), key=lambda kv: -kv[1][1])[:top]:
        print(f"{name[:60]:60s} {calls / n:7.2f} {ms * spent:7.3f} {1e6 * spent / calls:10.1f}")
    return 0


def timed_world(scene: str, knobs: list[str], warm: int, skip: int):
    """A fresh world of ``scene`` after ``warm`` steps of another (the kernels compiled or
    loaded) and ``skip`` steps of its own (the phase to time starts there)."""
    world = make_world(scene, knobs)
    for _ in range(warm):
        world.step()
    world = make_world(scene, knobs)
    for _ in range(skip):
        world.step()
    return world


def child(args: argparse.Namespace) -> int:
    """In the process with a fresh cache (the user's with ``--glue``): warm up, then
    map, record and report, or time by stage."""
    world = timed_world(args.scene, args.set, args.warm, args.skip)
    if args.glue:
        return glue_report(world, args.steps, args.top, args.scene)
    entries = map_entries()
    if args.refcounts:
        return count_refcounts(world, entries, args.steps, args.top)
    map_path = Path(f"/tmp/perf-{os.getpid()}.map")
    write_map(map_path, entries)
    if args.map_only:
        print(map_path)
        return 0
    with tempfile.TemporaryDirectory(prefix="sdfphys-perf-") as folder:
        data = Path(folder) / "perf.data"
        perf = subprocess.Popen(["perf", "record", "-e", "cpu-clock", "-F",
                                 str(args.frequency), "-p", str(os.getpid()), "-o", str(data)],
                                stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        time.sleep(1.0)                                    # perf attaches
        start = time.perf_counter()
        for _ in range(args.steps):
            world.step()
        seconds = time.perf_counter() - start
        perf.send_signal(signal.SIGINT)
        _, error = perf.communicate(timeout=60)
        report = (subprocess.run(["perf", "report", "-i", str(data), "--no-children",
                                  "--sort", "symbol", "--stdio"], capture_output=True,
                                 text=True).stdout if data.exists() else "")
    map_path.unlink(missing_ok=True)
    if not report:
        print(f"profile_steps: perf recorded nothing: {error.strip()[:300]}", file=sys.stderr)
        return 2
    print(f"{args.scene}: {args.steps} steps in {seconds:.3f} s "
          f"({seconds / max(args.steps, 1) * 1e3:.3f} ms a step, perf attached)")
    lines = [line for line in report.splitlines() if line.strip() and not line.startswith("#")]
    for line in lines[:args.top]:                   # without perf's empty IPC columns
        print(re.sub(r"(\s+-)+$", "", re.sub(r"\s+", " ", line.strip())))
    return 0


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("scene")
    parser.add_argument("--steps", type=int, default=None,
                        help="timed steps (default 300; 3 with --refcounts)")
    parser.add_argument("--warm", type=int, default=300)
    parser.add_argument("--skip", type=int, default=0,
                        help="untimed steps of the timed world before its timed steps")
    parser.add_argument("--top", type=int, default=30)
    parser.add_argument("--frequency", type=int, default=4000)
    parser.add_argument("--set", nargs="*", default=[], metavar="KNOB=VALUE")
    parser.add_argument("--map-only", action="store_true")
    mode = parser.add_mutually_exclusive_group()
    mode.add_argument("--refcounts", action="store_true",
                      help="count NRT_incref / NRT_decref calls by caller with gdb")
    mode.add_argument("--glue", action="store_true",
                      help="kernels against Python by stage (no perf needed)")
    args = parser.parse_args(argv)
    if args.steps is None:
        args.steps = 3 if args.refcounts else 300
    return args


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    if os.environ.get(_CHILD) == "1":
        try:
            return child(args)
        except (ValueError, OSError) as error:           # SpecError is a ValueError
            print(f"profile_steps: {args.scene}: {error}", file=sys.stderr)
            return 2
    if args.refcounts and shutil.which("gdb") is None:
        print("profile_steps: gdb is not on the PATH (needed by --refcounts)", file=sys.stderr)
        return 2
    if (not args.map_only and not args.refcounts and not args.glue
            and shutil.which("perf") is None):
        print("profile_steps: perf is not on the PATH (Linux's linux-tools; or --map-only)",
              file=sys.stderr)
        return 2
    command = [sys.executable, __file__, *(sys.argv[1:] if argv is None else argv)]
    env = dict(os.environ, SDFPHYS_WARM="0", **{_CHILD: "1"})
    if args.glue:                       # times only: the kernels may come from the cache
        return subprocess.run(command, env=env).returncode
    with tempfile.TemporaryDirectory(prefix="sdfphys-profile-cache-") as cache:
        return subprocess.run(command, env=dict(env, NUMBA_CACHE_DIR=cache)).returncode


if __name__ == "__main__":
    sys.exit(main())

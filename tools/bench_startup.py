"""Start-up time of ``sdfphys run``: cold and warm start, and numba's compile time per kernel.

Per scene (all of ``scenes/*.toml`` unless ``--scenes``), two fresh processes run the
command a user types, ``sdfphys run SCENE --seconds 1 -o OUT.mp4`` (``--seconds`` sets the
simulated seconds), with ``NUMBA_CACHE_DIR`` set to a new, empty temporary folder:

- cold s: wall time of the first process, measured by this tool around it: interpreter
  start, imports, numba compilation (the cache is empty), simulation, rendering and H.264
  encoding of the video;
- warm s: wall time of the second process, the same command on the cache the first one
  filled (numba loads the kernels from disk);
- compile s: the cold run's time inside numba's ``"numba:compile"`` events (numba's
  ``Dispatcher.compile``: type inference, lowering, LLVM; not loading or saving the disk
  cache), per kernel its self time: compiling a kernel compiles the njit functions it
  calls, whose events are nested in its own and are subtracted from it (they overlap);
  a kernel is ``module.qualname`` of the dispatcher's Python function and its time is
  summed over its specializations (signatures);
- kernels: the number of distinct sdfphys kernels the cold run compiled (compile s also
  counts the njit implementations of numpy functions and builtins that numba compiles
  for them, ``numba.np.arrayobj.ol_np_empty.<locals>.impl`` and the like, listed by
  ``--kernels``), and the three slowest kernels with their seconds (the ``sdfphys.``
  prefix left out); "warm compiles": the number of kernels of any module the warm run
  still compiled (0 when everything is cached).

Each process is this tool in child mode, ``--child SCENE OUT.json``, which registers a
``numba.core.event`` listener on "numba:compile" and then runs
``sdfphys.cli.main(["run", SCENE, "--seconds", S, "-o", TMP.mp4])`` in the same process
(what ``python -m sdfphys run ...`` does, plus the listener, whose cost is negligible;
the tool imports nothing but the standard library before that). It writes to OUT.json
the wall time from its own start (``wall_s``, ``import_s`` of sdfphys), the exit status
and one record per compile event (kernel, signature, self and total seconds, whether it
failed). Whether the process printed sdfphys's first-run notice ("compiling kernels for
this machine, first run only") on stderr is kept in the raw results (``--json``).

By default every scene gets its own fresh cache: each row is that scene's own cold start,
what a user pays when it is the first thing they run. ``--shared-cache`` runs all scenes,
in order, on one cache: then a scene's "cold" run starts from the kernels the scenes
before it compiled, and the sum of the compile times is what a user pays in total.
``--kernels`` adds the per-kernel table over all scenes: each (kernel, signature) counted
once, from the first scene whose cold run compiled it; "signatures" is the number of its
specializations so counted, "scenes" the number of scenes whose cold run compiled it.
``--markdown FILE`` writes the tables as markdown. The header line names the machine
(cores, CPU), Python, numba, llvmlite and numpy, and the commit of the checkout (with
"+ uncommitted changes" if sdfphys/ differs from it).

Usage: python tools/bench_startup.py [--scenes a.toml b.toml ...] [--seconds 1]
    [--shared-cache] [--kernels] [--markdown FILE] [--json FILE] [--timeout 1800]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from collections import defaultdict
from collections.abc import Sequence
from importlib import metadata
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SCENES = ROOT / "scenes"
TOOL = Path(__file__).resolve()

#: sdfphys's first-run notice on stderr (sdfphys._numba_cache).
NOTICE = "compiling kernels for this machine, first run only"

#: Slowest kernels shown per scene.
SLOWEST = 3


# ---------------------------------------------------------------------------- child mode


def kernel_name(dispatcher: object) -> str:
    """``module.qualname`` of a dispatcher's Python function."""
    func = getattr(dispatcher, "py_func", None)
    module = getattr(func, "__module__", None) or "?"
    name = getattr(func, "__qualname__", None) or getattr(func, "__name__", None) or "?"
    return f"{module}.{name}"


def make_compile_timer():
    """A ``numba.core.event.Listener`` that records, per "numba:compile" event, the kernel,
    its signature and its self time (total minus the nested compile events)."""
    from numba.core import event

    class CompileTimer(event.Listener):
        def __init__(self) -> None:
            self.stack: list[list[float]] = []     # [start, seconds of nested events]
            self.records: list[dict] = []

        def on_start(self, ev: event.Event) -> None:
            self.stack.append([time.perf_counter(), 0.0])

        def on_end(self, ev: event.Event) -> None:
            start, nested = self.stack.pop()
            total = time.perf_counter() - start
            if self.stack:
                self.stack[-1][1] += total
            data = ev.data if isinstance(ev.data, dict) else {}
            args = data.get("args") or ()
            self.records.append({
                "kernel": kernel_name(data.get("dispatcher")),
                "signature": "(" + ", ".join(map(str, args)) + ")",
                "self_s": total - nested,
                "total_s": total,
                "failed": _failed(ev),
            })

    return CompileTimer()


def _failed(ev: object) -> bool:
    """Whether a compile ended with an exception (numba retries some, e.g. to fold literal
    arguments). ``Event.is_failed`` is False for every event of ``trigger_event``, which
    passes ``(None, None, None)`` on success: read the exception type itself."""
    details = getattr(ev, "_exc_details", None)
    return bool(details) and details[0] is not None


def child(scene: str, out: Path, seconds: float) -> int:
    """Run ``sdfphys run SCENE --seconds S -o TMP.mp4`` here with a compile-event listener;
    write the wall time, exit status and compile records to ``out`` (JSON)."""
    start = time.perf_counter()
    from numba.core import event

    timer = make_compile_timer()
    event.register("numba:compile", timer)
    from sdfphys import cli

    imported = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="sdfphys-startup-") as tmp:
        status = cli.main(["run", scene, "--seconds", repr(seconds),
                           "-o", str(Path(tmp) / "out.mp4")])
    wall = time.perf_counter() - start
    out.write_text(json.dumps({"scene": scene, "seconds": seconds, "status": status,
                               "wall_s": wall, "import_s": imported - start,
                               "compiles": timer.records}, indent=1))
    return status


# ---------------------------------------------------------------------------- parent mode


def run_child(scene: Path, cache: Path, seconds: float, timeout: float) -> dict:
    """One fresh child process on ``cache``: its JSON plus ``process_s`` (wall time of the
    process, measured here) and ``notice`` (the first-run notice was on stderr)."""
    out = cache.parent / f"child-{time.monotonic_ns()}.json"
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache))
    command = [sys.executable, str(TOOL), "--child", str(scene), str(out),
               "--seconds", repr(seconds)]
    start = time.perf_counter()
    done = subprocess.run(command, env=env, capture_output=True, text=True, timeout=timeout)
    process = time.perf_counter() - start
    if done.returncode != 0 or not out.is_file():
        tail = "\n".join(done.stderr.strip().splitlines()[-15:])
        raise RuntimeError(f"{scene.name}: child exited with status {done.returncode}:\n{tail}")
    result = json.loads(out.read_text())
    out.unlink()
    result.update(process_s=process, notice=NOTICE in done.stderr)
    return result


def per_kernel(records: list[dict]) -> dict[str, float]:
    """Self seconds per kernel, summed over its compile events."""
    seconds: dict[str, float] = defaultdict(float)
    for record in records:
        seconds[record["kernel"]] += record["self_s"]
    return dict(seconds)


def short(kernel: str) -> str:
    """A kernel's name without the ``sdfphys.`` prefix."""
    return kernel.removeprefix("sdfphys.")


def code(name: str, markdown: bool) -> str:
    """A kernel's name, in backticks for markdown (``<locals>`` would read as a tag)."""
    return f"`{name}`" if markdown else name


def scene_row(name: str, cold: dict, warm: dict, markdown: bool = False) -> list[str]:
    """One row of the scene table."""
    kernels = per_kernel(cold["compiles"])
    slowest = sorted(kernels.items(), key=lambda item: -item[1])[:SLOWEST]
    return [name, f"{cold['process_s']:.1f}", f"{warm['process_s']:.1f}",
            f"{sum(kernels.values()):.1f}", str(sum(k.startswith("sdfphys.") for k in kernels)),
            str(len(per_kernel(warm["compiles"]))),
            ", ".join(f"{code(short(k), markdown)} {s:.1f}" for k, s in slowest) or "-"]


SCENE_HEADERS = ["scene", "cold s", "warm s", "compile s", "kernels", "warm compiles",
                 f"{SLOWEST} slowest kernels (s)"]


def kernel_rows(results: list[dict], markdown: bool = False) -> list[list[str]]:
    """The kernel table over the scenes' cold runs: each (kernel, signature) counted once,
    from the first scene that compiled it; sorted by seconds, slowest first; a total last."""
    first: dict[tuple[str, str], tuple[float, str]] = {}
    scenes: dict[str, set[str]] = defaultdict(set)
    for result in results:
        name = Path(result["scene"]).stem
        for record in result["cold"]["compiles"]:
            key = (record["kernel"], record["signature"])
            scenes[record["kernel"]].add(name)
            first.setdefault(key, (0.0, name))
            if first[key][1] == name:
                first[key] = (first[key][0] + record["self_s"], name)
    seconds: dict[str, float] = defaultdict(float)
    signatures: dict[str, int] = defaultdict(int)
    first_scene: dict[str, str] = {}
    for (kernel, _), (spent, name) in first.items():
        seconds[kernel] += spent
        signatures[kernel] += 1
        first_scene.setdefault(kernel, name)
    rows = [[code(kernel, markdown), f"{spent:.2f}", str(signatures[kernel]),
             str(len(scenes[kernel])), first_scene[kernel]]
            for kernel, spent in sorted(seconds.items(), key=lambda item: -item[1])]
    rows.append(["total", f"{sum(seconds.values()):.2f}", str(sum(signatures.values())),
                 "", ""])
    return rows


KERNEL_HEADERS = ["kernel", "compile s", "signatures", "scenes", "first scene"]


def table(headers: Sequence[str], rows: Sequence[Sequence[str]], markdown: bool) -> str:
    """A plain-text table (columns aligned; text left, numbers right) or a markdown one."""
    numeric = [all(_number(row[i]) for row in rows if row[i]) for i in range(len(headers))]
    if markdown:
        lines = ["| " + " | ".join(headers) + " |",
                 "|" + "|".join("---:" if n else "---" for n in numeric) + "|"]
        return "\n".join(lines + ["| " + " | ".join(row) + " |" for row in rows])
    widths = [max(len(str(cell)) for cell in column) for column in zip(headers, *rows)]

    def line(cells: Sequence[str]) -> str:
        return "  ".join(c.rjust(w) if n else c.ljust(w)
                         for c, w, n in zip(cells, widths, numeric)).rstrip()

    return "\n".join([line(headers), line(["-" * w for w in widths])] + [line(r) for r in rows])


def _number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def machine() -> str:
    """Cores, CPU, OS, Python, numba and llvmlite versions, and the checkout's commit."""
    cpu = platform.processor() or platform.machine()
    try:
        for text in Path("/proc/cpuinfo").read_text().splitlines():
            if text.startswith("model name"):
                cpu = text.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    usable = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else None
    cores = f"{os.cpu_count()} cores" + (f" ({usable} usable)" if usable not in
                                        (None, os.cpu_count()) else "")
    versions = ", ".join(f"{name} {_version(name)}" for name in ("numba", "llvmlite", "numpy"))
    return (f"{cores}, {cpu}, {platform.system()} {platform.release()}; "
            f"Python {platform.python_version()}, {versions}; sdfphys {_commit()}")


def _version(package: str) -> str:
    try:
        return metadata.version(package)
    except metadata.PackageNotFoundError:
        return "?"


def _commit() -> str:
    """The checkout's short commit, "+ uncommitted changes" if sdfphys/ differs from it."""
    def git(*args: str) -> str:
        return subprocess.run(["git", "-C", str(ROOT), *args], capture_output=True,
                              text=True, check=True).stdout.strip()

    try:
        commit = git("rev-parse", "--short", "HEAD")
        dirty = git("status", "--porcelain", "--", "sdfphys")
    except (OSError, subprocess.CalledProcessError):
        return "(not a git checkout)"
    return commit + (" + uncommitted changes" if dirty else "")


def resolve_scene(text: str) -> Path:
    """A scene file: the path given, else that name (with or without .toml) in scenes/."""
    for candidate in (Path(text), SCENES / text, SCENES / f"{text}.toml"):
        if candidate.is_file():
            return candidate.resolve()
    raise SystemExit(f"bench_startup: no scene {text!r} (nor in {SCENES})")


def measure(scenes: list[Path], seconds: float, shared: bool, timeout: float) -> list[dict]:
    """Cold and warm child runs per scene, on one cache per scene or one for all."""
    results = []
    with tempfile.TemporaryDirectory(prefix="sdfphys-startup-") as tmp:
        for index, scene in enumerate(scenes):
            cache = Path(tmp) / ("cache" if shared else f"cache-{index}")
            cold = run_child(scene, cache, seconds, timeout)
            warm = run_child(scene, cache, seconds, timeout)
            print(f"{scene.stem}: cold {cold['process_s']:.1f} s, warm {warm['process_s']:.1f} s",
                  file=sys.stderr, flush=True)
            results.append({"scene": str(scene), "cold": cold, "warm": warm})
    return results


def report(results: list[dict], header: str, kernels: bool, markdown: bool) -> str:
    """The scene table and, with ``kernels``, the kernel table, after the header line."""
    rows = [scene_row(Path(r["scene"]).stem, r["cold"], r["warm"], markdown) for r in results]
    parts = [header, table(SCENE_HEADERS, rows, markdown)]
    if kernels:
        parts.append(table(KERNEL_HEADERS, kernel_rows(results, markdown), markdown))
    return "\n\n".join(parts) + "\n"


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", nargs="+", metavar="SCENE",
                        help="scene files or names in scenes/ (default: all of scenes/*.toml)")
    parser.add_argument("--seconds", type=float, default=1.0,
                        help="simulated seconds per run (default 1)")
    parser.add_argument("--shared-cache", action="store_true",
                        help="run all scenes on one cache (default: a fresh cache per scene)")
    parser.add_argument("--kernels", action="store_true",
                        help="also the per-kernel table over all scenes")
    parser.add_argument("--markdown", metavar="FILE", help="write the tables as markdown")
    parser.add_argument("--json", metavar="FILE", help="write the raw results as JSON")
    parser.add_argument("--timeout", type=float, default=1800.0,
                        help="seconds allowed per process (default 1800)")
    parser.add_argument("--child", nargs=2, metavar=("SCENE", "OUT.json"),
                        help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.child:
        return child(args.child[0], Path(args.child[1]), args.seconds)

    scenes = ([resolve_scene(s) for s in args.scenes] if args.scenes
              else sorted(SCENES.glob("*.toml")))
    cache = "one cache shared by all scenes, in order" if args.shared_cache else \
        "a fresh cache per scene"
    header = (f"sdfphys run SCENE --seconds {args.seconds:g} -o OUT.mp4, {cache}; "
              f"{machine()}")
    results = measure(scenes, args.seconds, args.shared_cache, args.timeout)
    print(report(results, header, args.kernels, markdown=False), end="")
    if args.markdown:
        Path(args.markdown).write_text(report(results, header, args.kernels, markdown=True))
    if args.json:
        Path(args.json).write_text(json.dumps({"header": header, "results": results}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""``sdfphys sweep``: scenes x settings x repeats on a Dask cluster, one CSV row per run;
and the machinery (``cluster``, ``run_tasks``) that ``sdfphys bench`` runs its study on.

``sdfphys sweep SCENE... [--set KEY=V1,V2,...]... [--quality Q1,Q2] [--seconds T]
[--repeat R] -o RESULTS.csv [--workers N | --scheduler ADDRESS] [--resume]`` runs the
cross product of the scenes, the values of each swept key, the qualities and the
repeats, one task per run, on Dask's distributed scheduler: a local cluster of worker
processes (one per core, or ``--workers N``) or the existing cluster whose scheduler is
at ``--scheduler``. A task whose worker dies is rerun on another (Dask's scheduler does
that); a run is deterministic, so the rerun's row is the one the lost task would have
written.

Each run writes one CSV row (``columns``) as soon as it finishes, so an interrupted
sweep keeps what it finished and ``--resume`` runs only the rows the file lacks. The
row holds what ``sdfphys run`` prints (``summary.simulate``: the same hash for the
same setting); ``ms_per_step`` leaves out the first step, which loads (or, on a cold
cache, compiles) the kernels. A bad scene or setting is not fatal: its row carries the
one-line message in ``error`` and the rest go on.

The client reads the scene files and sends their contents with the tasks, so workers
need sdfphys and Dask installed, not the scenes. Workers on one machine share numba's
on-disk cache (``NUMBA_CACHE_DIR``, or the package's ``__pycache__``): the first run of
each worker compiles or loads the kernels there. Tasks run without the compiling child
of ``_warm`` (``SDFPHYS_WARM=0``): the workers already occupy the cores, and a worker
runs tasks on a thread of a multi-threaded process, which must not fork.
"""

from __future__ import annotations

import argparse
import csv
import itertools
import logging
import os
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import ExitStack, contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .errors import SpecError
from .interrupt import deferred
from .limits import check_steps
from .progress import Progress
from .scene import read_scene, read_scene_file
from .settings import PRESETS
from .summary import simulate, steps_for

__all__ = ["NO_DASK", "RESULTS", "Run", "cluster", "cluster_options", "columns", "plan",
           "run_one", "run_tasks", "split_values", "sweep_main"]

#: The columns after ``scene`` and the swept keys, in order.
RESULTS = ("quality", "repeat", "steps", "wall_s", "ms_per_step", "max_penetration",
           "energy_start", "energy_end", "state_hash", "error")

#: The message of a sweep (or a bench on a cluster) without Dask installed.
NO_DASK = ("Dask is not installed: pip install 'sdfphys[cluster]' (in a checkout: "
           "pip install -e \".[cluster]\")")

#: Seconds to wait for ``--scheduler`` to answer.
CONNECT_SECONDS = 10


# ---------------------------------------------------------------------------------------
# The machinery: a cluster, and tasks on it
# ---------------------------------------------------------------------------------------


def cluster_options(parser: argparse.ArgumentParser) -> None:
    """``--workers N | --scheduler ADDRESS`` (sweep and bench)."""
    where = parser.add_mutually_exclusive_group()
    where.add_argument("--workers", type=int, metavar="N", help="run on a local Dask "
                       "cluster of N worker processes (sweep's default: one per core)")
    where.add_argument("--scheduler", metavar="ADDRESS", help="an existing Dask cluster's "
                       "scheduler, e.g. tcp://host:8786")


def _distributed():
    """``dask.distributed``, or a SpecError (exit 2) saying how to install it."""
    try:
        from dask import distributed
    except ImportError:
        raise SpecError("", NO_DASK) from None
    return distributed


@contextmanager
def cluster(workers: int | None = None, scheduler: str | None = None) -> Iterator[Any]:
    """A Dask client, closed after the block: of the scheduler at ``scheduler``, else of a
    new local cluster of ``workers`` worker processes (default: one per core) with one
    thread each. SpecError without Dask, for ``workers`` < 1 or a scheduler that does not
    answer within ``CONNECT_SECONDS``."""
    distributed = _distributed()
    if scheduler is not None:
        try:
            client = distributed.Client(scheduler, timeout=CONNECT_SECONDS)
        except (OSError, TimeoutError, ValueError) as err:
            raise SpecError("--scheduler", f"cannot connect to {scheduler}: {err}") from None
        with client:
            yield client
        return
    if workers is not None and workers < 1:
        raise SpecError("--workers", f"must be >= 1, got {workers}")
    with (distributed.LocalCluster(n_workers=workers or os.cpu_count() or 1,
                                   threads_per_worker=1, processes=True,
                                   dashboard_address=None, silence_logs=logging.ERROR)
          as local, distributed.Client(local) as client):
        yield client


def _task(function: Callable[[Any], Any], item: Any) -> Any:
    """``function(item)`` on a worker, without the compiling child (module doc)."""
    os.environ["SDFPHYS_WARM"] = "0"
    return function(item)


def run_tasks(function: Callable[[Any], Any], items: Sequence[Any], client: Any = None,
              progress: Progress | None = None) -> Iterator[tuple[Any, Any]]:
    """``(item, function(item))`` for each of ``items`` as it finishes: one task each on
    ``client``'s cluster, or in this process in order without a client. ``function``
    must be importable by the workers (a module-level function of sdfphys). A task that
    raises ends the iteration with its exception. ``progress`` is updated per item."""
    try:
        if client is None:
            for done, item in enumerate(items, 1):
                yield item, function(item)
                if progress is not None:
                    progress.update(done)
            return
        futures = {client.submit(_task, function, item, pure=False): item for item in items}
        for done, future in enumerate(_distributed().as_completed(futures), 1):
            yield futures[future], future.result()
            if progress is not None:
                progress.update(done)
    finally:
        if progress is not None:
            progress.close()


# ---------------------------------------------------------------------------------------
# The sweep
# ---------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Run:
    """One run: a scene as given, one value (TOML text) per swept key, a quality preset
    ("": the scene's own) and the repeat (from 1)."""

    scene: str
    values: tuple[str, ...]
    quality: str
    repeat: int

    def identity(self) -> tuple[str, ...]:
        """Its first CSV cells: what ``--resume`` matches."""
        return (self.scene, *self.values, self.quality, str(self.repeat))


def columns(keys: Sequence[str]) -> list[str]:
    """The CSV header of a sweep of ``keys``."""
    return ["scene", *keys, *RESULTS]


def split_values(text: str) -> list[str]:
    """``text`` split at the commas outside brackets, braces and quotes
    (``[0,-1.62],[0,-9.81]`` is two values), each stripped."""
    values, depth, quote, start = [], 0, "", 0
    for i, char in enumerate(text):
        if quote:
            quote = "" if char == quote else quote
        elif char in "\"'":
            quote = char
        elif char in "[{":
            depth += 1
        elif char in "]}":
            depth -= 1
        elif char == "," and depth == 0:
            values.append(text[start:i].strip())
            start = i + 1
    values.append(text[start:].strip())
    return values


def _swept(items: Sequence[str]) -> dict[str, list[str]]:
    """``--set KEY=V1,V2,...`` options as {key: values}; SpecError for a malformed one, a
    key given twice or named like a column."""
    swept: dict[str, list[str]] = {}
    for item in items:
        key, sep, text = item.partition("=")
        key = key.strip()
        values = split_values(text)
        if not sep or not key or not all(values):
            raise SpecError("--set", f"expected KEY=V1,V2,..., got {item!r}")
        if key in swept:
            raise SpecError("--set", f"{key} is swept twice: give all its values in one "
                            f"--set {key}=V1,V2,...")
        if key in ("scene", *RESULTS):
            raise SpecError("--set", f"{key!r} is a column of the results, not a scene key")
        swept[key] = values
    return swept


def _qualities(text: str | None) -> list[str]:
    """``--quality Q1,Q2`` as a list ([""]: each scene's own); SpecError for another name."""
    if text is None:
        return [""]
    qualities = [q.strip() for q in text.split(",")]
    for q in qualities:
        if q not in PRESETS:
            raise SpecError("--quality", f"expected presets from {', '.join(PRESETS)}, "
                            f"got {q!r}")
    return qualities


def plan(scenes: Sequence[str], swept: dict[str, list[str]], qualities: Sequence[str],
         repeat: int) -> list[Run]:
    """Every run of the sweep: scenes x values of each key x qualities x repeats."""
    return [Run(scene, values, quality, r)
            for scene, values, quality, r in itertools.product(
                scenes, itertools.product(*swept.values()), qualities,
                range(1, repeat + 1))]


def run_one(job: tuple[Run, dict, list[str], float | None, int | None]) -> dict[str, Any]:
    """The result cells of one run (a task): ``job`` is the Run, its scene's TOML as read,
    the run's ``KEY=VALUE`` overrides, ``--seconds`` (None: the scene's duration) and
    ``--max-steps``. A bad scene or setting gives only ``error``, its one-line message
    (naming the scene file)."""
    run, data, overrides, seconds, max_steps = job
    try:
        scene = read_scene(data, overrides, quality=run.quality or None)
        steps = steps_for(scene.duration if seconds is None else seconds, scene.settings.dt)
        check_steps(steps, "steps", max_steps)
        world = scene.build()
    except SpecError as err:
        return {"error": str(err.in_file(run.scene))}
    summary = simulate(world, steps)
    return {"steps": summary.steps, "wall_s": round(summary.wall_s, 6),
            "ms_per_step": round(summary.ms_per_step, 6),
            "max_penetration": summary.max_penetration,
            "energy_start": summary.energy_start, "energy_end": summary.energy_end,
            "state_hash": summary.state_hash, "error": ""}


def _finished(path: Path, header: list[str]) -> list[dict[str, str]]:
    """The rows of the results file at ``path`` (none if it does not exist); SpecError if
    its header is not ``header`` (another sweep's file)."""
    if not path.exists():
        return []
    try:
        with open(path, newline="") as handle:
            reader = csv.DictReader(handle)
            rows = list(reader)
            found = reader.fieldnames
    except (OSError, UnicodeDecodeError, csv.Error) as err:
        raise SpecError("", f"cannot be read: {err}", str(path)) from None
    if found is None:                   # an empty file: a sweep that wrote nothing yet
        return []
    if list(found) != header:
        raise SpecError("", f"has the columns {','.join(found)!r}, not this sweep's "
                        f"{','.join(header)!r}", str(path))
    return rows


def _output(output: str, resume: bool) -> Path:
    """``-o`` as a Path; SpecError if its directory does not exist, or it exists and is
    not resumed."""
    path = Path(output)
    if not path.parent.is_dir():
        raise SpecError("", f"no such directory {str(path.parent)!r}", output)
    if path.is_dir():
        raise SpecError("", "is a directory, not a CSV file", output)
    if path.exists() and not resume:
        raise SpecError("", "exists: --resume continues it (runs only the rows it lacks); "
                        "or remove it", output)
    return path


def _jobs(runs: Sequence[Run], swept: dict[str, list[str]], seconds: float | None,
          max_steps: int | None) -> tuple[list[tuple], list[tuple[Run, dict[str, Any]]]]:
    """The tasks of ``runs`` (``run_one``'s jobs), and the rows of the runs whose scene
    file cannot be read (its error: those need no task)."""
    jobs, unread = [], []
    for scene in dict.fromkeys(r.scene for r in runs):
        mine = [r for r in runs if r.scene == scene]
        try:
            data = read_scene_file(scene)
        except SpecError as err:
            unread += [(run, {"error": str(err)}) for run in mine]
            continue
        jobs += [(run, data, [f"{k}={v}" for k, v in zip(swept, run.values, strict=True)],
                  seconds, max_steps) for run in mine]
    return jobs, unread


def sweep_main(scenes: Sequence[str], sets: Sequence[str], quality: str | None,
               seconds: float | None, repeat: int, output: str, *, resume: bool = False,
               workers: int | None = None, scheduler: str | None = None,
               max_steps: int | None = None) -> int:
    """``sdfphys sweep`` (module doc). Returns 0 when every row of the file ran, 1 when
    some row holds an error; raises SpecError for bad usage (exit 2: no Dask, a malformed
    ``--set`` or ``--quality``, ``--repeat`` < 1, an existing file without ``--resume``
    or another sweep's file with it, a cluster that cannot be had), before anything is
    written."""
    _distributed()
    swept = _swept(sets)
    qualities = _qualities(quality)
    if repeat < 1:
        raise SpecError("--repeat", f"must be >= 1, got {repeat}")
    path = _output(output, resume)
    header = columns(list(swept))
    finished = _finished(path, header) if resume else []
    identity = header[:len(swept) + 3]      # scene, the keys, quality, repeat
    done = {tuple(row[c] for c in identity) for row in finished}
    runs = [r for r in plan(scenes, swept, qualities, repeat) if r.identity() not in done]
    jobs, unread = _jobs(runs, swept, seconds, max_steps)
    errors = sum(bool(row["error"]) for row in finished) + len(unread)
    start = time.perf_counter()
    with ExitStack() as stack:
        client = stack.enter_context(cluster(workers, scheduler)) if jobs else None
        with deferred():
            handle = stack.enter_context(open(path, "a" if finished else "w", newline=""))
        writer = csv.writer(handle)

        def write(run: Run, result: dict[str, Any]) -> None:
            cells = dict(zip(header, run.identity(), strict=False)) | result
            with deferred():
                writer.writerow([cells.get(c, "") for c in header])
                handle.flush()

        if not finished:
            writer.writerow(header)
        for run, result in unread:
            write(run, result)
        where = ""
        if client is not None:
            count = len(client.nthreads())
            where = f" on {count} worker{'s' if count != 1 else ''}"
            progress = Progress(len(jobs), "runs", "sdfphys sweep")
            for job, result in run_tasks(run_one, jobs, client, progress):
                write(job[0], result)
                errors += bool(result["error"])
    print(f"ran            {len(runs)} runs{where} in {time.perf_counter() - start:.1f} s"
          + (f"; {len(finished)} rows were already in the file" if finished else ""))
    print(f"errors         {errors} of {len(finished) + len(runs)} rows")
    print(f"wrote          {path}")
    return 1 if errors else 0

"""Many recordings, many cores, many machines: ``labkit extract`` and ``labkit evaluate`` on Dask.

A task reads one recording (or one range of its scans, below), runs the pipeline on it and
writes its output itself, through ``labkit._safe`` (so a failed or interrupted task leaves
no half file), then returns a small :class:`Result`: counts, seconds, peak memory, and the
one-line error of a damaged or failed recording. The tasks run on

- a local Dask cluster by default: ``workers`` processes with one thread each
  (``distributed.LocalCluster(n_workers=workers, threads_per_worker=1, processes=True)``;
  default: one per core, at most one per recording or per :data:`MIN_PIECE_SCANS` scans);
- an existing Dask scheduler, ``scheduler="tcp://host:8786"``, for a real cluster;
- this process, one recording after another, with ``workers=0`` (no Dask at all).

Paths are made absolute here, before anything is sent (a worker's working folder is not this
one's), so the inputs and the outputs must lie on a file system every worker sees under the same
path. A worker that cannot see an input reports that recording as refused (exit status 2); an
output a worker wrote that this machine cannot see is a system error (3); a run in which no
recording could be read writes nothing.

Outputs: one per input (``<out>/<name>.features.jsonl`` or ``.parquet``, ``<name>`` being the
recording's name without its suffix), or one Parquet table for all (``out`` ending in
``.parquet``: each task writes its part, and the parts are joined in input order). The results
are the same as a serial run's, row for row (stage timings aside, which differ from run to run).

**A long recording uses every core.** With several workers, a recording longer than its share
of the set (all scans / workers) is split into scan ranges of equal length, one task each
(:func:`split_ranges`); each task reads its range (``read_scans(..., scans=slice(a, b))``: it
reads from the recording's start, skipping the scans before ``a``), the parts are written beside
the output and joined in order, and the recording gets one :class:`Result`, as if it had been one
task. Reading is cheap beside extraction (a CARMEN log: under a tenth), so the skipped scans cost
little. ``scans=slice(a, b)`` also limits every recording to a range of its own.

One damaged recording is reported and the others go on; a recording that cannot be read at
all (refused, a system error, a bug) is reported the same way. Ctrl-C asks every running task to
stop (a Dask ``Event`` the tasks look at twice a second): each keeps what it wrote as
``<name>.partial.<suffix>`` and the outputs already finished stay.
"""

from __future__ import annotations

import contextlib
import logging
import math
import os
import resource
import shutil
import sys
import tempfile
import time
import traceback
import uuid
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from labkit._safe import (
    TEMP_MARK,
    OutputInterrupted,
    check_output,
    make_parents,
    partial_name,
    remove_empty,
    safe_output,
)
from labkit.errors import CorruptFileError, RefusedError

__all__ = ["Result", "recordings_in", "output_paths", "preflight", "split_ranges", "extract_many", "evaluate_many",
           "extract_one", "run_tasks", "report", "MIN_PIECE_SCANS"]

#: Exit statuses of the command line (README, "When things go wrong"), per result.
STATUS = {"done": 0, "damaged": 1, "refused": 2, "system": 3, "bug": 70, "interrupted": 130}
_GRAVITY = ["done", "damaged", "refused", "system", "interrupted", "bug"]
_CHECK_EVERY_S = 0.5
#: A recording is split into scan ranges only into pieces of at least this many scans.
MIN_PIECE_SCANS = 500


@dataclass
class Result:
    """What one task did with one recording.

    Parameters
    ----------
    input : str
        The recording.
    output : str or None
        What it wrote (None: nothing, or a part of a joined table).
    status : str
        ``done``, ``damaged`` (the output holds every readable scan), ``refused``, ``system``,
        ``bug`` or ``interrupted`` (the partial output is ``output``); ``STATUS`` gives the
        exit status of each.
    error : str or None
        The one-line error (a bug: the traceback).
    n_scans, n_rows : int
        Scans read; rows (table) or records (JSON lines) written.
    counts : dict
        Features found, summed over the scans.
    seconds : float
        Wall time of the task (a recording split into ranges: the sum of its tasks').
    peak_rss_mb : float
        Peak resident memory of the process that ran it, MiB (since that process started).
    worker : str
        Where it ran (the Dask worker's address, or ``"local"``; a split recording: every
        worker that ran a range of it, comma-separated).
    rows : list
        ``evaluate``: the table rows of this recording.
    """

    input: str
    output: str | None = None
    status: str = "done"
    error: str | None = None
    n_scans: int = 0
    n_rows: int = 0
    counts: dict = field(default_factory=dict)
    seconds: float = 0.0
    peak_rss_mb: float = 0.0
    worker: str = "local"
    rows: list = field(default_factory=list)

    @property
    def exit_status(self) -> int:
        return STATUS[self.status]


# ---------------------------------------------------------------------------- inputs and outputs
def _is_recording(p: Path) -> bool:
    if p.name.startswith(".") or ".partial" in p.name:
        return False
    if p.is_dir():
        return (p / "metadata.yaml").is_file()
    from labkit.io.formats import recording_suffixes

    return p.name.lower().endswith(recording_suffixes(in_folders_only=True))


def recordings_in(paths: Iterable[str | Path]) -> list[Path]:
    """The recordings to run on, from paths that name recordings or folders of them.

    Every path given that is a file or a ROS2 bag folder is taken as it is; every other folder
    gives the recordings inside it (bags, MCAP files, ROS2 bag folders and CARMEN logs, sorted by
    name; JSON scans only when named, since a folder's ``.jsonl`` files may be labkit's own
    features). A folder that holds none, or a path that does not exist, is refused
    (:class:`labkit.errors.RefusedError`).

    Parameters
    ----------
    paths : iterable of str or Path
        Recordings and folders.

    Returns
    -------
    list of Path
        The recordings, each once, in the order given.
    """
    out: list[Path] = []
    for raw in paths:
        p = Path(raw)
        if not p.exists():
            raise RefusedError(f"{p} does not exist")
        if p.is_dir() and not (p / "metadata.yaml").is_file():
            found = sorted(q for q in p.iterdir() if _is_recording(q))
            if not found:
                from labkit.io import FORMATS

                kinds = ", ".join(f.label for f in FORMATS.values() if f.in_folders)
                raise RefusedError(f"{p} holds no recordings ({kinds})")
            out.extend(found)
        else:
            out.append(p)
    seen: set[Path] = set()
    unique = []
    for p in out:
        if p.resolve() not in seen:
            seen.add(p.resolve())
            unique.append(p)
    return unique


def _absolute(p: str | Path) -> Path:
    """``p`` as an absolute path, as this machine names it (symbolic links kept: a shared file
    system may be mounted through one), for workers whose working folder is not this one's."""
    return Path(os.path.abspath(os.fspath(p)))


def _stem(p: Path) -> str:
    name = p.name
    low = name.lower()
    from labkit.io.formats import recording_suffixes

    for end in sorted(recording_suffixes(), key=len, reverse=True):
        if low.endswith(end):
            return name[: -len(end)]
    return name


def output_paths(inputs: Sequence[Path], folder: str | Path, suffix: str = ".features.jsonl") -> list[Path]:
    """One output per input in a folder: ``<name>.features.jsonl``, ``<name>`` the recording's name without its suffix.

    Two inputs of one name are refused (:class:`labkit.errors.RefusedError`), and so is a ``folder``
    that is a file.

    Parameters
    ----------
    inputs : sequence of Path
        The recordings.
    folder : str or Path
        Where the outputs go.
    suffix : str
        The outputs' suffix.

    Returns
    -------
    list of Path
        The output of each input, in order.
    """
    folder = Path(folder)
    if folder.exists() and not folder.is_dir():
        raise RefusedError(f"{folder} is a file: with several inputs, -o names a folder (one output per input) or "
                           "one .parquet table")
    outs = [folder / f"{_stem(p)}{suffix}" for p in inputs]
    clash = {o for o in outs if outs.count(o) > 1}
    if clash:
        names = ", ".join(str(p) for p, o in zip(inputs, outs, strict=True) if o in clash)
        raise RefusedError(f"{names} would all write {sorted(clash)[0].name}: rename one, or run them separately")
    return outs


def split_ranges(sizes: Sequence[int | None], n_workers: int, *,
                 min_scans: int | None = None) -> list[list[tuple[int, int]] | None]:
    """How to split each recording of a set among ``n_workers`` workers.

    A recording longer than its share of the work, ``sum(sizes) / n_workers`` scans, is cut into
    ``ceil(size / share)`` ranges of (nearly) equal length, none shorter than ``min_scans``;
    the others stay whole, so a set of many similar recordings runs as before, one task each.

    Parameters
    ----------
    sizes : sequence of int or None
        The recordings' scan counts (None: unknown, e.g. a damaged bag; never split).
    n_workers : int
        The number of workers; fewer than 2: nothing is split.
    min_scans : int or None
        The shortest piece, scans; None: :data:`MIN_PIECE_SCANS`.

    Returns
    -------
    list of (list of tuple of (int, int)) or None
        Per recording, None (one task) or its ranges ``(start, stop)``, counted from its first scan.

    Examples
    --------
    >>> split_ranges([4791, 1941, 910, 440, 406, 237], 2)[:2]
    [[(0, 2396), (2396, 4791)], None]
    """
    known = [n for n in sizes if n is not None]
    min_scans = MIN_PIECE_SCANS if min_scans is None else min_scans
    if n_workers < 2 or not known:
        return [None] * len(sizes)
    share = sum(known) / n_workers
    plan: list[list[tuple[int, int]] | None] = []
    for n in sizes:
        pieces = 1 if n is None or n <= share else min(math.ceil(n / share), n // max(min_scans, 1))
        if n is None or pieces < 2:
            plan.append(None)
            continue
        bounds = [round(k * n / pieces) for k in range(pieces + 1)]
        plan.append(list(zip(bounds[:-1], bounds[1:], strict=True)))
    return plan


# ---------------------------------------------------------------------------- one task
def _peak_rss_mb() -> float:
    """This process's peak resident memory, MiB: its own high-water mark (Linux ``VmHWM``; getrusage's
    ``ru_maxrss`` also counts the parent's memory at the fork that started it)."""
    try:
        with open("/proc/self/status", encoding="ascii") as fh:
            return next(int(line.split()[1]) for line in fh if line.startswith("VmHWM:")) / 1024.0
    except (OSError, StopIteration, ValueError):
        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0  # Linux: KiB; macOS: bytes


class _Stop:
    """Raises KeyboardInterrupt inside a task once the client set the Dask Event ``name``
    (looked at twice a second, not per scan: each look is a round trip to the scheduler)."""

    def __init__(self, name: str | None) -> None:
        self.name, self.next = name, time.monotonic() + _CHECK_EVERY_S
        self.event: Any = None  # a distributed.Event, made on the first look

    def check(self, now: bool = False) -> None:
        if self.name is None or (time.monotonic() < self.next and not now):
            return
        self.next = time.monotonic() + _CHECK_EVERY_S
        if self.event is None:
            from distributed import Event

            self.event = Event(self.name)
        if self.event.is_set():
            raise KeyboardInterrupt


def _where() -> str:
    try:
        from distributed import get_worker

        return get_worker().address
    except (ImportError, ValueError):
        return "local"


def _guarded(result: Result, run: Callable[[Result], None]) -> Result:
    """Run ``run(result)``; turn what it raises into the result's status and one-line error."""
    t0 = time.perf_counter()
    result.worker = _where()
    try:
        run(result)
    except CorruptFileError as exc:
        result.status, result.error = "damaged", str(exc)
    except OutputInterrupted as exc:
        result.status, result.output = "interrupted", str(exc.partial) if exc.partial else None
        result.error = f"interrupted: {exc.target} was not changed" + (
            f"; what was written so far is in {exc.partial}" if exc.partial else "")
    except KeyboardInterrupt:
        result.status, result.error = "interrupted", "interrupted before it started: nothing was written"
    except RefusedError as exc:
        result.status, result.error = "refused", exc.cli
    except FileNotFoundError as exc:
        result.status, result.error = "refused", f"{exc.filename or result.input}: no such file or folder"
        if result.worker != "local":  # this machine saw it (every input is opened here first): the worker does not
            result.error += (f" on the Dask worker {result.worker}; every worker must see the inputs and outputs "
                             "under the same path as this machine")
    except OSError as exc:
        result.status, result.error = "system", (f"{exc.filename}: {exc.strerror}" if exc.filename and exc.strerror
                                                 else exc.strerror or str(exc))
    except ValueError as exc:  # bad input labkit names (a malformed scan, an empty bag)
        result.status, result.error = "refused", str(exc)
    except Exception:  # noqa: BLE001 - a bug: its traceback goes to the report
        result.status, result.error = "bug", traceback.format_exc()
    result.seconds = time.perf_counter() - t0
    result.peak_rss_mb = _peak_rss_mb()
    return result


def extract_one(path: str | Path, out: str | Path | None, *, config=None, topic: str | None = None,
                poses: str | bool | None = None, strict: bool = False, overwrite: bool = False,
                recording: str | None = None, stop: str | None = None, scans: slice | None = None) -> Result:
    """The task of :func:`extract_many`: every feature of one recording into a file.

    Never raises: what goes wrong is the result's status. The output is written under a
    temporary name and renamed when complete.

    Parameters
    ----------
    path : str or Path
        The recording.
    out : str, Path or None
        A features ``.jsonl`` or a ``.parquet`` table; None: the features are only counted.
    config : Config or None
        The pipeline's configuration; None: ``Config()``.
    topic : str or None
        The scan topic of a bag, as for :func:`labkit.read_scans`.
    poses : str, bool or None
        Where to read poses from, as for :func:`labkit.read_scans`.
    strict : bool
        Stop at the first bad record.
    overwrite : bool
        Replace an existing output.
    recording : str or None
        The ``recording`` column of a table; None: the recording's file name.
    stop : str or None
        The name of the Dask Event that interrupts the task.
    scans : slice or None
        Only this range of scans, numbered as in the whole recording.

    Returns
    -------
    Result
        What the task did.
    """
    from labkit.io import read_scans, write_features
    from labkit.pipeline import Config, extract_features
    from labkit.tables import write_features_table

    config = config or Config()
    halt = _Stop(stop)

    def run(result: Result) -> None:
        halt.check(now=True)  # stopped before it started: nothing is written
        stream = read_scans(path, topic=topic, strict=strict, poses=poses, scans=scans)
        counts = result.counts

        def pairs() -> Iterator:
            for scan in stream:
                halt.check()
                f = extract_features(scan, config)
                for k, v in f.counts().items():
                    counts[k] = counts.get(k, 0) + v
                result.n_scans += 1
                yield scan, f

        result.output = str(out)
        if out is not None and str(out).lower().endswith(".parquet"):
            name = recording or Path(path).name
            _, result.n_rows = write_features_table(pairs(), out, recording=name, method=config.lines.method,
                                                    overwrite=overwrite, inputs=[path], first_scan=stream.first)
        else:
            result.n_rows = write_features(
                (f for _, f in pairs()), out, overwrite=overwrite, inputs=[path], first_scan=stream.first)

    return _guarded(Result(str(path)), run)


def _evaluate_one(path: str | Path, extractors: dict, *, n_scans: int, topic: str | None = None,
                  strict: bool = False, stop: str | None = None, scans: slice | None = None) -> Result:
    """The task of :func:`evaluate_many`: ray-axis RMSE of every extractor on one recording."""
    from labkit.app.experiments import compare_on_logs

    def run(result: Result) -> None:
        damage: list[Exception] = []
        _Stop(stop).check(now=True)
        result.rows = compare_on_logs([path], extractors, n_scans=n_scans, topic=topic, strict=strict,
                                      on_damage=damage.append, scans=scans)
        result.n_scans = result.rows[0]["scans"] if result.rows else 0
        result.n_rows = len(result.rows)
        if damage:
            raise damage[0]

    return _guarded(Result(str(path)), run)


# ---------------------------------------------------------------------------- running tasks
@contextlib.contextmanager
def _sigint_ignored():
    """Ignore SIGINT while the local cluster starts its worker processes. Python leaves SIGINT
    ignored in a process started with it ignored, so Ctrl-C in a terminal (sent to the whole
    process group) reaches only this process, which stops the tasks through their Event: a
    worker killed mid-write would leave a temporary output behind."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    before = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, before)


@contextlib.contextmanager
def _client(workers: int | None, scheduler: str | None, n_tasks: int):
    """A Dask client: to ``scheduler``, or to a local cluster of ``workers`` processes
    (default: one per core, at most ``n_tasks``)."""
    try:
        from distributed import Client, LocalCluster
    except ImportError:
        raise RefusedError("running on Dask needs dask[distributed]: pip install 'labkit[research]' "
                           "(workers=0 runs in this process)",
                           "running on Dask needs dask[distributed]: pip install 'labkit[research]' "
                           "(--workers 0 runs in this process)") from None
    if scheduler:
        try:
            client = Client(scheduler, timeout="10s")
        except OSError as exc:
            raise RefusedError(f"cannot reach the Dask scheduler at {scheduler}: {exc}",
                               f"--scheduler {scheduler}: cannot reach the Dask scheduler: {exc}") from None
        try:
            yield client
        finally:
            client.close()
        return
    n = workers if workers else max(1, min(n_tasks, os.cpu_count() or 1))
    with _sigint_ignored():  # the worker processes inherit it: Ctrl-C reaches this process only
        cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=":0",
                               silence_logs=logging.ERROR)
    try:
        client = Client(cluster)
        try:
            yield client
        finally:
            client.close()
    finally:
        cluster.close()


@contextlib.contextmanager
def _session(workers: int | None, scheduler: str | None, client, n_tasks: int):
    """``(client, threads)``: the Dask client to run on (None: this process) and how many tasks
    it runs at once (the workers' threads), for :func:`split_ranges`."""
    if client is None and workers == 0 and not scheduler:
        yield None, 1
        return
    with contextlib.ExitStack() as stack:
        if client is None:
            client = stack.enter_context(_client(workers, scheduler, n_tasks))
        info = client.scheduler_info()
        threads = sum(w.get("nthreads", 1) for w in info.get("workers", {}).values())
        yield client, max(threads, 1)


def run_tasks(task: Callable[..., Result], jobs: Sequence[dict], *, workers: int | None = None,
              scheduler: str | None = None, client=None, progress: Callable | None = None,
              sizes: Sequence[int | None] | None = None, grace_s: float = 60.0) -> list[Result]:
    """Run ``task(**job)`` for every job, on Dask or (``workers=0``) here; the results in job order.

    Ctrl-C sets the Dask Event every job was given as ``stop``, waits up to ``grace_s`` for the
    jobs to stop (a second Ctrl-C does not wait), and raises KeyboardInterrupt with the
    results so far in its ``results`` attribute.

    Parameters
    ----------
    task : callable
        ``task(**job, stop=name)`` returning a :class:`Result`.
    jobs : sequence of dict
        The keyword arguments of each task.
    workers : int or None
        A local cluster of ``workers`` processes (None: one per core); 0: in this process.
    scheduler : str or None
        The address of an existing Dask scheduler to run on instead.
    client : distributed.Client or None
        A Dask client to use (else one is made: ``scheduler`` or a local cluster).
    progress : callable or None
        A tqdm-like bar factory, ``progress(total=..., unit=...)``, advanced as each job completes.
    sizes : sequence of int or None, or None
        Each job's size (e.g. its scans): the bar advances by it when every one is known, else by 1.
    grace_s : float
        Seconds to wait for the jobs to stop after Ctrl-C.

    Returns
    -------
    list of Result
        The results, in job order.
    """
    known = sizes is not None and all(s is not None for s in sizes)
    steps = [s or 0 for s in sizes] if sizes is not None and known else [1] * len(jobs)
    bar = progress(total=sum(steps), unit="scan" if known else "recording") if progress else None
    results: list[Result | None] = [None] * len(jobs)
    try:
        if workers == 0 and client is None and not scheduler:
            for k, job in enumerate(jobs):
                results[k] = result = task(**job, stop=None)
                if bar is not None:
                    bar.update(steps[k])
                if result.status == "interrupted":  # Ctrl-C here: no further recording
                    interrupted = KeyboardInterrupt()
                    interrupted.results = results  # type: ignore[attr-defined]
                    raise interrupted
            return results  # type: ignore[return-value]
        with contextlib.ExitStack() as stack:
            if client is None:
                client = stack.enter_context(_client(workers, scheduler, len(jobs)))
            _on_dask(client, task, jobs, results, bar, steps, grace_s)
        return results  # type: ignore[return-value]
    finally:
        if bar is not None:
            bar.close()


def _on_dask(client, task, jobs, results, bar, steps, grace_s: float) -> None:
    from distributed import Event, as_completed

    stop = f"labkit-stop-{uuid.uuid4().hex}"
    event = Event(stop, client=client)
    # the longest first, so that no core is left with it at the end: submitted in that order (idle workers
    # take tasks as they come) and with that priority (Dask runs higher priorities first from its queue)
    order = sorted(range(len(jobs)), key=lambda k: -steps[k])
    submitted = {k: client.submit(task, **jobs[k], stop=stop, pure=False, priority=int(steps[k])) for k in order}
    futures = [submitted[k] for k in range(len(jobs))]
    index = {f.key: k for k, f in enumerate(futures)}
    done = as_completed(futures)
    try:
        for future in done:
            results[index[future.key]] = future.result()
            if bar is not None:
                bar.update(steps[index[future.key]])
    except KeyboardInterrupt:
        event.set()
        deadline = time.monotonic() + grace_s
        with contextlib.suppress(KeyboardInterrupt):  # a second Ctrl-C: stop waiting
            for future in futures:
                if results[index[future.key]] is None and not future.done():
                    with contextlib.suppress(Exception):
                        future.result(timeout=max(0.1, deadline - time.monotonic()))
        for future in futures:
            if results[index[future.key]] is None and future.done() and future.status == "finished":
                results[index[future.key]] = future.result()
        for future in futures:
            future.cancel()
        interrupted = KeyboardInterrupt()
        interrupted.results = results  # type: ignore[attr-defined]
        raise interrupted from None
    finally:
        with contextlib.suppress(Exception):
            event.clear()


def _ranges(paths: Sequence[Path], topic, poses, scans: slice | None) -> list[tuple[int | None, int, int | None]]:
    """Open every recording (see :func:`preflight`): ``(scans in the range or None, first, stop)``."""
    from labkit.io import read_scans

    out: list[tuple[int | None, int, int | None]] = []
    for p in paths:
        try:
            stream = read_scans(p, topic=topic, poses=poses, scans=scans)
        except CorruptFileError:
            out.append((None, 0, None))
            continue
        out.append((stream.count, stream.first, stream.stop))
    return out


def preflight(inputs: Sequence[Path], topic: str | None = None, poses: str | bool | None = None,
              scans: slice | None = None) -> list[int | None]:
    """Open every recording before anything runs and say how many scans each holds.

    A refusal (unknown format, a topic it does not have, a pose topic that is not one, a range it
    cannot place) so stops the whole run at once, as for one file.

    Parameters
    ----------
    inputs : sequence of Path
        The recordings.
    topic : str or None
        The scan topic, as for :func:`labkit.read_scans`.
    poses : str, bool or None
        Where to read poses from, as for :func:`labkit.read_scans`.
    scans : slice or None
        Count only this range of each recording.

    Returns
    -------
    list of int or None
        The scans each recording says it holds (in ``scans``, if given); None when it does not
        say, or is too damaged to tell (its task reports that).
    """
    return [n for n, _, _ in _ranges(inputs, topic, poses, scans)]


# ---------------------------------------------------------------------------- many recordings
@dataclass
class _Job:
    """One task: a recording (``k``) or a range of it, and where it writes."""

    k: int
    scans: slice | None
    out: Path
    size: int | None


def _plan(paths: list[Path], ranges, n_workers: int, split: bool, part_of: Callable[[int, int], Path],
          user_scans: slice | None) -> list[_Job]:
    """The tasks: one per recording, or one per range of a recording :func:`split_ranges` cuts
    (those write ``part_of(k, j)``; the others ``part_of(k, -1)``)."""
    sizes = [n for n, _, _ in ranges]
    plan = split_ranges(sizes, n_workers) if split else [None] * len(paths)
    jobs: list[_Job] = []
    for k, (pieces, (n, first, stop)) in enumerate(zip(plan, ranges, strict=True)):
        if pieces is None:
            jobs.append(_Job(k, user_scans, part_of(k, -1), n))
            continue
        for j, (a, b) in enumerate(pieces):
            last = j == len(pieces) - 1
            jobs.append(_Job(k, slice(first + a, stop if last else first + b), part_of(k, j), b - a))
    return jobs


def _merged(path: Path, pieces: list[Result | None]) -> Result:
    """One result for a recording run as several ranges: counts summed, the gravest status, and
    its error (damage: the one of the range read furthest, which has seen every skipped record)."""
    done = [r for r in pieces if r is not None]
    result = Result(str(path))
    if not done:
        result.status, result.error = "interrupted", "interrupted before it started: nothing was written"
        return result
    worst = max((r.status for r in done), key=_GRAVITY.index)
    if len(done) < len(pieces):
        worst = max(worst, "interrupted", key=_GRAVITY.index)
    result.status = worst
    with_error = [r for r in done if r.status == worst]
    result.error = (with_error[-1] if worst == "damaged" else with_error[0]).error if with_error else (
        "interrupted: some of its ranges did not start")
    for r in done:
        result.n_scans += r.n_scans
        result.n_rows += r.n_rows
        result.seconds += r.seconds
        result.peak_rss_mb = max(result.peak_rss_mb, r.peak_rss_mb)
        for key, v in r.counts.items():
            result.counts[key] = result.counts.get(key, 0) + v
    result.worker = ", ".join(dict.fromkeys(r.worker for r in done))
    return result


def _check_seen(result: Result, written: Path) -> None:
    """A task on a Dask worker said it wrote ``written``: make sure this machine sees it."""
    if result.status in ("done", "damaged") and result.worker != "local" and not written.exists():
        result.status = "system"
        result.error = (f"{written} was written by the Dask worker {result.worker} but this machine does not see it: "
                        "the workers and this machine must share the output folder under the same path")
        result.output = None


def extract_many(inputs: Iterable[str | Path], out: str | Path, *, config=None, topic: str | None = None,
                 poses: str | bool | None = None, strict: bool = False, overwrite: bool = False,
                 workers: int | None = None, scheduler: str | None = None, client=None,
                 progress: Callable | None = None, scans: slice | None = None, split: bool = True) -> list[Result]:
    """Every feature of many recordings on Dask: one task per recording, or per scan range of a long one.

    See the module's docstring for where and how the tasks run.

    Parameters
    ----------
    inputs : iterable of paths
        Recordings, or folders of recordings (:func:`recordings_in`). Made absolute here.
    out : path
        A folder (one ``<name>.features.jsonl`` per input; missing folders are made), or a
        ``.parquet`` file: one table for all, rows in input order with a ``recording`` column.
    config : Config or None
        The pipeline's configuration, as for :func:`labkit.extract_features`; None: ``Config()``.
    topic : str or None
        The scan topic of a bag, as for :func:`labkit.read_scans`.
    poses : str, bool or None
        Where to read poses from, as for :func:`labkit.read_scans`.
    strict : bool
        Stop reading a recording at its first bad record, as for :func:`labkit.read_scans`.
    overwrite : bool
        Replace existing outputs (only labkit's own kind of file).
    workers : int or None
        A local cluster of ``workers`` processes (None: one per core); ``workers=0`` runs in
        this process.
    scheduler : str or None
        The address of an existing Dask scheduler to run on instead.
    client : distributed.Client or None
        A Dask client to run on instead.
    progress : callable, optional
        A tqdm-like bar factory (``progress(total=..., unit=...)``) advanced as tasks finish.
    scans : slice, optional
        Only this range of every recording (as :func:`labkit.read_scans` takes it).
    split : bool
        Split a long recording into scan ranges, one task each (:func:`split_ranges`), when
        there are several workers. The output is the same either way.

    Returns
    -------
    list of Result
        One per recording, in input order. Nothing is raised for one recording's trouble: see
        each status. Every output is checked before anything runs (an existing output without
        ``overwrite``, an output that is an input: :class:`labkit.errors.RefusedError`).
    """
    from labkit.io.feature_files import FEATURES_FILE
    from labkit.pipeline import Config

    config = config or Config()
    paths = [_absolute(p) for p in recordings_in(inputs)]
    out = _absolute(out)
    ranges = _ranges(paths, topic, poses, scans)
    common = {"config": config, "topic": topic, "poses": poses, "strict": strict}
    table = str(out).lower().endswith(".parquet")
    if table:
        from labkit.tables import PARQUET_FILE

        check_output(out, PARQUET_FILE, overwrite=overwrite, inputs=paths)
    else:
        outs = output_paths(paths, out)
        for o in outs:
            check_output(o, FEATURES_FILE, overwrite=overwrite, inputs=paths)
    n_hint = max(len(paths), sum(n or 0 for n, _, _ in ranges) // MIN_PIECE_SCANS)
    with _session(workers, scheduler, client, n_hint) as (session, n_workers):
        where = {"client": session, "workers": 0 if session is None else None, "progress": progress}
        if table:
            return _one_table(paths, out, ranges, common, overwrite=overwrite, n_workers=n_workers, split=split,
                              scans=scans, where=where)
        return _one_per_input(paths, outs, ranges, common, overwrite=overwrite, n_workers=n_workers, split=split,
                              scans=scans, where=where)


class _Scratch:
    """A hidden folder beside the outputs for the parts of split recordings (``.parts.labkit-XXXX``),
    made when first needed and removed at the end, with the folders made for it if left empty."""

    def __init__(self, folder: Path) -> None:
        self.folder = folder
        self.path: Path | None = None
        self.created: list[Path] = []

    def part(self, name: str) -> Path:
        if self.path is None:
            self.created = make_parents(self.folder)
            self.path = Path(tempfile.mkdtemp(prefix=f".parts{TEMP_MARK}", dir=self.folder))
        return self.path / name

    def remove(self) -> None:
        if self.path is not None:
            shutil.rmtree(self.path, ignore_errors=True)
            remove_empty(self.created)


def _partial_of(part: Path) -> Path:
    """Where an interrupted task kept what it wrote of ``part`` (labkit._safe's partial name)."""
    from labkit.io.feature_files import FEATURES_FILE

    return partial_name(part, FEATURES_FILE)


def _one_per_input(paths, outs, ranges, common, *, overwrite, n_workers, split, scans, where) -> list[Result]:
    """One features file per recording; a split recording's ranges write parts, joined here."""
    from labkit.io.feature_files import FEATURES_FILE

    scratch = _Scratch(outs[0].parent)
    try:
        jobs = _plan(paths, ranges, n_workers, split,
                     lambda k, j: outs[k] if j < 0 else scratch.part(f"{k:05d}-{j:05d}.features.jsonl"), scans)
        task_jobs = [{"path": str(paths[j.k]), "out": str(j.out), "scans": j.scans,
                      "overwrite": overwrite and j.out == outs[j.k], **common} for j in jobs]
        interrupted = None
        try:
            done = run_tasks(extract_one, task_jobs, sizes=[j.size for j in jobs], **where)
        except KeyboardInterrupt as exc:
            interrupted, done = exc, list(getattr(exc, "results", [None] * len(jobs)))
        results: list[Result | None] = []
        for k, path in enumerate(paths):
            mine = [(job, r) for job, r in zip(jobs, done, strict=True) if job.k == k]
            if len(mine) == 1 and mine[0][0].out == outs[k]:
                r = mine[0][1]
                if r is not None and r.output is not None:
                    _check_seen(r, Path(r.output))
                results.append(r)
                continue
            for job, r in mine:
                if r is not None:
                    _check_seen(r, job.out if r.status != "interrupted" else _partial_of(job.out))
            result = _merged(path, [r for _, r in mine])
            results.append(result)
            if result.status in ("done", "damaged"):
                try:
                    _join_lines([job.out for job, _ in mine], outs[k], FEATURES_FILE, overwrite, path)
                    result.output = str(outs[k])
                except OSError as exc:  # joining the parts failed (a full disk): nothing of it is in place
                    result.status, result.output = "system", None
                    result.error = f"{exc.filename or outs[k]}: {exc.strerror or exc}"
            elif result.status == "interrupted":
                parts = [p for job, _ in mine for p in (job.out, _partial_of(job.out)) if p.exists()]
                result.output = None
                if parts:
                    try:
                        _join_lines(parts, outs[k], FEATURES_FILE, overwrite, path, interrupted=True)
                    except OutputInterrupted as exc:
                        result.output = str(exc.partial) if exc.partial else None
                        result.error = f"interrupted: {exc.target} was not changed" + (
                            f"; what was written so far is in {exc.partial}" if exc.partial else "")
            else:
                result.output = None
    finally:
        scratch.remove()
    if interrupted is not None:
        interrupted.results = results  # type: ignore[attr-defined]
        raise interrupted
    return results  # type: ignore[return-value]


def _join_lines(parts: list[Path], out: Path, kind, overwrite: bool, source: Path, interrupted: bool = False) -> None:
    """Concatenate JSON-lines parts, in order, into ``out`` (through labkit._safe); ``interrupted``:
    into ``out``'s partial name."""
    with safe_output(out, kind, overwrite=overwrite, inputs=[source]) as tmp:
        with open(tmp, "wb") as fh:
            for part in parts:
                with open(part, "rb") as src:
                    shutil.copyfileobj(src, fh)
        if interrupted:
            raise KeyboardInterrupt


class _NothingRead(Exception):
    """No recording could be read: the joined table is not written."""


def _one_table(paths: list[Path], out: Path, ranges, common: dict, *, overwrite: bool, n_workers: int, split: bool,
               scans, where) -> list[Result]:
    """One Parquet table for many recordings: each task writes its part in a scratch folder
    beside ``out``; the parts are joined in input order into ``out`` (through labkit._safe).
    When no recording could be read, nothing is written."""
    from labkit.tables import PARQUET_FILE, research_module

    pq = research_module("pyarrow.parquet")
    results: list[Result | None] = []
    interrupted = None
    try:
        with safe_output(out, PARQUET_FILE, overwrite=overwrite, inputs=paths) as tmp:
            parts = Path(tempfile.mkdtemp(prefix=".parts-", dir=tmp.parent))
            jobs = _plan(paths, ranges, n_workers, split,
                         lambda k, j: parts / f"part-{k:05d}-{max(j, 0):05d}.parquet", scans)
            task_jobs = [{"path": str(paths[j.k]), "out": str(j.out), "recording": paths[j.k].name, "scans": j.scans,
                          **common} for j in jobs]
            try:
                done = run_tasks(extract_one, task_jobs, sizes=[j.size for j in jobs], **where)
            except KeyboardInterrupt as exc:
                interrupted, done = exc, list(getattr(exc, "results", [None] * len(jobs)))
            for job, r in zip(jobs, done, strict=True):
                if r is not None:
                    _check_seen(r, job.out)
            results = [_merged(path, [r for job, r in zip(jobs, done, strict=True) if job.k == k])
                       if sum(job.k == k for job in jobs) > 1 else
                       next(r for job, r in zip(jobs, done, strict=True) if job.k == k)
                       for k, path in enumerate(paths)]
            read = [job.out for job, r in zip(jobs, done, strict=True)
                    if r is not None and r.status in ("done", "damaged") and job.out.exists()]
            if interrupted is None:  # a recording's parts are joined only when all of them were read
                whole = {k for k, r in enumerate(results) if r is not None and r.status in ("done", "damaged")}
                read = [job.out for job in jobs if job.k in whole]
            if not read:
                raise _NothingRead
            writer = None
            try:
                for part in read:  # in input order, row group by row group: memory stays flat
                    pf = pq.ParquetFile(part)
                    if writer is None:
                        writer = pq.ParquetWriter(tmp, pf.schema_arrow)
                    for i in range(pf.num_row_groups):
                        writer.write_table(pf.read_row_group(i))
            finally:
                if writer is not None:
                    writer.close()
                shutil.rmtree(parts, ignore_errors=True)
            for res in results:
                if res is not None:
                    res.output = str(out) if res.status in ("done", "damaged") else None
            if interrupted is not None:
                raise interrupted
    except _NothingRead:
        for res in results:
            if res is not None:
                res.output = None
        if interrupted is not None:
            interrupted.results = results  # type: ignore[attr-defined]
            raise interrupted from None
    except OutputInterrupted as exc:
        exc.results = results  # type: ignore[attr-defined]
        raise
    return results  # type: ignore[return-value]


def evaluate_many(inputs: Iterable[str | Path], extractors: dict, *, n_scans: int = 100, topic: str | None = None,
                  strict: bool = False, workers: int | None = None, scheduler: str | None = None, client=None,
                  progress: Callable | None = None, scans: slice | None = None) -> list[Result]:
    """:func:`labkit.app.experiments.compare_on_logs` on many recordings, one task per recording, on Dask.

    Parameters
    ----------
    inputs : iterable of str or Path
        Recordings, or folders of recordings (:func:`recordings_in`).
    extractors : dict
        Name -> line extractor, as for :func:`labkit.app.experiments.compare_on_logs`.
    n_scans : int
        The first so many scans of each recording.
    topic : str or None
        The scan topic, as for :func:`labkit.read_scans`.
    strict : bool
        Stop at the first bad record.
    workers : int or None
        Where to run, as for :func:`extract_many`.
    scheduler : str or None
        Where to run, as for :func:`extract_many`.
    client : distributed.Client or None
        Where to run, as for :func:`extract_many`.
    progress : callable or None
        A tqdm-like bar factory, as for :func:`run_tasks`.
    scans : slice or None
        Score this range of every recording instead of its first ``n_scans``.

    Returns
    -------
    list of Result
        One per recording, in order; each result's ``rows`` are that recording's table rows.
    """
    paths = [_absolute(p) for p in recordings_in(inputs)]
    sizes = preflight(paths, topic, scans=scans)
    if scans is not None:
        n_scans = 0
    jobs = [{"path": str(p), "extractors": extractors, "n_scans": n_scans, "topic": topic, "strict": strict,
             "scans": scans} for p in paths]
    return run_tasks(_evaluate_one, jobs, workers=workers, scheduler=scheduler, client=client, progress=progress,
                     sizes=[n_scans] * len(paths) if scans is None else sizes)


def report(results: Sequence[Result], file=None) -> int:
    """Print one ``labkit: error:`` line per recording that did not finish cleanly and return the exit status.

    A bug prints its traceback.

    Parameters
    ----------
    results : sequence of Result
        The results of a run.
    file : file-like or None
        Where to print; None: standard error.

    Returns
    -------
    int
        The exit status of the whole run: that of the gravest status (``STATUS``).
    """
    file = file or sys.stderr
    for r in results:
        if r.status == "done":
            continue
        if r.status == "bug":
            print(r.error, file=file, end="")
            print(f"labkit: internal error while reading {r.input}: this is a bug in labkit; please report it "
                  "with the command you ran, `labkit --version` and the traceback above", file=file)
        elif r.status == "interrupted":
            print(f"labkit: {r.error} ({r.input})", file=file)
        else:
            print(f"labkit: error: {r.error}", file=file)
    worst = max((r.status for r in results), key=_GRAVITY.index, default="done")
    return STATUS[worst]

"""Many recordings, many cores, many machines: ``labkit extract`` and ``labkit evaluate`` on Dask.

A recording is the unit of work. Every task reads one recording, runs the pipeline on it and
writes its output itself, through :mod:`labkit._safe` (so a failed or interrupted task leaves
no half file), then returns a small :class:`Result`: counts, seconds, peak memory, and the
one-line error of a damaged or failed recording. The tasks run on

- a local Dask cluster by default: ``workers`` processes with one thread each
  (``distributed.LocalCluster(n_workers=workers, threads_per_worker=1, processes=True)``;
  default: one per core, at most one per recording);
- an existing Dask scheduler, ``scheduler="tcp://host:8786"``, for a real cluster: the
  workers read the inputs and write the outputs by their paths, so those must be on a file
  system every worker sees (the same paths on every machine);
- this process, one recording after another, with ``workers=0`` (no Dask at all).

Outputs: one per input (``<out>/<name>.features.jsonl`` or ``.parquet``, ``<name>`` being the
recording's name without its suffix), or one Parquet table for all (``out`` ending in
``.parquet``: each task writes its part, and the parts are joined in input order). The results
are the same as a serial run's, row for row (stage timings aside, which differ from run to run).

One damaged recording is reported and the others go on; a recording that cannot be read at
all (refused, a system error, a bug) is reported the same way. Ctrl-C asks every running task to
stop (a Dask ``Event`` the tasks look at twice a second): each keeps what it wrote as
``<name>.partial.<suffix>`` and the outputs already finished stay.

A single very long recording is one task: it runs on one core. Split it first if that matters
(``labkit convert`` a range of it), or run several recordings at once.
"""

from __future__ import annotations

import contextlib
import logging
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

from ._safe import OutputInterrupted, check_output, safe_output
from .errors import CorruptFileError, RefusedError

__all__ = ["Result", "recordings_in", "output_paths", "preflight", "extract_many", "evaluate_many", "extract_one",
           "run_tasks", "report"]

#: Exit statuses of the command line (README, "When things go wrong"), per result.
STATUS = {"done": 0, "damaged": 1, "refused": 2, "system": 3, "bug": 70, "interrupted": 130}
_CHECK_EVERY_S = 0.5


@dataclass
class Result:
    """What one task did with one recording.

    Attributes
    ----------
    input : str
    output : str or None
        What it wrote (None: nothing, or a part of a joined table).
    status : str
        ``done``, ``damaged`` (the output holds every readable scan), ``refused``, ``system``,
        ``bug`` or ``interrupted`` (the partial output is ``output``); :data:`STATUS` gives the
        exit status of each.
    error : str or None
        The one-line error (a bug: the traceback).
    n_scans, n_rows : int
        Scans read; rows (table) or records (JSON lines) written.
    counts : dict
        Features found, summed over the scans.
    seconds : float
        Wall time of the task.
    peak_rss_mb : float
        Peak resident memory of the process that ran it, MiB (since that process started).
    worker : str
        Where it ran (the Dask worker's address, or ``"local"``).
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
    from .io.formats import recording_suffixes

    return p.name.lower().endswith(recording_suffixes(in_folders_only=True))


def recordings_in(paths: Iterable[str | Path]) -> list[Path]:
    """The recordings to run on: every path given that is a file or a ROS2 bag folder, and the
    recordings inside every other folder given (bags, MCAP files, ROS2 bag folders and CARMEN
    logs, sorted by name; JSON scans only when named, since a folder's ``.jsonl`` files may be
    labkit's own features). A folder that holds none, or a path that does not exist, is refused."""
    out: list[Path] = []
    for raw in paths:
        p = Path(raw)
        if not p.exists():
            raise RefusedError(f"{p} does not exist")
        if p.is_dir() and not (p / "metadata.yaml").is_file():
            found = sorted(q for q in p.iterdir() if _is_recording(q))
            if not found:
                from .io import FORMATS

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


def _stem(p: Path) -> str:
    name = p.name
    low = name.lower()
    from .io.formats import recording_suffixes

    for end in sorted(recording_suffixes(), key=len, reverse=True):
        if low.endswith(end):
            return name[: -len(end)]
    return name


def output_paths(inputs: Sequence[Path], folder: str | Path, suffix: str = ".features.jsonl") -> list[Path]:
    """One output per input in ``folder``: ``<name>.features.jsonl`` (or ``suffix``), ``<name>``
    the recording's name without its suffix. Two inputs of one name are refused."""
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


# ---------------------------------------------------------------------------- one task
def _peak_rss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0  # Linux: KiB


class _Stop:
    """Raises KeyboardInterrupt inside a task once the client set the Dask Event ``name``
    (looked at twice a second, not per scan: each look is a round trip to the scheduler)."""

    def __init__(self, name: str | None) -> None:
        self.name, self.next = name, time.monotonic() + _CHECK_EVERY_S
        self.event = None

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
    except OSError as exc:
        result.status, result.error = "system", (f"{exc.filename}: {exc.strerror}" if exc.filename and exc.strerror
                                                 else exc.strerror or str(exc))
    except ValueError as exc:  # bad input labkit names (a malformed scan, an empty bag)
        result.status, result.error = "refused", str(exc)
    except Exception:  # noqa: BLE001 - a bug: its traceback goes to the report
        result.status, result.error = "bug", traceback.format_exc()
    result.seconds = time.perf_counter() - t0
    result.peak_rss_mb = _peak_rss_mb()
    result.worker = _where()
    return result


def extract_one(path: str | Path, out: str | Path | None, *, config=None, topic: str | None = None,
                poses: str | bool | None = None, strict: bool = False, overwrite: bool = False,
                recording: str | None = None, stop: str | None = None) -> Result:
    """The task of :func:`extract_many`: every feature of one recording into ``out`` (a features
    ``.jsonl`` or a ``.parquet`` table, through :mod:`labkit._safe`). Never raises: what goes
    wrong is the result's status. ``stop`` is the name of the Dask Event that interrupts it."""
    from .io import read_scans, write_features
    from .pipeline import Config, extract_features
    from .tables import write_features_table

    config = config or Config()
    halt = _Stop(stop)

    def run(result: Result) -> None:
        halt.check(now=True)  # stopped before it started: nothing is written
        stream = read_scans(path, topic=topic, strict=strict, poses=poses)
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
        if str(out).lower().endswith(".parquet"):
            name = recording or Path(path).name
            _, result.n_rows = write_features_table(pairs(), out, recording=name, method=config.lines.method,
                                                    overwrite=overwrite, inputs=[path])
        else:
            result.n_rows = write_features(
                (f for _, f in pairs()), out, overwrite=overwrite, inputs=[path])

    return _guarded(Result(str(path)), run)


def _evaluate_one(path: str | Path, extractors: dict, *, n_scans: int, topic: str | None = None,
                  strict: bool = False, stop: str | None = None) -> Result:
    """The task of :func:`evaluate_many`: ray-axis RMSE of every extractor on one recording."""
    from .experiments import compare_on_logs

    def run(result: Result) -> None:
        damage: list[Exception] = []
        _Stop(stop).check(now=True)
        result.rows = compare_on_logs([path], extractors, n_scans=n_scans, topic=topic, strict=strict,
                                      on_damage=damage.append)
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
    """A Dask client: to ``scheduler``, or to a local cluster of ``workers`` processes."""
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


def run_tasks(task: Callable[..., Result], jobs: Sequence[dict], *, workers: int | None = None,
              scheduler: str | None = None, client=None, progress: Callable | None = None,
              sizes: Sequence[int | None] | None = None, grace_s: float = 60.0) -> list[Result]:
    """Run ``task(**job)`` for every job, on Dask or (``workers=0``) here; the results in job order.

    ``client``: a ``distributed.Client`` to use (else one is made: ``scheduler`` or a local
    cluster). ``progress(total=..., unit=...)`` is a tqdm-like bar factory, advanced by each
    job's size (``sizes``, e.g. its scans, when every one is known; else by 1) as it completes.
    Ctrl-C sets the Dask Event every job was given as ``stop``, waits up to ``grace_s`` for the
    jobs to stop (a second Ctrl-C does not wait), and raises KeyboardInterrupt with the
    results so far in its ``results`` attribute.
    """
    known = sizes is not None and all(s is not None for s in sizes)
    steps = list(sizes) if known else [1] * len(jobs)
    bar = progress(total=sum(steps), unit="scan" if known else "recording") if progress else None
    results: list[Result | None] = [None] * len(jobs)
    try:
        if workers == 0 and client is None and not scheduler:
            for k, job in enumerate(jobs):
                results[k] = task(**job, stop=None)
                if bar is not None:
                    bar.update(steps[k])
                if results[k].status == "interrupted":  # Ctrl-C here: no further recording
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
    # the longest first (Dask runs higher priorities first), so that no core is left with it at the end
    futures = [client.submit(task, **job, stop=stop, pure=False, priority=int(size))
               for job, size in zip(jobs, steps, strict=True)]
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


def preflight(inputs: Sequence[Path], topic: str | None = None, poses: str | bool | None = None) -> list[int | None]:
    """Open every recording before anything runs, so that a refusal (unknown format, a topic it
    does not have, a pose topic that is not one) stops the whole run at once, as for one file;
    return how many scans each says it holds (None when it does not say, or is too damaged to tell:
    its task reports that)."""
    from .io import read_scans

    sizes: list[int | None] = []
    for p in inputs:
        try:
            sizes.append(read_scans(p, topic=topic, poses=poses).count)
        except CorruptFileError:
            sizes.append(None)
    return sizes


def extract_many(inputs: Iterable[str | Path], out: str | Path, *, config=None, topic: str | None = None,
                 poses: str | bool | None = None, strict: bool = False, overwrite: bool = False,
                 workers: int | None = None, scheduler: str | None = None, client=None,
                 progress: Callable | None = None) -> list[Result]:
    """Every feature of many recordings, one task per recording, on Dask (module docstring).

    Parameters
    ----------
    inputs : iterable of paths
        Recordings, or folders of recordings (:func:`recordings_in`).
    out : path
        A folder (one ``<name>.features.jsonl`` per input; missing folders are made), or a
        ``.parquet`` file: one table for all, rows in input order with a ``recording`` column.
    config, topic, poses, strict
        As for :func:`labkit.extract_features` and :func:`labkit.read_scans`.
    overwrite : bool
        Replace existing outputs (only labkit's own kind: see :mod:`labkit._safe`).
    workers, scheduler, client
        Where to run: a local cluster of ``workers`` processes (default: one per core),
        ``workers=0`` in this process, an existing scheduler's address, or a ``distributed.Client``.
    progress : callable, optional
        A tqdm-like bar factory (``progress(total=..., unit=...)``) advanced as recordings finish.

    Returns
    -------
    list of Result
        In input order. Nothing is raised for one recording's trouble: see each status. Every
        output is checked before anything runs (an existing output without ``overwrite``, an
        output that is an input: :class:`labkit.errors.RefusedError`).
    """
    from .io.features import FEATURES_FILE
    from .pipeline import Config

    config = config or Config()
    paths = recordings_in(inputs)
    sizes = preflight(paths, topic, poses)
    common = {"config": config, "topic": topic, "poses": poses, "strict": strict}
    if str(out).lower().endswith(".parquet"):
        return _one_table(paths, Path(out), common, overwrite=overwrite, workers=workers, scheduler=scheduler,
                          client=client, progress=progress, sizes=sizes)
    outs = output_paths(paths, out)
    for o in outs:
        check_output(o, FEATURES_FILE, overwrite=overwrite, inputs=paths)
    jobs = [{"path": str(p), "out": str(o), "overwrite": overwrite, **common} for p, o in zip(paths, outs, strict=True)]
    return run_tasks(extract_one, jobs, workers=workers, scheduler=scheduler, client=client, progress=progress,
                     sizes=sizes)


def _one_table(paths: list[Path], out: Path, common: dict, *, overwrite: bool, workers, scheduler, client, progress,
               sizes) -> list[Result]:
    """One Parquet table for many recordings: each task writes its part in a scratch folder
    beside ``out``; the parts are joined in input order into ``out`` (through labkit._safe)."""
    from .tables import PARQUET_FILE, _need

    pq = _need("pyarrow.parquet")
    with safe_output(out, PARQUET_FILE, overwrite=overwrite, inputs=paths) as tmp:
        parts = Path(tempfile.mkdtemp(prefix=".parts-", dir=tmp.parent))
        names = [f"part-{k:05d}.parquet" for k in range(len(paths))]
        jobs = [{"path": str(p), "out": str(parts / n), "recording": p.name, **common}
                for p, n in zip(paths, names, strict=True)]
        interrupted = None
        try:
            results = run_tasks(extract_one, jobs, workers=workers, scheduler=scheduler, client=client,
                                progress=progress, sizes=sizes)
        except KeyboardInterrupt as exc:
            interrupted, results = exc, [r for r in getattr(exc, "results", []) if r is not None]
        written = [parts / n for n in names if (parts / n).exists()]
        writer = None
        try:
            for part in written:  # in input order, row group by row group: memory stays flat
                pf = pq.ParquetFile(part)
                if writer is None:
                    writer = pq.ParquetWriter(tmp, pf.schema_arrow)
                for i in range(pf.num_row_groups):
                    writer.write_table(pf.read_row_group(i))
            if writer is None:  # no recording gave a table: an empty one, with the columns
                _empty_table(tmp, pq)
        finally:
            if writer is not None:
                writer.close()
            shutil.rmtree(parts, ignore_errors=True)
        for r in results:
            if r is not None:
                r.output = str(out) if r.status in ("done", "damaged") else None
        if interrupted is not None:
            raise interrupted
    return results


def _empty_table(path: Path, pq) -> None:
    from .tables import _schema

    pq.write_table(_schema(True, True).empty_table(), path)


def evaluate_many(inputs: Iterable[str | Path], extractors: dict, *, n_scans: int = 100, topic: str | None = None,
                  strict: bool = False, workers: int | None = None, scheduler: str | None = None, client=None,
                  progress: Callable | None = None) -> list[Result]:
    """:func:`labkit.experiments.compare_on_logs` on many recordings, one task per recording, on
    Dask (see :func:`extract_many` for where); each result's ``rows`` are that recording's."""
    paths = recordings_in(inputs)
    preflight(paths, topic)
    jobs = [{"path": str(p), "extractors": extractors, "n_scans": n_scans, "topic": topic, "strict": strict}
            for p in paths]
    return run_tasks(_evaluate_one, jobs, workers=workers, scheduler=scheduler, client=client, progress=progress,
                     sizes=[n_scans] * len(paths))


def report(results: Sequence[Result], file=None) -> int:
    """Print one ``labkit: error:`` line per recording that did not finish cleanly (a bug: its
    traceback) and return the exit status of the whole run: the gravest of them."""
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
    order = ["done", "damaged", "refused", "system", "interrupted", "bug"]
    worst = max((r.status for r in results), key=order.index, default="done")
    return STATUS[worst]

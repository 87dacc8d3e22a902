"""Time the pipeline on a recording, stage by stage and phase by phase (read, extract, log).

:func:`time_recording` is what ``labkit bench`` prints and what ``benchmarks/pipeline.py``'s
end-to-end part measures: one streaming pass that reads a scan, extracts its features and
hands both to the rerun logger, with the time of each phase kept apart.

>>> from labkit.app.data import bundled_data
>>> result = time_recording(bundled_data("hall.bag"), n_scans=30, warmup=5)
>>> result.n_scans, "lines" in result.stages
(30, True)
"""

from __future__ import annotations

import itertools
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from labkit.errors import RefusedError
from labkit.io import read_scans
from labkit.pipeline import Config, extract_features

__all__ = ["BenchResult", "time_recording"]


@dataclass
class BenchResult:
    """What one timed pass over a recording measured (times in seconds).

    Parameters
    ----------
    source : Path
        The recording timed.
    method : str
        The line extractor of the config (``config.lines.method``).
    n_scans : int
        Scans read and extracted.
    n_beams : int
        Beams per scan (of the last scan read).
    read_s : float
        Seconds spent reading scans.
    extract_s : float
        Seconds spent extracting features (warm-up passes not counted).
    total_s : float
        Seconds of the whole pass: reading, extracting and logging to the .rrd.
    stages : dict of str to ndarray
        Per pipeline stage, its time in seconds on every scan (``Features.timings``).
    error : Exception or None
        The :class:`labkit.CorruptFileError` of a damaged recording (what
        :func:`labkit.viz.rr.record_scans` reports), else None.
    kind : str
        What was read, for the report: ``".bag"``, ``"CARMEN .log/.gz"``, ...
    """

    source: Path
    method: str
    n_scans: int = 0
    n_beams: int = 0
    read_s: float = 0.0
    extract_s: float = 0.0
    total_s: float = 0.0
    stages: dict[str, np.ndarray] = field(default_factory=dict)
    error: Exception | None = None  # a CorruptFileError (what record_scans reports)
    kind: str = "recording"  # what was read, for the report: ".bag", "CARMEN .log/.gz", ...

    @property
    def log_s(self) -> float:
        """Time spent writing the .rrd: the pass's total less reading and extracting."""
        return max(self.total_s - self.read_s - self.extract_s, 1e-9)

    def rates(self) -> dict[str, float]:
        """Scans per second of each phase and of the whole pass."""
        n = self.n_scans
        return {"read": n / max(self.read_s, 1e-9), "extract": n / max(self.extract_s, 1e-9),
                "log": n / self.log_s, "all": n / max(self.total_s, 1e-9)}

    def report(self) -> str:
        """The table ``labkit bench`` prints: per stage median, mean, p99 and share; phase rates."""
        lines = [f"labkit bench: {self.n_scans} scans of {self.n_beams} beams from {self.source}, "
                 f"lines by {self.method}",
                 f"{'stage':14s} {'median us':>10s} {'mean us':>10s} {'p99 us':>10s} {'share':>7s}"]
        total = float(np.sum(self.stages["total"]))
        for name, v in self.stages.items():
            us = v * 1e6
            lines.append(f"{name:14s} {np.median(us):10.0f} {us.mean():10.0f} {np.percentile(us, 99):10.0f} "
                         f"{v.sum() / total:7.1%}")
        r = self.rates()
        lines.append(f"read {r['read']:,.0f} scans/s | extract {r['extract']:,.0f} scans/s | "
                     f"log .rrd {r['log']:,.0f} scans/s | {self.kind} -> features -> .rrd {r['all']:,.0f} scans/s")
        return "\n".join(lines)


def time_recording(source: str | Path, config: Config | None = None, *, topic: str | None = None,
                   strict: bool = False, n_scans: int | None = None, warmup: int = 20,
                   scans: slice | None = None) -> BenchResult:
    """Read a recording, extract every scan's features and log both to a temporary .rrd, timing each phase.

    Raises :class:`labkit.errors.RefusedError` when the recording holds no scans; a damaged recording is
    timed on what could be read and its error kept in ``result.error``.

    Parameters
    ----------
    source : str or Path
        The recording (any format :func:`labkit.read_scans` reads).
    config : Config or None
        The pipeline's configuration; None: ``Config()``.
    topic : str or None
        The scan topic of a bag; None: the only one.
    strict : bool
        Stop at the first bad record instead of skipping it.
    n_scans : int or None
        Only the first so many scans; None: all.
    warmup : int
        The first ``warmup`` scans are also extracted once untimed (caches, lazy imports).
    scans : slice or None
        Only this range of scans (a slice, as :func:`labkit.read_scans` takes it).

    Returns
    -------
    BenchResult
        The counts, phase times and per-stage times of the pass.
    """
    from labkit.viz import rr as lkrr  # the logger is a consumer, imported when timing

    config = config or Config()
    source = Path(source)
    from labkit.io import FORMATS

    stream = read_scans(source, topic=topic, strict=strict, scans=scans)
    items = iter(stream)
    if n_scans is not None:
        items = itertools.islice(items, n_scans)
    result = BenchResult(source, config.lines.method, kind=FORMATS[stream.format].label)
    stages: dict[str, list[float]] = {}

    def timed():  # one streaming pass: read a scan, extract its features, hand both to the logger
        warm = 0
        while True:
            t0 = time.perf_counter()
            scan = next(items, None)
            t1 = time.perf_counter()
            if scan is None:
                return
            if warm < warmup:
                extract_features(scan, config)
                warm += 1
            t2 = time.perf_counter()
            f = extract_features(scan, config)
            t3 = time.perf_counter()
            result.read_s += t1 - t0
            result.extract_s += t3 - t2
            for k, v in f.timings.items():
                stages.setdefault(k, []).append(v)
            result.n_beams = scan.n_beams
            yield scan, f

    with tempfile.TemporaryDirectory() as tmp:
        for_scans, for_features = itertools.tee(timed())  # zipped in step: tee holds one pair at a time
        t0 = time.perf_counter()
        summary = lkrr.record_scans((scan for scan, _ in for_scans), Path(tmp) / "bench.rrd", name=source.name,
                                    features=(f for _, f in for_features), start_index=stream.first)
        result.total_s = time.perf_counter() - t0
    result.n_scans = summary.n_scans
    result.error = summary.error
    if not result.n_scans:
        raise RefusedError(f"{source} holds no scans" + (f" ({summary.error})" if summary.error else ""))
    result.stages = {k: np.asarray(v) for k, v in stages.items()}
    return result

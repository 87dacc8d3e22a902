"""The main job on one recording: every scan through the pipeline, into a rerun file and a figure.

``make demo`` and ``labkit demo`` call :func:`run_demo`; the command line only prints its
:meth:`DemoResult.report`. :func:`richest_scan` picks the scan the figure shows.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from labkit import sim
from labkit._safe import OutputKind, check_output, safe_output, starts_with
from labkit.errors import CorruptFileError, RefusedError
from labkit.features import Features
from labkit.io import read_scans
from labkit.pipeline import Config, extract_features
from labkit.scan import Scan

__all__ = ["DemoResult", "PNG_FILE", "richest_scan", "run_demo"]

#: The figure ``labkit demo`` writes (see labkit._safe).
PNG_FILE = OutputKind("a PNG image (.png)", (".png",), starts_with(b"\x89PNG\r\n\x1a\n"))


def richest_scan(features: list[Features]) -> int:
    """The scan with the most kinds of feature (lines, circles, legs, ...); ties: the middle one.

    Parameters
    ----------
    features : list of Features
        The features of each scan, in order.

    Returns
    -------
    int
        The index of that scan in ``features``.

    Examples
    --------
    >>> from types import SimpleNamespace as F
    >>> f = lambda **k: F(LAYERS=("lines", "legs"), **{"lines": [], "legs": [], **k})
    >>> richest_scan([f(lines=[1]), f(lines=[1], legs=[1]), f(lines=[1], legs=[1]), f(lines=[1], legs=[1])])
    2
    """
    if not features:
        raise ValueError("no scans to choose from")
    kinds = np.array([sum(bool(getattr(f, k)) for k in f.LAYERS) for f in features])
    best = np.flatnonzero(kinds == kinds.max())
    return int(best[len(best) // 2])


@dataclass
class DemoResult:
    """What :func:`run_demo` did: counts, median stage times, phase rates and the files written.

    Parameters
    ----------
    source : Path
        The recording shown.
    rrd : Path
        The rerun recording written (``out/demo.rrd``).
    png : Path
        The picture of the richest scan written (``out/demo.png``).
    n_scans : int
        Scans logged.
    n_beams : int
        Beams per scan (of the first scan).
    method : str
        The line extractor used.
    scan_shown : int
        The index of the scan in the picture (:func:`richest_scan`).
    per_scan : dict of str to float
        Mean count per scan of each kind of feature.
    stage_us : dict of str to float
        Median microseconds per scan of each pipeline stage.
    seconds : dict of str to float
        Seconds of each phase: ``"read"``, ``"extract"``, ``"rrd"``.
    n_truth : int
        Scans logged with their ground truth.
    damage : CorruptFileError or None
        The error of a damaged recording (shown on what could be read), else None.
    """

    source: Path
    rrd: Path
    png: Path
    n_scans: int
    n_beams: int
    method: str
    scan_shown: int
    per_scan: dict[str, float]
    stage_us: dict[str, float]
    seconds: dict[str, float]
    n_truth: int
    damage: CorruptFileError | None = None

    def report(self) -> list[str]:
        """The lines ``labkit demo`` prints."""
        n, s = self.n_scans, self.seconds
        return [
            f"labkit demo on {self.source}",
            f"  {n} scans of {self.n_beams} beams; lines by {self.method}",
            "  features per scan: " + ", ".join(f"{name} {v:.1f}" for name, v in self.per_scan.items()),
            "  median us per scan: " + ", ".join(f"{name} {v:.0f}" for name, v in self.stage_us.items()),
            f"  read {n / s['read']:,.0f} scans/s, extracted {n / s['extract']:,.0f} scans/s, "
            f"wrote .rrd at {n / s['rrd']:,.0f} scans/s; bag -> features -> .rrd {n / sum(s.values()):,.0f} scans/s",
            f"  wrote {self.rrd} ({n} scans, ground truth for {self.n_truth}) and {self.png} (scan {self.scan_shown})",
        ]


def run_demo(source: str | Path, out: str | Path, config: Config | None = None, *, topic: str | None = None,
             strict: bool = False) -> DemoResult:
    """Extract every scan of a recording and write ``out/demo.rrd`` and ``out/demo.png``.

    The .rrd holds every scan with its features (and the ground truth when the simulator's truth
    file sits beside the recording); the picture shows the richest scan (:func:`richest_scan`).
    Only these two files are ever replaced, so the demo can run again and again; nothing else
    is. A damaged recording is shown on what could be read; its error is in ``result.damage``.

    Parameters
    ----------
    source : str or Path
        The recording (any format :func:`labkit.read_scans` reads).
    out : str or Path
        The folder to write the two files into.
    config : Config or None
        The pipeline's configuration; None: ``Config()``.
    topic : str or None
        The scan topic of a bag; None: the only one.
    strict : bool
        Stop at the first bad record instead of skipping it.

    Returns
    -------
    DemoResult
        What was written and measured.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from labkit.viz import plot
    from labkit.viz import rr as lkrr

    config = config or Config()
    source, out = Path(source), Path(out)
    rrd, png = out / "demo.rrd", out / "demo.png"
    check_output(rrd, lkrr.RRD_FILE, overwrite=True, inputs=[source])
    check_output(png, PNG_FILE, overwrite=True, inputs=[source])
    seconds = {}
    t0 = time.perf_counter()
    scans: list[Scan] = []
    damage: CorruptFileError | None = None
    try:
        scans.extend(read_scans(source, topic=topic, strict=strict))
    except CorruptFileError as exc:  # show what could be read, then report the damage
        damage = exc
    seconds["read"] = time.perf_counter() - t0
    if not scans:
        raise RefusedError(f"{source} holds no scans" + (f" ({damage})" if damage else ""))
    t0 = time.perf_counter()
    feats = [extract_features(s, config) for s in scans]
    seconds["extract"] = time.perf_counter() - t0
    truth_file = sim.truth_path_for(source)
    truth = sim.read_truth(truth_file) if truth_file.exists() else None
    t0 = time.perf_counter()
    summary = lkrr.record_scans(
        scans, rrd, name=source.name, truth=truth, features=feats, overwrite=True, inputs=[source, truth_file],
        description=lkrr.describe(f"labkit demo: {source.name}", config=config, truth=truth is not None,
                                  source="Every scan through `labkit.extract_features` with the default config."))
    seconds["rrd"] = time.perf_counter() - t0
    k = richest_scan(feats)
    f = feats[k]
    fig, ax = plt.subplots(figsize=(10, 8))
    plot.plot_features(scans[k], features=f, truth=truth.scans.get(scans[k].stamp_ns) if truth else None, ax=ax,
                       title=f"{source.name}, scan {k}: " + ", ".join(f"{v} {n}" for n, v in f.counts().items()))
    fig.tight_layout()
    with safe_output(png, PNG_FILE, overwrite=True, inputs=[source]) as tmp:
        fig.savefig(tmp, dpi=110, format="png")
    plt.close(fig)
    n = len(scans)
    return DemoResult(
        source=source, rrd=rrd, png=png, n_scans=summary.n_scans, n_beams=scans[0].n_beams, method=config.lines.method,
        scan_shown=k, per_scan={name: sum(x.counts()[name] for x in feats) / n for name in feats[0].counts()},
        stage_us={name: 1e6 * float(np.median([x.timings[name] for x in feats])) for name in feats[0].timings},
        seconds=seconds, n_truth=summary.n_truth, damage=damage)

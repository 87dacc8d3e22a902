"""Draw the picture of the README and the docs' front page: docs/_static/hall.png.

The richest scan of the bundled hall recording with every feature labkit finds in it and the
simulator's ground truth, as ``make demo`` draws it (``out/demo.png``), smaller. Run it again after
a change that alters what is found::

    .venv/bin/python docs/make_figure.py
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

import labkit  # noqa: E402
from labkit import sim  # noqa: E402
from labkit.app.demo import richest_scan  # noqa: E402
from labkit.viz import plot  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
TARGET = REPO / "docs" / "_static" / "hall.png"


def main() -> None:
    source = REPO / "data" / "hall.bag"
    scans = list(labkit.read_scans(source))
    feats = [labkit.extract_features(s) for s in scans]
    truth = sim.read_truth(sim.truth_path_for(source))
    k = richest_scan(feats)
    fig, ax = plt.subplots(figsize=(7.5, 5))
    plot.plot_features(scans[k], features=feats[k], truth=truth.scans.get(scans[k].stamp_ns), ax=ax,
                       title=f"hall.bag, scan {k}: " + ", ".join(f"{v} {n}" for n, v in feats[k].counts().items()))
    fig.tight_layout()
    TARGET.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(suffix=".png", dir=TARGET.parent)
    os.close(fd)
    os.chmod(tmp, 0o644)
    fig.savefig(tmp, dpi=80, format="png")
    os.replace(tmp, TARGET)
    print(f"wrote {TARGET} (scan {k} of {len(scans)})")


if __name__ == "__main__":
    main()

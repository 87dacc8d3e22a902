"""ipywidgets for notebooks: browse a recording scan by scan."""

from __future__ import annotations

from collections.abc import Callable, Sequence

import ipywidgets as widgets
import matplotlib.pyplot as plt

from ..scan import Scan
from .plot import plot_scan

__all__ = ["scan_browser"]


def scan_browser(
    scans: Sequence[Scan],
    draw: Callable | None = None,
    *,
    description: str = "scan",
    figsize: tuple[float, float] = (7, 5.5),
) -> widgets.VBox:
    """A slider over ``scans`` and a figure redrawn for the chosen one.

    The slider updates on release (``continuous_update=False``), so dragging stays smooth.

    Parameters
    ----------
    scans : sequence of Scan
        The scans.
    draw : callable or None
        ``draw(scan, ax, index)`` draws a scan; None: :func:`labkit.viz.plot.plot_scan`.
    description : str
        The slider's label.
    figsize : tuple of float
        The figure's size, inches.

    Returns
    -------
    ipywidgets.VBox
        The slider above the figure's output.
    """
    if len(scans) == 0:
        raise ValueError("scans must not be empty")
    draw = draw or (lambda scan, ax, k: plot_scan(scan, ax, title=f"scan {k}, t = {scan.stamp_s:.2f} s"))
    slider = widgets.IntSlider(value=0, min=0, max=len(scans) - 1, step=1, description=description,
                               continuous_update=False, layout=widgets.Layout(width="90%"))
    out = widgets.Output()

    def render(k: int) -> None:
        with out:
            out.clear_output(wait=True)
            fig, ax = plt.subplots(figsize=figsize)
            draw(scans[k], ax, k)
            plt.show()

    slider.observe(lambda change: render(change["new"]), names="value")
    render(0)
    return widgets.VBox([slider, out])

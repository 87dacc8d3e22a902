"""Colours shared by every viewer, so a feature looks the same in matplotlib and rerun."""

from __future__ import annotations

import colorsys

import numpy as np

#: RGB (0-255) per layer.
COLORS = {
    "points": (70, 110, 160),
    "invalid": (170, 170, 170),
    "sensor": (220, 40, 40),
    "lines": (215, 50, 40),
    "corners": (240, 150, 20),
    "circles": (40, 160, 70),
    "legs": (150, 60, 190),
    "arcs": (20, 140, 150),
    "people": (240, 90, 160),
    "truth": (120, 120, 120),
}

# A qualitative palette for segment labels: matplotlib's tab10 without its grey (grey is
# for invalid beams and ground truth).
PALETTE = np.array(
    [
        (31, 119, 180), (255, 127, 14), (44, 160, 44), (214, 39, 40), (148, 103, 189),
        (140, 86, 75), (227, 119, 194), (188, 189, 34), (23, 190, 207),
    ],
    dtype=np.uint8,
)


def label_colors(labels) -> np.ndarray:
    """RGB (N, 3) uint8 for integer labels; -1 (noise) is light grey."""
    labels = np.asarray(labels)
    out = PALETTE[np.mod(labels, len(PALETTE))]
    out[labels < 0] = COLORS["invalid"]
    return out


def mpl(name: str) -> tuple[float, float, float]:
    """A layer colour as a matplotlib RGB tuple in [0, 1]."""
    r, g, b = COLORS[name]
    return (r / 255, g / 255, b / 255)


def track_color(track_id: int) -> tuple[int, int, int]:
    """The RGB (0-255) colour of a track (:mod:`labkit.tracking`), the same in rerun and in matplotlib.

    Hues a golden-ratio step apart for successive ids, so that tracks born one after the other differ
    and an id keeps its colour for its whole life.

    Parameters
    ----------
    track_id : int
        The track's id.

    Returns
    -------
    tuple of (int, int, int)
        Red, green and blue, 0 to 255.

    Examples
    --------
    >>> track_color(1) == track_color(1), track_color(1) != track_color(2)
    (True, True)
    """
    hue = (int(track_id) * 0.6180339887498949) % 1.0
    r, g, b = colorsys.hsv_to_rgb(hue, 0.85, 0.9)
    return int(round(255 * r)), int(round(255 * g)), int(round(255 * b))

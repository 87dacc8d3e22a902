"""ipywidgets of notebook 09b: controls for a few pipeline parameters, and a button with its output area."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

__all__ = ["config_controls", "button_with_output"]


def config_controls(config, *, width: str = "32em") -> dict:
    """One control per parameter the notebook varies, set to ``config``'s values.

    Sliders update on release (``continuous_update=False``).

    Parameters
    ----------
    config : labkit.Config
        The values to start from.
    width : str, default "32em"
        Each control's width (its label takes 13em).

    Returns
    -------
    dict
        ``{"method": Dropdown of labkit.pipeline.LINE_METHODS, "split_m": SelectionSlider of "auto" and
        0.01 to 0.30 m, "seg_m": FloatSlider 0.02 to 0.40 m, "adaptive": Checkbox, "std_deg": FloatSlider
        0.5 to 25 deg}``, in that order: the keyword names of the notebook's ``redraw``.
    """
    import ipywidgets as widgets

    from labkit.pipeline import LINE_METHODS

    wide = {"style": {"description_width": "13em"}, "layout": widgets.Layout(width=width)}
    splits = [("auto", "auto")] + [(f"{v:.2f}", round(v, 2)) for v in np.arange(0.01, 0.305, 0.01)]
    return {
        "method": widgets.Dropdown(options=LINE_METHODS, value=config.lines.method, description="lines.method",
                                   **wide),
        "split_m": widgets.SelectionSlider(options=splits, value=config.lines.split_threshold_m,
                                           continuous_update=False, description="lines.split_threshold_m", **wide),
        "seg_m": widgets.FloatSlider(value=config.segmentation.threshold_m, min=0.02, max=0.40, step=0.01,
                                     readout_format=".2f", continuous_update=False,
                                     description="segmentation.threshold_m", **wide),
        "adaptive": widgets.Checkbox(value=config.segmentation.adaptive, description="segmentation.adaptive", **wide),
        "std_deg": widgets.FloatSlider(value=round(config.circles.std_max_deg, 1), min=0.5, max=25.0, step=0.5,
                                       readout_format=".1f", continuous_update=False,
                                       description="circles.std_max_deg", **wide),
    }


def button_with_output(description: str, action: Callable[[], object], icon: str = "refresh"):
    """A button that runs ``action()`` into an output area of its own, clearing what the last click left.

    Parameters
    ----------
    description : str
        The button's label.
    action : callable
        Called with no argument on every click; what it prints or shows goes to the area.
    icon : str, default "refresh"
        The button's icon.

    Returns
    -------
    (ipywidgets.Button, ipywidgets.Output)
        The button and its area; ``button.click()`` clicks it from code.
    """
    import ipywidgets as widgets

    button = widgets.Button(description=description, icon=icon)
    area = widgets.Output()

    def on_click(_button) -> None:
        with area:
            area.clear_output()
            action()

    button.on_click(on_click)
    return button, area

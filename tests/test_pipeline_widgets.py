"""labkit.viz.pipeline_widgets (notebook 09b): the controls start at the config's values, the button runs its action."""

from __future__ import annotations

import labkit
from labkit.viz import pipeline_widgets


def test_controls_start_at_the_config_and_name_redraws_arguments():
    config = labkit.Config().updated({"lines.method": "angular", "lines.split_threshold_m": 0.05,
                                      "segmentation.threshold_m": 0.12, "circles.std_max_deg": 9.04})
    controls = pipeline_widgets.config_controls(config)
    assert list(controls) == ["method", "split_m", "seg_m", "adaptive", "std_deg"]
    values = {name: c.value for name, c in controls.items()}
    assert values == {"method": "angular", "split_m": 0.05, "seg_m": 0.12,
                      "adaptive": config.segmentation.adaptive, "std_deg": 9.0}
    assert controls["split_m"].options[0] == ("auto", "auto") and controls["split_m"].options[-1] == ("0.30", 0.3)
    assert not controls["seg_m"].continuous_update and (controls["seg_m"].min, controls["seg_m"].max) == (0.02, 0.4)


def test_the_button_runs_its_action_on_each_click():
    calls = []
    button, area = pipeline_widgets.button_with_output("go", lambda: calls.append(len(calls)))
    assert button.description == "go" and calls == []
    button.click()
    button.click()
    assert calls == [0, 1]

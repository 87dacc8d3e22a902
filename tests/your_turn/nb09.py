"""Fill-ins for notebooks/09_bag_playback_in_rerun.ipynb (a Config for a task, features per scan) and
notebooks/09b_configurations_and_cli.ipynb (where the line extractors disagree): both notebooks start with "09",
so both read this file (see tests/your_turn/__init__.py)."""

from tests.your_turn import Fill

_CONFIG = "def config_for(method, split_threshold_cm):\n"
_MEAN = "def mean_per_scan(feats, kind):\n"

FILLS = {
    "64190793": Fill(
        correct=_CONFIG + ('    return labkit.Config().updated({"lines.method": method,\n'
                           '            "lines.split_threshold_m": split_threshold_cm / 100})\n'),
        # centimetres passed on as metres: 3 cm becomes a 3 m threshold (a valid, useless Config)
        mistake=_CONFIG + ('    return labkit.Config().updated({"lines.method": method,\n'
                           '                                    "lines.split_threshold_m": split_threshold_cm})\n'),
        hint="the Config wants metres",
    ),
    "76752249": Fill(
        correct=_MEAN + "    return float(np.mean([len(getattr(f, kind)) for f in feats]))\n",
        # the mean over the scans that have some: scans without any are left out
        mistake=_MEAN + "    return float(np.mean([len(getattr(f, kind)) for f in feats if len(getattr(f, kind))]))\n",
        hint="scans with no legs count too",
    ),
}

_FEWER = """
def fewer_lines_share(a, b):
    fewer = [len(y.lines) {op} len(x.lines) for x, y in zip(a, b)]
    return sum(fewer) / len(fewer)
"""

FILLS["5e1a31a5"] = Fill(
    correct=_FEWER.format(op="<"),
    mistake=_FEWER.format(op="<="),  # a scan where both runs find as many lines counted as "fewer"
    hint="strictly fewer",
)

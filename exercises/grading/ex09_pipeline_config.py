"""Hidden tests of exercise 9, ``config_dict(...)`` and ``scan_summary(records, kind)``.

Trusted: the grader runs this file in its own process, never where the student's code runs, and
nbgrader never copies it into the release. Each ``test_<cell>`` (or ``test_<cell>__<function>``)
function holds hidden tests of the graded cell with that grade id for one of the student's
functions: it gets that function (calls into the sandboxed worker) and ``rng``, a generator seeded
per submission and test, fresh for every change of the submitted code. Its messages name what is
wrong, never the inputs or the expected values. See exercises/README.md.

``config_dict`` is graded through ``labkit.Config.from_dict``: the student's nested dict must be a
configuration labkit accepts, equal to the one built with ``labkit.Config().updated`` from the
task's rule (centimetres to metres, a fixed gap switches the adaptive threshold off, arcs on with
their own finer threshold). ``scan_summary`` is graded on the per-scan records of
``labkit.Features.as_record`` (what ``labkit extract`` writes and ``labkit.read_features`` reads)
of scans simulated by ``labkit.sim`` and run through ``labkit.extract_all``, and on synthetic
records with many empty scans; the reference summary is numpy on those records.
"""

import math
import numbers

import numpy as np

import labkit
from labkit import sim

METHODS = ("iepf", "split_and_merge", "angular", "none")
SUMMARY_KEYS = ("mean", "seen", "median_us", "slowest", "share")


# ---------------------------------------------------------------------------- config_dict
def expected_config(method, split_threshold_cm, gap_cm=None, arcs_split_cm=None):
    """The task's rule as flat ``section.key`` changes, and labkit's Config built from them."""
    changes = {"lines.method": method, "lines.split_threshold_m": split_threshold_cm / 100}
    if gap_cm is not None:
        changes.update({"segmentation.threshold_m": gap_cm / 100, "segmentation.adaptive": False})
    if arcs_split_cm is not None:
        changes.update({"arcs.enabled": True, "arcs.split_threshold_m": arcs_split_cm / 100})
    return changes, labkit.Config().updated(changes)


def _flat(config_dict_value):
    return {f"{section}.{key}": value for section, keys in config_dict_value.items() for key, value in keys.items()}


def _same_value(got, want):
    if isinstance(want, bool) or isinstance(want, str):
        return type(got) is type(want) and got == want
    if isinstance(want, float):
        return isinstance(got, numbers.Real) and not isinstance(got, bool) and math.isclose(got, want, rel_tol=1e-12,
                                                                                           abs_tol=1e-15)
    return got == want


_HINTS = {
    "lines.split_threshold_m": "the Config wants metres: centimetres / 100",
    "segmentation.threshold_m": "the gap in metres: centimetres / 100",
    "segmentation.adaptive": "a fixed gap means the adaptive threshold is off (False)",
    "arcs.enabled": "arcs are off by default: switch them on (True)",
    "arcs.split_threshold_m": "the arcs' own split threshold, in metres",
    "lines.method": "the method's name, as given",
}


def _check_config(config_dict, setting, *args, **kwargs):
    changes, want = expected_config(*args, **kwargs)
    given = ", ".join(["method", "split_threshold_cm", *kwargs])
    got = config_dict(*args, **kwargs)
    if not isinstance(got, dict) or not all(isinstance(v, dict) for v in got.values()):
        raise AssertionError(f"{setting} (given {given}): return a dict of sections, each a dict of keys "
                             f"(e.g. {{'lines': {{'method': ...}}}}), got a {type(got).__name__}")
    flat = _flat(got)
    if set(flat) != set(changes):
        extra, missing = sorted(set(flat) - set(changes)), sorted(set(changes) - set(flat))
        raise AssertionError(f"{setting} (given {given}): the dict must set exactly the keys the task asks for; "
                             f"{'extra: ' + str(extra) if extra else ''}{' ' if extra and missing else ''}"
                             f"{'missing: ' + str(missing) if missing else ''}")
    for key, value in changes.items():
        if not _same_value(flat[key], value):
            raise AssertionError(f"{setting} (given {given}): {key} is wrong ({_HINTS[key]})")
    try:
        config = labkit.Config.from_dict(got)
    except (ValueError, TypeError):
        raise AssertionError(f"{setting} (given {given}): labkit.Config.from_dict rejects the dict") from None
    assert config == want, f"{setting} (given {given}): another Config than the task asks for"


def _expect_value_error(fn, what, *args, **kwargs):
    try:
        fn(*args, **kwargs)
    except ValueError:
        return
    raise AssertionError(f"{what} must raise ValueError")


def _random_config_args(rng):
    method = str(rng.choice(METHODS))
    split_cm = float(np.round(rng.uniform(0.5, 30.0), int(rng.integers(0, 3))) or 1.0)
    kwargs = {}
    if rng.random() < 0.5:
        gap = float(np.round(rng.uniform(1.0, 40.0), 1))
        kwargs["gap_cm"] = gap if rng.random() < 0.7 else int(rng.integers(2, 40))
    if rng.random() < 0.5:
        kwargs["arcs_split_cm"] = float(np.round(rng.uniform(0.1, 0.95) * split_cm, 2)) or 0.05
    return (method, split_cm), kwargs


# ---------------------------------------------------------------------------- scan_summary
def reference_summary(records, kind):
    """The summary the task asks for, with numpy, on the plain records."""
    counts = np.array([r["counts"][kind] for r in records], dtype=float)
    stages = list(records[0]["timings_ms"])
    ms = {s: np.array([r["timings_ms"][s] for r in records], dtype=float) for s in stages}
    median_us = {s: 1000.0 * float(np.median(ms[s])) for s in stages}
    share = {s: float(np.median(ms[s] / ms["total"])) for s in stages if s != "total"}
    return {"mean": float(counts.mean()), "seen": float(np.mean(counts > 0)), "median_us": median_us,
            "slowest": max(share, key=lambda s: median_us[s]), "share": share}


def _is_number(value):
    return isinstance(value, numbers.Real) and not isinstance(value, bool) and math.isfinite(value)


def _check_summary(scan_summary, records, kind, setting, want=None):
    want = reference_summary(records, kind) if want is None else want
    got = scan_summary(records, kind)
    where = f"{setting} ({len(records)} scans)"
    if not isinstance(got, dict) or set(got) != set(SUMMARY_KEYS):
        keys = sorted(got) if isinstance(got, dict) else type(got).__name__
        raise AssertionError(f"{where}: return a dict with the keys {list(SUMMARY_KEYS)}, got {keys}")
    counts = np.array([r["counts"][kind] for r in records])
    hints = {"mean": "every scan counts, a scan without any as zero",
             "seen": "the fraction of scans with at least one"}
    for key in ("mean", "seen"):
        if not _is_number(got[key]) or not math.isclose(got[key], want[key], rel_tol=1e-9, abs_tol=1e-12):
            extra = ""
            if key == "mean" and (counts > 0).any() and _is_number(got[key]) and math.isclose(
                    got[key], counts[counts > 0].mean(), rel_tol=1e-9) and want["mean"] != got[key]:
                extra = ": that is the mean over the scans that have one"
            raise AssertionError(f"{where}: {key} is wrong ({hints[key]}){extra}")
    for key, hint in (("median_us", "the median over scans, in microseconds (1 ms = 1000 us)"),
                      ("share", "per scan stage / total, then the median over scans; not 'total'")):
        value = got[key]
        if not isinstance(value, dict) or set(value) != set(want[key]):
            keys = sorted(value) if isinstance(value, dict) else type(value).__name__
            raise AssertionError(f"{where}: {key} must be a dict with one entry per stage ({hint}), got {keys}")
        wrong = [stage for stage, expected in want[key].items()
                 if not _is_number(value[stage]) or not math.isclose(value[stage], expected, rel_tol=1e-9,
                                                                     abs_tol=1e-12)]
        if wrong:
            raise AssertionError(f"{where}: {key} is wrong for {len(wrong)} of {len(want[key])} stages ({hint})")
    if got["slowest"] != want["slowest"]:
        raise AssertionError(f"{where}: slowest is wrong (the stage, not 'total', with the largest median time)")


def _plain_record(features, k):
    record = features.as_record()
    return {"scan": k, "stamp_ns": int(record["stamp_ns"]), "counts": dict(record["counts"]),
            "timings_ms": dict(record["timings_ms"])}


def simulated_records(rng, n_scans):
    """Per-scan records of a simulated recording run through labkit's pipeline, a random config."""
    scenario = str(rng.choice(["hall", "corridor", "office"]))
    scans = [scan for scan, _ in sim.simulate(scenario, seed=int(rng.integers(0, 2**31)), n_scans=n_scans)]
    config = labkit.Config().updated({"lines.method": str(rng.choice(METHODS[:3])),
                                      "lines.split_threshold_m": float(rng.uniform(0.02, 0.12))})
    return scenario, [_plain_record(f, k) for k, f in enumerate(labkit.extract_all(scans, config))]


def synthetic_records(rng, n_scans, kinds=("lines", "legs", "people")):
    """Records with counts that are often zero and stage times in milliseconds that vary a lot."""
    stages = ["segmentation", "legs", "circles", "lines", "corners"]
    scale = rng.uniform(0.01, 5.0, len(stages))
    records = []
    for k in range(n_scans):
        ms = {s: float(np.round(scale[i] * rng.lognormal(0.0, 0.6), 4) + 0.0001) for i, s in enumerate(stages)}
        ms["total"] = float(np.round(sum(ms.values()) + rng.uniform(0.0, 0.2), 4))
        counts = {kind: int(rng.poisson(rng.choice([0.3, 1.5, 6.0])) * (rng.random() > 0.4)) for kind in kinds}
        records.append({"scan": k, "counts": counts, "timings_ms": ms})
    return records


# ---------------------------------------------------------------------------- the graded cells: config_dict
def test_hidden_random__config_dict(config_dict, rng):
    """60 random task descriptions against labkit.Config."""
    for trial in range(60):
        args, kwargs = _random_config_args(rng)
        _check_config(config_dict, f"random task {trial}", *args, **kwargs)


def test_hidden_edges__config_dict(config_dict, rng):
    """Integer centimetres, an arcs threshold just below the line threshold, method none; bad methods and
    thresholds."""
    split = int(rng.integers(3, 30))
    _check_config(config_dict, "integer centimetres", str(rng.choice(METHODS)), split,
                  gap_cm=int(rng.integers(2, 40)), arcs_split_cm=int(rng.integers(1, split)))
    split = float(np.round(rng.uniform(2.0, 20.0), 2))
    _check_config(config_dict, "arcs just below the lines", str(rng.choice(METHODS)), split,
                  arcs_split_cm=round(split - 0.01, 2))
    _check_config(config_dict, "method none", "none", int(rng.integers(1, 10)))
    method, split = str(rng.choice(METHODS)), int(rng.integers(2, 20))
    bad = [("an unknown method", (str(rng.choice(["ransac", "hough", "IEPF", "split-and-merge"])), split), {}),
           ("an empty method", ("", split), {}), ("a split threshold of 0", (method, 0), {}),
           ("a negative split threshold", (method, -float(rng.uniform(0.1, 5.0))), {}),
           ("a gap of 0", (method, split), {"gap_cm": 0}), ("a negative gap", (method, split), {"gap_cm": -1.0}),
           ("arcs as coarse as the lines", (method, split), {"arcs_split_cm": split}),
           ("an arcs threshold of 0", (method, split), {"arcs_split_cm": 0}),
           ("arcs coarser than the lines", (method, split), {"arcs_split_cm": split + float(rng.uniform(0.5, 5.0))})]
    for what, args, kwargs in bad:
        _expect_value_error(config_dict, f"config_dict with {what}", *args, **kwargs)


def test_own_work__config_dict(config_dict, rng):
    """Ten more tasks: right answers where labkit cannot be imported."""
    for trial in range(10):
        args, kwargs = _random_config_args(rng)
        _check_config(config_dict, f"own-work task {trial}", *args, **kwargs)


# ---------------------------------------------------------------------------- the graded cells: scan_summary
def test_hidden_random__scan_summary(scan_summary, rng):
    """Two simulated recordings through labkit.extract_all (a random config each), every kind; 20 sets of
    synthetic records."""
    for trial in range(2):
        scenario, records = simulated_records(rng, int(rng.integers(8, 21)))
        for kind in ("lines", "corners", "circles", "legs", "people"):
            _check_summary(scan_summary, records, kind, f"simulated {scenario} recording {trial}, {kind}")
    for trial in range(20):
        records = synthetic_records(rng, int(rng.integers(1, 60)))
        _check_summary(scan_summary, records, str(rng.choice(["lines", "legs", "people"])),
                       f"synthetic records {trial}")


def test_hidden_edges__scan_summary(scan_summary, rng):
    """One scan, no scan with the kind, lists of records; no records, an unknown kind (ValueError)."""
    one = synthetic_records(rng, 1)
    one[0]["counts"]["legs"] = int(rng.integers(1, 5))
    _check_summary(scan_summary, one, "legs", "one scan")
    empty = synthetic_records(rng, int(rng.integers(4, 20)))
    for record in empty:
        record["counts"]["people"] = 0
    _check_summary(scan_summary, empty, "people", "no scan with a person")
    even = synthetic_records(rng, 2 * int(rng.integers(2, 10)))
    _check_summary(scan_summary, even, "lines", "an even number of scans (the median between two)")
    _expect_value_error(scan_summary, "scan_summary with no records", [], "lines")
    _expect_value_error(scan_summary, "scan_summary with a kind the records do not count", synthetic_records(rng, 3),
                        str(rng.choice(["doors", "walls", "chairs"])))


def test_own_work__scan_summary(scan_summary, rng):
    """Five more sets of records: right answers where labkit cannot be imported."""
    for trial in range(5):
        _check_summary(scan_summary, synthetic_records(rng, 30), "lines", f"own-work records {trial}")


# ---------------------------------------------------------------------------- proof (tests/test_exercises.py)
#: A submission that gets the right answers by calling labkit: it must score 0.
DELEGATE = {"pipeline": '''
import labkit


def config_dict(method, split_threshold_cm, gap_cm=None, arcs_split_cm=None):
    changes = {"lines.method": method, "lines.split_threshold_m": split_threshold_cm / 100}
    if gap_cm is not None:
        changes.update({"segmentation.threshold_m": gap_cm / 100, "segmentation.adaptive": False})
    if arcs_split_cm is not None:
        if not arcs_split_cm < split_threshold_cm:
            raise ValueError("arcs need a finer split threshold than the lines")
        changes.update({"arcs.enabled": True, "arcs.split_threshold_m": arcs_split_cm / 100})
    labkit.Config().updated(changes)  # let labkit check the method and the thresholds
    out = {}
    for key, value in changes.items():
        section, name = key.split(".")
        out.setdefault(section, {})[name] = value
    return out


def scan_summary(records, kind):
    if not records or kind not in records[0]["counts"]:
        raise ValueError("no records, or an unknown kind")
    counts = np.array([r["counts"][kind] for r in records], dtype=float)
    ms = {s: np.array([r["timings_ms"][s] for r in records]) for s in records[0]["timings_ms"]}
    median_us = {s: 1000.0 * float(np.median(v)) for s, v in ms.items()}
    share = {s: float(np.median(v / ms["total"])) for s, v in ms.items() if s != "total"}
    return {"mean": float(counts.mean()), "seen": float(np.mean(counts > 0)), "median_us": median_us,
            "slowest": max(share, key=median_us.get), "share": share}
'''}

#: Plausible wrong answers, as (text in the solution, replacement): a hidden test must catch each.
MISTAKES = {
    "centimetres passed on as metres": ('"split_threshold_m": split_threshold_cm / 100',
                                        '"split_threshold_m": split_threshold_cm'),
    "a fixed gap that leaves the adaptive threshold on": (', "adaptive": False}', "}"),
    "arcs given a threshold but not switched on": ('{"enabled": True, ', "{"),
    "an arcs threshold not checked against the lines'": ("if not arcs_split_cm < split_threshold_cm:", "if False:"),
    "an unknown method accepted": ("if method not in LINE_METHODS:", "if not method:"),
    "the mean over the scans that have one": (
        '"mean": float(counts.mean())', '"mean": float(counts[counts > 0].mean() if (counts > 0).any() else 0.0)'),
    "the mean time instead of the median": (
        "float(np.median(1000.0 * ms[stage]))", "float(np.mean(1000.0 * ms[stage]))"),
    "milliseconds, not microseconds": ("float(np.median(1000.0 * ms[stage]))", "float(np.median(ms[stage]))"),
    "the share as a ratio of medians": ('float(np.median(ms[stage] / ms["total"]))',
                                        'float(np.median(ms[stage]) / np.median(ms["total"]))'),
    "the total counted as the slowest stage": ("max(share, key=", "max(median_us, key="),
}

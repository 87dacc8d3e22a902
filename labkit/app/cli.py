"""The ``labkit`` command line: simulate, extract, track, view, convert, evaluate, benchmark, inspect, grade.

Run ``labkit --help`` or ``labkit COMMAND --help``. Every expected problem prints one line
``labkit: error: ...`` and exits with a documented status (README, "When things go wrong"):

====  ==========================================================================================
0     done
1     done, but an input was damaged: the output holds every record that could be read, and
      the line says where the first damage is and how many scans were kept and lost
2     nothing was done: the command line or an input was refused (unknown format, missing
      file, an input without any scan, an output that exists without ``-f`` or is not labkit's
      kind of file, an output that is the input, a wrong suffix, a bad value)
3     nothing was done: the system refused (permission denied, disk full, read-only folder)
70    a bug in labkit: the traceback is shown; please report it with the command line
130   interrupted (Ctrl-C): the output is unchanged; what was written so far is kept as
      ``<name>.partial<suffix>``
141   standard output was closed by the reader (``labkit extract run.bag | head``)
====  ==========================================================================================

Outputs are written under a temporary name and renamed when complete; ``-f`` replaces only
labkit's own kind of output, never another file or folder, and never an input.
"""

from __future__ import annotations

import argparse
import contextlib
import math
import os
import subprocess
import sys
import time
import traceback
import warnings
from functools import partial
from pathlib import Path

from labkit import __version__, sim
from labkit._safe import OutputInterrupted, OutputKind, check_output, json_object_with
from labkit.errors import CorruptFileError, RefusedError
from labkit.grading import add_grade_parser
from labkit.io import FORMATS, detect_format, read_scans
from labkit.io.formats import writable_formats

EXIT_OK, EXIT_DAMAGED, EXIT_REFUSED, EXIT_SYSTEM, EXIT_BUG, EXIT_INTERRUPTED, EXIT_PIPE = 0, 1, 2, 3, 70, 130, 141

#: What ``labkit evaluate --json`` and ``labkit demo`` write (see labkit._safe).
REPORT_FILE = OutputKind("a labkit evaluate report (.json)", (".json",),
                         json_object_with(allowed=("lines", "sweep", "round_objects", "recordings")))


def _progress(total: int | None, desc: str):
    from tqdm.auto import tqdm

    return partial(tqdm, total=total, unit="scan", desc=desc)


def _rerun_command() -> str:
    """How to call the rerun viewer: plain ``rerun`` if it is on PATH, else its full path."""
    import shutil

    if shutil.which("rerun"):
        return "rerun"
    beside = Path(sys.executable).parent / "rerun"
    if not beside.exists():
        return "rerun"
    try:
        return str(beside.relative_to(Path.cwd()))
    except ValueError:
        return str(beside)


def cmd_simulate(args: argparse.Namespace) -> int:
    from labkit.app.data import generate_bundled, write_simulation

    if args.bundled:
        if args.sensor or args.beams:
            raise RefusedError("--bundled regenerates data/ as it is; --sensor and --beams are for one WORLD")
        out = Path(args.output or "data")
        paths = generate_bundled(out, progress=not args.quiet, overwrite=args.force)
        for p in paths:
            print(p)
        return 0
    if not args.world or not args.output:
        raise RefusedError("give a WORLD and -o OUTPUT (or --bundled); worlds: hall, corridor, office, "
                           "random_polygons_<seed>")
    sc = _with_sensor(sim.scenario(args.world), args.sensor, args.beams)
    n = args.scans or sc.n_scans
    bag, truth, count = write_simulation(
        sc, args.output, args.format, seed=args.seed, n_scans=n, overwrite=args.force,
        progress=None if args.quiet else _progress(n, f"simulate {args.world}"),
    )
    print(f"wrote {count} scans to {bag} and their ground truth to {truth}")
    return 0


def _with_sensor(sc: sim.Scenario, sensor: str | None, beams: int | None) -> sim.Scenario:
    """The scenario with another lidar (``--sensor``, a :data:`labkit.sim.LIDARS` preset) and/or
    another number of beams over the same field of view (``--beams``)."""
    import dataclasses

    lidar = sim.LIDARS[sensor] if sensor else sc.lidar
    if beams is not None:
        if beams < 2:
            raise RefusedError(f"--beams must be at least 2, got {beams}")
        if lidar.is_full_circle:  # the last beam one step short of the first, as before
            step = 2 * math.pi / beams
        else:  # the same first and last beam directions
            step = (lidar.n_beams - 1) * lidar.angle_increment / (beams - 1)
        lidar = dataclasses.replace(lidar, name=f"{lidar.name}-{beams}", angle_increment=step, n_beams=beams)
    return dataclasses.replace(sc, lidar=lidar)


def cmd_convert(args: argparse.Namespace) -> int:
    from labkit.io import convert_recording

    done = convert_recording(args.input, args.output, topic=args.topic, format=args.format, overwrite=args.force,
                             progress=not args.quiet, strict=args.strict, poses=_poses(args),
                             only_scans=args.only_scans, scans=_chosen_scans(args, [args.input]))
    if done.messages:
        print(f"wrote {sum(done.messages.values())} messages of {len(done.messages)} topics ({done.scans} scans) "
              f"to {args.output}")
    else:
        print(f"wrote {done.scans} scans to {args.output}")
    return 0


def _config(args: argparse.Namespace):
    from labkit.pipeline import Config

    config = Config.load(args.config) if getattr(args, "config", None) else Config()
    if getattr(args, "method", None):
        config = config.updated({"lines.method": args.method})
    return _with_noise(config, args)


def _with_noise(config, args: argparse.Namespace):
    """``--range-noise``: every stage's noise-following setting (labkit.noise.noise_config)."""
    from labkit.noise import noise_config

    noise = getattr(args, "range_noise", None)
    return config if noise is None else config.updated(noise_config(noise))


def _range_noise(text: str):
    """``--range-noise``'s value: "auto", "fixed" or a positive number of metres (as noise_config checks it)."""
    from labkit.noise import AUTO, FIXED, noise_config

    try:
        value = text if text in (AUTO, FIXED) else float(text)
        noise_config(value)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected auto, fixed or a positive number of metres, got {text!r}") from None
    return value


def _scan_range(text: str):
    """``--scans``' value: ``N`` (the first N scans, as an int) or ``A:B`` (a slice, as Python
    slices: ``100:200``, ``100:``, ``:500``, ``-100:`` for the last 100)."""
    text = text.strip()
    try:
        if ":" not in text:
            n = int(text)
            if n < 0:
                raise ValueError
            return n
        parts = text.split(":")
        if len(parts) != 2:
            raise ValueError
        start, stop = (int(x) if x.strip() else None for x in parts)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected N (the first N scans) or A:B (scans A to B-1, as Python slices "
                                         f"them; -100: the last 100), got {text!r}") from None
    return slice(start, stop)


def _time_range(text: str) -> tuple[float | None, float | None]:
    """``--time``'s value: ``T0:T1`` seconds from the recording's first scan (either may be left out)."""
    try:
        parts = text.split(":")
        if len(parts) != 2:
            raise ValueError
        t0, t1 = (float(x) if x.strip() else None for x in parts)
        if any(t is not None and not math.isfinite(t) for t in (t0, t1)):
            raise ValueError
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected T0:T1, seconds from the first scan (e.g. 60:120, 60:, :30), "
                                         f"got {text!r}") from None
    return t0, t1


def _scans_of_time(path, topic: str | None, t0: float | None, t1: float | None) -> slice:
    """The scans from the first whose stamp is at least ``t0`` seconds after the recording's first
    scan up to, not including, the first at least ``t1`` after it (one pass over the stamps)."""
    first_ns = start = None
    k = -1
    stream = read_scans(path, topic=topic, poses=False)
    try:
        for k, scan in enumerate(stream):
            if first_ns is None:
                first_ns = scan.stamp_ns
            t = (scan.stamp_ns - first_ns) / 1e9
            if start is None and (t0 is None or t >= t0):
                start = k
            if start is not None and t1 is not None and t >= t1:
                return slice(start, k)
    except CorruptFileError:  # the stamps that could be read; reading the range reports the damage
        pass
    return slice(start if start is not None else k + 1, None)


def _chosen_scans(args: argparse.Namespace, inputs) -> slice | None:
    """The scan range of ``--scans`` (``N``: the first N) or ``--time`` (one recording only)."""
    value = getattr(args, "scans", None)
    times = getattr(args, "time", None)
    if times is not None:
        if len(inputs) != 1:
            raise RefusedError("--time takes one recording (its stamps place the range); use --scans A:B for several")
        return _scans_of_time(inputs[0], getattr(args, "topic", None), *times)
    if isinstance(value, int):
        return slice(0, value)
    return value


def _counts_line(counts: dict, n: int) -> str:
    return ", ".join(f"{k} {v / max(n, 1):.1f}" for k, v in counts.items())


def cmd_track(args: argparse.Namespace) -> int:
    """Features and tracks of every scan: one CSV row per track per scan (labkit.io.track_files)."""
    from labkit.io.track_files import TRACKS_FILE, write_tracks
    from labkit.pipeline import track_scans

    source = Path(args.input)
    check_output(args.output, TRACKS_FILE, overwrite=args.force, inputs=[source])  # before any reading
    config = _config(args)
    stream = read_scans(source, topic=args.topic, strict=args.strict, poses=_poses(args),
                        scans=_chosen_scans(args, [source]))
    scans = iter(stream)
    if not args.quiet:
        scans = _progress(stream.count, f"track {source.name}")(scans)
    confirmed: set[int] = set()
    frames: set[str] = set()
    t0 = time.perf_counter()

    def tables():
        for _features, table in track_scans(scans, config):
            confirmed.update(int(i) for i in table.ids[table.status == "confirmed"])
            frames.add(table.frame)
            yield table

    n, n_rows = write_tracks(tables(), args.output, overwrite=args.force, inputs=[source], first_scan=stream.first)
    dt = time.perf_counter() - t0
    print(f"wrote tracks of {n} scans to {args.output} ({n_rows} rows, {n / max(dt, 1e-9):,.0f} scans/s, "
          f"{'/'.join(sorted(frames)) or 'no'} frame)")
    print(f"  moving targets confirmed: {len(confirmed)}" + (f" (ids {_ids(sorted(confirmed))})" if confirmed else ""))
    return 0


def _ids(ids: list[int], most: int = 12) -> str:
    return ", ".join(map(str, ids[:most])) + (f", ... ({len(ids) - most} more)" if len(ids) > most else "")


class _NoPandas:
    """An import finder that refuses pandas (see :func:`_arrow_without_pandas`)."""

    def find_spec(self, name, path=None, target=None):
        if name == "pandas" or name.startswith("pandas."):
            raise ImportError("labkit view: pandas is not needed here")
        return None


def _arrow_without_pandas() -> None:
    """pyarrow imports pandas (some 45 MiB resident) at its first array conversion, only to ask whether
    the data are pandas objects; rerun converts every column through pyarrow, and ``labkit view`` hands
    it none. Let that first question find no pandas. pyarrow remembers the answer for its questions but
    imports pandas again when pandas is asked for by name (``Table.from_pandas``, ``to_pandas``): pandas
    still works in this process. Only in a process that has imported neither yet (the command line's
    own): a program that already uses them is left alone."""
    if "pyarrow" in sys.modules or "pandas" in sys.modules:
        return
    import numpy as np
    import pyarrow as pa  # type: ignore[import-untyped]

    finder = _NoPandas()
    sys.meta_path.insert(0, finder)
    try:
        pa.array(np.zeros(1))
    finally:
        sys.meta_path.remove(finder)


def cmd_view(args: argparse.Namespace) -> int:
    _arrow_without_pandas()  # before rerun, which converts columns at import
    from labkit.app.record import record

    if args.tracks and args.no_features:
        raise ValueError("--tracks needs the features: leave out --no-features")
    config = None if args.no_features else _config(args)
    summary = record(args.input, args.output, topic=args.topic, config=config,
                     features=not args.no_features, progress=not args.quiet, overwrite=args.force,
                     strict=args.strict, poses=_poses(args), scans=_chosen_scans(args, [args.input]),
                     tracks=args.tracks)
    extra = f" and ground truth for {summary.n_truth}" if summary.n_truth else ""
    print(f"wrote {summary.n_scans} scans{extra} to {summary.path}")
    if summary.counts:
        print(f"  per scan: {_counts_line(summary.counts, summary.n_scans)}")
    if args.tracks:
        moving = list(summary.moving_tracks)
        print(f"  moving targets confirmed: {len(moving)}" + (f" (ids {_ids(moving)})" if moving else ""))
    if args.spawn:
        env = {k: v for k, v in os.environ.items() if not (k == "RUST_LOG" and v == _RERUN_QUIET)}
        subprocess.Popen([sys.executable, "-m", "rerun", str(summary.path)], env=env)
    else:
        print(f"open it with: {_rerun_command()} {summary.path}")
    if summary.error is not None:
        raise summary.error
    return 0


def _poses(args: argparse.Namespace):
    """``--poses``: None (auto), False (``none``) or a topic."""
    value = getattr(args, "poses", None)
    return False if value == "none" else value


def cmd_extract(args: argparse.Namespace) -> int:
    from labkit.app.parallel import recordings_in
    from labkit.io import write_features
    from labkit.io.feature_files import FEATURES_FILE
    from labkit.pipeline import extract_features
    from labkit.tables import PARQUET_FILE, write_features_table

    inputs = recordings_in(args.inputs)
    chosen = _chosen_scans(args, inputs)
    if len(inputs) > 1 or args.workers is not None or args.scheduler:
        return _extract_many(args, inputs, chosen)
    source = inputs[0]
    to_stdout = args.output == "-"
    table = args.output.lower().endswith(".parquet")
    if not to_stdout:
        check_output(args.output, PARQUET_FILE if table else FEATURES_FILE, overwrite=args.force, inputs=[source])
    config = _config(args)
    stream = read_scans(source, topic=args.topic, strict=args.strict, poses=_poses(args), scans=chosen)
    scans = iter(stream)
    if not args.quiet:
        scans = _progress(stream.count, f"extract {source.name}")(scans)
    counts: dict[str, int] = {}
    t0 = time.perf_counter()

    def tallied():
        for scan in scans:
            f = extract_features(scan, config)
            for k, v in f.counts().items():
                counts[k] = counts.get(k, 0) + v
            yield scan, f

    if table:
        n, n_rows = write_features_table(tallied(), args.output, recording=source.name, method=config.lines.method,
                                         overwrite=args.force, inputs=[source], first_scan=stream.first)
    else:
        n = write_features((f for _, f in tallied()), args.output, overwrite=args.force, inputs=[source],
                           first_scan=stream.first)
    dt = time.perf_counter() - t0
    report = sys.stderr if to_stdout else sys.stdout
    where = "standard output" if to_stdout else args.output + (f" ({n_rows} rows)" if table else "")
    print(f"wrote features of {n} scans to {where} ({n / max(dt, 1e-9):,.0f} scans/s, lines by "
          f"{config.lines.method})", file=report)
    print(f"  per scan: {_counts_line(counts, n)}", file=report)
    return 0


def _extract_many(args: argparse.Namespace, inputs: list[Path], chosen: slice | None) -> int:
    """``labkit extract`` of several recordings (or with --workers/--scheduler): on Dask."""
    from labkit.app import parallel

    out = args.output
    if out == "-" or out.lower().endswith(".jsonl"):
        raise RefusedError(f"{len(inputs)} recordings need -o FOLDER (one features file each) or -o TABLE.parquet "
                           "(one table for all)" if len(inputs) > 1 else
                           "--workers and --scheduler write through -o FOLDER or -o TABLE.parquet")
    config = _config(args)
    t0 = time.perf_counter()
    try:
        results = parallel.extract_many(inputs, out, config=config, topic=args.topic, poses=_poses(args),
                                        strict=args.strict, overwrite=args.force, workers=args.workers,
                                        scheduler=args.scheduler, scans=chosen, progress=None if args.quiet else
                                        _set_bar(f"extract {len(inputs)} recording(s)"))
    except KeyboardInterrupt as exc:
        return _interrupted_many(exc)
    dt = time.perf_counter() - t0
    n = sum(r.n_scans for r in results)
    counts: dict[str, int] = {}
    for r in results:
        for k, v in r.counts.items():
            counts[k] = counts.get(k, 0) + v
    if args.scheduler:
        where = f"the Dask scheduler at {args.scheduler}"
    elif args.workers == 0:
        where = "this process"
    else:
        where = f"a local Dask cluster of {f'{args.workers} workers' if args.workers else 'one worker per core'}"
    print(f"wrote features of {n} scans from {len(inputs)} recordings to {out} ({n / max(dt, 1e-9):,.0f} scans/s "
          f"on {where}, lines by {config.lines.method})")
    for r in results:
        print(f"  {Path(r.input).name}: {r.n_scans} scans, {r.status}" + (f" -> {r.output}" if r.output else ""))
    print(f"  per scan: {_counts_line(counts, n)}")
    return parallel.report(results)


def _set_bar(desc: str):
    """A progress bar over a whole set of recordings (advanced as each finishes)."""
    from tqdm.auto import tqdm

    return partial(tqdm, desc=desc, file=sys.stderr)


def _interrupted_many(exc: KeyboardInterrupt) -> int:
    """Ctrl-C during a run over several recordings: what finished, and what was kept, then 130."""
    from labkit.app import parallel

    if isinstance(exc, OutputInterrupted):
        raise exc
    parallel.report([r for r in getattr(exc, "results", []) if r is not None])
    print("labkit: interrupted: finished outputs are in place; each recording stopped part-way kept what it had "
          "written as NAME.partial.SUFFIX", file=sys.stderr)
    return EXIT_INTERRUPTED


def cmd_config(args: argparse.Namespace) -> int:
    from labkit.pipeline import Config

    config = _with_noise(Config.load(args.input) if args.input else Config(), args)
    if args.output:
        out = Path(args.output)
        config.save(out, overwrite=args.force)
        print(f"wrote {out}; edit it and pass it with --config to extract, view or bench")
    else:
        print(config.to_toml())
    return 0


def cmd_bench(args: argparse.Namespace) -> int:
    from labkit.app.bench import time_recording
    from labkit.app.data import bundled_data

    source = Path(args.input) if args.input else bundled_data("hall.bag")
    result = time_recording(source, _config(args), topic=args.topic, strict=args.strict,
                            scans=_chosen_scans(args, [source]))
    print(result.report())
    if result.error is not None:
        raise result.error
    return 0


def cmd_info(args: argparse.Namespace) -> int:
    """Format, topics, and what the scans are: read in full, so the counts are what can be read
    (a damaged file: exit 1 with the scans kept and lost, as every command says it)."""
    import numpy as np

    from labkit.errors import RefusedError as Refused
    from labkit.io import salvage

    path = Path(args.input)
    fmt = detect_format(path)
    row = FORMATS[fmt]
    print(f"{path}: {row.description}")
    if row.list_topics is not None:
        topics, readable = row.list_topics(path)
        found = None
        if fmt in salvage.WALKERS:  # what a walk through the file finds, beside what its index says
            from labkit.io.bags import storage_file

            found = salvage.walk_topics(storage_file(path, fmt), fmt)[0].found
        if not readable:
            print("  damaged: rosbags cannot open its index; labkit reads it record by record")
        for name, msgtype, count in topics:
            listed = count if count is not None else "?"
            seen = "" if found is None or found[name] == count else f" ({found[name]} found intact)"
            print(f"  {name:30s} {msgtype:35s} {listed} messages{seen}")
    try:
        stream = read_scans(path, topic=args.topic)
    except Refused as exc:
        if "several LaserScan topics" not in str(exc):
            raise
        print("  several LaserScan topics: labkit info --topic TOPIC describes one")
        return 0
    n, beams, first, last, span, damage, posed = 0, set(), None, None, None, None, 0
    try:
        for scan in stream:
            n += 1
            beams.add(scan.n_beams)
            first = scan.stamp_ns if first is None else first
            last = scan.stamp_ns
            posed += scan.pose is not None
            if span is None and scan.n_beams > 1:
                span = (float(np.degrees(scan.angles[0])), float(np.degrees(scan.angles[-1])),
                        float(np.degrees(scan.angle_increment)))
    except CorruptFileError as exc:
        damage = exc
    what = f" ({stream.topic})" if stream.topic else ""
    print(f"  scans{what}: {n}" + ("" if damage is None else f" kept, {damage.lost_text}"))
    if n:
        lo, hi = min(beams), max(beams)
        print(f"  beams: {lo}" + (f" to {hi}" if hi != lo else ""))
        if span is not None:  # as sensor_msgs/LaserScan: from the first beam to the last
            fov = span[1] - span[0]
            full = " (a full circle)" if fov + span[2] >= 360 - 1e-6 else ""
            print(f"  field of view: {fov:.4g} deg{full} ({span[0]:.4g} to {span[1]:.4g} deg, {span[2]:.4g} deg "
                  "per beam)")
        assert first is not None and last is not None  # set by the first scan (n > 0)
        duration = (last - first) / 1e9
        rate = f", {(n - 1) / duration:.4g} scans/s" if duration > 0 and n > 1 else ""
        print(f"  duration: {duration:.6g} s{rate}")
        sources = "; ".join(f"{frame}: {how}" for frame, how in stream.pose_sources.items())
        print(f"  poses: {stream.poses or 'none'}" + (f" ({posed} of {n} scans have one" +
                                                      (f"; {sources})" if sources else ")") if stream.poses else ""))
    if damage is not None:
        raise damage
    return 0


def cmd_demo(args: argparse.Namespace) -> int:
    from labkit.app.data import bundled_data
    from labkit.app.demo import run_demo

    source = Path(args.input) if args.input else bundled_data("hall.bag")
    result = run_demo(source, args.output, _config(args), topic=args.topic, strict=args.strict)
    print("\n".join(result.report()))
    print(f"next: '{_rerun_command()} {result.rrd}' to scrub through it, 'make lab' for the notebooks")
    if result.damage is not None:
        raise result.damage
    return 0


def cmd_evaluate(args: argparse.Namespace) -> int:
    import json

    from labkit._safe import safe_output
    from labkit.app import experiments as ex
    from labkit.io.feature_files import json_safe
    from labkit.lines import LINE_EXTRACTORS

    extractors = dict(ex.LINE_EXTRACTORS)
    if args.method:  # the registry's names, as for extract --method (its labels are accepted too)
        by_name = {e.name: e.label for e in LINE_EXTRACTORS.values()}
        unknown = [m for m in args.method if m not in by_name and m not in extractors]
        if unknown:
            raise RefusedError(f"--method {unknown[0]!r} is not a line extractor; choose from {list(by_name)}")
        labels = [by_name.get(m, m) for m in args.method]
        extractors = {label: extractors[label] for label in labels}
    if args.json:
        check_output(args.json, REPORT_FILE, overwrite=args.force, inputs=args.inputs)
    if args.topic and not args.inputs:
        raise RefusedError("--topic needs recordings to read (IN ...)")
    progress = None if args.quiet else _bar
    report: dict[str, list] = {}
    damage: list[CorruptFileError] = []
    results = []
    if args.inputs:
        from labkit.app import parallel

        inputs = parallel.recordings_in(args.inputs)
        alone = len(inputs) == 1 and args.workers is None and not args.scheduler  # one file: no Dask
        chosen = _chosen_scans(args, inputs) if isinstance(args.scans, slice) or args.time else None
        try:
            results = parallel.evaluate_many(
                inputs, extractors, n_scans=args.scans if isinstance(args.scans, int) else 100, topic=args.topic,
                strict=args.strict, workers=0 if alone else args.workers, scheduler=args.scheduler, scans=chosen,
                progress=None if args.quiet else _set_bar(f"evaluate {len(inputs)} recording(s)"))
        except KeyboardInterrupt as exc:
            return _interrupted_many(exc)
        rows = [row for r in results for row in r.rows]
        report["recordings"] = rows
        which = (f"first {args.scans if isinstance(args.scans, int) else 100} scans" if chosen is None else
                 f"scans {'' if chosen.start is None else chosen.start}:{'' if chosen.stop is None else chosen.stop}")
        print(f"## Ray-axis RMSE on {len(inputs)} recording(s), {which} each\n")
        print(ex.markdown_table(rows, ex.LOG_COLUMNS))
    else:
        if isinstance(args.scans, slice) or args.time:
            raise RefusedError("--scans A:B and --time choose scans of recordings (IN ...); the simulated sets take "
                               "--scans N")
        n = args.scans or 102
        data = ex.nguyen_set(n, noise_levels=args.noise or ex.SENSOR_NOISE_LEVELS_M)
        rows = ex.compare_lines(data, extractors, progress=progress)
        report["lines"] = rows
        print(f"## Line extractors on {n} simulated scans of 722 beams per noise level"
              " (office, corridor, random polygons)\n")
        print(ex.markdown_table(rows, ex.LINE_COLUMNS))
        if args.sweep:
            rows = ex.sweep_split_and_merge(data, progress=progress)
            report["sweep"] = rows
            print("\n## Split-and-merge (IEPF): true against false positives by split threshold\n")
            print(ex.markdown_table(rows, ex.SWEEP_COLUMNS))
        if not args.method:
            rows = list(ex.score_round_objects(300, progress=progress).values())
            report["round_objects"] = rows
            print("\n## Circles and legs of the pipeline on 300 scans of the hall\n")
            print(ex.markdown_table(rows, ex.ROUND_COLUMNS))
    if args.json:
        with safe_output(args.json, REPORT_FILE, overwrite=args.force, inputs=args.inputs) as tmp:
            tmp.write_text(json.dumps(json_safe(report), indent=1, allow_nan=False) + "\n", encoding="utf-8")
        print(f"\nwrote {args.json}", file=sys.stderr)
    for later in damage[1:]:
        print(f"labkit: error: {later}", file=sys.stderr)
    if damage:
        raise damage[0]
    if results:
        from labkit.app import parallel

        return parallel.report(results)
    return 0


def _bar(items, total=None, desc=None):
    from tqdm.auto import tqdm

    return tqdm(items, total=total, desc=desc, unit="scan", leave=False, file=sys.stderr)


FORCE_HELP = "replace an existing output, if it is labkit's own kind of output (never another file or folder)"
SCANS_HELP = ("only these scans, counted from 0 as Python slices them: 100:200 the scans 100 to 199, 100: from 100 on, "
              ":500 or 500 the first 500, --scans=-100: the last 100 (write = before a leading minus); the scan "
              "numbers in the output stay the recording's")
TIME_HELP = ("only the scans from T0 to T1 seconds after the recording's first scan: from the first scan at or after "
             "T0 up to the first at or after T1 (60:120, 60:, :30); its stamps are read once to place the range")


def _either(labels: list[str]) -> str:
    return ", ".join(labels[:-1]) + f" or {labels[-1]}" if len(labels) > 1 else "".join(labels)


def _readable_help() -> str:
    """What the commands that read recordings take (labkit.io.FORMATS)."""
    return ", ".join(f.label for f in FORMATS.values())


def build_parser() -> argparse.ArgumentParser:
    from labkit.pipeline import line_methods  # the registered line extractors, read when the parser is built

    p = argparse.ArgumentParser(prog="labkit", description=__doc__.splitlines()[0],
                                epilog="Exit status: 0 done; 1 done, but an input was damaged (every readable "
                                       "record is in the output); 2 refused (bad command line or input); 3 the "
                                       "system refused (permissions, disk full); 70 a bug in labkit; 130 "
                                       "interrupted. See the README, 'When things go wrong'.")
    p.add_argument("--version", action="version", version=f"labkit {__version__}")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bars")
    p.add_argument("--debug", action="store_true", help="show the traceback of every error")
    common = argparse.ArgumentParser(add_help=False)  # -q also after the command
    common.add_argument("-q", "--quiet", action="store_true", default=argparse.SUPPRESS, help="no progress bars")
    reading = argparse.ArgumentParser(add_help=False)  # every command that reads recordings
    reading.add_argument("--strict", action="store_true",
                         help="stop at the first record that cannot be read (default: skip it, count it, read on)")
    reading.add_argument("--poses", metavar="TOPIC",
                         help="where a bag's sensor poses come from: a nav_msgs/Odometry or tf topic, or 'none' "
                         "(default: /tf if it moves the laser, else the one odometry topic; CARMEN logs: the log's)")
    ranged = argparse.ArgumentParser(add_help=False)  # commands that can read a range of a recording
    choose = ranged.add_mutually_exclusive_group()
    choose.add_argument("--scans", type=_scan_range, metavar="A:B", help=SCANS_HELP)
    choose.add_argument("--time", type=_time_range, metavar="T0:T1", help=TIME_HELP)
    many = argparse.ArgumentParser(add_help=False)  # commands that run many recordings on Dask
    many.add_argument("--workers", type=int, metavar="N",
                      help="run the recordings on a local Dask cluster of N worker processes (default: one per "
                      "core when there are several recordings; 0: one after another in this process)")
    many.add_argument("--scheduler", metavar="ADDRESS",
                      help="run the recordings on an existing Dask cluster (tcp://host:8786); paths are made absolute "
                      "here, and every worker must see the inputs and outputs under those same paths")
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND")
    sub.add_parser = partial(sub.add_parser, parents=[common])  # type: ignore[method-assign]  # every command takes -q

    s = sub.add_parser("simulate", help="simulate a world into a bag with ground truth beside it")
    s.add_argument("world", nargs="?", help="hall, corridor, office or random_polygons_<seed>")
    s.add_argument("-o", "--output", help="bag path: .bag (ROS1), .mcap, or a folder (ROS2 sqlite3)")
    s.add_argument("--format", choices=["ros1", "ros2", "mcap"], help="bag format (default: from the name)")
    s.add_argument("--seed", type=int, default=0, help="noise seed (default 0)")
    s.add_argument("--scans", type=int, help="number of scans (default: the scenario's duration)")
    s.add_argument("--sensor", choices=sorted(sim.LIDARS),
                   help="the lidar (labkit.sim.LIDARS; default: the scenario's): lms200 180 deg/361 beams, "
                   "lms111 270 deg/541 beams, xv11 360 deg/360 beams")
    s.add_argument("--beams", type=int, metavar="N",
                   help="N beams over the sensor's field of view (e.g. --sensor lms200 --beams 722: the 722-beam "
                   "180-degree scanner of the evaluation)")
    s.add_argument("--bundled", action="store_true", help="regenerate every bundled recording into -o (data/)")
    s.add_argument("-f", "--force", action="store_true", help=FORCE_HELP)
    s.set_defaults(func=cmd_simulate)

    c = sub.add_parser("convert", parents=[common, reading, ranged],
                       help="convert between bag formats (every topic, names kept), CARMEN logs and JSON (the scans)")
    c.add_argument("input", help=f"recording ({_readable_help()})")
    c.add_argument("output", help=_either([f.label for f in FORMATS.values() if f.writable]))
    c.add_argument("--topic", help="LaserScan topic (bags) or laser message (CARMEN)")
    c.add_argument("--format", choices=writable_formats(),
                   help="output format (default: from the name; must agree with it)")
    c.add_argument("--only-scans", action="store_true",
                   help="between bags, copy the scans alone (the LaserScan topic as /scan, their poses as /odom) "
                   "instead of every topic under its own name")
    c.add_argument("-f", "--force", action="store_true", help=FORCE_HELP)
    c.set_defaults(func=cmd_convert)

    noise = argparse.ArgumentParser(add_help=False)  # the noise-following thresholds
    noise.add_argument("--range-noise", type=_range_noise, metavar="auto|M|fixed",
                       help="how the thresholds follow the sensor's range noise: auto (estimated from each scan, "
                       "the default), the noise in metres (e.g. 0.03 for a cheap 360-degree scanner), or fixed "
                       "(the papers' fixed thresholds, labkit.noise.FIXED_CONFIG); sets those keys over the "
                       "config (see the README, 'Unknown range noise')")
    pipeline = argparse.ArgumentParser(add_help=False, parents=[noise])  # every command that runs the pipeline
    pipeline.add_argument("--topic", help="LaserScan topic (bags) or laser message (CARMEN)")
    pipeline.add_argument("--config", help="TOML file of extractor parameters (write one with `labkit config -o`)")
    pipeline.add_argument("--method", choices=line_methods(),
                          help="line extractor (overrides the config's lines.method; the names of "
                          "labkit.lines.LINE_EXTRACTORS, or none)")

    e = sub.add_parser("extract", parents=[common, pipeline, reading, many, ranged],
                       help="extract every feature of every scan into JSON lines (one record per scan) or a "
                       "Parquet table (one row per feature); several recordings run in parallel on Dask")
    e.add_argument("inputs", nargs="+", metavar="IN",
                   help=f"recordings ({_readable_help()}) or folders of them")
    e.add_argument("-o", "--output", default="-",
                   help="features file (.jsonl; default: standard output) or table (.parquet); for several "
                   "recordings a folder (one NAME.features.jsonl each) or one .parquet table for all")
    e.add_argument("-f", "--force", action="store_true", help=FORCE_HELP)
    e.set_defaults(func=cmd_extract)

    v = sub.add_parser("view", parents=[common, pipeline, reading, ranged],
                       help="write a recording's scans and features to a rerun .rrd file",
                       description="Write a recording's scans and features to a rerun .rrd file, as they are read. "
                       "Memory: about 400 MiB at 100,000 scans of 541 beams with the ground truth, 150 MiB of it "
                       "numba's compiler (mostly its library, mapped from disk); LABKIT_NO_JIT=1 does without it "
                       "(250 MiB), some 20 percent slower (benchmarks/io.py).")
    v.add_argument("input", help=f"recording ({_readable_help()})")
    v.add_argument("-o", "--output", required=True, help="the .rrd file to write")
    v.add_argument("-f", "--force", action="store_true", help=FORCE_HELP)
    v.add_argument("--no-features", action="store_true", help="scans and range segments only")
    v.add_argument("--tracks", action="store_true",
                   help="also follow people and moving circles (the config's [tracking] section, as `labkit track`) "
                   "and draw each track in a colour of its own with its id, its trail over the last 3 s and its "
                   "velocity, in the scan view and the map view; births, confirmations and deletions in the "
                   "'Track events' log")
    v.add_argument("--spawn", action="store_true", help="open the rerun viewer on the result")
    v.set_defaults(func=cmd_view)

    t = sub.add_parser("track", parents=[common, pipeline, reading, ranged],
                       help="follow people and moving circles over time: one CSV row per track per scan")
    t.add_argument("input", help=f"recording ({_readable_help()})")
    t.add_argument("-o", "--output", required=True, help="the tracks table to write (.csv)")
    t.add_argument("-f", "--force", action="store_true", help=FORCE_HELP)
    t.set_defaults(func=cmd_track)

    b = sub.add_parser("bench", parents=[common, pipeline, reading, ranged],
                       help="time every pipeline stage on a recording (default: the bundled hall.bag)")
    b.add_argument("input", nargs="?", help="recording (default: the bundled hall.bag)")
    b.set_defaults(func=cmd_bench)

    g = sub.add_parser("config", parents=[common, noise],
                       help="print the default extractor config as TOML, or write it with -o")
    g.add_argument("input", nargs="?", help="a config to check and print (default: the defaults)")
    g.add_argument("-o", "--output", help="write the TOML file here")
    g.add_argument("-f", "--force", action="store_true", help=FORCE_HELP)
    g.set_defaults(func=cmd_config)

    i = sub.add_parser("info", help="format, topics, scans (read in full: kept and lost), beams, field of view, "
                       "duration, scan rate and pose sources of a recording")
    i.add_argument("input", help=f"recording ({_readable_help()})")
    i.add_argument("--topic", help="LaserScan topic (bags) or laser message (CARMEN) to describe")
    i.set_defaults(func=cmd_info)

    ev = sub.add_parser("evaluate", parents=[common, reading, many],
                        help="score the line extractors against ground truth (simulated) or by ray-axis"
                        " RMSE on recordings, and circles and legs on the hall")
    ev.add_argument("inputs", nargs="*", metavar="IN",
                    help="recordings (or folders of them) to score by ray-axis RMSE, in parallel on Dask when "
                    "there are several (default: the simulated sets with ground truth)")
    ev.add_argument("--topic", help="LaserScan topic (bags) or laser message (CARMEN) of the recordings")
    choose = ev.add_mutually_exclusive_group()
    choose.add_argument("--scans", type=_scan_range, metavar="N|A:B",
                        help="scans per noise level (simulated, default 102) or the first N of each recording (default "
                        "100); A:B a range of each recording, as for extract")
    choose.add_argument("--time", type=_time_range, metavar="T0:T1", help=TIME_HELP)
    ev.add_argument("--noise", type=float, nargs="+", metavar="M",
                    help="range noise levels of the simulated sets, metres (default: 5 mm, 1 cm, 2 cm and 3 cm, "
                         "labkit.app.experiments.SENSOR_NOISE_LEVELS_M)")
    ev.add_argument("--method", action="append", metavar="NAME",
                    help=f"only this line extractor (repeatable): {', '.join(line_methods()[:-1])}")
    ev.add_argument("--sweep", action="store_true", help="also sweep split-and-merge's split threshold")
    ev.add_argument("--json", help="also write every table's rows to this JSON file (strict JSON: null for no value)")
    ev.add_argument("-f", "--force", action="store_true", help=FORCE_HELP)
    ev.set_defaults(func=cmd_evaluate)

    d = sub.add_parser("demo", parents=[common, pipeline, reading],
                       help="the README's demo: every feature of the bundled hall bag into .rrd and .png")
    d.add_argument("input", nargs="?", help="recording (default: the bundled hall.bag)")
    d.add_argument("-o", "--output", default="out", help="output folder (default out/); demo.rrd and demo.png "
                   "there are replaced")
    d.set_defaults(func=cmd_demo)

    add_grade_parser(sub)  # labkit grade: the instructor's grader (labkit.grading)
    _add_lab_parser(sub)  # labkit lab: the students' JupyterLab (labkit.grading.lab)
    return p


def cmd_lab(args: argparse.Namespace) -> int:
    """``labkit lab [FOLDER]``: the students' JupyterLab (labkit.grading.lab)."""
    from labkit.grading.lab import run_lab

    extra = (["--no-browser"] if args.no_browser else []) + ([f"--port={args.port}"] if args.port else [])
    return run_lab(args.folder, open_path=args.open_path, extra=extra)


def _add_lab_parser(sub) -> None:
    lab = sub.add_parser(
        "lab", help="open the students' JupyterLab on a folder (instructor tools hidden, Validate = grade --check)",
        description="Open JupyterLab on FOLDER (default: the current folder) the way the course is meant to be "
        "worked: nbgrader's instructor tools hidden, Validate running `labkit grade --check` on the notebook "
        "(your code in the grading sandbox: the verdicts it will be graded with), the rerun viewers offline. "
        "Example: labkit lab ~/labkit-exercises. Stop it with Ctrl-C.")
    lab.add_argument("folder", nargs="?", default=".", help="the folder to serve (default: the current folder)")
    lab.add_argument("--open", dest="open_path", metavar="NOTEBOOK",
                     help="a notebook to open first, relative to FOLDER")
    lab.add_argument("--no-browser", action="store_true", help="print the address instead of opening a browser")
    lab.add_argument("--port", type=int, help="the port to serve on (default: the first free one from 8888)")
    lab.set_defaults(func=cmd_lab)


def _show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    """Warnings reach the user as one line each: ``labkit: note: ...``."""
    print(f"labkit: note: {message}", file=sys.stderr)


def _raised_by_labkit(exc: BaseException) -> bool:
    """Whether ``exc`` was raised by labkit's own code (an expected error: bad input, refused
    request) rather than deep inside a library labkit calls (a bug to report)."""
    tb = exc.__traceback__
    last = None
    while tb is not None:
        last = tb.tb_frame.f_code.co_filename
        tb = tb.tb_next
    here = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))  # the labkit package
    return last is None or os.path.abspath(last).startswith(here + os.sep)


def _error(message: str) -> None:
    print(f"labkit: error: {message}", file=sys.stderr)


#: rerun's own log lines that would repeat, as a Rust log line, an error labkit reports in its one line
#: (a file writer that stopped: a full disk). Set as RUST_LOG for the command line unless the user set one.
_RERUN_QUIET = "warn,re_log_encoding::rrd=off,re_sdk::recording_stream=off"


def main(argv: list[str] | None = None) -> int:
    """Run the command line; returns the exit status (see the module docstring)."""
    args = build_parser().parse_args(argv)
    if "rerun" not in sys.modules:  # read when rerun is first imported
        os.environ.setdefault("RUST_LOG", _RERUN_QUIET)
    debug = args.debug or bool(os.environ.get("LABKIT_DEBUG"))
    with warnings.catch_warnings():
        warnings.showwarning = _show_warning
        try:
            return args.func(args)
        except CorruptFileError as exc:
            if debug:
                traceback.print_exc()
            _error(str(exc))
            return EXIT_DAMAGED
        except OutputInterrupted as exc:
            where = f"; what was written so far is in {exc.partial}" if exc.partial else ""
            print(f"labkit: interrupted: {exc.target} was not changed{where}", file=sys.stderr)
            return EXIT_INTERRUPTED
        except KeyboardInterrupt:
            print("labkit: interrupted", file=sys.stderr)
            return EXIT_INTERRUPTED
        except BrokenPipeError:
            with contextlib.suppress(OSError):  # stdout's reader went away: say nothing more there
                os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
            return EXIT_PIPE
        except RefusedError as exc:
            if debug:
                traceback.print_exc()
            _error(exc.cli)
            return EXIT_REFUSED
        except FileNotFoundError as exc:
            if debug:
                traceback.print_exc()
            _error(f"{exc.filename}: no such file or folder" if exc.filename else str(exc))
            return EXIT_REFUSED
        except OSError as exc:
            if debug:
                traceback.print_exc()
            _error(f"{exc.filename}: {exc.strerror}" if exc.filename and exc.strerror else
                   exc.strerror or str(exc))
            return EXIT_SYSTEM
        except ValueError as exc:
            if _raised_by_labkit(exc):
                if debug:
                    traceback.print_exc()
                _error(str(exc))
                return EXIT_REFUSED
            _report_bug()
            return EXIT_BUG
        except Exception:  # noqa: BLE001 - anything else is a bug: show it, and how to report it
            _report_bug()
            return EXIT_BUG


def _report_bug() -> None:
    traceback.print_exc()
    print(f"labkit: internal error: this is a bug in labkit {__version__}, not a problem with your data or "
          "command line. Please report it to the labkit developers with the command you ran, `labkit --version` "
          "and the traceback above.", file=sys.stderr)


if __name__ == "__main__":
    sys.exit(main())

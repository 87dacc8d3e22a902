"""The ``labkit`` command line: simulate, convert, view, inspect and demo recordings.

Run ``labkit --help`` or ``labkit COMMAND --help``. Errors print one line that says what
to do and exit with status 1; a damaged input file still produces its output with every
readable scan, then exits with status 1.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time
from functools import partial
from pathlib import Path

from . import sim
from .io import FORMATS, CorruptFileError, convert, detect_format, read_scans

EXIT_ERROR = 1


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
    from .data import generate_bundled, write_simulation

    if args.bundled:
        out = Path(args.output or "data")
        paths = generate_bundled(out, progress=not args.quiet)
        for p in paths:
            print(p)
        return 0
    if not args.world or not args.output:
        raise ValueError("give a WORLD and -o OUTPUT (or --bundled); worlds: hall, corridor, office, "
                         "random_polygons_<seed>")
    sc = sim.scenario(args.world)
    n = args.scans or sc.n_scans
    bag, truth, count = write_simulation(
        sc, args.output, args.format, seed=args.seed, n_scans=n, overwrite=args.force,
        progress=None if args.quiet else _progress(n, f"simulate {args.world}"),
    )
    print(f"wrote {count} scans to {bag} and their ground truth to {truth}")
    return 0


def cmd_convert(args: argparse.Namespace) -> int:
    n = convert(args.input, args.output, topic=args.topic, format=args.format, overwrite=args.force,
                progress=not args.quiet)
    print(f"wrote {n} scans to {args.output}")
    return 0


def cmd_view(args: argparse.Namespace) -> int:
    from .viz import rr as lkrr

    summary = lkrr.record(args.input, args.output, topic=args.topic, progress=not args.quiet)
    extra = f" and ground truth for {summary.n_truth}" if summary.n_truth else ""
    print(f"wrote {summary.n_scans} scans{extra} to {summary.path}")
    if args.spawn:
        subprocess.Popen([sys.executable, "-m", "rerun", str(summary.path)])
    else:
        print(f"open it with: {_rerun_command()} {summary.path}")
    if summary.error is not None:
        raise summary.error
    return 0


def cmd_info(args: argparse.Namespace) -> int:
    from .io import bags

    fmt = detect_format(args.input)
    print(f"{args.input}: {FORMATS[fmt]}")
    if fmt in bags.BAG_FORMATS:
        topics, readable = bags.list_topics(Path(args.input), fmt)
        if not readable:
            print("  damaged: rosbags cannot open it; labkit reads it sequentially")
        for name, msgtype, count in topics:
            print(f"  {name:30s} {msgtype:35s} {count if count is not None else '?'} messages")
    else:
        stream = read_scans(args.input)
        first = next(iter(stream), None)
        print(f"  {stream.count if stream.count is not None else '?'} scans" +
              (f"; first: {first!r}" if first is not None else ""))
    return 0


def cmd_demo(args: argparse.Namespace) -> int:
    import matplotlib

    matplotlib.use("Agg")
    import numpy as np

    from .data import bundled_data
    from .segmentation import segment_labels
    from .viz import plot
    from .viz import rr as lkrr

    source = Path(args.input) if args.input else bundled_data("hall.bag")
    out = Path(args.output)
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    scans = list(read_scans(source))
    t_read = time.perf_counter() - t0
    t0 = time.perf_counter()
    labels = [segment_labels(s) for s in scans]
    t_seg = time.perf_counter() - t0
    truth_file = sim.truth_path_for(source)
    truth = sim.read_truth(truth_file) if truth_file.exists() else None
    t0 = time.perf_counter()
    summary = lkrr.record_scans(scans, out / "demo.rrd", name=source.name, truth=truth, labels=labels,
                                description=f"# labkit demo: {source.name}\n\nColours in `world/segments` "
                                "are range segments (0.08 m threshold); `world/truth` is the ground truth.")
    t_rrd = time.perf_counter() - t0
    k = len(scans) // 2
    fig = plot.scan_figure(scans[k], labels=labels[k], truth=truth.scans.get(scans[k].stamp_ns) if truth else None,
                           title=f"{source.name}, scan {k}: range segments (0.08 m threshold)")
    fig.savefig(out / "demo.png", dpi=110)
    n_valid = np.array([s.valid.sum() for s in scans])
    n_seg = np.array([lab.max() + 1 for lab in labels])
    n = len(scans)
    print(f"labkit demo on {source}")
    print(f"  {n} scans of {scans[0].n_beams} beams, {n_valid.mean() / scans[0].n_beams:.1%} valid on average")
    print(f"  range segments per scan: mean {n_seg.mean():.1f}, min {n_seg.min()}, max {n_seg.max()}")
    print(f"  read {n / t_read:,.0f} scans/s, segmented {n / t_seg:,.0f} scans/s, "
          f"wrote .rrd at {n / t_rrd:,.0f} scans/s")
    print(f"  wrote {out / 'demo.rrd'} ({summary.n_scans} scans, ground truth for {summary.n_truth})"
          f" and {out / 'demo.png'}")
    print(f"next: '{_rerun_command()} {out / 'demo.rrd'}' to scrub through it, 'make lab' for the notebooks")
    return 0


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="labkit", description=__doc__.splitlines()[0])
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bars")
    common = argparse.ArgumentParser(add_help=False)  # -q also after the command
    common.add_argument("-q", "--quiet", action="store_true", default=argparse.SUPPRESS, help="no progress bars")
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND")
    sub.add_parser = partial(sub.add_parser, parents=[common])  # every command takes -q

    s = sub.add_parser("simulate", help="simulate a world into a bag with ground truth beside it")
    s.add_argument("world", nargs="?", help="hall, corridor, office or random_polygons_<seed>")
    s.add_argument("-o", "--output", help="bag path: .bag (ROS1), .mcap, or a folder (ROS2 sqlite3)")
    s.add_argument("--format", choices=["ros1", "ros2", "mcap"], help="bag format (default: from the name)")
    s.add_argument("--seed", type=int, default=0, help="noise seed (default 0)")
    s.add_argument("--scans", type=int, help="number of scans (default: the scenario's duration)")
    s.add_argument("--bundled", action="store_true", help="regenerate every bundled recording into -o (data/)")
    s.add_argument("-f", "--force", action="store_true", help="overwrite the output")
    s.set_defaults(func=cmd_simulate)

    c = sub.add_parser("convert", help="convert between bag formats, CARMEN logs and JSON")
    c.add_argument("input")
    c.add_argument("output", help=".bag, .mcap, a folder (ROS2 sqlite3), .jsonl or .json")
    c.add_argument("--topic", help="LaserScan topic (bags) or laser message (CARMEN)")
    c.add_argument("--format", choices=["ros1", "ros2", "mcap", "jsonl", "json"])
    c.add_argument("-f", "--force", action="store_true", help="overwrite the output")
    c.set_defaults(func=cmd_convert)

    v = sub.add_parser("view", help="write a recording's scans to a rerun .rrd file")
    v.add_argument("input")
    v.add_argument("-o", "--output", required=True, help="the .rrd file to write")
    v.add_argument("--topic", help="LaserScan topic (bags) or laser message (CARMEN)")
    v.add_argument("--spawn", action="store_true", help="open the rerun viewer on the result")
    v.set_defaults(func=cmd_view)

    i = sub.add_parser("info", help="format, topics and scan counts of a file")
    i.add_argument("input")
    i.set_defaults(func=cmd_info)

    d = sub.add_parser("demo", help="the README's demo: segment the bundled hall bag, write .rrd and .png")
    d.add_argument("input", nargs="?", help="recording (default: the bundled hall.bag)")
    d.add_argument("-o", "--output", default="out", help="output folder (default out/)")
    d.set_defaults(func=cmd_demo)
    return p


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except CorruptFileError as exc:
        print(f"labkit: error: {exc}", file=sys.stderr)
        return EXIT_ERROR
    except (ValueError, FileNotFoundError) as exc:
        print(f"labkit: error: {exc}", file=sys.stderr)
        return EXIT_ERROR
    except KeyboardInterrupt:
        return 130


if __name__ == "__main__":
    sys.exit(main())

"""Many recordings on Dask: scans per second with 1 and 2 workers, Dask's overhead, memory.

Part 1 -- ``labkit.app.parallel.extract_many`` (read, extract every feature, write JSON lines) on two
sets, each with a local Dask cluster of 1 and of 2 single-threaded worker processes, started before
the clock runs (its start-up is printed apart):

- ``simulated``: 8 equal bags (the corridor scenario, 300 scans of 541 beams each, 8 seeds);
- ``radish``: the six Radish CARMEN logs in ../shared/datasets (8,725 scans; skipped when
  absent). Their sizes are uneven -- freiburg-079 alone is about two thirds of the work -- so with
  one task per recording two workers could not halve the time (the bound total / largest is
  printed). With 2 workers, ``extract_many`` splits a recording longer than its share into scan
  ranges (``labkit.app.parallel.split_ranges``): the ranges it cut are printed, and the outputs of
  the 2-worker runs are checked against the 1-worker run's, record for record. The 2 workers run
  twice: before (``split=False``, one task per recording, as before issue 30) and after.

Part 2 -- the Radish logs one at a time: the plain loop (``workers=0``), 1 worker and 2 workers
for each log alone (a log longer than 2 x ``MIN_PIECE_SCANS`` scans is split in two).

Part 3 -- Dask's overhead for one recording: the same task in this process (the plain loop,
``workers=0``) against one Dask worker, best of ``--repeat`` runs each.

Part 4 -- peak resident memory of every worker process (its own high-water mark, VmHWM), and of
the plain loop.

Goals (issues 17 and 30): >= 1.8x the scans per second with 2 workers on this 2-core machine, the
Radish set included; <= 10 % overhead of Dask against the plain loop for one file.

Run: ``python benchmarks/parallel.py [--repeat 3] [--scans 300] [--no-alone]`` (``--no-alone`` skips
Part 2). Several minutes on 2 idle cores; on a loaded machine the ratios fall.
"""

from __future__ import annotations

import argparse
import json
import logging
import os
import shutil
import tempfile
import time
from pathlib import Path

from labkit.app import parallel
from labkit.app.data import write_simulation

SHARED = Path(os.environ.get("LABKIT_SHARED_DATASETS", Path(__file__).resolve().parents[2] / "shared" / "datasets"))


def simulated_set(folder: Path, n_scans: int, n_bags: int = 8) -> list[Path]:
    return [write_simulation("corridor", folder / f"corridor{k}.bag", "ros1", seed=k, n_scans=n_scans)[0]
            for k in range(n_bags)]


def timed_run(inputs, out: Path, **where) -> tuple[float, list]:
    t0 = time.perf_counter()
    results = parallel.extract_many(inputs, out, overwrite=True, **where)  # a fresh output each call
    dt = time.perf_counter() - t0
    bad = [r for r in results if r.status != "done"]
    if bad:
        raise SystemExit(f"{bad[0].input}: {bad[0].status}: {bad[0].error}")
    return dt, results


def records(path: str) -> list[dict]:
    """A features file's records without their stage timings (which differ from run to run)."""
    out = []
    with open(path, encoding="utf-8") as fh:
        for line in fh:
            record = json.loads(line)
            record.pop("timings_ms")
            out.append(record)
    return out


def same_output(a: list, b: list) -> bool:
    return all(records(x.output) == records(y.output) for x, y in zip(a, b, strict=True))


def cluster(n: int):
    from distributed import Client, LocalCluster

    t0 = time.perf_counter()
    c = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=":0",
                     silence_logs=logging.ERROR)
    client = Client(c)
    client.run(lambda: __import__("labkit.app.parallel"))  # every worker has imported labkit before the clock runs
    return c, client, time.perf_counter() - t0


def best_of(repeat: int, run) -> tuple[float, list]:
    best = None
    for _ in range(repeat):
        dt, results = run()
        if best is None or dt < best[0]:
            best = (dt, results)
    return best


def main() -> None:
    tmp = Path(tempfile.mkdtemp(prefix="labkit-bench-parallel-"))
    try:
        run(tmp)
    finally:  # also on Ctrl-C: the simulated bags and every output are this run's own
        shutil.rmtree(tmp, ignore_errors=True)


def run(tmp: Path) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--scans", type=int, default=300, help="scans per simulated bag")
    ap.add_argument("--no-alone", action="store_true", help="skip Part 2 (each Radish log alone)")
    args = ap.parse_args()
    logging.getLogger("distributed").setLevel(logging.ERROR)  # the scheduler runs in this process: no INFO lines
    sets = {"simulated": simulated_set(tmp / "sim", args.scans)}
    logs = sorted((SHARED / "carmen").glob("*.log.gz"))
    if logs:
        sets["radish"] = logs
    else:
        print(f"(the Radish logs are not in {SHARED}: that set is skipped)")
    sizes = {name: parallel.preflight(paths) for name, paths in sets.items()}
    clusters = {}
    for n in (1, 2):
        c, client, start = cluster(n)
        clusters[n] = (c, client)
        print(f"local cluster of {n} worker(s) started in {start:.1f} s (not in the times below)")

    print("\n## Scans per second, the whole set in one run (read, extract, write JSON lines)\n")
    print("2 workers before: one task per recording (``split=False``, as before issue 30); after: a recording "
          "longer than its share split into scan ranges (the default).\n")
    print("| set | recordings | scans | 1 worker (scans/s) | 2 workers before (scans/s) | ratio before "
          "| 2 workers after (scans/s) | ratio after | one task per recording could reach | ranges cut for 2 workers "
          "| 2 workers = 1 worker |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    memory: dict[str, float] = {}
    goal = {}
    for name, paths in sets.items():
        total = sum(sizes[name])
        rates, outputs = {}, {}
        for key, n, split in (("1", 1, True), ("2 before", 2, False), ("2 after", 2, True)):
            dt, results = best_of(args.repeat, lambda n=n, name=name, paths=paths, split=split, key=key: timed_run(
                paths, tmp / f"out-{name}-{key.replace(' ', '-')}", client=clusters[n][1], split=split))
            rates[key], outputs[key] = total / dt, results
            for r in results:
                for w in r.worker.split(", "):
                    memory[f"{n} worker(s): {w}"] = max(memory.get(f"{n} worker(s): {w}", 0.0), r.peak_rss_mb)
        bound = total / max(sizes[name])  # work is not exactly proportional to scans (beams differ), but near
        cut = ", ".join(f"{p.name.split('-')[0]} into {len(plan)}" for p, plan in
                        zip(paths, parallel.split_ranges(sizes[name], 2), strict=True) if plan) or "none"
        same = same_output(outputs["1"], outputs["2 after"]) and same_output(outputs["1"], outputs["2 before"])
        goal[name] = rates["2 after"] / rates["1"]
        print(f"| {name} | {len(paths)} | {total:,} | {rates['1']:,.0f} | {rates['2 before']:,.0f} "
              f"| {rates['2 before'] / rates['1']:.2f}x | {rates['2 after']:,.0f} | {goal[name]:.2f}x "
              f"| {min(bound, 2.0):.2f}x | {cut} | {'yes' if same else 'NO'} |")
    for name, ratio in goal.items():
        print(f"\n{name}: {ratio:.2f}x with 2 workers against 1 -- goal >= 1.8x "
              f"{'met' if ratio >= 1.8 else 'NOT met'}")

    if "radish" in sets and not args.no_alone:
        print(f"\n## Each Radish log alone (seconds, best of {args.repeat})\n")
        print("| log | scans | plain loop | 1 worker | 2 workers | 2 workers / 1 worker | 2 workers / plain loop |")
        print("|---|---|---|---|---|---|---|")
        totals = [0.0, 0.0, 0.0]
        for path, n_scans in zip(sets["radish"], sizes["radish"], strict=True):
            times = [best_of(args.repeat, lambda w=w, path=path: timed_run(
                [path], tmp / f"alone-{w}", **({"workers": 0} if w is None else {"client": clusters[w][1]})))[0]
                for w in (None, 1, 2)]
            totals = [a + b for a, b in zip(totals, times, strict=True)]
            print(f"| {path.name.split('-')[0]} | {n_scans:,} | {times[0]:.2f} | {times[1]:.2f} | {times[2]:.2f} | "
                  f"{times[1] / times[2]:.2f}x | {times[0] / times[2]:.2f}x |")
        print(f"| sum of the six | {sum(sizes['radish']):,} | {totals[0]:.2f} | {totals[1]:.2f} | {totals[2]:.2f} | "
              f"{totals[1] / totals[2]:.2f}x | {totals[0] / totals[2]:.2f}x |")

    one = max(sets.get("radish", sets["simulated"]), key=lambda p: p.stat().st_size)
    n_one = parallel.preflight([one])[0]
    plain_dt, plain = best_of(args.repeat, lambda: timed_run([one], tmp / "plain", workers=0))
    dask_dt, _ = best_of(args.repeat, lambda: timed_run([one], tmp / "dask1", client=clusters[1][1]))
    memory["plain loop (this process)"] = plain[0].peak_rss_mb
    print(f"\n## Dask against the plain loop, one recording ({one.name}, {n_one:,} scans), best of {args.repeat}\n")
    print("| run | seconds | scans/s |")
    print("|---|---|---|")
    print(f"| plain loop (workers=0) | {plain_dt:.2f} | {n_one / plain_dt:,.0f} |")
    print(f"| Dask, 1 worker | {dask_dt:.2f} | {n_one / dask_dt:,.0f} |")
    print(f"\noverhead of Dask: {100 * (dask_dt - plain_dt) / plain_dt:+.1f} % (goal <= 10 %)")

    print("\n## Peak resident memory per process (MiB, since the process started)\n")
    print("| process | peak RSS (MiB) |")
    print("|---|---|")
    for who, mb in sorted(memory.items()):
        print(f"| {who} | {mb:,.0f} |")
    for c, client in clusters.values():
        client.close()
        c.close()


if __name__ == "__main__":
    main()

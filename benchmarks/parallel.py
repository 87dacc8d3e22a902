"""Many recordings on Dask: scans per second with 1 and 2 workers, Dask's overhead, memory.

Part 1 -- ``labkit.parallel.extract_many`` (one task per recording: read, extract every feature,
write JSON lines) on two sets, each with a local Dask cluster of 1 and of 2 single-threaded
worker processes, started before the clock runs (its start-up is printed apart):

- ``simulated``: 8 equal bags (the corridor scenario, 300 scans of 541 beams each, 8 seeds);
- ``radish``: the six Radish CARMEN logs in ../shared/datasets (8,725 scans; skipped when
  absent). Their sizes are uneven -- freiburg-079 alone is about half the work -- so two
  workers cannot halve the time: the bound is total / largest, printed beside the ratio.

Part 2 -- Dask's overhead for one recording: the same task in this process (the plain loop,
``workers=0``) against one Dask worker, best of ``--repeat`` runs each.

Part 3 -- peak resident memory of every worker process (``getrusage``), and of the plain loop.

Goals (issue 17): >= 1.8x the scans per second with 2 workers on this 2-core machine; <= 10 %
overhead of Dask against the plain loop for one file.

Run: ``python benchmarks/parallel.py [--repeat 3] [--scans 300]``
"""

from __future__ import annotations

import argparse
import logging
import os
import tempfile
import time
from pathlib import Path

from labkit import parallel
from labkit.data import write_simulation

SHARED = Path(os.environ.get("LABKIT_SHARED_DATASETS", Path(__file__).resolve().parents[2] / "shared" / "datasets"))


def simulated_set(folder: Path, n_scans: int, n_bags: int = 8) -> list[Path]:
    return [write_simulation("corridor", folder / f"corridor{k}.bag", "ros1", seed=k, n_scans=n_scans)[0]
            for k in range(n_bags)]


def timed_run(inputs, out: Path, **where) -> tuple[float, list]:
    t0 = time.perf_counter()
    results = parallel.extract_many(inputs, out, overwrite=True, **where)
    dt = time.perf_counter() - t0
    bad = [r for r in results if r.status != "done"]
    if bad:
        raise SystemExit(f"{bad[0].input}: {bad[0].status}: {bad[0].error}")
    return dt, results


def cluster(n: int):
    from distributed import Client, LocalCluster

    t0 = time.perf_counter()
    c = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=":0",
                     silence_logs=logging.ERROR)
    client = Client(c)
    client.run(lambda: __import__("labkit.parallel"))  # every worker has imported labkit before the clock runs
    return c, client, time.perf_counter() - t0


def best_of(repeat: int, run) -> tuple[float, list]:
    best = None
    for _ in range(repeat):
        dt, results = run()
        if best is None or dt < best[0]:
            best = (dt, results)
    return best


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--scans", type=int, default=300, help="scans per simulated bag")
    args = ap.parse_args()
    logging.getLogger("distributed").setLevel(logging.ERROR)  # the scheduler runs in this process: no INFO lines
    tmp = Path(tempfile.mkdtemp(prefix="labkit-bench-parallel-"))
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

    print("\n## Scans per second, one task per recording (read, extract, write JSON lines)\n")
    print("| set | recordings | scans | 1 worker (scans/s) | 2 workers (scans/s) | ratio | bound (total / largest) |")
    print("|---|---|---|---|---|---|---|")
    memory: dict[str, float] = {}
    for name, paths in sets.items():
        total = sum(sizes[name])
        rates = {}
        for n in (1, 2):
            dt, results = best_of(args.repeat, lambda n=n, name=name, paths=paths: timed_run(
                paths, tmp / f"out-{name}-{n}", client=clusters[n][1]))
            rates[n] = total / dt
            for r in results:
                memory[f"{n} worker(s): {r.worker}"] = max(memory.get(f"{n} worker(s): {r.worker}", 0.0),
                                                           r.peak_rss_mb)
        bound = total / max(sizes[name])  # work is not exactly proportional to scans (beams differ), but near
        print(f"| {name} | {len(paths)} | {total:,} | {rates[1]:,.0f} | {rates[2]:,.0f} | {rates[2] / rates[1]:.2f}x "
              f"| {min(bound, 2.0):.2f}x |")

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

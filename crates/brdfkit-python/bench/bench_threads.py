"""Threads, processes and RAYON_NUM_THREADS with brdfkit (docs/python.md, "Threads").

    .venv/bin/python crates/brdfkit-python/bench/bench_threads.py [--tables N]

Every heavy call releases the GIL, but it also runs on every core already (rayon), so
Python threads should add nothing to one large call; what can help is running
several independent small jobs at once, each on one core. Measured here:

1. lookups: one call on 2 x 729,000 pairs against two threads of 729,000 pairs each;
2. fits of N tables (the five committed measured proxies on a 45 x 45 x 90 grid,
   repeated to N, cook-torrance, `fit`'s defaults): one after the other in one
   process; in a thread pool of as many threads as cores; and in a process pool
   of as many processes as cores (started with "spawn"), each with
   RAYON_NUM_THREADS=1.

Each figure is the median of the repeats (wall time); the load average is printed
before and after (the machine is shared).
"""

from __future__ import annotations

import argparse
import multiprocessing
import os
import tempfile
from concurrent.futures import ProcessPoolExecutor, ThreadPoolExecutor
from pathlib import Path

import numpy as np

from timing import median_time, unit_pairs  # noqa: E402 (beside this script)

ROOT = Path(__file__).resolve().parents[3]
MATERIALS = ["gold-paint", "blue-rubber", "chrome-steel", "pink-fabric", "specular-red-phenolic"]
DIMS = (45, 45, 90)




def fit_one(path: str) -> float:
    """Reads and fits one table (in a worker process: imports brdfkit there)."""
    import brdfkit

    return brdfkit.fit(brdfkit.MerlTable.read(path), "cook-torrance").losses["cbrt"]


def init_worker():
    # Read by rayon when its pool starts, at the first parallel call in the worker.
    os.environ["RAYON_NUM_THREADS"] = "1"


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--tables", type=int, default=10)
    ap.add_argument("--reps", type=int, default=3)
    a = ap.parse_args()
    import brdfkit

    cores = os.cpu_count() or 1
    print(f"cores {cores}; load before: {os.getloadavg()}")
    tmp = Path(tempfile.mkdtemp())
    paths = []
    for m in MATERIALS:
        p = tmp / f"{m}.binary"
        brdfkit.resample(brdfkit.Nbrdf.load(ROOT / "data-measured/merl" / m), DIMS).write(p)
        paths.append(str(p))
    paths = (paths * a.tables)[: a.tables]
    table = brdfkit.MerlTable.read(paths[0])

    half = 729_000
    wi, wo = unit_pairs(2 * half, 1)
    one = median_time(lambda: table.lookup(wi, wo, "linear"), 7)

    def two_threads():
        with ThreadPoolExecutor(2) as ex:
            list(ex.map(lambda k: table.lookup(wi[k * half:(k + 1) * half], wo[k * half:(k + 1) * half], "linear"), range(2)))

    two = median_time(two_threads, 7)
    print(f"lookup linear, 1,458,000 pairs: one call {one * 1e3:.0f} ms, two threads {two * 1e3:.0f} ms")

    seq = median_time(lambda: [fit_one(p) for p in paths], a.reps)

    def threads():
        with ThreadPoolExecutor(cores) as ex:
            list(ex.map(fit_one, paths))

    thr = median_time(threads, a.reps)

    def processes():
        # "spawn": a forked child inherits rayon's pool without its threads and hangs.
        ctx = multiprocessing.get_context("spawn")
        with ProcessPoolExecutor(cores, mp_context=ctx, initializer=init_worker) as ex:
            list(ex.map(fit_one, paths))

    proc = median_time(processes, a.reps)
    n = len(paths)
    print(f"{n} fits, {DIMS[0]}x{DIMS[1]}x{DIMS[2]}: one after the other {seq:.2f} s, "
          f"{cores} threads {thr:.2f} s, {cores} processes with RAYON_NUM_THREADS=1 {proc:.2f} s")
    print(f"load after: {os.getloadavg()}")


if __name__ == "__main__":
    main()

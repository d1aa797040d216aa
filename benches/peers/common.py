"""Shared helpers of the peer scripts: the exchange files written by benches/peers.rs."""
import json
import time

import numpy as np

N_GRID = 1_458_000


def load_pairs(path):
    """Six little-endian float64 planes wi_x wi_y wi_z wo_x wo_y wo_z -> (wi, wo), each (3, n)."""
    a = np.fromfile(path, dtype="<f8")
    if a.size % 6:
        raise SystemExit(f"{path}: not 6 planes of float64")
    a = a.reshape(6, -1)
    return a[0:3], a[3:6]


def median_time(reps, f):
    """Median and minimum wall time of reps runs of f after one warm-up run."""
    f()
    ts = []
    for _ in range(reps):
        t = time.perf_counter()
        f()
        ts.append(time.perf_counter() - t)
    ts.sort()
    return ts[len(ts) // 2], ts[0]


def emit(obj):
    print(json.dumps(obj))

"""What both benchmark scripts share: the median wall time of repeated calls and random
direction pairs on the upper hemisphere."""

from __future__ import annotations

import statistics
import time

import numpy as np


def median_time(f, reps):
    """Median wall time (s) of `reps` calls of `f`."""
    ts = []
    for _ in range(reps):
        t = time.perf_counter()
        f()
        ts.append(time.perf_counter() - t)
    return statistics.median(ts)


def unit_pairs(n, seed=1):
    """`n` pairs (wi, wo) of unit vectors, uniform in direction, z >= 0."""
    rng = np.random.default_rng(seed)

    def hemi():
        v = rng.normal(size=(n, 3))
        v[:, 2] = np.abs(v[:, 2])
        return v / np.linalg.norm(v, axis=1, keepdims=True)

    return hemi(), hemi()

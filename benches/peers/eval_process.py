#!/usr/bin/env python3
"""`fit-brdf eval` with .npy in and out against a numpy script doing the same job, each
timed as a whole process (start-up, reading the table and the pairs, the lookup, writing
the values), interleaved A/B over REPS rounds; prints the medians, the per-round ratios
and checks that both wrote the same values (bit for bit, NaN where missing).

Usage: eval_process.py FIT_BRDF TABLE [N] [REPS] [OUT.json]   (docs/performance.md)
With OUT.json (benches/peers/run) the medians, the ratios and the check are also written
there as JSON.
"""
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent


def random_pairs(n, seed=7):
    """Uniform directions on the upper hemisphere, both wi and wo."""
    rng = np.random.default_rng(seed)

    def dirs():
        z = rng.random(n)
        phi = rng.random(n) * 2 * np.pi
        s = np.sqrt(1 - z * z)
        return np.stack([s * np.cos(phi), s * np.sin(phi), z], axis=1)

    return np.ascontiguousarray(np.concatenate([dirs(), dirs()], axis=1))


def timed(cmd):
    t = time.perf_counter()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    return time.perf_counter() - t


def main():
    fit_brdf, table = sys.argv[1], sys.argv[2]
    n = int(sys.argv[3]) if len(sys.argv) > 3 else 1_458_000
    reps = int(sys.argv[4]) if len(sys.argv) > 4 else 11
    with tempfile.TemporaryDirectory() as d:
        pairs, va, vb = f"{d}/p.npy", f"{d}/a.npy", f"{d}/b.npy"
        np.save(pairs, random_pairs(n))
        a = [fit_brdf, "eval", "--table", table, "--dirs", pairs, "--out", va]
        b = [sys.executable, str(HERE / "eval_npy.py"), table, pairs, vb]
        timed(a), timed(b)  # warm the page cache and the interpreter's files
        ta, tb = [], []
        for r in range(reps):
            order = (a, b) if r % 2 == 0 else (b, a)
            for cmd in order:
                (ta if cmd is a else tb).append(timed(cmd))
        x, y = np.load(va), np.load(vb)
        same = x.shape == y.shape and np.array_equal(x, y, equal_nan=True)
        ratios = sorted(q / p for p, q in zip(ta, tb))
        print(f"pairs {n}, rounds {reps}")
        print(f"fit-brdf eval (.npy): median {statistics.median(ta) * 1e3:.1f} ms, "
              f"min {min(ta) * 1e3:.1f}, max {max(ta) * 1e3:.1f}")
        print(f"numpy script:         median {statistics.median(tb) * 1e3:.1f} ms, "
              f"min {min(tb) * 1e3:.1f}, max {max(tb) * 1e3:.1f}")
        print(f"ratio numpy / fit-brdf per round: median {statistics.median(ratios):.2f}, "
              f"min {ratios[0]:.2f}, max {ratios[-1]:.2f}")
        print(f"same values: {same} ({int(np.isnan(x[:, 0]).sum())} missing)")
        if len(sys.argv) > 5:
            with open(sys.argv[5], "w") as f:
                json.dump({"pairs": n, "rounds": reps, "fit_brdf_s": statistics.median(ta),
                           "numpy_s": statistics.median(tb),
                           "ratio_median": statistics.median(ratios), "same": bool(same)}, f)
        if not same:
            sys.exit(1)


if __name__ == "__main__":
    main()

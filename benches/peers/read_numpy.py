#!/usr/bin/env python3
"""numpy peer of reading a MERL table: the header, then the body as three float64 planes,
two ways: `np.fromfile` and `np.frombuffer` of the file's bytes (open().read()).

Usage: read_numpy.py DIR [REPS]  ->  one JSON object on stdout.
"""
import sys

import numpy as np

from common import emit, median_time


def read_fromfile(path):
    dims = np.fromfile(path, dtype="<i4", count=3)
    n = int(np.prod(dims))
    body = np.fromfile(path, dtype="<f8", offset=12, count=3 * n)
    return dims, body.reshape(3, n)


def read_frombuffer(path):
    with open(path, "rb") as f:
        b = f.read()
    dims = np.frombuffer(b, dtype="<i4", count=3)
    n = int(np.prod(dims))
    return dims, np.frombuffer(b, dtype="<f8", offset=12, count=3 * n).reshape(3, n)


def main():
    d = sys.argv[1]
    reps = int(sys.argv[2]) if len(sys.argv) > 2 else 7
    p = f"{d}/table.binary"
    reps = max(4 * reps, 10)
    t_file, m_file = median_time(reps, lambda: read_fromfile(p))
    t_buf, m_buf = median_time(reps, lambda: read_frombuffer(p))
    _, body = read_frombuffer(p)
    emit({"peer": "numpy-read", "fromfile_s": t_file, "fromfile_min_s": m_file,
          "frombuffer_s": t_buf, "frombuffer_min_s": m_buf,
          "valid_raw_sum": float(body[:, (body >= 0).all(axis=0)].sum())})


if __name__ == "__main__":
    main()

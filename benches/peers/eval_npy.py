#!/usr/bin/env python3
"""The numpy peer of `fit-brdf eval --table T --dirs P.npy --out V.npy`, as a whole
process: load the MERL table and the N x 6 float64 pairs, look up with the MERL
reference mapping (lookup_numpy.nearest), save the N x 3 float64 values (NaN missing).

Usage: eval_npy.py TABLE P.npy V.npy
"""
import sys

import numpy as np

from lookup_numpy import nearest


def main():
    table_path, pairs_path, out_path = sys.argv[1:4]
    with open(table_path, "rb") as f:
        b = f.read()
    dims = [int(x) for x in np.frombuffer(b, dtype="<i4", count=3)]
    n = dims[0] * dims[1] * dims[2]
    table = np.frombuffer(b, dtype="<f8", offset=12, count=3 * n).reshape(3, n)
    p = np.load(pairs_path)
    wi, wo = p[:, 0:3].T, p[:, 3:6].T
    np.save(out_path, nearest(table, dims, wi, wo).T)


if __name__ == "__main__":
    main()

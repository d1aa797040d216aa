#!/usr/bin/env python3
"""numpy peers of the table lookups: the MERL reference mapping (BRDFRead.cpp:
half/difference angles by two Rodrigues rotations, then the theta_h square-root bin, the
theta_d and phi_d bins, reciprocity folding phi_d into [0, pi)) vectorised over the random
pairs written by benches/peers.rs, then a gather from the three planes; a negative raw
value is missing (NaN). And trilinear interpolation on the same table at the same
continuous coordinates (brdfkit's `interpolated`: theta_h and theta_d hold their last
node, phi_d wraps, missing corners are left out and the weights renormalised).

Usage: lookup_numpy.py DIR [REPS]  ->  one JSON object on stdout.
"""
import sys

import numpy as np

from common import emit, load_pairs, median_time

SCALES = np.array([1.0 / 1500.0, 1.15 / 1500.0, 1.66 / 1500.0])


def rotate(v, axis, angle):
    """Rodrigues: v cos + axis (axis.v)(1 - cos) + (axis x v) sin; axis a constant (3,)."""
    c, s = np.cos(angle), np.sin(angle)
    dot = axis[0] * v[0] + axis[1] * v[1] + axis[2] * v[2]
    cross = np.stack([axis[1] * v[2] - axis[2] * v[1],
                      axis[2] * v[0] - axis[0] * v[2],
                      axis[0] * v[1] - axis[1] * v[0]])
    return v * c + axis[:, None] * (dot * (1.0 - c)) + cross * s


def angles(wi, wo):
    """theta_h, theta_d, phi_d of the reference conversion."""
    h = wi + wo
    h = h / np.linalg.norm(h, axis=0)
    theta_h = np.arccos(np.clip(h[2], -1.0, 1.0))
    phi_h = np.arctan2(h[1], h[0])
    d = rotate(wi, np.array([0.0, 0.0, 1.0]), -phi_h)
    d = rotate(d, np.array([0.0, 1.0, 0.0]), -theta_h)
    theta_d = np.arccos(np.clip(d[2], -1.0, 1.0))
    phi_d = np.arctan2(d[1], d[0])
    phi_d = np.where(phi_d < 0, phi_d + np.pi, phi_d)
    return theta_h, theta_d, phi_d


def nearest(table, dims, wi, wo):
    nth, ntd, npd = dims
    theta_h, theta_d, phi_d = angles(wi, wo)
    ih = np.where(theta_h <= 0, 0, np.sqrt(theta_h / (np.pi / 2) * nth * nth)).astype(np.int64)
    jd = (theta_d / (np.pi * 0.5) * ntd).astype(np.int64)
    kd = (phi_d / np.pi * npd).astype(np.int64)
    ih = np.clip(ih, 0, nth - 1)
    jd = np.clip(jd, 0, ntd - 1)
    kd = np.clip(kd, 0, npd - 1)
    idx = kd + npd * (jd + ntd * ih)
    raw = table[:, idx]
    ok = (raw >= 0).all(axis=0)
    return np.where(ok[None, :], raw * SCALES[:, None], np.nan)


def clamped_axis(x, n):
    """Lower node, upper node, fraction; the last node held past it."""
    x = np.where(np.isnan(x) | (x <= 0), 0.0, x)
    hold = x >= n - 1
    lo = np.floor(np.minimum(x, n - 1)).astype(np.int64)
    t = np.where(hold, 0.0, x - lo)
    hi = np.where(hold, lo, lo + 1)
    return lo, hi, t


def wrapped_axis(x, n):
    """Lower node, upper node, fraction; node n is node 0."""
    x = np.mod(x, n)
    lo = np.floor(x)
    t = x - lo
    lo = lo.astype(np.int64) % n
    return lo, (lo + 1) % n, t


def trilinear(table, dims, wi, wo):
    nth, ntd, npd = dims
    theta_h, theta_d, phi_d = angles(wi, wo)
    u = np.where(theta_h <= 0, 0.0, np.sqrt(theta_h / (np.pi / 2) * nth * nth))
    v = theta_d / (np.pi * 0.5) * ntd
    w = phi_d / np.pi * npd
    i0, i1, tu = clamped_axis(u, nth)
    j0, j1, tv = clamped_axis(v, ntd)
    k0, k1, tw = wrapped_axis(w, npd)
    acc = np.zeros((3, u.size))
    wsum = np.zeros(u.size)
    for i, wu in ((i0, 1.0 - tu), (i1, tu)):
        for j, wv in ((j0, 1.0 - tv), (j1, tv)):
            for k, ww in ((k0, 1.0 - tw), (k1, tw)):
                wt = wu * wv * ww
                raw = table[:, k + npd * (j + ntd * i)]
                ok = (raw >= 0).all(axis=0) & (wt > 0)
                wt = np.where(ok, wt, 0.0)
                acc += np.where(ok[None, :], raw, 0.0) * wt
                wsum += wt
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(wsum > 0, acc / wsum * SCALES[:, None], np.nan)


def main():
    d = sys.argv[1]
    reps = int(sys.argv[2]) if len(sys.argv) > 2 else 7
    with open(f"{d}/table.binary", "rb") as f:
        b = f.read()
    dims = [int(x) for x in np.frombuffer(b, dtype="<i4", count=3)]
    n = dims[0] * dims[1] * dims[2]
    table = np.frombuffer(b, dtype="<f8", offset=12, count=3 * n).reshape(3, n)
    wi, wo = load_pairs(f"{d}/random_pairs.f64")
    out = {}

    def run():
        out["v"] = nearest(table, dims, wi, wo)

    def run_interp():
        out["t"] = trilinear(table, dims, wi, wo)

    med, mn = median_time(reps, run)
    v = out["v"]
    found = np.isfinite(v).all(axis=0)
    imed, imn = median_time(reps, run_interp)
    t = out["t"]
    ifound = np.isfinite(t).all(axis=0)
    emit({"peer": "numpy-nearest", "time_s": med, "min_s": mn, "pairs": int(wi.shape[1]),
          "found": int(found.sum()), "sum": v[:, found].sum(axis=1).tolist(),
          "interp_time_s": imed, "interp_min_s": imn, "interp_found": int(ifound.sum()),
          "interp_sum": t[:, ifound].sum(axis=1).tolist()})


if __name__ == "__main__":
    main()

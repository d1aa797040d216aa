#!/usr/bin/env python3
"""numpy peer of the model evaluation: Cook-Torrance GGX, separable Smith, exact conductor
Fresnel, RGB, float64, over the MERL grid pairs written by benches/peers.rs.

Written as an ordinary vectorised numpy user would: whole-array expressions, with the
half vector and cos(theta_d) computed from the directions.

Usage: eval_numpy.py DIR [REPS]  ->  one JSON object on stdout.
"""
import sys

import numpy as np

from common import emit, load_pairs, median_time

ETA = np.array([0.143, 0.374, 1.442])
K = np.array([3.983, 2.385, 1.603])
ALPHA = 0.2


def ggx_conductor(wi, wo):
    h = wi + wo
    h = h / np.linalg.norm(h, axis=0)
    cos_d = np.sum(wi * h, axis=0)
    a2 = ALPHA * ALPHA
    s = (h[0] ** 2 + h[1] ** 2) / a2 + h[2] ** 2
    d = 1.0 / (np.pi * a2 * s * s)

    def g1(z):
        with np.errstate(divide="ignore", invalid="ignore"):
            q = a2 * (1.0 - z * z) / (z * z)
            return 2.0 / (1.0 + np.sqrt(1.0 + q))

    zi, zo = wi[2], wo[2]
    with np.errstate(divide="ignore", invalid="ignore"):
        spec = d * g1(zi) * g1(zo) / (4.0 * zi * zo)
    c = cos_d[None, :]
    c2 = c * c
    s2 = 1.0 - c2
    t = (ETA * ETA - K * K)[:, None] - s2
    ab2 = np.sqrt(t * t + (4.0 * ETA * ETA * K * K)[:, None])
    a = np.sqrt(np.maximum(0.5 * (ab2 + t), 0.0))
    t1 = ab2 + c2
    t2 = 2.0 * a * c
    rs = (t1 - t2) / (t1 + t2)
    t3 = ab2 * c2 + s2 * s2
    t4 = t2 * s2
    rp = rs * (t3 - t4) / (t3 + t4)
    f = spec[None, :] * 0.5 * (rs + rp)
    up = (zi > 0) & (zo > 0)
    return np.where(up[None, :], f, 0.0)


def main():
    d = sys.argv[1]
    reps = int(sys.argv[2]) if len(sys.argv) > 2 else 7
    wi, wo = load_pairs(f"{d}/grid_pairs.f64")
    out = {}

    def run():
        out["f"] = ggx_conductor(wi, wo)

    med, mn = median_time(reps, run)
    emit({"peer": "numpy", "numpy": np.__version__, "time_s": med, "min_s": mn,
          "cells": int(wi.shape[1]), "sum": out["f"].sum(axis=1).tolist()})


if __name__ == "__main__":
    main()

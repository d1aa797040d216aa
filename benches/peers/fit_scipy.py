#!/usr/bin/env python3
"""The fitter an ordinary user would write: numpy + scipy.optimize.least_squares.

Fits Cook-Torrance (GGX distribution, separable Smith masking, Schlick Fresnel, with
its own Lambertian rho_d) to the cells written by benches/fit.rs, with the same loss
(cbrt: weighted RMS of cbrt(f cos_i) differences, solid-angle weights), the same
start and the same bounds, using least_squares' defaults (method 'trf', 2-point
finite-difference Jacobian, ftol = xtol = gtol = 1e-8).

Usage: fit_scipy.py CELLS_FILE  ->  one JSON object on stdout.

Cells file (little-endian): 8 bytes b"BRDFCELL", u64 n, then 14 float64 arrays of
length n: wi_x wi_y wi_z wo_x wo_y wo_z h_x h_y h_z cos_d value_r value_g value_b
weight.
"""
import json
import sys
import time

import numpy as np
import scipy
from scipy.optimize import least_squares


def load(path):
    with open(path, "rb") as f:
        if f.read(8) != b"BRDFCELL":
            raise SystemExit(f"{path}: not a cells file")
        n = int(np.frombuffer(f.read(8), dtype="<u8")[0])
        a = np.frombuffer(f.read(14 * 8 * n), dtype="<f8").reshape(14, n)
    return a


def model(p, g):
    """f_r per channel, shape (3, n). Same formulas as brdfkit's cook-torrance."""
    rho_d, rho_s, alpha, f0 = p[0:3], p[3:6], p[6], p[7:10]
    wi_z, wo_z, hx, hy, hz, cos_d = g["wi_z"], g["wo_z"], g["hx"], g["hy"], g["hz"], g["cos_d"]
    a2 = alpha * alpha
    # GGX D = 1 / (pi a^2 s^2), s = (hx^2 + hy^2)/a^2 + hz^2
    s = (hx * hx + hy * hy) / a2 + hz * hz
    d = 1.0 / (np.pi * a2 * s * s)

    def g1(z):
        q = a2 * (1.0 - z * z) / (z * z)
        lam = q / (2.0 * (1.0 + np.sqrt(1.0 + q)))
        return 1.0 / (1.0 + lam)

    spec = d * g1(wi_z) * g1(wo_z) * 0.25 / (wi_z * wo_z)
    w = (1.0 - np.clip(cos_d, 0.0, 1.0)) ** 5
    fres = f0[:, None] + (1.0 - f0[:, None]) * w[None, :]
    f = rho_d[:, None] / np.pi + rho_s[:, None] * spec[None, :] * fres
    above = (wi_z > 0) & (wo_z > 0)
    return np.where(above[None, :], f, 0.0)


def main():
    a = load(sys.argv[1])
    g = dict(wi_z=a[2], wo_z=a[5], hx=a[6], hy=a[7], hz=a[8], cos_d=a[9])
    values = a[10:13]
    weight = a[13]
    cos_i = g["wi_z"]
    target = np.cbrt(values * cos_i[None, :])
    scale = np.sqrt(weight / (3.0 * weight.sum()))

    def residuals(p):
        f = model(p, g)
        return (scale[None, :] * (np.cbrt(f * cos_i[None, :]) - target)).ravel()

    x0 = np.array([0.3, 0.3, 0.3, 0.3, 0.3, 0.3, 0.2, 0.04, 0.04, 0.04])
    lo = np.array([0.0] * 6 + [1e-6] + [0.0] * 3)
    hi = np.array([1.0] * 6 + [100.0] + [1.0] * 3)
    t0 = time.perf_counter()
    c0 = time.process_time()
    res = least_squares(residuals, x0, bounds=(lo, hi))
    t = time.perf_counter() - t0
    cpu = time.process_time() - c0
    print(json.dumps({
        "time_s": t,
        "cpu_s": cpu,
        "loss_cbrt": float(np.sqrt(2.0 * res.cost)),
        "params": res.x.tolist(),
        "nfev": int(res.nfev),
        "njev": int(res.njev) if res.njev is not None else None,
        "status": int(res.status),
        "message": res.message,
        "cells": int(a.shape[1]),
        "numpy": np.__version__,
        "scipy": scipy.__version__,
    }))


if __name__ == "__main__":
    main()

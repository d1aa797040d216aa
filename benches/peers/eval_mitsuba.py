#!/usr/bin/env python3
"""Mitsuba 3 peer of the model evaluation: `roughconductor` (GGX, alpha 0.2, gold's eta
and k as RGB), variant `llvm_ad_rgb` (float32, Dr.Jit's vectorised LLVM backend), over the
MERL grid pairs written by benches/peers.rs.

Only the kernel is timed: the inputs are evaluated first, one warm-up run compiles the
kernel (drjit caches it), then each timed run is bsdf.eval + dr.eval + dr.sync_thread.
Dr.Jit's kernel history gives the execution time of the kernel alone as well.
Mitsuba's eval includes cos(theta) of wo; it is divided out (outside the timing) for the
checksum, so the sums compare with brdfkit's f_r.

Needs DRJIT_LIBLLVM_PATH pointing at LLVM 19 (Debian's libllvm19): the system LLVM 15
aborts the process.

Usage: eval_mitsuba.py DIR [REPS]  ->  one JSON object on stdout.
"""
import sys
import time

import numpy as np

from common import emit, load_pairs


def main():
    d = sys.argv[1]
    reps = int(sys.argv[2]) if len(sys.argv) > 2 else 7
    import drjit as dr
    import mitsuba as mi

    mi.set_variant("llvm_ad_rgb")
    wi_np, wo_np = load_pairs(f"{d}/grid_pairs.f64")
    n = wi_np.shape[1]
    bsdf = mi.load_dict({
        "type": "roughconductor",
        "distribution": "ggx",
        "alpha": 0.2,
        "sample_visible": False,
        "eta": {"type": "rgb", "value": [0.143, 0.374, 1.442]},
        "k": {"type": "rgb", "value": [3.983, 2.385, 1.603]},
    })
    f32 = np.float32
    si = dr.zeros(mi.SurfaceInteraction3f, n)
    si.wi = mi.Vector3f(wi_np[0].astype(f32), wi_np[1].astype(f32), wi_np[2].astype(f32))
    si.sh_frame = mi.Frame3f(mi.Vector3f(0, 0, 1))
    wo = mi.Vector3f(wo_np[0].astype(f32), wo_np[1].astype(f32), wo_np[2].astype(f32))
    ctx = mi.BSDFContext()
    dr.eval(si, wo)
    dr.sync_thread()

    def run():
        v = bsdf.eval(ctx, si, wo)
        dr.eval(v)
        dr.sync_thread()
        return v

    run()  # warm-up: traces and compiles the kernel
    dr.set_flag(dr.JitFlag.KernelHistory, True)
    ts, ks = [], []
    v = None
    for _ in range(reps):
        dr.kernel_history()  # clear
        t = time.perf_counter()
        v = run()
        ts.append(time.perf_counter() - t)
        hist = dr.kernel_history()
        ks.append(sum(h.get("execution_time", 0.0) for h in hist) / 1e3)  # ms -> s
    dr.set_flag(dr.JitFlag.KernelHistory, False)
    ts.sort()
    ks.sort()
    f = np.array(v).reshape(3, -1) if np.array(v).shape[0] == 3 else np.array(v).T
    cos_o = wo_np[2]
    with np.errstate(divide="ignore", invalid="ignore"):
        fr = np.where(cos_o > 0, f / cos_o[None, :], 0.0)
    emit({"peer": "mitsuba", "variant": "llvm_ad_rgb", "mitsuba": mi.__version__,
          "drjit": dr.__version__, "threads": dr.thread_count(),
          "time_s": ts[len(ts) // 2], "min_s": ts[0],
          "kernel_s": ks[len(ks) // 2], "kernel_min_s": ks[0],
          "cells": int(n), "sum": np.nan_to_num(fr).sum(axis=1).tolist()})


if __name__ == "__main__":
    main()

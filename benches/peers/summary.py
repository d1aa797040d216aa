#!/usr/bin/env python3
"""Prints the peer comparison of benches/peers/run and writes the raw figures as JSON.

Usage: summary.py WORKDIR OUT.json LOAD_START LOAD_END
"""
import json
import os
import platform
import sys
import time


def load(work, name):
    p = os.path.join(work, name)
    if not os.path.exists(p):
        return None
    with open(p) as f:
        return json.load(f)


def close(a, b, rel):
    return all(abs(x - y) <= rel * max(abs(x), abs(y), 1e-300) for x, y in zip(a, b))


def main():
    work, out, l0, l1 = sys.argv[1:5]
    r = load(work, "rust.json")
    peers = {k: load(work, f"{k}.json") for k in
             ["eval_numpy", "eval_mitsuba", "read_numpy", "lookup_numpy", "fit_scipy",
              "eval_process"]}
    rows = []  # (what, ours label, ours s, peer label, peer s, target)

    def row(what, ours_label, ours, peer_label, peer, target=""):
        rows.append((what, ours_label, ours, peer_label, peer, target))

    e = r["eval"]
    checks = []
    notes = []
    if peers["eval_mitsuba"]:
        m = peers["eval_mitsuba"]
        row("eval CT GGX conductor, 1,458,000 cells", "eval_batch_f32 (f32)", e["eval_f32_s"],
            "Mitsuba llvm_ad_rgb kernel (f32)", m["kernel_s"], "ratio >= 1")
        row("", "eval_batch_f32 (f32)", e["eval_f32_s"],
            "Mitsuba eval+dr.eval+sync (wall)", m["time_s"])
        row("", "eval_batch (f64)", e["eval_batch_s"], "Mitsuba kernel (f32)", m["kernel_s"])
        row("", "eval from (wi, wo) (f64)", e["eval_pairs_s"], "Mitsuba kernel (f32)",
            m["kernel_s"])
        if "eval_dirs_s" in e:
            row("eval CT GGX conductor from raw (wi, wo)", "raw::eval_dirs_f32 (f32)",
                e["eval_dirs_f32_s"], "Mitsuba llvm_ad_rgb kernel (f32)", m["kernel_s"],
                "ratio >= 1")
            row("", "raw::eval_dirs_f32 (f32)", e["eval_dirs_f32_s"],
                "Mitsuba eval+dr.eval+sync (wall)", m["time_s"])
            row("", "raw::eval_dirs (f64)", e["eval_dirs_s"], "Mitsuba kernel (f32)",
                m["kernel_s"], "ratio >= 0.5")
            checks.append(("Mitsuba sum of f_r vs brdfkit raw f32 (1e-4)",
                           close(m["sum"], e["sum_dirs_f32"], 1e-4)))
    if "eval_dirs_s" in e:
        checks.append(("raw::eval_dirs sum == eval_batch sum (same bits)",
                       e["sum_dirs"] == e["sum_f64"]))
        checks.append(("Mitsuba sum of f_r vs brdfkit f64 (1e-3)",
                       close(m["sum"], e["sum_f64"], 1e-3)))
        checks.append(("Mitsuba sum of f_r vs brdfkit f32 (1e-4)",
                       close(m["sum"], e["sum_f32"], 1e-4)))
    if peers["eval_numpy"]:
        n = peers["eval_numpy"]
        row("", "eval_batch (f64)", e["eval_batch_s"], "numpy (f64)", n["time_s"])
        checks.append(("numpy sum of f_r vs brdfkit (1e-9)", close(n["sum"], e["sum_f64"], 1e-9)))
    rgl = load(work, "rgl.json")
    if rgl:
        what = f"RGL .bsdf eval, {rgl['pairs']:,} pairs"
        row(what, "RglBsdf::eval_flat (f32)", rgl["eval_inprocess_s"],
            "Mitsuba measured eval+sync (wall)", rgl["mitsuba_s"], "ratio >= 1")
        row("", "fit-brdf eval --bsdf (process)", rgl["eval_process_s"],
            "Mitsuba measured eval+sync (wall)", rgl["mitsuba_s"])
        row("RGL .bsdf resample to 90x90x180", "fit-brdf resample --bsdf", rgl["resample_process_s"],
            "the issue's bound, 1 s", 1.0, "ratio >= 1")
        checks.append(("RGL eval within 1e-4 of Mitsuba (>= 99.9 %)",
                       rgl["within_1e4_of_mitsuba"] >= 0.999))
        notes.append(f"RGL CPU: eval_flat {rgl['eval_inprocess_cpu_s']:.3f} s, Mitsuba "
                     f"{rgl['mitsuba_cpu_s']:.3f} s (load {rgl['load_start']} -> {rgl['load_end']})")
    rd = r["read"]
    row("read a 34,992,012-byte table", "MerlTable::read", rd["read_s"], "cat FILE > /dev/null",
        rd["cat_s"], "read/cat <= 1.5")
    if "pair_ratio_median" in rd:
        notes.append(f"read/cat per interleaved pair: median {rd['pair_ratio_median']:.2f} "
                     f"(p10 {rd['pair_ratio_p10']:.2f}, p90 {rd['pair_ratio_p90']:.2f}), "
                     f"{rd['pairs_within_1_5']} of {rd['runs']} pairs <= 1.5")
    if peers["read_numpy"]:
        p = peers["read_numpy"]
        row("", "MerlTable::read", rd["read_s"], "numpy frombuffer(read())", p["frombuffer_s"])
        row("", "MerlTable::read", rd["read_s"], "numpy fromfile", p["fromfile_s"])
        checks.append(("table raw sums", close([p["valid_raw_sum"]], [rd["valid_raw_sum"]], 1e-9)))
    nr = r["nearest"]
    if peers["lookup_numpy"]:
        p = peers["lookup_numpy"]
        row("nearest lookup, 1,458,000 random pairs", "nearest_flat (N×6 -> N×3)",
            nr["time_s"], "numpy reference mapping", p["time_s"], "ratio >= 20")
        if "lookup_batch_s" in nr:
            row("", "lookup_batch (Vec3 pairs)", nr["lookup_batch_s"],
                "numpy reference mapping", p["time_s"])
        checks.append((f"lookup found {nr['found']} vs numpy {p['found']} (within 0.01 %)",
                       abs(nr["found"] - p["found"]) <= 1e-4 * nr["pairs"]))
        checks.append(("lookup sums (1e-4)", close(nr["sum"], p["sum"], 1e-4)))
        ip = r.get("interpolated")
        if ip and "interp_time_s" in p:
            row("interpolated lookup, same pairs", "interpolated_flat", ip["time_s"],
                "numpy trilinear, same table", p["interp_time_s"], "ratio >= 10")
            checks.append((f"interpolated found {ip['found']} vs numpy {p['interp_found']} "
                           "(within 0.01 %)",
                           abs(ip["found"] - p["interp_found"]) <= 1e-4 * ip["pairs"]))
            checks.append(("interpolated sums (1e-4)", close(ip["sum"], p["interp_sum"], 1e-4)))
    if peers["eval_process"]:
        p = peers["eval_process"]
        row("fit-brdf eval --table T --dirs P.npy --out V.npy, whole process",
            "fit-brdf eval", p["fit_brdf_s"], "numpy script eval_npy.py", p["numpy_s"],
            "ratio >= 10")
        notes.append(f"eval process: median of per-round ratios {p['ratio_median']:.2f}")
        checks.append(("fit-brdf eval and the numpy script wrote the same values (bits)",
                       p["same"]))
    if "fit" in r and peers["fit_scipy"]:
        p = peers["fit_scipy"]
        f = r["fit"]
        row("full-table fit, CT GGX + Schlick, cbrt", "brdfkit fit (LM, warm-up)", f["time_s"],
            "scipy least_squares (trf)", p["time_s"], "ratio >= 50, loss <=")
        checks.append((f"fit loss brdfkit {f['loss_cbrt']:.3e} <= scipy {p['loss_cbrt']:.3e}",
                       f["loss_cbrt"] <= p["loss_cbrt"] * (1 + 1e-6)))

    print(f"machine: {platform.machine()}, {os.cpu_count()} CPUs; rayon threads {r['threads']}; "
          f"load average {l0} at the start, {l1} at the end")
    w = max(len(x[0]) for x in rows)
    print(f"{'what':<{w}}  {'brdfkit':<26} {'ms':>9}  {'peer':<34} {'ms':>9}  {'peer/brdfkit':>12}  target")
    for what, ol, o, pl, p, t in rows:
        ratio = p / o if o > 0 else float("nan")
        if t == "read/cat <= 1.5":
            ratio_s = f"{o / p:.2f} (read/cat)"
        else:
            ratio_s = f"{ratio:.2f}x"
        print(f"{what:<{w}}  {ol:<26} {o * 1e3:9.2f}  {pl:<34} {p * 1e3:9.2f}  {ratio_s:>12}  {t}")
    for n in notes:
        print(f"note: {n}")
    for name, ok in checks:
        print(f"check: {name}: {'ok' if ok else 'MISMATCH'}")
    with open(out, "w") as f:
        json.dump({"time_unix": time.time(), "load_start": float(l0), "load_end": float(l1),
                   "brdfkit": r, "peers": peers,
                   "rows": [dict(zip(["what", "brdfkit", "brdfkit_s", "peer", "peer_s", "target"], x))
                            for x in rows],
                   "notes": notes,
                   "checks": [{"check": n, "ok": ok} for n, ok in checks]}, f, indent=1)
    print(f"raw figures: {out}")
    if not all(ok for _, ok in checks):
        sys.exit(1)


if __name__ == "__main__":
    main()

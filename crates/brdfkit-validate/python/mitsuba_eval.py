#!/usr/bin/env python3
"""Evaluate Mitsuba 3 BSDFs on a batch of direction pairs, for brdfkit's cross-check.

Usage:
    mitsuba_eval.py --version            print {"mitsuba": ..., "drjit": ..., "variant": ...}
    mitsuba_eval.py IN.json OUT.json     evaluate a batch

Input (written by brdfkit_validate::mitsuba):

    {"variant": "scalar_rgb",
     "configs": [{"name": "...",
                  "bsdf": {...a mitsuba.load_dict dictionary...},
                  "cases": [[wi_x, wi_y, wi_z, wo_x, wo_y, wo_z], ...]}, ...]}

`wi` and `wo` are in brdfkit's convention: local frame, z = normal, both pointing away
from the surface, `wi` towards the light and `wo` towards the viewer; f_r(wi, wo) is
wanted without the cosine.

Mitsuba's convention differs (include/mitsuba/render/bsdf.h): `si.wi` is the direction
towards the viewer (brdfkit's wo), the `wo` argument of `BSDF.eval` points towards the
light (brdfkit's wi), and `eval` returns f_r · cos θ of its `wo`. So each case is
evaluated as `bsdf.eval(ctx, si{wi = wo}, wi)` and divided by wi.z, the float32 value
Mitsuba multiplied by (`Frame3f::cos_theta(wo)` is its z component).

Output:

    {"mitsuba": "3.9.1", "drjit": "1.5.0", "variant": "scalar_rgb",
     "configs": [{"name": "...", "eval": [[r, g, b], ...], "f": [[r, g, b], ...]}, ...]}

`eval` is Mitsuba's raw value (with the cosine), `f` the BRDF. Every configuration is
evaluated in this one process: importing Mitsuba and loading the variant costs seconds.

Exit codes: 0 success; 2 bad input; 3 Mitsuba or Dr.Jit cannot be imported or the
variant is not available (the caller treats 3 as "Mitsuba is missing").
"""

import json
import sys


def fail(code, msg):
    print(f"mitsuba_eval.py: {msg}", file=sys.stderr)
    sys.exit(code)


def load_mitsuba(variant):
    try:
        import drjit as dr
        import mitsuba as mi
    except Exception as e:  # ImportError, or a broken binary wheel
        fail(3, f"cannot import mitsuba/drjit: {e!r} "
                "(install: python3 -m venv .venv && .venv/bin/pip install -r python/requirements.txt)")
    try:
        mi.set_variant(variant)
    except Exception as e:
        fail(3, f"mitsuba variant `{variant}` is not available: {e!r}")
    return mi, dr


def versions(mi, dr, variant):
    return {"mitsuba": mi.__version__, "drjit": dr.__version__, "variant": variant}


def f32(x):
    """x rounded to float32, as nanobind converts a Python float for Mitsuba."""
    import struct
    return struct.unpack("f", struct.pack("f", x))[0]


def evaluate(mi, config):
    name = config.get("name", "?")
    try:
        bsdf = mi.load_dict(config["bsdf"])
    except Exception as e:
        fail(2, f"config `{name}`: mitsuba rejected the bsdf {config.get('bsdf')!r}: {e}")
    ctx = mi.BSDFContext()
    si = mi.SurfaceInteraction3f()
    evals, fs = [], []
    for n, case in enumerate(config["cases"]):
        if len(case) != 6 or not all(isinstance(v, (int, float)) for v in case):
            fail(2, f"config `{name}` case {n}: expected 6 numbers, got {case!r}")
        wi = mi.Vector3f(case[0], case[1], case[2])
        wo = mi.Vector3f(case[3], case[4], case[5])
        # Mitsuba's viewer side is brdfkit's wo, its light side brdfkit's wi.
        si.wi = wo
        v = bsdf.eval(ctx, si, wi)
        e = [float(v[0]), float(v[1]), float(v[2])]
        cos = f32(case[2])
        evals.append(e)
        fs.append([c / cos if cos > 0.0 else 0.0 for c in e])
    return {"name": name, "eval": evals, "f": fs}


def main(argv):
    if len(argv) == 2 and argv[1] == "--version":
        mi, dr = load_mitsuba("scalar_rgb")
        print(json.dumps(versions(mi, dr, "scalar_rgb")))
        return 0
    if len(argv) != 3:
        fail(2, "usage: mitsuba_eval.py IN.json OUT.json | --version")
    try:
        with open(argv[1], encoding="utf-8") as fh:
            batch = json.load(fh)
    except (OSError, ValueError) as e:
        fail(2, f"{argv[1]}: {e}")
    if not isinstance(batch, dict) or not isinstance(batch.get("configs"), list):
        fail(2, f"{argv[1]}: expected an object with a `configs` list")
    variant = batch.get("variant", "scalar_rgb")
    mi, dr = load_mitsuba(variant)
    out = versions(mi, dr, variant)
    out["configs"] = [evaluate(mi, c) for c in batch["configs"]]
    tmp = argv[2] + ".tmp"
    with open(tmp, "w", encoding="utf-8") as fh:
        json.dump(out, fh)
    import os
    os.replace(tmp, argv[2])
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))

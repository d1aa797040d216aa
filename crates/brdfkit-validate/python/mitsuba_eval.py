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
import os
import sys

# The shared helpers live in <workspace>/python.
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "..", "python"))
from brdfkit_mitsuba import eval_case, fail, load_mitsuba, read_json, versions, write_json  # noqa: E402


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
        e, f = eval_case(mi, bsdf, ctx, si, case)
        evals.append(e)
        fs.append(f)
    return {"name": name, "eval": evals, "f": fs}


def main(argv):
    if len(argv) == 2 and argv[1] == "--version":
        mi, dr = load_mitsuba("scalar_rgb")
        print(json.dumps(versions(mi, dr, "scalar_rgb")))
        return 0
    if len(argv) != 3:
        fail(2, "usage: mitsuba_eval.py IN.json OUT.json | --version")
    batch = read_json(argv[1])
    if not isinstance(batch, dict) or not isinstance(batch.get("configs"), list):
        fail(2, f"{argv[1]}: expected an object with a `configs` list")
    variant = batch.get("variant", "scalar_rgb")
    mi, dr = load_mitsuba(variant)
    out = versions(mi, dr, variant)
    out["configs"] = [evaluate(mi, c) for c in batch["configs"]]
    write_json(argv[2], out)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))

#!/usr/bin/env python3
"""Load `fit-brdf export --to mitsuba` output in Mitsuba 3 and evaluate it, for the
export test of fit-brdf (crates/fit-brdf/tests/export.rs).

Usage:
    export_check.py IN.json OUT.json

Input:

    {"variant": "scalar_rgb",
     "cases": [[wi_x, wi_y, wi_z, wo_x, wo_y, wo_z], ...],
     "exports": [{"name": "...", "xml": "<bsdf ...>...</bsdf>", "dict": {...}}, ...]}

`xml` is the text of `--format xml`, loaded with `mitsuba.load_string`; `dict` the JSON
of `--format dict`, loaded with `mitsuba.load_dict`. Directions are in brdfkit's
convention: local frame, z = normal, both pointing away from the surface, `wi` towards
the light and `wo` towards the viewer.

Mitsuba's `si.wi` is the viewer side (brdfkit's wo); the `wo` argument of `BSDF.eval`
is the light side (brdfkit's wi), and `eval` returns f_r * cos(theta) of that argument.
Each case is evaluated as `bsdf.eval(ctx, si{wi = wo}, wi)` and divided by the float32
wi.z Mitsuba multiplied by.

Output:

    {"mitsuba": "3.9.1", "drjit": "1.5.0", "variant": "scalar_rgb",
     "exports": [{"name": "...", "xml": [[r, g, b], ...], "dict": [[r, g, b], ...],
                  "xml_type": "RoughConductor", "dict_type": "RoughConductor"}, ...]}

Exit codes: 0 success; 2 bad input or an export Mitsuba rejects; 3 Mitsuba or Dr.Jit
cannot be imported or the variant is missing (the caller treats 3 as "Mitsuba is
missing").
"""

import json
import os
import struct
import sys


def fail(code, msg):
    print(f"export_check.py: {msg}", file=sys.stderr)
    sys.exit(code)


def load_mitsuba(variant):
    try:
        import drjit as dr
        import mitsuba as mi
    except Exception as e:  # ImportError, or a broken binary wheel
        fail(3, f"cannot import mitsuba/drjit: {e!r}")
    try:
        mi.set_variant(variant)
    except Exception as e:
        fail(3, f"mitsuba variant `{variant}` is not available: {e!r}")
    return mi, dr


def f32(x):
    """x rounded to float32, as Mitsuba sees a Python float."""
    return struct.unpack("f", struct.pack("f", x))[0]


def evaluate(mi, bsdf, cases):
    ctx = mi.BSDFContext()
    si = mi.SurfaceInteraction3f()
    out = []
    for case in cases:
        wi = mi.Vector3f(case[0], case[1], case[2])
        wo = mi.Vector3f(case[3], case[4], case[5])
        si.wi = wo  # Mitsuba's viewer side is brdfkit's wo
        v = bsdf.eval(ctx, si, wi)
        cos = f32(case[2])
        out.append([float(v[c]) / cos if cos > 0.0 else 0.0 for c in range(3)])
    return out


def main(argv):
    if len(argv) != 3:
        fail(2, "usage: export_check.py IN.json OUT.json")
    try:
        with open(argv[1], encoding="utf-8") as fh:
            batch = json.load(fh)
    except (OSError, ValueError) as e:
        fail(2, f"{argv[1]}: {e}")
    cases = batch.get("cases")
    if not isinstance(cases, list) or not all(
        isinstance(c, list) and len(c) == 6 for c in cases
    ):
        fail(2, f"{argv[1]}: `cases` must be a list of 6-number lists")
    variant = batch.get("variant", "scalar_rgb")
    mi, dr = load_mitsuba(variant)
    result = {"mitsuba": mi.__version__, "drjit": dr.__version__, "variant": variant,
              "exports": []}
    for e in batch.get("exports", []):
        name = e.get("name", "?")
        r = {"name": name}
        for form in ("xml", "dict"):
            if form not in e:
                continue
            try:
                bsdf = mi.load_string(e["xml"]) if form == "xml" else mi.load_dict(e["dict"])
            except Exception as ex:
                fail(2, f"export `{name}`: mitsuba rejected the {form}: {ex}")
            # The plugin class as Mitsuba prints it: "RoughConductor[...]" -> RoughConductor.
            r[form + "_type"] = str(bsdf).split("[")[0].strip()
            r[form] = evaluate(mi, bsdf, cases)
        result["exports"].append(r)
    tmp = argv[2] + ".tmp"
    with open(tmp, "w", encoding="utf-8") as fh:
        json.dump(result, fh)
    os.replace(tmp, argv[2])
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))

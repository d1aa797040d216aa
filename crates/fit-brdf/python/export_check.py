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

import os
import sys

# The shared helpers live in <workspace>/python.
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "..", "python"))
from brdfkit_mitsuba import eval_case, fail, load_mitsuba, read_json, versions, write_json  # noqa: E402


def evaluate(mi, bsdf, cases):
    """f_r of `bsdf` at each pair."""
    ctx = mi.BSDFContext()
    si = mi.SurfaceInteraction3f()
    return [eval_case(mi, bsdf, ctx, si, case)[1] for case in cases]


def main(argv):
    if len(argv) != 3:
        fail(2, "usage: export_check.py IN.json OUT.json")
    batch = read_json(argv[1])
    cases = batch.get("cases")
    if not isinstance(cases, list) or not all(
        isinstance(c, list) and len(c) == 6 for c in cases
    ):
        fail(2, f"{argv[1]}: `cases` must be a list of 6-number lists")
    variant = batch.get("variant", "scalar_rgb")
    mi, dr = load_mitsuba(variant)
    result = versions(mi, dr, variant)
    result["exports"] = []
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
    write_json(argv[2], result)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))

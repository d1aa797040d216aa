"""What brdfkit's Mitsuba 3 scripts share: loading Mitsuba, evaluating a BSDF on a
direction pair in brdfkit's convention, and their JSON files.

Used by crates/brdfkit-validate/python/mitsuba_eval.py (the cross-check) and
crates/fit-brdf/python/export_check.py (the export test), which put this directory on
`sys.path`.

Directions are in brdfkit's convention: local frame, z = normal, both pointing away from
the surface, `wi` towards the light and `wo` towards the viewer; f_r(wi, wo) is wanted
without the cosine. Mitsuba's `si.wi` is the viewer side (brdfkit's wo); the `wo`
argument of `BSDF.eval` is the light side (brdfkit's wi), and `eval` returns
f_r * cos(theta) of that argument (include/mitsuba/render/bsdf.h). So a pair is evaluated
as `bsdf.eval(ctx, si{wi = wo}, wi)` and divided by the float32 wi.z Mitsuba multiplied
by (`Frame3f::cos_theta(wo)` is its z component).

Exit codes of the scripts: 2 bad input; 3 Mitsuba or Dr.Jit cannot be imported or the
variant is not available (their callers treat 3 as "Mitsuba is missing").
"""

import json
import os
import struct
import sys


def fail(code, msg):
    """Print `<script>: msg` on stderr and exit with `code`."""
    print(f"{os.path.basename(sys.argv[0])}: {msg}", file=sys.stderr)
    sys.exit(code)


def load_mitsuba(variant):
    """(mitsuba, drjit) with `variant` set; exit 3 when either is missing."""
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
    """The versions the output files record."""
    return {"mitsuba": mi.__version__, "drjit": dr.__version__, "variant": variant}


def f32(x):
    """x rounded to float32, as nanobind converts a Python float for Mitsuba."""
    return struct.unpack("f", struct.pack("f", x))[0]


def eval_case(mi, bsdf, ctx, si, case):
    """Mitsuba's raw value (with the cosine) and f_r for one pair
    [wi_x, wi_y, wi_z, wo_x, wo_y, wo_z], each as [r, g, b]."""
    wi = mi.Vector3f(case[0], case[1], case[2])
    wo = mi.Vector3f(case[3], case[4], case[5])
    si.wi = wo  # Mitsuba's viewer side is brdfkit's wo, its light side brdfkit's wi
    v = bsdf.eval(ctx, si, wi)
    e = [float(v[0]), float(v[1]), float(v[2])]
    cos = f32(case[2])
    return e, [c / cos if cos > 0.0 else 0.0 for c in e]


def read_json(path):
    """The JSON in `path`; exit 2 when it cannot be read or parsed."""
    try:
        with open(path, encoding="utf-8") as fh:
            return json.load(fh)
    except (OSError, ValueError) as e:
        fail(2, f"{path}: {e}")


def write_json(path, value):
    """`value` as JSON in `path`, atomically (a temporary file, then a rename)."""
    tmp = path + ".tmp"
    with open(tmp, "w", encoding="utf-8") as fh:
        json.dump(value, fh)
    os.replace(tmp, path)

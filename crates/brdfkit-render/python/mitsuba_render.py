#!/usr/bin/env python3
"""Render a brdfkit-render scene file with Mitsuba 3 (the cross-check reference).

Usage: mitsuba_render.py SCENE.toml OUT.f32 [--spp N] [--variant scalar_rgb]

Reads the same TOML scene as brdfkit-render (Python's tomllib), builds the equivalent
Mitsuba 3 scene and renders it with the `direct` integrator. Writes the linear RGB
radiance as raw little-endian float32, row-major (row 0 at the top), 3 channels, and
prints one JSON line: {"width", "height", "spp", "seconds", "variant", "mitsuba"}.

Supported (anything else is an error, exit code 2):
- camera: perspective, fov across the film width (fov_axis "x"), look_at/up;
- one [sphere], and optionally the [plane] as a 2000 x 2000 `rectangle` (needs the
  shadows effect: Mitsuba always traces shadow rays);
- materials: `lambert` -> `diffuse`; `cook-torrance` with rho_d = 0, rho_s = 1,
  distribution ggx (or beckmann with beckmann_g1 = "rational"), masking
  smith-separable, conductor Fresnel -> `roughconductor`;
- point lights (`intensity`, W/sr), directional lights (`irradiance`, W/m^2),
  a constant environment (`constant`, radiance) or a lat-long image (`envmap`);
- film.filter "center" without environment: a `stratified` sampler with
  sample_count = 1 and jitter = false samples every pixel exactly at its centre
  (raster x + 0.5, y + 0.5), and the box filter (radius 0.5) gives that sample to its
  pixel only: the same rays as brdfkit's "center" filter, no noise.
  film.filter "box": a `multijitter` sampler (stratified, like brdfkit's), spp jittered
  rays per pixel through a one-pixel box filter, as brdfkit's "box" filter. At 256 spp
  it is within about 1 % of a 4096-spp `independent` render (the i.i.d. sampler at 256
  spp: 2.7 %).
"""

import argparse
import json
import os
import sys
import time
import tomllib


def fail(msg):
    print(f"error: {msg}", file=sys.stderr)
    sys.exit(2)


def rgb(v):
    if isinstance(v, (int, float)):
        return [float(v)] * 3
    if isinstance(v, list) and len(v) == 3:
        return [float(x) for x in v]
    fail(f"expected a number or [r, g, b], got {v!r}")


def spectrum(v):
    c = rgb(v)
    return {"type": "rgb", "value": c}


def load_model(mat, base):
    if "table" in mat:
        fail("a MERL table has no Mitsuba equivalent")
    m = mat.get("model")
    if isinstance(m, str):
        with open(os.path.join(base, m)) as f:
            m = json.load(f)
    if not isinstance(m, dict):
        fail("material.model must be a path or an inline table")
    name, p = m.get("model"), m.get("params") or {}
    if name == "lambert":
        return {"type": "diffuse", "reflectance": spectrum(p.get("rho_d", 0.5))}
    if name == "cook-torrance":
        if rgb(p.get("rho_d", 0.3)) != [0.0] * 3 or rgb(p.get("rho_s", 0.3)) != [1.0] * 3:
            fail("cook-torrance needs rho_d = 0 and rho_s = 1 to be a roughconductor")
        dist = p.get("distribution", "ggx")
        if dist == "beckmann" and p.get("beckmann_g1", "exact") != "rational":
            fail("beckmann needs beckmann_g1 = \"rational\" (Mitsuba's Smith G1)")
        if p.get("masking", "smith-separable") != "smith-separable":
            fail("roughconductor uses the separable Smith masking")
        fr = p.get("fresnel")
        if not (isinstance(fr, dict) and "conductor" in fr):
            fail("roughconductor needs fresnel = {conductor = {eta, k}}")
        cond = fr["conductor"] or {}
        out = {
            "type": "roughconductor",
            "distribution": dist,
            "eta": spectrum(cond.get("eta", 0.2)),
            "k": spectrum(cond.get("k", 3.0)),
            "sample_visible": True,
        }
        if "alpha" in p:
            out["alpha"] = float(p["alpha"])
        elif "alpha_x" in p:
            out["alpha_u"], out["alpha_v"] = float(p["alpha_x"]), float(p["alpha_y"])
        else:
            out["alpha"] = 0.2
        return out
    fail(f"model {name!r} has no Mitsuba equivalent here")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("scene")
    ap.add_argument("out")
    ap.add_argument("--spp", type=int, default=None)
    ap.add_argument("--variant", default="scalar_rgb")
    a = ap.parse_args()

    import mitsuba as mi
    import numpy as np

    mi.set_variant(a.variant)
    from mitsuba import ScalarTransform4f as T

    with open(a.scene, "rb") as f:
        s = tomllib.load(f)
    base = os.path.dirname(os.path.abspath(a.scene))
    film, cam = s["film"], s["camera"]
    effects = set(s["effects"])
    w, h = int(film["width"]), int(film["height"])
    filt = film.get("filter", "center")
    has_env = "environment" in s
    if "plane" in s and "shadows" not in effects:
        fail("Mitsuba always traces shadow rays: a scene with a [plane] needs the shadows effect")
    if filt == "center":
        if has_env:
            fail("an environment needs film.filter = \"box\" (Mitsuba has no centre-only multi-sample mode)")
        spp = 1
        sampler = {"type": "stratified", "sample_count": 1, "jitter": False}
    else:
        spp = a.spp or int(film.get("spp", 64))
        sampler = {"type": "multijitter", "sample_count": spp}

    scene = {"type": "scene"}
    scene["integrator"] = {
        "type": "direct",
        "emitter_samples": 1,
        "bsdf_samples": 1 if has_env else 0,
        "hide_emitters": not film.get("show_environment", True),
    }
    scene["sensor"] = {
        "type": "perspective",
        "fov": float(cam["fov"]),
        "fov_axis": "x",
        "to_world": T().look_at(
            origin=cam["position"], target=cam["look_at"], up=cam.get("up", [0, 1, 0])
        ),
        "film": {
            "type": "hdrfilm",
            "width": w,
            "height": h,
            "pixel_format": "rgb",
            "rfilter": {"type": "box"},
        },
        "sampler": sampler,
    }
    sp = s["sphere"]
    mat = sp.get("material") or s.get("material")
    scene["sphere"] = {
        "type": "sphere",
        "center": sp["center"],
        "radius": float(sp["radius"]),
        "bsdf": load_model(mat, base),
    }
    if "plane" in s:
        # brdfkit's plane is infinite; a 2000 x 2000 rectangle is the same to within the
        # pixels at the horizon (masked: far away, so both are dark) and a 0.1 % sliver of
        # sky near the horizon for environment occlusion.
        pl = s["plane"]
        n = np.asarray(pl["normal"], dtype=float)
        n /= np.linalg.norm(n)
        # Orthonormal frame (Duff et al. 2017) with the rectangle's +z on the normal.
        sign = 1.0 if n[2] >= 0 else -1.0
        ia = -1.0 / (sign + n[2])
        ib = n[0] * n[1] * ia
        t = np.array([1.0 + sign * n[0] * n[0] * ia, sign * ib, -sign * n[0]])
        bb = np.array([ib, sign + n[1] * n[1] * ia, -n[1]])
        half = 1000.0
        m = np.eye(4)
        m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = half * t, half * bb, n, pl["point"]
        pmat = pl.get("material") or s.get("material")
        scene["plane"] = {
            "type": "rectangle",
            "to_world": T(m.tolist()),
            "bsdf": load_model(pmat, base),
        }
    if "direct" in effects:
        for i, l in enumerate(s.get("light", [])):
            if l["type"] == "point":
                scene[f"light{i}"] = {
                    "type": "point",
                    "position": l["position"],
                    "intensity": spectrum(l["intensity"]),
                }
            elif l["type"] == "directional":
                scene[f"light{i}"] = {
                    "type": "directional",
                    "direction": l["direction"],
                    "irradiance": spectrum(l["irradiance"]),
                }
            else:
                fail(f"light type {l['type']!r}")
    if has_env:
        e = s["environment"]
        scale = float(e.get("scale", 1.0))
        if "constant" in e:
            c = [scale * x for x in rgb(e["constant"])]
            scene["env"] = {"type": "constant", "radiance": spectrum(c)}
        else:
            scene["env"] = {
                "type": "envmap",
                "filename": os.path.join(base, e["file"]),
                "scale": scale,
            }

    t0 = time.perf_counter()
    sc = mi.load_dict(scene)
    img = mi.render(sc, spp=spp, seed=int(film.get("seed", 0)))
    seconds = time.perf_counter() - t0

    arr = np.asarray(img, dtype=np.float32).reshape(h, w, 3)
    arr.astype("<f4").tofile(a.out)
    print(
        json.dumps(
            {
                "width": w,
                "height": h,
                "spp": spp,
                "seconds": seconds,
                "variant": a.variant,
                "mitsuba": mi.__version__,
            }
        )
    )


if __name__ == "__main__":
    main()

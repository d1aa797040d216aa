# Mitsuba 3 on files written by brdfkit's RGL writer: the reference of
# tests/write_mitsuba.rs.
#   python write_mitsuba.py chi2 FILE.bsdf THETA_DEG[@PHI_DEG]...
#       Mitsuba's chi^2 test (mitsuba.chi2) of the `measured` plugin's sampling at each
#       incident direction (elevation, azimuth; the azimuth defaults to 0.7 rad);
#       prints one JSON line per direction.
#   python write_mitsuba.py render TABLE.binary FILE.bsdf SPP_POINT SPP_ENV
#       256x256 renders of a sphere under a point light and under a constant
#       environment, the file through `measured` and the table through brdfkit's
#       `brdfkit_merl` (linear lookup); prints JSON: the relative RMS of each pair over
#       8x8-pixel block means on the sphere (and over single pixels), and the noise
#       floor (two renders of the file, two seeds).
import json
import math
import sys

import numpy as np
import mitsuba as mi
import drjit as dr

BLOCK = 8


def llvm():
    """Mitsuba's `llvm_ad_rgb` (the χ² module and the brdfkit plugin's batched eval need
    a vectorised variant), or exit 3 with how to get it (.ci/run installs LLVM 19)."""
    try:
        mi.set_variant("llvm_ad_rgb")
    except Exception as e:  # noqa: BLE001 - any failure to load LLVM is the same message
        print(f"llvm_ad_rgb unavailable ({e}): apt-get install libllvm19 and set "
              "DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1", file=sys.stderr)
        sys.exit(3)


def chi2(path, degrees):
    llvm()
    from mitsuba.chi2 import BSDFAdapter, ChiSquareTest, SphericalDomain

    for arg in degrees:
        deg, _, az = arg.partition("@")
        th = math.radians(float(deg))
        phi = math.radians(float(az)) if az else 0.7
        wi = [math.sin(th) * math.cos(phi), math.sin(th) * math.sin(phi), math.cos(th)]
        sample, pdf = BSDFAdapter("measured", f'<string name="filename" value="{path}"/>', wi=wi)
        test = ChiSquareTest(domain=SphericalDomain(), sample_func=sample, pdf_func=pdf,
                             sample_dim=3, sample_count=1_000_000, res=101, ires=8)
        ok = bool(test.run(0.01, quiet=True))
        print(json.dumps({"theta_deg": float(deg), "phi_deg": math.degrees(phi), "passed": ok, "p_value": float(test.p_value),
                          "messages": "" if ok else test.messages}), flush=True)


def scene(bsdf, light, spp, seed):
    d = {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": 2},
        "sensor": {
            "type": "perspective",
            "fov": 30,
            "to_world": mi.ScalarTransform4f().look_at(origin=[0, -1.5, 4.2], target=[0, 0, 0], up=[0, 1, 0]),
            "film": {"type": "hdrfilm", "width": 256, "height": 256, "pixel_format": "rgb",
                     "rfilter": {"type": "box"}},
            "sampler": {"type": "independent", "sample_count": spp, "seed": seed},
        },
        "sphere": {"type": "sphere", "bsdf": bsdf},
    }
    if light == "point":
        d["light"] = {"type": "point", "position": [3.0, -2.0, 4.0],
                      "intensity": {"type": "rgb", "value": [30.0, 30.0, 30.0]}}
    else:
        d["light"] = {"type": "constant", "radiance": {"type": "rgb", "value": [1.0, 1.0, 1.0]}}
    return mi.load_dict(d)


def render(table, path, spp_point, spp_env):
    llvm()
    import brdfkit.mitsuba
    brdfkit.mitsuba.register()
    measured = {"type": "measured", "filename": path}
    merl = {"type": "brdfkit_merl", "filename": table, "interp": "linear"}
    # The sphere's pixels: where a depth AOV is positive.
    aov = mi.load_dict({
        "type": "scene",
        "integrator": {"type": "aov", "aovs": "dd:depth"},
        "sensor": scene(measured, "point", 4, 0).sensors()[0],
        "sphere": {"type": "sphere"},
    })
    mask = np.array(mi.render(aov, spp=4))[:, :, 0] > 0
    # Blocks of BLOCK x BLOCK pixels wholly on the sphere: the Monte Carlo noise of a
    # block mean is BLOCK times smaller than a pixel's (independent samples), while the
    # shading varies little within a block, so the RMS over blocks measures the
    # systematic difference; the noise floor (two seeds of the same file) shows what is
    # left of the noise.
    B = BLOCK
    h, w = mask.shape
    blocks = mask.reshape(h // B, B, w // B, B).all(axis=(1, 3))

    def block_means(img):
        return img.reshape(h // B, B, w // B, B, 3).mean(axis=(1, 3))[blocks]

    def rms(x, y):
        return float(np.sqrt(np.mean((x - y) ** 2) / np.mean(y ** 2)))

    out = {"sphere_pixels": int(mask.sum()), "blocks": int(blocks.sum()), "block": B}
    for light, spp in (("point", spp_point), ("env", spp_env)):
        a = np.array(mi.render(scene(measured, light, spp, 1)))
        b = np.array(mi.render(scene(merl, light, spp, 2)))
        c = np.array(mi.render(scene(measured, light, spp, 3)))
        out[light] = {
            "spp": spp,
            "rel_rms": rms(block_means(a), block_means(b)),
            "noise_floor": rms(block_means(c), block_means(a)),
            "rel_rms_pixels": rms(a[mask], b[mask]),
            "noise_floor_pixels": rms(c[mask], a[mask]),
            "mean_measured": float(a[mask].mean()),
            "mean_merl": float(b[mask].mean()),
        }
    print(json.dumps(out), flush=True)


if __name__ == "__main__":
    if sys.argv[1] == "chi2":
        chi2(sys.argv[2], sys.argv[3:])
    else:
        render(sys.argv[2], sys.argv[3], int(sys.argv[4]), int(sys.argv[5]))

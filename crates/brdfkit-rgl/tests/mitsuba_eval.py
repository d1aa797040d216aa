# Mitsuba 3's `measured` plugin evaluated at direction pairs: the reference of
# tests/mitsuba.rs. Usage: python mitsuba_eval.py VARIANT FILE.bsdf PAIRS.bin OUT.bin [WL.bin]
# PAIRS.bin: N×6 float64 (wi, wo); WL.bin (spectral): N×4 float64 wavelengths.
# OUT.bin: N×k float64 of what BSDF.eval returns (k = 3 for RGB, 4 for spectral).
import sys
import numpy as np
import mitsuba as mi

variant, path, pairs_path, out_path = sys.argv[1:5]
mi.set_variant(variant)
bsdf = mi.load_dict({'type': 'measured', 'filename': path})
pairs = np.fromfile(pairs_path, dtype=np.float64).reshape(-1, 6)
spectral = 'spectral' in variant
wl = np.fromfile(sys.argv[5], dtype=np.float64).reshape(-1, 4) if spectral else None
ctx = mi.BSDFContext()
si = mi.SurfaceInteraction3f()
out = np.zeros((len(pairs), 4 if spectral else 3))
for k, p in enumerate(pairs):
    si.wi = mi.Vector3f(p[0], p[1], p[2])
    if spectral:
        si.wavelengths = mi.Spectrum(wl[k])
    v = bsdf.eval(ctx, si, mi.Vector3f(p[3], p[4], p[5]))
    out[k] = np.array(v).ravel()[: out.shape[1]]
out.tofile(out_path)

# The relative RMS figures of docs/export.md's worked example ("From a measured fabric to
# a web page"), run in Blender's Python (it has numpy and reads OpenEXR):
#
#   blender -b --factory-startup --python docs/engines/compare.py -- THREE.json FIT.exr TABLE.exr
#
# THREE.json is crates/fit-brdf/tests/engines/threejs.cjs's output (one material, rows
# top-down); the EXRs are fit-brdf render's (linear). Pixels: where three.js covered the
# pixel centre (alpha 1). Relative RMS = sqrt(sum (a - b)^2 / sum b^2) over them.
import bpy, json, sys, numpy as np
a = sys.argv[sys.argv.index('--')+1:]
def exr(p):
    im = bpy.data.images.load(p); n = im.size[0]
    px = np.array(im.pixels[:]).reshape(n, n, 4)[::-1, :, :3]  # Blender's rows are bottom-up
    return px
three = json.load(open(a[0])); n = three['size']
t = np.array(three['renders'][0]['rgba']).reshape(n, n, 4)
mask = t[..., 3] == 1.0
fit, table = exr(a[1]), exr(a[2])
def rr(x, y): return float(np.sqrt(((x[mask]-y[mask])**2).sum() / (y[mask]**2).sum()))
print("RESULT three.js vs brdfkit(fit) %.2f %%, brdfkit(fit) vs table %.2f %%, three.js vs table %.2f %%, pixels %d" % (100*rr(t[..., :3], fit), 100*rr(fit, table), 100*rr(t[..., :3], table), mask.sum()))

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

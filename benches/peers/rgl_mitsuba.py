# Mitsuba 3's `measured` plugin evaluated over a whole array of pairs (llvm_ad_rgb):
# the peer of `fit-brdf eval --bsdf` (docs/rgl.md, "Speed").
#   python rgl_mitsuba.py FILE.bsdf PAIRS.npy [OUT.npy] [--reps N]
# PAIRS.npy: N×6 float64 (wi, wo), given to Mitsuba as f32. Prints the time of each
# bsdf.eval + dr.eval + dr.sync_thread (the first includes the JIT compilation; later
# ones hit Dr.Jit's kernel cache) and their median after the first; with OUT.npy,
# writes the N×3 values. Needs DRJIT_LIBLLVM_PATH for LLVM 19 (benches/peers/run).
import sys
import time
import numpy as np
import mitsuba as mi
import drjit as dr

args = [a for a in sys.argv[1:] if not a.startswith('--')]
reps = int(sys.argv[sys.argv.index('--reps') + 1]) if '--reps' in sys.argv else 5
if '--reps' in sys.argv:
    args.remove(str(reps))
mi.set_variant('llvm_ad_rgb')
bsdf = mi.load_dict({'type': 'measured', 'filename': args[0]})
p = np.load(args[1])
p = p.astype(np.float32)
si = dr.zeros(mi.SurfaceInteraction3f, len(p))
si.wi = mi.Vector3f(p[:, 0], p[:, 1], p[:, 2])
wo = mi.Vector3f(p[:, 3], p[:, 4], p[:, 5])
dr.eval(si, wo)
dr.sync_thread()
ctx = mi.BSDFContext()
ts = []
for r in range(reps):
    t, c = time.perf_counter(), time.process_time()
    v = bsdf.eval(ctx, si, wo)
    dr.eval(v)
    dr.sync_thread()
    ts.append(time.perf_counter() - t)
    print(f"rep {r}: {ts[-1]:.3f} s wall, {time.process_time() - c:.3f} s CPU (all threads)")
print(f"median of reps 1..: {sorted(ts[1:])[len(ts[1:]) // 2]:.3f} s" if reps > 1 else "")
if len(args) > 2:
    np.save(args[2], np.array(v).T.astype(np.float64))

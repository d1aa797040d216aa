"""A realistic-size RGL-EPFL .bsdf (isotropic RGB, 8 theta_i slices, 128^2 VNDF, 32^2
values, about the size of a database *_rgb.bsdf) and N random pairs above 1 degree, for
benches/peers/rgl. Usage: python rgl_make.py OUT.bsdf PAIRS.npy"""
import numpy as np, mitsuba as mi, sys
rng=np.random.default_rng(7)
th=np.radians([0,12,25,38,50,61,71,80]).astype(np.float32)
n=32; m=128
u=np.linspace(0,1,n); U,V=np.meshgrid(u,u)
rgb=np.stack([np.stack([0.3+0.36*np.sin(3*U+c+t)*np.sin(2*V+c) for c in range(3)]) for t in range(8)])[None].astype(np.float32)
um=np.linspace(0,1,m); Um,Vm=np.meshgrid(um,um)
vndf=np.stack([np.exp(-((Um-0.3-0.03*t)**2)/0.05)*(1.2+np.sin(6*Vm)) + 0.05 for t in range(8)])[None].astype(np.float32)
d=dict(version=np.array([1,0],np.uint32), description='a realistic-size test material', phi_i=np.array([0],np.float32), theta_i=th,
  sigma=(1+0.1*np.sin(np.linspace(0,3,256))).reshape(2,128).astype(np.float32), ndf=(1+2*np.exp(-np.linspace(0,4,256))).reshape(2,128).astype(np.float32),
  vndf=vndf, luminance=np.abs(rgb).mean(axis=2).astype(np.float32)+0.01,
  rgb=rgb, jacobian=np.array([1],np.uint8), valid=np.packbits(rng.random(8*n*n)<0.3))
mi.tensor_io.write(sys.argv[1], **d)
N=1458000
def dirs():
    z=rng.uniform(np.sin(np.radians(1)),1,N); ph=rng.uniform(0,2*np.pi,N); r=np.sqrt(1-z*z)
    return np.stack([r*np.cos(ph), r*np.sin(ph), z],1)
np.save(sys.argv[2], np.concatenate([dirs(),dirs()],1))

"""Out-of-sample check of the diffusion model's vacuum floor (pv_ambient.stages.diffusion, "Vacuum
floor") on scenes the trade benchmark does not use: smoke plume (point light, g = 0.3), the
Marschner–Lobb volume lit from its centre, the cloud under a directional light (g = 0.6).

For each: a path-traced reference (4096 spp or 1 % standard error, 64²), then plain and
flux-limited diffusion with the default floor (1/mean chord), the earlier 0.01/diagonal, 1/diagonal
and 10/diagonal, and single / ambient scattering for scale; 4×4-block relative RMSE and bias.

The scenes are benchmarks/scenes.py's "floor" group.

Usage: ``python benchmarks/diffusion_floor.py [smoke_plume,marschner_lobb,cloud_sun]``
"""
import sys, time, numpy as np
import pv_ambient as pa, pv_ambient.stages.diffusion as dm
from pv_ambient.stages.diffusion import solve as dsolve
from pv_ambient import metrics
size=(64,64)
from scenes import scene  # benchmarks/scenes.py (the script's directory is on sys.path); n = 64
names = sys.argv[1] if len(sys.argv) > 1 else "smoke_plume,marschner_lobb,cloud_sun"
for name in names.split(","):
    g, tf, lights, ph, cam = scene(name)
    r=pa.Renderer(g, transfer_function=tf, lights=lights)
    t=time.perf_counter()
    ref=r.render(camera=cam, window_size=size, model="path_traced", phase=ph, seed=99, samples_per_pixel=4096, target_error=0.01)
    mask=metrics.light_mask(size[::-1], cam, size, lights)
    noise=float(np.sqrt(np.mean(ref.std_error[mask]**2)/16)/np.mean(ref.radiance[mask]))
    print(name, "ref", ref.metadata["spp"], "spp %.0fs block noise %.3f"%(time.perf_counter()-t, noise), flush=True)
    chord=dm.mean_chord(tuple(g.dimensions), g.spacing)
    diag=float(np.linalg.norm((np.array(g.dimensions)-1)*np.array(g.spacing)))
    for label, rel in (("default 1/chord",1.0),("old 0.01/diag",0.01*chord/diag),("1/diag", chord/diag),("10/diag",10*chord/diag)):
        dsolve.SIGMA_FLOOR_REL=rel
        r2=pa.Renderer(g, transfer_function=tf, lights=lights)
        for fl in (False,True):
            img=r2.render(camera=cam, window_size=size, model="diffusion", phase=ph, flux_limited=fl).radiance
            print("   %-16s %-5s block %.3f bias %+.3f"%(label, "FL" if fl else "plain", metrics.block_relative_rmse(img,ref.radiance,mask), metrics.relative_bias(img,ref.radiance,mask)), flush=True)
    dsolve.SIGMA_FLOOR_REL=1.0
    for m in ("single_scattering","ambient_scattering"):
        img=r.render(camera=cam, window_size=size, model=m, phase=ph).radiance
        print("   %-22s block %.3f bias %+.3f"%(m, metrics.block_relative_rmse(img,ref.radiance,mask), metrics.relative_bias(img,ref.radiance,mask)), flush=True)

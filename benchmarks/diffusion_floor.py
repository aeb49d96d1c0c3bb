"""Out-of-sample check of the diffusion model's vacuum floor (pv_ambient.stages.diffusion, "Vacuum
floor") on scenes the trade benchmark does not use: smoke plume (point light, g = 0.3), the
Marschner–Lobb volume lit from its centre, the cloud under a directional light (g = 0.6).

For each: a path-traced reference (4096 spp or 1 % standard error, 64²), then plain and
flux-limited diffusion with the default floor (1/mean chord), the earlier 0.01/diagonal, 1/diagonal
and 10/diagonal, and single / ambient scattering for scale; 4×4-block relative RMSE and bias.

Usage: ``python benchmarks/diffusion_floor.py [smoke_plume,marschner_lobb,cloud_sun]``
"""
import sys, time, numpy as np
import pv_ambient as pa, pv_ambient.stages.diffusion as dm
from pv_ambient.stages.diffusion import solve as dsolve
from pv_ambient import datasets, metrics
size=(64,64)
def scene(name):
    if name=="smoke_plume":
        g=datasets.smoke_plume(n=64); st=datasets.suggested_style("smoke_plume")
        return g, pa.TransferFunction(**st, albedo=0.9), [pa.PointLight((1.2,-0.8,1.0),intensity=5.0)], 0.3, pa.Camera((0,-3.6,0.5),(0,0,0),(0,0,1),view_angle=30)
    if name=="marschner_lobb":
        g=datasets.marschner_lobb(n=64); st=datasets.suggested_style("marschner_lobb")
        return g, pa.TransferFunction(**st, albedo=0.9), [pa.PointLight((0.0,0.0,0.0),intensity=2.0)], 0.0, pa.Camera((0,-3.6,1.0),(0,0,0),(0,0,1),view_angle=30)
    if name=="cloud_sun":
        g=datasets.cloud(n=64); st=datasets.suggested_style("cloud")
        return g, pa.TransferFunction(**{**st,"density_scale":8.0}, albedo=0.95), [pa.DirectionalLight((0.3,0.4,-1.0),irradiance=2.0)], 0.6, pa.Camera((0,-3.6,0.8),(0,0,0),(0,0,1),view_angle=30)
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

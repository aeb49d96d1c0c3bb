"""Where a frame's time goes (issue 16's profile): the emission–absorption march taken apart, and
the stages of the relight and first-frame rows.

Part 1 — the march. :mod:`benchmarks.speed`'s scene (supernova ``--n``³, ``--size``² pixels, half-voxel
step, the camera of its camera-move rows). A stand-alone copy of the ray cast's emission–absorption
loop (``pv_ambient._kernels.raycast.march_pixel`` in LUT mode: trilinear scalar, table lookup of σt
and colour, exact segment integration, early termination; the same 16² pixel tiles, no jitter — the
supernova's TF leaves no majorant block empty, so the block skipping it leaves out never fires) is
checked against the renderer's own image (≤ 1e-6 relative: its float32 radiance), then timed with one piece replaced at a
time:

* ``kernel``: the copy as is;
* ``no exp``: ``exp(−σℓ)`` replaced by a rational function of σℓ (the cost of ``exp``);
* ``nearest``: the scalar read from the nearest sample instead of trilinear interpolation (the cost
  of the interpolation's seven further loads and lerps);
* ``no fetch``: the scalar made from the sample position, no volume read (what is left: the table
  lookups, the compositing and the loop — the march's compute floor in this form).

Each line prints the median time of ``--repeats`` frames, the ratio to VTK's ``fixed_point`` frame of
the same scene (interleaved, medians) and ns per loop iteration per thread (iterations counted in the
kernel; the variants march slightly different numbers of samples when early termination moves).

Part 2 — the stages. cProfile of one relight (SS, AS) and one first frame (SS, diffusion) of
:mod:`benchmarks.speed`'s rows, caches as there; the kernels with the largest own time.

Usage: ``python benchmarks/march_floor.py [--n 256] [--size 512] [--repeats 5]``; writes
``results/march_floor_n{N}.txt``.
"""

from __future__ import annotations

import argparse
import cProfile
import io
import math
import os
import pstats
import sys
import time
from pathlib import Path

os.environ.setdefault("PYVISTA_OFF_SCREEN", "true")
os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
sys.path.insert(0, str(Path(__file__).parent))

import numba  # noqa: E402
import numpy as np  # noqa: E402
from numba import njit, prange  # noqa: E402

import speed as S  # noqa: E402
from pv_ambient._kernels.geometry import camera_ray, ray_box  # noqa: E402
from pv_ambient._kernels.interp import trilinear  # noqa: E402
from pv_ambient._kernels.medium import lut_coords, lut_value  # noqa: E402
from pv_ambient._kernels.raycast import TILE, index_ray  # noqa: E402

VARIANTS = ("kernel", "no exp", "nearest", "no fetch")
FASTMATH = {"nsz", "arcp", "contract", "afn", "reassoc"}  # the package's kernels' flags


def make_march(variant):
    """The EA march with ``variant``'s piece replaced (module docstring)."""
    v = VARIANTS.index(variant)

    @njit(parallel=True, fastmath=FASTMATH, error_model="numpy")
    def march(cam, w2i, lo, hi, field, table, lut_lo, lut_inv, step, ert, out, iters):
        H, W = out.shape[0], out.shape[1]
        n_cols = (W + TILE - 1) // TILE
        n = n_cols * ((H + TILE - 1) // TILE)
        nt = table.shape[0]
        for q in prange(n):
            a = q // n_cols
            b = q - a * n_cols
            for j in range(a * TILE, min((a + 1) * TILE, H)):
                for i in range(b * TILE, min((b + 1) * TILE, W)):
                    ox, oy, oz, dx, dy, dz = camera_ray(cam, i, j, W, H)
                    px, py, pz, qx, qy, qz = index_ray(w2i, ox, oy, oz, dx, dy, dz)
                    t0, t1 = ray_box(px, py, pz, qx, qy, qz, lo, hi)
                    t = max(t0, 0.0)
                    r = 0.0
                    g = 0.0
                    bl = 0.0
                    T = 1.0
                    m = 0
                    while t < t1:
                        te = min(t + step, t1)
                        tm = 0.5 * (t + te)
                        x = px + tm * qx
                        y = py + tm * qy
                        z = pz + tm * qz
                        m += 1
                        if v == 2:
                            s = field[min(max(int(x + 0.5), 0), field.shape[0] - 1),
                                      min(max(int(y + 0.5), 0), field.shape[1] - 1),
                                      min(max(int(z + 0.5), 0), field.shape[2] - 1)]
                        elif v == 3:
                            s = 0.3 + 0.0005 * (x + y + z)  # varied, in the TF's range; no read, no transcendental
                        else:
                            s = trilinear(field, x, y, z)
                        k0, k1, f = lut_coords(s, lut_lo, lut_inv, nt)
                        sig = lut_value(table, k0, k1, f, 0)
                        if sig > 0.0:
                            if v == 1:
                                u = sig * (te - t)
                                e = 1.0 / (1.0 + u + 0.5 * u * u)
                            else:
                                e = math.exp(-sig * (te - t))
                            w = T * (1.0 - e)
                            r += w * lut_value(table, k0, k1, f, 7)
                            g += w * lut_value(table, k0, k1, f, 8)
                            bl += w * lut_value(table, k0, k1, f, 9)
                            T *= e
                            if T < ert:
                                break
                        t = te
                    out[j, i, 0] = r
                    out[j, i, 1] = g
                    out[j, i, 2] = bl
                    out[j, i, 3] = T
                    iters[j, i] = m

    return march


def march_part(frames, size, repeats):
    r = frames.renderer
    cam = frames.cam
    view, medium = S.march_records(r, cam, size)
    w, h = size
    out = np.zeros((h, w, 4))
    iters = np.zeros((h, w), np.int64)
    ert = S.ERT

    def args():
        return (view.cam, view.w2i, view.lo, view.hi, medium.field, medium.table, medium.lut_lo, medium.lut_inv,
                float(frames.step), ert, out, iters)

    # the copy against the renderer (black background: radiance = the march's sum)
    ref = r.render(camera=cam, window_size=size, model="emission_absorption", step=frames.step, background=(0, 0, 0))
    kern = {name: make_march(name) for name in VARIANTS}
    kern["kernel"](*args())
    rel = float(np.max(np.abs(out[..., :3] - ref.radiance)) / np.max(np.abs(ref.radiance)))
    lines = [f"the copy of the EA march against Renderer.render: max |Δ| / max = {rel:.1e} (must be ≤ 1e-6: the renderer returns float32)"]
    if not rel <= 1e-6:
        raise SystemExit("\n".join(lines))
    for k in kern.values():  # compile
        k(*args())
    vtk = S.VtkPeer(frames.grid, r, size, frames.step)
    threads = numba.get_num_threads()
    full = frames.frame_fn("camera", "EA")
    rows = []
    for name in ("frame",) + VARIANTS:
        if name == "frame":
            def ours(k):
                full(k)
            n_it = None
        else:
            kk = kern[name]

            def ours(k, kk=kk):
                kk(*args())
        t, tv = S.interleaved(vtk, ours, lambda k: S.turned(cam, k), repeats)
        n_it = int(iters.sum()) if name != "frame" else None
        rows.append((name, t, tv, n_it))
    vtk.close()
    n_frame = next(x[3] for x in rows if x[0] == "kernel")
    lines += ["", f"{'march':34s} {'s':>7s} {'VTK s':>7s} {'÷VTK':>6s} {'iterations (M)':>15s} {'ns/iter/thread':>15s}"]
    labels = {"frame": "Renderer.render (EA camera move)", "kernel": "kernel (the copy)",
              "no exp": "kernel, exp → rational", "nearest": "kernel, nearest sample",
              "no fetch": "kernel, no volume read"}
    for name, t, tv, n_it in rows:
        n_used = n_it if n_it is not None else n_frame
        lines.append(f"{labels[name]:34s} {t:7.3f} {tv:7.3f} {t / tv:6.2f} {n_used / 1e6:15.1f} "
                     f"{t * threads / n_used * 1e9:15.1f}")
    lines.append(f"({threads} threads; the frame row's iterations: the copy's, the same march)")
    return lines


def profile_part(frames):
    lines = []
    for m in ("SS", "AS", "diffusion"):
        frames.render(frames.renderer, m, frames.cam)
    for kind, model in (("relight", "SS"), ("relight", "AS"), ("first", "SS"), ("first", "diffusion")):
        fn = frames.frame_fn(kind, model)
        fn(0)
        pr = cProfile.Profile()
        t = time.perf_counter()
        pr.enable()
        fn(1)
        pr.disable()
        total = time.perf_counter() - t
        st = pstats.Stats(pr, stream=io.StringIO())
        own = sorted(((v[2], f"{Path(k[0]).name}:{k[2]}", v[1]) for k, v in st.stats.items()), reverse=True)
        lines += ["", f"{kind} {model}: {total:.2f} s; largest own time"]
        for tt, name, calls in own[:6]:
            lines.append(f"  {tt:7.3f} s  {100 * tt / total:5.1f} %  {name} ({calls} calls)")
    return lines


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=256)
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--out", default=str(Path(__file__).parent / "results"))
    args = ap.parse_args(argv)
    size = (args.size, args.size)
    frames = S.make_frames(args.n, size)
    lines = ["$ python " + " ".join(sys.argv), "",
             f"supernova {args.n}³, {size[0]}x{size[1]}, step {frames.step:.5f} (half a voxel); medians of "
             f"{args.repeats} after a warm-up, VTK fixed_point interleaved", ""]
    lines += march_part(frames, size, args.repeats)
    print("\n".join(lines), flush=True)
    prof = profile_part(frames)
    print("\n".join(prof))
    Path(args.out).mkdir(parents=True, exist_ok=True)
    (Path(args.out) / f"march_floor_n{args.n}.txt").write_text("\n".join(lines + prof) + "\n")


if __name__ == "__main__":
    main()

"""Speed (issue 16): every kind of frame against VTK's ``fixed_point`` emission–absorption frame,
measured interleaved in one process, plus our cost per marched sample.

Scene: ``supernova_centre`` of benchmarks/scenes.py at ``--n``³ (the synthetic supernova, its
``suggested_style`` with albedo 0.9, one point light of intensity 4 at the centre, camera from
(0, −3.6, 0.6) looking at the centre, view angle 30°), ``--size``² pixels, half-voxel step
(``Renderer.default_step()``, quality "balanced"). Rows (the issue's table):

* camera move — EA, single scattering (SS), ambient scattering (AS, Beer–Lambert), diffusion: every
  cache warm, the camera turned by 1° per frame (only the ray cast runs); and AS with the two lights
  of the relight row below (the camera pass that row's stage excludes);
* relight — SS, AS and diffusion: the light moves by 0.02 (a new position each frame), the moved
  light's volumes are rebuilt, then the ray cast; and AS with two lights, one of them moved (the
  other's volumes reused);
* TF change — AS: a new ``Renderer`` of another density scale that shares the preintegrated table
  slices (``cache.share``: the disk cache's role), then its first frame;
* first frame — SS, AS, diffusion and ``model="auto", quality="accurate"`` ("auto accurate", at
  that preset's own step; its camera move is a row too): a new ``Renderer`` (classification
  included) and its first frame, table slices shared as above; Numba compiled beforehand (the
  warm-up frame).

The camera moves' targets are frame ratios (the CPU camera pass's goals); the other rows' are on
the *stage*, each frame less its own camera pass (the ray cast's time, ``metadata["time_render"]``),
median over the row's frames, in VTK frames (the first-frame work's goals): both are printed. The
last column, "less row", is the stage measured the earlier way, the row's median frame less the
same model's camera-move row (same lights) in this run — the difference of two medians, each with
the spread of this machine's frames.

Every row alternates one VTK ``fixed_point`` frame (benchmarks/timing.py's peer: same TF, camera and
step; a camera that does not move is turned a little every other frame, or VTK would not re-render)
and one frame of ours in the same loop: after a warm-up pair, ``--repeats`` pairs (≥ 5), and each
side's median. VTK's frame time drifts by several×
on a shared machine, hence the interleaving and the printed VTK time per row. Printed per row: our
median, VTK's median, the ratio, the issue's target ratio, whether it is met, and for the camera moves
the cost in ns per marched sample per thread = time × threads / samples, where ``samples`` are the ray
cast's segments in non-empty majorant blocks up to early termination — counted by
:func:`count_samples`, which walks the ray cast's march (``pv_ambient._kernels.raycast.march_pixel``)
with the kernels' own scalar functions. Before the table the count is checked on a tiny scene against
a brute-force NumPy march (:func:`brute_force_count`) and against the ray cast's own alpha.

Options: ``--models`` and ``--kinds`` keep only some rows (into ``speed_rows_n{N}.txt``; a row's
stage needs its model's camera move); ``--threads-scaling`` re-runs the camera-move and relight rows and diffusion's first frame in subprocesses with
NUMBA_NUM_THREADS = each of ``--threads`` (default 1,2) and prints the speed-ups over one thread
(``--scaling-only``: that table alone, into ``speed_threads_n{N}.txt``; it needs neither pyvista nor
vtk, for a many-core machine that lacks them); ``--memory`` renders AS with two lights in a fresh
subprocess and prints its peak resident-set growth above its size after imports, loading the grid and
a warm-up compile (``resource.getrusage``; the peak restarted there through ``/proc/self/clear_refs``)
as a multiple of the volume's float32 size (``--memory-only``: that line alone, into
``speed_memory_n{N}.txt``); ``--drag`` prints frames
per second over a simulated 36-step camera drag (1° azimuth per step, caches warm) per model, in a plotter
with ``interactive=True`` (drag frames at half resolution per axis) and the resting frame after it.

The table is also written to ``benchmarks/results/speed_n{N}.txt`` (``--out`` for another folder),
the command line at its top.

Usage (from the repository root)::

    python benchmarks/speed.py [--n 128] [--size 512] [--repeats 5] [--threads-scaling] [--memory] [--drag]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

os.environ.setdefault("PYVISTA_OFF_SCREEN", "true")
os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")

import pv_ambient as pa  # noqa: E402  (before Numba: the packet driver's load policy)
import numba  # noqa: E402
import numpy as np  # noqa: E402
from pv_ambient._kernels import records as K  # noqa: E402
from pv_ambient._kernels.geometry import camera_ray, ray_box  # noqa: E402
from pv_ambient._kernels.majorant import block_at, block_span  # noqa: E402
from pv_ambient._kernels.medium import MODE_GRID  # noqa: E402
from pv_ambient._kernels.raycast import index_ray, medium_sigma  # noqa: E402
from pv_ambient.inputs.transfer import COL_COLOR, COL_SIGMA  # noqa: E402
from pv_ambient.rendering.presets import MAJORANT_BLOCK  # noqa: E402

import scenes  # noqa: E402  (benchmarks/: the script's directory is on sys.path)
from timing import VtkPeer, interleaved  # noqa: E402

ERT = 1e-5  # the renderer's default early termination
SCENE = "supernova_centre"  # benchmarks/scenes.py
MODELS = {"EA": "emission_absorption", "SS": "single_scattering", "AS": "ambient_scattering",
          "diffusion": "diffusion"}

#: Render options per row model beyond speed.py's scene: "auto accurate" is ``model="auto"`` with
#: ``quality="accurate"`` and that preset's own step (no explicit step).
MODEL_OPTIONS = {"auto accurate": {"quality": "accurate"}}
ROW_MODELS = {**MODELS, "auto accurate": "auto"}

# (row, kind, model, target ratio, stage target): the camera moves' targets are the CPU camera pass's
# goals (frame / VTK frame); the other rows' are the first-frame work's, on the stage — the frame less
# the camera move of the same model measured in the same run, in VTK frames (docs/performance.rst,
# "CPU speed")
ROWS = [
    ("emission-absorption, camera move", "camera", "EA", 1.5, None),
    ("single scattering, camera move", "camera", "SS", 2.0, None),
    ("ambient scattering, camera move", "camera", "AS", 2.5, None),
    ("diffusion, camera move", "camera", "diffusion", 2.5, None),
    ("auto accurate, camera move", "camera", "auto accurate", None, None),
    ("relight (one light moved), SS", "relight", "SS", None, 2.0),
    ("relight (one light moved), AS", "relight", "AS", None, 2.0),
    ("ambient scattering, camera move, 2 lights", "camera2", "AS", None, None),
    ("relight (one of two moved), AS", "relight2", "AS", None, 2.0),
    ("relight (one light moved), diffusion", "relight", "diffusion", None, None),
    ("TF change, AS", "tf", "AS", None, 5.0),
    ("first frame, SS", "first", "SS", None, 4.0),
    ("first frame, AS", "first", "AS", None, 5.0),
    ("first frame, diffusion", "first", "diffusion", None, 12.0),
    ("first frame, auto accurate", "first", "auto accurate", None, 60.0),
]


# --- the scene: benchmarks/scenes.py's supernova_centre ----------------------------------------

#: Environment variable naming an .npz of the supernova TF's nodes (``--tf-nodes``): the TF is then
#: built from them by ``TransferFunction.from_table`` — the same lookup table, without pyvista.
TF_NODES_ENV = "PV_AMBIENT_SPEED_TF_NODES"


def transfer_function(density=1.0, clim=None):
    """The scene's transfer function, its density scale × ``density`` (and its colour and opacity
    range ``clim`` when given); from the ``--tf-nodes`` table where that is set."""
    nodes = os.environ.get(TF_NODES_ENV)
    if nodes and clim is None:
        d = np.load(nodes)
        return pa.TransferFunction.from_table(d["values"], sigma_t=d["sigma_t"] * density, color=d["color"],
                                              albedo=float(d["albedo"]))
    return scenes.supernova_tf(density, clim)


def write_tf_nodes(path):
    """Write the supernova TF's lookup table as nodes (scalar values, σt, colour, albedo): one node
    per table entry, so ``TransferFunction.from_table`` rebuilds the same table. Resolving the TF
    needs pyvista here, not where the file is read."""
    grid, tf, *_ = scenes.scene(SCENE, 16)
    optics = tf.resolve(grid)
    n = optics.table.shape[0]
    values = optics.lut_lo + np.arange(n) / optics.lut_inv
    np.savez(path, values=values, sigma_t=optics.table[:, COL_SIGMA], color=optics.table[:, COL_COLOR:COL_COLOR + 3],
             albedo=tf.albedo)


def light_at(x, light):
    """``light`` moved to (x, 0, 0)."""
    return pa.PointLight((float(x), 0.0, 0.0), intensity=light.intensity)


# --- what each row times ---------------------------------------------------------------------

class Frames:
    """The frame functions of each kind of row, ``fn(k)`` for frame k, and the VTK camera of each;
    ``options``: further render options of every frame (e.g. ``propagation``)."""

    def __init__(self, n, size, options=None):
        self.grid, _, lights, _, self.cam = scenes.scene(SCENE, n)
        self.light = lights[0]
        self.size, self.options = size, dict(options or {})
        self.renderer = pa.Renderer(self.grid, backend="cpu", transfer_function=transfer_function(), lights=lights)
        self.step = self.renderer.default_step()
        self.moves = 0  # every relight goes to a position never used before (no cached volume)
        self._two = None  # the two-light rows' renderer (:meth:`two_lights`)

    def two_lights(self):
        """The renderer of the two-light rows (the scene's light and a second point light), made once."""
        if self._two is None:
            second = pa.PointLight((0.3, -0.2, 0.1), intensity=2.0)
            self._two = pa.Renderer(self.grid, backend="cpu", transfer_function=transfer_function(),
                                    lights=[self.light, second])
            self._two.cache.share(self.renderer.cache)
        return self._two

    def render(self, renderer, model, camera):
        opts = {"step": self.step, **self.options, **MODEL_OPTIONS.get(model, {})}
        if model in MODEL_OPTIONS:
            opts.pop("step")  # the preset's own step
        return renderer.render(camera=camera, window_size=self.size, model=ROW_MODELS[model], **opts)

    def camera_of(self, kind, k):
        """The camera of frame k of a row: turned 1° per frame for a camera move, else fixed (VTK's
        peer then turns it a little every other frame: it does not render an unchanged view)."""
        return scenes.orbit(self.cam, k) if kind in ("camera", "camera2") else self.cam

    def frame_fn(self, kind, model):
        r = self.renderer
        if kind == "camera":
            return lambda k: self.render(r, model, self.camera_of(kind, k))
        if kind == "camera2":  # the relight2 row's camera pass: both lights baked, every cache warm
            r2 = self.two_lights()
            return lambda k: self.render(r2, model, self.camera_of(kind, k))
        if kind == "relight":
            def relight(k):
                self.moves += 1
                r.set_lights([light_at(0.02 * self.moves, self.light)])
                return self.render(r, model, self.cam)
            return relight
        if kind == "relight2":
            r2 = self.two_lights()
            second = r2.lights[1]

            def relight2(k):  # the first light moves, the second stays: its volumes are reused
                self.moves += 1
                r2.set_lights([light_at(0.02 * self.moves, self.light), second])
                return self.render(r2, model, self.cam)
            return relight2
        if kind == "tf":
            def tf_change(k):
                self.moves += 1
                r2 = pa.Renderer(self.grid, backend="cpu", transfer_function=transfer_function(1.0 + 0.02 * self.moves),
                                 lights=[self.light])
                r2.cache.share(r.cache)  # the preintegrated table slices: the disk cache's role
                return self.render(r2, model, self.cam)
            return tf_change
        if kind == "first":
            def first(k):
                r2 = pa.Renderer(self.grid, backend="cpu", transfer_function=transfer_function(), lights=[self.light])
                r2.cache.share(r.cache)
                return self.render(r2, model, self.cam)
            return first
        raise ValueError(kind)


# --- marched samples --------------------------------------------------------------------------

@numba.njit(parallel=True, cache=True)
def count_samples(view, medium, step, ert, W, H, counts, trans):
    """Per pixel, the segments the ray cast marches in non-empty majorant blocks before early
    termination (``counts``) and the ray's remaining transmittance (``trans``): ``march_pixel``'s
    loop (no jitter, no ray end) with its source terms left out."""
    cam, w2i, lo, hi = view.cam, view.w2i, view.lo, view.hi
    maj, block = medium.maj, medium.block
    for j in numba.prange(H):
        for i in range(W):
            ox, oy, oz, dx, dy, dz = camera_ray(cam, i, j, W, H)
            px, py, pz, qx, qy, qz = index_ray(w2i, ox, oy, oz, dx, dy, dz)
            t0, t1 = ray_box(px, py, pz, qx, qy, qz, lo, hi)
            t0 = max(t0, 0.0)
            n = 0
            T = 1.0
            if t0 < t1:
                t = t0
                tnext = t0 + step
                t_block = -1.0
                while t < t1:
                    te = min(tnext, t1)
                    tm = 0.5 * (t + te)
                    x = px + tm * qx
                    y = py + tm * qy
                    z = pz + tm * qz
                    if tm >= t_block:
                        ba, bb, bc = block_at(x, y, z, maj, block)
                        _, _, _, tex = block_span(px, py, pz, qx, qy, qz, ba, bb, bc, maj, block, tm, t1)
                        if maj[ba, bb, bc] <= 0.0:
                            t = max(tex, te)  # skip the empty block; realign the segment grid after it
                            tnext = t + step
                            continue
                        t_block = tex
                    n += 1
                    sig = medium_sigma(medium.mode, medium, x, y, z)[0]
                    if sig > 0.0:
                        T *= np.exp(-sig * (te - t))
                        if T < ert:
                            break
                    t = te
                    tnext = te + step
            counts[j, i] = n
            trans[j, i] = T


def march_records(renderer, camera, size):
    """The ray cast's View and Medium records of ``camera`` at ``size`` (its own majorant grid: the
    blocks it skips, docs/performance.rst, "Empty space")."""
    return (K.view_of(camera, size, renderer.geometry),
            K.medium_of(renderer.optics, renderer.stages.cast_majorant(), MAJORANT_BLOCK))


def sample_counts(renderer, camera, size, step, ert=ERT):
    """Per-pixel marched samples (H, W) and remaining transmittance of ``camera``'s frame."""
    view, medium = march_records(renderer, camera, size)
    w, h = size
    counts = np.zeros((h, w), np.int64)
    trans = np.zeros((h, w), np.float64)
    count_samples(view, medium, float(step), float(ert), w, h, counts, trans)
    return counts, trans


def brute_force_count(renderer, camera, size, step, ert=ERT):
    """The same count in NumPy, all pixels at once, no block cache: every segment looks its block
    up, an empty block is skipped to its exit; σt by explicit trilinear interpolation and the table
    by ``np.interp`` (perspective cameras only)."""
    view, medium = march_records(renderer, camera, size)
    cam, w2i = view.cam, np.asarray(view.w2i)
    assert cam[14] < 0.5, "perspective camera"
    w, h = size
    jj, ii = np.mgrid[0:h, 0:w].astype(np.float64)
    su = 2.0 * (ii + 0.5) / w - 1.0
    sv = 1.0 - 2.0 * (jj + 0.5) / h
    d = np.stack([cam[3 + a] + su * cam[12] * cam[13] * cam[6 + a] + sv * cam[12] * cam[9 + a] for a in range(3)], -1)
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    p = np.broadcast_to(w2i[:3, :3] @ cam[0:3] + w2i[:3, 3], d.shape)
    q = d @ w2i[:3, :3].T
    with np.errstate(divide="ignore", invalid="ignore"):
        ta = (np.asarray(view.lo) - p) / q
        tb = (np.asarray(view.hi) - p) / q
    t0 = np.maximum(np.nanmax(np.minimum(ta, tb), axis=-1), 0.0)
    t1 = np.nanmin(np.maximum(ta, tb), axis=-1)
    maj, B = medium.maj, medium.block
    m = np.array(maj.shape)
    field = np.asarray(medium.field, np.float64)
    nf = np.array(field.shape)
    table = np.asarray(medium.table)[:, 0].astype(np.float64)

    def sigma(x):
        xc = np.clip(x, 0.0, nf - 1)
        i0 = np.minimum(np.floor(xc).astype(int), nf - 2)
        f = xc - i0
        s = 0.0
        for c in np.ndindex(2, 2, 2):
            wgt = np.prod(np.where(np.array(c), f, 1.0 - f), axis=-1)
            s = s + wgt * field[i0[:, 0] + c[0], i0[:, 1] + c[1], i0[:, 2] + c[2]]
        if medium.mode == MODE_GRID:
            return s
        u = np.clip((s - medium.lut_lo) * medium.lut_inv, 0.0, table.size - 1)
        return np.interp(u, np.arange(table.size), table)

    def block_exit(pp, qq, blk):
        with np.errstate(divide="ignore", invalid="ignore"):
            up = np.where(blk >= m - 1, np.inf, ((blk + 1) * B - pp) / qq)
            down = np.where(blk <= 0, np.inf, (blk * B - pp) / qq)
        return np.min(np.where(qq > 0, up, np.where(qq < 0, down, np.inf)), axis=-1)

    p, q, t0, t1 = p.reshape(-1, 3), q.reshape(-1, 3), t0.ravel(), t1.ravel()
    t, tnext, T = t0.copy(), t0 + step, np.ones(t0.size)
    counts = np.zeros(t0.size, np.int64)
    live = np.nonzero(t0 < t1)[0]
    while live.size:
        te = np.minimum(tnext[live], t1[live])
        tm = 0.5 * (t[live] + te)
        x = p[live] + tm[:, None] * q[live]
        blk = np.clip(np.floor(x / B).astype(int), 0, m - 1)
        empty = maj[blk[:, 0], blk[:, 1], blk[:, 2]] <= 0.0
        tex = np.maximum(np.minimum(block_exit(p[live], q[live], blk), t1[live]), tm)
        counts[live] += ~empty
        T[live] *= np.where(empty, 1.0, np.exp(-sigma(x) * (te - t[live])))
        t[live] = np.where(empty, np.maximum(tex, te), te)
        tnext[live] = t[live] + step
        live = live[(t[live] < t1[live]) & (T[live] >= ert)]
    return counts.reshape(h, w), T.reshape(h, w)


def check_count(n=48, size=(48, 40)):
    """Lines reporting :func:`count_samples` against :func:`brute_force_count` and against the EA
    ray cast's alpha on a small scene: three cameras; the supernova's TF as is, its density ×30 (rays
    then terminate early) and its colour/opacity range starting at 0.15 (empty blocks to skip)."""
    lines = [f"sample-count check (supernova n={n}, {size[0]}x{size[1]}; numba count vs NumPy brute force,"
             f" and the count's 1 − T vs the EA ray cast's alpha):"]
    grid, _, _, _, base = scenes.scene(SCENE, n)
    cases = {"as is": transfer_function(), "density ×30": transfer_function(30.0),
             "clim (0.15, 1)": transfer_function(clim=(0.15, 1.0))}
    for name, tf in cases.items():
        r = pa.Renderer(grid, transfer_function=tf)
        step = r.default_step()
        maj = r.stages.cast_majorant()
        lines.append(f"  TF {name}: {int((maj <= 0).sum())} of {maj.size} of the ray cast's majorant blocks empty")
        for deg in (0.0, 37.0, 101.0):
            cam = scenes.orbit(base, deg)
            c_numba, T_numba = sample_counts(r, cam, size, step)
            c_numpy, _ = brute_force_count(r, cam, size, step)
            alpha = r.render(camera=cam, window_size=size, step=step).alpha
            lines.append(f"    azimuth {deg:5.1f}°: numba {int(c_numba.sum())} samples, NumPy {int(c_numpy.sum())}"
                         f" ({int((c_numba != c_numpy).sum())} pixels differ, max |diff|"
                         f" {int(np.abs(c_numba - c_numpy).max())}); {int((T_numba < ERT).sum())} of {T_numba.size}"
                         f" rays terminated early; max |alpha − (1 − T)|"
                         f" {np.abs(alpha - (1.0 - T_numba)).max():.1e}")
    return lines


# --- the table ----------------------------------------------------------------------------------

def measure_rows(frames, vtk, repeats, kinds=None, models=None, count=True, keep=None):
    """Dicts per row (of ``kinds`` and ``models`` when given, and where ``keep(kind, model)`` when
    given): ours, VTK, samples (camera moves at speed.py's step when ``count``; nan otherwise). Each
    row interleaves ``vtk``'s frames (benchmarks/timing.py) from the row's cameras with ours."""
    out = []
    threads = numba.get_num_threads()
    for name, kind, model, target, stage_target in ROWS:
        if (kinds and kind not in kinds) or (models and model not in models) or (keep and not keep(kind, model)):
            continue
        fn, staged = frames.frame_fn(kind, model), []

        def frame(k, fn=fn, staged=staged):  # the frame, and its stage: the frame less its own camera pass
            t = time.perf_counter()
            res = fn(k)
            if res is not None and "time_render" in res.metadata:
                staged.append(time.perf_counter() - t - res.metadata["time_render"])

        ours, theirs = interleaved(vtk, frame, lambda k: frames.camera_of(kind, k), repeats)
        stage = float(np.median(staged[1:])) if kind not in ("camera", "camera2") and len(staged) > 1 else None
        samples = float("nan")
        if kind == "camera" and count and model not in MODEL_OPTIONS:
            samples = float(np.mean([sample_counts(frames.renderer, frames.camera_of(kind, k), frames.size,
                                                   frames.step)[0].sum() for k in range(1, repeats + 1)]))
        out.append(dict(row=name, kind=kind, model=model, target=target, stage_target=stage_target, ours=ours,
                        vtk=theirs, samples=samples, ns=ours * threads / samples * 1e9, stage=stage))
        print(f"  measured {name}: {ours:.3f} s (VTK {theirs:.3f} s)", flush=True)
    return out


def format_table(rows):
    """The table: per row our frame, VTK's, their ratio; for the other rows also the stage (each
    frame less its own camera pass, ``metadata["time_render"]``: median) in VTK frames and, beside
    it, the frame less the same model's camera-move row of this run (the earlier measure, which
    carries the spread of two medians of frames); each against its target."""
    camera = {(d["model"], d["kind"] == "camera2"): d["ours"] for d in rows if d["kind"] in ("camera", "camera2")}
    head = (f"{'frame':38s} {'ours s':>8} {'VTK s':>8} {'ours/VTK':>9} {'stage/VTK':>9} {'target':>7} {'met':>4}"
            f" {'ns/sample/thread':>17} {'samples (M)':>11} {'less row':>10}")
    lines = [head, "-" * len(head)]
    for d in rows:
        ratio = d["ours"] / d["vtk"]
        ns = f"{d['ns']:.1f}" if np.isfinite(d["ns"]) else ""
        ms = f"{d['samples'] / 1e6:.2f}" if np.isfinite(d["samples"]) else ""
        # the stage less the camera pass of the same model and lights (two lights: the relight2 row)
        cam = camera.get((d["model"], d["kind"] == "relight2"))
        by_row = (d["ours"] - cam) / d["vtk"] if d["kind"] not in ("camera", "camera2") and cam is not None else None
        stage = d["stage"] / d["vtk"] if d.get("stage") is not None else by_row
        value, goal = (ratio, d["target"]) if d["target"] is not None else (stage, d["stage_target"])
        target = "" if goal is None else "≤" + format(goal, "g")
        met = "" if goal is None or value is None else ("yes" if value <= goal else "no")
        stage_s = "" if stage is None else f"{stage:.2f}"
        row_s = "" if by_row is None else f"{by_row:.2f}"
        lines.append(f"{d['row']:38s} {d['ours']:>8.3f} {d['vtk']:>8.3f} {ratio:>9.2f} {stage_s:>9} {target:>7}"
                     f" {met:>4} {ns:>17} {ms:>11} {row_s:>10}")
    return lines


# --- options: thread scaling, memory, drag ---------------------------------------------------------

def child_rows(args, threads):
    """The camera-move and relight rows (ours only) in a subprocess with ``threads`` Numba threads."""
    cmd = [sys.executable, __file__, "--n", str(args.n), "--size", str(args.size), "--repeats", str(args.repeats),
           "--child-rows"]
    env = {**os.environ, "NUMBA_NUM_THREADS": str(threads)}
    proc = subprocess.run(cmd, env=env, capture_output=True, text=True)
    if proc.returncode:
        raise RuntimeError(f"child with {threads} threads failed:\n{proc.stderr[-3000:]}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def threads_scaling(args):
    """Lines of the thread-scaling table: the camera-move and relight rows with each of ``--threads``
    (1 first), speed-up over one thread per column; the 1 → 2 target ≥ 1.8×, 1 → 16 ≥ 12×."""
    counts = sorted({int(t) for t in args.threads.split(",")} | {1})
    runs = {}
    for t in counts:
        runs[t] = child_rows(args, t)
        print(f"  thread scaling: {t} thread(s) done", flush=True)
    lines = [f"thread scaling (ours only, subprocesses with NUMBA_NUM_THREADS = {', '.join(map(str, counts))};"
             f" {os.cpu_count()} cores; targets 1 → 2 ≥ 1.8×, 1 → 16 ≥ 12×):",
             f"  {'frame':38s} {'1 thread s':>10}" + "".join(f" {f'{t} thr s':>9} {'×':>6}" for t in counts[1:])]
    for i, a in enumerate(runs[1]):
        row = f"  {a['row']:38s} {a['ours']:>10.3f}"
        for t in counts[1:]:
            b = runs[t][i]
            row += f" {b['ours']:>9.3f} {a['ours'] / b['ours']:>6.2f}"
        lines.append(row)
        if a.get("stage") is not None:  # the stage: each frame less its own camera pass
            row = f"  {'  its stage':38s} {a['stage']:>10.3f}"
            for t in counts[1:]:
                b = runs[t][i]
                row += f" {b['stage']:>9.3f} {a['stage'] / b['stage']:>6.2f}"
            lines.append(row)
    return lines


def peak_rss():
    """This process's peak resident set in bytes: ``VmHWM`` of ``/proc/self/status`` (which
    :func:`reset_peak_rss` restarts; ``ru_maxrss`` keeps the all-time peak), else ``ru_maxrss``."""
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    import resource

    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024


def reset_peak_rss() -> bool:
    """Restart the peak at the current resident set (Linux ``clear_refs`` 5 resets ``VmHWM``):
    else the grid synthesis' and the warm-up's peaks would hide the renderer's growth."""
    try:
        with open("/proc/self/clear_refs", "w") as f:
            f.write("5")
        return True
    except OSError:
        return False


def memory_child(n, size):
    """Peak RSS growth of rendering AS with two lights at n³ (JSON): the grid is loaded (its synthesis
    has a peak of its own, not the renderer's) and the kernels compiled on a small scene, then the
    peak is restarted, then a Renderer renders its first frame."""
    small, _, (light,), _, cam = scenes.scene(SCENE, 24)
    lights = [light, light_at(0.4, light)]
    grid = scenes.scene(SCENE, n)[0]
    small = pa.Renderer(small, transfer_function=transfer_function(), lights=lights)
    small.render(camera=cam, window_size=(32, 32), model="ambient_scattering")
    reset = reset_peak_rss()
    base = peak_rss()
    r = pa.Renderer(grid, transfer_function=transfer_function(), lights=lights)
    r.render(camera=cam, window_size=size, model="ambient_scattering")
    print(json.dumps(dict(base=base, peak=peak_rss(), volume=n ** 3 * 4, reset=reset)))


def memory(args):
    cmd = [sys.executable, __file__, "--n", str(args.n), "--size", str(args.size), "--child-memory"]
    out = subprocess.run(cmd, capture_output=True, text=True, check=True).stdout
    d = json.loads(out.strip().splitlines()[-1])
    mb = 1024 ** 2
    grow = d["peak"] - d["base"]
    reset = "peak reset there" if d["reset"] else "peak NOT reset: the warm-up's"
    return [f"memory (fresh process, AS with two lights, n={args.n}, {args.size}²; target ≤ 12× the volume):",
            f"  RSS with the grid loaded, after imports and a warm-up compile {d['base'] / mb:.0f} MiB ({reset});"
            f" peak of the first AS frame {d['peak'] / mb:.0f} MiB; growth {grow / mb:.0f} MiB ="
            f" {grow / d['volume']:.1f}× the volume's float32 size ({d['volume'] / mb:.1f} MiB)"]


def drag(frames, steps=36, interactive_step=16):
    """Frames per second over a ``steps``-frame camera drag (1° azimuth per frame, caches warm) in a
    PyVista plotter with ``add_ambient_volume(..., interactive=True, interactive_step=...)`` (drag
    resolution half the window per axis, drag step up to ``interactive_step`` resting steps, 16 the
    default): the render window asks for 15 fps as VTK's interactor does during a drag, so each
    frame is rendered at the drag resolution and the step doubles while frames are slower than
    1/15 s; four drag frames before the clock (the drag-size buffers, and the step found, as it is
    kept from one drag to the next); then the resting frame at full resolution and the resting step."""
    import pyvista as pv

    w, h = frames.size
    lines = [f"camera drag ({steps} frames of 1° in a {w}x{h} plotter, interactive=True: drag frames at"
             f" half resolution per axis, step up to {interactive_step}× while frames are slower than 1/15 s;"
             f" caches warm; target ≥ 15 fps):"]
    for model in MODELS:
        pl = pv.Plotter(off_screen=True, window_size=frames.size)
        frames.cam.to_vtk(pl.camera)
        pl.camera_set = True
        vol = pa.add_ambient_volume(pl, renderer=frames.renderer, model=MODELS[model], interactive=True,
                                    step=frames.step, interactive_step=interactive_step)
        win = pl.ren_win
        win.SetDesiredUpdateRate(15.0)
        for _ in range(4):  # the first drag frames: the drag-size buffers, the drag step found
            pl.camera.Azimuth(1.0)
            win.Render()
        parts = []  # per frame: the whole frame, our update, the renderer's preparation and ray cast
        update = vol.update

        def timed_update(*a, **k):
            t0 = time.perf_counter()
            out = update(*a, **k)
            meta = vol.volume_result.metadata
            parts[-1][1:] = [time.perf_counter() - t0, meta["time_prepare"], meta["time_render"]]
            return out

        vol.update = timed_update  # the observer calls it through the instance
        t = time.perf_counter()
        for _ in range(steps):
            pl.camera.Azimuth(1.0)
            parts.append([time.perf_counter(), 0.0, 0.0, 0.0])
            win.Render()
            parts[-1][0] = time.perf_counter() - parts[-1][0]
        fps = steps / (time.perf_counter() - t)
        del vol.update
        drag_size, factor = vol.result.window_size, vol.step_factor
        frame, ours, prep, cast = np.median(np.array(parts), axis=0) * 1e3
        win.SetDesiredUpdateRate(0.0001)
        t = time.perf_counter()
        win.Render()
        rest = time.perf_counter() - t
        assert vol.result.window_size == frames.size
        lines.append(f"  {model:10s} {fps:6.2f} fps at {drag_size[0]}x{drag_size[1]}, step ×{factor} at the end;"
                     f" resting frame {rest:.3f} s")
        lines.append(f"  {'':10s} median drag frame {frame:.0f} ms: ray cast {cast:.0f}, render preparation {prep:.0f},"
                     f" rest of our update {ours - cast - prep:.0f} (composite, texture), VTK {frame - ours:.0f}")
        pl.close()
    return lines


# --- main --------------------------------------------------------------------------------------------

def packet_line():
    """Which camera-pass driver and load policy ran (pv_ambient._kernels.packet, .cpu_features)."""
    from pv_ambient._kernels import packet
    from pv_ambient._kernels.cpu_features import load_policy

    pol = load_policy()
    if not packet.enabled():
        return "camera pass: the scalar driver everywhere (PV_AMBIENT_PACKETS=0)"
    from pv_ambient.rendering import record

    lit = ("bakes of one slot (grey or rgb) or two rgb slots on the data samples through the lit record"
           " (docs/performance.rst)" if record.enabled()
           else "the lit record off (PV_AMBIENT_RECORD=0)")
    return (f"camera pass: emission-absorption and baked single/ambient scattering and diffusion of a table TF in packets of "
            f"{packet.LANES} rays, loads {pol['loads']}, vectors {pol['width']} ({pol['why']}), {lit}; the others one ray "
            f"at a time")


def command_line():
    return "$ python " + " ".join(sys.argv)


def make_frames(n, size, options=None):
    """The rows' :class:`Frames` on the scene at n³, half-voxel step."""
    return Frames(n, size, options)


def write_result(args, name, lines):
    """Write ``lines`` into ``{--out}/{name}_n{N}.txt``."""
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / f"{name}_n{args.n}.txt").write_text("\n".join(lines) + "\n")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=128, help="volume size n³ (the issue: 128 and 256)")
    ap.add_argument("--size", type=int, default=512, help="image size² (pixels)")
    ap.add_argument("--repeats", type=int, default=5, help="timed frames per row (medians; the issue: ≥ 5)")
    ap.add_argument("--threads-scaling", action="store_true", help="camera-move and relight rows with 1 and 2 threads")
    ap.add_argument("--memory", action="store_true", help="peak RSS growth of a fresh process rendering AS, 2 lights")
    ap.add_argument("--drag", action="store_true", help="frames per second over a 36-frame camera drag")
    ap.add_argument("--models", help="only the rows of these models (comma-separated: EA,SS,AS,diffusion,"
                    "'auto accurate'); with --kinds, into speed_rows_n{N}.txt")
    ap.add_argument("--kinds", help="only the rows of these kinds (comma-separated: camera,relight,relight2,tf,first;"
                    " a stage needs its model's camera row)")
    ap.add_argument("--memory-only", action="store_true",
                    help="only the memory line (no VTK table), into speed_memory_n{N}.txt")
    ap.add_argument("--drag-only", action="store_true",
                    help="only the camera drag (no VTK table), into speed_drag_n{N}.txt (speed_drag_step{S}_n{N}.txt"
                         " with a --drag-step other than 16)")
    ap.add_argument("--drag-step", type=int, default=16,
                    help="the drags' interactive_step: the longest drag step, in resting steps (default 16)")
    ap.add_argument("--out", default=str(Path(__file__).parent / "results"), help="folder of speed_n{N}.txt")
    ap.add_argument("--threads", default="1,2", help="thread counts of --threads-scaling (comma-separated)")
    ap.add_argument("--scaling-only", action="store_true",
                    help="only the thread-scaling table (no VTK needed: runs where pyvista/vtk are not installed)")
    ap.add_argument("--tf-nodes", help="an .npz of the TF's nodes: written here if missing (needs pyvista), "
                    "else read (TransferFunction.from_table) — for --scaling-only where pyvista is missing")
    ap.add_argument("--child-rows", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--child-memory", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    size = (args.size, args.size)
    if args.child_memory:
        return memory_child(args.n, size)
    if args.tf_nodes:
        if not os.path.exists(args.tf_nodes):
            write_tf_nodes(args.tf_nodes)
        os.environ[TF_NODES_ENV] = os.path.abspath(args.tf_nodes)
    if args.memory_only:
        lines = [command_line(), ""] + memory(args)
        print("\n".join(lines))
        return write_result(args, "speed_memory", lines)
    if args.drag_only:
        frames = make_frames(args.n, size)
        for model in MODELS:  # every model's caches warm before the drags
            frames.render(frames.renderer, model, frames.cam)
        lines = [command_line(), "", f"supernova {args.n}³, the rows' scene and renderer;"
                 f" {numba.get_num_threads()} Numba threads", ""] + drag(frames, interactive_step=args.drag_step)
        print("\n".join(lines))
        name = "speed_drag" if args.drag_step == 16 else f"speed_drag_step{args.drag_step}"
        return write_result(args, name, lines)
    if args.scaling_only:
        lines = [command_line(), "", f"supernova {args.n}³, {size[0]}x{size[1]}, the rows' scene;"
                 f" medians of {args.repeats}", ""] + threads_scaling(args)
        print("\n".join(lines))
        return write_result(args, "speed_threads", lines)
    frames = make_frames(args.n, size)
    grid = frames.grid
    if args.child_rows:  # the camera moves and relights, and diffusion's first frame
        rows = measure_rows(frames, None, args.repeats, kinds=("camera", "relight", "first"),
                            keep=lambda kind, model: model != "auto accurate" and (kind != "first" or model == "diffusion"))
        print(json.dumps([{"row": d["row"], "ours": d["ours"], "stage": d["stage"]} for d in rows]))
        return None

    lines = [command_line(), ""] + check_count() + [""]
    print("\n".join(lines), flush=True)
    vtk = VtkPeer(grid, frames.renderer, size, frames.step)
    subset = bool(args.models or args.kinds)
    rows = measure_rows(frames, vtk, args.repeats, kinds=args.kinds.split(",") if args.kinds else None,
                        models=args.models.split(",") if args.models else None)
    vtk.close()
    threads = numba.get_num_threads()
    table = [f"{SCENE} {args.n}³ ({scenes.DESCRIPTIONS[SCENE]}), {size[0]}x{size[1]}, "
             f"step {frames.step:.5f} (half a voxel), early termination {ERT:g}; "
             f"{threads} Numba threads; VTK fixed_point EA interleaved frame by frame; medians of {args.repeats}"
             f" after a warm-up pair", packet_line(), ""]
    table += format_table(rows)
    lines += table
    for flag, fn in ((args.threads_scaling, lambda: threads_scaling(args)), (args.memory, lambda: memory(args)),
                     (args.drag, lambda: drag(frames, interactive_step=args.drag_step))):
        if flag:
            extra = [""] + fn()
            table += extra
            lines += extra
    print("\n".join(table))
    write_result(args, "speed_rows" if subset else "speed", lines)
    return rows


if __name__ == "__main__":
    main()

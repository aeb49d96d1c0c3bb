"""The accuracy benchmarks' common ground: the path-traced references they score against, the
references' block noise, and the log that writes a results file.

* :func:`reference` — the cached reference of one of the nine referenced scenes
  (``scenes.REFERENCED``) at 64×64 pixels and 64³ data points: 4096 samples per pixel or 1 %
  relative standard error, whichever comes first (seed 99). Cached in
  ``benchmarks/results/noise_free_refs/NAME.npz``, keyed by the scene's optics, lights, camera,
  settings and the path tracer's source files; a key that does not match traces it again. Used
  by noise_free.py, progressive.py, drag_frame.py, control_step.py and refine_min.py.
* :func:`trace` — a reference traced now (not cached) at a benchmark's own size and seed
  (trade.py, baked.py, diffusion_sweeps.py), with its light mask and block noise.
* :func:`block_noise` — a reference's standard error averaged over 4×4 blocks, relative to its
  mean: it must stay well below the errors it measures.
* :class:`Log`, :func:`results_log` and :func:`commit` — print, keep and write a results file
  headed by the command and the commit.
"""

from __future__ import annotations

import hashlib
import json
import subprocess
import sys
import time
import warnings
from pathlib import Path

import numpy as np

import pv_ambient as pa
from pv_ambient import metrics

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
RESULTS = HERE / "results"
REFS = RESULTS / "noise_free_refs"
SIZE = (64, 64)
N = 64
REF_SPP, REF_ERROR, REF_SEED = 4096, 0.01, 99

#: The path tracer's sources (pv_ambient.stages.reference and what its kernel imports): part of
#: the cached references' key.
PATH_TRACER_SOURCES = ("stages/reference.py", "_kernels/pathtrace.py", "_kernels/pathtrace_nee.py",
                       "_kernels/pathtrace_near.py", "_kernels/models.py", "_kernels/tracking.py",
                       "_kernels/equiangular.py", "_kernels/majorant.py", "_kernels/phase.py",
                       "_kernels/geometry.py", "_kernels/raycast.py", "_kernels/rng.py", "_kernels/interp.py",
                       "_kernels/medium.py", "_kernels/records.py", "_kernels/_jit.py")


class Log:
    """Print, and keep every line for the results file (rewritten after each line: a run cut short
    still leaves what it measured)."""

    def __init__(self, path, header):
        self.path, self.lines = path, [header]
        print(header, flush=True)

    def __call__(self, line=""):
        print(line, flush=True)
        self.lines.append(line)
        if self.path is not None:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            self.path.write_text("\n".join(self.lines) + "\n")


def add_scene_options(ap, scenes, name):
    """``--scenes`` (any of ``scenes``, all by default) and ``--out`` (the folder of ``NAME.txt``) on
    the argument parser ``ap``; :func:`results_log` reads ``--out``."""
    ap.add_argument("--scenes", nargs="+", default=list(scenes), choices=list(scenes))
    ap.add_argument("--out", default=None, help=f"directory of {name}.txt (default benchmarks/results)")


def results_log(name, out=None, argv=None):
    """The :class:`Log` of ``benchmarks/NAME.py``: written to ``NAME.txt`` in ``out`` (default
    benchmarks/results), headed by the command (``argv``: its arguments; ``sys.argv``'s when None)."""
    args = sys.argv[1:] if argv is None else list(argv)
    return Log((Path(out) if out else RESULTS) / f"{name}.txt", " ".join(["python", f"benchmarks/{name}.py", *args]))


def commit():
    """The checkout's short commit hash (``?`` without git)."""
    try:
        return subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True, text=True,
                              check=True).stdout.strip()
    except Exception:  # noqa: BLE001 (no git: the key still identifies the reference)
        return "?"


def block_noise(radiance, std_error, mask):
    """The reference's standard error averaged over 4×4 blocks, relative to its mean (over ``mask``)."""
    return float(np.sqrt(np.mean(std_error[mask] ** 2) / 16) / np.mean(radiance[mask]))


def trace(r, cam, size, g, lights, *, seed, spp, target_error):
    """A ``path_traced`` reference traced now: (result, light mask, block noise, seconds)."""
    t = time.perf_counter()
    ref = r.render(camera=cam, window_size=size, model="path_traced", phase=g, seed=seed, samples_per_pixel=spp,
                   target_error=target_error)
    t = time.perf_counter() - t
    mask = metrics.light_mask(size[::-1], cam, size, lights)
    return ref, mask, block_noise(ref.radiance, ref.std_error, mask), t


def ref_key(name, renderer, lights, g, cam, size, spp):
    """Hash of what a reference depends on: the optics (data and TF), lights, phase, camera, the
    reference's settings and the path tracer's sources."""
    h = hashlib.sha256()
    h.update(repr((name, renderer.optics.key, [lt.to_dict() for lt in lights], float(g), cam.to_dict(), size,
                   tuple(renderer.geometry.spacing), tuple(renderer.bounds),
                   spp, REF_ERROR, REF_SEED)).encode())
    pkg = Path(pa.__file__).resolve().parent
    for rel in PATH_TRACER_SOURCES:
        h.update((pkg / rel).read_bytes())
    return h.hexdigest()[:20]


def reference(name, r, lights, g, cam, mask, recompute, size=SIZE, spp=REF_SPP, cache=True):
    """The scene's reference radiance and its figures: cached (``cache``), or traced now."""
    key = ref_key(name, r, lights, g, cam, size, spp)
    path = REFS / f"{name}.npz"
    if not cache:
        why = "traced, not cached"
    elif path.exists() and not recompute:
        with np.load(path) as z:
            info = json.loads(str(z["info"]))
            if info.get("key") == key:
                return z["radiance"].astype(np.float32), info, "cached"
            why = "stale cache: recomputed"
    else:
        why = "recomputed" if path.exists() else "traced"
    t = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # "target_error was not reached": the relative error is printed
        ref = r.render(camera=cam, window_size=size, model="path_traced", phase=g, seed=REF_SEED,
                       samples_per_pixel=spp, target_error=REF_ERROR, progress_bar=False)
    elapsed = time.perf_counter() - t
    info = dict(key=key, spp=int(ref.metadata["spp"]), time=elapsed,
                relative_error=float(ref.metadata["relative_error"]),
                block_noise=block_noise(ref.radiance, ref.std_error, mask), commit=commit())
    if cache:
        REFS.mkdir(parents=True, exist_ok=True)
        np.savez_compressed(path, radiance=ref.radiance.astype(np.float32), info=json.dumps(info))
    return ref.radiance, info, why

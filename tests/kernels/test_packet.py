"""The CPU camera pass in ray packets (pv_ambient._kernels.packet): the same image as the per-pixel
march (the scalar fallback) on every path through the march, the step-corrected table against the
analytic transmittance, SIMD in the compiled driver, and the load policy."""

import os
import re
import subprocess
import sys

import numpy as np
import pytest
import pyvista as pv

import pv_ambient as pa
from pv_ambient._kernels import cpu_features, packet
from pv_ambient._kernels.medium import step_sample, step_table
from pv_ambient._kernels.models import DIFFUSION
from pv_ambient.inputs.camera import Camera

#: Packet vs per-pixel march: the same float32 sample and float64 sums; only the rounding of a
#: sample position (a fused multiply-add in one, not the other) differs, a few float32 ulps.
PACKET_TOL = 1e-6


def blob(dims=(21, 18, 15)):
    """A smooth scalar blob on a non-cubic grid (an odd number of samples per axis)."""
    g = pv.ImageData(dimensions=dims, spacing=(0.1, 0.11, 0.13), origin=(-1.0, -0.9, -0.85))
    p = g.points
    g["d"] = np.exp(-2.0 * (p[:, 0] ** 2 + 1.5 * p[:, 1] ** 2 + 2.0 * (p[:, 2] - 0.1) ** 2)).astype(np.float32)
    return g


CAM = Camera((0.4, -3.5, 0.8), (0.0, 0.05, 0.0), (0, 0, 1), view_angle=38)


def both(r, monkeypatch, model="emission_absorption", **kw):
    """(packet image, per-pixel image) of ``r``'s emission–absorption frame, and how many rows the
    packet driver rendered."""
    calls = []
    models = []
    real = packet.raycast_packets

    def counting(*a):
        calls.append(a[9] - a[8])  # row1 - row0
        models.append(a[0])
        return real(*a)

    monkeypatch.setattr(packet, "raycast_packets", counting)
    kw.setdefault("window_size", (37, 23))  # partial packets and tiles at the right and bottom
    out = []
    for flag in ("1", "0"):
        monkeypatch.setenv("PV_AMBIENT_PACKETS", flag)
        res = r.render(camera=CAM, model=model, progress_bar=False, **kw)
        out.append((np.asarray(res.radiance, np.float64), np.asarray(res.alpha, np.float64)))
    both.models = models  # the kernel models that ran in packets
    return out[0], out[1], sum(calls)


@pytest.mark.parametrize("case", ["plain", "jitter", "empty_blocks", "early_termination", "rows", "opaque_depth"])
def test_packets_equal_the_per_pixel_march(case, monkeypatch):
    tf = dict(cmap="viridis", clim=(0.0, 1.0), opacity="linear", opacity_unit_distance=0.3)
    kw = {}
    if case == "jitter":
        kw = dict(jitter=True, seed=7)
    elif case == "empty_blocks":
        tf["clim"] = (0.5, 1.0)  # most majorant blocks of the blob's tails are empty: skips and realigned grids
    elif case == "early_termination":
        tf["opacity_unit_distance"] = 0.003  # rays stop inside the blob
    r = pa.Renderer(blob(), transfer_function=pa.TransferFunction(**tf))
    if case == "rows":  # an image rendered in row bands (progress bars): bands not multiples of a packet
        kw = dict(window_size=(29, 41))
        from pv_ambient import backend

        real = backend.run_raycast

        def banded(args, rad, alpha, **k):
            from pv_ambient._kernels.packet import raycast_image

            for r0, r1 in ((0, 3), (3, 17), (17, 41)):
                raycast_image(*args, r0, r1, rad, alpha)
            return "cpu"

        monkeypatch.setattr(backend, "run_raycast", banded)
    if case == "opaque_depth":  # rays ending at opaque geometry: a per-pixel ray end
        end = np.full((23, 37), np.inf)
        end[5:15, 10:30] = np.linspace(2.8, 4.0, 200).reshape(10, 20)
        kw = dict(ray_end=end)
    (pa_rad, pa_alpha), (px_rad, px_alpha), rows = both(r, monkeypatch, **kw)
    assert rows > 0  # the packet driver ran
    assert px_alpha.max() > 0.2
    if case == "early_termination":
        assert px_alpha.max() > 1 - 1e-4
    assert np.abs(pa_rad - px_rad).max() <= PACKET_TOL
    assert np.abs(pa_alpha - px_alpha).max() <= PACKET_TOL


@pytest.mark.parametrize("model, rgb", [("single_scattering", False), ("single_scattering", True),
                                        ("ambient_scattering", True), ("diffusion", False), ("diffusion", True)])
def test_lit_packets_equal_the_per_pixel_march(model, rgb, monkeypatch):
    """Baked in-scattering (isotropic phase): a point light inside the blob (its 1/d² at the sample)
    and a directional light; grey slots (white lights, grey albedo) or rgb slots. Diffusion's field,
    on the data samples, is read beside the bake on a light grid finer than the data's."""
    tf = pa.TransferFunction(cmap="viridis", clim=(0.1, 1.0), opacity="linear", opacity_unit_distance=0.05,
                             albedo=0.8)
    power = (3.0, 2.0, 1.0) if rgb else 2.0
    lights = [pa.PointLight((0.1, -0.05, 0.1), intensity=power), pa.DirectionalLight((0.3, 0.5, -1.0), irradiance=0.7)]
    r = pa.Renderer(blob(), transfer_function=tf, lights=lights)
    extra = {"light_resolution": 2.0} if model == "diffusion" else {}  # a light grid finer than the data's
    (a, aa), (b, ba), rows = both(r, monkeypatch, model=model, quality="preview", jitter=True, **extra)
    assert rows > 0 and b.mean() > 1e-3
    if model == "diffusion":
        assert both.models and set(both.models) == {DIFFUSION}  # its own driver, not single scattering's
    assert np.abs(a - b).max() <= PACKET_TOL * max(1.0, b.max()) and np.abs(aa - ba).max() <= PACKET_TOL


def test_run_end_is_where_the_ray_first_meets_an_empty_block():
    """``majorant.run_end`` (where the packet driver next looks a block up) against an independent
    count: the ray sampled every 1e-4 of its length in NumPy, the first sample in an empty block of a
    random majorant grid (a third of the blocks empty); equal within that spacing, or the ray's end."""
    from pv_ambient._kernels.majorant import block_at, run_end
    from pv_ambient._kernels.packet import distances

    rng = np.random.default_rng(7)
    block = 4
    maj = np.where(rng.random((5, 4, 6)) < 1 / 3, 0.0, 1.0).astype(np.float32)
    dist = distances(maj)
    hi = np.array(maj.shape) * block
    checked = 0
    for _ in range(200):
        p = rng.uniform(0, hi)
        q = rng.normal(size=3)
        q /= np.linalg.norm(q)
        a, b, c = block_at(p[0], p[1], p[2], maj, block)
        if maj[a, b, c] <= 0.0:
            continue
        t1 = 30.0
        got = run_end(p[0], p[1], p[2], q[0], q[1], q[2], a, b, c, 0.0, t1, maj, dist, block)
        ts = np.arange(0.0, t1, 1e-4)
        pts = p[None, :] + ts[:, None] * q[None, :]
        idx = np.clip(np.floor(pts / block).astype(int), 0, np.array(maj.shape) - 1)
        empty = maj[idx[:, 0], idx[:, 1], idx[:, 2]] <= 0.0
        want = ts[np.argmax(empty)] if empty.any() else t1
        assert abs(got - want) <= 1.1e-4, (p, q, got, want)
        checked += 1
    assert checked > 100


def test_run_end_equals_the_block_walk():
    """``run_end`` crosses a cube of non-empty blocks in one step and otherwise one block at a time:
    the boundary it returns is the block walk's (``walk_step``, every block's exits) on random rays
    through grids with few and with no empty blocks, rays parallel to a face and rays starting on
    one — to 4 ulp, not the bit: compiled in a loop, a division by the ray's direction may become a
    product with its reciprocal taken once (the fastmath set's ``arcp``), in either function."""
    from pv_ambient._kernels.majorant import block_at, run_end, walk_step
    from pv_ambient._kernels.packet import distances

    def walked(px, py, pz, qx, qy, qz, a, b, c, t, t1, maj, block):
        walk = (a, b, c, t)
        while True:
            walk, ta, tb, _ = walk_step(walk, px, py, pz, qx, qy, qz, t1, maj, block)
            if tb >= t1 or tb <= ta or maj[walk[0], walk[1], walk[2]] <= 0.0:
                return tb

    rng = np.random.default_rng(11)
    block = 8
    grids = [np.where(rng.random((9, 8, 10)) < p, 0.0, 1.0).astype(np.float32) for p in (0.02, 0.15)]
    grids.append(np.ones((6, 5, 7), np.float32))
    checked = 0
    for k in range(1200):
        maj = grids[k % 3]
        dist = distances(maj)
        hi = np.array(maj.shape) * block
        p = rng.uniform(0, hi)
        if k % 4 == 0:
            p[k % 3] = block * rng.integers(0, 4)  # on a block face
        q = rng.normal(size=3)
        if k % 5 == 0:
            q[(k // 5) % 3] = 0.0  # parallel to a face
        q /= np.linalg.norm(q)
        a, b, c = block_at(p[0], p[1], p[2], maj, block)
        if maj[a, b, c] <= 0.0:
            continue
        args = (p[0], p[1], p[2], q[0], q[1], q[2], a, b, c, 0.0, 80.0, maj)
        want = walked(*args, block)
        got = run_end(*args, dist, block)
        if want <= 0.0:
            # a ray leaving a face it starts on: the walk stops at once (a lookup follows at the next
            # step); any boundary up to the run's end is right, so no more than a dense sampling's
            ts = np.arange(0.0, 80.0, 1e-3)
            idx = np.clip(np.floor((p[None, :] + ts[:, None] * q[None, :]) / block).astype(int), 0,
                          np.array(maj.shape) - 1)
            empty = maj[idx[:, 0], idx[:, 1], idx[:, 2]] <= 0.0
            assert 0.0 <= got <= (ts[np.argmax(empty)] if empty.any() else 80.0) + 1e-3, (k % 3, p, q)
        else:
            assert abs(got - want) <= 4 * np.spacing(want), (k % 3, p, q)
        checked += 1
    assert checked > 900


def test_empty_distance_is_the_chebyshev_distance():
    """``empty_distance``: each block's Chebyshev distance (in blocks) to the nearest empty block, by
    brute force over every pair; ``NO_EMPTY`` in a grid without one."""
    from pv_ambient._kernels.majorant import NO_EMPTY, empty_distance

    rng = np.random.default_rng(5)
    for shape, p in (((7, 5, 9), 0.05), ((4, 11, 3), 0.3), ((1, 6, 2), 0.2)):
        maj = np.where(rng.random(shape) < p, 0.0, 2.0).astype(np.float32)
        maj.flat[rng.integers(maj.size)] = 0.0
        got = empty_distance(maj)
        idx = np.indices(shape).reshape(3, -1).T
        empties = idx[maj.ravel() <= 0.0]
        want = np.abs(idx[:, None, :] - empties[None, :, :]).max(axis=2).min(axis=1).reshape(shape)
        assert np.array_equal(got, want), shape
    assert np.all(empty_distance(np.ones((3, 4, 5), np.float32)) == NO_EMPTY)



def test_tiny_grids(monkeypatch):
    """Axes of two samples render as the per-pixel march does; an axis of one sample (the kernels'
    placeholders) reads that sample twice, never past the array."""
    for dims in ((2, 2, 7), (2, 3, 2)):
        g = pv.ImageData(dimensions=dims, spacing=(0.3, 0.3, 0.3), origin=(-0.3, -0.3, -0.3))
        g["d"] = np.linspace(0.2, 1.0, g.n_points).astype(np.float32)
        r = pa.Renderer(g, transfer_function=pa.TransferFunction(clim=(0, 1), opacity_unit_distance=0.05))
        (a, aa), (b, ba), _ = both(r, monkeypatch, window_size=(9, 7))
        assert np.isfinite(a).all() and np.abs(a - b).max() <= PACKET_TOL and np.abs(aa - ba).max() <= PACKET_TOL
    field = np.array([[[0.25, 0.5], [0.75, 1.0], [0.0, 0.5]]], np.float32)  # (1, 3, 2)
    stab = np.zeros((5, 4), np.float32)
    stab[:, 0] = np.linspace(0.0, 1.0, 5)
    stab[:, 1] = 2.0
    for x, y, z, want in ((0.0, 0.5, 0.5, 0.625), (3.0, 1.0, 1.0, 1.0), (-1.0, 2.0, 0.0, 0.0), (0.0, 1.5, 0.25, 0.46875)):
        a, cr, _, _ = step_sample(field, stab, 0.0, 4.0, x, y, z)  # lut: s·4 entries, opacity = s
        assert a == pytest.approx(want, abs=1e-6) and cr == 2.0


def test_step_corrected_table_is_exact_for_a_constant_medium():
    """σt constant along a ray: every full step's table opacity is 1 − e^{−σ·step} and the last,
    partial, segment takes exp: alpha is 1 − e^{−σL} (L the chord), to float32 rounding."""
    g = pv.ImageData(dimensions=(12, 12, 12), spacing=(0.2,) * 3, origin=(-1.1,) * 3)
    g["d"] = np.full(g.n_points, 0.6, np.float32)
    tf = pa.TransferFunction(clim=(0, 1), opacity="linear", opacity_unit_distance=1.0)
    r = pa.Renderer(g, transfer_function=tf)
    cam = Camera((0.0, -5.0, 0.0), (0.0, 0.0, 0.0), (0, 0, 1), parallel_projection=True, parallel_scale=0.5)
    res = r.render(camera=cam, window_size=(8, 8), model="emission_absorption", step=0.0123, progress_bar=False)
    sigma = float(r.optics.table[:, 0][int(round((0.6 - r.optics.lut_lo) * r.optics.lut_inv))])
    L = 2.2  # the box's chord along y
    assert np.abs(np.asarray(res.alpha, np.float64) - (1.0 - np.exp(-sigma * L))).max() <= 2e-6


def test_step_table_columns():
    table = np.zeros((4, 10), np.float32)
    table[:, 0] = [0.0, 1.0, 10.0, 1e4]
    table[:, 1:10] = np.arange(36).reshape(4, 9)
    t = step_table(table, 0.05)
    assert t.dtype == np.float32 and t.shape == (4, 11)
    assert np.allclose(t[:, 0], 1.0 - np.exp(-table[:, 0].astype(np.float64) * 0.05), rtol=1e-6)
    assert t[0, 0] == 0.0 and t[3, 0] == 1.0  # no underflow or NaN at extreme extinction
    assert np.array_equal(t[:, 1:4], table[:, 7:10])  # colour
    assert np.array_equal(t[:, 4:10], table[:, 1:7])  # albedo, emission
    assert np.array_equal(t[:, 10], table[:, 0])  # σt, for a partial step


_ASM_SCRIPT = r"""
import sys
import pv_ambient as pa  # first: its vector policy is set before Numba is imported
import numba
import numpy as np
import pyvista as pv
from pv_ambient._kernels import packet
from pv_ambient._kernels.cpu_features import load_policy
g = pv.ImageData(dimensions=(6, 6, 6), spacing=(0.2,) * 3, origin=(-0.5,) * 3)
g["d"] = np.linspace(0, 1, g.n_points).astype(np.float32)
r = pa.Renderer(g, transfer_function=pa.TransferFunction(clim=(0, 1)))
seen = []
real = packet.raycast_packets
packet.raycast_packets = lambda *a: seen.append(a) or real(*a)
r.render(camera=pa.Camera((0, -3, 0), (0, 0, 0), (0, 0, 1)), window_size=(8, 8), progress_bar=False)
# diffusion's driver compiled for the same argument types (no solve: only its code is looked at)
args = seen[0][1:] + packet.scratch() + (packet.distances(seen[0][3].maj),)
packet.PACKET_DRIVERS[4].compile(tuple(numba.typeof(a) for a in args))
print("POLICY", load_policy()["loads"])
print("WIDTH", load_policy()["width"].replace(" ", "_"))
import llvmlite.binding as ll
print("AVX2", int(bool(ll.get_host_cpu_features().get("avx2", False))))
for model in (0, 4):  # emission-absorption, diffusion (the lit lane loops and the field's)
    drv = packet.PACKET_DRIVERS[model]
    asm = drv.inspect_asm(drv.signatures[0])
    print(f"PACKED_FMA{model}", len(re.findall(r"vfmadd\w*ps\s+[^\n]*%[xyz]mm", asm)))
    print(f"NARROW_FMA{model}", len(re.findall(r"vfmadd\w*ps\s+[^\n]*%xmm", asm)))
    print(f"GATHERS{model}", len(re.findall(r"vgather\w+", asm)))
    print(f"ZMM_FMA{model}", len(re.findall(r"vfmadd\w*ps\s+[^\n]*%zmm", asm)))
"""


def test_packet_driver_is_vectorised(tmp_path):
    """Compiled outside the disk cache, the packet drivers' assembly (emission–absorption's, and
    diffusion's, which holds the lit lane loops and the field's) has packed float32 FMAs (the lane
    loops vectorised), on a CPU with AVX2 none of them 128-bit: the loops with float32 arithmetic touch
    no float64 field, which would make LLVM run them 4 lanes per instruction (docs/performance.rst,
    "CPU camera pass"); with the lane-by-lane load policy, no hardware gathers; with the 512-bit
    policy, 512-bit FMAs."""
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"), PV_AMBIENT_PACKETS="1")
    env.pop("NUMBA_CPU_FEATURES", None)
    proc = subprocess.run([sys.executable, "-c", "import re\n" + _ASM_SCRIPT], env=env, capture_output=True,
                          text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    found = dict(line.split(" ", 1) for line in proc.stdout.splitlines() if line.split(" ")[0] in
                 ("POLICY", "WIDTH", "ZMM_FMA0", "ZMM_FMA4", "AVX2", "PACKED_FMA0", "GATHERS0", "PACKED_FMA4", "GATHERS4", "NARROW_FMA0", "NARROW_FMA4"))
    wide = found["AVX2"] == "1"
    for model in (0, 4):
        assert int(found[f"PACKED_FMA{model}"]) >= 4, found
        if wide:
            assert int(found[f"NARROW_FMA{model}"]) == 0, found
        if found["POLICY"] == "lane by lane":
            assert int(found[f"GATHERS{model}"]) == 0, found
        if found["WIDTH"] == "512_bits":
            assert int(found[f"ZMM_FMA{model}"]) >= 4, found


def test_load_policy(monkeypatch):
    """The policy is chosen once, before Numba is imported: 512-bit vectors on the Intel CPUs of
    ``WIDE_CPUS`` unless ``PV_AMBIENT_WIDE_VECTORS=0``, lane-by-lane loads only when asked; a user's
    NUMBA_CPU_FEATURES wins; nothing once Numba has been imported."""
    import llvmlite.binding as ll

    pol = cpu_features.load_policy()
    assert pol["loads"] in ("lane by lane", "Numba's choice") and pol["why"]
    assert pol["width"] in ("512 bits", "Numba's choice")
    if os.environ.get("PV_AMBIENT_LANE_LOADS") != "1":
        assert pol["loads"] == "Numba's choice"
    set_here = "set with" in pol["why"]
    if set_here:  # the process this test runs in: its features as the policy set them
        assert (pol["width"] == "512 bits") == (ll.get_host_cpu_name() in cpu_features.WIDE_CPUS)
        assert ("-prefer-256-bit" in os.environ["NUMBA_CPU_FEATURES"]) == (pol["width"] == "512 bits")
    monkeypatch.setattr(cpu_features, "_POLICY", {"loads": None, "width": None, "why": ""})
    monkeypatch.setenv("NUMBA_CPU_FEATURES", "+avx2,+fma")
    assert cpu_features.apply_load_policy() == {"loads": "Numba's choice", "width": "Numba's choice",
                                                "why": "NUMBA_CPU_FEATURES/NUMBA_CPU_NAME set by the user"}
    monkeypatch.setattr(cpu_features, "_POLICY", {"loads": None, "width": None, "why": ""})
    monkeypatch.setenv("NUMBA_CPU_FEATURES", "+avx512f,-prefer-256-bit")
    assert cpu_features.apply_load_policy()["width"] == "512 bits"
    monkeypatch.setattr(cpu_features, "_POLICY", {"loads": None, "width": None, "why": ""})
    monkeypatch.delenv("NUMBA_CPU_FEATURES")
    monkeypatch.delenv("NUMBA_CPU_NAME", raising=False)
    monkeypatch.setenv("PV_AMBIENT_WIDE_VECTORS", "0")
    assert cpu_features.apply_load_policy()["why"] == "PV_AMBIENT_WIDE_VECTORS=0"
    monkeypatch.setattr(cpu_features, "_POLICY", {"loads": None, "width": None, "why": ""})
    monkeypatch.setenv("PV_AMBIENT_LANE_LOADS", "1")
    assert cpu_features.apply_load_policy()["why"] == "numba was imported before pv_ambient"
    assert "NUMBA_CPU_FEATURES" not in os.environ


_WIDTH_SCRIPT = r"""
import os
os.environ.pop("NUMBA_CPU_FEATURES", None)
import pv_ambient
import llvmlite.binding as ll
from pv_ambient._kernels.cpu_features import load_policy
print("NAME", ll.get_host_cpu_name())
print("WIDTH", load_policy()["width"])
print("FEATS", os.environ.get("NUMBA_CPU_FEATURES", ""))
"""


def test_wide_vectors_in_a_fresh_process():
    """A fresh process that imports pv_ambient before Numba: on a CPU of ``WIDE_CPUS`` Numba's features
    are the host's with ``-prefer-256-bit``; elsewhere, or with ``PV_AMBIENT_WIDE_VECTORS=0``, they
    are left to Numba."""
    for opt_out in ("1", "0"):
        env = dict(os.environ, PV_AMBIENT_WIDE_VECTORS=opt_out)
        env.pop("NUMBA_CPU_FEATURES", None)
        env.pop("PV_AMBIENT_LANE_LOADS", None)
        proc = subprocess.run([sys.executable, "-c", _WIDTH_SCRIPT], env=env, capture_output=True, text=True,
                              timeout=300)
        assert proc.returncode == 0, proc.stderr[-3000:]
        found = dict((line.split(" ", 1) + [""])[:2] for line in proc.stdout.splitlines())
        wide = found["NAME"] in cpu_features.WIDE_CPUS and opt_out == "1"
        assert found["WIDTH"] == ("512 bits" if wide else "Numba's choice"), found
        assert ("-prefer-256-bit" in found["FEATS"]) == wide, found

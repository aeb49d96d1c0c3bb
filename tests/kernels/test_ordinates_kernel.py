"""The transport sweep's kernel (pv_ambient._kernels.ordinates): its vectorised row loops against a
plain node-by-node sweep written here, its exp against math.exp, and that the loops vectorise."""

from __future__ import annotations

import math
import os
import re
import subprocess
import sys

import numpy as np
import pytest

from pv_ambient._kernels import ordinates as K
from pv_ambient._kernels.expneg import exp_neg
from pv_ambient.stages.diffusion.ordinates import fibonacci_directions, sweep_once


def _reference_sweep(sig, q, omega, kind, g, spacing, R, half, M):
    """sweep_once node by node, one direction at a time, in Python (docs/diffusion.rst §5): the
    characteristic back one plane, bilinear values there, the exact linear-source segment."""
    seg_w = K.segment_weights.py_func
    lateral = K.lateral.py_func
    entry = K.entry_fraction.py_func
    phase = K.first_scatter_phase.py_func
    shape = sig.shape
    C = q.shape[3]
    wm = np.linalg.norm(omega, axis=-1)
    wu = omega / np.where(wm > 0, wm, 1.0)[..., None]
    wm = np.minimum(wm, 1.0)
    dirs = fibonacci_directions(M)
    u_all = (dirs @ R) / np.asarray(spacing)
    active = np.asarray(shape) > 1
    phi = np.zeros(shape + (C,))
    F = np.zeros(shape + (C, 3))
    for om, u in zip(dirs, u_all):
        a = int(np.argmax(np.abs(u) * active))
        s = 1 if u[a] > 0 else -1
        lat = [x for x in range(3) if x != a]
        ell = 1.0 / abs(u[a])
        d = [-u[x] * ell for x in lat]
        prevL = prevS = prevsig = None
        for step in range(shape[a]):
            k = step if s > 0 else shape[a] - 1 - step
            sl = [slice(None)] * 3
            sl[a] = k
            sp = sig[tuple(sl)]
            qq = q[tuple(sl)]
            uu = wu[tuple(sl)]
            mm = wm[tuple(sl)]
            n1, n2 = sp.shape
            L = np.zeros((n1, n2, C))
            S = np.zeros((n1, n2, C))
            for i in range(n1):
                for j in range(n2):
                    p = phase(kind, g, uu[i, j, 0], uu[i, j, 1], uu[i, j, 2], mm[i, j], *om)
                    S[i, j] = qq[i, j] * p
                    frac = 1.0 if step == 0 else min(entry(i, d[0], n1, half), entry(j, d[1], n2, half))
                    if step > 0 and frac >= 1.0:
                        b0, b1, fb = lateral(i + d[0], n1)
                        c0, c1, fc = lateral(j + d[1], n2)
                        wts = [((b0, c0), (1 - fb) * (1 - fc)), ((b1, c0), fb * (1 - fc)), ((b0, c1), (1 - fb) * fc),
                               ((b1, c1), fb * fc)]
                        s_in = sum(w * prevsig[ij] for ij, w in wts)
                        l_in = sum(w * prevL[ij] for ij, w in wts)
                        src_in = sum(w * prevS[ij] for ij, w in wts)
                        wi, wn, e = seg_w(0.5 * (s_in + sp[i, j]) * ell)
                        L[i, j] = l_in * e + ell * (wi * src_in + wn * S[i, j])
                    else:
                        seg = ell * (half if step == 0 else frac)
                        wi, wn, _ = seg_w(sp[i, j] * seg)
                        L[i, j] = seg * (wi + wn) * S[i, j]
            w = 4.0 * math.pi / M
            idx = [slice(None)] * 3
            idx[a] = k
            phi[tuple(idx)] += w * L
            F[tuple(idx)] += w * L[..., None] * om
            prevL, prevS, prevsig = L, S, sp
    return phi, F


@pytest.mark.parametrize("shape, association, kind, g, C, rotated", [
    ((7, 6, 8), "point", 0, 0.0, 3, False),   # isotropic: the source interpolated from q, no per-direction buffer
    ((7, 6, 8), "cell", 1, 0.6, 3, True),     # Henyey–Greenstein, rotated axes, cell data
    ((6, 1, 9), "point", 1, -0.5, 1, False),  # a uniform axis (one node)
    ((5, 9, 6), "cell", 2, 0.3, 1, True),
])
def test_row_loops_equal_a_node_by_node_sweep(shape, association, kind, g, C, rotated):
    """The kernel (fixed-stencil interior loops + the general path at the edges) equals a plain
    sweep node by node within 1e-12 relative (their exp and weights differ in the last bits)."""
    rng = np.random.default_rng(7)
    sig = rng.exponential(1.5, shape) * (rng.random(shape) < 0.8)
    sig.flat[0] = 400.0  # an optically thick node: e^{−τ} ~ 0
    q = rng.random(shape + (C,))
    om = rng.normal(size=shape + (3,))
    om *= (rng.random(shape) / np.linalg.norm(om, axis=-1))[..., None]
    R = np.linalg.qr(rng.normal(size=(3, 3)))[0] if rotated else np.eye(3)
    spacing = (0.7, 1.1, 0.9)
    half = 0.0 if association == "point" else 0.5
    phi, F = sweep_once(sig, q, om, kind, g, spacing, association=association, direction=R, directions=12)
    ref_phi, ref_F = _reference_sweep(sig, q, om, kind, g, spacing, R, half, 12)
    assert np.max(np.abs(phi - ref_phi)) <= 1e-12 * np.max(ref_phi)
    assert np.max(np.abs(F - ref_F)) <= 1e-6 * np.max(np.abs(ref_F))  # F is returned as float32
    # without the flux (flux=False: the fluence's loops alone) the same fluence, and no F
    phi0, F0 = sweep_once(sig, q, om, kind, g, spacing, association=association, direction=R, directions=12,
                          flux=False)
    assert F0 is None
    assert np.max(np.abs(phi0 - ref_phi)) <= 1e-12 * np.max(ref_phi)


def test_exp_neg_matches_math_exp():
    """exp_neg: ≤ 1e-13 relative to math.exp on [0, 700], exact at 0, 0 beyond e^{−708} and at inf."""
    taus = np.concatenate([np.linspace(0.0, 700.0, 20001), np.geomspace(1e-12, 50.0, 2001)])
    got = np.array([exp_neg(t) for t in taus])
    want = np.exp(-taus)
    assert np.max(np.abs(got - want) / want) <= 1e-13
    assert exp_neg(0.0) == 1.0
    assert exp_neg(709.0) == 0.0 and exp_neg(math.inf) == 0.0


_ASM = r"""
import re
import numpy as np
from pv_ambient._kernels import ordinates as K
from pv_ambient.stages.diffusion.ordinates import sweep_once
n = 6
sweep_once(np.ones((n, n, n)), np.ones((n, n, n, 3)), np.zeros((n, n, n, 3)), 0, 0.0, (1, 1, 1), directions=8)
asm = K.sweep_group.inspect_asm(K.sweep_group.signatures[0])
print("PACKED_FMA", len(re.findall(r"vfmadd\w*pd\s+%[xyz]mm", asm)))
"""


def test_sweep_row_loops_are_vectorised(tmp_path):
    """Compiled outside the disk cache, the sweep's assembly has packed float64 FMAs: its row loops
    vectorised (they silently stay scalar if an array stream aliases another or exp is a call)."""
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"))
    proc = subprocess.run([sys.executable, "-c", _ASM], env=env, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    found = int(re.search(r"PACKED_FMA (\d+)", proc.stdout).group(1))
    assert found >= 8, proc.stdout


@pytest.mark.parametrize("shape", [(5, 4, 37, 3), (3, 6, 16, 1), (2, 1, 1, 9)])
def test_last_axis_first_is_numpy_transpose(shape):
    """The sweeps along the grid's last axis run on a copy with that axis first: the parallel,
    tiled copy (planes across tile boundaries, one channel, a single plane) equals NumPy's
    transpose, and the way back restores the array to the bit."""
    a = np.random.default_rng(5).random(shape)
    t = np.empty((shape[2], shape[0], shape[1], shape[3]))
    K.last_axis_first(a, t)
    assert np.array_equal(t, a.transpose(2, 0, 1, 3))
    back = np.empty_like(a)
    K.first_axis_last(t, back)
    assert np.array_equal(back, a)

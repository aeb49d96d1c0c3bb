"""The first-collision source on the nodes' hat functions (pv_ambient._kernels.diffusion_sources
hat_source), computed once per half-index point and summed per node, against its definition
evaluated node by node in Python: each node's 27 sub-samples (medium.hat_sub), classified and lit."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pv_ambient._kernels import diffusion_sources as DS
from pv_ambient._kernels.medium import MODE_LUT, hat_sub, scattering_at


def _reference(args):
    (mode, field, table, lut_lo, lut_inv, aux, M, box_lo, box_hi, is_point, pl, lvec, tau, tlo, tinv, near,
     q_out, w_out, done) = args
    nx, ny, nz = done.shape
    for i in range(nx):
        for j in range(ny):
            for k in range(nz):
                if is_point and max(abs(i - pl[0]), abs(j - pl[1]), abs(k - pl[2])) < near + 1.0 - DS.TIE:
                    done[i, j, k] = False
                    continue
                done[i, j, k] = True
                wsum, q, bw, u = 0.0, np.zeros(3), 0.0, np.zeros(3)
                for s in range(27):
                    px, py, pz, w = hat_sub.py_func(s, i, j, k, box_lo, box_hi)
                    if w == 0.0:
                        continue
                    wsum += w
                    st, sr, sg, sb = scattering_at(mode, field, table, lut_lo, lut_inv, aux, px, py, pz)
                    if st <= 0.0:
                        continue
                    e = math.exp(-DS.tau_at(tau, tlo, tinv, px, py, pz))
                    if is_point:
                        wv = M[:, :3] @ np.array([px, py, pz]) + M[:, 3] - lvec
                        d2 = float(wv @ wv)
                        e /= d2
                        v = wv / math.sqrt(d2)
                    else:
                        v = lvec
                    q += w * e * np.array([sr, sg, sb])
                    bw += w * e * st
                    u += w * e * st * v
                q_out[i, j, k] = q / wsum
                w_out[i, j, k] = lvec if not is_point else (u / bw if bw > DS.HAT_TINY else np.nan)


@pytest.mark.parametrize("is_point, cell", [(True, False), (False, False), (True, True)])
def test_hat_source_equals_its_node_by_node_definition(is_point, cell):
    rng = np.random.default_rng(3)
    shape = (5, 4, 6)
    field = rng.random(shape).astype(np.float32)
    table = np.stack([np.linspace(0.0, 6.0, 16), np.full(16, 0.9), np.linspace(0.2, 0.8, 16),
                      np.full(16, 0.5)], axis=1).astype(np.float32)
    ang = 0.3
    M = np.array([[0.4 * math.cos(ang), -0.5 * math.sin(ang), 0.0, 1.0],
                  [0.4 * math.sin(ang), 0.5 * math.cos(ang), 0.0, -2.0],
                  [0.0, 0.0, 0.3, 0.5]])
    half = 0.5 if cell else 0.0
    box_lo = np.full(3, -half)
    box_hi = np.array(shape, np.float64) - 1.0 + half
    tau_grid = rng.random((7, 6, 8)) * 3.0
    tlo = np.full(3, -half)
    tinv = (np.array(tau_grid.shape) - 1.0) / (box_hi - box_lo)
    if is_point:
        pl = np.array([1.3, 2.2, 2.6])
        lvec = M[:, :3] @ pl + M[:, 3]
    else:
        pl = np.zeros(3)
        lvec = np.array([0.6, -0.64, 0.48])
    args = [MODE_LUT, field, table, 0.0, 15.0, np.zeros((1, 1, 1, 3), np.float32), M, box_lo, box_hi, is_point,
            pl, lvec, tau_grid, tlo, tinv, 0.5, np.zeros(shape + (3,)), np.zeros(shape + (3,)),
            np.zeros(shape, np.bool_)]
    ref = list(args)
    ref[16], ref[17], ref[18] = np.zeros(shape + (3,)), np.zeros(shape + (3,)), np.zeros(shape, np.bool_)
    DS.hat_source(*args)
    _reference(ref)
    assert np.array_equal(args[18], ref[18]) and (not is_point or not args[18].all())
    d = args[18]
    assert np.allclose(args[16][d], ref[16][d], rtol=1e-13, atol=0.0)
    ok = d & np.isfinite(ref[17][..., 0])
    assert np.allclose(args[17][ok], ref[17][ok], rtol=1e-12, atol=1e-15)


@pytest.mark.parametrize("cell", [False, True])
def test_hat_medium_equals_its_node_by_node_definition(cell):
    """medium.hat_medium (sub-samples shared between nodes) against the hat-weighted means
    evaluated node by node from medium.hat_sub, 1e-13."""
    from pv_ambient._kernels.medium import hat_medium

    rng = np.random.default_rng(5)
    shape = (6, 5, 4)
    field = rng.random(shape).astype(np.float32)
    table = np.stack([np.linspace(0.0, 6.0, 16) ** 1.5, np.linspace(0.9, 0.3, 16), np.linspace(0.2, 0.8, 16),
                      np.full(16, 0.5)], axis=1).astype(np.float32)
    half = 0.5 if cell else 0.0
    box_lo, box_hi = np.full(3, -half), np.array(shape, np.float64) - 1.0 + half
    aux = np.zeros((1, 1, 1, 3), np.float32)
    sig, sigs = np.zeros(shape), np.zeros(shape + (3,))
    hat_medium(MODE_LUT, field, table, 0.0, 15.0, aux, box_lo, box_hi, sig, sigs)
    for i, j, k in np.ndindex(*shape):
        ws, acc = 0.0, np.zeros(4)
        for s in range(27):
            px, py, pz, w = hat_sub.py_func(s, i, j, k, box_lo, box_hi)
            if w:
                ws += w
                acc += w * np.array(scattering_at(MODE_LUT, field, table, 0.0, 15.0, aux, px, py, pz))
        assert sig[i, j, k] == pytest.approx(acc[0] / ws, rel=1e-13)
        assert np.allclose(sigs[i, j, k], acc[1:] / ws, rtol=1e-13, atol=0.0)

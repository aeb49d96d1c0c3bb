"""The CPU drivers of the optical-depth sweep, row by row (:func:`sweep_rows`, :func:`sweep_rows_each`).

It computes what :func:`.lightvol.sweep_tau` computes — the same characteristics, the same
trapezoid samples of σt, the same bilinear interpolation of the layer ``J`` back, the same TIE
rules and the same point-light reach pyramid — up to the rounding of a reordered sum, in a form
whose inner loop runs along memory:

* **The sweep axis first.** The caller hands the arrays permuted so that the sweep runs along
  axis 0 and a layer is a C-ordered (nb, nc) block (lateral axes in their original order, so the
  history ring and the reach are those of the per-node driver). A layer's nodes are then
  processed row by row (``ib``), the row's nodes (``ic``) contiguous in memory. Why: a sweep along
  the last axis wrote its layers with a stride of a whole row of the volume, and every node's
  samples touched other cache lines.
* **What a run of a row shares, once per run.** On a row (layer ``k``, lateral ``ib``) every
  node's characteristic toward the light has the same component along the sweep axis and along
  ``b`` (a point light: ``l − x`` with the same ``x_a``, ``x_b``; a directional light: all of
  ``v``). Where the nodes' marches also take the same number of steps (a run: all of a
  directional light's row; a point light's nodes within its dominant pyramid, and steps of a few
  nodes on the pyramid's margins, whose marches are longer), sample ``n`` of the march,
  ``x + t_n·v``, lies for all of them at the same position along those two axes: its bilinear
  interpolation in the (a, b) plane is done once for the run (``R[n, c]``, a vectorised pass over
  the contiguous axis), and each node only interpolates ``R[n]`` linearly along ``c`` (a
  directional light: at a fixed offset, a two-tap stencil). Equally the layer ``J`` back's ``b``
  coordinate is one per row, and the path lengths are closed forms (a point light inside the box:
  the segment to it lies inside the box; a directional light: the exit along each axis) instead of
  ray/box clippings.
* **The rest by the per-node rule.** The first layer, nodes that see the light within reach,
  nodes whose characteristic leaves the box before the layer ``J`` back and every node of a point
  light outside the box are computed by :func:`.lightvol.node_tau` itself (on the permuted arrays,
  as a sweep along axis 0): the ray/box clipping is theirs.
* **Fewer waits between threads.** A point light's sweeps are independent: they run side by side,
  each on one thread (:func:`sweep_rows_each`). A directional light's single sweep runs ``jump``
  layers per parallel region (:func:`sweep_rows`), since a layer reads only the layer ``jump``
  back. Why: a region per layer makes every thread wait for the slowest at each layer, and on a
  machine where another process holds a core that wait lasts a time slice.

The GPU keeps the per-node kernel (:func:`.lightvol.sweep_node`): one thread per node has no row
to share, and both compute the same values (tests/stages/test_propagation.py).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from ._jit import driver, prange, scalar
from .lightvol import TIE, dominant_axis, lateral_range, node_tau, put_node, sweep_start, wlen


@scalar(force_inline=True)
def lerp_coord(x, n):
    """Lower index (at most ``n − 2``) and fraction of ``x`` clamped to [0, n − 1] (``n ≥ 2``): the
    linear interpolation it gives equals :func:`.interp.cell_coords`' (which clamps the index to
    ``n − 1`` with fraction 0 where this one takes ``n − 2`` with fraction 1)."""
    x = min(max(x, 0.0), n - 1.0)
    i0 = min(int(x), n - 2)
    return i0, x - i0


@scalar(force_inline=True)
def exit_t(x, v, n):
    """Ray parameter where ``x + t·v`` leaves [0, n − 1] along one axis (``inf`` if ``v = 0``)."""
    if v > 0.0:
        return (n - 1.0 - x) / v
    if v < 0.0:
        return -x / v
    return math.inf


@scalar(force_inline=True)
def write_node(sig, is_point, l0, l1, l2, axis, k, ib, ic, tau, ln, out, cur):
    """Store node (k, ib, ic)'s path-mean extinction in ``cur`` and its τ in ``out`` (a point light:
    only if ``axis``, the sweep's axis in the unpermuted grid, is the node's dominant axis — ties
    decided in the unpermuted axis order, as :func:`.lightvol.sweep_node` decides them). ``out`` is
    the grid in its own order: the node of permuted (k, ib, ic) is written where it lies there,
    so a sweep needs no permuted result array of its own (a 256³ grid's 64 MB, fresh memory in
    every relight) and no copy back."""
    cur[ib, ic] = tau / ln if ln > 0.0 else sig[k, ib, ic]
    if is_point:
        d0 = abs(l0 - k)
        d1 = abs(l1 - ib)
        d2 = abs(l2 - ic)
        if axis == 0:
            dom = dominant_axis(d0, d1, d2)
        elif axis == 1:
            dom = dominant_axis(d1, d0, d2)
        else:
            dom = dominant_axis(d1, d2, d0)
        if dom != axis:
            return
    put_node(out, axis, k, ib, ic, tau)


@scalar(force_inline=True)
def node_steps(f, va, v1, v2):
    """The step count of :func:`.lightvol.march_tau` over ``t ∈ [0, f]`` along ``v`` (its largest
    component ``max(va, |v1|, |v2|)``): the same expression, so the same integer."""
    return int(math.ceil(2.0 * f * max(va, abs(v1), abs(v2)) - TIE)) + 1


@scalar
def row_run(sig, B, is_point, l0, l1, l2, axis, k, J, prev, ib, ca, cb, nstep, f, out, cur, R):
    """Nodes ``ca..cb`` of a row (:func:`sweep_row`) whose marches take ``nstep`` steps (so their
    samples ``n`` share the position along the sweep axis and ``b``): ``R[n, c]`` is sample ``n``'s
    bilinear interpolation in that plane at column ``c``, built once for the run along the
    contiguous axis; each node interpolates it linearly at its own column and sums
    :func:`.lightvol.march_tau`'s trapezoid; the layer ``J`` back, the path lengths and the
    writes as :func:`.lightvol.node_tau` and :func:`.lightvol.sweep_node` do them."""
    na, nb, nc = sig.shape
    x = float(k)
    y = float(ib)
    v0 = l0 - x if is_point else l0
    v1 = l1 - y if is_point else l1
    va = abs(v0)
    pb = y + v1 * f
    dt = f / nstep
    # the columns the run's samples read: between a node and its landing point on the layer J back
    # (which moves with the node: x_c + f·v_c is increasing in x_c)
    lo = min(ca + f * ((l2 - ca) if is_point else l2), float(ca))
    hi = max(cb + f * ((l2 - cb) if is_point else l2), float(cb))
    rlo = max(0, int(math.floor(max(lo, -1.0))) - 1)
    rhi = min(nc - 1, int(math.floor(min(hi, nc + 1.0))) + 2)
    for n in range(nstep + 1):
        t = n * dt if n < nstep else f
        ia, fa = lerp_coord(x + t * v0, na)
        jb, fb = lerp_coord(y + t * v1, nb)
        s00 = sig[ia, jb]
        s10 = sig[ia + 1, jb]
        s01 = sig[ia, jb + 1]
        s11 = sig[ia + 1, jb + 1]
        Rn = R[n]
        for c in range(rlo, rhi + 1):
            u = np.uint64(c)  # unsigned: no negative-index wraparound, so the loop vectorises
            e0 = s00[u] + fa * (s10[u] - s00[u])
            e1 = s01[u] + fa * (s11[u] - s01[u])
            Rn[u] = e0 + fb * (e1 - e0)
        Rn[nc] = Rn[nc - 1]
    # march_tau's trapezoid for every node of the run
    acc = R[R.shape[0] - 1]
    top = nc - 1.0
    if is_point:
        # node outer, samples inner: a sum held in a register, which LLVM vectorises over the
        # samples with gathers (a loop along c that adds into ``acc`` stays scalar: its gathers
        # from R might alias the stores)
        for c in range(ca, cb + 1):
            total = 0.0
            for n in range(nstep + 1):
                t = n * dt if n < nstep else f
                wgt = 0.5 if (n == 0 or n == nstep) else 1.0
                w = min(max(c + t * (l2 - c), 0.0), top)
                j = np.uint64(np.uint32(w))
                a = R[n, j]
                total += wgt * (a + (w - float(j)) * (R[n, j + np.uint64(1)] - a))
            acc[np.uint64(c)] = total
    else:
        # a directional light: sample n sits at a fixed offset o + fo from every node (sample n
        # outer: a loop along c, a two-tap stencil); the nodes whose sample needs no clamp form
        # the range [m0, m1]
        for c in range(ca, cb + 1):
            acc[np.uint64(c)] = 0.0
        for n in range(nstep + 1):
            t = n * dt if n < nstep else f
            wgt = 0.5 if (n == 0 or n == nstep) else 1.0
            Rn = R[n]
            off = t * l2
            o = int(math.floor(off))
            fo = off - o
            m0 = max(ca, -o)
            m1 = min(cb, nc - 1 - o)
            if fo > 0.0:
                m1 = min(m1, nc - 2 - o)
            for c in range(ca, cb + 1):
                if c < m0 or c > m1:
                    w = min(max(c + off, 0.0), top)
                    j = int(w)
                    acc[c] += wgt * (Rn[j] + (w - j) * (Rn[j + 1] - Rn[j]))
            w0 = wgt * (1.0 - fo)
            w1 = wgt * fo
            for c in range(m0, m1 + 1):
                u = np.uint64(c + o)
                acc[np.uint64(c)] += w0 * Rn[u] + w1 * Rn[u + np.uint64(1)]
    # the layer J back's b coordinate, shared by the row (lightvol._bilerp_layer, clamped alike)
    ub, fub = lerp_coord(pb, nb)
    pq0 = prev[ub]
    pq1 = prev[ub + 1]
    for ic in range(ca, cb + 1):
        z = float(ic)
        v2 = l2 - z if is_point else l2
        pc = z + v2 * f
        if pc < -TIE or pc > nc - 1 + TIE:  # leaves the box before the layer J back
            tau, ln = node_tau(sig, B, is_point, l0, l1, l2, 0, k, J, prev, ib, ic)
            write_node(sig, is_point, l0, l1, l2, axis, k, ib, ic, tau, ln, out, cur)
            continue
        wl = wlen(B, v0, v1, v2)
        vc, fvc = lerp_coord(pc, nc)
        e0 = pq0[vc] + fvc * (pq0[vc + 1] - pq0[vc])
        e1 = pq1[vc] + fvc * (pq1[vc + 1] - pq1[vc])
        q = e0 + fub * (e1 - e0)
        if is_point:
            # the light inside the box: the segment to it is too, no clipping
            ln = wl
            lp = (1.0 - f) * wl
        else:
            te = min(exit_t(x, v0, na), exit_t(y, v1, nb), exit_t(z, v2, nc))
            ln = max(te, 0.0) * wl
            lp = max(te - f, 0.0) * wl
        tau = q * lp + acc[ic] * (wl * dt)
        write_node(sig, is_point, l0, l1, l2, axis, k, ib, ic, tau, ln, out, cur)


@scalar
def sweep_row(sig, B, is_point, l0, l1, l2, axis, k, J, prev, ib, c0, c1, out, cur, R, inside):
    """Nodes ``c0..c1`` of row ``ib`` of layer ``k`` of a sweep along axis 0 of the permuted arrays
    (:func:`sweep_rows`), in runs of equal march step count (:func:`row_run`; a directional
    light's are all equal, a point light's grow away from the light on the reach pyramid's
    margins). ``R`` (≥ 4·jump + 4, nc + 1) is the row's scratch: rows 0..nstep the samples' (a, b)
    interpolation (column nc repeats nc − 1, so a sample on the last node needs no clamp), the last
    row the nodes' march sums; ``inside``: a point light inside the box. Nodes that see the light
    within reach, the first layer, a row whose landing row leaves the box and a point light outside
    the box (its path lengths need node_tau's ray/box clipping) take :func:`.lightvol.node_tau`."""
    nb = sig.shape[1]
    x = float(k)
    y = float(ib)
    v0 = l0 - x if is_point else l0
    v1 = l1 - y if is_point else l1
    va = abs(v0)
    fast = J > 0 and not (is_point and (va <= J + TIE or not inside))
    f = J / va if fast else 0.0
    if fast:
        pb = y + v1 * f
        fast = not (pb < -TIE or pb > nb - 1 + TIE)
    if not fast:
        for ic in range(c0, c1 + 1):
            tau, ln = node_tau(sig, B, is_point, l0, l1, l2, 0, k, J, prev, ib, ic)
            write_node(sig, is_point, l0, l1, l2, axis, k, ib, ic, tau, ln, out, cur)
        return
    ca = c0
    while ca <= c1:
        ns = node_steps(f, va, v1, (l2 - ca) if is_point else l2)
        cb = ca
        while cb < c1 and node_steps(f, va, v1, (l2 - cb - 1) if is_point else l2) == ns:
            cb += 1
        if ns + 2 <= R.shape[0]:
            row_run(sig, B, is_point, l0, l1, l2, axis, k, J, prev, ib, ca, cb, ns, f, out, cur, R)
        else:
            for ic in range(ca, cb + 1):
                tau, ln = node_tau(sig, B, is_point, l0, l1, l2, 0, k, J, prev, ib, ic)
                write_node(sig, is_point, l0, l1, l2, axis, k, ib, ic, tau, ln, out, cur)
        ca = cb + 1


def chunks() -> int:
    """How many chunks :func:`sweep_rows` splits a region's rows into: Numba's thread count."""
    return numba.get_num_threads()


@driver
def sweep_rows(sig, B, is_point, l0, l1, l2, axis, sign, jump, out, hist, reach, inside, scratch):
    """One sweep along axis 0 of the permuted array ``sig`` (C order, the grid's axis ``axis`` first,
    the other two in their order; ``B``'s columns and the light (l0, l1, l2) permuted alike) in
    direction ``sign``, its nodes written into ``out`` in the grid's own order (:func:`write_node`): the CPU driver of
    :func:`pv_ambient.stages.propagation.optical_depth` for a directional light, by
    :func:`sweep_row` in parallel over the rows of up to ``jump`` layers at once.

    A layer reads only the layer ``J = min(jump, d)`` back (its ``d``-th in sweep order), so layers
    ``d … d + jump − 1`` depend only on layers before ``d`` and run in one parallel region: a
    quarter of the waits of one region per layer, which under load (another process holding a
    core, each wait lasting until the descheduled thread runs again) cost more than the layer.
    ``hist`` (≥ 2·jump slots, nb, nc) float64 is the ring of the layers' path-mean extinction
    (:func:`.lightvol.sweep_tau`'s, with room for a group being written while the one before it is
    read); ``reach`` as there. ``scratch`` (chunks, ≥ 4·jump + 4, nc + 1) float64: one
    :func:`sweep_row` scratch per chunk of a region's rows (:func:`chunks`: one per thread)."""
    na = sig.shape[0]
    nb = hist.shape[1]
    nc = hist.shape[2]
    nslot = hist.shape[0]
    k0 = sweep_start(na, is_point, l0, sign)
    nlayers = na - k0 if sign > 0 else k0 + 1
    nchunk = scratch.shape[0]
    done = 0
    while done < nlayers:
        g = 1 if done == 0 else max(1, min(jump, nlayers - done))
        total = g * nb
        for t in prange(nchunk):
            R = scratch[t]
            for item in range(total * t // nchunk, total * (t + 1) // nchunk):
                d = done + item // nb
                ib = item % nb
                k = k0 + sign * d
                b0, b1 = lateral_range(nb, l1, reach[k, 0])
                if b0 <= ib <= b1:
                    J = min(jump, d)
                    c0, c1 = lateral_range(nc, l2, reach[k, 1])
                    sweep_row(sig, B, is_point, l0, l1, l2, axis, k, J, hist[(d - J) % nslot], ib, c0, c1, out,
                              hist[d % nslot], R, inside)
        done += g


@scalar
def sweep_serial(sig, B, is_point, l0, l1, l2, axis, sign, jump, out, hist, reach, rows, inside):
    """:func:`sweep_rows` on one thread (a layer's rows in order, ``rows`` the one
    :func:`sweep_row` scratch): one of the sweeps that :func:`sweep_rows_each` runs side by side."""
    na = sig.shape[0]
    nb = hist.shape[1]
    nc = hist.shape[2]
    nslot = hist.shape[0]
    k = sweep_start(na, is_point, l0, sign)
    done_layers = 0
    while 0 <= k < na:
        J = min(jump, done_layers)
        prev = hist[(done_layers - J) % nslot]
        cur = hist[done_layers % nslot]
        b0, b1 = lateral_range(nb, l1, reach[k, 0])
        c0, c1 = lateral_range(nc, l2, reach[k, 1])
        for ib in range(b0, b1 + 1):
            sweep_row(sig, B, is_point, l0, l1, l2, axis, k, J, prev, ib, c0, c1, out, cur, rows, inside)
        done_layers += 1
        k += sign


@driver
def sweep_rows_each(sigs, Bs, ls, outs, axes, signs, jump, hists, reaches, rows, inside):
    """A point light's sweeps (up to six: each axis, each side of the light) side by side, one per
    thread, each on one thread (:func:`sweep_serial`). Why: the sweeps are independent (each writes
    the nodes of its own pyramid), and a sweep parallel over a layer's rows waits for every thread
    at each of its layers, which under load (another process holding a core) costs more than the
    sweep. ``sigs``, ``Bs``: per grid axis, the permuted σt and ``B``; ``outs``: per grid axis the
    result, the one grid-ordered array (each sweep writes the nodes of its own pyramid); ``ls[a]``
    the light in axis ``a``'s permuted order; sweep ``i`` runs along ``axes[i]`` in direction
    ``signs[i]`` with ``hists[i]``, ``reaches[i]`` and the scratch ``rows[i]`` (≥ 4·jump + 4, nc + 1)."""
    for i in prange(len(axes)):
        a = axes[i]
        sweep_serial(sigs[a], Bs[a], True, ls[a, 0], ls[a, 1], ls[a, 2], a, signs[i], jump, outs[a], hists[i],
                     reaches[i], rows[i], inside)

#: Edge of the tiles in which :func:`permute` moves data from the grid's order into a sweep's
#: (both sides of a tile stay in cache).
TILE = 32


@driver
def permute(src, a, dst):
    """``dst`` (C order) = ``src`` with axis ``a`` moved first, the others in their order (a sweep's
    layout, :func:`sweep_rows`); tiled and in parallel (NumPy's copy of a transposed view runs on
    one thread and, for the last axis, through the cache at a stride)."""
    n0, n1, n2 = src.shape
    if a == 1:
        for i in prange(n0):
            for j in range(n1):
                for k in range(n2):
                    dst[j, i, k] = src[i, j, k]
    else:
        for i in prange(n0):
            for j0 in range(0, n1, TILE):
                for k0 in range(0, n2, TILE):
                    for k in range(k0, min(k0 + TILE, n2)):
                        for j in range(j0, min(j0 + TILE, n1)):
                            dst[k, i, j] = src[i, j, k]

"""The diffusion field as the camera pass reads it (docs/diffusion.rst §4): (φ, F) per channel
packed at the data samples, in the smallest layout that holds the radiance's terms, and the sum
over lights."""

from __future__ import annotations

import numpy as np


def pack_for_march(solution, g) -> np.ndarray:
    """``solution``'s (φ, F) per channel, float32 (nx, ny, nz, 12) — (…, 4) when the channels are
    equal, and φ alone, (…, 3) or (…, 1), for a phase function of mean cosine ``g`` = 0, whose
    radiance has no flux term (the march then reads a quarter of the memory)."""
    from ..._kernels.raycast import diffusion_layout

    if g == 0.0:  # no flux term in the radiance (raycast.diffusion_light): φ alone, F never packed
        phi = solution.phi if solution.phi.ndim == 4 else solution.phi[..., None]
        packed = phi.astype(np.float32, copy=False)  # a coarse solve's interpolated φ is float32 already
    else:
        packed = solution.packed()
    n, nch = diffusion_layout(packed.shape[3])  # values per channel, channels
    if nch == 3 and np.array_equal(packed[..., 0:n], packed[..., n:2 * n]) and np.array_equal(
            packed[..., 0:n], packed[..., 2 * n:]):
        packed = packed[..., 0:n]  # grey: one channel read per sample
    return np.ascontiguousarray(packed)


def add_packed(total, part):
    """``total + part`` of two packed fields (``total`` None: ``part``); a grey field is widened to
    every channel when the other is coloured."""
    from ..._kernels.raycast import diffusion_layout

    if total is None:
        return part
    if total.shape != part.shape:  # grey and coloured lights: all channels
        total, part = (np.tile(a, (1, 1, 1, 3)) if diffusion_layout(a.shape[3])[1] == 1 else a for a in (total, part))
    return total + part


def packed_phi(packed) -> np.ndarray:
    """φ per channel (nx, ny, nz, 3) of a packed field (a view; a grey field broadcast to three)."""
    from ..._kernels.raycast import diffusion_layout

    n, nch = diffusion_layout(packed.shape[3])
    phi = packed[..., 0::n]
    return np.broadcast_to(phi, phi.shape[:3] + (3,)) if nch == 1 else phi

"""The lane layout of the CPU's ray packets (:mod:`.packet`): how many rays step together, the
lane fields each thread holds in its flat float32 and float64 arrays, and the compositing every
packet pass 3 ends with. A module of its own so that the passes 3 of the record models
(:mod:`.packet_records`) share them without importing the driver."""

from __future__ import annotations

import numpy as np

from ._jit import scalar

#: Rays per packet, a 4 × 8 pixel block: two AVX-512 registers of float32 lanes. Why two: each lane
#: loop then holds two independent vectors of gathers and arithmetic, which the CPU overlaps where
#: one vector's gathers wait on memory (docs/performance.rst, "CPU camera pass": 16 lanes were
#: 9–17 % slower on the speed scene's camera moves).
LANES = 32
#: The packet's width in pixels; its height is ``LANES // SIDE``.
SIDE = 4

# float32 lane fields: the sample's index-space and world position, whether the lane samples this
# step; the sample's opacity (zero where inactive) and source rgb (a lit sample: its in-scattered
# light first); for a lit sample its table entry and fraction, and light-grid position
X, Y, Z, ACT, WX, WY, WZ, A, SR, SG, SB, Q0, FQ, LX, LY, LZ = range(16)
N32 = 16
# float64 lane fields: ray origin and direction in index space, segment start, next boundary,
# ray end, exit of the current non-empty block, done, transmittance, radiance rgb, the world ray
PX, PY, PZ, QX, QY, QZ, TS, TN, T1, TB, DONE, TR, RR, RG, RB, OX, OY, OZ, DX, DY, DZ = range(21)
N64 = 21


@scalar(inline=True)
def lanes_composite(l32, b32, l64, b64):
    """Pass 3, last (vectorised): every lane's sample, opacity ``A`` and source ``SR, SG, SB``
    (float32), composited into its radiance and transmittance (float64). Why a loop of its own: LLVM
    picks one vector width per loop, from the widest type the loop loads or stores; the sample
    loops before it, which hold the gathers, touch only float32 and so run twice the lanes per
    instruction (docs/performance.rst, "CPU camera pass")."""
    for k in range(LANES):
        T = l64[np.uint64(b64 + TR * LANES + k)]
        w = T * l32[np.uint64(b32 + A * LANES + k)]
        l64[np.uint64(b64 + RR * LANES + k)] += w * l32[np.uint64(b32 + SR * LANES + k)]
        l64[np.uint64(b64 + RG * LANES + k)] += w * l32[np.uint64(b32 + SG * LANES + k)]
        l64[np.uint64(b64 + RB * LANES + k)] += w * l32[np.uint64(b32 + SB * LANES + k)]
        l64[np.uint64(b64 + TR * LANES + k)] = T - w

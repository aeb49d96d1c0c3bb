"""``exp(−τ)`` and ``ln x`` as plain arithmetic, for loops that LLVM should vectorise
(docs/performance.rst, "Transport sweeps" and "Relight: the bake").

Numba compiles ``math.exp`` to a call of the C library's ``exp``; a loop holding that call stays
scalar (this project does not rely on Intel's SVML). :func:`exp_neg` computes the same value with
a range reduction ``−τ = k ln 2 + r`` (``|r| ≤ ln 2 / 2``), a degree-11 Taylor polynomial of ``e^r``
and the exponent ``k`` written into the bits of a double: a relative error below 1e-13 against
``math.exp`` (the fastmath set may re-associate the reduction's two-part ``ln 2``), no branch, so a
loop over it vectorises. Below ``e^{−708}`` it returns 0 (no subnormals).
"""

from __future__ import annotations

import math

import numpy as np
from llvmlite import ir
from numba import types
from numba.extending import intrinsic

from ._jit import scalar


@intrinsic
def _bits_as_float64(typingctx, bits):
    """The float64 whose IEEE-754 bit pattern is the int64 ``bits``."""
    sig = types.float64(types.int64)

    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], ir.DoubleType())

    return sig, codegen


LOG2E = 1.4426950408889634
# ln 2 in two parts (Cody and Waite): the high part has trailing zero bits, so k·LN2_HI is exact
LN2_HI = 6.93147180369123816490e-01
LN2_LO = 1.90821492927058770002e-10
#: Below e^{−TAU_MAX} the result is 0 (e^{−708} ≈ 3e−308, the smallest normal double is 2.2e−308).
TAU_MAX = 708.0


@scalar(inline=True)
def exp_neg(tau):
    """``e^{−τ}`` for ``τ ≥ 0`` (this module's docstring); 0 for ``τ > 708`` and for ``τ = inf``.

    >>> import math
    >>> abs(exp_neg(0.3) / math.exp(-0.3) - 1.0) < 1e-13, exp_neg(0.0), exp_neg(800.0)
    (True, 1.0, 0.0)
    """
    x = max(-tau, -TAU_MAX)
    k = math.floor(x * LOG2E + 0.5)
    r = x - k * LN2_HI - k * LN2_LO
    p = 1.0 + r * (1.0 + r * (1.0 / 2 + r * (1.0 / 6 + r * (1.0 / 24 + r * (1.0 / 120 + r * (1.0 / 720 + r * (
        1.0 / 5040 + r * (1.0 / 40320 + r * (1.0 / 362880 + r * (1.0 / 3628800 + r * (1.0 / 39916800)))))))))))
    scale = _bits_as_float64((np.int64(k) + 1023) << 52)
    return p * scale if x > -TAU_MAX else 0.0


@intrinsic
def _float64_bits(typingctx, x):
    """The int64 holding the IEEE-754 bit pattern of the float64 ``x``."""
    sig = types.int64(types.float64)

    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], ir.IntType(64))

    return sig, codegen


SQRT2 = 1.4142135623730951
MANTISSA = (1 << 52) - 1
ONE_BITS = 1023 << 52


@scalar(inline=True)
def log_pos(x):
    """``ln x`` for a normal positive ``x`` (no zero, subnormal, inf or NaN: the caller clamps), as
    plain arithmetic for loops that LLVM should vectorise: ``x = m·2^e`` from the bits, ``m`` moved
    into [√½, √2), ``ln m = 2 atanh s`` with ``s = (m − 1)/(m + 1)`` (``|s| ≤ 0.172``) by its odd
    series to ``s^23`` (truncation below 1e-18 of ``ln m``); a relative error below 1e-15 against
    ``math.log`` away from x = 1, an absolute one below 1e-16 near it.

    >>> import math
    >>> all(abs(log_pos(v) - math.log(v)) <= 1e-15 * max(1.0, abs(math.log(v))) for v in (1e-300, 0.3, 1.0, 2.0, 7e5))
    True
    """
    bits = _float64_bits(x)
    e = (bits >> 52) - 1023
    m = _bits_as_float64((bits & MANTISSA) | ONE_BITS)
    big = m > SQRT2
    m = 0.5 * m if big else m
    ef = float(e + 1) if big else float(e)
    s = (m - 1.0) / (m + 1.0)
    z = s * s
    p = 1.0 + z * (1.0 / 3 + z * (1.0 / 5 + z * (1.0 / 7 + z * (1.0 / 9 + z * (1.0 / 11 + z * (1.0 / 13 + z * (
        1.0 / 15 + z * (1.0 / 17 + z * (1.0 / 19 + z * (1.0 / 21 + z * (1.0 / 23)))))))))))
    return ef * LN2_HI + (2.0 * s * p + ef * LN2_LO)

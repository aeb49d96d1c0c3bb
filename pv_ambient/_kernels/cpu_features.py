"""The CPU kernels' vector policy: how wide the vectorised loops run and how the lane loops of
:mod:`.packet` read the volume (docs/performance.rst, "CPU camera pass").

Numba takes the CPU's features from ``NUMBA_CPU_FEATURES``, read once, when Numba is imported, for
every function it compiles (the features are part of its disk cache's key). ``import pv_ambient``
sets that variable, before it imports Numba, in two cases:

**Vector width** (on by default). LLVM tunes Intel's AVX-512 CPUs for 256-bit vectors
(``prefer-256-bit``), a choice made for Skylake-SP, whose 512-bit instructions lowered the clock.
On Ice Lake and later the lane loops of the camera pass — gathers and their index arithmetic — run
faster at 512 bits: on :data:`WIDE_CPUS`, the variable is the host's features with
``-prefer-256-bit`` (what LLVM does on AMD Zen 4 and 5 by default). The images are those of the
256-bit code: the lanes are independent, no sum is reordered. ``PV_AMBIENT_WIDE_VECTORS=0`` keeps
LLVM's choice.

**Loads** (opt-in). A lane loop reads 8 corners per lane at unrelated addresses, as hardware gathers
or as one load per lane inserted into a vector. On AMD Zen 4 per-lane loads were the faster; LLVM
picks gathers unless ``prefer-no-gather`` is set. ``PV_AMBIENT_LANE_LOADS=1`` adds
``+prefer-no-gather`` on Zen 4 and Zen 5.

Neither applies when the user set ``NUMBA_CPU_FEATURES`` or ``NUMBA_CPU_NAME``, or when Numba was
imported before pv_ambient (then Numba has read the features already); :func:`load_policy` says
which policy runs and why, and ``benchmarks/speed.py`` prints it.
"""

from __future__ import annotations

import os
import sys

#: LLVM CPU names whose lane loops may load lane by lane (``+prefer-no-gather``, opt-in).
NO_GATHER_CPUS = ("znver4", "znver5")
#: LLVM CPU names (Intel, AVX-512, Ice Lake and later) whose loops run 512 bits wide
#: (``-prefer-256-bit``), unless ``PV_AMBIENT_WIDE_VECTORS=0``.
WIDE_CPUS = ("icelake-client", "icelake-server", "tigerlake", "rocketlake", "sapphirerapids", "emeraldrapids",
             "graniterapids", "graniterapids-d", "diamondrapids")

_POLICY = {"loads": None, "width": None, "why": ""}


def apply_load_policy() -> dict:
    """Choose the vector policy once per process (see the module docstring); returns :func:`load_policy`."""
    if _POLICY["loads"] is not None:
        return load_policy()
    if os.environ.get("NUMBA_CPU_FEATURES") is not None or os.environ.get("NUMBA_CPU_NAME") is not None:
        feats = os.environ.get("NUMBA_CPU_FEATURES") or ""
        loads = "lane by lane" if "+prefer-no-gather" in feats else "Numba's choice"
        width = "512 bits" if "-prefer-256-bit" in feats else "Numba's choice"
        return _set(loads, width, "NUMBA_CPU_FEATURES/NUMBA_CPU_NAME set by the user")
    lanes = os.environ.get("PV_AMBIENT_LANE_LOADS") == "1"
    wide = os.environ.get("PV_AMBIENT_WIDE_VECTORS", "1") != "0"
    if not (lanes or wide):
        return _set("Numba's choice", "Numba's choice", "PV_AMBIENT_WIDE_VECTORS=0")
    if "numba" in sys.modules:
        return _set("Numba's choice", "Numba's choice", "numba was imported before pv_ambient")
    try:
        import llvmlite.binding as llvm

        name = llvm.get_host_cpu_name()
        feats = llvm.get_host_cpu_features().flatten()
    except Exception as exc:  # pragma: no cover - llvmlite always answers where Numba works
        return _set("Numba's choice", "Numba's choice", f"host CPU unknown ({exc})")
    extra = []
    if lanes and name in NO_GATHER_CPUS:
        extra.append("+prefer-no-gather")
    if wide and name in WIDE_CPUS:
        extra.append("-prefer-256-bit")
    if not extra:
        return _set("Numba's choice", "Numba's choice", f"host CPU {name}")
    os.environ["NUMBA_CPU_FEATURES"] = ",".join([feats] + extra)
    return _set("lane by lane" if "+prefer-no-gather" in extra else "Numba's choice",
                "512 bits" if "-prefer-256-bit" in extra else "Numba's choice",
                f"host CPU {name}: NUMBA_CPU_FEATURES set with {','.join(extra)}")


def _set(loads, width, why):
    _POLICY.update(loads=loads, width=width, why=why)
    return load_policy()


def load_policy() -> dict:
    """The policy in this process: ``loads`` ("lane by lane" or "Numba's choice", hardware gathers
    where LLVM's tuning for the CPU prefers them), ``width`` ("512 bits" or "Numba's choice") and why."""
    return dict(_POLICY)

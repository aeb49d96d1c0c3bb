"""The packet driver's load policy: how the vectorised lane loops of :mod:`.packet` read the volume
(docs/performance.rst, "CPU camera pass").

A lane loop reads 8 corners per lane at unrelated addresses. LLVM compiles such a read as a
hardware gather (``vgatherdps``) or as one load per lane inserted into a vector register. On AMD Zen 4
the per-lane loads are the faster (docs/performance.rst gives the figures), and LLVM picks gathers
there unless the subtarget feature ``prefer-no-gather`` is set. Numba takes the CPU's features from
``NUMBA_CPU_FEATURES``, read once, when Numba is imported, for every function it compiles. With that
variable set, code Numba loads from its disk cache has been seen to differ in the last bits from the
same code compiled in the process — an image would then depend on whether its kernels were cached —
so the lane-by-lane policy is opt-in: ``PV_AMBIENT_LANE_LOADS=1`` makes ``import pv_ambient`` set the
variable (host features plus ``+prefer-no-gather``, on Zen 4 and Zen 5, before it imports Numba),
unless the variable is set already or Numba was imported first. By default the loops load as
Numba's LLVM chooses.
"""

from __future__ import annotations

import os
import sys

#: LLVM CPU names whose lane loops load lane by lane (``+prefer-no-gather``).
NO_GATHER_CPUS = ("znver4", "znver5")

_POLICY = {"loads": None, "why": ""}


def apply_load_policy() -> dict:
    """Choose the load policy once per process (see the module docstring); returns :func:`load_policy`."""
    if _POLICY["loads"] is not None:
        return load_policy()
    if os.environ.get("NUMBA_CPU_FEATURES") is not None or os.environ.get("NUMBA_CPU_NAME") is not None:
        feats = os.environ.get("NUMBA_CPU_FEATURES") or ""
        loads = "lane by lane" if "+prefer-no-gather" in feats else "Numba's choice"
        return _set(loads, "NUMBA_CPU_FEATURES/NUMBA_CPU_NAME set by the user")
    if os.environ.get("PV_AMBIENT_LANE_LOADS") != "1":
        return _set("Numba's choice", "the default (PV_AMBIENT_LANE_LOADS=1 asks for lane-by-lane loads)")
    if "numba" in sys.modules:
        return _set("Numba's choice", "numba was imported before pv_ambient")
    try:
        import llvmlite.binding as llvm

        name = llvm.get_host_cpu_name()
        feats = llvm.get_host_cpu_features().flatten()
    except Exception as exc:  # pragma: no cover - llvmlite always answers where Numba works
        return _set("Numba's choice", f"host CPU unknown ({exc})")
    if name in NO_GATHER_CPUS:
        os.environ["NUMBA_CPU_FEATURES"] = feats + ",+prefer-no-gather"
        return _set("lane by lane", f"host CPU {name}: NUMBA_CPU_FEATURES set with +prefer-no-gather")
    return _set("Numba's choice", f"host CPU {name}")


def _set(loads, why):
    _POLICY.update(loads=loads, why=why)
    return load_policy()


def load_policy() -> dict:
    """The packet driver's policy in this process: ``loads`` ("lane by lane" or "Numba's choice",
    hardware gathers where LLVM's tuning for the CPU prefers them) and why."""
    return dict(_POLICY)

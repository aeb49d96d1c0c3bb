"""Tests benchmarks/gpu_kernels.py's helpers that need no CUDA compiler: reading ``ptxas -v`` output,
the register-limited block size, and the argument descriptions that carry a kernel launch's types
from the simulator process to the compiler's."""
import sys
from collections import namedtuple
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
import gpu_kernels as gk  # noqa: E402

#: ptxas 12.9's -v output for a kernel calling a non-inlined device function (names shortened).
PTXAS = """\
ptxas info    : 88 bytes gmem, 88 bytes cmem[4]
ptxas info    : Function properties for _Zdevice
    48 bytes stack frame, 0 bytes spill stores, 0 bytes spill loads
ptxas info    : Compiling entry function '_Zkernel' for 'sm_90'
ptxas info    : Function properties for _Zkernel
    160 bytes stack frame, 184 bytes spill stores, 208 bytes spill loads
ptxas info    : Used 254 registers, used 0 barriers, 1024 bytes smem, 816 bytes cmem[0], 24 bytes cmem[2]
ptxas info    : Compile time = 991.067 ms
"""


def test_parse_ptxas_reads_the_entry_function():
    assert gk.parse_ptxas(PTXAS) == dict(registers=254, smem=1024, stack=160, spill_stores=184, spill_loads=208)


def test_parse_ptxas_without_properties_line():
    text = "ptxas info    : Compiling entry function '_Zk' for 'sm_86'\nptxas info    : Used 40 registers\n"
    assert gk.parse_ptxas(text) == dict(registers=40, smem=0, stack=0, spill_stores=0, spill_loads=0)


def test_max_threads_per_block():
    assert gk.max_threads_per_block(254) == 256  # the 254 registers: at most 256 threads
    assert gk.max_threads_per_block(128) == 512
    assert gk.max_threads_per_block(32) == 1024


def test_descriptions_keep_types_not_values():
    Rec = namedtuple("Rec", "a b")
    a = np.zeros((3, 4, 5), np.float32)
    one = [Rec(a, 1.5), 3, np.float32(2.0), True]
    other = [Rec(a[..., None], 2.5), 7, np.float32(1.0), False]  # a 4-d array in the record
    d1, d2 = [gk.describe(v) for v in one], [gk.describe(v) for v in other]
    assert gk.type_key(d1) != gk.type_key(d2)
    d2[0]["items"][0] = gk.describe(a)
    assert gk.type_key(d1) == gk.type_key(d2)  # only the values differ
    diff = gk.type_diff(d1, [gk.describe(v) for v in other], names=["rec", "n", "x", "flag"])
    assert diff == [("rec.a", "float32 3d C", "float32 4d C")]


Rec2 = namedtuple("Rec2", "a b")  # at module level: rebuild() imports a record's class by name


def test_rebuild_types_as_the_original():
    import numba

    value = (Rec2(np.zeros((2, 3), np.float32), np.zeros(4)[::2]), 5, 0.5, np.int32(3))
    assert numba.typeof(gk.rebuild(gk.describe(value))) == numba.typeof(value)

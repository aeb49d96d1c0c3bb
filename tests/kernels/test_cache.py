"""Numba's disk cache keeps every compiled driver: a new process loads it, it does not compile again.

Numba keys a cached function on its bytecode and, for a closure, a pickle of its cells. A cell
holding a dispatcher pickles with an id drawn anew in each process, so such a closure misses the
cache in every new process and its first frame pays the whole compile (the packet drivers did so
for a while: 15 s at each first diffusion frame). These tests compare the keys two processes
compute and render in one process and then in another, which must load the packet driver.
"""

import importlib
import json
import os
import pkgutil
import subprocess
import sys
from pathlib import Path

from numba.core.dispatcher import Dispatcher

import pv_ambient._kernels as kernels

ROOT = Path(__file__).resolve().parents[2]

#: Prints {name: hash of the closure's cells as Numba's cache pickles them} of every compiled CPU
#: function of pv_ambient._kernels that is a closure (module attributes and the values of dicts there).
KEYS_SCRIPT = r"""
import hashlib, importlib, json, pkgutil
from numba.core.dispatcher import Dispatcher
from numba.core.serialize import dumps
import pv_ambient._kernels as kernels
out = {}
for info in pkgutil.iter_modules(kernels.__path__):
    if info.name == "cuda":
        continue  # imports numba.cuda: not in the test environment
    mod = importlib.import_module("pv_ambient._kernels." + info.name)
    for attr, obj in vars(mod).items():
        items = obj.items() if isinstance(obj, dict) else [(None, obj)]
        for key, d in items:
            if isinstance(d, Dispatcher) and d.py_func.__closure__ is not None:
                cells = tuple(c.cell_contents for c in d.py_func.__closure__)
                out[f"{info.name}.{attr}[{key}]"] = hashlib.sha256(dumps(cells)).hexdigest()
print(json.dumps(out))
"""


def closure_keys():
    proc = subprocess.run([sys.executable, "-c", KEYS_SCRIPT], capture_output=True, text=True, cwd=ROOT, check=True)
    return json.loads(proc.stdout.strip().splitlines()[-1])


def test_closure_cache_keys_are_the_same_in_every_process():
    """Why: a key that changes between processes is a compile in every process. The packet and
    per-pixel drivers (closures over their model id) must be among the keys checked."""
    first, second = closure_keys(), closure_keys()
    assert any(k.startswith("packet.PACKET_DRIVERS") for k in first)
    assert any(k.startswith("raycast.RAYCAST_DRIVERS") for k in first)
    assert first.keys() == second.keys()
    changed = [k for k in first if first[k] != second[k]]
    assert not changed, f"cache keys drawn anew in each process (a closure over a dispatcher?): {changed}"


def test_no_compiled_closure_holds_a_dispatcher():
    """The rule behind the test above, checked in this process: what a compiled closure calls is a
    global (``_jit.with_globals``), never a cell."""
    bad = []
    for info in pkgutil.iter_modules(kernels.__path__):
        if info.name == "cuda":
            continue
        mod = importlib.import_module("pv_ambient._kernels." + info.name)
        for attr, obj in vars(mod).items():
            for d in (obj.values() if isinstance(obj, dict) else [obj]):
                if isinstance(d, Dispatcher) and d.py_func.__closure__ is not None:
                    if any(isinstance(c.cell_contents, Dispatcher) for c in d.py_func.__closure__):
                        bad.append(f"{info.name}.{attr}")
    assert not bad, bad


def test_a_second_process_loads_the_packet_driver(tmp_path):
    """A tiny render in two processes, one after the other, with the suite's cache folder: the first
    may compile the emission–absorption packet driver (a cold cache), the second loads it (a cache
    hit) and compiles none."""
    script = (
        "import json, numpy as np, pv_ambient as pa\n"
        "from pv_ambient._kernels import packet\n"
        "from pv_ambient.inputs.grid import Volume\n"
        "x = np.linspace(-1, 1, 12)\n"
        "v = np.exp(-4 * (x[:, None, None] ** 2 + x[None, :, None] ** 2 + x[None, None, :] ** 2)).astype(np.float32)\n"
        "vol = Volume({'d': v}, spacing=(0.2, 0.2, 0.2), origin=(-1, -1, -1))\n"
        "tf = pa.TransferFunction.from_table([0, 1], sigma_t=[0, 8], albedo=0.5, color=[[0, 0, 0], [1, 1, 1]])\n"
        "pa.Renderer(vol, transfer_function=tf, backend='cpu').render(window_size=(8, 8), camera='iso')\n"
        "d = packet.PACKET_DRIVERS[0]\n"
        "print(json.dumps({'hits': sum(d.stats.cache_hits.values()), 'misses': sum(d.stats.cache_misses.values()),"
        " 'sigs': len(d.signatures)}))\n")
    env = dict(os.environ, PV_AMBIENT_PACKETS="1")
    runs = [json.loads(subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, env=env,
                                      cwd=tmp_path, check=True).stdout.strip().splitlines()[-1]) for _ in range(2)]
    assert runs[0]["sigs"] == 1, runs
    assert runs[1] == {"hits": 1, "misses": 0, "sigs": 1}, runs  # loaded, not compiled

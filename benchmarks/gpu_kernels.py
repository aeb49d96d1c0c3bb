"""Every CUDA kernel the package launches, compiled without a GPU: registers, spills, stack, compile time.

For each kernel ``backend="cuda"`` launches (docs/architecture.rst, DESIGN §5b: "check registers and
spills without a GPU") and each target architecture, one line: the registers per thread, the spill
stores and loads (bytes), the stack frame (bytes), the static shared memory (bytes) that ``ptxas -v``
reports, and the compile time — Python → PTX (``numba.cuda.compile_ptx``: typing, lowering, NVVM) in
a fresh process, so a cold compile, and PTX → SASS (``ptxas``)::

    python -m venv .venv-cuda && .venv-cuda/bin/pip install -e ".[cuda-dev]"
    .venv-cuda/bin/python benchmarks/gpu_kernels.py                 # sm_90 (H100) and sm_86 (laptop RTX)
    .venv-cuda/bin/python benchmarks/gpu_kernels.py --arch sm_90 --out /tmp/k.txt
    make gpu-kernels                                                # the same two steps, .venv-cuda kept

No GPU or driver is used. The ``cuda-dev`` extra (pyproject.toml) installs numba-cuda with NVVM and
ptxas from one CUDA release (the ``nvidia-cuda-nvcc-cu12`` wheel holds both; NVVM and ptxas must
match: NVVM 13 writes PTX 9.0, which a 12.x ptxas refuses) and NumPy < 2.5 (numba-cuda 0.30 cannot
compile with NumPy 2.5). Keep it out of the test suite's ``.venv``. The script uses the NVVM that
numba-cuda loads (cuda-pathfinder: the wheels, then ``CUDA_HOME``) and the ``ptxas`` of the same
toolkit (``bin/ptxas`` beside its ``nvvm/``; ``$PTXAS`` overrides), and says what is missing when
one is.

**Which kernels, with which argument types.** Not a list written here: a tiny render of every model
(:data:`CASES`, the ``supernova_table`` scene of benchmarks/scenes.py that benchmarks/gpu.py times,
at 12³ and 8²) runs on ``backend="cuda"`` in Numba's CUDA simulator (a subprocess with
``NUMBA_ENABLE_CUDASIM=1``), and every kernel launch is recorded at the simulator's kernel class:
the kernel (found as an attribute of a ``pv_ambient`` module, or an entry of a dict there) and the
Numba types of its arguments as numba-cuda would type the device arrays the backend passes. Each
distinct (kernel, argument types) is one line, with the cases that launched it; a kernel launched
with two signatures is compiled twice (two specialisations in a real process too). The kernel is
compiled from its dispatcher's Python function with the dispatcher's own options (``fastmath``,
``opt``, ``lineinfo``, ``debug``, ``launch_bounds``; ``max_registers`` goes to ptxas as
``--maxrregcount``). Argument types can depend on the scene (dtypes of the data, placeholders of
unused parts): these are the benchmark scene's.

On a device the driver compiles the PTX with its own ptxas, of the driver's CUDA release: the
figures here are those of the ptxas the table names.

The table goes to stdout and to ``benchmarks/results/gpu_kernels.txt`` (``--out``), the commit at
its top.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
DEFAULT_OUT = HERE / "results" / "gpu_kernels.txt"
ARCHS = ("sm_90", "sm_86")

#: The renders whose launches are recorded: (label, Renderer.render options) on the
#: ``supernova_table`` scene (:data:`SCENE_N`³, one point light) at :data:`WINDOW`. Every model, and
#: the options that may change a kernel's argument types (tube propagation; the progressive model's
#: residual kernel).
CASES = (("emission_absorption", dict(model="emission_absorption")),
         ("ambient_occlusion", dict(model="ambient_occlusion")),
         ("single_scattering", dict(model="single_scattering")),
         ("ambient_scattering", dict(model="ambient_scattering")),
         ("ambient_scattering/tube", dict(model="ambient_scattering", propagation="tube")),
         ("diffusion", dict(model="diffusion")),
         # a forward-scattering phase function: the lights are not baked (the unbaked specialisations)
         ("single_scattering/g=0.5", dict(model="single_scattering", phase=0.5)),
         ("ambient_scattering/g=0.5", dict(model="ambient_scattering", phase=0.5)),
         ("diffusion/g=0.5", dict(model="diffusion", phase=0.5)),
         # a physical transfer function (per-voxel σt, albedo, emission: the medium's GRID mode)
         *((f"{label}/physical", dict(opts, physical=True)) for label, opts in (
             ("emission_absorption", dict(model="emission_absorption")),
             ("ambient_occlusion", dict(model="ambient_occlusion")),
             ("single_scattering", dict(model="single_scattering")),
             ("diffusion", dict(model="diffusion")),
             ("single_scattering/g=0.5", dict(model="single_scattering", phase=0.5)),
             ("ambient_scattering/g=0.5", dict(model="ambient_scattering", phase=0.5)),
             ("diffusion/g=0.5", dict(model="diffusion", phase=0.5)))),
         ("path_traced", dict(model="path_traced", samples_per_pixel=1, max_depth=3)),
         ("progressive", dict(model="progressive", samples_per_pixel=1, max_depth=3)))
SCENE = "supernova_table"
SCENE_N = 8
WINDOW = (4, 4)

INSTALL_HINT = ('install the CUDA compilers into a venv of their own: python -m venv .venv-cuda && '
                '.venv-cuda/bin/pip install -e ".[cuda-dev]"  (or: make gpu-kernels)')


# --------------------------------------------------------------------------------------------------
# argument types: described as JSON in the simulator process, rebuilt as Numba types in the compiler's


def describe(value):
    """A JSON description of kernel argument ``value`` that :func:`rebuild` turns back into something
    numba-cuda types as it types ``value`` at a launch: device arrays (the simulator's
    ``FakeCUDAArray``: its ``_numba_type_``, as numba-cuda's ``DeviceNDArray`` has it), host arrays,
    Python and NumPy scalars, tuples and namedtuples (the records of ``_kernels/records.py``)."""
    import numpy as np

    ary = getattr(value, "_ary", None)
    if isinstance(ary, np.ndarray) and hasattr(value, "_numba_type_"):  # a device array
        t = value._numba_type_
        return {"kind": "array", "dtype": ary.dtype.str, "ndim": int(t.ndim), "layout": str(t.layout),
                "readonly": False}
    if isinstance(value, np.ndarray):
        c, f = value.flags.c_contiguous, value.flags.f_contiguous
        return {"kind": "array", "dtype": value.dtype.str, "ndim": value.ndim,
                "layout": "C" if c else "F" if f else "A", "readonly": not value.flags.writeable}
    if isinstance(value, (bool, np.bool_)) and not isinstance(value, np.generic):
        return {"kind": "bool", "value": bool(value)}
    if isinstance(value, int) and not isinstance(value, np.generic):
        return {"kind": "int", "value": int(value)}
    if isinstance(value, float) and not isinstance(value, np.generic):
        return {"kind": "float", "value": float(value)}
    if isinstance(value, np.generic):
        return {"kind": "npscalar", "dtype": value.dtype.str, "value": value.item()}
    if isinstance(value, tuple):
        items = [describe(v) for v in value]
        if hasattr(value, "_fields"):
            cls = type(value)
            return {"kind": "namedtuple", "class": f"{cls.__module__}:{cls.__qualname__}",
                    "fields": list(value._fields), "items": items}
        return {"kind": "tuple", "items": items}
    raise TypeError(f"gpu_kernels: a kernel argument of type {type(value).__name__} has no description "
                    "here; add it to describe()/rebuild()")


def type_key(desc):
    """``desc`` without the values of scalars: what decides the Numba types (a launch with other
    values of the same types runs the same compiled kernel)."""
    if isinstance(desc, list):
        return [type_key(d) for d in desc]
    out = {k: v for k, v in desc.items() if k != "value"}
    if "items" in out:
        out["items"] = [type_key(d) for d in out["items"]]
    if desc["kind"] == "int" and not -2**63 <= desc["value"] < 2**63:
        out["kind"] = "uint64"
    return out


def type_diff(a, b, path="", names=None):
    """Where argument descriptions ``a`` and ``b`` (lists, with parameter ``names``) differ in type:
    ``[(path, a's, b's)]``, a path such as ``lgrid.tau``."""
    if isinstance(a, list):
        names = names or [f"arg{i}" for i in range(len(a))]
        return [d for name, x, y in zip(names, a, b) for d in type_diff(x, y, name)]
    if "items" in a and "items" in b and a.get("class") == b.get("class") and len(a["items"]) == len(b["items"]):
        fields = a.get("fields") or [f"[{i}]" for i in range(len(a["items"]))]
        return [d for f, x, y in zip(fields, a["items"], b["items"])
                for d in type_diff(x, y, f"{path}.{f}" if not f.startswith("[") else path + f)]
    return [] if type_key(a) == type_key(b) else [(path, short_type(a), short_type(b))]


def short_type(desc):
    """``float32[:, :, ::A]``-like text of a description."""
    if desc["kind"] == "array":
        import numpy as np

        return f"{np.dtype(desc['dtype']).name} {desc['ndim']}d {desc['layout']}" + (" readonly" if desc["readonly"] else "")
    if desc["kind"] == "npscalar":
        import numpy as np

        return np.dtype(desc["dtype"]).name
    if "items" in desc:
        return f"{desc.get('class', 'tuple').split(':')[-1]}({len(desc['items'])})"
    return desc["kind"]


class _Typed:
    """Stands for an argument whose Numba type is known (numba-cuda's typeof reads ``_numba_type_``)."""

    def __init__(self, numba_type):
        self._numba_type_ = numba_type


def rebuild(desc):
    """A value that numba-cuda types as the argument :func:`describe` described."""
    import importlib

    import numpy as np

    kind = desc["kind"]
    if kind == "array":
        from numba.core import types
        from numba.np.numpy_support import from_dtype

        return _Typed(types.Array(from_dtype(np.dtype(desc["dtype"])), desc["ndim"], desc["layout"],
                                  readonly=desc["readonly"]))
    if kind in ("bool", "int", "float"):
        return {"bool": bool, "int": int, "float": float}[kind](desc["value"])
    if kind == "npscalar":
        return np.dtype(desc["dtype"]).type(desc["value"])
    items = [rebuild(d) for d in desc["items"]]
    if kind == "tuple":
        return tuple(items)
    module, qualname = desc["class"].split(":")
    cls = importlib.import_module(module)
    for part in qualname.split("."):
        cls = getattr(cls, part)
    return cls(*items)


def numba_signature(descs):
    """The Numba argument types of a kernel launch described by ``descs``."""
    try:
        from numba.cuda.typing.typeof import Purpose, typeof  # numba-cuda's own (its dispatcher uses it)

        return tuple(typeof(rebuild(d), Purpose.argument) for d in descs)
    except ImportError:
        import numba

        return tuple(numba.typeof(rebuild(d)) for d in descs)


# --------------------------------------------------------------------------------------------------
# capture: runs in a subprocess with NUMBA_ENABLE_CUDASIM=1


def _locate(kernel):
    """``module:attribute`` (or ``module:attribute[key]``) of the ``pv_ambient`` module attribute that
    holds ``kernel``; None when no module holds it."""
    found = []
    for name, mod in sorted(sys.modules.items()):
        if not (name == "pv_ambient" or name.startswith("pv_ambient.")) or mod is None:
            continue
        for attr, obj in list(vars(mod).items()):
            if obj is kernel:
                found.append(f"{name}:{attr}")
            elif isinstance(obj, dict):
                found += [f"{name}:{attr}[{key!r}]" for key, v in obj.items() if v is kernel]
    # the module that defines it, before one that imported it
    found.sort(key=lambda s: (not s.startswith("pv_ambient._kernels"), s))
    return found[0] if found else None


def capture():
    """Render :data:`CASES` on ``backend="cuda"`` in the simulator; return every distinct launch as
    ``{"kernel", "args", "cases", "launches"}``."""
    assert os.environ.get("NUMBA_ENABLE_CUDASIM") == "1", "run with NUMBA_ENABLE_CUDASIM=1"
    import inspect
    import warnings

    import numpy as np

    sys.path.insert(0, str(ROOT))
    sys.path.insert(0, str(HERE))
    import pv_ambient as pa
    import scenes
    from numba.cuda.simulator.kernel import FakeCUDAKernel

    from pv_ambient.inputs.grid import Volume

    seen = {}
    current = {"case": None}
    launch = FakeCUDAKernel.__call__

    def recording_call(self, *args):
        if not self._device:
            where = _locate(self)
            fn = self.fn
            key = where or f"{fn.__module__}:{fn.__qualname__} (not a module attribute)"
            descs = [describe(a) for a in args]
            item = seen.setdefault(json.dumps([key, type_key(descs)]),
                                   {"kernel": key, "locatable": where is not None, "args": descs, "cases": [],
                                    "launches": 0, "params": list(inspect.signature(fn).parameters)})
            item["launches"] += 1
            if current["case"] not in item["cases"]:
                item["cases"].append(current["case"])
        return launch(self, *args)

    FakeCUDAKernel.__call__ = recording_call
    vol, tf, lights, _g, cam = scenes.scene(SCENE, SCENE_N)
    r = pa.Renderer(vol, transfer_function=tf, lights=lights, backend="cuda")
    # the same medium as per-voxel arrays: a physical transfer function
    scalars = np.asarray(vol.arrays[vol.active], dtype=np.float64)
    phys = Volume({"sigma_t": 40.0 * np.clip(scalars, 0.0, None), "albedo": np.full(scalars.shape, 0.8)},
                  association=vol.association, geometry=vol.geometry)
    rp = pa.Renderer(phys, transfer_function=pa.TransferFunction.physical(), lights=lights, backend="cuda")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # the simulator's uint64 hash wrap-around
        for label, opts in CASES:
            current["case"] = label
            t = time.perf_counter()
            opts = dict(opts)
            renderer = rp if opts.pop("physical", False) else r
            res = renderer.render(camera=cam, window_size=WINDOW, progress_bar=False, **opts)
            assert res.metadata["backend"] == "cuda", (label, res.metadata["backend"])
            print(f"  captured {label:26s} in {time.perf_counter() - t:5.1f} s", file=sys.stderr)
    return list(seen.values())


# --------------------------------------------------------------------------------------------------
# compile: Python -> PTX in a fresh process per (kernel, arch); PTX -> SASS with ptxas


def _kernel_object(locator):
    """The CUDA dispatcher at ``module:attribute`` or ``module:attribute[key]``."""
    import ast
    import importlib

    module, attr = locator.split(":", 1)
    key = None
    m = re.fullmatch(r"(\w+)\[(.*)\]", attr)
    if m:
        attr, key = m.group(1), ast.literal_eval(m.group(2))
    obj = getattr(importlib.import_module(module), attr)
    return obj if key is None else obj[key]


#: Dispatcher options that compile_ptx takes as they are.
_PTX_OPTIONS = ("fastmath", "opt", "lineinfo", "debug", "launch_bounds")


def compile_to_ptx(locator, descs, arch, ptx_path):
    """Compile the kernel at ``locator`` for argument descriptions ``descs`` to PTX for ``arch``
    (``"sm_90"``), written to ``ptx_path``; returns a JSON-able record with the time it took."""
    import types as pytypes

    digits = re.match(r"sm_(\d+)", arch).group(1)  # sm_90 -> (9, 0), sm_100a -> (10, 0)
    cc = (int(digits[:-1]), int(digits[-1]))
    sys.path.insert(0, str(ROOT))  # this checkout's pv_ambient
    import numba.cuda.dispatcher as disp
    from numba import cuda

    # device functions are compiled for the current device's compute capability: there is none
    disp.get_current_device = lambda: pytypes.SimpleNamespace(compute_capability=cc)
    kernel = _kernel_object(locator)
    opts = {k: kernel.targetoptions[k] for k in _PTX_OPTIONS if kernel.targetoptions.get(k) is not None}
    sig = numba_signature(descs)
    t = time.perf_counter()
    ptx, _ = cuda.compile_ptx(kernel.py_func, sig, device=False, cc=cc, **opts)
    seconds = time.perf_counter() - t
    Path(ptx_path).write_text(ptx)
    return {"seconds": seconds, "options": {k: sorted(v) if isinstance(v, (set, frozenset)) else v
                                            for k, v in opts.items()},
            "max_registers": kernel.targetoptions.get("max_registers"),
            "signature": ", ".join(str(s) for s in sig)}


_PTXAS_PROPS = re.compile(r"(\d+) bytes stack frame, (\d+) bytes spill stores, (\d+) bytes spill loads")


def parse_ptxas(text, entry=None):
    """The entry function's figures in ``ptxas -v`` output ``text``: registers, spill stores and
    loads, stack frame and static shared memory (bytes). ``entry``: its mangled name (default: the
    only entry function)."""
    result = None
    current = current_props = None
    for line in text.splitlines():
        m = re.search(r"Compiling entry function '([^']+)'", line)
        if m:
            current = m.group(1)
            continue
        m = re.search(r"Function properties for (\S+)", line)
        if m:
            current_props = m.group(1)
            continue
        m = _PTXAS_PROPS.search(line)
        if m and current is not None and current_props == current and (entry is None or current == entry):
            result = dict(result or {}, stack=int(m.group(1)), spill_stores=int(m.group(2)),
                          spill_loads=int(m.group(3)))
            continue
        m = re.search(r"Used (\d+) registers", line)
        if m and current is not None and (entry is None or current == entry):
            smem = re.search(r"(\d+) bytes smem", line)
            result = dict(result or {}, registers=int(m.group(1)), smem=int(smem.group(1)) if smem else 0)
    if not result or "registers" not in result:
        raise ValueError(f"no entry function's register count in ptxas output:\n{text}")
    result.setdefault("stack", 0)
    result.setdefault("spill_stores", 0)
    result.setdefault("spill_loads", 0)
    return result


def ptx_header(ptx):
    """``# PTX: ...``: the PTX ISA version and the CUDA release of the NVVM that wrote ``ptx``."""
    version = re.search(r"^\.version (\S+)", ptx, re.M)
    release = re.search(r"Cuda compilation tools, (release [^\n]+)", ptx)
    return (f"# PTX: ISA {version.group(1) if version else '?'}, written by the NVVM of CUDA "
            f"{release.group(1) if release else '(release not stated)'}")


def max_threads_per_block(registers):
    """The most threads per block that ``registers`` per thread allow on sm_70 … sm_90 (65536
    registers per SM, allocated per warp in units of 256, at most 1024 threads per block)."""
    per_warp = -(-max(registers, 1) * 32 // 256) * 256
    return min(1024, 65536 // per_warp * 32)


def ptxas_stats(ptxas, ptx_path, arch, max_registers=None):
    """Run ``ptxas -v`` on ``ptx_path`` for ``arch``: :func:`parse_ptxas`'s figures and its time."""
    cmd = [ptxas, "-v", "--gpu-name", arch, str(ptx_path), "-o", os.devnull]
    if max_registers:
        cmd[1:1] = ["--maxrregcount", str(max_registers)]
    t = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True)
    seconds = time.perf_counter() - t
    if proc.returncode != 0:
        version = re.search(r"^\.version (\S+)", Path(ptx_path).read_text(), re.M)
        raise RuntimeError(f"ptxas failed on PTX .version {version.group(1) if version else '?'}:\n"
                           f"{proc.stderr.strip()}\n(NVVM and ptxas must come from one CUDA release; "
                           f"this ptxas is {ptxas})")
    return dict(parse_ptxas(proc.stderr + proc.stdout), ptxas_seconds=seconds)


# --------------------------------------------------------------------------------------------------
# the toolchain


def toolchain():
    """numba-cuda's version, the NVVM it loads and the ptxas of the same toolkit; exits with a
    message naming what is missing."""
    missing = []
    info = {}
    try:
        from importlib.metadata import version

        info["numba-cuda"] = version("numba-cuda")
        import numba
        import numpy

        info["numba"], info["numpy"] = numba.__version__, numpy.__version__
    except Exception as exc:  # noqa: BLE001
        sys.exit(f"gpu_kernels: numba-cuda is not installed ({exc}); {INSTALL_HINT}")
    nvvm = None
    try:
        from numba.cuda.cuda_paths import get_cuda_paths

        found = get_cuda_paths()["nvvm"]
        nvvm = Path(found.info) if found.info else None
        info["nvvm"] = f"{found.info} (found via {found.by})"
    except Exception as exc:  # noqa: BLE001 - pathfinder's not-found error, or an older numba-cuda
        missing.append(f"NVVM (libnvvm), which numba-cuda could not load: {exc}")
    ptxas = os.environ.get("PTXAS")
    if not ptxas and nvvm is not None:  # <toolkit>/nvvm/lib64/libnvvm.so -> <toolkit>/bin/ptxas
        for root in nvvm.parents:
            if (root / "nvvm").is_dir() and (root / "bin" / "ptxas").exists():
                ptxas = str(root / "bin" / "ptxas")
                break
    if not ptxas:
        ptxas = shutil.which("ptxas")
        if ptxas:
            info["ptxas_warning"] = "ptxas found on PATH, not beside the NVVM: check that both are of one CUDA release"
    if ptxas and not os.access(ptxas, os.X_OK):
        missing.append(f"ptxas: {ptxas} is not an executable file")
    elif not ptxas:
        missing.append("ptxas (the nvidia-cuda-nvcc-cu12 wheel's nvidia/cuda_nvcc/bin/ptxas, a CUDA "
                       "toolkit's bin/ptxas, or $PTXAS)")
    else:
        out = subprocess.run([ptxas, "--version"], capture_output=True, text=True).stdout
        rel = re.search(r"release ([\d.]+), (V[\d.]+)", out)
        info["ptxas"] = f"{ptxas} ({rel.group(2) if rel else out.strip()})"
        info["ptxas_path"] = ptxas
    if missing:
        sys.exit("gpu_kernels: missing " + "; ".join(missing) + f".\n{INSTALL_HINT}")
    return info


def commit():
    """The checkout's commit, ``+modified`` when pv_ambient/ has uncommitted changes."""
    try:
        head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True,
                              text=True, check=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--", "pv_ambient"], cwd=ROOT,
                               capture_output=True, text=True).stdout.strip()
        return head + (" +modified pv_ambient/" if dirty else "")
    except (OSError, subprocess.CalledProcessError):
        return "unknown (not a git checkout)"


def _child(args, env_extra=None, timeout=1800):
    """Run this script with ``args`` in a fresh Python; its last stdout line is JSON."""
    env = dict(os.environ, **(env_extra or {}))
    proc = subprocess.run([sys.executable, __file__, *args], capture_output=True, text=True, env=env,
                          timeout=timeout, cwd=ROOT)
    sys.stderr.write(proc.stderr if proc.returncode else "".join(
        ln + "\n" for ln in proc.stderr.splitlines() if ln.startswith("  captured")))
    if proc.returncode != 0:
        raise RuntimeError(f"gpu_kernels {' '.join(args[:1])} failed (exit {proc.returncode}):\n"
                           f"{proc.stdout[-3000:]}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def _short(locator):
    """``pathtrace_kernel`` for ``pv_ambient._kernels.cuda:pathtrace_kernel``; a ray-cast
    specialisation ``RAYCAST_KERNELS[(2, 1, 1)]`` as ``raycast[single_scattering,baked,grid]`` (a medium
    classified in MODE_GRID: a physical transfer function's grids)."""
    name = locator.split(":", 1)[-1]
    m = re.fullmatch(r"RAYCAST_KERNELS\[\((\d+), (\d+), (\d+)\)\]", name)
    if m:
        sys.path.insert(0, str(ROOT))
        from pv_ambient._kernels import models

        names = {v: k.lower() for k, v in vars(models).items() if k.isupper() and isinstance(v, int)}
        model = names.get(int(m.group(1)), m.group(1))
        return f"raycast[{model}{',baked' if int(m.group(2)) else ''}{',grid' if int(m.group(3)) else ''}]"
    return name


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--arch", nargs="+", default=list(ARCHS), help="ptxas --gpu-name values (default: %(default)s)")
    p.add_argument("--out", default=str(DEFAULT_OUT), help="where the table is written (default: %(default)s; "
                                                           "'-' for stdout only)")
    p.add_argument("--ptx-dir", help="keep each kernel's PTX in this folder (default: a temporary one)")
    p.add_argument("--_capture", action="store_true", help=argparse.SUPPRESS)
    p.add_argument("--_compile", nargs=4, metavar=("KERNEL", "ARGS_JSON", "ARCH", "PTX"), help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    if args._capture:
        print(json.dumps(capture()))
        return 0
    if args._compile:
        locator, descs, arch, ptx_path = args._compile
        print(json.dumps(compile_to_ptx(locator, json.loads(Path(descs).read_text()), arch, ptx_path)))
        return 0
    for a in args.arch:
        if not re.fullmatch(r"sm_\d\d+a?", a):
            p.error(f"--arch: {a!r} is not a ptxas GPU name such as sm_90 or sm_86")

    tools = toolchain()
    lines = [f"# benchmarks/gpu_kernels.py --arch {' '.join(args.arch)} | commit {commit()}",
             f"# machine: {os.cpu_count()} CPU cores, no GPU used; python "
             f"{platform.python_version()}, numba {tools['numba']}, numba-cuda {tools['numba-cuda']}, "
             f"numpy {tools['numpy']}",
             f"# NVVM: {tools['nvvm']}", f"# ptxas: {tools['ptxas']}"]
    if "ptxas_warning" in tools:
        lines.append(f"# WARNING: {tools['ptxas_warning']}")
    lines.append(f"# kernels and argument types: the launches of a {SCENE} {SCENE_N}³ render at "
                 f"{WINDOW[0]}x{WINDOW[1]} of every case below on backend='cuda' in Numba's CUDA simulator")
    for line in lines:
        print(line, flush=True)

    t0 = time.perf_counter()
    print("recording the kernel launches (CUDA simulator) ...", file=sys.stderr, flush=True)
    launches = _child(["--_capture"], {"NUMBA_ENABLE_CUDASIM": "1"})
    lines.append(f"# cases: {', '.join(label for label, _ in CASES)} (recorded in {time.perf_counter() - t0:.0f} s)")
    print(lines[-1], flush=True)
    unlocatable = [item["kernel"] for item in launches if not item["locatable"]]
    if unlocatable:
        sys.exit("gpu_kernels: these kernels were launched but are not held by a module attribute (or a dict "
                 "in one) of pv_ambient, so they cannot be compiled here: " + ", ".join(unlocatable))
    # one name per (kernel, signature): kernel, kernel#2, ...
    names, first, specialised = [], {}, []
    for item in launches:
        k = _short(item["kernel"])
        if k not in first:
            first[k] = item
            names.append(k)
            continue
        names.append(f"{k}#{sum(n.split('#')[0] == k for n in names) + 1}")
        diff = type_diff(first[k]["args"], item["args"], names=item["params"])
        specialised.append(f"# {names[-1]}: another specialisation of {k}, its argument types differing in "
                           + "; ".join(f"{path}: {a} there, {b} here" for path, a, b in diff))

    # the specialisations of a kernel together, kernels in the order of their first launch
    order = sorted(range(len(launches)), key=lambda i: (list(first).index(names[i].split("#")[0]), i))
    head = (f"{'kernel':36s} {'arch':6s} {'regs':>5s} {'spill st':>9s} {'spill ld':>9s} {'stack':>6s} "
            f"{'smem':>6s} {'thr/blk':>7s} {'py->ptx':>8s} {'ptxas':>7s} {'PTX kB':>7s}  launched by")
    rows = [head, "-" * len(head)]
    print(head, flush=True)
    print(rows[1], flush=True)
    notes = []
    failed = False
    ptx_info = None
    with tempfile.TemporaryDirectory(prefix="gpu_kernels_") as tmp:
        if args.ptx_dir:
            tmp = args.ptx_dir
            Path(tmp).mkdir(parents=True, exist_ok=True)
        for name, item in ((names[i], launches[i]) for i in order):
            desc_path = Path(tmp) / f"{name.replace('#', '_')}.json"
            desc_path.write_text(json.dumps(item["args"]))
            for arch in args.arch:
                ptx_path = Path(tmp) / f"{name.replace('#', '_')}_{arch}.ptx"
                try:
                    comp = _child(["--_compile", item["kernel"], str(desc_path), arch, str(ptx_path)],
                                  {"NUMBA_ENABLE_CUDASIM": "0"})
                    st = ptxas_stats(tools["ptxas_path"], ptx_path, arch, comp["max_registers"])
                except (RuntimeError, subprocess.TimeoutExpired) as exc:
                    failed = True
                    row = f"{name:36s} {arch:6s} FAILED: {str(exc).splitlines()[0]}"
                    notes.append(f"# {name} {arch}: {exc}")
                else:
                    kb = ptx_path.stat().st_size / 1024
                    row = (f"{name:36s} {arch:6s} {st['registers']:5d} {st['spill_stores']:9d} "
                           f"{st['spill_loads']:9d} {st['stack']:6d} {st['smem']:6d} "
                           f"{max_threads_per_block(st['registers']):7d} {comp['seconds']:7.1f}s "
                           f"{st['ptxas_seconds']:6.1f}s {kb:7.0f}  {', '.join(item['cases'])}")
                    if arch == args.arch[0]:
                        opts = comp["options"] or "none"
                        notes.append(f"# {name}: {item['kernel']}; compile options {opts}"
                                     + (f", max_registers {comp['max_registers']}" if comp["max_registers"] else "")
                                     + f"; {item['launches']} launches; argument types ({comp['signature']})")
                print(row, flush=True)
                rows.append(row)
                if ptx_info is None and ptx_path.exists():
                    ptx_info = ptx_header(ptx_path.read_text())
    tail = ["", *([ptx_info] if ptx_info else []), "# regs: registers per thread; spill st/ld: bytes of local-memory spill stores/loads; stack: "
            "stack frame (bytes); smem: static shared memory (bytes) — all from ptxas -v for the entry "
            "function; thr/blk: the most threads a block can have with these registers (64K registers per "
            "SM, allocated per warp in units of 256); py->ptx: numba.cuda.compile_ptx in a fresh process (typing, lowering, NVVM; the "
            "device functions it calls compiled too: a cold compile); ptxas: ptxas -O3 of that PTX.",
            *specialised, *notes]
    for line in tail:
        print(line)
    text = "\n".join(lines + rows + tail) + "\n"
    if args.out != "-":
        Path(args.out).parent.mkdir(parents=True, exist_ok=True)
        Path(args.out).write_text(text)
        print(f"written to {args.out}", file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())

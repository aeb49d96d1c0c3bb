"""The package's structure (docs/architecture.rst): layers import downward only, no import cycle,
no module imports another's private name, stages never take the renderer, the array core imports
neither pyvista nor vtk (and renders every camera-pass model with both blocked), every sub-package
is installed, and a pickled Renderer renders the same image in another process (what a Dask worker
does)."""
import ast
import inspect
import os
import pickle
import subprocess
import sys
from pathlib import Path

import numpy as np

import pv_ambient as pa
from pv_ambient import datasets

PKG = Path(pa.__file__).resolve().parent
ROOT = PKG.parent

#: Layer of each part of the package, lowest first; a module may import only its own layer or below.
LAYERS = [
    ("_kernels", 0), ("device_cache", 1), ("cuda_launch", 1), ("backend", 1), ("device_stages", 1), ("inputs", 2), ("datasets", 2), ("metrics", 2), ("stages", 3),
    ("rendering", 4), ("pyvista", 5), ("scene", 5), ("cli", 5), ("series", 5), ("preintegration", 5), ("", 6),
]
#: Parts that form the array core: no pyvista, no vtk (they run where only numpy and numba exist).
#: ``rendering`` may convert a result to a PyVista object inside a method (``RenderResult.to_plane``),
#: never at import and never ``pyvista.plotting``.
ARRAY_CORE = ("_kernels", "device_cache", "cuda_launch", "backend", "device_stages", "stages")
LAZY_PYVISTA = ("rendering",)


def module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def layer(mod: str) -> int:
    rest = mod[len("pv_ambient"):].lstrip(".")
    top = rest.split(".")[0]
    for name, rank in LAYERS:
        if top == name:
            return rank
    raise AssertionError(f"module {mod} is in no layer: add it to LAYERS")


def top_level_imports(path: Path) -> set:
    """Line numbers of the imports that run when the module is imported (not inside a function)."""
    tree = ast.parse(path.read_text(), str(path))
    nested = {id(n) for f in ast.walk(tree) if isinstance(f, (ast.FunctionDef, ast.AsyncFunctionDef))
              for n in ast.walk(f)}
    return {n.lineno for n in ast.walk(tree) if isinstance(n, (ast.Import, ast.ImportFrom)) and id(n) not in nested}


def imports(path: Path):
    """(imported module, imported names, line) for every import in the file, relative ones resolved."""
    mod = module_name(path)
    package = mod if path.name == "__init__.py" else mod.rsplit(".", 1)[0]
    tree = ast.parse(path.read_text(), str(path))
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for a in node.names:
                yield a.name, (), node.lineno
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - (node.level - 1)]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            names = tuple(a.name for a in node.names)
            if target.startswith("pv_ambient"):
                # "from . import x": x may be a sub-module
                subs = [f"{target}.{n}" for n in names if (PKG.parent / f"{target}.{n}".replace(".", "/")).with_suffix(".py").exists()
                        or (PKG.parent / f"{target}.{n}".replace(".", "/")).is_dir()]
                if subs:
                    for s in subs:
                        yield s, (), node.lineno
                    continue
            yield target, names, node.lineno


FILES = sorted(PKG.rglob("*.py"))


def test_layers_import_downward_only():
    bad = []
    for f in FILES:
        mod = module_name(f)
        for target, _, line in imports(f):
            if target.startswith("pv_ambient") and layer(target) > layer(mod):
                bad.append(f"{f.relative_to(ROOT)}:{line} imports {target} (layer {layer(target)} > {layer(mod)})")
    assert not bad, "\n".join(bad)


def test_no_import_cycle():
    graph = {}
    for f in FILES:
        mod = module_name(f)
        graph.setdefault(mod, set())
        for target, _, _ in imports(f):
            if target.startswith("pv_ambient") and target != mod and not mod.startswith(target + "."):
                graph[mod].add(target)
    # depth-first search for a back edge
    state, stack = {}, []

    def visit(m):
        state[m] = 1
        stack.append(m)
        for t in sorted(graph.get(m, ())):
            if state.get(t) == 1:
                raise AssertionError("import cycle: " + " -> ".join(stack[stack.index(t):] + [t]))
            if t in graph and state.get(t) is None:
                visit(t)
        stack.pop()
        state[m] = 2

    for m in sorted(graph):
        if state.get(m) is None:
            visit(m)


def test_no_private_name_crosses_modules():
    bad = []
    for f in FILES:
        for target, names, line in imports(f):
            if target.startswith("pv_ambient"):
                bad += [f"{f.relative_to(ROOT)}:{line} imports {n} from {target}" for n in names
                        if n.startswith("_") and not n.startswith("__")]
    assert not bad, "\n".join(bad)


def test_array_core_imports_neither_pyvista_nor_vtk():
    bad = []
    for f in FILES:
        mod = module_name(f)
        top = mod[len("pv_ambient"):].lstrip(".").split(".")[0]
        if top not in ARRAY_CORE + LAZY_PYVISTA:
            continue
        eager = top_level_imports(f)
        for target, names, line in imports(f):
            if target.split(".")[0] not in ("pyvista", "vtk", "vtkmodules"):
                continue
            if top in ARRAY_CORE or line in eager or target.startswith("pyvista.plotting") or "Plotter" in names:
                bad.append(f"{f.relative_to(ROOT)}:{line} imports {target}")
    assert not bad, "\n".join(bad)


def test_array_core_without_pyvista_and_vtk():
    code = r"""
import sys
for name in ("pyvista", "vtk", "vtkmodules"):
    sys.modules[name] = None  # import fails
import numpy as np
import pv_ambient as pa
from pv_ambient.inputs.grid import Volume
x, y, z = np.meshgrid(*(np.linspace(-1, 1, 12),) * 3, indexing="ij")
vol = Volume(np.exp(-4 * (x * x + y * y + z * z)).astype(np.float32), spacing=(2 / 11,) * 3, origin=(-1,) * 3)
tf = pa.TransferFunction.from_table([0.0, 1.0], sigma_t=[0.0, 8.0], albedo=0.9, color=[[0, 0, 0], [1, 1, 1]])
r = pa.Renderer(vol, transfer_function=tf, lights=[pa.PointLight((0, 0, 2.0), 4.0)])
cam = pa.Camera((0, -4, 0), (0, 0, 0), (0, 0, 1))
for model in ("emission_absorption", "single_scattering", "ambient_scattering", "diffusion"):
    res = r.render(camera=cam, window_size=(8, 8), model=model, quality="preview")
    assert res.radiance.max() > 0, model
loaded = sorted(m for m in sys.modules if m.split(".")[0] in ("pyvista", "vtk", "vtkmodules") and sys.modules[m])
print("OK", loaded, hasattr(pa, "add_ambient_volume"))
"""
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert proc.stdout.strip() == "OK [] False"


def test_no_stage_takes_the_renderer():
    import importlib
    import pkgutil

    import pv_ambient.stages as stages

    checked = 0
    for info in pkgutil.walk_packages(stages.__path__, "pv_ambient.stages."):
        module = importlib.import_module(info.name)
        for _, obj in inspect.getmembers(module, inspect.isfunction):
            if obj.__module__ != module.__name__:
                continue
            params = inspect.signature(obj).parameters
            checked += 1
            assert "renderer" not in params, f"{info.name}.{obj.__name__} takes a renderer"
            for p in params.values():
                assert "Renderer" not in str(p.annotation), f"{info.name}.{obj.__name__}({p.name}: Renderer)"
    assert checked > 20


#: What ``rendering/`` may import from ``_kernels``: plain records and the model ids — data, no
#: compiled function. Every kernel runs through ``backend`` or a stage of ``stages/``.
RENDERING_KERNEL_IMPORTS = {"pv_ambient._kernels.records", "pv_ambient._kernels.models"}


def test_rendering_launches_no_kernel():
    """rendering/ decides which stage runs when; it computes nothing itself: it imports no compiled
    kernel (only records and model ids from ``_kernels``) and calls no ``numba`` entry point."""
    bad = []
    for f in sorted((PKG / "rendering").rglob("*.py")):
        for target, names, line in imports(f):
            if target.startswith("numba"):
                bad.append(f"{f.relative_to(ROOT)}:{line} imports {target}")
            if target.startswith("pv_ambient._kernels") and target not in RENDERING_KERNEL_IMPORTS:
                bad.append(f"{f.relative_to(ROOT)}:{line} imports {target}")
    assert not bad, "\n".join(bad)


def test_the_stage_cache_is_a_component_of_the_renderer():
    """The per-scene stages are an object the renderer owns (``Renderer.stages``), not a base class:
    Renderer derives from ``object`` alone, and its stages hold no renderer."""
    from pv_ambient.rendering.scene_stages import SceneStages

    assert pa.Renderer.__mro__ == (pa.Renderer, object)
    r = pa.Renderer(datasets.cloud(n=8))
    assert isinstance(r.stages, SceneStages)
    assert not any(isinstance(v, pa.Renderer) for v in vars(r.stages).values())


def test_kernels_own_the_model_ids():
    """The ray-cast kernel's model ids are one enumeration in ``_kernels`` (the bottom layer); the
    model table reads them from there, and no module outside ``_kernels`` writes an id as a literal."""
    from pv_ambient._kernels import models
    from pv_ambient.rendering.presets import MODEL_IDS, MODEL_TABLE

    ids = {m.name: m.kernel_id for m in MODEL_TABLE if m.kernel_id is not None}
    assert ids == MODEL_IDS and sorted(ids.values()) == sorted(models.RAYCAST_MODELS)
    assert all(getattr(models, name.upper()) == i for name, i in ids.items())
    src = (PKG / "rendering" / "presets.py").read_text()
    tree = ast.parse(src)
    literal_ids = [n.lineno for n in ast.walk(tree) if isinstance(n, ast.Call)
                   and getattr(n.func, "id", "") == "ModelSpec" and len(n.args) > 1
                   and isinstance(n.args[1], ast.Constant) and n.args[1].value is not None]
    assert not literal_ids, f"rendering/presets.py writes model ids as literals on lines {literal_ids}"


def test_every_subpackage_is_installed():
    # what a non-editable install carries: pyproject's package discovery must find every folder
    # with Python modules (an editable install would hide a missing one)
    import setuptools

    found = set(setuptools.find_packages(str(ROOT), include=["pv_ambient", "pv_ambient.*"]))
    folders = {module_name(p.parent / "__init__.py") for p in FILES}
    assert folders <= found, folders - found
    text = (ROOT / "pyproject.toml").read_text()
    assert '"pv_ambient.*"' in text and "packages.find" in text


SCRIPT = r"""
import pickle, sys
import numpy as np
with open(sys.argv[1], "rb") as f:
    r, kw = pickle.load(f)
out = {}
for model in ("emission_absorption", "single_scattering", "ambient_scattering", "diffusion", "path_traced"):
    out[model] = r.render(model=model, **kw, **({"samples_per_pixel": 4} if model == "path_traced" else {})).radiance
np.savez(sys.argv[2], **out)
"""


def test_pickled_renderer_renders_identically_in_a_subprocess(tmp_path):
    r = pa.Renderer(datasets.supernova(n=16), lights=[pa.PointLight((0.1, 0.0, 0.3), 3.0)])
    kw = dict(camera=pa.Camera((0.0, -3.6, 0.6), (0, 0, 0), (0, 0, 1), view_angle=30), window_size=(14, 10),
              table_quality="preview", phase=0.3)  # samples_per_pixel=4 for path_traced only (0.3.0 warns)
    r.render(model="ambient_scattering", **kw)  # warm caches travel too
    blob = tmp_path / "renderer.pkl"
    blob.write_bytes(pickle.dumps((r, kw)))
    (tmp_path / "script.py").write_text(SCRIPT)
    env = dict(os.environ)
    proc = subprocess.run([sys.executable, str(tmp_path / "script.py"), str(blob), str(tmp_path / "out.npz")],
                          capture_output=True, text=True, timeout=600, env=env)
    assert proc.returncode == 0, proc.stderr[-3000:]
    there = np.load(tmp_path / "out.npz")
    for model in there.files:
        here = r.render(model=model, **kw, **({"samples_per_pixel": 4} if model == "path_traced" else {})).radiance
        assert here.max() > 0 or model == "emission_absorption"
        np.testing.assert_array_equal(there[model], here, err_msg=model)


#: Limits that keep each module about one job and each function readable in one screen (docs/architecture.rst).
MAX_MODULE_LINES = 600
MAX_FUNCTION_CODE_LINES = 100


def code_lines(node, source_lines) -> int:
    """Lines of code of a function: non-blank, non-comment lines, its docstring excluded."""
    lines = set(range(node.lineno, node.end_lineno + 1))
    body = node.body
    if body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant) \
            and isinstance(body[0].value.value, str):
        lines -= set(range(body[0].lineno, body[0].end_lineno + 1))
    return sum(1 for n in lines if source_lines[n - 1].strip() and not source_lines[n - 1].strip().startswith("#"))


def test_modules_and_functions_stay_small():
    """No module over 600 lines; no function outside ``_kernels`` over 100 lines of code (a kernel
    may be one long loop that must stay one function to be compiled as one)."""
    bad = []
    for f in FILES:
        src = f.read_text()
        lines = src.splitlines()
        if len(lines) > MAX_MODULE_LINES:
            bad.append(f"{f.relative_to(ROOT)}: {len(lines)} lines")
        if "_kernels" in f.relative_to(PKG).parts:
            continue
        for node in ast.walk(ast.parse(src)):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                n = code_lines(node, lines)
                if n > MAX_FUNCTION_CODE_LINES:
                    bad.append(f"{f.relative_to(ROOT)}:{node.lineno} {node.name}: {n} lines of code")
    assert not bad, "\n".join(bad)

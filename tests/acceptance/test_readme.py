"""The README's front door works: every ```python block of README.md runs, as a reader would paste
it, and writes the files it names; the README stays short and its links point at files that exist.

Each block runs on its own (the README writes them self-contained) in a temporary folder, with
warnings as errors (the suite's ``filterwarnings``). Only the sizes change: :data:`FAST` shrinks grids
and windows so the blocks run in seconds, and each of its replacements must still match the
README (a README edit that drops one shows up here instead of silently running at full size).
Shell blocks (``make``, ``pip``) are not run. A block whose import of an optional extra fails is
skipped with the extra's name (``make test`` installs ``mri``).
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
README = ROOT / "README.md"
TEXT = README.read_text(encoding="utf-8")
BLOCK = re.compile(r"^```python\n(.*?)^```", re.MULTILINE | re.DOTALL)
BLOCKS = [(TEXT.count("\n", 0, m.start()) + 2, m.group(1)) for m in BLOCK.finditer(TEXT)]

#: Fast settings: (README text, what the test runs instead).
FAST = (
    ("datasets.supernova(n=96)", "datasets.supernova(n=24)"),
    ("window_size=(512, 512)", "window_size=(48, 40)"),
    ("window_size=(400, 400)", "window_size=(48, 40)"),
    ("factor=2)", "factor=8)"),
)
#: Optional modules a block may need, and the extra that installs each.
EXTRAS = {"nilearn": "mri", "pyoidn": "denoise", "dask": "distributed", "distributed": "distributed",
          "imageio": "movie", "numba_cuda": "cuda"}
#: Files a block says it writes.
WRITES = re.compile(r"""\.(?:save|screenshot)\(\s*["']([^"']+)["']""")


def test_readme_has_python_blocks_and_every_fast_setting_matches():
    assert len(BLOCKS) >= 2, "README.md has lost its code examples"
    for old, _ in FAST:
        assert any(old in code for _, code in BLOCKS), (
            f"{old!r} is no longer in README.md's code: update FAST in {Path(__file__).name}")


def test_readme_is_a_front_door():
    """Issue 41's limits: at most 200 lines and 12 KB."""
    assert TEXT.count("\n") <= 200 and len(TEXT.encode("utf-8")) <= 12 * 1024


def test_readme_links_point_at_files():
    links = re.findall(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", TEXT)
    local = [link for link in links if "://" not in link]
    assert local, "README.md links to no docs page"
    missing = [link for link in local if not (ROOT / link).exists()]
    assert not missing, f"README.md links to missing files: {missing}"


@pytest.mark.parametrize("line, code", BLOCKS, ids=[f"line{line}" for line, _ in BLOCKS])
def test_readme_python_block_runs(line, code, tmp_path, monkeypatch):
    import pyvista as pv

    for old, new in FAST:
        code = code.replace(old, new)
    monkeypatch.chdir(tmp_path)
    pv.OFF_SCREEN = True
    namespace = {"__name__": "__readme__"}
    try:
        exec(compile(code, f"README.md, block at line {line}", "exec"), namespace)
    except ImportError as exc:
        extra = EXTRAS.get((exc.name or "").split(".")[0])
        if extra is None:
            raise
        pytest.skip(f"needs the {extra!r} extra ({exc.name} is not installed)")
    finally:
        pv.close_all()
    for name in WRITES.findall(code):
        assert (tmp_path / name).is_file(), f"the README block at line {line} did not write {name}"

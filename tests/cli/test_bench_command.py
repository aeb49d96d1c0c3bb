"""Tests the ``pv-ambient bench`` command (pv_ambient/cli.py): its help lists the benchmarks, and
the command runs benchmarks/NAME.py with the options passed through."""
import sys


def test_bench_help_shows_the_benchmarks_and_how_to_get_their_options(capsys):
    """Why: ``pv-ambient bench --help`` showed only ``rest``."""
    from pv_ambient.cli import main

    assert main(["bench", "--help"]) == 0
    out = capsys.readouterr().out
    assert all(f"  {name} " in out for name in ("trade", "ea", "ambient", "gpu"))
    assert "bench NAME --help" in out and "--backend cuda" in out


def test_bench_backend_cuda_runs_the_gpu_benchmark(monkeypatch):
    # `pv-ambient bench --backend cuda ARGS` runs benchmarks/gpu.py with ARGS (options pass through)
    import runpy

    from pv_ambient.cli import main

    seen = {}
    monkeypatch.setattr(runpy, "run_path", lambda path, run_name: seen.update(path=path, argv=list(sys.argv)))
    monkeypatch.setattr(sys, "argv", list(sys.argv))
    monkeypatch.setattr(sys, "path", list(sys.path))
    assert main(["bench", "--backend", "cuda", "--cases", "8:4", "--repeats", "1"]) == 0
    assert seen["path"].endswith("gpu.py") and seen["argv"][1:] == ["--cases", "8:4", "--repeats", "1"]
    assert main(["bench", "ambient", "--sizes", "16"]) == 0
    assert seen["path"].endswith("ambient.py") and seen["argv"][1:] == ["--sizes", "16"]

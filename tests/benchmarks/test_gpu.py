"""Tests benchmarks/gpu.py without a GPU: its arguments (``--backends``, the cases), the rule that the
CPU baseline stops at 256³, the CPU-only table end to end on a tiny scene, the fresh-process child's
timed steps and the compile counter that says whether a warm cache compiled nothing."""
import json
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
import gpu  # noqa: E402


def test_backends_default_to_both_and_cuda_alone_skips_the_cpu():
    assert gpu.parser().parse_args([]).backends == ["cuda", "cpu"]
    assert gpu.parser().parse_args(["--backends", "cuda"]).backends == ["cuda"]
    with pytest.raises(SystemExit):
        gpu.parser().parse_args(["--backends", "gpu"])


def test_cases_parse_as_n_and_window():
    assert gpu.parser().parse_args([]).cases == [(256, 512), (512, 1024)]
    assert gpu.parser().parse_args(["--cases", "32:64", "8:4"]).cases == [(32, 64), (8, 4)]
    with pytest.raises(SystemExit):
        gpu.parser().parse_args(["--cases", "32x64"])


def test_the_cpu_baseline_stops_at_256():
    both = ["cuda", "cpu"]
    assert gpu.backends_at(256, both, gpu.CPU_MAX_N) == both
    assert gpu.backends_at(512, both, gpu.CPU_MAX_N) == ["cuda"]
    assert gpu.backends_at(512, ["cpu"], gpu.CPU_MAX_N) == []
    assert gpu.backends_at(512, ["cpu"], 512) == ["cpu"]


def test_cpu_only_table_runs_and_is_written(tmp_path, capsys):
    out = tmp_path / "gpu.txt"
    args = ["--backends", "cpu", "--cases", "8:4", "512:4", "--models", "emission_absorption", "--repeats", "1",
            "--out", str(out)]
    assert gpu.main(args) == 0
    text = out.read_text()
    assert text == capsys.readouterr().out  # the file holds what was printed
    rows = [ln for ln in text.splitlines() if not ln.startswith("#")]
    assert rows[0].split()[:3] == ["case", "model", "first"]
    assert rows[1].split()[:3] == ["8³/4²", "emission_absorption", "cpu"]
    assert "no backend here" in rows[2] and not any(" gpu " in ln for ln in rows)
    assert text.startswith("# $ python benchmarks/gpu.py --backends cpu")


def test_measures_pick_the_columns_and_profile_prints_the_frame(tmp_path, capsys):
    args = ["--backends", "cpu", "--cases", "8:4", "--models", "emission_absorption", "--repeats", "1",
            "--measures", "camera", "--profile", "3", "--out", "-"]
    assert gpu.main(args) == 0
    lines = capsys.readouterr().out.splitlines()
    row = next(ln for ln in lines if ln.startswith("8³/4²")).split()
    assert row[3] == "-" and row[4].endswith("ms") and row[5:7] == ["-", "-"]  # first, camera, relight, TF
    prof = [ln for ln in lines if "camera-move profile" in ln]
    assert prof[0].split("| ")[1].startswith("per 1 frames") and any("ncalls" in ln for ln in prof)
    with pytest.raises(SystemExit):
        gpu.parser().parse_args(["--measures", "frame"])


def test_fresh_process_child_times_each_step(capsys):
    assert gpu.main(["--_first-frame", "emission_absorption", "cpu", "8", "4"]) == 0
    res = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert {"import", "scene", "render", "compiled", "loaded"} <= set(res)
    assert "context" not in res  # a CPU frame creates no CUDA context
    assert res["render"] > 0 and res["compiled"] >= 0 and res["loaded"] >= 0
    row = gpu.fresh_row("8³/4²", "emission_absorption", "cpu", {"render": 9.0}, {**res, "process": 2.0})
    total = float(row.split()[6].rstrip("s"))  # case, model, backend, import, numba.cuda, context, render, total
    assert total == pytest.approx(res["import"] + res["render"], abs=0.011)


def test_compile_counts_see_a_compilation():
    import numba

    @numba.njit
    def twice(x):
        return 2 * x

    before = gpu.compile_counts()
    assert twice(3) == 6
    after = gpu.compile_counts()
    assert after[0] == before[0] + 1 and after[1] == before[1]

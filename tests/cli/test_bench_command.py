"""Tests the ``pv-ambient bench`` command (pv_ambient/cli.py): its help lists the benchmarks, and
the command runs benchmarks/NAME.py with the options passed through."""


def test_bench_help_shows_the_benchmarks_and_how_to_get_their_options(capsys):
    """Why: ``pv-ambient bench --help`` showed only ``rest``."""
    from pv_ambient.cli import main

    assert main(["bench", "--help"]) == 0
    out = capsys.readouterr().out
    assert all(f"  {name} " in out for name in ("trade", "ea", "ambient", "gpu"))
    assert "bench NAME --help" in out and "--backend cuda" in out

"""Tests pv_ambient/__init__.py, the package's public face: the version string."""
from pathlib import Path

import pv_ambient as pa


def test_version_is_0_4_0_in_the_package_and_pyproject():
    """0.3.0: documented PNG defaults changed; 0.4.0: a new model and command, the path tracer's samples
    moved (README)."""
    import re

    toml = (Path(__file__).resolve().parent.parent / "pyproject.toml").read_text()
    assert re.search(r'^version = "0\.4\.0"$', toml, re.MULTILINE)
    assert pa.__version__ == "0.4.0"

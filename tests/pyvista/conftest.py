"""Fixtures of the PyVista-layer tests: a 32³ cloud and its renderer (one per module)."""
import pytest

import pv_ambient as pa
from pv_ambient import datasets


@pytest.fixture(scope="module")
def cloud():
    grid = datasets.cloud(n=32)
    return grid, pa.Renderer(grid, transfer_function=pa.TransferFunction(**datasets.suggested_style("cloud")))

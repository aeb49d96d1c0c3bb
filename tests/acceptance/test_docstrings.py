"""Every docstring example in the package runs and prints what it claims (doctest)."""

import doctest
import importlib
import pkgutil

import pytest

import pv_ambient

MODULES = sorted(m.name for m in pkgutil.walk_packages(pv_ambient.__path__, "pv_ambient.")
                 if ".cli" not in m.name)


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples(name):
    import pyvista as pv

    pv.OFF_SCREEN = True
    mod = importlib.import_module(name)
    res = doctest.testmod(mod, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE, verbose=False)
    assert res.failed == 0, f"{res.failed} of {res.attempted} docstring examples failed in {name}"

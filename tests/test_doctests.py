"""The docstring examples run as written (``>>>`` lines and their output)."""

import doctest
import importlib

import pytest

MODULES = ["softshadows.claims", "softshadows.envmap", "softshadows.methods", "softshadows.scenes"]


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples_run(name):
    result = doctest.testmod(importlib.import_module(name), optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    assert result.attempted > 0 and result.failed == 0, result

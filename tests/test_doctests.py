"""The docstring examples run as written (``>>>`` lines and their output), in every public module."""

import doctest
import importlib
import pkgutil

import pytest

import softshadows


def _public_modules() -> list[str]:
    """Every module of the package whose name does not start with an underscore, subpackages included."""
    found = pkgutil.walk_packages(softshadows.__path__, prefix="softshadows.")
    return sorted(m.name for m in found if not any(part.startswith("_") for part in m.name.split(".")))


MODULES = _public_modules()


def test_every_public_module_is_found():
    # The walk itself could come back short (a broken install); these are the modules users read.
    assert {"softshadows.methods", "softshadows.io", "softshadows.metrics", "softshadows.cli"} <= set(MODULES)


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples_run(name):
    module = importlib.import_module(name)
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    assert result.failed == 0, result

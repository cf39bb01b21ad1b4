"""The docstring examples run as written (``>>>`` lines and their output), in every public module."""

import doctest
import importlib
import pkgutil

import pytest

import softshadows


def _public_modules() -> list[str]:
    """The package itself and every module of it whose name does not start with an underscore,
    subpackages included."""
    found = pkgutil.walk_packages(softshadows.__path__, prefix="softshadows.")
    return ["softshadows"] + sorted(m.name for m in found if not any(part.startswith("_") for part in m.name.split(".")))


MODULES = _public_modules()


def test_every_public_module_is_found():
    # The walk itself could come back short (a broken install); these are the modules users read.
    assert {"softshadows", "softshadows.methods", "softshadows.io", "softshadows.metrics", "softshadows.cli"} <= set(MODULES)


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples_run(name):
    module = importlib.import_module(name)
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    assert result.failed == 0, result


def test_every_public_function_and_class_has_an_example():
    """Each name a user imports (the package's own and each public module's, as ``__all__`` lists
    them or else its public names) shows a ``>>>`` example in its docstring."""
    import inspect

    missing = []
    for name in MODULES:
        module = importlib.import_module(name)
        for attr in getattr(module, "__all__", None) or [a for a in dir(module) if not a.startswith("_")]:
            obj = getattr(module, attr, None)
            if not (inspect.isfunction(obj) or inspect.isclass(obj)) or not obj.__module__.startswith(name):
                continue
            if ">>>" not in (inspect.getdoc(obj) or ""):
                missing.append(f"{obj.__module__}.{obj.__qualname__}")
    assert not missing, sorted(set(missing))

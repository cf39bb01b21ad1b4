"""The type stub `_core.pyi` names the very parameters the compiled module takes."""

import ast
import inspect
from pathlib import Path

import softshadows
from softshadows import _core

STUB = Path(softshadows.__file__).parent / "_core.pyi"


def stub_functions():
    tree = ast.parse(STUB.read_text())
    return {node.name: [a.arg for a in node.args.args] for node in tree.body if isinstance(node, ast.FunctionDef)}


def test_every_module_function_is_stubbed_with_its_parameters():
    stubbed = stub_functions()
    compiled = {name for name, obj in vars(_core).items() if inspect.isbuiltin(obj)}
    assert compiled == set(stubbed)
    for name in compiled:
        signature = inspect.signature(getattr(_core, name))
        assert list(signature.parameters) == stubbed[name], name

"""The stub file ``softshadows/_core.pyi`` matches the compiled extension (mypy's stubtest):
every function and class of the binary is in the stub with the binary's parameters, and the stub
names nothing the binary lacks."""

import subprocess
import sys


def test_stub_matches_the_binary(tmp_path):
    # Run from an empty folder, so the installed package is what gets checked.
    result = subprocess.run(
        [sys.executable, "-m", "mypy.stubtest", "softshadows._core"],
        cwd=tmp_path, capture_output=True, text=True, timeout=300,
    )
    assert result.returncode == 0, result.stdout[-4000:] + result.stderr[-2000:]

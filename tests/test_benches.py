"""Every benchmark script starts: its imports resolve (the scripts share helpers through
``bench/shadow_rays.py``, and a renamed helper once broke four of them silently) and its options
parse."""

import subprocess
import sys
from pathlib import Path

import pytest

BENCH = Path(__file__).resolve().parents[1] / "bench"


@pytest.mark.parametrize("script", sorted(p.name for p in BENCH.glob("*.py")))
def test_every_bench_script_starts_and_documents_its_options(script):
    done = subprocess.run([sys.executable, str(BENCH / script), "--help"], capture_output=True, text=True,
                          cwd=BENCH, timeout=300)
    assert done.returncode == 0, done.stderr
    assert "usage:" in done.stdout

"""scripts/gpu_check.sh, the GPU backend's check on a real GPU: it refuses any adapter but an
NVIDIA GPU, saying which one it found and how to run it; and, told to run anyway, it runs the
parity tests and the GPU benchmark and writes its report (here on Mesa's lavapipe)."""

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

import softshadows as ss

SCRIPT = Path(__file__).resolve().parent.parent / "scripts" / "gpu_check.sh"

#: The script's switches at their defaults, whatever this process's environment says.
DEFAULTS = {"SOFTSHADOWS_GPU_CHECK_ANY_ADAPTER": "0", "SOFTSHADOWS_GPU_CHECK_CARGO": "1"}

pytestmark = [
    pytest.mark.gpu,
    pytest.mark.skipif(shutil.which("bash") is None or sys.platform == "win32", reason="scripts/gpu_check.sh is a bash script"),
]


@pytest.fixture(scope="module")
def adapter():
    try:
        info = ss.gpu_info()
    except RuntimeError as error:
        pytest.skip(f"no GPU adapter: {error}")
    return info


@pytest.fixture
def other_adapter(adapter):
    if "nvidia" in f"{adapter['name']} {adapter['driver']}".lower():
        pytest.skip(f"an NVIDIA adapter is here ({adapter['name']}): the script runs, so its refusal cannot be seen")
    return adapter


def check(tmp_path, *args, **env):
    return subprocess.run(
        ["bash", str(SCRIPT), "--out", str(tmp_path / "out"), *args],
        capture_output=True, text=True, env={**os.environ, "PYTHON": sys.executable, **DEFAULTS, **env},
    )


def test_another_adapter_is_refused_by_name_with_what_to_do(tmp_path, other_adapter):
    adapter = other_adapter
    done = check(tmp_path)
    assert done.returncode == 3, done.stderr
    assert f"no NVIDIA GPU adapter; found {adapter['name']} ({adapter['device_type']}" in done.stderr
    assert "nvidia-smi" in done.stderr and "SOFTSHADOWS_GPU_CHECK_ANY_ADAPTER=1" in done.stderr
    assert not (tmp_path / "out" / "report.md").exists()


def test_an_unknown_argument_is_named(tmp_path):
    done = check(tmp_path, "--sise", "8")
    assert done.returncode == 2 and "unknown argument --sise" in done.stderr


@pytest.mark.slow
def test_told_to_run_anyway_it_runs_every_step_and_reports(tmp_path, adapter):
    done = check(tmp_path, "--size", "32", "--repeat", "1",
                 SOFTSHADOWS_GPU_CHECK_ANY_ADAPTER="1", SOFTSHADOWS_GPU_CHECK_CARGO="0")
    assert done.returncode == 0, done.stdout + done.stderr
    out = tmp_path / "out"
    assert json.loads((out / "adapter.json").read_text())["name"] == adapter["name"]
    report = (out / "report.md").read_text()
    assert "verdict: every step passed" in report and " passed" in report
    for method in ("vwss", "cssm", "shadow_map", "pcss", "mvr", "alias_free"):
        assert f"{method:>10}     gpu" in report, method

"""The ``softshadows`` command line: --version, --help with defaults, usage errors for bad names
and numbers (before anything runs), and --latex. The runs themselves are in test_demo.py.

The last tests are the GPU probe's (gpu.py): it must not leave libwayland's XDG_RUNTIME_DIR
complaint on stderr of headless machines, where the command line runs in logs and CI."""

import os
import stat
import subprocess
import sys
import textwrap

import numpy as np
import pandas as pd
import pytest

import softshadows as ss
from softshadows import cli, evaluation, gpu


def usage_error(capsys, argv) -> str:
    """The stderr of a command that argparse refuses (exit status 2)."""
    with pytest.raises(SystemExit) as done:
        cli.main(argv)
    assert done.value.code == 2
    err = capsys.readouterr().err
    assert err.startswith("usage: softshadows") and "Traceback" not in err
    return err


def test_version(capsys):
    with pytest.raises(SystemExit) as done:
        cli.main(["--version"])
    assert done.value.code == 0 and capsys.readouterr().out == f"softshadows {ss.__version__}\n"


@pytest.mark.parametrize(
    "command, shown",
    [
        ("demo", ["--size SIZE           image width and height in pixels (default: 256)", "(default: columns)", "(default: demo)",
                  "(default: 1024)"]),
        ("evaluate", ["(default: 128)", "default columns, or none with --mesh", "(default: rect)", "(default: evaluation)", "(default: 4096)"]),
        ("reproduce", ["(default: fast)", "(default: claims)"]),
    ],
)
def test_help_shows_the_defaults(capsys, command, shown):
    with pytest.raises(SystemExit):
        cli.main([command, "--help"])
    text = " ".join(capsys.readouterr().out.split())  # argparse wraps to the terminal's width
    for default in shown:
        assert " ".join(default.split()) in text
    assert "(default: None)" not in text and "(default: False)" not in text


@pytest.mark.parametrize(
    "argv, message, choice",
    [
        (["demo", "--scene", "column"], "argument --scene: invalid choice: 'column'", "'columns'"),
        (["evaluate", "--methods", "ray_traced,ray_trace"], "argument --methods: unknown method 'ray_trace'; choose from", "pcss"),
        (["evaluate", "--scenes", "column"], "argument --scenes: unknown scene 'column'; choose from", "fence"),
        (["evaluate", "--lights", "area"], "argument --lights: unknown light 'area'; choose from", "ellipsoid"),
        (["evaluate", "--lights", ","], "argument --lights: expected comma-separated light names from", "rect"),
        (["reproduce", "--papers", "sintorn"], "argument --papers: unknown paper 'sintorn'; choose from", "sintorn08"),
        (["reproduce", "--ids", "annen08.nope"], "argument --ids: unknown claim id 'annen08.nope'; choose from",
         "annen08.closer_than_pcss"),
        (["reproduce", "--papers", "forest09", "--ids", "annen08.closer_than_pcss"],
         "--ids: annen08.closer_than_pcss not among the claims of --papers forest09", "forest09"),
        (["demo", "--size", "0"], "argument --size: expected a positive integer, got '0'", ""),
        (["evaluate", "--reference-samples", "many"], "argument --reference-samples: expected a positive integer, got 'many'", ""),
    ],
)
def test_bad_names_and_numbers_are_usage_errors_listing_the_choices(capsys, monkeypatch, tmp_path, argv, message, choice):
    def never(*args, **kwargs):
        raise AssertionError("ran despite a bad argument")

    monkeypatch.setattr(evaluation, "evaluate", never)
    monkeypatch.setattr(ss.claims, "reproduce", never)
    monkeypatch.setattr(cli, "demo", never)
    err = usage_error(capsys, [*argv, "--out", str(tmp_path / "out")])
    assert f"softshadows {argv[0]}: error: {message}" in err and choice in err.split("error:", 1)[1]
    assert not (tmp_path / "out").exists()


def test_evaluate_latex_writes_the_table(tmp_path, monkeypatch, capsys):
    ref = np.tile(np.linspace(0, 1, 8), (8, 1))
    rows = [{"scene": "columns", "light": "rect", "method": name, **ss.metrics.summary(vis, ref), "seconds": seconds, "error": None}
            for name, vis, seconds in [("ray_traced", ref, 2.0), ("pcss", np.clip(ref + 0.1, 0, 1), 0.1)]]
    calls = []
    monkeypatch.setattr(evaluation, "evaluate", lambda *args, **kwargs: calls.append((args, kwargs)) or pd.DataFrame(rows))
    out = tmp_path / "evaluation"
    assert cli.main(["evaluate", "--methods", "ray_traced, pcss", "--lights", "rect,disk", "--out", str(out), "--latex"]) == 0
    (args, kwargs), = calls
    assert args == (["columns"], ["ray_traced", "pcss"]) and kwargs["lights"] == ["rect", "disk"] and kwargs["size"] == 128
    assert (out / "results.tex").read_text() == evaluation.latex_table(pd.DataFrame(rows)) + "\n"
    assert "results.tex" in capsys.readouterr().out
    assert cli.main(["evaluate", "--out", str(tmp_path / "plain")]) == 0
    assert not (tmp_path / "plain" / "results.tex").exists()


# ----------------------------------------------------------------------------------------------
# The GPU probe (gpu.py)
# ----------------------------------------------------------------------------------------------


@pytest.fixture
def unprobed(monkeypatch):
    """gpu.py as in a fresh process, its probe recording XDG_RUNTIME_DIR instead of calling the core."""
    seen = []

    def probe():
        directory = os.environ.get("XDG_RUNTIME_DIR")
        mode = stat.S_IMODE(os.stat(directory).st_mode) if directory and os.path.isdir(directory) else None
        seen.append((directory, mode))
        return [("name", "fake"), ("backend", "vulkan"), ("device_type", "cpu"), ("driver", "fake"),
                ("max_workgroups_per_dimension", "65535"), ("max_storage_binding_bytes", "134217728"), ("timestamp_queries", "false")]

    monkeypatch.setattr(gpu, "_probed", False)
    monkeypatch.setattr(gpu._core, "gpu_info", probe)
    return seen


def test_the_first_probe_gets_a_private_runtime_dir_where_none_is_set(monkeypatch, unprobed):
    monkeypatch.delenv("XDG_RUNTIME_DIR", raising=False)
    assert gpu.gpu_info()["max_workgroups_per_dimension"] == 65535
    (directory, mode), = unprobed
    assert os.path.isabs(directory) and mode == 0o700  # as the XDG base directory specification asks
    assert "XDG_RUNTIME_DIR" not in os.environ and not os.path.exists(directory)
    gpu.gpu_info()  # the core has its context now: the environment is not touched again
    assert unprobed[1] == (None, None)


@pytest.mark.parametrize("value, kept", [("/run/user/1000", True), ("relative", False), ("", False)])
def test_a_set_runtime_dir_is_kept_and_an_invalid_one_restored(monkeypatch, unprobed, value, kept):
    monkeypatch.setenv("XDG_RUNTIME_DIR", value)
    assert gpu.resolve_backend("auto", "vwss") == "gpu"
    (directory, _), = unprobed
    assert (directory == value) is kept and os.path.isabs(directory)
    assert os.environ["XDG_RUNTIME_DIR"] == value


def test_the_cpu_backend_does_not_probe(unprobed):
    assert gpu.resolve_backend("cpu", "vwss") == "cpu" and unprobed == []


@pytest.mark.gpu
@pytest.mark.parametrize(
    "call",
    ["ss.gpu_info()",
     "s = ss.scenes.get('columns').with_size(16, 16); ss.vwss(s.scene, s.light, ss.gbuffer(s.scene, s.camera), backend='gpu', samples=4)"],
    ids=["gpu_info", "backend=gpu"],
)
def test_no_xdg_runtime_dir_complaint_on_stderr_of_a_headless_machine(monkeypatch, capfd, call):
    # A fresh process: this one's context may already exist. It writes to the captured fd 2.
    monkeypatch.delenv("XDG_RUNTIME_DIR", raising=False)
    script = textwrap.dedent(f"""
        import softshadows as ss
        try:
            {call}
        except RuntimeError:
            raise SystemExit(3)
        """)
    code = subprocess.run([sys.executable, "-c", script], timeout=300).returncode
    if code == 3:
        pytest.skip("no GPU adapter")
    err = capfd.readouterr().err
    assert code == 0 and "XDG_RUNTIME_DIR" not in err, err

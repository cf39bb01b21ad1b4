"""The demo runs end to end at a small size and writes what it promises."""

import json

import numpy as np

from softshadows import cli, io


def test_demo_writes_grid_exr_and_tables(tmp_path, monkeypatch):
    monkeypatch.setenv("SOFTSHADOWS_CACHE", str(tmp_path / "cache"))
    out = tmp_path / "demo"
    assert cli.main(["demo", "--out", str(out), "--size", "48", "--samples", "16", "--reference-samples", "64"]) == 0
    table = json.loads((out / "metrics.json").read_text())["methods"]
    assert set(table) >= {"ray_traced", "shadow_map"}
    for name, m in table.items():
        assert 0 <= m["rmse"] <= 1 and -1 <= m["ssim"] <= 1 and m["seconds"] > 0
        vis = io.read_exr(out / f"{name}.exr")
        assert vis.shape == (48, 48) and np.all((vis >= 0) & (vis <= 1))
    # ray_traced with 16 samples estimates the 64-sample reference better than hard shadows do.
    assert table["ray_traced"]["rmse"] < table["shadow_map"]["rmse"]
    assert (out / "demo.png").stat().st_size > 10_000
    assert "| ray_traced |" in (out / "metrics.md").read_text()


def test_evaluate_command_writes_the_report(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("SOFTSHADOWS_CACHE", str(tmp_path / "cache"))
    out = tmp_path / "evaluation"
    args = ["evaluate", "--scenes", "columns,fence", "--methods", "ray_traced,stsv,dcs", "--lights", "rect",
            "--size", "32", "--samples", "16", "--reference-samples", "64", "--out", str(out)]
    assert cli.main(args) == 0
    page = (out / "report.md").read_text()
    assert "## columns, rect light" in page and "## fence, rect light" in page
    # dcs refuses the perforated fence and says so; stsv takes it.
    assert "| dcs | refused:" in page and page.count("| stsv |") + page.count("| **stsv** |") == 2
    for name in ("results.csv", "pareto.png", "columns_rect.png", "fence_rect.png"):
        assert (out / name).stat().st_size > 0
    assert "wrote" in capsys.readouterr().out

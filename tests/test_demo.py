"""The demo runs end to end at a small size and writes what it promises."""

import json
import math

import numpy as np
import pytest

from softshadows import cli, io, metrics


def _strict(constant):
    raise ValueError(f"metrics.json holds {constant}, which is not JSON")


def test_demo_writes_grid_exr_and_tables(tmp_path, monkeypatch):
    monkeypatch.setenv("SOFTSHADOWS_CACHE", str(tmp_path / "cache"))
    out = tmp_path / "demo"
    assert cli.main(["demo", "--out", str(out), "--size", "48", "--samples", "16", "--reference-samples", "64"]) == 0
    table = json.loads((out / "metrics.json").read_text(), parse_constant=_strict)["methods"]
    assert set(table) >= {"ray_traced", "shadow_map"}
    for name, m in table.items():
        assert set(m) == {*metrics.SUMMARY_KEYS, "seconds"}
        assert 0 <= m["rmse"] <= 1 and -1 <= m["ssim"] <= 1 and m["seconds"] > 0
        assert m["psnr"] == pytest.approx(-20 * math.log10(m["rmse"]))
        vis = io.read_exr(out / f"{name}.exr")
        assert vis.shape == (48, 48) and np.all((vis >= 0) & (vis <= 1))
    # ray_traced with 16 samples estimates the 64-sample reference better than hard shadows do,
    # and the hard shadow's error is in the penumbra, which it does not have.
    assert table["ray_traced"]["rmse"] < table["shadow_map"]["rmse"]
    assert table["shadow_map"]["rmse.penumbra"] > max(table["shadow_map"]["rmse.umbra"], table["shadow_map"]["rmse.lit"])
    assert (out / "demo.png").stat().st_size > 10_000
    page = (out / "metrics.md").read_text()
    assert "| method | RMSE | PSNR (dB) | SSIM | FLIP | RMSE umbra | RMSE penumbra | RMSE lit | seconds |" in page
    assert "| ray_traced |" in page


@pytest.mark.parametrize(
    "options, name",
    [({"scene": "column"}, "scene"), ({"size": 0}, "size"), ({"samples": 2.5}, "samples"), ({"reference_samples": -1}, "reference_samples")],
)
def test_demo_checks_its_arguments_before_it_creates_the_folder(tmp_path, options, name):
    out = tmp_path / "demo"
    with pytest.raises(ValueError, match=f"^{name}:"):
        cli.demo(out, **options)
    assert not out.exists()


def test_demo_command_refuses_a_bad_scene_before_it_creates_the_folder(tmp_path, capsys):
    out = tmp_path / "demo"
    with pytest.raises(SystemExit) as done:
        cli.main(["demo", "--out", str(out), "--scene", "column"])
    assert done.value.code == 2 and not out.exists()
    err = capsys.readouterr().err
    assert "argument --scene: invalid choice: 'column'" in err and "'columns'" in err and "Traceback" not in err


def test_evaluate_command_writes_the_report(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("SOFTSHADOWS_CACHE", str(tmp_path / "cache"))
    out = tmp_path / "evaluation"
    args = ["evaluate", "--scenes", "columns,fence", "--methods", "ray_traced,stsv,dcs", "--lights", "rect",
            "--size", "32", "--samples", "16", "--reference-samples", "64", "--out", str(out), "--latex"]
    assert cli.main(args) == 0
    page = (out / "report.md").read_text()
    assert "## columns, rect light" in page and "## fence, rect light" in page
    # dcs refuses the perforated fence and says so; stsv takes it.
    assert "| dcs | refused:" in page and page.count("| stsv |") + page.count("| **stsv** |") == 2
    for name in ("results.csv", "results.tex", "pareto.png", "columns_rect.png", "fence_rect.png"):
        assert (out / name).stat().st_size > 0
    assert "stsv" in (out / "results.tex").read_text()
    assert "wrote" in capsys.readouterr().out


@pytest.fixture
def mesh_file(tmp_path):
    trimesh = pytest.importorskip("trimesh")
    path = tmp_path / "statue.glb"
    trimesh.Scene({"statue": trimesh.creation.cylinder(radius=0.2, height=1.0, sections=16)}).export(path)
    return path


def test_demo_runs_on_a_mesh_file_of_your_own(tmp_path, monkeypatch, mesh_file):
    monkeypatch.setenv("SOFTSHADOWS_CACHE", str(tmp_path / "cache"))
    out = tmp_path / "demo"
    argv = ["demo", "--mesh", str(mesh_file), "--light", "disk", "--out", str(out), "--size", "32", "--samples", "8",
            "--reference-samples", "32"]
    assert cli.main(argv) == 0
    meta = json.loads((out / "metrics.json").read_text(), parse_constant=_strict)
    assert meta["setup"]["scene"] == "statue" and meta["setup"]["light"] == "disk"
    assert meta["methods"]["ray_traced"]["rmse"] < meta["methods"]["shadow_map"]["rmse"]


def test_evaluate_runs_on_a_mesh_file_and_scenes_lists_the_built_in_ones(tmp_path, monkeypatch, capsys, mesh_file):
    monkeypatch.setenv("SOFTSHADOWS_CACHE", str(tmp_path / "cache"))
    out = tmp_path / "evaluation"
    argv = ["evaluate", "--mesh", str(mesh_file), "--methods", "ray_traced,pcss", "--lights", "rect,sphere", "--size", "32",
            "--samples", "8", "--reference-samples", "32", "--out", str(out)]
    assert cli.main(argv) == 0
    table = capsys.readouterr().out
    assert table.count("statue") == 4 and "columns" not in table and (out / "report.md").exists()
    assert cli.main(["scenes"]) == 0
    listing = capsys.readouterr().out
    assert listing.splitlines()[0].startswith("ground_sphere") and "lights: rect, disk, sphere" in listing


def test_a_mesh_that_is_not_a_file_is_a_usage_error(tmp_path, capsys):
    with pytest.raises(SystemExit):
        cli.main(["demo", "--mesh", str(tmp_path / "nothing.glb"), "--out", str(tmp_path / "out")])
    assert "does not exist" in capsys.readouterr().err and not (tmp_path / "out").exists()

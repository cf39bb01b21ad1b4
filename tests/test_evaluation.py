"""The evaluation suite's engine: rows, refusals, the Pareto front, the report and the cache."""

import numpy as np
import pandas as pd
import pytest

import softshadows as ss
from softshadows import evaluation, reference


@pytest.fixture
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("SOFTSHADOWS_CACHE", str(tmp_path / "cache"))
    return tmp_path / "cache"


def test_rows_per_scene_light_and_method_with_refusals(cache):
    frame = ss.evaluate(["columns"], ["ray_traced", "shadow_map", "backprojection"], lights=("rect", "sphere"), size=32,
                        reference_samples=64, progress=False)
    assert len(frame) == 6 and set(frame["method"]) == {"ray_traced", "shadow_map", "backprojection"}
    refused = frame[frame["error"].notna()]
    assert list(zip(refused["light"], refused["method"])) == [("sphere", "backprojection")]
    assert "planar" in refused["error"].iloc[0] and refused["rmse"].isna().all()
    done = frame[frame["error"].isna()]
    assert done["rmse"].between(0, 1).all() and done["ssim"].between(-1, 1).all() and (done["seconds"] > 0).all()
    # Each method's own stats come along, and the exact oracle beats the hard shadow map.
    assert done.loc[done["method"] == "ray_traced", "stats.rays"].gt(0).all()
    for light in ("rect", "sphere"):
        rows = done[done["light"] == light].set_index("method")
        assert rows.loc["ray_traced", "rmse"] < rows.loc["shadow_map", "rmse"]


def test_unknown_methods_are_refused():
    with pytest.raises(ValueError, match="methods"):
        ss.evaluate(["columns"], ["ray_trace"], progress=False)


def test_pareto_front():
    frame = pd.DataFrame({"seconds": [1.0, 2.0, 0.5, 3.0, 1.0, np.nan], "rmse": [0.1, 0.05, 0.3, 0.05, 0.2, 0.0]})
    assert evaluation.pareto_front(frame).tolist() == [True, True, True, False, False, False]


def test_report_and_cached_references(cache, tmp_path, monkeypatch):
    kwargs = dict(size=32, reference_samples=64, progress=False, keep_images=True)
    frame = ss.evaluate(["columns"], ["ray_traced", "pcss"], **kwargs)
    page = evaluation.report(frame, tmp_path / "report")
    text = page.read_text()
    assert "| **ray_traced** |" in text or "| **pcss** |" in text
    for name in ("results.csv", "pareto.png", "columns_rect.png"):
        assert (tmp_path / "report" / name).stat().st_size > 0
    # A second run reads the references from the cache: Mitsuba traces nothing again...
    calls = []
    real = reference._Tracer
    monkeypatch.setattr(reference, "_Tracer", lambda *a: calls.append(1) or real(*a))
    again = ss.evaluate(["columns"], ["ray_traced", "pcss"], **kwargs)
    assert not calls and np.allclose(again["rmse"], frame["rmse"])
    # ... until an input changes.
    ss.evaluate(["columns"], ["pcss"], **{**kwargs, "reference_samples": 65})
    assert calls


def test_readme_table_is_rewritten_between_its_markers(tmp_path):
    frame = pd.DataFrame({"scene": ["a", "a", "b", "b"], "light": ["rect"] * 4, "method": ["x", "y", "x", "y"],
                          "rmse": [0.1, 0.2, np.nan, 0.3], "ssim": [0.9, 0.8, np.nan, 0.7], "seconds": [1.0, 2.0, np.nan, 3.0]})
    readme = tmp_path / "README.md"
    readme.write_text("intro\n<!-- evaluation:start -->\nold table\n<!-- evaluation:end -->\noutro\n")
    evaluation.update_readme(frame, readme)
    text = readme.read_text()
    assert "old table" not in text and text.startswith("intro\n") and text.endswith("outro\n")
    assert "| x | 0.1000, 0.900, 1.000 | - |" in text and "| y | 0.2000, 0.800, 2.000 | 0.3000, 0.700, 3.000 |" in text
    plain = tmp_path / "plain.md"
    plain.write_text("no markers\n")
    with pytest.raises(ValueError, match="path"):
        evaluation.update_readme(frame, plain)


def test_sweep_gives_the_same_records_on_a_process_pool_and_on_dask(cache):
    distributed = pytest.importorskip("distributed", reason='needs pip install "softshadows[test]" (dask.distributed)')
    grid = {"budget": [5, 12], "extend": [True, False]}
    local = ss.sweep("backprojection", grid, size=32, reference_samples=64, progress=False)
    assert len(local) == 4 and list(local["budget"]) == [5, 5, 12, 12] and local["rmse"].between(0, 1).all()
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        with distributed.Client(cluster) as client:
            remote = ss.sweep("backprojection", grid, size=32, reference_samples=64, progress=False, executor=client.get_executor())
    columns = [c for c in local.columns if c != "seconds"]
    pd.testing.assert_frame_equal(local[columns], remote[columns])


def test_sweep_parameters_reach_the_setup_and_the_method(cache):
    from concurrent.futures import ThreadPoolExecutor

    with ThreadPoolExecutor(1) as pool:
        frame = ss.sweep("ray_traced", {"samples": [8, 128]}, size=32, reference_samples=256, progress=False, executor=pool)
    assert list(frame["samples"]) == [8, 128] and frame["rmse"].iloc[1] < frame["rmse"].iloc[0]
    with pytest.raises(ValueError, match="method"):
        ss.sweep("ray_trace", {"samples": [8]})


def test_shaded_images_against_the_path_traced_reference(cache):
    frame = ss.evaluate(["columns"], ["ray_traced", "shadow_map"], size=32, reference_samples=64, shaded=True, render_spp=16,
                        progress=False, repeat=1)
    assert frame["shaded.rmse"].gt(0).all() and frame["shaded.flip"].between(0, 1).all()

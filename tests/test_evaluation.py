"""The evaluation suite's engine: rows, refusals, the Pareto front, the report and the cache."""

import io
from concurrent.futures import ThreadPoolExecutor
import math

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
    assert "planar" in refused["error"].iloc[0] and refused[list(ss.metrics.SUMMARY_KEYS)].isna().all(axis=None)
    done = frame[frame["error"].isna()]
    assert done["rmse"].between(0, 1).all() and done["ssim"].between(-1, 1).all() and (done["seconds"] > 0).all()
    assert np.allclose(done["psnr"], -20 * np.log10(done["rmse"]))
    # The columns' scene has all three regions under both lights, and hard shadows err in the penumbra most.
    assert done[["rmse.umbra", "rmse.penumbra", "rmse.lit"]].notna().all(axis=None)
    hard = done[done["method"] == "shadow_map"]
    assert (hard["rmse.penumbra"] > hard["rmse.lit"]).all() and (hard["rmse.penumbra"] > hard["rmse.umbra"]).all()
    # Each method's own stats come along, and the exact oracle beats the hard shadow map.
    assert done.loc[done["method"] == "ray_traced", "stats.rays"].gt(0).all()
    for light in ("rect", "sphere"):
        rows = done[done["light"] == light].set_index("method")
        assert rows.loc["ray_traced", "rmse"] < rows.loc["shadow_map", "rmse"]


def test_a_refusal_is_recorded_and_a_bug_stops_the_evaluation(cache):
    """Only :class:`softshadows.UnsupportedSetup` is a method's refusal of a setup; any other
    error, a ValueError from a bug included, is raised, not written into the table."""

    def rect_only(scene, light, receivers, *, samples):
        if not isinstance(light, ss.RectLight):
            raise ss.UnsupportedSetup("light: rect_only takes a RectLight")
        return ss.ray_traced(scene, light, receivers, samples=samples)

    def buggy(scene, light, receivers, *, samples):
        raise ValueError("an index out of range in the user's own code")

    kwargs = dict(lights=("rect", "sphere"), size=16, reference_samples=16, progress=False)
    frame = ss.evaluate(["columns"], {"rect_only": rect_only}, **kwargs)
    assert frame.set_index("light")["error"].isna().tolist() == [True, False]
    assert "takes a RectLight" in frame.set_index("light").loc["sphere", "error"]
    with pytest.raises(ValueError, match="the user's own code"):
        ss.evaluate(["columns"], {"buggy": buggy}, **kwargs)
    with pytest.raises(ValueError, match="the user's own code"):
        with ThreadPoolExecutor(1) as pool:
            ss.sweep(buggy, {"samples": [4]}, size=16, reference_samples=16, executor=pool, progress=False)


def test_refusals_are_unsupported_setups_and_bad_input_is_not():
    setup = ss.scenes.get("columns", width=8, height=8)
    gb = ss.gbuffer(setup.scene, setup.camera)
    with pytest.raises(ss.UnsupportedSetup, match="planar"):
        ss.backprojection(setup.scene, ss.SphereLight((0, 4, 0), 0.5), gb)
    with pytest.raises(ss.UnsupportedSetup, match="emission"):
        ss.pcss(setup.scene, ss.RectLight((0, 4, 0), (0.5, 0, 0), (0, 0, 0.5), emission=np.ones((2, 2))), gb)
    with pytest.raises(ValueError, match="resolution") as bad:
        ss.shadow_map(setup.scene, setup.light, gb, resolution=0)
    assert not isinstance(bad.value, ss.UnsupportedSetup)
    assert issubclass(ss.UnsupportedSetup, ValueError)


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
    real = reference._tracer
    monkeypatch.setattr(reference, "_tracer", lambda *a: calls.append(1) or real(*a))
    again = ss.evaluate(["columns"], ["ray_traced", "pcss"], **kwargs)
    assert not calls and np.allclose(again["rmse"], frame["rmse"])
    # ... until an input changes.
    ss.evaluate(["columns"], ["pcss"], **{**kwargs, "reference_samples": 65})
    assert calls


class _Terminal(io.StringIO):
    """A stderr that says it is a terminal, as tqdm asks before it draws."""

    def isatty(self):
        return True


def test_one_progress_bar_on_a_terminal_and_none_in_a_log(cache, monkeypatch, capsys):
    run = dict(size=16, reference_samples=16, repeat=1)
    ss.evaluate(["columns"], ["shadow_map"], **run)  # pytest's captured stderr is no terminal
    assert capsys.readouterr().err == ""
    terminal = _Terminal()
    monkeypatch.setattr("sys.stderr", terminal)
    ss.evaluate(["columns"], ["shadow_map"], lights=("disk",), **run)  # a new reference: Mitsuba traces
    drawn = terminal.getvalue()
    assert "columns/disk" in drawn and "mitsuba_visibility" not in drawn


def _frame():
    """Rows like evaluate()'s on an 8x8 ramp: an exact method, a hard one, a refusal, two setups."""
    ref = np.tile(np.linspace(0, 1, 8), (8, 1))
    rows = []
    for scene in ("ramp", "other"):
        for name, vis, seconds in [("ray_traced", ref, 2.0), ("shadow_map", 1.0 * (ref > 0.5), 0.1)]:
            rows.append({"scene": scene, "light": "rect", "method": name, **ss.metrics.summary(vis, ref), "seconds": seconds,
                         "error": None})
    rows.append({"scene": "ramp", "light": "rect", "method": "dcs", **dict.fromkeys(ss.metrics.SUMMARY_KEYS, np.nan),
                 "seconds": np.nan, "error": "dcs: refused"})
    return pd.DataFrame(rows)


def test_report_shows_psnr_and_the_region_split_and_writes_latex_on_request(tmp_path):
    frame = _frame()
    page = evaluation.report(frame, tmp_path / "plain")
    assert not (tmp_path / "plain" / "results.tex").exists()
    text = page.read_text()
    assert "| method | RMSE | PSNR (dB) | SSIM | FLIP | RMSE umbra | RMSE penumbra | RMSE lit | seconds |" in text
    hard = frame.iloc[1]
    assert (f"| **shadow_map** | {hard['rmse']:.4f} | {hard['psnr']:.2f} | {hard['ssim']:.4f} | {hard['flip']:.4f} | "
            f"0.0000 | {hard['rmse.penumbra']:.4f} | 0.0000 | 0.100 |") in text
    assert "| **ray_traced** | 0.0000 | inf |" in text and "| dcs | refused: dcs: refused |" in text
    evaluation.report(frame, tmp_path / "paper", latex=True)
    tex = (tmp_path / "paper" / "results.tex").read_text()
    assert tex == evaluation.latex_table(frame) + "\n"
    lines = tex.splitlines()
    assert lines[0] == r"\begin{tabular}{lllrrrrrrrr}" and lines[1] == r"\toprule" and lines[-1] == r"\end{tabular}"
    assert r"ramp & rect & \bfseries ray\_traced & 0.0000 & $\infty$ & 1.0000 &" in tex
    assert r"ramp & rect & dcs & -- & -- & -- & -- & -- & -- & -- & -- \\" in tex
    assert len([line for line in lines if line.endswith(r"\\")]) == 1 + len(frame)


def test_latex_table_names_missing_columns():
    with pytest.raises(ValueError, match=r"frame: missing columns \['psnr'"):
        evaluation.latex_table(_frame().drop(columns=["psnr"]))


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
    columns = [c for c in local.columns if c != "seconds" and not c.endswith("_seconds")]  # wall times differ
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


def my_shadows(scene, light, receivers, *, samples):
    """A user's method: here the oracle itself, so its rows must equal ray_traced's."""
    return ss.ray_traced(scene, light, receivers, samples=samples)


def user_setup():
    trimesh = pytest.importorskip("trimesh")
    box = ss.Scene.from_trimesh(trimesh.creation.box(extents=(0.6, 0.6, 0.6)))
    return ss.scenes.stage(box, light="disk", width=32, height=32, name="box")


def test_evaluate_takes_a_user_setup_a_mesh_file_and_a_user_callable(cache, tmp_path):
    import trimesh

    path = tmp_path / "crate.glb"
    trimesh.Scene({"crate": trimesh.creation.box(extents=(0.5, 1.0, 0.5))}).export(path)
    frame = ss.evaluate([user_setup(), path], ["ray_traced", my_shadows], lights=("rect", "sphere"), size=32,
                        reference_samples=64, progress=False, repeat=1)
    # The Setup runs under its own light, the file under each kind asked for.
    assert sorted(zip(frame["scene"], frame["light"], frame["method"])) == sorted(
        [("box", "disk", "ray_traced"), ("box", "disk", "my_shadows")]
        + [("crate", k, m) for k in ("rect", "sphere") for m in ("ray_traced", "my_shadows")])
    assert frame["error"].isna().all()
    rows = frame.set_index(["scene", "light", "method"])
    for scene, light in [("box", "disk"), ("crate", "rect"), ("crate", "sphere")]:
        assert rows.loc[(scene, light, "my_shadows"), "rmse"] == rows.loc[(scene, light, "ray_traced"), "rmse"]
    with pytest.raises(ValueError, match="needs a name of its own"):
        ss.evaluate(["columns"], [lambda *a, **k: None, lambda *a, **k: None], progress=False)
    with pytest.raises(ValueError, match="scenes: unknown"):
        ss.evaluate([tmp_path / "missing.glb"], progress=False)


def test_sweep_runs_a_user_callable_on_a_user_setup_in_a_process_pool_and_on_dask(cache):
    import functools

    distributed = pytest.importorskip("distributed", reason='needs pip install "softshadows[test]" (dask.distributed)')
    method = functools.partial(ss.ray_traced, pattern="poisson")
    grid = {"rotate": [None, "per_receiver"]}
    options = dict(scenes=[user_setup()], size=32, reference_samples=64, progress=False, name="rt")
    local = ss.sweep(method, grid, **options)
    assert list(zip(local["scene"], local["light"], local["method"])) == [("box", "disk", "rt")] * 2
    assert local["error"].isna().all() and local["rmse"].between(0, 1).all()
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        with distributed.Client(cluster) as client:
            remote = ss.sweep(method, grid, executor=client.get_executor(), **options)
    columns = [c for c in local.columns if c != "seconds" and not c.endswith("_seconds")]  # wall times differ
    pd.testing.assert_frame_equal(local[columns], remote[columns])


def test_a_registered_method_is_known_by_name_and_the_command_line_imports_one(cache):
    from softshadows import cli

    evaluation.register_method("mine", my_shadows)
    try:
        frame = ss.evaluate(["columns"], ["ray_traced", "mine"], size=16, reference_samples=16, progress=False, repeat=1)
        assert list(frame["method"]) == ["ray_traced", "mine"] and frame["rmse"].iloc[0] == frame["rmse"].iloc[1]
        assert cli._method_list("pcss, mine") == ["pcss", "mine"]
    finally:
        del evaluation.REGISTERED["mine"]
    assert cli._method_list(f"pcss, {__name__}:my_shadows") == ["pcss", my_shadows]
    with pytest.raises(ValueError, match="name: expected a new method name"):
        evaluation.register_method("pcss", my_shadows)

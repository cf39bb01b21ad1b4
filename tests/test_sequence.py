"""Shadows over time: sequences of set-ups, their evaluation frame by frame, the temporal metrics
and the animated comparison."""

import io
import multiprocessing
from concurrent.futures import ProcessPoolExecutor

import numpy as np
import pandas as pd
import pytest

import softshadows as ss
from softshadows import metrics, plot
from softshadows.evaluation import OverTime
from softshadows.scenes import Orbit, Slide


@pytest.fixture
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("SOFTSHADOWS_CACHE", str(tmp_path / "cache"))
    return tmp_path / "cache"


@pytest.fixture(scope="module")
def columns():
    return ss.scenes.get("columns", width=32, height=32)


def _turn(degrees, axis=(0.0, 1.0, 0.0)):
    """A rigid 4 x 4 turn about an axis through the origin, made independently of Orbit (by
    scipy-free Euler-Rodrigues quaternions)."""
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    half = np.radians(degrees) / 2
    w, (x, y, z) = np.cos(half), np.sin(half) * a
    m = np.eye(4)
    m[:3, :3] = [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                 [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                 [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]
    return m


# --- moving things: lights, meshes and cameras -------------------------------------------------

@pytest.mark.parametrize("light", [
    ss.PointLight((1, 4, 0)),
    ss.RectLight((1, 4, 0), (0.5, 0, 0), (0, 0, 0.25), emission=np.ones((2, 3))),
    ss.DiskLight((1, 4, 0), (0, -1, 0.2), 0.3),
    ss.SphereLight((1, 4, 0), 0.4),
    ss.EllipsoidLight((1, 4, 0), [[0.5, 0, 0], [0, 0.2, 0], [0, 0, 0.1]]),
], ids=lambda light: light.kind)
def test_a_moved_light_keeps_its_shape_and_turns_with_its_samples(light):
    move = _turn(70, axis=(1, 2, 0.5))
    move[:3, 3] = (0.3, -1.0, 2.0)
    moved = light.transformed(move)
    assert type(moved) is type(light)
    samples = moved.samples(64, pattern="halton", seed=3)
    back = (samples - move[:3, 3]) @ move[:3, :3]  # the moved light's samples carried back
    if light.kind in ("point", "rect", "ellipsoid"):  # patterns laid out along the light's own axes
        assert np.allclose(samples, light.samples(64, pattern="halton", seed=3) @ move[:3, :3].T + move[:3, 3], atol=1e-5)
    else:  # a disk's and a sphere's patterns keep their orientation in the world: on the light, still
        distance = np.linalg.norm(back - light.center, axis=1)
        assert (distance <= light.radius * (1 + 1e-5)).all() and distance.max() > 0.5 * light.radius
        if light.kind == "disk":
            assert np.allclose((back - light.center) @ light.normal, 0, atol=1e-5)
    assert np.isclose(moved.extent, light.extent, rtol=1e-5)
    if light.kind in ("rect", "disk"):
        assert np.allclose(moved.normal, move[:3, :3] @ light.normal, atol=1e-6) and moved.area == pytest.approx(light.area)
        assert np.array_equal(moved.emission, light.emission) if light.emission is not None else moved.emission is None


def test_meshes_and_cameras_move_rigidly_and_a_scale_is_refused():
    move = _turn(90)
    move[:3, 3] = (0, 1, 0)
    mesh = ss.Mesh([[1, 0, 0], [2, 0, 0], [1, 0, 1]], [[0, 1, 2]], uvs=[[0, 0], [1, 0], [0, 1]], alpha=[[1.0]], closed=False,
                   name="card")
    moved = mesh.transformed(move)
    assert np.allclose(moved.vertices, [[0, 1, -1], [0, 1, -2], [1, 1, -1]], atol=1e-6)
    assert moved.name == "card" and np.array_equal(moved.faces, mesh.faces) and np.array_equal(moved.alpha, mesh.alpha)
    camera = ss.Camera.look_at((0, 2, 5), (0, 0, 0), width=16, height=12).transformed(move)
    assert np.allclose(camera.eye, [5, 3, 0], atol=1e-6) and np.allclose(camera.target, [0, 1, 0], atol=1e-6)
    assert (camera.width, camera.height) == (16, 12)
    for bad in (np.diag([2.0, 2.0, 2.0, 1.0]), np.diag([1.0, 1.0, -1.0, 1.0]), np.ones((3, 3))):
        with pytest.raises(ValueError, match="matrix"):
            mesh.transformed(bad)


# --- sequences ---------------------------------------------------------------------------------

def test_a_light_orbit_turns_the_light_about_the_occluders_keeping_it_aimed_at_them(columns):
    seq = ss.sequence(columns, frames=7, light_path=Orbit(90))
    pivot = columns.occluder_bounds.mean(axis=0)
    offsets = np.array([s.light.center - pivot for s in seq], dtype=np.float64)
    angles = np.degrees(np.arctan2(offsets[:, 0], offsets[:, 2]))
    assert np.allclose(np.diff(angles), 15.0, atol=1e-3)  # 90 degrees in 6 equal steps, counter-clockwise
    assert np.allclose(offsets[:, 1], offsets[0, 1], atol=1e-5)
    assert np.allclose(np.linalg.norm(offsets, axis=1), np.linalg.norm(offsets[0]), rtol=1e-6)
    # A rect light staged to face the occluders still faces them.
    facing = [float(np.dot(s.light.normal, -o / np.linalg.norm(o))) for s, o in zip(seq, offsets)]
    assert np.allclose(facing, facing[0], atol=1e-5)
    # Nothing else moves: the same scene and camera objects in every frame.
    assert all(s.scene is columns.scene and s.camera is columns.camera for s in seq)
    assert "light Orbit(degrees=90.0" in seq.description and seq.name == "columns"


def test_paths_as_positions_moving_meshes_and_a_camera_orbit(columns):
    positions = columns.light.center + np.outer(np.linspace(0, 1, 4), [1.0, 0.0, 0.0])
    seq = ss.sequence(columns, frames=4, light_path=positions, camera_path=Orbit(-30), moving={1: Slide((0, 0, 0.6))},
                      name="busy")
    assert np.allclose([s.light.center for s in seq], positions, atol=1e-5)
    assert np.allclose(seq[2].light.u, columns.light.u)  # carried, not turned
    shift = seq[3].scene.meshes[1].vertices - columns.scene.meshes[1].vertices
    assert np.allclose(shift, [0, 0, 0.6], atol=1e-5) and seq[3].scene is not columns.scene
    assert seq[3].scene.meshes[0] is columns.scene.meshes[0]  # the ground stays
    eye = [np.linalg.norm(s.camera.eye - columns.camera.target) for s in seq]
    assert np.allclose(eye, eye[0], rtol=1e-5) and np.allclose(seq[3].camera.target, columns.camera.target, atol=1e-5)
    assert seq.name == "busy" and len(seq) == 4 and "mesh columns Slide" in seq.description
    assert len(ss.sequence(columns, frames=1, light_path=Orbit(10))) == 1


def test_bad_sequences_are_refused_naming_the_argument(columns):
    with pytest.raises(ValueError, match="setup: expected a softshadows.scenes.Setup"):
        ss.sequence("columns")
    with pytest.raises(ValueError, match="frames"):
        ss.sequence(columns, frames=0)
    with pytest.raises(ValueError, match=r"light_path: expected shape \(3, 3\)"):
        ss.sequence(columns, frames=3, light_path=np.zeros((4, 3)))
    with pytest.raises(ValueError, match=r"camera_path: expected a scenes.Orbit, a scenes.Slide or positions of shape \(3, 3\)"):
        ss.sequence(columns, frames=3, camera_path="orbit")
    with pytest.raises(ValueError, match=r"moving: no single mesh 'pillars'; the scene's meshes are \['ground', 'columns'\]"):
        ss.sequence(columns, moving={"pillars": Slide((1, 0, 0))})
    with pytest.raises(ValueError, match="axis"):
        Orbit(10, axis=(0, 0, 0))


# --- the temporal metrics ----------------------------------------------------------------------

def test_temporal_metrics_match_a_pixel_by_pixel_computation():
    rng = np.random.default_rng(7)
    test, ref = rng.random((5, 6, 4)), rng.random((5, 6, 4))
    mask = rng.random((5, 6, 4)) > 0.3
    deviations, changes = [], []
    for i in range(6):
        for j in range(4):
            frames = [t for t in range(5) if mask[t, i, j]]
            if len(frames) >= 2:
                deviations.append(np.std([test[t, i, j] - ref[t, i, j] for t in frames]))
            changes += [abs((test[t, i, j] - test[t - 1, i, j]) - (ref[t, i, j] - ref[t - 1, i, j]))
                        for t in range(1, 5) if mask[t, i, j] and mask[t - 1, i, j]]
    assert metrics.temporal_std(test, ref, mask) == pytest.approx(np.mean(deviations), rel=1e-12)
    assert metrics.flicker(test, ref, mask) == pytest.approx(np.mean(changes), rel=1e-12)
    per_frame = metrics.flicker(test, ref, mask, per_frame=True)
    assert np.isnan(per_frame[0]) and per_frame.shape == (5,)
    both = mask[1:] & mask[:-1]
    weights = both.sum(axis=(1, 2))
    assert np.average(per_frame[1:], weights=weights) == pytest.approx(np.mean(changes), rel=1e-12)
    with pytest.raises(ValueError, match="F >= 2"):
        metrics.flicker(test[:1], ref[:1])
    with pytest.raises(ValueError, match="mask"):
        metrics.temporal_std(test, ref, mask[..., 0])


# --- evaluation over time ----------------------------------------------------------------------

EXACT = {"ray_traced": "ray_traced", "alias_free": "alias_free", "dcs": "dcs"}


def test_a_static_sequence_gives_exact_methods_no_temporal_error(cache, columns):
    still = ss.sequence(columns, frames=4)
    summary = ss.evaluate_sequence(still, EXACT, size=32, samples=16, reference_samples=64, options={"alias_free": {"lut": None}},
                                   progress=False)
    assert list(summary["method"]) == list(EXACT) and summary["error"].isna().all()
    assert (summary["temporal.std"] == 0).all() and (summary["temporal.flicker"] == 0).all()
    frames = summary.attrs["frames"]
    assert len(frames) == 4 * len(EXACT) and frames.groupby("method")["rmse"].nunique().eq(1).all()
    assert frames["flicker"].isna().sum() == len(EXACT) and (frames["flicker"].dropna() == 0).all()
    assert summary["rmse"].gt(0).all()  # 16 samples against the reference's 64: a steady error, not none


def test_temporal_jitter_is_the_methods_own_frame_jitter_and_converges(cache, columns):
    still = ss.sequence(columns, frames=6)
    entries = {"fixed": "ray_traced", "jittered": OverTime("ray_traced")}
    summary = ss.evaluate_sequence(still, entries, size=32, samples=8, reference_samples=256, keep_images=True,
                                   progress=False).set_index("method")
    images = summary.attrs["images"]["columns"]
    gb = ss.gbuffer(still[0].scene, still[0].camera)
    for frame in range(6):
        own = ss.ray_traced(still[frame].scene, still[frame].light, gb, samples=8, frame=frame)
        assert np.array_equal(images["jittered"][frame], own)
    assert summary.loc["fixed", "temporal.std"] == 0 and summary.loc["jittered", "temporal.std"] > 0.01
    # Jitter turns a standing error into one that averages out: the mean of the jittered frames
    # is nearer the reference than any one frame, where the fixed samples' mean is not.
    ref, mask = images["reference"][0], images["mask"][0]
    single = max(metrics.rmse(f, ref, mask) for f in images["jittered"])
    assert metrics.rmse(images["jittered"].mean(axis=0), ref, mask) < 0.7 * single
    assert metrics.rmse(images["fixed"].mean(axis=0), ref, mask) == pytest.approx(summary.loc["fixed", "rmse"], rel=1e-6)


def test_under_a_moving_light_accumulation_flickers_less_than_per_frame_samples(cache):
    setup = ss.scenes.get("columns", width=32, height=32)
    turning = ss.sequence(setup, frames=8, light_path=Orbit(30))
    entries = {"jittered": OverTime("ray_traced"), "accumulated": OverTime("ray_traced", accumulate=True)}
    summary = ss.evaluate_sequence(turning, entries, size=32, samples=8, reference_samples=256, keep_images=True,
                                   progress=False).set_index("method")
    assert summary.loc["accumulated", "temporal.flicker"] < 0.6 * summary.loc["jittered", "temporal.flicker"]
    # The accumulated entry is the jittered frames through softshadows.accumulate, frame by frame.
    images, history = summary.attrs["images"]["columns"], ss.History()
    gb = ss.gbuffer(setup.scene, setup.camera)
    by_hand = [ss.accumulate(frame, gb, history) for frame in images["jittered"]]
    assert np.array_equal(images["accumulated"], np.stack(by_hand))
    assert summary.loc["accumulated", "frames"] == 8 and history.frames == 8


def test_a_method_with_a_temporal_stage_of_its_own_gets_the_frame_and_one_history(cache):
    setup = ss.scenes.get("columns", width=24, height=24)
    panning = ss.sequence(setup, frames=4, camera_path=Orbit(8))
    summary = ss.evaluate_sequence(panning, {"denoised": OverTime("denoised", history=True)}, size=24, reference_samples=64,
                                   keep_images=True, progress=False)
    history = ss.History()
    by_hand = [ss.denoised(s.scene, s.light, ss.gbuffer(s.scene, s.camera), frame=i, history=history) for i, s in enumerate(panning)]
    assert np.array_equal(summary.attrs["images"]["columns"]["denoised"], np.stack(by_hand)) and history.frames == 4


def test_entries_are_checked_before_any_reference(cache, columns, monkeypatch):
    from softshadows import reference

    monkeypatch.setattr(reference, "mitsuba_visibility", lambda *a, **k: pytest.fail("a reference was traced"))
    seq = ss.sequence(columns, frames=2)
    with pytest.raises(ValueError, match="'pcss\\+jitter' jitters over frames, but pcss takes neither"):
        ss.evaluate_sequence(seq, [OverTime("pcss")], progress=False)
    with pytest.raises(ValueError, match="'ray_traced\\+jitter\\+history' passes a History, but ray_traced takes no history="):
        ss.evaluate_sequence(seq, [OverTime("ray_traced", history=True)], progress=False)
    with pytest.raises(ValueError, match="methods: unknown"):
        ss.evaluate_sequence(seq, [OverTime("ray_trace")], progress=False)
    with pytest.raises(ValueError, match="sequences: the names"):
        ss.evaluate_sequence([seq, seq], ["pcss"], progress=False)
    with pytest.raises(ValueError, match="sequences: expected"):
        ss.evaluate_sequence(columns, ["pcss"], progress=False)
    with pytest.raises(ValueError, match="options"):
        ss.evaluate_sequence(seq, ["pcss"], options={"mvr": {}}, progress=False)


def test_a_refused_method_has_no_temporal_figures(cache):
    sphere = ss.scenes.get("columns", light="sphere", width=16, height=16)
    summary = ss.evaluate_sequence(ss.sequence(sphere, frames=2), ["backprojection", "pcss"], size=16, reference_samples=16,
                                   progress=False).set_index("method")
    assert "planar" in summary.loc["backprojection", "error"]
    assert summary.loc["backprojection", list(metrics.TEMPORAL_KEYS)].isna().all()
    assert summary.loc["pcss", list(metrics.TEMPORAL_KEYS)].notna().all()


class _Terminal(io.StringIO):
    """A stderr that says it is a terminal, as tqdm asks before it draws."""

    def isatty(self):
        return True


def test_the_progress_bar_counts_frames(cache, columns, monkeypatch):
    terminal = _Terminal()
    monkeypatch.setattr("sys.stderr", terminal)
    ss.evaluate_sequence(ss.sequence(columns, frames=3), ["pcss", "shadow_map"], size=16, reference_samples=16)
    drawn = terminal.getvalue()
    assert "9/9" in drawn and "columns/shadow_map" in drawn


def _moving_light():
    setup = ss.scenes.get("columns", width=24, height=24)
    return ss.sequence(setup, frames=3, light_path=Orbit(20), moving={"columns": Slide((0.2, 0, 0))})


def test_sequences_give_the_same_records_in_a_process_pool_and_on_dask(cache):
    distributed = pytest.importorskip("distributed", reason='needs pip install "softshadows[test]" (dask.distributed)')
    seq = _moving_light()
    entries = ["pcss", OverTime("alias_free"), OverTime("alias_free", accumulate=0.2)]
    kwargs = dict(size=24, samples=8, reference_samples=64, progress=False)
    local = ss.evaluate_sequence(seq, entries, **kwargs)
    with ProcessPoolExecutor(2, mp_context=multiprocessing.get_context("spawn")) as pool:
        pooled = ss.evaluate_sequence(seq, entries, executor=pool, **kwargs)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        with distributed.Client(cluster) as client:
            remote = ss.evaluate_sequence(seq, entries, executor=client.get_executor(), **kwargs)
    assert local["temporal.flicker"].gt(0).all()
    for other in (pooled, remote):
        for mine, theirs in ((local, other), (local.attrs["frames"], other.attrs["frames"])):
            columns = [c for c in mine.columns if c != "seconds" and not c.endswith("_seconds")]  # wall times differ
            pd.testing.assert_frame_equal(mine[columns], theirs[columns])


# --- the animated comparison -------------------------------------------------------------------

def test_an_animation_has_a_frame_per_frame_and_refuses_what_it_cannot_write(tmp_path):
    from PIL import Image

    reference = np.stack([np.full((8, 8), k / 4) for k in range(4)])
    mask = np.ones(reference.shape, bool)
    mask[2, :, :4] = False
    path = plot.animation(reference, {"late": np.roll(reference, 1, axis=0)}, mask, path=tmp_path / "a.gif", fps=5,
                          titles={"late": "one frame late"})
    with Image.open(path) as gif:
        assert gif.n_frames == 4 and gif.info["duration"] == 200
    with pytest.raises(ValueError, match=r"results: expected shape \(4, 8, 8\)"):
        plot.animation(reference, {"short": reference[:3]}, path=tmp_path / "b.gif")
    with pytest.raises(ValueError, match="path: expected a .gif"):
        plot.animation(reference, {}, path=tmp_path / "c.png")

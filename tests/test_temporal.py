"""Temporal accumulation over a sequence (``softshadows.History``, ``softshadows.accumulate``):
a still view accumulates the mean of its frames, a pixel whose surface changed restarts, and a
camera move puts each value back where its world point went (checked through
``Camera.project``, independently of the core's reprojection)."""

import pickle

import numpy as np
import pytest

import softshadows as ss


@pytest.fixture(scope="module")
def columns():
    setup = ss.scenes.get("columns", width=40, height=32)
    return setup, ss.gbuffer(setup.scene, setup.camera)


def frames(setup, gb, count):
    """``count`` different frames of one view: 4 rays per pixel, rotated per frame."""
    return [ss.ray_traced(setup.scene, setup.light, gb, samples=4, frame=f) for f in range(count)]


def test_a_still_view_accumulates_the_mean_of_its_frames(columns):
    setup, gb = columns
    shots = frames(setup, gb, 10)
    history = ss.History()
    for shot in shots:
        acc, stats = ss.accumulate(shot, gb, history, alpha=0.1, return_stats=True)
    # Ten frames at alpha = 0.1: the history never outgrows the plain mean. (A pixel's point,
    # interpolated on its triangle in float32, projects back within about 1e-4 pixels of its
    # center, so its neighbours leak into the bilinear read by as much.)
    np.testing.assert_allclose(acc[gb.mask], np.mean(shots, axis=0)[gb.mask], atol=1e-4)
    assert np.all(acc[~gb.mask] == 0)
    assert history.frames == 10 and np.array_equal(history.visibility, acc)
    np.testing.assert_allclose(history.length[gb.mask], 10, atol=1e-4)
    assert stats["reprojected"] == gb.mask.sum() and stats["restarted"] == 0
    assert ss.metrics.rmse(acc, shots[0], gb.mask) > 0.01  # the frames do differ


def test_past_one_over_alpha_frames_the_blend_is_a_moving_average(columns):
    setup, gb = columns
    shots = frames(setup, gb, 6)
    history = ss.History()
    for shot in shots:
        acc = ss.accumulate(shot, gb, history, alpha=0.5)
    expected = np.mean(shots[:2], axis=0)
    for shot in shots[2:]:
        expected = 0.5 * expected + 0.5 * shot
    np.testing.assert_allclose(acc[gb.mask], expected[gb.mask], atol=1e-4)


def test_a_pixel_whose_surface_changed_restarts(columns):
    setup, gb = columns
    # The same camera on the scene without its last column: the pixels that saw it now see
    # the ground behind, and the ground it shadowed is unchanged.
    without = setup.scene.subset(list(range(len(setup.scene.meshes) - 1)))
    after = ss.gbuffer(without, setup.camera)
    moved = np.linalg.norm(after.positions - gb.positions, axis=-1)
    changed = after.mask & (~gb.mask | (moved > 1e-3))
    same = after.mask & gb.mask & (moved == 0)
    assert changed.sum() > 20 and same.sum() > 500
    history = ss.History()
    ss.accumulate(np.ones(gb.shape), gb, history)
    acc, stats = ss.accumulate(np.zeros(after.shape), after, history, return_stats=True)
    np.testing.assert_array_equal(acc[changed], 0)  # restarted from this frame alone
    np.testing.assert_array_equal(history.length[changed], 1)
    np.testing.assert_allclose(acc[same], 0.5, atol=1e-4)  # the mean of the two frames
    assert stats["restarted"] == changed.sum()


def test_a_camera_move_puts_each_value_back_where_its_world_point_went(columns):
    setup, gb = columns
    cam = setup.camera
    moved_camera = ss.Camera.look_at(cam.eye + np.float32([0.3, 0.15, -0.2]), cam.target + np.float32([0.1, 0, 0]),
                                     cam.up, cam.fov_y, cam.width, cam.height)
    after = ss.gbuffer(setup.scene, moved_camera)
    # A first frame whose values vary smoothly over the image, then an all-zero frame at
    # alpha = 0.5: the accumulation is half the first frame read where each point was.
    h, w = gb.shape
    rows, cols = np.mgrid[0:h, 0:w]
    first = np.where(gb.mask, 0.5 + 0.4 * np.sin(cols / 5.0) * np.cos(rows / 7.0), 0).astype(np.float32)
    history = ss.History()
    ss.accumulate(first, gb, history, alpha=0.5)
    acc = ss.accumulate(np.zeros(after.shape), after, history, alpha=0.5)
    # Independently: project each new pixel's point into the first camera, read bilinearly.
    xy = cam.project(after.positions.reshape(-1, 3)).reshape(h, w, 2) - 0.5
    x0, y0 = np.floor(xy[..., 0]), np.floor(xy[..., 1])
    tx, ty = xy[..., 0] - x0, xy[..., 1] - y0
    inside = after.mask & (x0 >= 0) & (y0 >= 0) & (x0 < w - 1) & (y0 < h - 1)
    x0, y0 = np.where(inside, x0, 0).astype(int), np.where(inside, y0, 0).astype(int)
    ground = len(setup.scene.meshes[0].faces)
    taps = [(y0, x0), (y0, x0 + 1), (y0 + 1, x0), (y0 + 1, x0 + 1)]
    # Where the point and its four taps all lie on the ground, every tap is consistent.
    flat = inside & (after.face_ids < ground) & (after.face_ids >= 0)
    for y, x in taps:
        flat &= gb.mask[y, x] & (gb.face_ids[y, x] < ground)
    assert flat.sum() > 300
    expected = ((1 - tx) * (1 - ty) * first[taps[0]] + tx * (1 - ty) * first[taps[1]]
                + (1 - tx) * ty * first[taps[2]] + tx * ty * first[taps[3]])
    np.testing.assert_allclose(2 * acc[flat], expected[flat], atol=2e-3)
    # And not merely the same pixel of the first frame: the view did move.
    assert np.abs(first[flat] - expected[flat]).max() > 0.1


def test_a_history_pickles_and_resumes(columns):
    setup, gb = columns
    shots = frames(setup, gb, 3)
    history = ss.History()
    for shot in shots[:2]:
        ss.accumulate(shot, gb, history)
    copy = pickle.loads(pickle.dumps(history))
    assert repr(copy) == repr(history) == "History(2 frames, 40x32 pixels)"
    np.testing.assert_array_equal(ss.accumulate(shots[2], gb, copy), ss.accumulate(shots[2], gb, history))


@pytest.mark.parametrize(
    "call, name",
    [
        (lambda gb, h: ss.accumulate(np.zeros(gb.shape), ss.Receivers([[0, 0, 0]], [[0, 1, 0]]), h), "gbuffer"),
        (lambda gb, h: ss.accumulate(np.zeros(gb.shape), gb, None), "history"),
        (lambda gb, h: ss.accumulate(np.zeros((3, 3)), gb, h), "visibility"),
        (lambda gb, h: ss.accumulate(np.full(gb.shape, 2.0), gb, h), "visibility"),
        (lambda gb, h: ss.accumulate(np.full(gb.shape, np.nan), gb, h), "visibility"),
        (lambda gb, h: ss.accumulate(np.zeros(gb.shape), gb, h, alpha=0), "alpha"),
        (lambda gb, h: ss.accumulate(np.zeros(gb.shape), gb, h, depth_tolerance=-1), "depth_tolerance"),
        (lambda gb, h: ss.accumulate(np.zeros(gb.shape), gb, h, normal_tolerance=270), "normal_tolerance"),
    ],
)
def test_bad_arguments_are_named(columns, call, name):
    _, gb = columns
    with pytest.raises(ValueError, match=f"^{name}"):
        call(gb, ss.History())

"""``denoised``: a few stochastic shadow rays per pixel and a penumbra-aware denoiser. It
converges to ``ray_traced`` as ``spp`` grows, keeps hard contact shadows sharp, is deterministic
for a seed whatever the thread count, and its temporal stage is ``accumulate``'s."""

import numpy as np
import pytest

import softshadows as ss


@pytest.fixture(scope="module")
def columns():
    setup = ss.scenes.get("columns", width=48, height=48)
    gb = ss.gbuffer(setup.scene, setup.camera)
    exact = ss.ray_traced(setup.scene, setup.light, gb, samples=1024, pattern="sobol")
    return setup, gb, exact


def test_it_converges_to_ray_traced_as_spp_grows(columns):
    setup, gb, exact = columns
    counts = (1, 4, 16, 64)
    # The RMSE of one seed is a random variable: its mean over seeds falls with every count.
    rmse = [np.mean([ss.metrics.rmse(ss.denoised(setup.scene, setup.light, gb, spp=spp, seed=seed), exact, gb.mask)
                     for seed in range(4)]) for spp in counts]
    assert all(a > b for a, b in zip(rmse, rmse[1:])), rmse
    assert rmse[-1] < 0.25 * rmse[0], rmse
    # And the filter earns its keep: one ray per pixel, unfiltered, is far worse.
    raw = ss.ray_traced(setup.scene, setup.light, gb, samples=1, rotate="per_receiver")
    assert rmse[0] < 0.5 * ss.metrics.rmse(raw, exact, gb.mask), rmse


def test_contact_shadows_stay_as_sharp_as_the_oracle():
    # A box on the ground under a small light: its shadow is hard where it meets the box.
    setup = ss.scenes.columns(n=1, kind="box", radius=0.4, column_height=0.8, light_size=0.25, width=96, height=96)
    gb = ss.gbuffer(setup.scene, setup.camera)
    exact = ss.ray_traced(setup.scene, setup.light, gb, samples=256)
    vis, stats = ss.denoised(setup.scene, setup.light, gb, return_stats=True)
    # The ground within 0.1 of the box's foot (|x|, |z| <= 0.4 on y = 0).
    ground = gb.mask & (gb.face_ids < len(setup.scene.meshes[0].faces))
    gap = np.maximum(np.abs(gb.positions[..., 0]), np.abs(gb.positions[..., 2])) - 0.4
    contact = ground & (gap > 0) & (gap < 0.1)
    lit, dark = exact == 1, exact == 0

    def beside(a):
        p = np.pad(a, 1)
        return p[:-2, 1:-1] | p[2:, 1:-1] | p[1:-1, :-2] | p[1:-1, 2:]

    # The oracle's hard edge there: fully lit pixels beside fully shadowed ones, and back.
    edge = contact & ((lit & beside(dark)) | (dark & beside(lit)))
    assert edge.sum() >= 10 and (contact & lit).sum() >= 20 and (contact & dark).sum() >= 100
    # The filter leaves it alone: every edge pixel keeps its value, as nearly every hard one.
    assert np.abs(vis[edge] - exact[edge]).max() < 0.1
    hard = contact & (lit | dark)
    assert np.mean(np.abs(vis[hard] - exact[hard]) < 0.1) > 0.95
    assert stats["radius"] > 0.5  # while it does filter the wide penumbrae further out


def test_it_is_deterministic_for_a_seed_whatever_the_thread_count(columns):
    setup, gb, _ = columns
    runs = []
    for threads in (1, 2, 3):
        ss.set_num_threads(threads)
        try:
            runs.append(ss.denoised(setup.scene, setup.light, gb, spp=2, seed=7, frame=3))
        finally:
            ss.set_num_threads(None)
    for run in runs[1:]:
        np.testing.assert_array_equal(run, runs[0])
    assert not np.array_equal(runs[0], ss.denoised(setup.scene, setup.light, gb, spp=2, seed=8, frame=3))
    assert not np.array_equal(runs[0], ss.denoised(setup.scene, setup.light, gb, spp=2, seed=7, frame=4))


def test_its_temporal_stage_accumulates_the_frames(columns):
    setup, gb, exact = columns
    history = ss.History()
    for frame in range(12):
        vis, stats = ss.denoised(setup.scene, setup.light, gb, frame=frame, history=history, return_stats=True)
        if frame == 0:
            first = ss.metrics.rmse(vis, exact, gb.mask)
            assert stats["restarted"] == gb.mask.sum() and stats["temporal_seconds"] > 0
    assert stats["reprojected"] == gb.mask.sum() and history.frames == 12
    np.testing.assert_allclose(history.length[gb.mask], 12, atol=1e-4)
    assert ss.metrics.rmse(vis, exact, gb.mask) < 0.6 * first
    # Without a history no temporal stage runs.
    _, still = ss.denoised(setup.scene, setup.light, gb, return_stats=True)
    assert still["temporal_seconds"] == 0 and still["reprojected"] == 0


def test_explicit_receivers_are_refused_with_advice(columns):
    setup, _, _ = columns
    with pytest.raises(ss.UnsupportedSetup, match="^receivers: .*GBuffer.*ray_traced"):
        ss.denoised(setup.scene, setup.light, ss.Receivers([[2.5, 0, 2.5]], [[0, 1, 0]]))


@pytest.mark.parametrize("option, value", [("spp", 0), ("spp", 5000), ("max_radius", 300), ("sigma_n", 0.0),
                                           ("epsilon", -1.0), ("alpha", 1.5), ("frame", 2**32)])
def test_bad_options_are_named(columns, option, value):
    setup, gb, _ = columns
    history = ss.History() if option == "alpha" else None
    with pytest.raises(ValueError, match=f"^{option}"):
        ss.denoised(setup.scene, setup.light, gb, history=history, **{option: value})

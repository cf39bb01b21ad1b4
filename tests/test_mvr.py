"""Multi-view rasterization: one depth map per light sample, against the ray-traced oracle."""

import numpy as np
import pytest

import softshadows as ss


@pytest.fixture(scope="module")
def columns():
    setup = ss.scenes.get("columns", width=64, height=64)
    return setup, ss.gbuffer(setup.scene, setup.camera)


def test_converges_to_ray_traced_on_the_same_samples(columns):
    setup, gb = columns
    samples = setup.light.samples(16, pattern="poisson", seed=2)
    exact = ss.ray_traced(setup.scene, setup.light, gb, samples=samples)
    errors = [
        ss.metrics.rmse(ss.mvr(setup.scene, setup.light, gb, samples=samples, resolution=r, pcf=1), exact, gb.mask)
        for r in (128, 512, 2048)
    ]
    assert errors[0] > errors[1] > errors[2], errors
    assert errors[2] < 0.01, errors


def test_one_view_of_a_point_light_is_the_shadow_map(columns):
    setup, gb = columns
    light = ss.PointLight(setup.light.center)
    for pcf, side in [(1, 1), (9, 3)]:
        np.testing.assert_array_equal(
            ss.mvr(setup.scene, light, gb, samples=1, resolution=256, pcf=pcf),
            ss.shadow_map(setup.scene, light, gb, resolution=256, pcf=side),
        )


def test_views_are_deterministic_per_seed_and_stats_are_reported(columns):
    setup, gb = columns
    by_count, stats = ss.mvr(setup.scene, setup.light, gb, samples=8, seed=4, resolution=128, return_stats=True)
    np.testing.assert_array_equal(by_count, ss.mvr(setup.scene, setup.light, gb, samples=8, seed=4, resolution=128))
    assert np.any(by_count != ss.mvr(setup.scene, setup.light, gb, samples=8, seed=5, resolution=128))
    assert stats["views"] == 8 and stats["resolution"] == 128 and stats["fragments"] > 0
    assert stats["depth_maps_seconds"] > 0 and stats["lighting_seconds"] > 0
    assert by_count.dtype == np.float32 and by_count.shape == gb.mask.shape
    assert np.all(by_count[~gb.mask] == 0) and 0 <= by_count.min() and by_count.max() <= 1


def test_the_five_tap_filter_softens_edges(columns):
    setup, gb = columns
    light = ss.PointLight(setup.light.center)
    hard = ss.mvr(setup.scene, light, gb, samples=1, resolution=128, pcf=1)
    cross = ss.mvr(setup.scene, light, gb, samples=1, resolution=128, pcf=5)
    assert set(np.unique(hard)) <= {0.0, 1.0}
    assert np.isin(np.unique(cross[gb.mask]), np.arange(6, dtype=np.float32) / np.float32(5)).all()
    assert np.mean((cross > 0) & (cross < 1)) > 0.005


def test_emission_weights_count(columns):
    setup, gb = columns
    c, u, v = setup.light.center, setup.light.u, setup.light.v
    half_dark = ss.RectLight(c, u, v, emission=np.array([[1.0, 0.0]], dtype=np.float32))
    samples = half_dark.samples(16, seed=1)
    np.testing.assert_allclose(
        ss.mvr(setup.scene, half_dark, gb, samples=samples, resolution=128),
        ss.mvr(setup.scene, setup.light, gb, samples=samples[half_dark.weights(samples) > 0], resolution=128),
        atol=1e-6,
    )


@pytest.mark.parametrize(
    "options, match",
    [
        ({"samples": 0}, "samples"),
        ({"samples": np.zeros((3, 2))}, "samples"),
        ({"pcf": 4}, "pcf"),
        ({"resolution": 0}, "resolution"),
        ({"bias": -1.0}, "bias"),
        ({"pattern": "grid"}, "pattern"),
        ({"samples": np.zeros((2, 3)), "frame": 1}, "frame"),
    ],
)
def test_bad_options_name_the_argument(columns, options, match):
    setup, gb = columns
    with pytest.raises(ValueError, match=match):
        ss.mvr(setup.scene, setup.light, gb, **options)


def test_casters_leave_meshes_out_of_the_depth_maps(columns):
    setup, gb = columns
    everything = ss.mvr(setup.scene, setup.light, gb, samples=4, resolution=256)
    occluders = ss.mvr(setup.scene, setup.light, gb, samples=4, resolution=256, casters=["columns"])
    ground_only = ss.mvr(setup.scene, setup.light, gb, samples=4, resolution=256, casters=[0])
    assert np.mean((everything != occluders)[gb.mask]) < 0.01  # the ground shadows nothing here
    assert np.all(ground_only[gb.mask & (everything < 1)] >= everything[gb.mask & (everything < 1)])
    assert np.mean(ground_only[gb.mask] == 1) > np.mean(everything[gb.mask] == 1) + 0.05
    with pytest.raises(ValueError, match="casters.*no mesh named 'roof'"):
        ss.mvr(setup.scene, setup.light, gb, casters=["roof"])

"""The hard-shadow baseline against the oracle under a point light."""

import numpy as np
import pytest
from conftest import quad

import softshadows as ss


@pytest.fixture
def setup():
    scene = ss.Scene([quad((0, 0), 4.0, 0.0), quad((0.2, -0.3), 0.8, 1.2)])
    cam = ss.Camera.look_at((0, 6, 5), (0, 0, 0), width=96, height=96)
    return scene, ss.PointLight((0.5, 5, 0.3)), ss.gbuffer(scene, cam)


def test_matches_point_light_ray_tracing_away_from_edges(setup):
    scene, light, gb = setup
    exact = ss.ray_traced(scene, light, gb, samples=1)
    hard = ss.shadow_map(scene, light, gb, resolution=1024)
    assert set(np.unique(hard[gb.mask])) <= {0.0, 1.0}
    wrong = (hard != exact) & gb.mask
    assert exact[gb.mask].min() == 0 and exact[gb.mask].max() == 1
    assert wrong.mean() < 0.01, f"{wrong.sum()} of {gb.mask.sum()} pixels differ"


def test_resolution_controls_aliasing(setup):
    scene, light, gb = setup
    exact = ss.ray_traced(scene, light, gb, samples=1)
    errors = [np.mean(ss.shadow_map(scene, light, gb, resolution=r)[gb.mask] != exact[gb.mask]) for r in (32, 1024)]
    assert errors[0] > errors[1]


def test_pcf_filters_the_edge_and_stats_are_reported(setup):
    scene, light, gb = setup
    vis, stats = ss.shadow_map(scene, light, gb, resolution=256, pcf=5, return_stats=True)
    fractional = (vis > 0) & (vis < 1)
    assert fractional.sum() > 0
    assert stats["resolution"] == 256 and stats["texels_drawn"] > 0 and "render_seconds" in stats


def test_area_lights_cast_from_their_center(setup):
    scene, _, gb = setup
    center = np.array([0.5, 5, 0.3], dtype=np.float32)
    rect = ss.RectLight(center, (1, 0, 0), (0, 0, -1))
    np.testing.assert_array_equal(
        ss.shadow_map(scene, rect, gb, resolution=512), ss.shadow_map(scene, ss.PointLight(center), gb, resolution=512)
    )


def test_a_light_among_the_receivers_gets_a_map_per_cube_face(setup):
    scene, _, _ = setup
    rx = ss.Receivers([[-5, 0, 0], [5, 6, 0], [0, 0, 0.5]], [[0, 1, 0], [0, 1, 0], [0, 1, 0]])
    light = ss.PointLight((0, 3, 0))
    vis, stats = ss.shadow_map(scene, light, rx, return_stats=True)
    assert stats["light_faces"] == 3  # -x (the first), +x (the second), -y (the third)
    np.testing.assert_array_equal(vis, ss.ray_traced(scene, light, rx))

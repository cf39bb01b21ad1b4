"""View-warped soft shadows against multi-view rasterization on the same light samples."""

import importlib.util

import numpy as np
import pytest

import softshadows as ss

needs_pymeshlab = pytest.mark.skipif(
    importlib.util.find_spec("pymeshlab") is None, reason='needs pip install "softshadows[models]"'
)


def case(name, size=128, **options):
    setup = ss.scenes.get(name, width=size, height=size, **options)
    gb = ss.gbuffer(setup.scene, setup.camera)
    return setup, gb, setup.light.samples(24, pattern="poisson", seed=0)


@pytest.mark.parametrize("name", ["columns", "fence", pytest.param("bunny", marks=needs_pymeshlab)])
def test_matches_multi_view_rasterization_on_the_same_samples(name):
    setup, gb, samples = case(name)
    reference = ss.mvr(setup.scene, setup.light, gb, views=samples)
    warped = ss.vwss(setup.scene, setup.light, gb, views=samples)
    assert np.mean((reference > 0) & (reference < 1) & gb.mask) > 0.02, "the scene needs a penumbra"
    assert ss.metrics.rmse(warped, reference, gb.mask) < 0.02


@pytest.mark.parametrize("name", ["hairball", "leaves"])
def test_single_layer_warping_leaks_light_at_disocclusions(name):
    """Figure 4: warping only the nearest surface lets light through where another view sees
    occluders the source view hid. Measure: the share of hit pixels lit more than 0.1 above mvr."""
    setup, gb, samples = case(name)
    reference = ss.mvr(setup.scene, setup.light, gb, views=samples, resolution=512)
    naive, layered = (
        ss.vwss(setup.scene, setup.light, gb, views=samples, resolution=512, layered=flag) for flag in (False, True)
    )
    # The single layer is a subset of the layered points, so it can only be lighter.
    assert np.all(naive >= layered)
    leaks = {k: np.mean((vis - reference)[gb.mask] > 0.1) for k, vis in [("naive", naive), ("layered", layered)]}
    assert leaks["naive"] > 0.02 and leaks["layered"] < leaks["naive"] / 3, leaks


def test_too_few_points_leave_holes_that_leak_light():
    setup, gb, samples = case("columns")
    reference = ss.mvr(setup.scene, setup.light, gb, views=samples, resolution=512)
    gain = [
        np.mean((ss.vwss(setup.scene, setup.light, gb, views=samples, resolution=512, point_density=d) - reference)[gb.mask])
        for d in (1.0, 2.0)
    ]
    assert gain[0] > gain[1] + 0.005, gain


def test_modes_and_schedules_agree_and_report_the_papers_columns():
    setup, gb, samples = case("torus_knot", size=64)
    run = lambda **o: ss.vwss(setup.scene, setup.light, gb, views=samples, resolution=256, return_stats=True, **o)
    reference, stats = run()
    assert stats["maps_per_traversal"] == 8 and stats["traversals"] == 3 and stats["views"] == 24
    assert stats["points"] > 0 and stats["source_resolution"] > 256 and stats["pull_back"] > 0
    for name in ("point_generation_seconds", "depth_maps_seconds", "lighting_seconds"):
        assert stats[name] > 0, name
    for options, traversals in [
        ({"parallel": "serial"}, 24),
        ({"parallel": "full"}, 1),
        ({"views_per_pass": 5}, 5),
        ({"mode": "unbuffered"}, 3),
        ({"mode": "unbuffered", "parallel": "full"}, 1),
    ]:
        vis, st = run(**options)
        np.testing.assert_array_equal(vis, reference, err_msg=str(options))
        assert st["traversals"] == traversals, options
    assert st["point_generation_seconds"] == 0 and st["points"] == stats["points"]


def test_back_faces_and_half_precision_points():
    setup, gb, samples = case("ground_sphere", size=64)
    run = lambda scene, **o: ss.vwss(scene, setup.light, gb, views=samples, resolution=256, return_stats=True, **o)
    culled, st_culled = run(setup.scene)
    both, st_both = run(setup.scene, cull_backfaces=False)
    half, st_half = run(setup.scene, precision="float16")
    # Every source ray through a closed convex mesh enters once and leaves once (watertight
    # rasterization): keeping back faces exactly doubles the sphere's points.
    sphere = ss.Scene(setup.occluders)
    front, back_too = (run(sphere, cull_backfaces=c)[1]["points"] for c in (True, False))
    assert front > 500 and back_too == 2 * front
    assert st_both["points"] > st_culled["points"]
    assert st_half["points"] == st_culled["points"]
    assert ss.metrics.rmse(both, culled, gb.mask) < 0.02
    assert 0 < ss.metrics.rmse(half, culled, gb.mask) < 0.02


def test_open_meshes_cast_whichever_side_faces_the_light():
    """Back-face culling applies to closed meshes: a one-sided quad seen from behind still casts."""
    from conftest import quad

    ground = quad((0, 0), 4.0, 0.0)
    flipped = quad((0, 0), 0.6, 1.0)
    flipped.faces = flipped.faces[:, ::-1].copy()
    scene = ss.Scene([ground, flipped])
    light = ss.RectLight((0, 4, 0), (0.3, 0, 0), (0, 0, -0.3))
    rx = ss.Receivers([[0, 0, 0], [3, 0, 3]], [[0, 1, 0], [0, 1, 0]])
    np.testing.assert_array_equal(ss.vwss(scene, light, rx, views=8, resolution=512), [0.0, 1.0])


@pytest.mark.parametrize(
    "options, match",
    [
        ({"mode": "fast"}, "mode"),
        ({"parallel": "all"}, "parallel"),
        ({"precision": "float8"}, "precision"),
        ({"views_per_pass": 0}, "views_per_pass"),
        ({"point_density": 0.0}, "point_density"),
        ({"source_resolution": 0}, "source_resolution"),
        ({"layered": False, "mode": "unbuffered"}, "layered"),
        ({"precision": "float16", "mode": "unbuffered"}, "precision"),
        ({"views": 0}, "views"),
        ({"pcf": 3}, "pcf"),
    ],
)
def test_bad_options_name_the_argument(options, match):
    setup, gb, _ = case("ground_sphere", size=16)
    with pytest.raises(ValueError, match=match):
        ss.vwss(setup.scene, setup.light, gb, **options)

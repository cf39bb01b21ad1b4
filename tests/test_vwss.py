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


@pytest.mark.parametrize("name", ["columns", "fence"])
def test_matches_multi_view_rasterization_on_the_same_samples(name):
    """Same samples, same maps' resolution, same depth bias: what differs is the method."""
    setup, gb, samples = case(name)
    reference = ss.mvr(setup.scene, setup.light, gb, samples=samples)
    warped = ss.vwss(setup.scene, setup.light, gb, samples=samples)
    assert np.mean((reference > 0) & (reference < 1) & gb.mask) > 0.02, "the scene needs a penumbra"
    assert ss.metrics.rmse(warped, reference, gb.mask) < 0.02


@needs_pymeshlab
def test_on_a_curved_occluder_only_its_own_surface_shadows_itself_more():
    """Section 5.1: a warped texel keeps the nearest point anywhere inside it, so under the depth
    bias mvr uses the bunny darkens its own surface (RMSE 0.048 against mvr there, mean -0.021);
    the shadow it casts on the ground matches mvr's."""
    setup, gb, samples = case("bunny")
    reference = ss.mvr(setup.scene, setup.light, gb, samples=samples)
    warped = ss.vwss(setup.scene, setup.light, gb, samples=samples)
    on_bunny = gb.mask & (gb.face_ids >= len(setup.scene.meshes[0].faces))
    on_ground = gb.mask & ~on_bunny
    assert on_bunny.sum() > 1000 and np.mean((reference > 0) & (reference < 1) & on_ground) > 0.02
    assert ss.metrics.rmse(warped, reference, on_ground) < 0.02
    assert np.mean((warped - reference)[on_bunny]) < -0.01


def light_views_over_a_square(light_half: float):
    """Receivers on a square [-2, 2]² of the ground straight under a square light 4 up, and a
    1 x 1 occluder 1.5 up: the views look straight down (their axes along x and z) with the square
    field of view that holds the receivers from every sample, with the 1% margin of the fit."""
    from conftest import quad

    height, half = 4.0, 2.0
    xs = np.linspace(-half, half, 9)
    grid = np.array([(x, 0.0, z) for x in xs for z in xs])
    receivers = ss.Receivers(grid, np.tile([0.0, 1.0, 0.0], (len(grid), 1)))
    light = ss.RectLight((0, height, 0), (light_half, 0, 0), (0, 0, light_half))  # facing down
    samples = light.samples(24, pattern="poisson", seed=0)
    offsets = np.abs(samples[:, [0, 2]])
    tan = 1.01 * (half + offsets.max()) / height
    near = 1e-3 * height
    return ss.Scene([quad((0, 0), 0.5, 1.5)]), light, receivers, samples, tan, near, height - 1.5


@pytest.mark.parametrize("light_half", [0.002, 0.3])
def test_the_paper_source_view_follows_equations_1_to_3(light_half):
    """Section 3.1 as printed: d = max(l_w, l_h) / (2 tan(fov/2)) (eq. 1), the eye d behind the
    light (eq. 2), a side of m (z_n + d) / z_n with z_n the views' near plane (eq. 3, Listing 1),
    capped at 8 m. The smaller light stays under the cap, the larger one reaches it."""
    scene, light, receivers, samples, tan, near, _ = light_views_over_a_square(light_half)
    m = 256
    d = 2 * light_half / (2 * tan)
    side = int(np.ceil(m * min((near + d) / near, 8.0)))
    _, stats = ss.vwss(scene, light, receivers, samples=samples, resolution=m, source_view="paper", return_stats=True)
    assert stats["pull_back"] == pytest.approx(d, rel=1e-5, abs=1e-6)  # read back from the f32 eye
    assert stats["source_resolution"] == side
    assert (side == 8 * m) == (light_half > 0.01)


def test_the_fitted_source_view_holds_the_samples_and_the_nearest_occluder():
    """Our variant: d just holds the actual samples (max |offset| / tan, the samples lying in the
    light's plane), and z_n is the occluder's depth below the light, times sqrt(point_density)."""
    scene, light, receivers, samples, tan, _, occluder_depth = light_views_over_a_square(0.3)
    m = 256
    d = np.abs(samples[:, [0, 2]]).max() / tan
    for density in (1.0, 2.0):
        side = int(np.ceil(m * np.sqrt(density) * (occluder_depth + d) / occluder_depth))
        _, stats = ss.vwss(scene, light, receivers, samples=samples, resolution=m, point_density=density,
                           return_stats=True)
        assert stats["pull_back"] == pytest.approx(d, rel=1e-5, abs=1e-6)  # read back from the f32 eye
        assert stats["source_resolution"] == side, density
    assert d < 2 * 0.3 / (2 * tan), "the fitted pull-back is shorter than eq. 1's"


def test_the_papers_equations_need_a_planar_light():
    setup, gb, _ = case("ground_sphere", size=16)
    sphere = ss.SphereLight(setup.light.center, 0.2)
    with pytest.raises(ValueError, match="source_view='fitted'"):
        ss.vwss(setup.scene, sphere, gb, samples=4, source_view="paper")


@pytest.mark.parametrize("name", ["hairball", "leaves"])
def test_single_layer_warping_leaks_light_at_disocclusions(name):
    """Figure 4: warping only the nearest surface lets light through where another view sees
    occluders the source view hid. Measure: the share of hit pixels lit more than 0.1 above mvr."""
    setup, gb, samples = case(name)
    reference = ss.mvr(setup.scene, setup.light, gb, samples=samples, resolution=512)
    naive, layered = (
        ss.vwss(setup.scene, setup.light, gb, samples=samples, resolution=512, layered=flag) for flag in (False, True)
    )
    # The single layer is a subset of the layered points, so it can only be lighter.
    assert np.all(naive >= layered)
    leaks = {k: np.mean((vis - reference)[gb.mask] > 0.1) for k, vis in [("naive", naive), ("layered", layered)]}
    assert leaks["naive"] > 0.02 and leaks["layered"] < leaks["naive"] / 3, leaks


def test_too_few_points_leave_holes_that_leak_light():
    setup, gb, samples = case("columns")
    reference = ss.mvr(setup.scene, setup.light, gb, samples=samples, resolution=512)
    gain = [
        np.mean((ss.vwss(setup.scene, setup.light, gb, samples=samples, resolution=512, point_density=d) - reference)[gb.mask])
        for d in (1.0, 2.0)
    ]
    assert gain[0] > gain[1] + 0.005, gain


def test_modes_and_schedules_agree_and_report_the_papers_columns():
    setup, gb, samples = case("torus_knot", size=64)
    run = lambda **o: ss.vwss(setup.scene, setup.light, gb, samples=samples, resolution=256, return_stats=True, **o)
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
    run = lambda scene, **o: ss.vwss(scene, setup.light, gb, samples=samples, resolution=256, return_stats=True, **o)
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
    light = ss.RectLight((0, 4, 0), (0.3, 0, 0), (0, 0, 0.3))
    rx = ss.Receivers([[0, 0, 0], [3, 0, 3]], [[0, 1, 0], [0, 1, 0]])
    np.testing.assert_array_equal(ss.vwss(scene, light, rx, samples=8, resolution=512), [0.0, 1.0])


@pytest.mark.parametrize(
    "options, match",
    [
        ({"mode": "fast"}, "mode"),
        ({"parallel": "all"}, "parallel"),
        ({"precision": "float8"}, "precision"),
        ({"source_view": "literal"}, "source_view"),
        ({"views_per_pass": 0}, "views_per_pass"),
        ({"point_density": 0.0}, "point_density"),
        ({"source_resolution": 0}, "source_resolution"),
        ({"layered": False, "mode": "unbuffered"}, "layered"),
        ({"precision": "float16", "mode": "unbuffered"}, "precision"),
        ({"samples": 0}, "samples"),
        ({"pcf": 3}, "pcf"),
    ],
)
def test_bad_options_name_the_argument(options, match):
    setup, gb, _ = case("ground_sphere", size=16)
    with pytest.raises(ValueError, match=match):
        ss.vwss(setup.scene, setup.light, gb, **options)


def scattered_knots(count=80, seed=0):
    """``count`` small closed torus knots (1536 triangles each) scattered over a 12 x 12 ground
    under a 1.2 x 1.2 light 6 up: a large scene whose maps give each knot a few dozen texels."""
    knot = ss.scenes.torus_knot(tube_segments=64, radial_segments=12).occluders[0]
    v, f = np.asarray(knot.vertices), np.asarray(knot.faces)
    lo, hi = v.min(0), v.max(0)
    v = (v - (lo + hi) / 2) / (hi - lo).max()
    ground = ss.Mesh(np.array([[-6, 0, -6], [6, 0, -6], [6, 0, 6], [-6, 0, 6]], np.float32),
                     np.array([[0, 2, 1], [0, 3, 2]], np.uint32), name="ground")
    rng = np.random.default_rng(seed)
    knots = []
    for i in range(count):
        x, z = rng.uniform(-5, 5, 2)
        s = rng.uniform(0.4, 1.0)
        knots.append(ss.Mesh((v * s + [x, s / 2 + rng.uniform(0, 1), z]).astype(np.float32), f, closed=True, name=f"knot{i}"))
    scene = ss.Scene([ground, *knots])
    light = ss.RectLight((0, 6, 0), (0.6, 0, 0), (0, 0, 0.6))
    gb = ss.gbuffer(scene, ss.Camera.look_at((0, 9, 9), (0, 0, 0), fov_y=50.0, width=128, height=128))
    return scene, light, gb


def test_on_a_large_scene_the_bloat_follows_the_silhouettes_in_texels():
    """What grows with the scene (123k triangles in 81 meshes: RMSE 0.020 against mvr at 1024²
    maps, 0.009 on one 50k-triangle knot) is Figure 6's bloat: each small knot's silhouette is a
    larger share of its shadow in texels. The shadows on the ground come out darker, not lighter
    (no holes), and maps of twice the side shrink the difference."""
    scene, light, gb = scattered_knots()
    ground = gb.mask & (gb.face_ids < 2)
    samples = light.samples(24, pattern="poisson", seed=0)
    difference = {}
    for side in (512, 1024):
        peer = ss.mvr(scene, light, gb, samples=samples, resolution=side)
        warped = ss.vwss(scene, light, gb, samples=samples, resolution=side)
        difference[side] = (ss.metrics.rmse(warped, peer, ground), float(np.mean((warped - peer)[ground])))
    assert all(mean < -0.003 for _, mean in difference.values()), difference
    assert difference[1024][0] < 0.75 * difference[512][0], difference

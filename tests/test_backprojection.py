"""Backprojection soft shadow mapping (Schwarz and Stamminger 2008) against 1024 ray-traced samples."""

import importlib.util

import numpy as np
import pytest

import softshadows as ss
from softshadows import metrics

needs_pymeshlab = pytest.mark.skipif(
    importlib.util.find_spec("pymeshlab") is None, reason='needs pip install "softshadows[models]"'
)


def case(name, size=128):
    setup = ss.scenes.get(name, width=size, height=size)
    gb = ss.gbuffer(setup.scene, setup.camera)
    reference = ss.ray_traced(setup.scene, setup.light, gb, samples=1024, pattern="sobol", seed=1)
    return setup, gb, reference


@pytest.mark.parametrize("name", ["columns", "torus_knot"])
@pytest.mark.parametrize("occluder", [{}, {"occluder": "microquad"}])
def test_the_unbounded_budget_converges_to_ray_traced_as_the_map_grows(name, occluder):
    setup, gb, reference = case(name)
    # The ground's receivers: on the knot itself about 20 pixels near its self-shadowing terminator
    # keep errors near 0.45 at every map size (the tangent-plane test, not the map's resolution).
    ground = gb.mask & (gb.face_ids < 2)
    errors = [metrics.rmse(ss.backprojection(setup.scene, setup.light, gb, resolution=r, **occluder), reference, ground)
              for r in (256, 512, 1024, 2048)]
    assert all(b < a for a, b in zip(errors, errors[1:])), errors
    assert errors[-1] < 0.6 * errors[0], errors


def step_setup(size=96):
    """Two boxes side by side on a common base, 0.9 and 1.3 high: adjacent micropatches at two
    depths along the step's edge, which the taller box's side wall joins in the true geometry."""
    from softshadows.scene import Mesh, Scene

    plates = ss.scenes.parallel_plates(width=size, height=size, light_size=1.5)
    boxes = [ss.scenes.primitives.box((-1, 0.6, -1), (0, 0.9, 1)), ss.scenes.primitives.box((0, 0.6, -1), (1, 1.3, 1))]
    meshes = [Mesh(v.astype(np.float32), f, name=f"box{i}") for i, (v, f) in enumerate(boxes)]
    scene = Scene([plates.ground, *meshes])
    return plates, scene


def test_gap_filling_closes_the_gaps_between_micropatches_at_two_depths():
    plates, scene = step_setup()
    gb = ss.gbuffer(scene, plates.camera)
    reference = ss.ray_traced(scene, plates.light, gb, samples=1024, pattern="sobol", seed=1)
    plain, filled = (ss.backprojection(scene, plates.light, gb, resolution=512, extend=e) for e in (False, True))
    # Filling only adds occlusion (the bitmap's samples are the same), and where it matters, at
    # the step, plain micropatches let light through the gap that the taller box's wall blocks.
    assert np.all(filled <= plain)
    step = gb.mask & (np.abs(gb.positions[..., 0]) < 0.5) & (reference > 0.02) & (reference < 0.98)
    assert step.sum() > 30
    leak = {name: np.sqrt(np.mean((v - reference)[step] ** 2)) for name, v in (("plain", plain), ("filled", filled))}
    assert leak["filled"] < 0.6 * leak["plain"], leak
    assert np.mean((plain - reference)[step]) > 0.02  # the gap lets light through


def test_gap_filling_covers_no_texel_that_no_occluder_covers():
    # A plate at one depth over a ground behind every receiver: no two occluding micropatches
    # differ in depth, and the plate's border micropatches have no occluding neighbour, so the
    # filled micropatches are the plain ones on every pixel.
    setup = ss.scenes.parallel_plates(width=96, height=96)
    gb = ss.gbuffer(setup.scene, setup.camera)
    plain, filled = (ss.backprojection(setup.scene, setup.light, gb, resolution=512, extend=e, accumulation="area") for e in (False, True))
    np.testing.assert_array_equal(filled, plain)


def excess_jump(vis, reference, inside):
    """The 99th percentile, over pairs of 4-neighbours inside the penumbra, of their difference in
    visibility beyond the reference's own difference (the single largest is one noisy pair)."""
    dx = np.abs(np.diff(vis, axis=1)) - np.abs(np.diff(reference, axis=1))
    dy = np.abs(np.diff(vis, axis=0)) - np.abs(np.diff(reference, axis=0))
    return np.percentile(np.concatenate([dx[inside[:, 1:] & inside[:, :-1]], dy[inside[1:] & inside[:-1]]]), 99)


def test_blending_removes_level_transitions():
    setup, gb, reference = case("columns", size=160)
    # A budget of 12 micro-occluders per axis spreads levels 1-2 across the penumbrae.
    penumbra = (reference > 0.05) & (reference < 0.95) & gb.mask & (gb.face_ids < 2)
    jumps, levels = {}, None
    for blend in (False, True):
        vis, levels = ss.backprojection(setup.scene, setup.light, gb, resolution=512, budget=12, blend=blend, return_levels=True)
        jumps[blend] = excess_jump(vis, reference, penumbra)
    used = np.unique(np.ceil(levels[penumbra & np.isfinite(levels)]))
    assert len(used) >= 2, f"needs several integer levels, got {used}"
    assert jumps[True] < 0.8 * jumps[False], jumps


@pytest.mark.parametrize("name", ["columns", pytest.param("bunny", marks=needs_pymeshlab)])
def test_microrects_beat_micropatches_at_coarse_levels(name):
    # Section 5.2 and Figure 12: both with occlusion bitmaps, plain micropatches (the primitive
    # microrects generalize), at fixed coarse levels and under budgets.
    setup, gb, reference = case(name)
    for options in ({"level": 2}, {"level": 3}, {"budget": 12}, {"budget": 5}):
        patch, rect = (
            metrics.rmse(ss.backprojection(setup.scene, setup.light, gb, resolution=512, occluder=o, extend=False, **options), reference, gb.mask)
            for o in ("micropatch", "microrect")
        )
        assert rect < patch, (options, rect, patch)


def test_microrects_are_micropatches_at_level_zero():
    setup, gb, _ = case("columns", size=64)
    patch = ss.backprojection(setup.scene, setup.light, gb, resolution=256, level=0, extend=False)
    np.testing.assert_array_equal(ss.backprojection(setup.scene, setup.light, gb, resolution=256, level=0, occluder="microrect"), patch)
    assert not np.array_equal(ss.backprojection(setup.scene, setup.light, gb, resolution=256, level=2, occluder="microrect"),
                              ss.backprojection(setup.scene, setup.light, gb, resolution=256, level=2, extend=False))


@pytest.mark.parametrize("name", ["columns", "torus_knot", pytest.param("bunny", marks=needs_pymeshlab)])
@pytest.mark.parametrize("budget", [None, 6])
def test_classification_is_never_wrong_on_the_ground_and_finer_structures_classify_more(name, budget):
    setup, gb, reference = case(name)
    ground = (gb.face_ids < 2) & gb.mask  # the whole light lies in front of the ground
    classified = {}
    for accel in ("hsm", "ysm", "mssm"):
        vis, levels, stats = ss.backprojection(setup.scene, setup.light, gb, resolution=1024, accel=accel, budget=budget,
                                               return_levels=True, return_stats=True)
        lit = ground & np.isnan(levels) & (vis > 0)
        assert lit.sum() > 100 and stats["lit"] >= lit.sum()
        assert reference[lit].min() >= 0.99, accel
        assert 0 < stats["backprojecting_percent"] < 100 and stats["processed_mean"] > 0
        classified[accel] = stats["lit"] + stats["umbra"]
    # Table 1 / Figure 8: the MSSM's exact ranges classify the most, the YSM (HSM levels, then an
    # MSSM of the 256^2 level) at least as many as the HSM.
    assert classified["hsm"] <= classified["ysm"] <= classified["mssm"], classified


@pytest.mark.parametrize("options", [{}, {"occluder": "microrect"}, {"accel": "mssm"}, {"smoothing": 1}, {"accumulation": "area"}])
def test_no_pixel_processes_more_micro_occluders_than_its_budget_allows(options):
    # Level ceil(l) reads at most floor(b)^2 micro-occluders and level floor(l) at most
    # (2 floor(b))^2 (section 8), pixel by pixel, for uniform budgets and a budget map.
    setup = ss.scenes.get("columns", width=128, height=128)
    gb = ss.gbuffer(setup.scene, setup.camera)
    x = np.linspace(-1, 1, gb.shape[1], dtype=np.float32)[None, :].repeat(gb.shape[0], axis=0)
    for budget in (5, 12, 12.5, 12 - 7 * np.abs(x)):
        for blend in (False, True):
            _, counts, stats = ss.backprojection(setup.scene, setup.light, gb, resolution=512, budget=budget, blend=blend,
                                                 return_counts=True, return_stats=True, **options)
            b = np.floor(np.broadcast_to(budget, gb.shape))
            allowed = b**2 + blend * (2 * b) ** 2
            assert counts.max() > 0 and np.all(counts <= allowed), (budget, blend, (counts - allowed).max())
            assert stats["processed_max"] == counts.max() and stats["backprojected_max"] <= stats["processed_max"]


def test_budgets_lower_the_micro_occluders_and_budget_maps_vary_them():
    setup, gb, reference = case("columns")
    counts = {}
    for budget in (None, 12, 5):
        vis, stats = ss.backprojection(setup.scene, setup.light, gb, resolution=512, budget=budget, return_stats=True)
        counts[budget] = stats["processed_mean"]
    assert counts[5] < counts[12] < counts[None]
    x = np.linspace(0, 1, gb.shape[1])[None, :].repeat(gb.shape[0], axis=0)
    border = np.where(np.abs(x - 0.5) > 0.3, 5.0, 12.0)  # Figure 1d: lower quality at the borders
    _, levels = ss.backprojection(setup.scene, setup.light, gb, resolution=512, budget=border, return_levels=True)
    _, uniform = ss.backprojection(setup.scene, setup.light, gb, resolution=512, budget=12, return_levels=True)
    edge = (np.abs(x - 0.5) > 0.35) & np.isfinite(levels) & np.isfinite(uniform)
    assert edge.sum() > 50 and np.nanmean(levels[edge]) > np.nanmean(uniform[edge]) + 0.5


@pytest.mark.parametrize(
    "options, match",
    [({"budget": 0.5}, "budget"), ({"budget": np.ones((3, 3))}, "budget"), ({"smoothing": 4}, "smoothing"),
     ({"occluder": "micropoint"}, "occluder"), ({"accumulation": "max"}, "accumulation"), ({"resolution": 0}, "resolution")],
)
def test_bad_options_name_the_argument(options, match):
    setup = ss.scenes.get("ground_sphere", width=16, height=16)
    with pytest.raises(ValueError, match=match):
        ss.backprojection(setup.scene, setup.light, ss.gbuffer(setup.scene, setup.camera), **options)


def test_non_planar_lights_are_refused():
    setup = ss.scenes.get("ground_sphere", width=16, height=16, light="sphere")
    with pytest.raises(ValueError, match="light"):
        ss.backprojection(setup.scene, setup.light, ss.gbuffer(setup.scene, setup.camera))


def test_msaa_resolve_takes_the_neighbour_of_closest_depth():
    # Three pixels in a row at depths 1, 2 and 3 (camera at the origin looking down +x); the
    # middle pixel's four samples: two at its own depth, one at the left's, one at the right's.
    from softshadows.camera import Camera, GBuffer

    camera = Camera.look_at((0, 0, 0), (1, 0, 0), fov_y=10, width=3, height=1)
    positions = np.array([[[1.0, 0, 0], [2.0, 0, 0], [3.0, 0, 0]]], np.float32)
    depths = np.array([[[1, 1, 1, 1], [2, 2, 1.0, 3.0], [3, 3, 3, np.inf]]], np.float32)
    gb = GBuffer(positions, np.tile(np.float32([-1, 0, 0]), (1, 3, 1)), np.ones((1, 3), bool), np.zeros((1, 3), np.int64), depths, camera)
    resolved = ss.resolve_msaa(np.array([[0.0, 0.5, 1.0]], np.float32), gb)
    np.testing.assert_allclose(resolved, [[0.0, (0.5 + 0.5 + 0.0 + 1.0) / 4, 1.0]])


def test_multisampled_gbuffers_backproject_once_per_pixel():
    setup = ss.scenes.get("columns", width=96, height=96)
    single, multi = ss.gbuffer(setup.scene, setup.camera), ss.gbuffer(setup.scene, setup.camera, msaa=4)
    v1 = ss.backprojection(setup.scene, setup.light, single, resolution=512)
    v4, stats = ss.backprojection(setup.scene, setup.light, multi, resolution=512, return_stats=True)
    depth = np.linalg.norm(single.positions - setup.camera.eye, axis=-1)
    agree = single.mask & np.all(np.abs(multi.sample_depths - depth[..., None]) <= 0.01 * depth[..., None], axis=-1)
    np.testing.assert_array_equal(v4[agree], v1[agree])
    assert np.any(v4[single.mask & ~agree] != v1[single.mask & ~agree])
    assert 0 < stats["msaa_overhead"] < 1

"""Alias-free shadow maps against the ray-traced oracle on the same samples."""

import dataclasses
import importlib.util

import numpy as np
import pytest

import softshadows as ss

needs_pymeshlab = pytest.mark.skipif(
    importlib.util.find_spec("pymeshlab") is None, reason='needs pip install "softshadows[models]"'
)


def oracle(scene, light, receivers, **options):
    """``ray_traced`` casting as ``alias_free``'s default does: closed meshes' triangles from the
    receiver itself, only where it lies in front of them (no bias); open meshes' from the receiver
    moved ``scene.epsilon``."""
    return ss.ray_traced(scene, light, receivers, caster_faces="backfacing", **options)


def case(name, size=96, **options):
    setup = ss.scenes.get(name, width=size, height=size, **options)
    return setup, ss.gbuffer(setup.scene, setup.camera)


@pytest.mark.parametrize("name", ["columns", "torus_knot", pytest.param("bunny", marks=needs_pymeshlab)])
def test_hard_shadows_equal_ray_tracing_without_a_bias_in_closed_mode(name):
    setup, gb = case(name, size=256 if name == "bunny" else 128)
    light = ss.PointLight(setup.light.center)
    # Closed casters: back faces only, tested from the receiver itself; the ground (open) uses
    # scene.epsilon. The oracle casts alike. (Against ray_traced's shadow rays started 1/100 of
    # the default offset off the surface, 2 of the bunny's 48785 hit pixels differed: the
    # offset, however small, is not the limit.)
    exact = oracle(setup.scene, light, gb, samples=1)
    hard = ss.alias_free(setup.scene, light, gb, caster_faces="backfacing")
    assert set(np.unique(hard[gb.mask])) <= {0.0, 1.0}
    assert exact[gb.mask].min() == 0 and exact[gb.mask].max() == 1
    np.testing.assert_array_equal(hard[gb.mask], exact[gb.mask])
    # The default offset alone moves shadow-boundary pixels (0.14% of the bunny's at 256x256).
    assert np.any(ss.ray_traced(setup.scene, light, gb, samples=1) != exact)


@pytest.mark.parametrize("name", ["columns", "torus_knot", pytest.param("bunny", marks=needs_pymeshlab)])
def test_hard_shadows_with_every_caster_equal_ray_tracing(name):
    setup, gb = case(name)
    light = ss.PointLight(setup.light.center)
    exact = ss.ray_traced(setup.scene, light, gb, samples=1)
    np.testing.assert_array_equal(ss.alias_free(setup.scene, light, gb, caster_faces="all")[gb.mask], exact[gb.mask])


@pytest.mark.parametrize("kind", ["rect", "disk", "sphere", "ellipsoid"])
def test_exact_soft_shadows_give_the_oracles_bits(kind):
    setup, gb = case("columns", light=kind)
    samples = setup.light.samples(256, pattern="poisson", seed=3)
    exact = oracle(setup.scene, setup.light, gb, samples=samples)
    soft, stats = ss.alias_free(setup.scene, setup.light, gb, samples=samples, lut=None, return_stats=True)
    assert np.mean((exact > 0) & (exact < 1) & gb.mask) > 0.02, "needs a penumbra"
    np.testing.assert_array_equal(soft[gb.mask], exact[gb.mask])
    # Bias-free for the closed columns (section 3.3), area lights included; with every caster,
    # from receivers moved scene.epsilon, the definition's bits.
    offset = ss.ray_traced(setup.scene, setup.light, gb, samples=samples)
    assert np.mean((offset != exact)[gb.mask]) > 0.005
    every = ss.alias_free(setup.scene, setup.light, gb, samples=samples, lut=None, caster_faces="all")
    np.testing.assert_array_equal(every[gb.mask], offset[gb.mask])
    lut = ss.alias_free(setup.scene, setup.light, gb, samples=samples)
    assert np.abs(lut - exact)[gb.mask].mean() < 0.01
    assert stats["light_samples"] == 256 and stats["view_samples"] > 0 and 0 < stats["occupied_texels_percent"] <= 100
    assert stats["max_list_length"] >= stats["average_list_length"] >= 1
    for stage in ("list_build", "rasterization", "visibility"):
        assert stats[f"{stage}_seconds"] > 0


@needs_pymeshlab
def test_exact_soft_shadows_on_a_closed_scan():
    setup, gb = case("bunny", size=64)
    samples = setup.light.samples(128, pattern="poisson", seed=1)
    exact = oracle(setup.scene, setup.light, gb, samples=samples)
    soft = ss.alias_free(setup.scene, setup.light, gb, samples=samples, lut=None)
    np.testing.assert_array_equal(soft[gb.mask], exact[gb.mask])


@pytest.mark.parametrize(
    "name, options",
    [("columns", {"light": "rect"}), ("columns", {"light": "sphere"}), ("fence", {}), pytest.param("bunny", {}, marks=needs_pymeshlab)],
)
def test_restricting_to_the_penumbra_changes_nothing(name, options):
    setup, gb = case(name, **options)
    samples = setup.light.samples(128, pattern="poisson", seed=6)
    exact = oracle(setup.scene, setup.light, gb, samples=samples)
    assert exact[gb.mask].min() == 0 and exact[gb.mask].max() == 1, "needs umbra and lit receivers"
    for lut in (None, 64):
        whole = ss.alias_free(setup.scene, setup.light, gb, samples=samples, lut=lut, restrict_to_penumbra=False)
        restricted, stats = ss.alias_free(setup.scene, setup.light, gb, samples=samples, lut=lut, return_stats=True)
        np.testing.assert_array_equal(restricted, whole)
    # Most of the map is left to the one test against the light's center.
    assert stats["silhouette_edges"] > 0 and 0 < stats["penumbra_texels_percent"] < 50


def test_textured_lights_weight_their_samples():
    setup, gb = case("columns", size=64)
    c, u, v = setup.light.center, setup.light.u, setup.light.v
    light = ss.RectLight(c, u, v, emission=np.array([[1.0, 3.0], [0.5, 2.0]], dtype=np.float32))
    samples = light.samples(128, seed=2)
    np.testing.assert_allclose(
        ss.alias_free(setup.scene, light, gb, samples=samples, lut=None),
        oracle(setup.scene, light, gb, samples=samples),
        atol=1e-6,
    )


def test_adding_an_occluder_never_raises_visibility():
    from conftest import quad

    setup, gb = case("columns", size=64)
    samples = setup.light.samples(128, seed=5)
    before = ss.alias_free(setup.scene, setup.light, gb, samples=samples)
    extra = quad((0.3, 0.4), 0.3, 0.8)
    after = ss.alias_free(ss.Scene(setup.scene.meshes + [extra]), setup.light, gb, samples=samples)
    assert np.all(after <= before) and np.any(after < before)


@pytest.mark.parametrize(
    "options, match",
    [
        ({"samples": 0}, "samples"),
        ({"samples": 1025}, "samples"),
        ({"caster_faces": "front"}, "caster_faces"),
        ({"lut": 2}, "lut"),
        ({"hull_degree": 2}, "hull_degree"),
        ({"bias": -1.0}, "bias"),
        ({"resolution": 0}, "resolution"),
    ],
)
def test_bad_options_name_the_argument(options, match):
    setup, gb = case("ground_sphere", size=16)
    with pytest.raises(ValueError, match=match):
        ss.alias_free(setup.scene, setup.light, gb, **options)


def test_receivers_without_hits_and_lights_inside_geometry_are_defined():
    setup, gb = case("ground_sphere", size=16)
    empty = dataclasses.replace(gb, mask=np.zeros_like(gb.mask))
    assert np.all(ss.alias_free(setup.scene, setup.light, empty, samples=16) == 0)
    inside = ss.SphereLight(np.asarray(setup.occluders[0].vertices).mean(axis=0), 0.05)
    samples = inside.samples(16)
    vis = ss.alias_free(setup.scene, inside, gb, samples=samples, lut=None)
    ref = oracle(setup.scene, inside, gb, samples=samples)
    assert vis.shape == gb.mask.shape and np.all(np.isfinite(vis))
    np.testing.assert_array_equal(vis, ref)


@pytest.mark.parametrize("kind", ["disk", "sphere"])
def test_rotated_lookups_for_symmetric_lights(kind):
    setup, gb = case("columns", size=64, light=kind)
    samples = setup.light.samples(128, pattern="poisson", seed=4)
    exact = oracle(setup.scene, setup.light, gb, samples=samples, rotate="per_receiver", seed=9)
    soft = ss.alias_free(setup.scene, setup.light, gb, samples=samples, rotate="per_receiver", seed=9, lut=None)
    np.testing.assert_array_equal(soft[gb.mask], exact[gb.mask])
    assert np.any(exact != oracle(setup.scene, setup.light, gb, samples=samples))
    lut = ss.alias_free(setup.scene, setup.light, gb, samples=samples, rotate="per_receiver", seed=9)
    assert np.abs(lut - exact)[gb.mask].mean() < 0.01


def test_rect_lights_refuse_rotated_lookups():
    setup, gb = case("columns", size=16)
    with pytest.raises(ValueError, match="rotate"):
        ss.alias_free(setup.scene, setup.light, gb, samples=16, rotate="per_receiver")


def twice_as_large(light, samples):
    """``samples`` scaled by 2 about the light's center: the samples of a light twice as large."""
    center = np.asarray(light.center, np.float32)
    return center + 2 * (samples - center)


@pytest.mark.parametrize("kind", ["rect", "disk", "sphere"])
def test_samples_off_the_light_give_the_oracles_bits(kind):
    # Sintorn et al. 2008 take samples anywhere: the influence regions, the penumbra restriction
    # and the receivers that face the light must bound the samples given, not the light (they
    # bounded the light's own extent: 329 of these 1024 pixels differed for the rect light).
    setup, gb = case("columns", size=32, light=kind)
    on = setup.light.samples(32, seed=3)
    samples = twice_as_large(setup.light, on)
    exact = oracle(setup.scene, setup.light, gb, samples=samples)
    assert np.mean((exact != oracle(setup.scene, setup.light, gb, samples=on))[gb.mask]) > 0.1
    for restrict in (True, False):
        vis = ss.alias_free(setup.scene, setup.light, gb, samples=samples, lut=None, restrict_to_penumbra=restrict)
        np.testing.assert_array_equal(vis, exact)


@pytest.mark.parametrize("kind", ["rect", "disk", "sphere"])
def test_lookup_tables_span_samples_off_the_light(kind):
    # The table's distances covered the light only: planes past it but not past the samples were
    # decided by the light's center (errors up to 0.36 for these samples).
    setup, gb = case("columns", size=32, light=kind)
    samples = twice_as_large(setup.light, setup.light.samples(64, seed=3))
    exact = oracle(setup.scene, setup.light, gb, samples=samples)
    lut = ss.alias_free(setup.scene, setup.light, gb, samples=samples)
    assert np.abs(lut - exact)[gb.mask].max() < 0.15


def test_point_lights_refuse_samples_off_their_position():
    # A point light's one bit is its position: samples elsewhere were silently ignored.
    setup, gb = case("ground_sphere", size=16)
    light = ss.PointLight(setup.light.center)
    at = np.tile(np.float32(setup.light.center), (3, 1))
    np.testing.assert_array_equal(ss.alias_free(setup.scene, light, gb, samples=at), ss.alias_free(setup.scene, light, gb))
    with pytest.raises(ValueError, match="^samples: .*SphereLight"):
        ss.alias_free(setup.scene, light, gb, samples=at + np.float32([0.1, 0, 0]))


def lights_around(center, half, kinds=("rect", "disk", "sphere")):
    """A rect (half-sides ``half``), disk or sphere (radius ``half``) light at ``center``, facing down."""
    make = {"rect": lambda: ss.RectLight(center, (half, 0, 0), (0, 0, -half)),
            "disk": lambda: ss.DiskLight(center, (0, -1, 0), half),
            "sphere": lambda: ss.SphereLight(center, half)}
    return [make[k]() for k in kinds]


@pytest.mark.parametrize("light", lights_around((0, 3, 0), 10.0), ids=["rect", "disk", "sphere"])
def test_the_table_leaves_lights_larger_than_the_scene_to_the_exact_tests(light):
    # The table's bins are relative to the light: under a light 10x the scene its binned planes
    # put up to 0.11 of the light on the wrong side of a receiver (mean 0.03 over the hit pixels;
    # ordinary lights: 0.005). Every receiver sees the light wider than TABLE_MAX_SPREAD here.
    setup, gb = case("ground_sphere", size=16)
    samples = light.samples(64, pattern="poisson", seed=3)
    exact = oracle(setup.scene, light, gb, samples=samples)
    assert np.mean((exact > 0) & (exact < 1) & gb.mask) > 0.3, "needs a penumbra"
    vis, stats = ss.alias_free(setup.scene, light, gb, samples=samples, return_stats=True)
    np.testing.assert_array_equal(vis[gb.mask], exact[gb.mask])
    assert stats["exact_view_samples"] == stats["view_samples"] > 0


@pytest.mark.parametrize("half", [1e19, 1e20])
def test_extreme_rect_lights_are_exact_or_refused(half):
    # A rect light of half-side 1e19 got a mean error of 0.38 through the table, one of 1e20
    # (whose extent overflows float32) visibility 0 on every pixel where the oracle has 0.90.
    setup, gb = case("ground_sphere", size=16)
    light = ss.RectLight((0, 3, 0), (half, 0, 0), (0, 0, -half))
    samples = light.samples(64, pattern="poisson", seed=3)
    exact = oracle(setup.scene, light, gb, samples=samples)
    try:
        vis = ss.alias_free(setup.scene, light, gb, samples=samples)
    except ValueError as error:
        assert str(error).startswith(("light:", "samples:")), error
        return
    np.testing.assert_array_equal(vis[gb.mask], exact[gb.mask])


def test_receivers_near_a_wide_light_test_exactly_and_the_others_keep_the_table():
    # A light of half-side 1 at height 3: wider than TABLE_MAX_SPREAD from the ground below it,
    # not from the ground farther out and the sphere's far side.
    setup, gb = case("ground_sphere", size=32)
    light = ss.RectLight((0, 3, 0), (1.0, 0, 0), (0, 0, -1.0))
    samples = light.samples(64, pattern="poisson", seed=3)
    exact = oracle(setup.scene, light, gb, samples=samples)
    vis, stats = ss.alias_free(setup.scene, light, gb, samples=samples, return_stats=True)
    assert 0 < stats["exact_view_samples"] < stats["view_samples"]
    radius = np.linalg.norm(samples - np.float32(light.center), axis=1).max()
    spread = 0.4  # TABLE_MAX_SPREAD of rust/core/src/methods/alias_free/mod.rs
    near = gb.mask & (np.linalg.norm(gb.positions - np.float32(light.center), axis=-1) < 0.99 * radius / spread)
    assert near.sum() > 50 and (gb.mask & ~near).sum() > 50
    np.testing.assert_array_equal(vis[near], exact[near])
    assert np.abs(vis - exact)[gb.mask & ~near].mean() < 0.01


@pytest.mark.parametrize("name, kind", [("ground_sphere", "rect"), ("columns", "sphere"), ("torus_knot", "disk")])
def test_ordinary_lights_keep_the_table_for_every_receiver(name, kind):
    setup, gb = case(name, size=48, light=kind)
    vis, stats = ss.alias_free(setup.scene, setup.light, gb, samples=64, return_stats=True)
    assert stats["exact_view_samples"] == 0 and stats["view_samples"] > 0
    # Receivers on the closed occluders face out: the paper's bias-free culling serves them all.
    assert stats["inside_view_samples"] == 0


def inward_receivers(setup, gb):
    """The G-buffer's hits on the closed sphere of ``ground_sphere``, with their normals turned
    into it, and hits on the ground moved up into the sphere's lower half, facing up."""
    on = gb.mask & (gb.face_ids >= 2)
    sphere = np.asarray(setup.occluders[0].vertices, np.float64)
    center, radius = sphere.mean(axis=0), np.linalg.norm(sphere - sphere.mean(axis=0), axis=1).min()
    inner = center + (np.random.default_rng(0).uniform(-1, 1, (40, 3)) * radius * 0.5)
    points = np.concatenate([gb.positions[on], inner]).astype(np.float32)
    normals = np.concatenate([-gb.normals[on], np.tile([0, 1, 0], (len(inner), 1))]).astype(np.float32)
    return ss.Receivers(points, normals)


@pytest.mark.parametrize("kind", ["rect", "point"])
def test_receivers_inside_a_closed_mesh_are_shadowed_as_the_oracle_says(kind):
    # Culling to back faces (Sintorn et al. 2008, section 3.3) assumes receivers outside closed
    # meshes; from inside, a shadow ray leaves through a light front-facing triangle. These got
    # 1.0 where ray_traced gives 0 (36 of 95 of the sphere's hits for the rect light).
    setup, gb = case("ground_sphere", size=24, light=kind)
    light = ss.PointLight(setup.light.center) if kind == "point" else setup.light
    rx = inward_receivers(setup, gb)
    samples = 1 if kind == "point" else light.samples(64, seed=2)
    exact = oracle(setup.scene, light, rx, samples=samples)
    assert np.all(exact == 0)
    vis, stats = ss.alias_free(setup.scene, light, rx, samples=samples, lut=None, return_stats=True)
    np.testing.assert_array_equal(vis, exact)
    assert stats["inside_view_samples"] > 0
    # The table approximates each plane: at most a few samples through the gaps it leaves.
    assert np.abs(ss.alias_free(setup.scene, light, rx, samples=samples) - exact).max() <= 4 / 64
    # stsv's opaque part is alias_free's bitmasks, culling included.
    np.testing.assert_array_equal(ss.stsv(setup.scene, light, rx, samples=samples), exact)


@pytest.mark.parametrize("name, kind", [("columns", "rect"), ("torus_knot", "sphere"), ("ground_sphere", "point"), ("leaves", "disk")])
def test_the_shadow_does_not_depend_on_the_light_space_resolution(name, kind):
    # The alias-free property (Sintorn et al. 2008, section 3): the lists only decide which
    # receivers a triangle is tested against, never the answer, so the same bits at 2^2 texels
    # as at 2048^2. (The lookup table's answers do vary with it: the penumbra texels, where the
    # table is read, are fewer at finer resolutions, 408 of 4096 pixels between 2 and 16 here.)
    setup, gb = case(name, size=64, light=kind)
    light = ss.PointLight(setup.light.center) if kind == "point" else setup.light
    samples = 1 if kind == "point" else light.samples(64, seed=3)
    coarse = ss.alias_free(setup.scene, light, gb, samples=samples, resolution=2, lut=None)
    assert np.mean((coarse > 0) & (coarse < 1) & gb.mask) > 0.01 or kind == "point"
    assert np.any(coarse[gb.mask] < 1)
    for resolution in (16, 512, 2048):
        fine = ss.alias_free(setup.scene, light, gb, samples=samples, resolution=resolution, lut=None)
        np.testing.assert_array_equal(fine, coarse, err_msg=f"resolution {resolution}")


def test_accumulated_jittered_frames_are_the_union_of_their_samples_and_converge():
    # Sintorn et al. 2008, section 4.3 and Figure 7: each frame jitters the pattern and frames
    # are accumulated. With exact plane tests the mean of F frames of S samples is the visibility
    # of the union of their F * S samples, and so converges to the many-sample result.
    setup, gb = case("columns", size=48)
    frames, n = 8, 32
    images = [ss.alias_free(setup.scene, setup.light, gb, samples=n, frame=f, lut=None) for f in range(frames)]
    union = np.concatenate([setup.light.samples(n, frame=f) for f in range(frames)])
    np.testing.assert_allclose(np.mean(images, axis=0), oracle(setup.scene, setup.light, gb, samples=union), atol=1e-6)
    assert not np.array_equal(images[0], images[1]), "each frame jitters its samples"
    reference = oracle(setup.scene, setup.light, gb, samples=4096)
    error = [np.sqrt(np.mean((np.mean(images[:k], axis=0) - reference)[gb.mask] ** 2)) for k in (1, frames)]
    assert error[1] < 0.6 * error[0], error

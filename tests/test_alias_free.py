"""Alias-free shadow maps against the ray-traced oracle on the same samples."""

import dataclasses
import importlib.util

import numpy as np
import pytest

import softshadows as ss

needs_pymeshlab = pytest.mark.skipif(
    importlib.util.find_spec("pymeshlab") is None, reason='needs pip install "softshadows[models]"'
)


def case(name, size=96, **options):
    setup = ss.scenes.get(name, width=size, height=size, **options)
    return setup, ss.gbuffer(setup.scene, setup.camera)


@pytest.mark.parametrize("name", ["columns", "torus_knot", pytest.param("bunny", marks=needs_pymeshlab)])
def test_hard_shadows_equal_ray_tracing_without_a_bias_in_closed_mode(name):
    setup, gb = case(name, size=256 if name == "bunny" else 128)
    light = ss.PointLight(setup.light.center)
    # Closed casters: back faces only, tested from the receiver itself; the ground (open) uses
    # scene.epsilon. The oracle is taken in the same limit: its shadow rays start 1/100 of the
    # default offset off the surface (the default offset alone moves 0.14% of the bunny's
    # shadow-boundary pixels at 256x256).
    exact = ss.ray_traced(setup.scene, light, gb, samples=1, epsilon=setup.scene.epsilon / 100)
    hard = ss.alias_free(setup.scene, light, gb, casters="backfacing")
    assert set(np.unique(hard[gb.mask])) <= {0.0, 1.0}
    assert exact[gb.mask].min() == 0 and exact[gb.mask].max() == 1
    assert np.mean((hard == exact)[gb.mask]) >= 0.999


@pytest.mark.parametrize("name", ["columns", "torus_knot", pytest.param("bunny", marks=needs_pymeshlab)])
def test_hard_shadows_with_every_caster_equal_ray_tracing(name):
    setup, gb = case(name)
    light = ss.PointLight(setup.light.center)
    exact = ss.ray_traced(setup.scene, light, gb, samples=1)
    assert np.mean((ss.alias_free(setup.scene, light, gb, casters="all") == exact)[gb.mask]) >= 0.999


@pytest.mark.parametrize("kind", ["rect", "disk", "sphere", "ellipsoid"])
def test_exact_soft_shadows_give_the_oracles_bits(kind):
    setup, gb = case("columns", light=kind)
    samples = setup.light.samples(256, pattern="poisson", seed=3)
    exact = ss.ray_traced(setup.scene, setup.light, gb, samples=samples)
    soft, stats = ss.alias_free(setup.scene, setup.light, gb, samples=samples, lut=None, return_stats=True)
    assert np.mean((exact > 0) & (exact < 1) & gb.mask) > 0.02, "needs a penumbra"
    assert np.mean((soft == exact)[gb.mask]) >= 0.995
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
    exact = ss.ray_traced(setup.scene, setup.light, gb, samples=samples)
    soft = ss.alias_free(setup.scene, setup.light, gb, samples=samples, lut=None)
    assert np.mean((soft == exact)[gb.mask]) >= 0.995


@pytest.mark.parametrize(
    "name, options",
    [("columns", {"light": "rect"}), ("columns", {"light": "sphere"}), ("fence", {}), pytest.param("bunny", {}, marks=needs_pymeshlab)],
)
def test_restricting_to_the_penumbra_changes_nothing(name, options):
    setup, gb = case(name, **options)
    samples = setup.light.samples(128, pattern="poisson", seed=6)
    exact = ss.ray_traced(setup.scene, setup.light, gb, samples=samples)
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
        ss.ray_traced(setup.scene, light, gb, samples=samples),
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
        ({"casters": "front"}, "casters"),
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
    ref = ss.ray_traced(setup.scene, inside, gb, samples=samples)
    assert vis.shape == gb.mask.shape and np.all(np.isfinite(vis))
    assert np.mean((vis == ref)[gb.mask]) > 0.99


@pytest.mark.parametrize("kind", ["disk", "sphere"])
def test_rotated_lookups_for_symmetric_lights(kind):
    setup, gb = case("columns", size=64, light=kind)
    samples = setup.light.samples(128, pattern="poisson", seed=4)
    exact = ss.ray_traced(setup.scene, setup.light, gb, samples=samples, rotate="per_receiver", seed=9)
    soft = ss.alias_free(setup.scene, setup.light, gb, samples=samples, rotate="per_receiver", seed=9, lut=None)
    assert np.mean((soft == exact)[gb.mask]) >= 0.995
    assert np.any(exact != ss.ray_traced(setup.scene, setup.light, gb, samples=samples))
    lut = ss.alias_free(setup.scene, setup.light, gb, samples=samples, rotate="per_receiver", seed=9)
    assert np.abs(lut - exact)[gb.mask].mean() < 0.01


def test_rect_lights_refuse_rotated_lookups():
    setup, gb = case("columns", size=16)
    with pytest.raises(ValueError, match="rotate"):
        ss.alias_free(setup.scene, setup.light, gb, samples=16, rotate="per_receiver")

"""Depth complexity sampling against the ray-traced oracle on the same samples."""

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


@pytest.mark.parametrize(
    "name, kind",
    [("columns", "rect"), ("torus_knot", "disk"), ("ground_sphere", "sphere"), ("columns", "ellipsoid"),
     pytest.param("bunny", "rect", marks=needs_pymeshlab)],
)
def test_counts_give_the_oracles_bits_on_closed_meshes(name, kind):
    setup, gb = case(name, light=kind)
    samples = setup.light.samples(64, pattern="poisson", seed=3)
    exact = ss.ray_traced(setup.scene, setup.light, gb, samples=samples)
    assert np.mean((exact > 0) & (exact < 1) & gb.mask) > 0.05, "needs a penumbra"
    vis, stats = ss.dcs(setup.scene, setup.light, gb, samples=samples, return_stats=True)
    assert np.mean((vis == exact)[gb.mask]) >= 0.995
    assert stats["silhouette_edges"] > 0 and stats["wedge_tests"] > 0 and stats["light_samples"] == 64


@pytest.mark.parametrize("options", [{"rotate": "per_receiver"}, {"interleaved": 3}, {"pattern": "sobol", "frame": 2}])
def test_decorrelated_samples_follow_each_receiver(options):
    setup, gb = case("columns", size=64, light="disk")
    exact = ss.ray_traced(setup.scene, setup.light, gb, samples=16, seed=4, **options)
    vis = ss.dcs(setup.scene, setup.light, gb, samples=16, seed=4, **options)
    assert np.mean((vis == exact)[gb.mask]) >= 0.995
    assert np.any(exact != ss.ray_traced(setup.scene, setup.light, gb, samples=16, seed=4))


def test_point_lights_give_hard_shadows_by_counting():
    setup, gb = case("torus_knot", size=64)
    light = ss.PointLight(setup.light.center)
    hard = ss.dcs(setup.scene, light, gb)
    assert set(np.unique(hard[gb.mask])) == {0.0, 1.0}
    assert np.mean((hard == ss.ray_traced(setup.scene, light, gb, samples=1))[gb.mask]) >= 0.999


def test_perforated_meshes_are_left_to_stsv():
    setup, gb = case("fence", size=16)
    with pytest.raises(ValueError, match="stsv"):
        ss.dcs(setup.scene, setup.light, gb)


@pytest.mark.parametrize("options, match", [({"resolution": 0}, "resolution"), ({"hull_degree": 2}, "hull_degree"),
                                            ({"epsilon": -1.0}, "epsilon"), ({"samples": 0}, "samples")])
def test_bad_options_name_the_argument(options, match):
    setup, gb = case("ground_sphere", size=16)
    with pytest.raises(ValueError, match=match):
        ss.dcs(setup.scene, setup.light, gb, **options)

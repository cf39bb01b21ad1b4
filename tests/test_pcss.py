"""Percentage-closer soft shadows: the single-view baseline and its known failure."""

import numpy as np
import pytest

import softshadows as ss


def case(name, size=128, **options):
    setup = ss.scenes.get(name, width=size, height=size, **options)
    return setup, ss.gbuffer(setup.scene, setup.camera)


def test_misses_a_thin_occluder_that_vwss_keeps():
    """Marrs et al. 2018, Figure 10: the blocker search steps over a thin blade. Measure: among the pixels
    the reference puts in the blade's shadow (V < 0.5), the share lit more than 0.25 too much."""
    setup, gb = case("sword")
    reference = ss.ray_traced(setup.scene, setup.light, gb, samples=256)
    shadow = (reference < 0.5) & gb.mask
    assert shadow.sum() > 50
    samples = setup.light.samples(24, pattern="poisson", seed=0)
    pcss = ss.pcss(setup.scene, setup.light, gb)
    vwss = ss.vwss(setup.scene, setup.light, gb, samples=samples)
    holes = {name: np.mean((vis - reference)[shadow] > 0.25) for name, vis in [("pcss", pcss), ("vwss", vwss)]}
    assert holes["pcss"] > 0.05 and holes["vwss"] < holes["pcss"] / 4, holes


def test_fuses_occluders_at_two_depths_that_mvr_and_vwss_keep_apart():
    """Marrs et al. 2018, section 2.1 and Figure 10 (bottom): where a high plate and a low block
    both shadow the ground, PCSS sizes one penumbra from their average depth; the multi-view maps
    keep each occluder at its own depth. RMSE against the reference on the pixels both shadow."""
    from softshadows.claims.marrs18 import _fusion_scene

    setup, gb, both = _fusion_scene(96)
    assert both.sum() > 200, "the occluders' shadows must overlap"
    reference = ss.ray_traced(setup.scene, setup.light, gb, samples=1024, pattern="sobol", seed=1)
    samples = setup.light.samples(24, pattern="poisson", seed=0)
    error = {
        name: ss.metrics.rmse(vis, reference, both)
        for name, vis in [
            ("pcss", ss.pcss(setup.scene, setup.light, gb)),
            ("mvr", ss.mvr(setup.scene, setup.light, gb, samples=samples)),
            ("vwss", ss.vwss(setup.scene, setup.light, gb, samples=samples)),
        ]
    }
    assert error["pcss"] > 2 * max(error["mvr"], error["vwss"]), error


@pytest.mark.parametrize("name", ["columns", "torus_knot"])
def test_error_against_the_reference_lies_between_vwss_and_a_hard_shadow(name):
    setup, gb = case(name)
    reference = ss.ray_traced(setup.scene, setup.light, gb, samples=256)
    samples = setup.light.samples(24, pattern="poisson", seed=0)
    rmse = {
        "pcss": ss.metrics.rmse(ss.pcss(setup.scene, setup.light, gb), reference, gb.mask),
        "vwss": ss.metrics.rmse(ss.vwss(setup.scene, setup.light, gb, samples=samples), reference, gb.mask),
        "shadow_map": ss.metrics.rmse(ss.shadow_map(setup.scene, setup.light, gb, pcf=5), reference, gb.mask),
    }
    print(f"{name} RMSE against 256 ray-traced samples: {rmse}")
    assert rmse["vwss"] < rmse["pcss"] < rmse["shadow_map"], rmse


def test_a_point_sized_light_gives_the_hard_shadow_map():
    setup, gb = case("columns", size=96)
    tiny = ss.SphereLight(setup.light.center, 1e-6)  # a rect light would turn the map towards its edges
    soft, stats = ss.pcss(setup.scene, tiny, gb, resolution=512, return_stats=True)
    hard = ss.shadow_map(setup.scene, tiny, gb, resolution=512)
    assert np.mean((soft != hard)[gb.mask]) < 0.002
    assert 0 < stats["no_blocker"] < 1 and stats["search_near"] > 0 and stats["depth_map_seconds"] > 0


def test_larger_lights_widen_the_penumbra():
    setup, gb = case("ground_sphere", size=96)
    c, u, v = setup.light.center, np.asarray(setup.light.u), np.asarray(setup.light.v)
    widths = [
        np.mean(((vis := ss.pcss(setup.scene, ss.RectLight(c, u * k, v * k), gb)) > 0.02) & (vis < 0.98) & gb.mask)
        for k in (0.25, 1.0, 2.0)
    ]
    assert widths[0] < widths[1] < widths[2], widths


def test_a_nearer_search_plane_searches_wider_and_finds_more_blockers():
    setup, gb = case("columns", size=64)
    _, default = ss.pcss(setup.scene, setup.light, gb, return_stats=True)
    _, near = ss.pcss(setup.scene, setup.light, gb, near=0.5 * default["search_near"], return_stats=True)
    assert near["search_near"] < default["search_near"] and near["no_blocker"] < default["no_blocker"]


@pytest.mark.parametrize(
    "options, match",
    [
        ({"blocker_samples": 0}, "blocker_samples"),
        ({"filter_samples": 5000}, "filter_samples"),
        ({"near": -1.0}, "near"),
        ({"bias": float("nan")}, "bias"),
        ({"resolution": 0}, "resolution"),
        ({"seed": -1}, "seed"),
    ],
)
def test_bad_options_name_the_argument(options, match):
    setup, gb = case("ground_sphere", size=16)
    with pytest.raises(ValueError, match=match):
        ss.pcss(setup.scene, setup.light, gb, **options)

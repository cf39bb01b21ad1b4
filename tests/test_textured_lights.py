"""A light's emission texture through every method: weighted into the result, or refused with a
ValueError naming ``light``; never ignored."""

import numpy as np
import pytest

import softshadows as ss
from softshadows.methods import METHODS, SAMPLED

#: The methods that filter one shadow map from the light's center and cannot weight a texture.
REFUSING = {"shadow_map", "pcss", "cssm", "backprojection"}


@pytest.fixture(scope="module")
def case():
    """The columns under their rect light, and the same light emitting from one half only: the
    shadows move, so a method that ignored the texture would give the untextured result."""
    setup = ss.scenes.get("columns", width=48, height=48)
    gb = ss.gbuffer(setup.scene, setup.camera)
    light = setup.light
    half = np.zeros((8, 8), np.float32)
    half[:, :4] = 1.0  # texture columns j < W/2: the u < 0 half of the rect
    textured = ss.RectLight(light.center, light.u, light.v, emission=half)
    return setup, gb, light, textured


@pytest.mark.parametrize("name", list(METHODS))
def test_a_textured_light_is_used_or_refused(name, case):
    setup, gb, plain, textured = case
    samples = textured.samples(64, pattern="sobol", seed=1)
    kwargs = {"samples": samples} if name in SAMPLED else {}
    if name == "denoised":
        kwargs["spp"] = 16  # one ray per pixel leaves noise as large as the texture's effect here
    if name in REFUSING:
        with pytest.raises(ValueError, match="light"):
            METHODS[name](setup.scene, textured, gb, **kwargs)
        return
    vis = METHODS[name](setup.scene, textured, gb, **kwargs)
    with_texture = ss.ray_traced(setup.scene, textured, gb, samples=samples)
    without = ss.ray_traced(setup.scene, plain, gb, samples=samples)
    assert ss.metrics.rmse(with_texture, without, gb.mask) > 0.02  # the texture matters here
    assert ss.metrics.rmse(vis, with_texture, gb.mask) < 0.5 * ss.metrics.rmse(vis, without, gb.mask)


# alias_free with every caster from the moved receiver, as ray_traced traces the halves.
EXACT = {"ray_traced": {}, "alias_free": {"lut": None, "caster_faces": "all"}, "dcs": {}, "stsv": {}}


@pytest.mark.parametrize("name", list(EXACT))
def test_the_weighting_matches_an_independent_average_over_the_two_halves(name):
    """A light emitting 1 from one half and 3 from the other: each method's visibility is the
    emission-weighted mean of the two halves' visibilities, each computed here by tracing only
    that half's samples with an untextured light (no weight function involved)."""
    setup = ss.scenes.get("columns", width=32, height=32)
    gb = ss.gbuffer(setup.scene, setup.camera)
    light = setup.light
    emission = np.ones((4, 4), np.float32)
    emission[:, 2:] = 3.0
    textured = ss.RectLight(light.center, light.u, light.v, emission=emission)
    samples = light.samples(256, pattern="sobol", seed=2)
    # The sample's parameter u in [-1, 1] along the rect's u axis: columns j < W/2 are u < 0.
    u = (samples - np.asarray(light.center)) @ np.asarray(light.u) / np.dot(light.u, light.u)
    halves = [(samples[u < 0], 1.0), (samples[u >= 0], 3.0)]
    weighted = [w * len(s) * ss.ray_traced(setup.scene, light, gb, samples=s).astype(np.float64) for s, w in halves]
    expected = sum(weighted) / sum(w * len(s) for s, w in halves)
    unweighted = ss.ray_traced(setup.scene, light, gb, samples=samples)
    assert np.abs(expected - unweighted)[gb.mask].max() > 0.1  # the weights matter here
    got = METHODS[name](setup.scene, textured, gb, samples=samples, rotate=None, **EXACT[name])
    np.testing.assert_allclose(got[gb.mask], expected[gb.mask], atol=1e-6)

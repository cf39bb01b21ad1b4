"""The oracle agrees with Mitsuba's own ray_test on the same samples (docs/design.md sections 3-4)."""

import numpy as np
import pytest

import softshadows as ss
from softshadows import reference, scenes

pytestmark = pytest.mark.mitsuba


@pytest.mark.parametrize("name", ["bunny", "columns", "fence", "leaves"])
def test_ray_traced_matches_mitsuba_ray_test(name, tmp_path, monkeypatch):
    monkeypatch.setenv("SOFTSHADOWS_CACHE", str(tmp_path))  # a fresh reference, not a cached one
    setup = scenes.get(name, width=128, height=128)
    gb = ss.gbuffer(setup.scene, setup.camera)
    samples = setup.light.samples(64, pattern="poisson", seed=7)
    ours = ss.ray_traced(setup.scene, setup.light, gb, samples=samples)
    theirs = reference.mitsuba_visibility(setup.scene, setup.light, gb, samples)
    hit = gb.mask
    same = np.mean(ours[hit] == theirs[hit])
    assert hit.sum() > 1000
    # The scene must actually have penumbrae, or agreement would be trivial.
    assert np.mean((theirs[hit] > 0) & (theirs[hit] < 1)) > 0.01
    assert same >= 0.995, f"{name}: identical on {same:.4%} of hit pixels"


@pytest.mark.slow
@pytest.mark.parametrize("light", ["rect", "disk", "sphere"])
@pytest.mark.parametrize("name", sorted(scenes.SCENES))
def test_every_scene_and_light_matches_mitsuba_at_full_size(name, light, tmp_path, monkeypatch):
    monkeypatch.setenv("SOFTSHADOWS_CACHE", str(tmp_path))
    setup = scenes.get(name, width=256, height=256, light=light)
    gb = ss.gbuffer(setup.scene, setup.camera)
    samples = setup.light.samples(128, pattern="sobol", seed=3)
    ours = ss.ray_traced(setup.scene, setup.light, gb, samples=samples)
    theirs = reference.mitsuba_visibility(setup.scene, setup.light, gb, samples, progress=False)
    same = np.mean(ours[gb.mask] == theirs[gb.mask])
    assert same >= 0.995, f"{name}/{light}: identical on {same:.4%} of hit pixels"


def test_textured_light_weights_agree_with_mitsuba_including_all_black_samples(tmp_path, monkeypatch):
    monkeypatch.setenv("SOFTSHADOWS_CACHE", str(tmp_path))
    ground = ss.Mesh([[-3, 0, -3], [3, 0, -3], [3, 0, 3], [-3, 0, 3]], [[0, 2, 1], [0, 3, 2]])
    blocker = ss.Mesh([[-0.4, 1, -0.4], [0.4, 1, -0.4], [0.4, 1, 0.4], [-0.4, 1, 0.4]], [[0, 2, 1], [0, 3, 2]])
    scene = ss.Scene([ground, blocker])
    light = ss.RectLight((0, 3, 0), (1, 0, 0), (0, 0, -1), emission=np.array([[0.0, 1.0, 3.0], [2.0, 0.5, 0.0]]))
    xs = np.linspace(-2, 2, 41)
    rx = ss.Receivers(np.c_[xs, np.zeros_like(xs), np.full_like(xs, 0.2)], np.tile([0, 1, 0], (len(xs), 1)))
    samples = light.samples(256, pattern="sobol", seed=2)
    ours = ss.ray_traced(scene, light, rx, samples=samples)
    theirs = reference.mitsuba_visibility(scene, light, rx, samples, progress=False)
    assert np.mean((ours > 0) & (ours < 1)) > 0.3  # a penumbra, not a trivial all-lit answer
    assert not np.allclose(ours, ours[::-1], atol=0.02)  # the texture makes it asymmetric in x
    np.testing.assert_allclose(ours, theirs, atol=1e-6)
    # Samples only on black texels (a < -1/3 and b < 0): zero total weight gives V = 0, not NaN.
    black = light.center + np.array([[-0.9, -0.5], [-0.5, -0.9]]) @ np.stack([light.u, light.v])
    assert np.all(light.weights(black) == 0)
    np.testing.assert_array_equal(reference.mitsuba_visibility(scene, light, rx, black, cache=False), 0)
    np.testing.assert_array_equal(ss.ray_traced(scene, light, rx, samples=black), 0)

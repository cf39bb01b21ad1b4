"""The oracle agrees with Mitsuba's own ray_test on the same samples (DESIGN.md sections 3-4)."""

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

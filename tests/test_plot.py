"""Pictures: sample scatter plots lie in the light's plane."""

import numpy as np

import softshadows as ss


def test_show_samples_projects_onto_the_light_plane():
    light = ss.RectLight((0, 5, 0), (2, 0, 0), (0, 0, 0.5))
    samples = light.samples(64, pattern="stratified", seed=1)
    ax = ss.plot.show_samples(light, samples)
    xy = ax.collections[0].get_offsets()
    assert xy.shape == (64, 2)
    # The plane's principal axes: spread 2 along u, 0.5 along v (in some order and sign).
    spans = sorted(np.ptp(np.asarray(xy), axis=0))
    assert spans[1] > 3.5 and 0.8 < spans[0] < 1.0

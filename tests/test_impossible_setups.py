"""Set-ups that cannot mean what they say warn (SetupWarning), with advice that works."""

import importlib.util
import warnings

import numpy as np
import pytest

import softshadows as ss
from softshadows.methods import METHODS, SAMPLED


def ground_scene(size=32):
    setup = ss.scenes.get("columns", width=size, height=size)
    return setup, ss.gbuffer(setup.scene, setup.camera)


def run(name, scene, light, gb):
    options = {"samples": 8} if name in SAMPLED else {}
    if name in ("shadow_map", "pcss", "cssm", "backprojection", "mvr", "vwss"):
        options["resolution"] = 128
    return METHODS[name](scene, light, gb, **options)


def setup_warnings(call):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = call()
    return result, [str(w.message) for w in caught if issubclass(w.category, ss.SetupWarning)]


@pytest.mark.parametrize(
    "light, fixed",
    [
        (ss.RectLight((0, 3, 0), (0.5, 0, 0), (0, 0, -0.5)), lambda l: ss.RectLight(l.center, l.u, -l.v)),
        (ss.DiskLight((0, 3, 0), (0, 1, 0), 0.5), lambda l: ss.DiskLight(l.center, -l.normal, l.radius)),
    ],
)
def test_a_light_facing_away_from_every_receiver_warns_and_its_advice_lights_them(light, fixed):
    setup, gb = ground_scene()
    vis, messages = setup_warnings(lambda: ss.ray_traced(setup.scene, light, gb, samples=16))
    assert len(messages) == 1 and "flip it" in messages[0], messages
    # Visibility alone looks normal; the light emits away, so the shaded image is black.
    assert vis[gb.mask].mean() > 0.5
    assert np.all(ss.shading.direct(gb, light, vis, 0.8)[gb.mask] == 0)
    flipped = fixed(light)
    vis, messages = setup_warnings(lambda: ss.ray_traced(setup.scene, flipped, gb, samples=16))
    assert messages == [] and ss.shading.direct(gb, flipped, vis, 0.8)[gb.mask].max() > 0


@pytest.mark.parametrize("name", list(METHODS))
def test_a_light_under_the_floor_warns_in_every_method(name):
    """Mirrored below the ground, the light lies behind every receiver's surface: ray_traced's
    visibility is 0 everywhere, while the depth-map methods see no occluder and light the floor."""
    setup, gb = ground_scene()
    mirror = np.array([1.0, -1.0, 1.0])
    light = setup.light
    below = ss.RectLight(light.center * mirror, light.u * mirror, -light.v * mirror)
    _, messages = setup_warnings(lambda: run(name, setup.scene, below, gb))
    assert len(messages) == 1 and "under the floor" in messages[0], messages
    _, messages = setup_warnings(lambda: run(name, setup.scene, light, gb))
    assert messages == []


def test_under_the_floor_pcss_leaks_where_shadow_rays_see_nothing():
    setup, gb = ground_scene()
    mirror = np.array([1.0, -1.0, 1.0])
    below = ss.RectLight(setup.light.center * mirror, setup.light.u * mirror, -setup.light.v * mirror)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ss.SetupWarning)
        assert ss.ray_traced(setup.scene, below, gb, samples=16)[gb.mask].max() == 0
        assert ss.pcss(setup.scene, below, gb, resolution=256)[gb.mask].max() > 0.3


@pytest.mark.parametrize("name", list(ss.scenes.SCENES))
def test_no_built_in_scene_warns(name):
    if name in ss.scenes.MODELS and importlib.util.find_spec("pymeshlab") is None:
        pytest.skip('the models need pip install "softshadows[models]"')
    setup = ss.scenes.get(name, width=32, height=32)
    gb = ss.gbuffer(setup.scene, setup.camera)
    with warnings.catch_warnings():
        warnings.simplefilter("error", ss.SetupWarning)
        ss.shadow_map(setup.scene, setup.light, gb, resolution=64)

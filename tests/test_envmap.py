"""Environment maps decomposed into area lights, and shading under them."""

import numpy as np
import pytest

import softshadows as ss
from softshadows import envmap


def latlong_energy(env):
    h, w = env.shape[:2]
    theta = np.pi * (np.arange(h) + 0.5) / h
    domega = (np.pi / h) * (2 * np.pi / w) * np.sin(theta)[:, None, None]
    return (env.astype(np.float64) * domega).sum(axis=(0, 1))


def rects(fit):
    return [(light.face, light.rect) for light in fit.lights]


@pytest.mark.parametrize("threshold", [0.015, 0.025, 0.035])
def test_the_lights_carry_the_maps_energy_and_none_repeats_or_is_empty(threshold):
    env = envmap.sky(64)
    fit = envmap.fit_area_lights(env, threshold=threshold)
    total = sum(light.energy for light in fit.lights)
    np.testing.assert_allclose(total, fit.energy, rtol=1e-9)  # exactly the cube map's energy
    np.testing.assert_allclose(total, latlong_energy(env), rtol=0.01)  # and the lat-long's within 1%
    assert len(set(rects(fit))) == len(fit.lights)
    assert all(light.energy @ [0.2126, 0.7152, 0.0722] > 0 for light in fit.lights)


def test_the_threshold_sets_the_lights_per_face():
    """Section 4.2: t alone decides how far a light grows, so a larger t gives smaller, more
    lights on every face; at the paper's thresholds (0.015 to 0.035) a uniform face is one light."""
    rng = np.random.default_rng(4)
    cube = np.repeat(rng.gamma(2.0, 1.0, (6, 16, 16, 1)).astype(np.float32), 3, axis=-1)
    cube[2] = 1.0  # +y uniform
    per_face = {t: np.bincount([l.face for l in envmap.fit_area_lights(cube, threshold=t).lights], minlength=6)
                for t in (0.01, 0.05, 0.2)}
    assert per_face[0.01][2] == per_face[0.05][2] == 1, per_face
    for face in range(6):
        counts = [per_face[t][face] for t in (0.01, 0.05, 0.2)]
        assert counts[0] <= counts[1] <= counts[2] and counts[0] < counts[2], (face, counts)


def test_a_cap_bounds_the_lights_and_keeps_the_energy():
    env = envmap.sky(64)
    free = envmap.fit_area_lights(env, threshold=0.2)
    capped = envmap.fit_area_lights(env, threshold=0.2, max_lights=8)
    assert len(free.lights) > 8 and len(capped.lights) == 8
    np.testing.assert_allclose(sum(l.energy for l in capped.lights), capped.energy, rtol=1e-9)


def test_a_single_sun_yields_one_dominant_light_at_its_direction():
    sun = np.array([-0.5, 0.7, 0.4])
    env = envmap.sky(64, sun_direction=sun, zenith=(0, 0, 0), horizon=(0, 0, 0), ground=(0, 0, 0))
    fit = envmap.fit_area_lights(env)
    brightest = fit.lights[0]
    share = brightest.energy.sum() / fit.energy.sum()
    angle = np.degrees(np.arccos(np.clip(brightest.direction @ (sun / np.linalg.norm(sun)), -1, 1)))
    assert share > 0.9 and angle < 2.0, (share, angle)


def test_a_fitted_light_placed_in_the_scene_spans_its_cube_rectangle():
    fit = envmap.fit_area_lights(envmap.sky(32), resolution=16)
    center = np.array([1.0, 2.0, 3.0])
    for light in fit.lights:
        rect = light.area_light(center, 50.0)
        corners = [np.asarray(rect.center) + a * np.asarray(rect.u) + b * np.asarray(rect.v) for a in (-1, 1) for b in (-1, 1)]
        directions = [(c - center) / np.linalg.norm(c - center) for c in corners]
        mid = (np.asarray(rect.center) - center) / np.linalg.norm(np.asarray(rect.center) - center)
        np.testing.assert_allclose(mid, light.direction, atol=1e-6)
        assert all(d @ light.direction > 0 for d in directions)
        assert np.dot(rect.normal, light.direction) < 0  # it faces the scene


def test_an_open_receiver_under_a_uniform_sky_gets_the_center_cosine_estimate():
    """Under a uniform environment of radiance L an unoccluded, upward Lambertian receiver
    reflects albedo * L. The paper's center-direction shading gives the six face lights of a
    uniform map their center cosines: only the +y light counts, with solid angle 2 pi / 3 instead
    of the hemisphere's cosine-weighted pi, so 2/3 of the truth."""
    from conftest import quad

    scene = ss.Scene([quad((0, 0), 1.0, 0.0)])
    rx = ss.Receivers([[0.0, 0.0, 0.0], [0.3, 0.0, -0.2]], [[0, 1, 0], [0, 1, 0]])
    fit = envmap.fit_area_lights(np.full((6, 16, 16, 3), 2.0, np.float32))
    assert len(fit.lights) == 6
    out = envmap.environment(scene, fit, rx, method="ray_traced", samples=16, albedo=0.5, progress=False)
    np.testing.assert_allclose(out, 0.5 * 2.0 * 2 / 3, rtol=1e-3)


def test_environment_shadows_come_from_the_method():
    setup = ss.scenes.get("ground_sphere", width=48, height=48)
    gb = ss.gbuffer(setup.scene, setup.camera)
    fit = envmap.fit_area_lights(envmap.sky(32), resolution=16)
    lit = envmap.environment(ss.Scene([setup.ground]), fit, gb, method="cssm", progress=False)
    shadowed = envmap.environment(setup.scene, fit, gb, method="cssm", progress=False)
    assert shadowed.shape == gb.mask.shape + (3,) and np.all(shadowed[~gb.mask] == 0)
    ground = gb.mask & (np.abs(gb.positions[..., 1]) < 1e-4)
    assert np.mean(shadowed[ground].sum(-1) < 0.7 * lit[ground].sum(-1)) > 0.02


@pytest.mark.parametrize(
    "call, match",
    [
        (lambda: envmap.fit_area_lights(np.zeros((6, 8, 8, 3)), threshold=0.0), "threshold"),
        (lambda: envmap.fit_area_lights(np.zeros((6, 8, 8, 3)), max_lights=5), "max_lights"),
        (lambda: envmap.fit_area_lights(-np.ones((6, 8, 8, 3))), "env"),
        (lambda: envmap.fit_area_lights(np.zeros((6, 8, 4, 3))), "env"),
        (lambda: envmap.environment(None, [], None), "method|lights"),
    ],
)
def test_bad_input_names_the_argument(call, match):
    with pytest.raises(ValueError, match=match):
        call()

"""Convolution soft shadow maps: convergence to the hard test, error against the reference,
sharpening, prefiltering."""

import importlib.util

import numpy as np
import pytest

import softshadows as ss

needs_pymeshlab = pytest.mark.skipif(
    importlib.util.find_spec("pymeshlab") is None, reason='needs pip install "softshadows[models]"'
)


def case(name, size=128, **options):
    setup = ss.scenes.get(name, width=size, height=size, **options)
    return setup, ss.gbuffer(setup.scene, setup.camera)


def parallel_plates(grid=160):
    """The paper's exact case (``scenes.parallel_plates``: a 2 x 2 plate 1 over the ground, a
    1 x 1 light 3 above it, penumbrae 1/3 wide) with receivers on a ground grid over [-2, 2]^2
    and on a line across the edge x = 1 (z = 0)."""
    setup = ss.scenes.parallel_plates()
    xs = np.linspace(-2, 2, grid)
    line = np.linspace(0.5, 1.5, 201)
    points = np.vstack([np.stack(np.meshgrid(xs, xs), -1).reshape(-1, 2), np.stack([line, np.zeros_like(line)], 1)])
    rx = ss.Receivers(np.insert(points, 1, 0.0, axis=1), np.tile([0, 1, 0], (len(points), 1)))
    return setup.scene, setup.light, rx, line


def penumbra_width(line, vis):
    """The 10%-90% width of a penumbra along ``line`` (visibility rising with x), interpolated."""
    return np.interp(0.9, vis, line) - np.interp(0.1, vis, line)


@pytest.mark.parametrize("order", [4, 16])
def test_parallel_plates_are_nearly_exact(order):
    """Where CSSM is exact up to the series: RMSE against 1024 ray-traced samples below 0.01 at
    order 16 (0.02 at order 4, whose step is four times wider), penumbra width within 5%."""
    scene, light, rx, line = parallel_plates()
    reference = ss.ray_traced(scene, light, rx, samples=light.samples(1024, pattern="sobol", seed=1))
    vis = ss.cssm(scene, light, rx, order=order)
    rmse = ss.metrics.rmse(vis, reference)
    widths = [penumbra_width(line, v[-len(line):]) for v in (vis, reference)]
    print(f"M = {order}: RMSE {rmse:.4f}, 10-90% penumbra width {widths[0]:.4f} against {widths[1]:.4f}")
    assert rmse < (0.01 if order == 16 else 0.02)
    assert abs(widths[0] / widths[1] - 1) < 0.05, widths


def test_the_default_shift_makes_a_receivers_own_surface_test_lit():
    """The series at the receiver's own depth: with the default shift a receiver's own surface
    tests exactly 1 (``rust/core/src/methods/cssm/mod.rs`` checks the series), so the penumbra keeps
    its width; at the step's half width (0.5 / M) it tests 1.09 and the clamp narrows the
    penumbra."""
    scene, light, rx, line = parallel_plates(grid=40)
    reference = ss.ray_traced(scene, light, rx, samples=light.samples(1024, pattern="sobol", seed=1))
    target = penumbra_width(line, reference[-len(line):])
    default = penumbra_width(line, ss.cssm(scene, light, rx, order=4)[-len(line):])
    half_width = penumbra_width(line, ss.cssm(scene, light, rx, order=4, offset=0.5 / 4)[-len(line):])
    assert abs(default / target - 1) < 0.05 and half_width / target < 0.9, (default, half_width, target)


def test_a_point_light_and_a_growing_order_converge_to_the_hard_shadow_map():
    setup, gb = case("columns", size=96)
    point = ss.SphereLight(setup.light.center, 1e-5)
    _, stats = ss.cssm(setup.scene, point, gb, resolution=512, return_stats=True)
    offset = 0.02  # the same depth shift for every order, as a constant bias for the shadow map
    hard = ss.shadow_map(setup.scene, point, gb, resolution=512, bias=offset * stats["depth_span"])
    errors = [
        ss.metrics.rmse(ss.cssm(setup.scene, point, gb, resolution=512, order=m, offset=offset), hard, gb.mask)
        for m in (4, 8, 16, 64)
    ]
    assert all(a > b for a, b in zip(errors, errors[1:])), errors
    assert errors[-1] < 0.01, errors


@pytest.mark.parametrize(
    "name, order", [("columns", 4), ("columns", 16), pytest.param("bunny", 16, marks=needs_pymeshlab)]
)
def test_error_against_the_reference_is_below_a_filtered_hard_shadow(name, order):
    setup, gb = case(name)
    reference = ss.ray_traced(setup.scene, setup.light, gb, samples=256)
    soft = ss.metrics.rmse(ss.cssm(setup.scene, setup.light, gb, order=order), reference, gb.mask)
    hard = ss.metrics.rmse(ss.shadow_map(setup.scene, setup.light, gb, resolution=512, pcf=5), reference, gb.mask)
    print(f"{name}: cssm (M={order}) RMSE {soft:.4f}, shadow_map (5x5 PCF) {hard:.4f}")
    assert soft < hard


def test_sharpening_darkens_contact_shadows_more_than_wide_penumbrae():
    setup, gb = case("columns")
    plain = ss.cssm(setup.scene, setup.light, gb)
    sharp = ss.cssm(setup.scene, setup.light, gb, sharpen_a=30.0, sharpen_b=10.0)
    ground = gb.mask & (np.abs(gb.positions[..., 1]) < 1e-4)
    xz = gb.positions[..., [0, 2]]
    axes = np.array([[(i - 2) * 0.45, 0.0] for i in range(5)])  # the columns' axes (scenes.columns)
    distance = np.min(np.linalg.norm(xz[..., None, :] - axes, axis=-1), axis=-1)
    shadowed = ground & (plain < 0.95)
    contact, wide = shadowed & (distance < 0.2), shadowed & (distance > 0.6)
    assert contact.sum() > 20 and wide.sum() > 20
    darkening = plain - sharp
    assert np.all(darkening >= 0)
    assert darkening[contact].mean() > 2 * darkening[wide].mean(), (darkening[contact].mean(), darkening[wide].mean())


def test_mipmap_prefiltering_is_close_to_the_summed_area_table_and_stats_are_reported():
    setup, gb = case("columns", size=96)
    sat, stats = ss.cssm(setup.scene, setup.light, gb, return_stats=True)
    mip = ss.cssm(setup.scene, setup.light, gb, prefilter="mipmap")
    assert 0 < ss.metrics.rmse(mip, sat, gb.mask) < 0.05
    assert stats["basis_images"] == 17 and stats["resolution"] == 512
    for stage in ("shadow_map", "basis", "prefilter", "lookup"):
        assert stats[f"{stage}_seconds"] > 0, stage


def test_rectangular_lights_filter_anisotropically():
    setup, gb = case("columns", size=96)
    c, u, v = setup.light.center, np.asarray(setup.light.u), np.asarray(setup.light.v)
    wide_u = ss.cssm(setup.scene, ss.RectLight(c, 3 * u, v), gb)
    wide_v = ss.cssm(setup.scene, ss.RectLight(c, u, 3 * v), gb)
    square = ss.cssm(setup.scene, setup.light, gb)
    assert np.mean(np.abs(wide_u - wide_v)[gb.mask]) > 0.005
    for vis in (wide_u, wide_v):
        assert np.mean((vis > 0.05) & (vis < 0.95) & gb.mask) > np.mean((square > 0.05) & (square < 0.95) & gb.mask)


@pytest.mark.parametrize(
    "options, match",
    [
        ({"order": 0}, "order"),
        ({"order": 65}, "order"),
        ({"prefilter": "box"}, "prefilter"),
        ({"offset": 0.7}, "offset"),
        ({"scale": 0.0}, "scale"),
        ({"scale": -1.0}, "scale"),
        ({"sharpen_a": -1.0}, "sharpen_a"),
        ({"sharpen_b": float("nan")}, "sharpen_b"),
        ({"near": 0.0}, "near"),
        ({"resolution": 0}, "resolution"),
    ],
)
def test_bad_options_name_the_argument(options, match):
    setup, gb = case("ground_sphere", size=16)
    with pytest.raises(ValueError, match=match):
        ss.cssm(setup.scene, setup.light, gb, **options)

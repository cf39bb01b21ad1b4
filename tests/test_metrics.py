"""Image metrics (metrics.py): known values, masks, the region split, and argument checks."""

from __future__ import annotations

import math

import numpy as np
import pytest

from softshadows import metrics


def smooth_image(h=48, w=64, seed=0):
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:h, 0:w] / max(h, w)
    return np.clip(0.5 + 0.4 * np.sin(6 * x + rng.uniform()) * np.cos(4 * y), 0, 1)


def test_identical_images_are_perfect():
    a = smooth_image()
    assert metrics.rmse(a, a) == 0
    assert metrics.ssim(a, a) == pytest.approx(1.0)
    assert metrics.flip(a, a) == pytest.approx(0.0, abs=1e-6)
    out = metrics.summary(a, a)
    assert tuple(out) == metrics.SUMMARY_KEYS and out["psnr"] == math.inf
    assert {k: out[k] for k in ("rmse", "ssim", "flip")} == pytest.approx({"rmse": 0.0, "ssim": 1.0, "flip": 0.0}, abs=1e-6)
    # smooth_image lies in [0.1, 0.9]: all penumbra, no umbra and no lit pixels.
    assert out["rmse.penumbra"] == 0 and math.isnan(out["rmse.umbra"]) and math.isnan(out["rmse.lit"])


def test_rmse_value_and_mask():
    ref = np.zeros((4, 5))
    test = np.zeros((4, 5))
    test[0] = 1.0  # 5 of 20 pixels off by one
    assert metrics.rmse(test, ref) == pytest.approx(np.sqrt(5 / 20))
    mask = np.zeros((4, 5), bool)
    mask[1:] = True
    assert metrics.rmse(test, ref, mask) == 0
    mask[0, 0] = True
    assert metrics.rmse(test, ref, mask) == pytest.approx(np.sqrt(1 / 16))
    assert metrics.rmse(np.ones(7), np.zeros(7)) == 1.0  # explicit receivers: (K,)


def test_worse_images_score_worse():
    ref = smooth_image()
    rng = np.random.default_rng(1)
    slightly = np.clip(ref + rng.normal(0, 0.02, ref.shape), 0, 1)
    badly = np.clip(ref + rng.normal(0, 0.2, ref.shape), 0, 1)
    assert metrics.rmse(slightly, ref) < metrics.rmse(badly, ref)
    assert metrics.ssim(slightly, ref) > metrics.ssim(badly, ref)
    assert metrics.flip(slightly, ref) < metrics.flip(badly, ref)


def test_masked_metrics_ignore_errors_outside_the_mask():
    ref = smooth_image()
    test = ref.copy()
    test[:, 40:] = 1 - test[:, 40:]  # wrong on the right
    mask = np.zeros(ref.shape, bool)
    mask[:, :30] = True  # far enough from column 40 for the 7x7 SSIM window
    assert metrics.ssim(test, ref, mask) == pytest.approx(1.0)
    assert metrics.flip(test, ref, mask) < 0.2 * metrics.flip(test, ref)
    assert metrics.ssim(test, ref) < 0.9


def test_ssim_of_a_mask_is_the_mean_of_the_ssim_map_over_it():
    from skimage.metrics import structural_similarity

    ref = smooth_image()
    test = np.clip(ref + np.random.default_rng(3).normal(0, 0.1, ref.shape), 0, 1)
    mask = np.random.default_rng(4).uniform(size=ref.shape) < 0.5
    _, smap = structural_similarity(test, ref, data_range=1.0, full=True)
    assert metrics.ssim(test, ref, mask) == pytest.approx(smap[mask].mean())


def test_rgb_inputs_and_grayscale_flip_equals_replicated_rgb():
    ref = smooth_image()
    test = np.clip(ref + 0.1, 0, 1)
    rgb_ref, rgb_test = np.repeat(ref[..., None], 3, -1), np.repeat(test[..., None], 3, -1)
    assert metrics.flip(test, ref) == pytest.approx(metrics.flip(rgb_test, rgb_ref))
    assert metrics.rmse(rgb_test, rgb_ref) == pytest.approx(metrics.rmse(test, ref))
    assert metrics.ssim(rgb_test, rgb_ref) == pytest.approx(metrics.ssim(test, ref), rel=1e-6)


def test_error_heatmap_colours():
    ref = np.zeros((3, 4))
    test = np.zeros((3, 4))
    test[0, 0], test[0, 1] = 0.5, -0.5
    mask = np.ones((3, 4), bool)
    mask[2, 3] = False
    img = metrics.error_heatmap(test, ref, mask)
    assert img.shape == (3, 4, 3) and img.dtype == np.float32
    assert img[0, 0, 0] > img[0, 0, 2]  # too bright: red
    assert img[0, 1, 2] > img[0, 1, 0]  # too dark: blue
    assert np.allclose(img[1, 1], 1, atol=0.05)  # exact: near white
    np.testing.assert_array_equal(img[2, 3], metrics.MASKED_GRAY)
    absolute = metrics.error_heatmap(test, ref, signed=False, vmax=1.0)
    np.testing.assert_allclose(absolute[0, 0], absolute[0, 1])  # same magnitude, same colour
    assert not np.allclose(absolute[0, 0], absolute[1, 1])


def test_psnr_is_20_log10_of_peak_over_rmse():
    ref = np.zeros((4, 5))
    test = np.full((4, 5), 0.1)
    assert metrics.psnr(test, ref) == pytest.approx(20.0)
    assert metrics.psnr(test, ref, peak=2.0) == pytest.approx(20.0 + 20 * np.log10(2.0))
    test[0] = 1.0  # outside the mask below
    mask = np.ones((4, 5), bool)
    mask[0] = False
    assert metrics.psnr(test, ref, mask) == pytest.approx(20.0)
    assert metrics.psnr(test, ref) == pytest.approx(-20 * np.log10(metrics.rmse(test, ref)))
    assert metrics.psnr(ref, ref) == math.inf
    assert metrics.psnr(np.full(3, 0.5), np.zeros(3)) == pytest.approx(20 * np.log10(2))  # explicit receivers


def test_regions_split_the_mask_at_the_threshold():
    ref = np.array([0.0, 0.01, 0.0101, 0.5, 0.9899, 0.99, 1.0])
    split = metrics.regions(ref)
    assert list(split) == list(metrics.REGIONS)
    assert {k: m.nonzero()[0].tolist() for k, m in split.items()} == {"umbra": [0, 1], "penumbra": [2, 3, 4], "lit": [5, 6]}
    exact = metrics.regions(ref, threshold=0)
    assert exact["umbra"].nonzero()[0].tolist() == [0] and exact["lit"].nonzero()[0].tolist() == [6]
    mask = np.array([True, False, True, True, False, True, False])
    masked = metrics.regions(ref, mask)
    assert not np.any(masked["umbra"] & masked["penumbra"]) and not np.any(masked["penumbra"] & masked["lit"])
    np.testing.assert_array_equal(masked["umbra"] | masked["penumbra"] | masked["lit"], mask)
    image = metrics.regions(ref[:6].reshape(2, 3))
    assert image["penumbra"].shape == (2, 3) and image["penumbra"].sum() == 3


def test_region_rmse_counts_each_region_alone():
    ref = np.zeros((6, 8))
    ref[:, 2:4] = np.linspace(0.2, 0.8, 6)[:, None]  # a penumbra band between umbra and lit
    ref[:, 4:] = 1.0
    test = ref.copy()
    test[:, 2:4] += 0.1  # wrong only in the penumbra
    penumbra = np.zeros(ref.shape, bool)
    penumbra[:, 2:4] = True
    split = metrics.region_rmse(test, ref)
    assert split == {"umbra": 0.0, "penumbra": pytest.approx(0.1), "lit": 0.0}
    assert split["penumbra"] == pytest.approx(metrics.rmse(test, ref, penumbra))
    # The image-wide RMSE dilutes the same error by the flat regions around it.
    assert metrics.rmse(test, ref) == pytest.approx(0.1 * np.sqrt(12 / 48))
    lit_only = metrics.region_rmse(test[:, 4:], ref[:, 4:])
    assert math.isnan(lit_only["umbra"]) and math.isnan(lit_only["penumbra"]) and lit_only["lit"] == 0


def test_summary_of_explicit_receivers_gives_the_point_metrics_and_nan_for_image_metrics():
    ref = np.array([0.0, 0.0, 0.4, 0.6, 1.0, 1.0])
    test = np.array([0.0, 0.2, 0.4, 0.3, 1.0, 1.0])
    out = metrics.summary(test, ref)
    assert tuple(out) == metrics.SUMMARY_KEYS
    assert math.isnan(out["ssim"]) and math.isnan(out["flip"])
    assert out["rmse"] == pytest.approx(metrics.rmse(test, ref)) and out["psnr"] == pytest.approx(metrics.psnr(test, ref))
    assert out["rmse.umbra"] == pytest.approx(0.2 / np.sqrt(2)) and out["rmse.penumbra"] == pytest.approx(0.3 / np.sqrt(2))
    assert out["rmse.lit"] == 0
    mask = np.array([True, False, True, True, True, True])
    assert metrics.summary(test, ref, mask)["rmse.umbra"] == 0


def test_summary_of_images_that_are_not_visibility_has_no_region_split():
    ref = np.repeat(smooth_image()[..., None], 3, axis=-1)
    out = metrics.summary(np.clip(ref + 0.05, 0, 1), ref)
    assert out["rmse"] == pytest.approx(0.05) and all(math.isfinite(out[k]) for k in ("psnr", "ssim", "flip"))
    assert all(math.isnan(out[f"rmse.{k}"]) for k in metrics.REGIONS)
    radiance = 3 * smooth_image()  # grayscale, but beyond [0, 1]
    assert all(math.isnan(metrics.summary(radiance, radiance)[f"rmse.{k}"]) for k in metrics.REGIONS)


@pytest.mark.parametrize(
    "call, name",
    [
        (lambda: metrics.psnr(np.zeros(4), np.ones(4), peak=0), "peak"),
        (lambda: metrics.regions(np.zeros((8, 8, 3))), "ref"),
        (lambda: metrics.regions(np.full(4, 1.5)), "ref"),
        (lambda: metrics.regions(np.zeros(4), threshold=0.5), "threshold"),
        (lambda: metrics.regions(np.zeros(4), threshold=-0.1), "threshold"),
        (lambda: metrics.regions(np.zeros(4), np.ones(3, bool)), "mask"),
        (lambda: metrics.region_rmse(np.zeros(4), np.zeros(5)), "ref"),
        (lambda: metrics.rmse(np.zeros((4, 4)), np.zeros((4, 5))), "ref"),
        (lambda: metrics.rmse(np.zeros((4, 4)), np.zeros((4, 4)), np.ones((3, 3), bool)), "mask"),
        (lambda: metrics.rmse(np.zeros((4, 4)), np.zeros((4, 4)), np.zeros((4, 4), bool)), "mask"),
        (lambda: metrics.rmse(np.full((4, 4), np.nan), np.zeros((4, 4))), "test"),
        (lambda: metrics.ssim(np.zeros((4, 4)), np.zeros((4, 4))), "test"),
        (lambda: metrics.ssim(np.zeros(16), np.zeros(16)), "test"),
        (lambda: metrics.flip(np.zeros((8, 8)), np.zeros((8, 8)), dynamic_range="hdr"), "dynamic_range"),
        (lambda: metrics.error_heatmap(np.zeros((8, 8)), np.zeros((8, 8)), vmax=0), "vmax"),
    ],
)
def test_bad_arguments_name_themselves(call, name):
    with pytest.raises(ValueError, match=name):
        call()

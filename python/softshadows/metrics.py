"""Image metrics for comparing a method's result with a reference (docs/design.md section 3).

All functions take ``test`` and ``ref`` of the same shape: visibility images (H, W) in [0, 1],
or RGB images (H, W, 3); ``rmse``, ``psnr``, ``regions``, ``region_rmse`` and ``summary`` also
take flat (K,) visibility of explicit receivers. The optional ``mask`` (H, W) (or (K,)) selects
the pixels that count, normally the G-buffer's hit mask; a metric over an empty mask is refused.

* ``rmse``: root mean square difference over the masked pixels (and channels).
* ``psnr``: ``20 log10(peak / rmse)`` in decibels, ``peak=1`` for visibility; inf when exact.
* ``ssim``: ``skimage.metrics.structural_similarity`` with ``data_range=1`` and its default 7x7
  uniform window; with a mask, the full SSIM map is averaged over the masked pixels (windows
  near the mask border still see unmasked pixels, whose values are whatever the images hold:
  0 for visibility from any method).
* ``flip``: NVIDIA's FLIP (``flip_evaluator``, 67 pixels per degree). Grayscale images are
  replicated to RGB. ``dynamic_range="LDR"`` (default) treats values as displayed sRGB values
  clipped to [0, 1], which is how visibility images are viewed; use ``"HDR"`` for radiance.
  With a mask, the mean of the FLIP error map over the masked pixels.
* ``regions`` and ``region_rmse``: the receivers split by the reference visibility into umbra
  (``ref <= threshold``), penumbra and lit (``ref >= 1 - threshold``), and the RMSE over each;
  :data:`REGION_THRESHOLD` says why the default threshold is 0.01 rather than exactly 0 and 1.
  Soft-shadow methods differ mostly in the penumbra, which is often a small part of the image:
  an image-wide RMSE hides a method that gets the penumbra wrong and the large flat regions right.
* ``summary``: all of them at once (:data:`SUMMARY_KEYS`), NaN where one does not apply.

Over a sequence of frames (:func:`softshadows.evaluate_sequence`), stacks (F, H, W) or (F, K) of
results and references, with one mask per frame, measure what a viewer sees over time, on the
screen (a pixel is a pixel, whatever surface the camera brings to it):

* ``temporal_std``: the mean over pixels of the standard deviation over frames of the error
  ``test - ref``: noise that changes from frame to frame (jitter that has not converged),
  where a steady error (a bias) counts nothing;
* ``flicker``: the mean over pixels and pairs of consecutive frames of the change of the result
  against the reference's own change, ``|(test[t] - test[t-1]) - (ref[t] - ref[t-1])|``: what
  flickers, where a shadow that moves as the reference's does counts nothing.
"""

from __future__ import annotations

import math

import numpy as np

from . import _validate as v
from ._extras import require

__all__ = ["rmse", "psnr", "ssim", "flip", "regions", "region_rmse", "error_heatmap", "summary", "temporal_std", "flicker",
           "TEMPORAL_KEYS"]

#: Colour of masked-out pixels in heatmaps.
MASKED_GRAY = (0.5, 0.5, 0.5)

#: Reference visibility at or below which a receiver is in the umbra, and at or above one minus
#: which it is lit (:func:`regions`). Not exactly 0 and 1: the reference is an estimate from a
#: finite number of light samples, and with exact bounds a receiver that one of 4096 rays reaches
#: past an occluder's silhouette would count as penumbra. A 1 % fringe is about two and a half
#: steps of an 8-bit display, which leaves the penumbra the visible soft transition.
REGION_THRESHOLD = 0.01

#: The keys of :func:`summary`, in order.
SUMMARY_KEYS = ("rmse", "psnr", "ssim", "flip", "rmse.umbra", "rmse.penumbra", "rmse.lit")

#: The keys of the temporal metrics in :func:`softshadows.evaluate_sequence`'s summary.
TEMPORAL_KEYS = ("temporal.std", "temporal.flicker")

#: The regions of :func:`regions`, in order from dark to bright.
REGIONS = ("umbra", "penumbra", "lit")


def rmse(test, ref, mask=None) -> float:
    """Root mean square error over the masked pixels.

    Parameters
    ----------
    test, ref : array_like, shape (H, W), (H, W, 3) or (K,)
        Same shape; finite.
    mask : array_like of bool, shape (H, W) or (K,), optional
        Pixels that count; all by default.

    Returns
    -------
    float
        In the units of the inputs (visibility: fraction of the light, 0 to 1).

    Examples
    --------
    >>> import numpy as np
    >>> from softshadows import metrics
    >>> metrics.rmse(np.array([1.0, 0.0, 0.0, 0.0]), np.zeros(4))
    0.5
    """
    t, r, m = _inputs(test, ref, mask, images_only=False)
    # Scaled by the largest difference, so that errors near 1e200 do not square to inf.
    d = t[m] / 2 - r[m] / 2  # halved: the difference of two values near 1e308 stays finite
    scale = float(np.max(np.abs(d)))
    if scale == 0:
        return 0.0
    return float(2 * scale * np.sqrt(np.mean((d / scale) ** 2)))


def psnr(test, ref, mask=None, *, peak: float = 1.0) -> float:
    """Peak signal-to-noise ratio ``20 log10(peak / RMSE)`` over the masked pixels.

    Parameters
    ----------
    test, ref : array_like, shape (H, W), (H, W, 3) or (K,)
        Same shape; finite.
    mask : array_like of bool, shape (H, W) or (K,), optional
        Pixels that count; all by default.
    peak : float
        The largest possible value, in the units of the inputs: 1 for visibility (default);
        for radiance, the brightest value the comparison should count as full scale.

    Returns
    -------
    float
        Decibels; higher is better, ``inf`` when ``test`` equals ``ref`` over the mask.

    Examples
    --------
    >>> import numpy as np
    >>> from softshadows import metrics
    >>> round(metrics.psnr(np.full(4, 0.1), np.zeros(4)), 6)  # RMSE 0.1: 20 dB
    20.0
    >>> metrics.psnr(np.zeros(4), np.zeros(4))
    inf
    """
    peak = v.positive("peak", peak)
    error = rmse(test, ref, mask)
    # Two logarithms: peak / error overflows for a tiny error and a large peak.
    return math.inf if error == 0 else float(20 * (math.log10(peak) - math.log10(error)))


def ssim(test, ref, mask=None) -> float:
    """Mean structural similarity (1 = identical) over the masked pixels.

    Parameters
    ----------
    test, ref : array_like, shape (H, W) or (H, W, 3)
        Same shape, values nominally in [0, 1] (``data_range=1``) and at most 1e3 in magnitude;
        H and W >= 7.
    mask : array_like of bool, shape (H, W), optional

    Returns
    -------
    float
        In [-1, 1]; 1 for identical images.

    Examples
    --------
    >>> import numpy as np
    >>> from softshadows import metrics
    >>> ramp = np.linspace(0, 1, 64).reshape(8, 8)
    >>> metrics.ssim(ramp, ramp), round(metrics.ssim(np.clip(ramp + 0.1, 0, 1), ramp), 4)
    (1.0, 0.9682)
    """
    structural_similarity = require("skimage.metrics", extra="evaluation", for_="softshadows.metrics.ssim").structural_similarity

    t, r, m = _inputs(test, ref, mask)
    if min(t.shape[:2]) < 7:
        raise ValueError(f"test: SSIM needs images of at least 7x7 pixels, got shape {t.shape}")
    for name, a in (("test", t), ("ref", r)):
        # Its variances are E[x^2] - E[x]^2: their cancellation error grows with x^2 against
        # data_range=1's constant C2 = 9e-4, and the "SSIM" of two flat 1e30 images was 3e6.
        if np.abs(a).max() > _SSIM_MAX:
            raise ValueError(f"{name}: SSIM takes values nominally in [0, 1] (data_range=1) and at most {_SSIM_MAX:g} in magnitude, "
                             f"got {np.abs(a).max():g}")
    _, smap = structural_similarity(t, r, data_range=1.0, full=True, channel_axis=-1 if t.ndim == 3 else None)
    if smap.ndim == 3:
        smap = smap.mean(axis=-1)
    # |SSIM| <= 1; near 1e3 rounding leaves up to 1 + 3e-7.
    return float(np.clip(smap[m].mean(), -1.0, 1.0))


#: The largest magnitude :func:`ssim` takes (see there).
_SSIM_MAX = 1e3


def flip(test, ref, mask=None, *, dynamic_range: str = "LDR") -> float:
    """Mean FLIP error (0 = identical) over the masked pixels.

    Parameters
    ----------
    test, ref : array_like, shape (H, W) or (H, W, 3)
        Same shape; grayscale is replicated to RGB. LDR values are clipped to [0, 1]; HDR
        values must be >= 0.
    mask : array_like of bool, shape (H, W), optional
    dynamic_range : {"LDR", "HDR"}

    Returns
    -------
    float
        In [0, 1]; 0 for identical images.

    Examples
    --------
    >>> import numpy as np
    >>> from softshadows import metrics
    >>> ramp = np.linspace(0, 1, 64).reshape(8, 8)
    >>> metrics.flip(ramp, ramp), 0 < metrics.flip(np.clip(ramp + 0.1, 0, 1), ramp) < 1
    (0.0, True)
    """
    flip_evaluator = require("flip_evaluator", extra="evaluation", for_="softshadows.metrics.flip")

    if dynamic_range not in ("LDR", "HDR"):
        raise ValueError(f"dynamic_range: expected 'LDR' or 'HDR', got {dynamic_range!r}")
    t, r, m = _inputs(test, ref, mask)
    t, r = _rgb(t), _rgb(r)
    if dynamic_range == "LDR":
        t, r = np.clip(t, 0, 1), np.clip(r, 0, 1)
    else:
        _check_hdr(t, r)
    error_map, _, _ = flip_evaluator.evaluate(
        np.ascontiguousarray(r, np.float32), np.ascontiguousarray(t, np.float32), dynamic_range, applyMagma=False
    )
    return float(np.asarray(error_map).reshape(m.shape)[m].mean())


#: FLIP's HDR mode derives its exposure range from the reference's luminance: it clamps the
#: median to 2^-23 and calls ``exit(-1)`` (killing the Python process) when the brightest pixel
#: is darker than that. A reference must be at least twice as bright to leave float32 rounding
#: of the luminance a margin.
_HDR_MIN_LUMINANCE = 2.0**-22


def _check_hdr(t: np.ndarray, r: np.ndarray) -> None:
    """Refuses what HDR FLIP cannot take: negative values, values beyond float32 (they would
    turn into inf), and a reference too dark for FLIP to choose exposures (it exits instead)."""
    for name, a in (("test", t), ("ref", r)):
        if a.min() < 0:
            raise ValueError(f"{name}: HDR FLIP needs non-negative values")
        if a.max() > np.finfo(np.float32).max:
            raise ValueError(f"{name}: HDR FLIP computes in float32; values must be <= 3.4e38, got {a.max():g}")
    luminance = r.astype(np.float32) @ np.float32([0.2126, 0.7152, 0.0722])
    if not luminance.max() >= _HDR_MIN_LUMINANCE:
        raise ValueError(
            f"ref: HDR FLIP needs a reference whose brightest pixel has luminance >= 2^-22 (it derives its "
            f"exposure range from it), got {float(luminance.max()):g}"
        )


def error_heatmap(test, ref, mask=None, *, vmax: float | None = None, signed: bool = True, cmap: str | None = None) -> np.ndarray:
    """An RGB picture of the per-pixel error ``test - ref``.

    Parameters
    ----------
    test, ref : array_like, shape (H, W) or (H, W, 3)
        RGB errors are averaged over channels.
    mask : array_like of bool, shape (H, W), optional
        Masked-out pixels are drawn gray (0.5, 0.5, 0.5).
    vmax : float, optional
        Error mapped to the end of the colour map; default the largest absolute error over the
        mask. ``signed`` maps [-vmax, vmax], otherwise [0, vmax].
    signed : bool
        Signed error through a diverging map (default ``"RdBu_r"``: red where ``test`` is too
        bright, blue too dark, white exact), or absolute error (default ``"magma"``).
    cmap : str, optional
        Any matplotlib colour map name.

    Returns
    -------
    ndarray, shape (H, W, 3), float32 in [0, 1]

    Examples
    --------
    >>> import numpy as np
    >>> from softshadows import metrics
    >>> img = metrics.error_heatmap(np.array([[0.5, 0.0]]), np.zeros((1, 2)), np.array([[True, False]]))
    >>> img.shape, bool(img[0, 0, 0] > img[0, 0, 2]), img[0, 1].tolist()  # too bright: red; masked: gray
    ((1, 2, 3), True, [0.5, 0.5, 0.5])
    """
    matplotlib = require("matplotlib", extra="evaluation", for_="softshadows.metrics.error_heatmap")

    t, r, m = _inputs(test, ref, mask)
    err = t - r
    if err.ndim == 3:
        err = err.mean(axis=-1)
    if not signed:
        err = np.abs(err)
    if vmax is None:
        vmax = float(np.abs(err[m]).max())
    else:
        vmax = v.positive("vmax", vmax)
    vmax = vmax if vmax > 0 else 1.0  # identical images: any scale shows zero error
    lo = -vmax if signed else 0.0
    try:
        colors = matplotlib.colormaps[cmap or ("RdBu_r" if signed else "magma")]
    except (KeyError, TypeError):
        raise ValueError(f"cmap: expected a matplotlib colour map name, got {cmap!r}") from None
    rgb = colors(np.clip((err - lo) / (vmax - lo), 0, 1))[..., :3].astype(np.float32)
    rgb[~m] = MASKED_GRAY
    return rgb


def regions(ref, mask=None, *, threshold: float = REGION_THRESHOLD) -> dict:
    """The masked receivers split into umbra, penumbra and lit by their reference visibility.

    Parameters
    ----------
    ref : array_like, shape (H, W) or (K,)
        Reference visibility, in [0, 1].
    mask : array_like of bool, shape (H, W) or (K,), optional
        Receivers that count; all by default.
    threshold : float
        Umbra where ``ref <= threshold``, lit where ``ref >= 1 - threshold``, penumbra between;
        in [0, 0.5), default :data:`REGION_THRESHOLD` (0.01, see there for why). Receivers that
        face away from the light have visibility 0 and so count as umbra.

    Returns
    -------
    dict of str to ndarray of bool
        ``{"umbra": ..., "penumbra": ..., "lit": ...}``, each of ``ref``'s shape; disjoint, and
        together the mask.

    Examples
    --------
    >>> import numpy as np
    >>> from softshadows import metrics
    >>> split = metrics.regions(np.array([0.0, 0.005, 0.5, 0.995, 1.0]))
    >>> {name: where.nonzero()[0].tolist() for name, where in split.items()}
    {'umbra': [0, 1], 'penumbra': [2], 'lit': [3, 4]}
    """
    _, r, m = _inputs(ref, ref, mask, images_only=False)
    if r.ndim == 3:
        raise ValueError(f"ref: regions are classified from visibility of shape (H, W) or (K,), got {r.shape}; "
                         "pass the reference visibility, not a shaded image")
    if r.min() < 0 or r.max() > 1:
        raise ValueError(f"ref: regions are classified from visibility in [0, 1], got values in [{r.min():g}, {r.max():g}]")
    threshold = v.positive("threshold", threshold, allow_zero=True)
    if threshold >= 0.5:
        raise ValueError(f"threshold: must be below 0.5 (umbra and lit would overlap), got {threshold:g}")
    umbra, lit = m & (r <= threshold), m & (r >= 1 - threshold)
    return {"umbra": umbra, "penumbra": m & ~umbra & ~lit, "lit": lit}


def region_rmse(test, ref, mask=None, *, threshold: float = REGION_THRESHOLD) -> dict:
    """The RMSE over the umbra, the penumbra and the lit receivers (:func:`regions`).

    Parameters
    ----------
    test, ref : array_like, shape (H, W) or (K,)
        Visibility, same shape; ``ref`` in [0, 1] classifies the receivers.
    mask : array_like of bool, shape (H, W) or (K,), optional
        Receivers that count; all by default.
    threshold : float
        As in :func:`regions`.

    Returns
    -------
    dict of str to float
        ``{"umbra": ..., "penumbra": ..., "lit": ...}``; NaN for a region without receivers (a
        large light may leave no umbra).

    Examples
    --------
    >>> import numpy as np
    >>> from softshadows import metrics
    >>> ref = np.array([0.0, 0.5, 1.0, 1.0])
    >>> {name: round(error, 4) for name, error in metrics.region_rmse(np.array([0.0, 0.3, 1.0, 0.9]), ref).items()}
    {'umbra': 0.0, 'penumbra': 0.2, 'lit': 0.0707}
    >>> metrics.region_rmse(np.ones(2), np.ones(2))["umbra"]
    nan
    """
    t, r, _ = _inputs(test, ref, mask, images_only=False)
    split = regions(r, mask, threshold=threshold)
    return {name: rmse(t, r, where) if where.any() else math.nan for name, where in split.items()}


def summary(test, ref, mask=None, *, threshold: float = REGION_THRESHOLD) -> dict:
    """Every metric of this module that applies to the inputs, as :data:`SUMMARY_KEYS`.

    Parameters
    ----------
    test, ref : array_like, shape (H, W), (H, W, 3) or (K,)
        Same shape; SSIM needs H and W >= 7.
    mask : array_like of bool, shape (H, W) or (K,), optional
        Pixels or receivers that count; all by default.
    threshold : float
        The region split's threshold (:func:`regions`).

    Returns
    -------
    dict of str to float
        ``rmse``, ``psnr`` (dB, peak 1), ``ssim``, ``flip`` and the region split ``rmse.umbra``,
        ``rmse.penumbra``, ``rmse.lit``. NaN where a metric does not apply: ``ssim`` and ``flip``
        for (K,) explicit receivers, as both compare pixel neighbourhoods (SSIM's 7x7 window,
        FLIP's filters at a viewing distance) that scattered points do not have; the region split
        for an RGB ``ref`` or one outside [0, 1], which is not visibility; and a region with no
        receivers.

    Examples
    --------
    >>> import numpy as np
    >>> from softshadows import metrics
    >>> ref = np.array([0.0, 0.5, 1.0, 1.0])
    >>> test = np.array([0.0, 0.3, 1.0, 0.9])
    >>> {key: round(value, 4) for key, value in metrics.summary(test, ref).items()}  # doctest: +NORMALIZE_WHITESPACE
    {'rmse': 0.1118, 'psnr': 19.0309, 'ssim': nan, 'flip': nan,
     'rmse.umbra': 0.0, 'rmse.penumbra': 0.2, 'rmse.lit': 0.0707}
    """
    t, r, m = _inputs(test, ref, mask, images_only=False)
    out = {"rmse": rmse(t, r, m), "psnr": psnr(t, r, m)}
    points = t.ndim == 1
    out["ssim"] = math.nan if points else ssim(t, r, m)
    out["flip"] = math.nan if points else flip(t, r, m)
    visibility = r.ndim < 3 and r.min() >= 0 and r.max() <= 1
    split = region_rmse(t, r, m, threshold=threshold) if visibility else dict.fromkeys(REGIONS, math.nan)
    out.update({f"rmse.{name}": value for name, value in split.items()})
    return out


def temporal_std(test, ref, mask=None) -> float:
    """The mean over pixels of the standard deviation over frames of the error ``test - ref``.

    Parameters
    ----------
    test, ref : array_like, shape (F, H, W) or (F, K)
        A result and its reference in each of F >= 2 frames; finite.
    mask : array_like of bool, same shape, optional
        The pixels that count in each frame (each frame's G-buffer hit mask); all by default. A
        pixel's deviation is taken over the frames that count it, and pixels counted in fewer
        than two frames are left out.

    Returns
    -------
    float
        In the units of the inputs; 0 when the error is the same in every frame.

    Examples
    --------
    >>> import numpy as np
    >>> from softshadows import metrics
    >>> ref = np.zeros((4, 1, 2))
    >>> test = ref + np.array([0.1, -0.1, 0.1, -0.1])[:, None, None] * [1, 0]  # one pixel alternates, one is exact
    >>> round(metrics.temporal_std(test, ref), 6)
    0.05
    >>> metrics.temporal_std(ref + 0.3, ref)  # a steady error does not change over time
    0.0
    """
    error, m = _frame_stacks(test, ref, mask)
    counted = m.sum(axis=0)
    keep = counted >= 2
    if not keep.any():
        raise ValueError("mask: no pixel is counted in two frames")
    weight, error, counted = m[:, keep], error[:, keep], counted[keep]
    mean = (weight * error).sum(axis=0) / counted
    return float(np.sqrt((weight * (error - mean) ** 2).sum(axis=0) / counted).mean())


def flicker(test, ref, mask=None, *, per_frame: bool = False):
    """The change of a result from one frame to the next, against the reference's own change:
    the mean over pixels of ``|(test[t] - test[t-1]) - (ref[t] - ref[t-1])|``.

    Parameters
    ----------
    test, ref : array_like, shape (F, H, W) or (F, K)
        A result and its reference in each of F >= 2 frames; finite.
    mask : array_like of bool, same shape, optional
        The pixels that count in each frame; a pair of frames counts the pixels both count.
    per_frame : bool
        Return the mean of each frame against the one before it instead of the mean over all
        pairs.

    Returns
    -------
    float, or ndarray of shape (F,) with ``per_frame``
        In the units of the inputs; 0 where the result changes exactly as the reference does.
        With ``per_frame``, NaN for the first frame and for a pair with no pixel in common.

    Examples
    --------
    >>> import numpy as np
    >>> from softshadows import metrics
    >>> ref = np.arange(4)[:, None] / 4 * np.ones((4, 3))  # every pixel brightens
    >>> metrics.flicker(ref + 0.25, ref)  # an offset that follows the reference does not flicker
    0.0
    >>> noisy = ref + np.array([0.0, 0.1, 0.0, 0.1])[:, None]
    >>> metrics.flicker(noisy, ref, per_frame=True).round(6).tolist()
    [nan, 0.1, 0.1, 0.1]
    """
    error, m = _frame_stacks(test, ref, mask)
    both = m[1:] & m[:-1]
    change = np.abs(np.diff(error, axis=0))
    axes = tuple(range(1, error.ndim))
    pixels = both.sum(axis=axes)
    if per_frame:
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.concatenate([[np.nan], np.where(both, change, 0).sum(axis=axes) / pixels])
    if not pixels.any():
        raise ValueError("mask: no pixel is counted in two consecutive frames")
    return float(change[both].mean())


def _frame_stacks(test, ref, mask):
    """The error ``test - ref`` of two (F, ...) stacks of F >= 2 frames, and a boolean mask of
    its shape."""
    t, r = _finite("test", test), _finite("ref", ref)
    if t.ndim not in (2, 3) or len(t) < 2:
        raise ValueError(f"test: expected frames of shape (F, H, W) or (F, K) with F >= 2, got {t.shape}")
    if r.shape != t.shape:
        raise ValueError(f"ref: expected the shape of test {t.shape}, got {r.shape}")
    if mask is None:
        return t - r, np.ones(t.shape, bool)
    m = np.asarray(mask)
    if m.shape != t.shape or m.dtype != bool:
        raise ValueError(f"mask: expected booleans of shape {t.shape}, got {m.dtype} {m.shape}")
    return t - r, m


def _inputs(test, ref, mask, *, images_only: bool = True):
    """Validated float64 copies of test and ref and a boolean mask of the pixel shape."""
    t = _finite("test", test)
    r = _finite("ref", ref)
    if t.shape != r.shape:
        raise ValueError(f"ref: expected the shape of test {t.shape}, got {r.shape}")
    ok = t.ndim == 2 or (t.ndim == 3 and t.shape[2] == 3) or (t.ndim == 1 and not images_only)
    if not ok:
        expected = "(H, W) or (H, W, 3)" + ("" if images_only else " or (K,)")
        raise ValueError(f"test: expected shape {expected}, got {t.shape}")
    pixels = t.shape[:2] if t.ndim == 3 else t.shape
    if mask is None:
        m = np.ones(pixels, bool)
    else:
        try:
            m = np.asarray(mask)
        except (TypeError, ValueError):  # ragged nested lists
            raise ValueError(f"mask: expected a boolean array of shape {pixels}, got {type(mask).__name__}") from None
        if m.shape != pixels:
            raise ValueError(f"mask: expected shape {pixels}, got {m.shape}")
        if m.dtype != bool:
            if m.dtype.kind not in "biu" or not np.isin(m, (0, 1)).all():
                raise ValueError(f"mask: expected booleans, got dtype {m.dtype}")
            m = m.astype(bool)
    if not m.any():
        raise ValueError("mask: selects no pixel")
    return t, r, m


def _finite(name: str, value) -> np.ndarray:
    try:
        a = np.asarray(value)
    except (TypeError, ValueError) as exc:  # ragged nested lists
        raise ValueError(f"{name}: expected an array, got {type(value).__name__} ({exc})") from None
    if a.dtype.kind not in "biuf":
        raise ValueError(f"{name}: expected a numeric array, got dtype {a.dtype}")
    a = a.astype(np.float64)
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name}: contains NaN or Inf")
    return a


def _rgb(a: np.ndarray) -> np.ndarray:
    return np.repeat(a[..., None], 3, axis=-1) if a.ndim == 2 else a

"""Image metrics for comparing a method's result with a reference (docs/design.md section 3).

All functions take ``test`` and ``ref`` of the same shape: visibility images (H, W) in [0, 1],
or RGB images (H, W, 3); ``rmse`` also takes flat (K,) visibility of explicit receivers. The
optional ``mask`` (H, W) (or (K,)) selects the pixels that count, normally the G-buffer's hit
mask; a metric over an empty mask is refused.

* ``rmse``: root mean square difference over the masked pixels (and channels).
* ``ssim``: ``skimage.metrics.structural_similarity`` with ``data_range=1`` and its default 7x7
  uniform window; with a mask, the full SSIM map is averaged over the masked pixels (windows
  near the mask border still see unmasked pixels, whose values are whatever the images hold:
  0 for visibility from any method).
* ``flip``: NVIDIA's FLIP (``flip_evaluator``, 67 pixels per degree). Grayscale images are
  replicated to RGB. ``dynamic_range="LDR"`` (default) treats values as displayed sRGB values
  clipped to [0, 1], which is how visibility images are viewed; use ``"HDR"`` for radiance.
  With a mask, the mean of the FLIP error map over the masked pixels.
"""

from __future__ import annotations

import numpy as np

from . import _validate as v

__all__ = ["rmse", "ssim", "flip", "error_heatmap", "summary"]

#: Colour of masked-out pixels in heatmaps.
MASKED_GRAY = (0.5, 0.5, 0.5)


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
    """
    t, r, m = _inputs(test, ref, mask, images_only=False)
    # Scaled by the largest difference, so that errors near 1e200 do not square to inf.
    d = t[m] / 2 - r[m] / 2  # halved: the difference of two values near 1e308 stays finite
    scale = float(np.max(np.abs(d)))
    if scale == 0:
        return 0.0
    return float(2 * scale * np.sqrt(np.mean((d / scale) ** 2)))


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
    """
    from skimage.metrics import structural_similarity

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
    """
    import flip_evaluator

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
    """
    import matplotlib

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


def summary(test, ref, mask=None) -> dict:
    """RMSE, SSIM and FLIP together.

    Parameters
    ----------
    test, ref : array_like, shape (H, W) or (H, W, 3)
    mask : array_like of bool, shape (H, W), optional

    Returns
    -------
    dict
        ``{"rmse": float, "ssim": float, "flip": float}``.
    """
    return {"rmse": rmse(test, ref, mask), "ssim": ssim(test, ref, mask), "flip": flip(test, ref, mask)}


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

"""Reading and writing images: OpenEXR for float data, PNG for viewing.

* EXR files are written as single-part scanline images, float32, ZIP-compressed: a (H, W)
  array as one channel ``"Y"``, a (H, W, 3) array as ``"R"``, ``"G"``, ``"B"`` (and (H, W, 4)
  adds ``"A"``). Reading returns float32 whatever the stored pixel type (half included).
* Environment maps (docs/design.md section 2) are lat-long images (row 0 is the top, the +up pole;
  columns sweep the azimuth) or cube maps stored as a vertical strip of six square faces in the
  order +x, -x, +y, -y, +z, -z (the OpenGL face order), each face's row 0 at its top.
* PNGs go through ``matplotlib.image.imsave`` (no pyplot, no GUI backend needed).
"""

from __future__ import annotations

import errno
import os
import stat
import tempfile

import numpy as np

from . import _validate as _v

__all__ = ["write_exr", "read_exr", "read_environment", "write_png"]


def write_exr(path, image) -> None:
    """Writes a float image to an OpenEXR file.

    Parameters
    ----------
    path : str or os.PathLike
    image : array_like, shape (H, W), (H, W, 3) or (H, W, 4)
        Stored as float32 channels ``Y``, ``RGB`` or ``RGBA``. NaN and Inf are refused.
    """
    import OpenEXR

    path = _path(path)
    a = _image(image)
    with np.errstate(over="ignore", invalid="ignore"):  # beyond float32: refused just below
        a = np.ascontiguousarray(a, np.float32)
    if not np.all(np.isfinite(a)):
        raise ValueError("image: contains NaN or Inf (or values beyond float32)")
    name = "Y" if a.ndim == 2 else ("RGB" if a.shape[2] == 3 else "RGBA")
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    _writable(path)
    # OpenEXR does not report a short write (a full disk leaves a 0-byte file, /dev/full returns
    # normally): encode to a temporary file, then write its bytes with Python's own I/O, which
    # raises OSError on every failed or short write.
    with tempfile.TemporaryDirectory() as tmp:
        encoded = os.path.join(tmp, "image.exr")
        with OpenEXR.File(header, {name: a}) as f:
            try:
                f.write(encoded)
            except RuntimeError as exc:  # OpenEXR reports I/O failures as RuntimeError
                raise OSError(f"path: cannot encode {path} ({exc})") from None
        with open(encoded, "rb") as f:
            data = f.read()
    try:
        with open(path, "wb") as out:
            if out.write(data) != len(data):
                raise OSError(errno.EIO, "short write")
            out.flush()
            if os.path.isfile(path):
                os.fsync(out.fileno())
    except OSError as exc:
        raise OSError(exc.errno, f"path: cannot write {path} ({exc.strerror or exc})", path) from None


def read_exr(path) -> np.ndarray:
    """Reads an OpenEXR image as float32.

    Parameters
    ----------
    path : str or os.PathLike

    Returns
    -------
    ndarray, float32
        (H, W, 3) for R, G, B channels, (H, W, 4) with A, (H, W) for a single channel (``Y``
        or any other name).
    """
    import OpenEXR

    path = _path(path)
    if not os.path.exists(path):
        raise FileNotFoundError(errno.ENOENT, "path: no such file", path)
    if os.path.isdir(path):
        raise IsADirectoryError(errno.EISDIR, "path: is a directory, not an OpenEXR file", path)
    if not stat.S_ISREG(os.stat(path).st_mode):  # a FIFO or a device would block the reader
        raise ValueError(f"path: {path} is not a regular file (a pipe, socket or device), not an OpenEXR file")
    try:
        with OpenEXR.File(path) as f:
            channels = {k: np.asarray(c.pixels) for k, c in f.channels().items()}
    except RuntimeError as exc:  # not an EXR file, truncated, or unreadable
        raise ValueError(f"path: {path} is not a readable OpenEXR file ({exc})") from None
    for name in ("RGB", "RGBA", "Y"):
        if name in channels:
            return np.ascontiguousarray(channels[name], np.float32)
    if len(channels) == 1:
        return np.ascontiguousarray(next(iter(channels.values())), np.float32)
    raise ValueError(f"path: {path} has channels {sorted(channels)}; expected R, G, B (, A) or a single channel")


def read_environment(path, *, layout: str = "latlong") -> np.ndarray:
    """Reads an environment map (the input of environment lighting, Annen et al. 2008, section 4.2).

    Parameters
    ----------
    path : str or os.PathLike
        An OpenEXR file. RGBA drops alpha; a single channel is replicated to RGB.
    layout : {"latlong", "cube"}
        ``"latlong"`` (equirectangular): row 0 is the top, width normally twice the height.
        ``"cube"``: a vertical strip of six N x N faces (image height 6 N), in the order
        +x, -x, +y, -y, +z, -z.

    Returns
    -------
    ndarray, float32, linear radiance >= 0 (small negative values, which some tools write, are clamped)
        Shape (H, W, 3) for ``"latlong"``; (6, N, N, 3) for ``"cube"``.
    """
    if layout not in ("latlong", "cube"):
        raise ValueError(f"layout: expected 'latlong' or 'cube', got {layout!r}")
    img = read_exr(path)
    if img.ndim == 2:
        img = np.repeat(img[..., None], 3, axis=-1)
    img = img[..., :3]
    if not np.all(np.isfinite(img)):
        raise ValueError(f"path: {os.fspath(path)} contains NaN or Inf")
    img = np.ascontiguousarray(np.maximum(img, 0), np.float32)
    h, w = img.shape[:2]
    if layout == "cube":
        if h != 6 * w:
            raise ValueError(f"path: a cube-map strip must be 6 square faces stacked vertically (H = 6 W), got {h}x{w}")
        return img.reshape(6, w, w, 3)
    if h < 2 or w < 2:
        raise ValueError(f"path: a lat-long map needs at least 2x2 pixels, got {img.shape[:2]}")
    return img


def write_png(path, image, *, vmin: float = 0.0, vmax: float = 1.0, cmap: str | None = None) -> None:
    """Writes an image for viewing.

    Parameters
    ----------
    path : str or os.PathLike
    image : array_like, shape (H, W), (H, W, 3) or (H, W, 4)
        Float values are mapped linearly from [vmin, vmax] to [0, 1] and clipped (no gamma:
        visibility is shown as is). uint8 images are written unchanged.
    vmin, vmax : float
        Value range, vmin < vmax.
    cmap : str, optional
        Matplotlib colour map for (H, W) images; default gray. Not allowed with RGB.
    """
    import matplotlib
    import matplotlib.image

    path = _path(path)
    a = _image(image)
    if a.ndim == 3 and cmap is not None:
        raise ValueError("cmap: only single-channel (H, W) images take a colour map")
    if cmap is not None:
        try:
            matplotlib.colormaps[cmap]
        except (KeyError, TypeError):
            raise ValueError(f"cmap: expected a matplotlib colour map name, got {cmap!r}") from None
    vmin, vmax = _v.number("vmin", vmin), _v.number("vmax", vmax)
    if not vmin < vmax or not np.isfinite(vmax - vmin):  # vmax - vmin = inf would map all to 0
        raise ValueError(f"vmax: expected finite vmin < vmax, got vmin={vmin}, vmax={vmax}")
    if a.dtype != np.uint8:
        a = a.astype(np.float64)
        if not np.all(np.isfinite(a)):
            raise ValueError("image: contains NaN or Inf")
        a = np.clip((a - vmin) / (vmax - vmin), 0, 1)
    if a.ndim == 2:
        top = 255 if a.dtype == np.uint8 else 1
        matplotlib.image.imsave(os.fspath(path), a, cmap=cmap or "gray", vmin=0, vmax=top, format="png")
    else:
        matplotlib.image.imsave(os.fspath(path), a, format="png")


def _path(path) -> str:
    """``path`` as a str, or a TypeError naming the argument (a ValueError for a NUL in it, where
    OpenEXR would cut the path short)."""
    try:
        path = os.fspath(path)
    except TypeError:
        raise TypeError(f"path: expected a str or os.PathLike, got {type(path).__name__}") from None
    if isinstance(path, bytes):
        path = os.fsdecode(path)
    if "\0" in path:
        raise ValueError(f"path: contains a NUL character: {path!r}")
    return path


def _image(image) -> np.ndarray:
    """A non-empty numeric (H, W), (H, W, 3) or (H, W, 4) array."""
    try:
        a = np.asarray(image)
    except (TypeError, ValueError) as exc:  # ragged nested lists
        raise ValueError(f"image: expected an array, got {type(image).__name__} ({exc})") from None
    if a.dtype.kind not in "biuf":
        raise ValueError(f"image: expected a numeric array, got dtype {a.dtype}")
    if not (a.ndim == 2 or (a.ndim == 3 and a.shape[2] in (3, 4))) or a.size == 0:
        raise ValueError(f"image: expected a non-empty array of shape (H, W), (H, W, 3) or (H, W, 4), got {a.shape}")
    return a


def _writable(path: str) -> None:
    """A missing folder as FileNotFoundError (OpenEXR would raise a bare RuntimeError)."""
    folder = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(folder):
        raise FileNotFoundError(errno.ENOENT, "path: no such directory", folder)

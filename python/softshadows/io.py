"""Reading and writing images: OpenEXR for float data, PNG for viewing.

* EXR files are written as single-part scanline images, float32, ZIP-compressed: a (H, W)
  array as one channel ``"Y"``, a (H, W, 3) array as ``"R"``, ``"G"``, ``"B"`` (and (H, W, 4)
  adds ``"A"``). Reading returns float32 whatever the stored pixel type (half included).
* Environment maps (docs/design.md section 2) are lat-long images (row 0 is the top, the +up pole;
  columns sweep the azimuth) or cube maps stored as a vertical strip of six square faces in the
  order +x, -x, +y, -y, +z, -z (the OpenGL face order), each face's row 0 at its top.
* PNGs go through ``matplotlib.image.imsave`` (no pyplot, no GUI backend needed). They show
  either data or radiance. Data (visibility, masks, error maps; the default) is mapped linearly
  from ``[vmin, vmax]`` to the 8-bit range with no transfer curve (a visibility of 0.5 is
  stored as mid grey). Radiance (the output of :func:`softshadows.shading.direct`, in
  W m^-2 sr^-1, often far below 1) needs ``exposure=``: it is scaled (``"auto"``: see
  :func:`auto_exposure`), clipped to [0, 1] and sRGB-encoded, as a camera would show it.
  The two cannot be told apart from the values (a dim radiance image and a dark visibility map
  both lie in [0, 1]), so the choice is the caller's.
* Each writer refuses a file name whose extension names another format (``write_exr("x.jpg")``
  would otherwise write EXR bytes under a JPEG name); a name with no extension is accepted.
  ``read_exr`` reads by content and names the format of a PNG or JPEG it is given.

>>> import numpy as np
>>> from softshadows import io
>>> radiance = np.full((4, 4), 0.06, np.float32)    # a dim, evenly lit receiver
>>> float(io.tonemap(radiance).max())               # "auto": the bright end shows as white
1.0
"""

from __future__ import annotations

import errno
import os
import stat
import tempfile

import numpy as np

from . import _validate as _v
from ._extras import require

__all__ = ["write_exr", "read_exr", "read_environment", "write_png", "tonemap", "auto_exposure", "AUTO_PERCENTILE"]

#: The percentile of the lit pixels that ``exposure="auto"`` maps to white: a few highlights
#: (a sliver of pixels facing the light) may clip, and the rest of the image is not dimmed for them.
AUTO_PERCENTILE = 99.0

#: File signatures of the formats ``read_exr`` recognizes, to name what it was given instead.
_EXR_MAGIC = b"\x76\x2f\x31\x01"
_OTHER_FORMATS = {b"\x89PNG": "a PNG image", b"\xff\xd8\xff": "a JPEG image"}


def write_exr(path, image) -> None:
    """Writes a float image to an OpenEXR file.

    Parameters
    ----------
    path : str or os.PathLike
        Ends in ``.exr`` (any case) or has no extension; another extension is refused.
    image : array_like, shape (H, W), (H, W, 3) or (H, W, 4)
        Stored as float32 channels ``Y``, ``RGB`` or ``RGBA``. NaN and Inf are refused.

    Examples
    --------
    >>> import os, tempfile
    >>> import numpy as np
    >>> from softshadows import io
    >>> folder = tempfile.TemporaryDirectory()
    >>> path = os.path.join(folder.name, "visibility.exr")
    >>> io.write_exr(path, np.full((2, 3), 0.25))
    >>> io.read_exr(path)
    array([[0.25, 0.25, 0.25],
           [0.25, 0.25, 0.25]], dtype=float32)
    >>> io.write_exr(path[:-4] + ".png", np.zeros((2, 3)))
    Traceback (most recent call last):
    ...
    ValueError: path: '...visibility.png' has the extension '.png' but write_exr writes OpenEXR; ...
    >>> folder.cleanup()
    """
    OpenEXR = require("OpenEXR", extra="evaluation", for_="softshadows.io.write_exr")

    path = _path(path)
    _extension(path, ".exr", "write_exr writes OpenEXR", "or call write_png for a PNG to look at")
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
        An OpenEXR file, whatever its extension (the file's signature decides; a PNG or JPEG
        is refused by name).

    Returns
    -------
    ndarray, float32
        (H, W, 3) for R, G, B channels, (H, W, 4) with A, (H, W) for a single channel (``Y``
        or any other name).

    Examples
    --------
    >>> import os, tempfile
    >>> import numpy as np
    >>> from softshadows import io
    >>> folder = tempfile.TemporaryDirectory()
    >>> io.write_exr(os.path.join(folder.name, "rgb.exr"), np.ones((2, 2, 3)))
    >>> io.read_exr(os.path.join(folder.name, "rgb.exr")).shape
    (2, 2, 3)
    >>> io.write_png(os.path.join(folder.name, "view.png"), np.ones((2, 2)))
    >>> io.read_exr(os.path.join(folder.name, "view.png"))
    Traceback (most recent call last):
    ...
    ValueError: path: ...view.png is a PNG image, not an OpenEXR file; read it with matplotlib.image.imread (8-bit display values)
    >>> folder.cleanup()
    """
    OpenEXR = require("OpenEXR", extra="evaluation", for_="softshadows.io.read_exr")

    path = _path(path)
    if not os.path.exists(path):
        raise FileNotFoundError(errno.ENOENT, "path: no such file", path)
    if os.path.isdir(path):
        raise IsADirectoryError(errno.EISDIR, "path: is a directory, not an OpenEXR file", path)
    if not stat.S_ISREG(os.stat(path).st_mode):  # a FIFO or a device would block the reader
        raise ValueError(f"path: {path} is not a regular file (a pipe, socket or device), not an OpenEXR file")
    with open(path, "rb") as f:
        head = f.read(4)
    for magic, what in _OTHER_FORMATS.items():
        if head.startswith(magic):
            # OpenEXR itself only says "Unable to open ... for read", as for a missing file.
            raise ValueError(f"path: {path} is {what}, not an OpenEXR file; "
                             "read it with matplotlib.image.imread (8-bit display values)")
    if head != _EXR_MAGIC:
        raise ValueError(f"path: {path} is not an OpenEXR file (it does not start with the OpenEXR signature)")
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

    Examples
    --------
    >>> import os, tempfile
    >>> import numpy as np
    >>> from softshadows import io
    >>> folder = tempfile.TemporaryDirectory()
    >>> path = os.path.join(folder.name, "sky.exr")
    >>> io.write_exr(path, np.full((8, 16, 3), 0.5, np.float32))
    >>> io.read_environment(path).shape
    (8, 16, 3)
    >>> io.read_environment(path, layout="cube")
    Traceback (most recent call last):
    ...
    ValueError: path: a cube-map strip must be 6 square faces stacked vertically (H = 6 W), got 8x16
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


def write_png(path, image, *, exposure=None, vmin=None, vmax=None, cmap: str | None = None) -> None:
    """Writes an image for viewing: data as it is, or radiance exposed and sRGB-encoded.

    Parameters
    ----------
    path : str or os.PathLike
        Ends in ``.png`` (any case) or has no extension; another extension is refused.
    image : array_like, shape (H, W), (H, W, 3) or (H, W, 4)
        Data (visibility in [0, 1], an error map) or, with ``exposure``, linear radiance in
        W m^-2 sr^-1 (e.g. from :func:`softshadows.shading.direct`). uint8 images are written
        unchanged.
    exposure : None, "auto" or float, optional
        ``None`` (the default): ``image`` is data, mapped linearly from [vmin, vmax] to [0, 1]
        and clipped, with no transfer curve (a visibility of 0.5 is stored as mid grey).
        ``"auto"`` or a positive float: ``image`` is radiance, written as :func:`tonemap` shows
        it (``"auto"`` maps the bright end of the lit pixels to white, see
        :func:`auto_exposure`). To compare images at one exposure, pass them all the float
        that :func:`auto_exposure` gives for the reference.
    vmin, vmax : float, optional
        Data range, vmin < vmax; default 0 and 1. Not taken with ``exposure``.
    cmap : str, optional
        Matplotlib colour map for (H, W) data; default gray. Not taken with RGB or ``exposure``.

    Examples
    --------
    >>> import os, tempfile
    >>> import matplotlib.image
    >>> import numpy as np
    >>> from softshadows import io
    >>> folder = tempfile.TemporaryDirectory()
    >>> path = os.path.join(folder.name, "shaded.png")
    >>> radiance = np.linspace(0, 0.06, 16).reshape(4, 4)     # peaks at 0.06 W m^-2 sr^-1
    >>> io.write_png(path, radiance)                          # as data: dark grey
    >>> round(float(matplotlib.image.imread(path)[..., 0].max()), 2)
    0.06
    >>> io.write_png(path, radiance, exposure="auto")         # as radiance: the bright end is white
    >>> round(float(matplotlib.image.imread(path)[..., 0].max()), 2)
    1.0
    >>> folder.cleanup()
    """
    matplotlib = require("matplotlib", extra="evaluation", for_="softshadows.io.write_png")
    require("matplotlib.image", extra="evaluation", for_="softshadows.io.write_png")

    path = _path(path)
    _extension(path, ".png", "write_png writes PNG", "or call write_exr to keep the float values")
    a = _image(image)
    if a.ndim == 3 and cmap is not None:
        raise ValueError("cmap: only single-channel (H, W) images take a colour map")
    if cmap is not None:
        try:
            matplotlib.colormaps[cmap]
        except (KeyError, TypeError):
            raise ValueError(f"cmap: expected a matplotlib colour map name, got {cmap!r}") from None
    if exposure is not None:
        for name, value in (("vmin", vmin), ("vmax", vmax), ("cmap", cmap)):
            if value is not None:
                raise ValueError(f"{name}: not taken with exposure= (radiance is scaled by the exposure, "
                                 f"then sRGB-encoded); drop {name}, or drop exposure to write the values as data")
        if a.dtype == np.uint8:
            raise ValueError("exposure: a uint8 image is already encoded for display; "
                             "pass linear float radiance, or drop exposure to write it unchanged")
        a = tonemap(a, exposure=exposure)
    else:
        vmin = 0.0 if vmin is None else _v.number("vmin", vmin)
        vmax = 1.0 if vmax is None else _v.number("vmax", vmax)
        if not vmin < vmax or not np.isfinite(vmax - vmin):  # vmax - vmin = inf would map all to 0
            raise ValueError(f"vmax: expected finite vmin < vmax, got vmin={vmin}, vmax={vmax}")
        if a.dtype != np.uint8:
            a = np.clip((_finite(a) - vmin) / (vmax - vmin), 0, 1)
    if a.ndim == 2:
        top = 255 if a.dtype == np.uint8 else 1
        matplotlib.image.imsave(path, a, cmap=cmap or "gray", vmin=0, vmax=top, format="png")
    else:
        matplotlib.image.imsave(path, a, format="png")


def tonemap(image, *, exposure="auto") -> np.ndarray:
    """Display values of linear radiance: scaled by the exposure, clipped to [0, 1], sRGB-encoded.

    Parameters
    ----------
    image : array_like, shape (H, W), (H, W, 3) or (H, W, 4)
        Linear radiance, W m^-2 sr^-1 (negative values show as black). A fourth channel is alpha:
        clipped to [0, 1], neither scaled nor encoded.
    exposure : "auto" or float
        A positive factor applied to the radiance before clipping (radiance ``1 / exposure``
        shows as white); ``"auto"`` takes :func:`auto_exposure` of ``image``.

    Returns
    -------
    ndarray, float32, the shape of ``image``
        sRGB-encoded values in [0, 1] (the IEC 61966-2-1 transfer curve), ready for
        ``matplotlib.pyplot.imshow`` or an 8-bit file.

    Examples
    --------
    >>> import numpy as np
    >>> from softshadows import io
    >>> io.tonemap(np.array([[0.0, 0.01], [0.02, 0.04]]), exposure=25.0).round(3)
    array([[0.   , 0.537],
           [0.735, 1.   ]], dtype=float32)
    """
    a = _finite(_image(image))
    scale = auto_exposure(a) if isinstance(exposure, str) and exposure == "auto" else _exposure(exposure)
    x = np.clip(a * scale, 0, 1)
    encoded = np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)
    if a.ndim == 3 and a.shape[2] == 4:
        encoded[..., 3] = np.clip(a[..., 3], 0, 1)  # alpha is coverage, not light
    return encoded.astype(np.float32)


def auto_exposure(image, *, percentile: float = AUTO_PERCENTILE) -> float:
    """The exposure that maps the ``percentile``-th percentile of the lit pixels to white.

    A pixel's brightness is its largest colour channel (its value for an (H, W) image; alpha is
    left out); the lit pixels are those brighter than 0, so a black background or umbra does not
    pull the exposure up.

    Parameters
    ----------
    image : array_like, shape (H, W), (H, W, 3) or (H, W, 4)
        Linear radiance, W m^-2 sr^-1.
    percentile : float
        In (0, 100]; 100 maps the brightest pixel to white.

    Returns
    -------
    float
        The factor for ``tonemap(..., exposure=)``, in sr m^2 W^-1; 1.0 for an image with no lit pixel.

    Examples
    --------
    >>> import numpy as np
    >>> from softshadows import io
    >>> shaded = np.zeros((8, 8))
    >>> shaded[2:6, 2:6] = 0.05                  # a lit patch on a black background
    >>> io.auto_exposure(shaded)
    20.0
    """
    a = _finite(_image(image))
    percentile = _v.positive("percentile", percentile, maximum=100.0)
    brightness = a[..., :3].max(axis=-1) if a.ndim == 3 else a
    lit = brightness[brightness > 0]
    if lit.size == 0:
        return 1.0
    return float(1.0 / np.percentile(lit, percentile))


def _exposure(exposure) -> float:
    """An explicit exposure: a finite factor > 0 (not a string or a bool), or a ValueError naming the argument."""
    try:
        return _v.positive("exposure", exposure)
    except ValueError:
        raise ValueError(f"exposure: expected 'auto' or a finite number > 0, got {exposure!r}") from None


def _finite(a: np.ndarray) -> np.ndarray:
    """``a`` as float64, or a ValueError if it holds NaN or Inf."""
    a = a.astype(np.float64)
    if not np.all(np.isfinite(a)):
        raise ValueError("image: contains NaN or Inf")
    return a


def _extension(path: str, expected: str, writes: str, instead: str) -> None:
    """Refuses a file name whose extension names another format than ``expected``."""
    ext = os.path.splitext(path)[1]
    if ext and ext.lower() != expected:
        fixed = os.path.splitext(path)[0] + expected
        raise ValueError(f"path: {path!r} has the extension {ext!r} but {writes}; "
                         f"name it {fixed!r}, {instead}")


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

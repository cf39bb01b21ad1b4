"""Environment lighting by fitted area lights (Annen et al. 2008, section 4.2).

An environment map is decomposed into square area lights by :func:`fit_area_lights` (the greedy
algorithm of ``rust/core/src/methods/envmap.rs``); :func:`environment` then shades receivers by
summing, over the fitted lights, radiance x BRDF at the light's center direction x visibility,
with the visibility from any soft-shadow method.

Conventions
-----------
- **Lat-long maps** (H, W, 3) use Mitsuba's ``envmap`` convention, so the same array can be given
  to :func:`softshadows.reference.mitsuba_environment_render`: pixel (i, j) is the direction
  ``(sin t sin p, cos t, -sin t cos p)`` with ``t = pi (i + 1/2) / H`` from +y (row 0 is the top)
  and ``p = 2 pi (j + 1/2) / W``.
- **Cube maps** (6, N, N, 3): faces +x, -x, +y, -y, +z, -z in OpenGL's convention (see the Rust
  module).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np

from . import _core
from . import _validate as v

__all__ = ["EnvironmentLight", "EnvironmentFit", "fit_area_lights", "cube_from_latlong", "environment", "sky"]

#: Face axis, d(direction)/du and d(direction)/dv of each cube face: direction = axis + u du + v dv.
_FACES = np.array(
    [
        [[1, 0, 0], [0, 0, -1], [0, -1, 0]],
        [[-1, 0, 0], [0, 0, 1], [0, -1, 0]],
        [[0, 1, 0], [1, 0, 0], [0, 0, 1]],
        [[0, -1, 0], [1, 0, 0], [0, 0, -1]],
        [[0, 0, 1], [1, 0, 0], [0, -1, 0]],
        [[0, 0, -1], [-1, 0, 0], [0, -1, 0]],
    ],
    dtype=np.float64,
)


def latlong_directions(height: int, width: int) -> np.ndarray:
    """Unit directions (height, width, 3) of the pixel centers of a lat-long map."""
    i, j = np.meshgrid(np.arange(height), np.arange(width), indexing="ij")
    t, p = np.pi * (i + 0.5) / height, 2 * np.pi * (j + 0.5) / width
    return np.stack([np.sin(t) * np.sin(p), np.cos(t), -np.sin(t) * np.cos(p)], axis=-1)


def sky(height: int = 128, *, sun_direction=(0.4, 0.8, -0.3), sun_radiance: float = 2000.0,
        sun_radius: float = 2.0, zenith=(0.25, 0.4, 0.8), horizon=(0.6, 0.7, 0.85),
        ground=(0.15, 0.12, 0.1)) -> np.ndarray:
    """A procedural lat-long sky (height, 2 height, 3) with a sun disk, for experiments.

    Parameters
    ----------
    height : int
        Rows of the map; it has twice as many columns.
    sun_direction : array_like, shape (3,)
        Direction towards the sun (normalized here).
    sun_radiance : float
        Radiance of the sun disk (all channels).
    sun_radius : float
        Angular radius of the sun disk, degrees.
    zenith, horizon, ground : array_like, shape (3,)
        RGB radiance at the zenith and at the horizon (blended by elevation) and of the lower
        hemisphere.

    Examples
    --------
    >>> import softshadows as ss
    >>> env = ss.envmap.sky(32)
    >>> env.shape, env.dtype, bool(env.max() > 100 * env.mean())  # the sun outshines the sky
    ((32, 64, 3), dtype('float32'), True)
    """
    height = v.positive_int("height", height)
    # About 100 bytes of float64 temporaries per pixel (directions, blends, the sun mask).
    v.memory("sky", 100.0 * height * 2 * height)
    s = v.vec3("sun_direction", sun_direction).astype(np.float64)
    if not np.any(s):
        raise ValueError("sun_direction: must be non-zero")
    s /= np.linalg.norm(s)
    zenith, horizon, ground = (_radiance(name, c) for name, c in (("zenith", zenith), ("horizon", horizon), ("ground", ground)))
    sun_radiance = v.positive("sun_radiance", sun_radiance, maximum=float(np.finfo(np.float32).max) / 2)
    sun_radius = v.positive("sun_radius", sun_radius)
    d = latlong_directions(height, 2 * height)
    up = np.clip(d[..., 1:2], 0.0, 1.0)
    env = np.where(d[..., 1:2] > 0, horizon * (1 - up) + zenith * up, ground)
    env = env + sun_radiance * (d @ s > np.cos(np.radians(sun_radius)))[..., None]
    return env.astype(np.float32)


def _radiance(name: str, value) -> np.ndarray:
    """An RGB radiance: three finite values >= 0 that stay finite in float32."""
    rgb = v.array(name, value, np.float64, (3,))
    if rgb.min() < 0 or rgb.max() > np.finfo(np.float32).max / 2:
        raise ValueError(f"{name}: expected RGB radiance in [0, 1.7e38], got {rgb.tolist()}")
    return rgb


def _latlong_lookup(latlong: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Bilinear lookup of unit directions ``d`` (..., 3) in a lat-long map (wrapping in azimuth)."""
    h, w = latlong.shape[:2]
    phi = np.arctan2(d[..., 0], -d[..., 2]) % (2 * np.pi)
    theta = np.arccos(np.clip(d[..., 1], -1.0, 1.0))
    x = phi / (2 * np.pi) * w - 0.5
    y = np.clip(theta / np.pi * h - 0.5, 0, h - 1)
    x0, y0 = np.floor(x).astype(int), np.floor(y).astype(int)
    fx, fy = (x - x0)[..., None], (y - y0)[..., None]
    y1 = np.minimum(y0 + 1, h - 1)
    at = lambda yy, xx: latlong[yy, xx % w]
    top = at(y0, x0) * (1 - fx) + at(y0, x0 + 1) * fx
    bottom = at(y1, x0) * (1 - fx) + at(y1, x0 + 1) * fx
    return top * (1 - fy) + bottom * fy


def cube_from_latlong(latlong, n: int = 64, *, supersample: int = 3) -> np.ndarray:
    """Resamples a lat-long map (H, W, 3) into a cube map (6, n, n, 3), averaging
    ``supersample ** 2`` bilinear lookups per texel.

    Examples
    --------
    >>> import numpy as np
    >>> import softshadows as ss
    >>> cube = ss.envmap.cube_from_latlong(np.ones((16, 32, 3), np.float32), n=8)
    >>> cube.shape, bool(np.allclose(cube, 1.0))  # a constant map stays constant
    ((6, 8, 8, 3), True)
    """
    latlong = v.array("env", latlong, np.float32, (None, None, 3)).astype(np.float64)
    if latlong.size == 0:
        raise ValueError(f"env: expected a non-empty lat-long map, got shape {latlong.shape}")
    n, k = v.positive_int("n", n), v.positive_int("supersample", supersample)
    # One face's sub-texel directions and lookups at a time: about 400 bytes per sub-texel.
    v.memory("cube_from_latlong", 400.0 * (float(n) * k) ** 2)
    t = (np.arange(n * k) + 0.5) / (n * k) * 2 - 1  # face coordinates of the sub-texels
    uu, vv = np.meshgrid(t, t)  # rows are v, columns u
    faces = []
    for axis, du, dv in _FACES:
        d = axis + uu[..., None] * du + vv[..., None] * dv
        d /= np.linalg.norm(d, axis=-1, keepdims=True)
        sub = _latlong_lookup(latlong, d)
        faces.append(sub.reshape(n, k, n, k, 3).mean(axis=(1, 3)))
    return np.stack(faces).astype(np.float32)


@dataclass(frozen=True)
class EnvironmentLight:
    """One fitted light: a rectangle of texels of one cube face.

    Attributes
    ----------
    direction : ndarray, shape (3,)
        Unit direction of the rectangle's center, from the scene towards the light.
    solid_angle : float
        Solid angle of the rectangle, steradians.
    radiance : ndarray, shape (3,)
        RGB radiance: the energy the light took over its solid angle.
    face : int
        Cube face (+x, -x, +y, -y, +z, -z).
    rect : tuple of int
        Texel rows ``i0:i1`` and columns ``j0:j1`` on the face.

    Examples
    --------
    >>> import softshadows as ss
    >>> fit = ss.envmap.fit_area_lights(ss.envmap.sky(32), resolution=16)
    >>> light = max(fit.lights, key=lambda l: l.energy.sum())  # the sun's
    >>> bool(light.direction[1] > 0.5), bool(light.solid_angle < 0.1)
    (True, True)
    >>> rect = light.area_light((0, 0, 0), 10.0)
    >>> type(rect).__name__, bool(rect.normal @ light.direction < 0)  # it faces the scene
    ('RectLight', True)
    """

    direction: np.ndarray
    solid_angle: float
    radiance: np.ndarray
    face: int
    rect: tuple

    @property
    def energy(self) -> np.ndarray:
        """RGB radiance times solid angle."""
        return self.radiance * self.solid_angle

    def area_light(self, center, distance: float):
        """The light as a :class:`~softshadows.RectLight` at ``distance`` from ``center``: the
        face rectangle scaled by ``distance``, so it subtends the same solid angle, facing
        ``center``."""
        from .lights import RectLight

        center = v.vec3("center", center).astype(np.float64)
        distance = v.positive("distance", distance)
        axis, du, dv = _FACES[self.face]
        n = self._n
        i0, i1, j0, j1 = self.rect
        u0, u1, v0, v1 = 2 * j0 / n - 1, 2 * j1 / n - 1, 2 * i0 / n - 1, 2 * i1 / n - 1
        mid = axis + 0.5 * (u0 + u1) * du + 0.5 * (v0 + v1) * dv
        a, b = 0.5 * (u1 - u0) * du * distance, 0.5 * (v1 - v0) * dv * distance
        if np.dot(np.cross(a, b), mid) > 0:  # the light must face the scene
            a, b = b, a
        try:
            return RectLight(center + distance * mid, a, b)
        except ValueError as exc:  # the rectangle is degenerate or overflows in float32
            raise ValueError(f"distance: the light at distance {distance:g} from {center.tolist()} is degenerate in float32 ({exc})") from None

    _n: int = field(default=0, repr=False)


@dataclass(frozen=True)
class EnvironmentFit:
    """The result of :func:`fit_area_lights`: the lights, the cube map they were fitted to, and
    the map's total RGB energy (radiance times solid angle).

    Examples
    --------
    >>> import numpy as np
    >>> import softshadows as ss
    >>> fit = ss.envmap.fit_area_lights(ss.envmap.sky(32), resolution=16)
    >>> fit.cube.shape, bool(np.allclose(sum(l.energy for l in fit.lights), fit.energy, rtol=1e-4))
    ((6, 16, 16, 3), True)
    """

    lights: list
    cube: np.ndarray
    energy: np.ndarray

    def plot(self, ax=None, *, path=None):
        """The cube map unfolded as a cross with every fitted light outlined (Annen et al. 2008, Figure 10)."""
        import matplotlib.pyplot as plt
        from matplotlib.patches import Rectangle

        n = self.cube.shape[1]
        origin = {0: (2, 1), 1: (0, 1), 2: (1, 0), 3: (1, 2), 4: (1, 1), 5: (3, 1)}  # (column, row)
        canvas = np.full((3 * n, 4 * n, 3), np.nan)
        for f, (c, r) in origin.items():
            canvas[r * n:(r + 1) * n, c * n:(c + 1) * n] = self.cube[f]
        tone = canvas / (1 + canvas)  # Reinhard, for display only
        if ax is None:
            _, ax = plt.subplots(figsize=(8, 6))
        ax.imshow(np.nan_to_num(tone ** (1 / 2.2), nan=1.0))
        for light in self.lights:
            c, r = origin[light.face]
            i0, i1, j0, j1 = light.rect
            ax.add_patch(Rectangle((c * n + j0 - 0.5, r * n + i0 - 0.5), j1 - j0, i1 - i0, fill=False, ec="lime", lw=1))
        ax.set_title(f"{len(self.lights)} fitted lights")
        ax.axis("off")
        if path is not None:
            ax.figure.savefig(path, dpi=100, bbox_inches="tight")
        return ax


def fit_area_lights(env, *, threshold: float = 0.025, max_lights: int | None = None, resolution: int = 64,
                    layout: str = "latlong", square: bool = True) -> EnvironmentFit:
    """Decomposes an environment map into area lights (Annen et al. 2008, section 4.2, Figures
    6 and 10).

    Each cube face is decomposed on its own: a light is seeded at the brightest texel no light
    covers yet, grown while the energy a side adds over the enlarged light's energy exceeds
    ``threshold``, and its energy removed from the map, leaving the face's mean radiance as a
    residual; until the face is covered or nothing uncovered emits. The threshold alone sets the
    number of lights: a uniform face is one light, every hot spot its own. What the residuals
    leave goes to the lights that cover it, so the lights' energies sum to the map's; no light
    repeats another and none is empty.

    Parameters
    ----------
    env : array_like or str or os.PathLike
        A lat-long map (H, W, 3), a cube map (6, N, N, 3), or an OpenEXR file read with
        ``layout``.
    threshold : float
        Growth threshold t in (0, 1): a side of a light moves out while the energy it adds over
        the energy of the enlarged light exceeds t. Larger t stops growth sooner: smaller and
        more lights (the paper: t = 0.015, 0.025 and 0.035 for 30, 45 and 60 lights on its maps).
    max_lights : int, optional
        A cap on the number of lights (>= 6). Faces then take their lights in turns and the
        energy not yet taken goes to each face's nearest light. Default: no cap.
    resolution : int
        Cube-face side N a lat-long map is resampled to.
    layout : {"latlong", "cube"}
        Layout of an EXR file given as ``env``.
    square : bool
        Keep lights square (the paper's results) or let each side grow on its own.

    Returns
    -------
    EnvironmentFit
        ``.lights`` (brightest first), ``.cube``, ``.energy`` and ``.plot()``.

    Examples
    --------
    >>> from softshadows import envmap
    >>> fit = envmap.fit_area_lights(envmap.sky(32), resolution=16)
    >>> bool(abs(sum(l.energy for l in fit.lights) / fit.energy - 1).max() < 1e-6)
    True
    """
    if isinstance(env, (str, bytes)) or hasattr(env, "__fspath__"):
        from .io import read_environment

        try:
            env = read_environment(env, layout=layout)
        except OSError as exc:  # the file is this function's ``env``, not read_environment's ``path``
            raise type(exc)(exc.errno, (exc.strerror or "").replace("path:", "env:"), exc.filename) from None
        except ValueError as exc:
            raise ValueError(str(exc).replace("path:", "env:", 1)) from None
    # Checked before the (possibly large) resampling; the core checks the ranges again.
    threshold = v.number("threshold", threshold)
    if not 0 < threshold < 1:
        raise ValueError(f"threshold: must be in (0, 1), got {threshold}")
    max_lights = None if max_lights is None else v.positive_int("max_lights", max_lights, maximum=2**32 - 1)
    try:
        with np.errstate(over="ignore", invalid="ignore"):  # beyond float32: refused below as not finite
            arr = np.asarray(env, dtype=np.float32)
    except (TypeError, ValueError) as exc:  # ragged nested lists, strings in arrays
        raise ValueError(f"env: expected an array of radiance, got {type(env).__name__} ({exc})") from None
    if arr.ndim == 4:
        cube = v.array("env", arr, np.float32, (6, None, None, 3))
        if cube.shape[1] != cube.shape[2] or cube.shape[1] == 0:
            raise ValueError(f"env: cube faces must be square and non-empty, got {cube.shape[1]}x{cube.shape[2]}")
    else:
        cube = cube_from_latlong(arr, v.positive_int("resolution", resolution))
    if not np.all(np.isfinite(cube)) or cube.min() < 0:
        raise ValueError("env: radiance must be finite and >= 0")
    n = cube.shape[1]
    fitted = _core.fit_area_lights(np.ascontiguousarray(cube), n, threshold, max_lights, v.flag("square", square))
    solid = _core.cube_solid_angles(n)
    lights = []
    for face, i0, i1, j0, j1, energy in fitted:
        omega = float(solid[i0:i1, j0:j1].sum())
        axis, du, dv = _FACES[face]
        uc, vc = (j0 + j1) / n - 1, (i0 + i1) / n - 1
        d = axis + uc * du + vc * dv
        lights.append(EnvironmentLight(d / np.linalg.norm(d), omega, np.asarray(energy) / omega, face, (i0, i1, j0, j1), n))
    lights.sort(key=lambda l: -float(l.energy @ [0.2126, 0.7152, 0.0722]))
    energy = (cube.astype(np.float64) * np.broadcast_to(solid[None, ..., None], cube.shape)).sum(axis=(0, 1, 2))
    return EnvironmentFit(lights, cube, energy)


def environment(scene, lights, receivers, *, method: str = "cssm", albedo=0.8, distance: float | None = None,
                progress: bool = True, **options) -> np.ndarray:
    """Outgoing radiance of Lambertian receivers under fitted environment lights.

    ``sum_i albedo / pi * L_i * Omega_i * max(0, n . w_i) * V_i``: each light's radiance ``L_i``
    and solid angle ``Omega_i``, the BRDF and cosine at the light's center direction ``w_i`` (as
    the paper does), and its visibility ``V_i`` from ``method`` run on the light as a
    :class:`~softshadows.RectLight` at ``distance`` from the scene's center. The center cosine
    is the method's approximation: a light that straddles a receiver's horizon (a smooth sky
    fits whole cube faces) counts for its center only; under a uniform sky an open, upward
    receiver gets 2/3 of its true radiance (``tests/test_envmap.py``).

    Parameters
    ----------
    scene : Scene
    lights : EnvironmentFit or sequence of EnvironmentLight
    receivers : GBuffer or Receivers
    method : str
        Any name in ``softshadows.METHODS``.
    albedo : float or array_like of shape (3,)
    distance : float, optional
        Distance of the lights from the scene's center; default 20 times the scene's bounding
        radius (distant lights, as an environment is).
    progress : bool
        Show a progress bar over the lights.
    **options
        Passed to the method (e.g. ``samples=64`` for ``ray_traced``).

    Returns
    -------
    ndarray, float32, the receivers' shape + (3,): linear RGB, 0 where there is no hit.

    Examples
    --------
    >>> import softshadows as ss
    >>> setup = ss.scenes.get("columns", width=16, height=16)
    >>> gb = ss.gbuffer(setup.scene, setup.camera)
    >>> fit = ss.envmap.fit_area_lights(ss.envmap.sky(32), resolution=16, max_lights=6)
    >>> radiance = ss.envmap.environment(setup.scene, fit, gb, method="cssm", resolution=64, progress=False)
    >>> radiance.shape, bool((radiance[gb.mask] > 0).all())
    ((16, 16, 3), True)
    """
    from .camera import as_receivers
    from .methods import METHODS, SetupWarning
    from .scene import Scene

    if not isinstance(method, str) or method not in METHODS:
        raise ValueError(f"method: expected one of {list(METHODS)}, got {method!r}")
    if isinstance(lights, EnvironmentFit):
        lights = list(lights.lights)
    elif isinstance(lights, (list, tuple)):
        lights = list(lights)
    if not isinstance(lights, list) or not lights or not all(isinstance(l, EnvironmentLight) for l in lights):
        raise ValueError("lights: expected an EnvironmentFit or a non-empty list of EnvironmentLight")
    v.instance("scene", scene, Scene, "a softshadows.Scene")
    rx = as_receivers(receivers)
    lo, hi = scene.bounds.astype(np.float64)
    center, radius = (lo + hi) / 2, max(float(np.linalg.norm(hi - lo)) / 2, 1e-6)
    distance = 20 * radius if distance is None else v.positive("distance", distance)
    try:
        albedo = np.broadcast_to(np.asarray(albedo, np.float64), (3,))
    except (TypeError, ValueError):
        raise ValueError(f"albedo: expected a number or an RGB triple in [0, 1], got {albedo!r}") from None
    if not np.all(np.isfinite(albedo)) or albedo.min() < 0 or albedo.max() > 1:
        raise ValueError(f"albedo: expected a number or an RGB triple in [0, 1], got {albedo.tolist()}")
    flat = rx._flat()
    points, normals, mask = flat.points, flat.normals, flat.mask
    out = np.zeros((len(points), 3))
    if progress:
        from tqdm.auto import tqdm

        lights = tqdm(lights, desc=f"environment ({method})", disable=None)  # only on a terminal
    for light in lights:
        irradiance = light.solid_angle * np.maximum(normals.astype(np.float64) @ light.direction, 0.0)
        if not np.any(irradiance[mask] > 0):
            continue
        try:
            with warnings.catch_warnings():  # an environment's lights below the horizon are no mistake
                warnings.simplefilter("ignore", SetupWarning)
                vis = METHODS[method](scene, light.area_light(center, distance), rx, **options).reshape(-1)
        except ValueError as exc:
            if str(exc).startswith("light:"):  # the light is this function's doing: its distance
                raise ValueError(f"distance: {method} refuses a fitted light placed {distance:g} from the scene's center ({exc})") from None
            raise
        out += light.radiance[None] * (irradiance * vis)[:, None]
    out *= albedo / np.pi
    out[~mask] = 0
    return out.reshape(rx.shape + (3,)).astype(np.float32)

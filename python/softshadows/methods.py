"""The soft-shadow methods (DESIGN.md section 5).

Every method is ``NAME(scene, light, receivers, *, ...)`` and returns visibility in the
receivers' shape — (H, W) for a :class:`~softshadows.GBuffer`, (K,) for
:class:`~softshadows.Receivers` — as float32 in [0, 1], 0 where the G-buffer has no hit.
``return_stats=True`` returns ``(visibility, stats)`` with per-stage seconds and work counters.
The GIL is released while the core runs.

Sample-based methods share one way to choose light samples: ``samples=n`` with ``pattern``,
``seed``, ``rotate``, ``interleaved`` and ``frame``, or an explicit (S, 3) array used for every
receiver, so that two methods can run on the very same samples.
"""

from __future__ import annotations

import numpy as np

from . import _core
from . import _validate as v
from .camera import as_receivers
from .lights import _Light, _pattern
from .scene import Scene

__all__ = ["ray_traced", "shadow_map", "METHODS"]

ROTATIONS = (None, "per_receiver")


def _native_receivers(receivers):
    points, normals, mask, width, height = receivers._flat()
    return _core.NativeReceivers(
        v.array("points", points, np.float32, (None, 3), finite=False),
        v.array("normals", normals, np.float32, (None, 3), finite=False),
        np.ascontiguousarray(mask, dtype=bool),
        width,
        height,
    )


def _native_samples(light, samples, *, pattern, seed, rotate, interleaved, frame):
    """The core sample set for ``samples`` (an int or an (S, 3) array) and the sampling options."""
    if rotate not in ROTATIONS:
        raise ValueError(f"rotate: expected None or 'per_receiver', got {rotate!r}")
    seed = v.nonneg_int("seed", seed)
    if isinstance(samples, (int, np.integer)) and not isinstance(samples, bool):
        n = v.positive_int("samples", samples)
        k = v.positive_int("interleaved", interleaved)
        return _core.NativeSamples.generate(
            light.native(), n, _pattern(pattern), seed, k, rotate == "per_receiver", v.nonneg_int("frame", frame)
        )
    pts = v.light_points("samples", samples)
    if interleaved != 1:
        raise ValueError("interleaved: explicit samples are shared by every receiver; pass samples=n to interleave")
    if frame != 0:
        raise ValueError("frame: explicit samples are used as given; pass samples=n to jitter over frames")
    return _core.NativeSamples.explicit(pts, seed if rotate == "per_receiver" else None)


def _check(scene, light) -> None:
    v.instance("scene", scene, Scene, "a softshadows.Scene")
    v.instance("light", light, _Light, "a PointLight, RectLight, DiskLight or SphereLight")


def _finish(receivers, out, return_stats):
    vis, stats = out
    vis = vis.reshape(receivers.shape)
    return (vis, dict(stats)) if return_stats else vis


def ray_traced(
    scene,
    light,
    receivers,
    *,
    samples=64,
    pattern: str = "poisson",
    seed: int = 0,
    rotate: str | None = None,
    interleaved: int = 1,
    frame: int = 0,
    epsilon: float | None = None,
    return_stats: bool = False,
):
    """Exact sampled visibility by shadow rays through a BVH: the oracle (DESIGN.md section 3).

    V(p) is the (emission-weighted) fraction of light samples y_s for which the open segment from
    p + epsilon n to y_s hits no opaque surface (alpha-tested for perforated meshes) and y_s lies
    in front of p's tangent plane.

    Parameters
    ----------
    scene : Scene
    light : PointLight, RectLight, DiskLight or SphereLight
    receivers : GBuffer or Receivers
    samples : int or array_like, shape (S, 3)
        Light samples per receiver, or explicit world-space samples shared by all receivers.
    pattern : {"poisson", "uniform", "stratified", "sobol", "halton"}
    seed : int
    rotate : {None, "per_receiver"}
        Decorrelate receivers by a random rotation of their samples (seed 001 section 4.1).
    interleaved : int
        Tile ``k x k`` independent patterns over the screen (seed 001 Figure 5f).
    frame : int
        Temporal jitter: frame ``i > 0`` rotates the whole pattern (seed 000 section 4.3). Only
        with ``samples=n``, like ``interleaved``; explicit samples are used as given.
    epsilon : float, optional
        Shadow-ray offset along the normal in world units; default ``scene.epsilon``.
    return_stats : bool
        Also return ``{"rays", "trace_seconds", ...}``.

    Returns
    -------
    ndarray, float32, the receivers' shape; with ``return_stats`` a ``(visibility, stats)`` tuple.
    """
    _check(scene, light)
    receivers = as_receivers(receivers)
    native_samples = _native_samples(
        light, samples, pattern=pattern, seed=seed, rotate=rotate, interleaved=interleaved, frame=frame
    )
    eps = scene.epsilon if epsilon is None else v.positive("epsilon", epsilon, allow_zero=True)
    out = _core.ray_traced(scene.native(), light.native(), _native_receivers(receivers), native_samples, eps)
    return _finish(receivers, out, return_stats)


def shadow_map(
    scene,
    light,
    receivers,
    *,
    resolution: int = 1024,
    bias: float | None = None,
    pcf: int = 1,
    return_stats: bool = False,
):
    """Hard shadows from one shadow map rendered at the light's center: the aliasing baseline.

    The depth map is fitted to the receivers' bounds as seen from a point light's position or
    an area light's center (seed 000 and 004 use it as the baseline).

    Parameters
    ----------
    scene : Scene
    light : any light
        Only its center is used.
    receivers : GBuffer or Receivers
    resolution : int
        Shadow-map width and height in texels.
    bias : float, optional
        Constant depth bias in world units. Default: slope-scaled,
        ``1.5 (r + 1) texel_size(depth) min(tan theta, 20) + 1e-4 depth`` with ``r = (pcf - 1) / 2``
        (see ``rust/core/src/methods/shadow_map.rs``).
    pcf : int
        Percentage-closer filtering taps per side, odd, at most 63 (1 = a single tap, 3 = 3x3, ...).
    return_stats : bool

    Returns
    -------
    ndarray, float32, the receivers' shape; with ``return_stats`` a ``(visibility, stats)`` tuple.
    """
    _check(scene, light)
    receivers = as_receivers(receivers)
    resolution = v.positive_int("resolution", resolution)
    pcf = v.positive_int("pcf", pcf)
    bias = None if bias is None else v.positive("bias", bias, allow_zero=True)
    out = _core.shadow_map(scene.native(), light.native(), _native_receivers(receivers), resolution, bias, pcf)
    return _finish(receivers, out, return_stats)


#: Every method by name, for the CLI and the evaluation suite.
METHODS = {"ray_traced": ray_traced, "shadow_map": shadow_map}

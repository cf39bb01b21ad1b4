"""The soft-shadow methods (docs/design.md section 5).

Every method is ``NAME(scene, light, receivers, *, ...)`` and returns visibility in the
receivers' shape — (H, W) for a :class:`~softshadows.GBuffer`, (K,) for
:class:`~softshadows.Receivers` — as float32 in [0, 1], 0 where the G-buffer has no hit.
``return_stats=True`` returns ``(visibility, stats)`` with per-stage seconds and work counters.
The GIL is released while the core runs.

Sample-based methods share one way to choose light samples: ``samples=n`` with ``pattern``,
``seed``, ``rotate``, ``interleaved`` and ``frame``, or an explicit (S, 3) array, so that two
methods can run on the very same samples. ``rotate="per_receiver"`` decorrelates each
receiver's copy of them: the default of ``stsv``, ``dcs`` and ``penumbra_wedge``, as Forest et
al. 2009 (section 4.1) always sample; every other method shares one pattern by default
(``rotate=None``), and so do these with ``rotate=None``.
"""

from __future__ import annotations

import time
import warnings
import weakref

import numpy as np

from . import _core
from . import _validate as v
from .camera import GBuffer, Receivers, as_receivers
from .gpu import resolve_backend
from .lights import DiskLight, PointLight, RectLight, _Light
from .scene import Scene
from .temporal import sequence_inputs, temporal_options

__all__ = ["SetupWarning", "ray_traced", "denoised", "shadow_map", "mvr", "vwss", "pcss", "cssm", "alias_free", "dcs", "penumbra_wedge", "stsv", "stsv_volumes", "backprojection", "resolve_msaa", "METHODS"]

ROTATIONS = (None, "per_receiver")


def _native_samples(light, samples, *, pattern, seed, rotate, interleaved, frame, receivers):
    """The core sample set for ``samples`` (an int or an (S, 3) array) and the sampling options,
    with only the interleaved patterns the pixels of ``receivers`` (core receivers) use."""
    if rotate not in ROTATIONS:
        raise ValueError(f"rotate: expected None or 'per_receiver', got {rotate!r}")
    seed = v.nonneg_int("seed", seed)
    if isinstance(samples, (int, np.integer)) and not isinstance(samples, bool):
        n = v.positive_int("samples", samples)
        k = v.positive_int("interleaved", interleaved)
        return _core.NativeSamples.generate(
            light.native(), n, v.option("pattern", pattern), seed, k, rotate == "per_receiver", v.nonneg_int("frame", frame), receivers
        )
    pts = v.light_points("samples", samples)
    if interleaved != 1:
        raise ValueError("interleaved: explicit samples are shared by every receiver; pass samples=n to interleave")
    if frame != 0:
        raise ValueError("frame: explicit samples are used as given; pass samples=n to jitter over frames")
    return _core.NativeSamples.explicit(pts, seed if rotate == "per_receiver" else None)


def _check(scene, light) -> None:
    v.instance("scene", scene, Scene, "a softshadows.Scene")
    v.instance("light", light, _Light, "a PointLight, RectLight, DiskLight, SphereLight or EllipsoidLight")


def _casting(scene, casters):
    """The scene whose meshes the depth maps are rendered from: all, or ``casters``."""
    if casters is None:
        return scene
    try:
        return scene.subset(casters)
    except ValueError as err:
        raise ValueError(f"casters: {err}") from None


_CASTERS_PARAMETER = """casters : sequence of int or str, optional
        The meshes (indices or names) that cast shadows; default every mesh. Every receiver
        still receives. Leaving out meshes that shadow nothing (a ground plane) saves work, as
        Marrs et al. 2018 render only the occluders within the light's influence (section 3.1);
        the depth-map methods leave them out of their maps, the object-based ones out of the
        casters they test."""


_CUBE_NOTE = """A light among the receivers (a lamp in a room: no frustum from its center holds
    their bounds) gets one map per face of a cube around its center, each receiver looked up in
    its own face's; each face's map reaches 1/8 past the face's edges, so that filters find the
    texels they read across a seam (stat ``light_faces``: 1 for one fitted frustum)."""


class SetupWarning(UserWarning):
    """A scene and light that cannot mean what they say: a one-sided light that faces away from
    every receiver (every method's visibility looks normal, every shaded image is black), or a
    light whose center no receiver sees, as under the floor (the depth-map methods then leak
    light through the floor: ``pcss`` and ``cssm`` up to 0.5).

    Examples
    --------
    >>> import warnings
    >>> import softshadows as ss
    >>> setup = ss.scenes.get("columns", width=16, height=16)
    >>> gb = ss.gbuffer(setup.scene, setup.camera)
    >>> light = ss.RectLight((0, 3, 0), (0.5, 0, 0), (0, 0, -0.5))  # faces up (u x v), away from all
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     _ = ss.shadow_map(setup.scene, light, gb, resolution=64)
    >>> [type(w.message).__name__ for w in caught]
    ['SetupWarning']
    """


#: Receivers the set-up check looks at, evenly spread over the hit ones.
SETUP_CHECK_RECEIVERS = 4096

#: The set-ups already checked, receivers -> scene -> lights (their reprs): a method run again on
#: them (the evaluation's repeated runs) does not pay the check's shadow rays again.
_CHECKED = weakref.WeakKeyDictionary()


def _warn_impossible_setup(scene, light, receivers) -> None:
    """Warns (:class:`SetupWarning`) when ``light`` cannot light any receiver: a one-sided light
    with every receiver behind it, or a light center that no receiver sees (one shadow ray per
    receiver of up to :data:`SETUP_CHECK_RECEIVERS`, through every mesh). Once per set-up."""
    lights = _CHECKED.setdefault(receivers, weakref.WeakKeyDictionary()).setdefault(scene, set())
    if repr(light) in lights:
        return
    lights.add(repr(light))
    flat = receivers._flat()
    hit = np.flatnonzero(flat.mask)
    if hit.size == 0:
        return
    pick = hit[np.linspace(0, hit.size - 1, min(hit.size, SETUP_CHECK_RECEIVERS)).round().astype(np.int64)]
    points, normals = flat.points[pick], flat.normals[pick]
    name = type(light).__name__
    if isinstance(light, (RectLight, DiskLight)) and np.all((points - light.center) @ light.normal.astype(np.float64) <= 0):
        flipped = ("RectLight(center, u, -v)" if isinstance(light, RectLight) else "DiskLight(center, -normal, radius)")
        warnings.warn(f"light: the {name} emits towards {np.round(light.normal, 3).tolist()} and every receiver lies "
                      f"behind it, so every shaded image is black; to light them, flip it: {flipped}",
                      SetupWarning, stacklevel=4)
        return
    # A point at the centre: an emission texture may leave the centre itself dark.
    centre = PointLight(light.center)
    sampled = _core.NativeSamples.explicit(v.light_points("samples", light.center[None, :]), None)
    check = Receivers(points, normals)
    seen, _ = _core.ray_traced(scene.native(), centre.native(), check.native(), sampled, scene.epsilon, "all")
    if not np.any(seen):
        warnings.warn(f"light: no receiver sees the {name}'s center {light.center.tolist()}: it lies behind every "
                      "receiver's surface or an occluder hides it from all of them (a light under the floor?), where "
                      "the depth-map methods leak light; move it in front of the surfaces it should light",
                      SetupWarning, stacklevel=4)


def _inputs(scene, light, receivers, casters=None):
    """Checks the common arguments; returns the receivers and the core's (scene, light, receivers)."""
    _check(scene, light)
    receivers = as_receivers(receivers)
    _warn_impossible_setup(scene, light, receivers)
    return receivers, (_casting(scene, casters).native(), light.native(), receivers.native())


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
    caster_faces: str = "all",
    casters=None,
    return_stats: bool = False,
):
    """Exact sampled visibility by shadow rays through a BVH: the oracle (docs/design.md section 3).

    V(p) is the (emission-weighted) fraction of light samples y_s for which the open segment from
    p + epsilon n to y_s hits no opaque surface (alpha-tested for perforated meshes) and y_s lies
    in front of p's tangent plane.

    Parameters
    ----------
    scene : Scene
    light : PointLight, RectLight, DiskLight, SphereLight or EllipsoidLight
    receivers : GBuffer or Receivers
    samples : int or array_like, shape (S, 3)
        Light samples per receiver, or explicit world-space samples shared by all receivers. A
        count ``n`` (without ``interleaved``) draws ``light.samples(n, pattern=pattern,
        seed=seed, frame=frame)``.
    pattern : {"poisson", "uniform", "stratified", "sobol", "halton"}
    seed : int
    rotate : {None, "per_receiver"}
        Decorrelate receivers by a random rotation of their samples (Forest et al. 2009, Soft
        Textured Shadow Volume, section 4.1).
    interleaved : int
        Tile ``k x k`` independent patterns over the screen (Forest et al. 2009, Figure 5f).
    frame : int
        Temporal jitter: frame ``i > 0`` rotates the whole pattern (Sintorn et al. 2008, section 4.3). Only
        with ``samples=n``, like ``interleaved``; explicit samples are used as given.
    epsilon : float, optional
        Shadow-ray offset along the normal in world units; default ``scene.epsilon``.
    caster_faces : {"all", "backfacing"}
        ``"all"`` (the default, the definition above): every surface blocks the segment from
        ``p + epsilon n``. ``"backfacing"``: as ``alias_free``'s default culls (Sintorn et al.
        2008, section 3.3), a closed mesh's triangle blocks the segment from ``p`` itself, and
        only when ``p`` lies strictly in front of its plane; open meshes still block from
        ``p + epsilon n``, and receivers inside a closed mesh are traced as with ``"all"``.
        For receivers on the outside of closed meshes this is the limit of ``"all"`` as
        ``epsilon`` goes to 0, computed without an offset (the closed faces' test in f64, which
        tells a receiver on its own face from one crossing it); it traces one ray at a time,
        with no packets: 10-18 times slower than ``"all"`` on five built-in scenes (128x128
        and 256x256 receivers, 64 samples).
    {casters}
    return_stats : bool
        Also return the stats dict, whose keys are {stats}.

    Returns
    -------
    ndarray, float32, the receivers' shape; with ``return_stats`` a ``(visibility, stats)`` tuple.

    Examples
    --------
    >>> import numpy as np
    >>> import softshadows as ss
    >>> setup = ss.scenes.get("columns", width=32, height=32)
    >>> gb = ss.gbuffer(setup.scene, setup.camera)
    >>> vis = ss.ray_traced(setup.scene, setup.light, gb, samples=setup.light.samples(16))
    >>> vis.shape, vis.dtype
    ((32, 32), dtype('float32'))
    >>> bool(np.all(np.round(vis * 16) == vis * 16))  # each pixel counts its 16 equal-weight samples
    True
    """
    receivers, inputs = _inputs(scene, light, receivers, casters)
    native_samples = _native_samples(
        light, samples, pattern=pattern, seed=seed, rotate=rotate, interleaved=interleaved, frame=frame, receivers=inputs[2]
    )
    eps = scene.epsilon if epsilon is None else v.number("epsilon", epsilon)  # its range: the core
    out = _core.ray_traced(*inputs, native_samples, eps, v.option("caster_faces", caster_faces))
    return _finish(receivers, out, return_stats)


def denoised(
    scene,
    light,
    receivers,
    *,
    spp: int = 1,
    seed: int = 0,
    frame: int = 0,
    history=None,
    epsilon: float | None = None,
    search_radius: int = 8,
    max_radius: int = 16,
    sigma_z: float = 1.0,
    sigma_n: float = 128.0,
    alpha: float = 0.1,
    depth_tolerance: float = 0.02,
    normal_tolerance: float = 25.0,
    casters=None,
    return_stats: bool = False,
):
    """A few stochastic shadow rays per pixel and a penumbra-aware spatio-temporal denoiser: what
    current engines ship (Boksansky, Wimmer and Bittner 2019), as a baseline for the classic methods.

    Stages (``rust/core/src/methods/denoised.rs``):

    1. ``spp`` shadow rays per pixel through the BVH that ``ray_traced`` uses, to points of each
       pixel's own Owen-scrambled Sobol sequence (Burley 2020): pixels get uncorrelated samples,
       and frame ``f`` continues a pixel's sequence where frame ``f - 1`` stopped. A textured
       light's samples fall in proportion to its emission. Each blocked ray reports the distance
       to its first blocker.
    2. The penumbra estimate of PCSS (Fernando 2005) from those hits: the mean blocker distance
       over a ``search_radius`` window and, by parallel planes, a penumbra width ``w`` on the
       receiver. A contact shadow (a blocker close to the receiver) has none and stays sharp.
    3. With a ``history``: the temporal stage of :func:`softshadows.accumulate` (reprojection,
       rejection, an exponential moving average of weight ``alpha``; Schied et al. 2017).
    4. A separable edge-aware Gaussian of standard deviation ``w / 4`` over the taps' world
       distances on the surface (reaching at most ``max_radius`` pixels), shrunk by
       ``sqrt(spp * frames)`` as the noise is, with the normal and depth edge-stopping weights
       of Schied et al. 2017 (section 4.4), depth measured off each pixel's tangent plane. As
       ``spp`` grows the filter narrows and the result converges to ``ray_traced``.

    Visibility is an estimate: noise and filter bias remain at low ``spp``, most in wide
    penumbrae. Without ``history`` every call is one still frame.

    Parameters
    ----------
    scene : Scene
    light : PointLight, RectLight, DiskLight, SphereLight or EllipsoidLight
    receivers : GBuffer
        The filter works over the image: explicit ``Receivers`` are refused
        (``UnsupportedSetup``); ``ray_traced`` serves them.
    spp : int
        Shadow rays per pixel and frame, in [1, 4096].
    seed : int
        Seed of the pixels' sequences.
    frame : int
        Index of this frame in a sequence: decorrelates the samples over time.
    history : History, optional
        The sequence's state (one per sequence, passed to every frame in order; updated in
        place): runs the temporal stage. None: a still frame.
    epsilon : float, optional
        Shadow-ray offset along the normal in world units; default ``scene.epsilon``.
    search_radius : int
        Half width in pixels of the window averaging the blocker distances, at most 256.
    max_radius : int
        The farthest a filter tap lies from its pixel, in pixels, at most 256 (stat ``radius``:
        the mean reach).
    sigma_z, sigma_n : float
        The depth and normal edge-stopping parameters (Schied et al. 2017: 1 and 128), > 0.
    alpha, depth_tolerance, normal_tolerance : float
        The temporal stage's options, as in :func:`softshadows.accumulate`.
    {casters}
    return_stats : bool
        Also return the stats dict, whose keys are {stats}.

    Returns
    -------
    ndarray, shape (H, W), float32; with ``return_stats`` a ``(visibility, stats)`` tuple.

    References
    ----------
    J. Boksansky, M. Wimmer and J. Bittner. Ray Traced Shadows: Maintaining Real-Time Frame
    Rates. Ray Tracing Gems, chapter 13, 2019.
    R. Fernando. Percentage-Closer Soft Shadows. SIGGRAPH 2005 Sketches.
    C. Schied et al. Spatiotemporal Variance-Guided Filtering: Real-Time Reconstruction for
    Path-Traced Global Illumination. High-Performance Graphics 2017.
    B. Burley. Practical Hash-based Owen Scrambling. Journal of Computer Graphics Techniques
    9(4), 2020.

    Examples
    --------
    >>> import numpy as np
    >>> import softshadows as ss
    >>> setup = ss.scenes.get("columns", width=48, height=48)
    >>> gb = ss.gbuffer(setup.scene, setup.camera)
    >>> exact = ss.ray_traced(setup.scene, setup.light, gb, samples=256)
    >>> one = ss.ray_traced(setup.scene, setup.light, gb, samples=1, rotate="per_receiver")  # 1 ray, unfiltered
    >>> vis, stats = ss.denoised(setup.scene, setup.light, gb, spp=1, return_stats=True)
    >>> int(stats["spp"]), int(stats["rays"]) <= int(gb.mask.sum())  # rays to samples behind a surface are not traced
    (1, True)
    >>> bool(ss.metrics.rmse(vis, exact, gb.mask) < 0.5 * ss.metrics.rmse(one, exact, gb.mask))
    True
    >>> history = ss.History()  # a sequence: the temporal stage accumulates its frames
    >>> for f in range(4):
    ...     vis = ss.denoised(setup.scene, setup.light, gb, frame=f, history=history)
    >>> history.frames
    4
    """
    receivers, inputs = _inputs(scene, light, receivers, casters)
    if not isinstance(receivers, GBuffer):
        raise _core.UnsupportedSetup("receivers: denoised filters over an image and needs a GBuffer "
                                     "(softshadows.gbuffer(scene, camera)); ray_traced serves explicit receivers")
    previous = None
    if history is not None:
        _, previous = sequence_inputs(receivers, history)
    eps = scene.epsilon if epsilon is None else v.number("epsilon", epsilon)  # its range: the core
    vis, accumulated, length, stats = _core.denoised(
        *inputs,
        receivers.camera.native(),
        v.positive_int("spp", spp),
        v.nonneg_int("seed", seed),
        v.nonneg_int("frame", frame),
        eps,
        v.nonneg_int("search_radius", search_radius),
        v.nonneg_int("max_radius", max_radius),
        v.number("sigma_z", sigma_z),
        v.number("sigma_n", sigma_n),
        history is not None,
        previous,
        *temporal_options(alpha, depth_tolerance, normal_tolerance),
    )
    if history is not None:
        history.record(receivers, accumulated, length)
    return _finish(receivers, (vis, stats), return_stats)


def shadow_map(
    scene,
    light,
    receivers,
    *,
    resolution: int = 1024,
    bias: float | None = None,
    pcf: int = 1,
    casters=None,
    backend: str = "cpu",
    return_stats: bool = False,
):
    """Hard shadows from one shadow map rendered at the light's center: the aliasing baseline.

    The depth map is fitted to the receivers' bounds as seen from a point light's position or
    an area light's center (Sintorn et al. 2008 and Marrs et al. 2018 use it as the baseline).

    {cube}

    Parameters
    ----------
    scene : Scene
    light : any light
        Only its center is used. A light with an emission texture is refused (ValueError): a
        hard shadow from its center cannot weight it.
    receivers : GBuffer or Receivers
    resolution : int
        Shadow-map width and height in texels.
    bias : float, optional
        Constant depth bias in world units. Default: every tap compares with the receiver's
        tangent plane, less half a texel of its depth gradient (``rust/core/src/raster/pcf.rs``).
    pcf : int
        Percentage-closer filtering taps per side, odd, at most 63 (1 = a single tap, 3 = 3x3, ...).
    {casters}
    backend : {"cpu", "gpu", "auto"}
        Where the lookups run: the CPU, or the GPU (wgpu; the lighting pass of ``mvr`` and
        ``vwss`` in ``rust/core/src/gpu/multiview.wgsl``, with one view), equal to the CPU's.
        The map is rasterized on the CPU either way. ``"auto"``: the GPU when an adapter exists,
        else the CPU with a warning.
    return_stats : bool
        Also return the stats dict, whose keys are {stats}.

    Returns
    -------
    ndarray, float32, the receivers' shape; with ``return_stats`` a ``(visibility, stats)`` tuple.

    Examples
    --------
    >>> import numpy as np
    >>> import softshadows as ss
    >>> setup = ss.scenes.get("columns", width=32, height=32)
    >>> gb = ss.gbuffer(setup.scene, setup.camera)
    >>> hard = ss.shadow_map(setup.scene, setup.light, gb, resolution=256)
    >>> bool(np.isin(hard, [0.0, 1.0]).all())  # one tap: lit or not
    True
    """
    receivers, inputs = _inputs(scene, light, receivers, casters)
    resolution = v.positive_int("resolution", resolution)
    pcf = v.positive_int("pcf", pcf)
    bias = None if bias is None else v.positive("bias", bias, allow_zero=True)
    out = _core.shadow_map(*inputs, resolution, bias, pcf, resolve_backend(backend, "shadow_map"))
    return _finish(receivers, out, return_stats)


def _view_samples(light, samples, *, pattern, seed, frame):
    """The light samples that multi-view methods render one depth map from each: ``samples`` is
    a count (a ``pattern`` on the light, Poisson by default as in Marrs et al. 2018) or an (S, 3)
    array."""
    if isinstance(samples, (int, np.integer)) and not isinstance(samples, bool):
        n = v.positive_int("samples", samples)
        return _core.NativeSamples.generate(
            light.native(), n, v.option("pattern", pattern), v.nonneg_int("seed", seed), 1, False, v.nonneg_int("frame", frame)
        )
    if frame != 0:
        raise ValueError("frame: explicit samples are used as given; pass samples=n to jitter over frames")
    return _core.NativeSamples.explicit(v.light_points("samples", samples), None)


def _multiview_options(resolution, pcf, bias):
    resolution = v.positive_int("resolution", resolution)
    pcf = v.positive_int("pcf", pcf)
    bias = None if bias is None else v.positive("bias", bias, allow_zero=True)
    return resolution, pcf, bias


_MULTIVIEW_PARAMETERS = """samples : int or array_like, shape (S, 3)
        Light samples, one depth map (one view) each: a count of ``pattern`` samples on the
        light, or explicit world-space samples (e.g. the ones given to ``ray_traced``).
    resolution : int
        Side of every light-sample depth map in texels (Marrs et al. 2018: 1024).
    pcf : int
        PCF taps per depth map: 5 (the paper's: the texel and its four neighbours), 1, or an odd
        square such as 9 (3x3) or 25 (5x5).
    bias : float, optional
        Constant depth bias in world units. Default: every tap compares with the receiver's
        tangent plane (``rust/core/src/raster/pcf.rs``).
    pattern : {"poisson", "uniform", "stratified", "sobol", "halton"}
        Pattern of ``samples=n``.
    seed : int
    frame : int
        Temporal jitter of ``samples=n`` (frame ``i > 0`` rotates the pattern)."""


def mvr(
    scene,
    light,
    receivers,
    *,
    samples=24,
    resolution: int = 1024,
    pcf: int = 5,
    bias: float | None = None,
    pattern: str = "poisson",
    seed: int = 0,
    frame: int = 0,
    casters=None,
    backend: str = "cpu",
    return_stats: bool = False,
):
    """Multi-view rasterization: one rasterized depth map per light sample (the reference of Marrs
    et al. 2018, View-warped Multi-view Soft Shadows).

    Every triangle is rasterized into a perspective depth map from each light sample (all views
    share one orientation and field of view fitted to the receivers); each receiver averages its
    PCF shadow tests over the maps, weighted by the light's emission at each sample. With 512
    views this is the paper's "ultra-high quality" reference.

    A light among the receivers (a lamp in a room: its center or a sample inside their bounds)
    gets a cube of six depth maps around every sample instead, each receiver tested in the face
    its direction from that sample falls in (stat ``light_faces``: the most faces one sample
    needed), on the CPU only.

    Parameters
    ----------
    scene : Scene
    light : RectLight, DiskLight, SphereLight, EllipsoidLight or PointLight
    receivers : GBuffer or Receivers
    {params}
    {casters}
    backend : {"cpu", "gpu", "auto"}
        Where the maps are rasterized and lit: the CPU, or the GPU (wgpu: one thread per triangle
        and view runs the CPU rasterizer's rules in f64, ``rust/core/src/methods/mvr/mvr.wgsl``, so the
        maps equal the CPU's texel for texel; the lighting is ``multiview.wgsl``). Perforated
        meshes need the CPU (no alpha test on the GPU). ``"auto"``: the GPU when an adapter
        exists, else the CPU with a warning.
    return_stats : bool
        Also return the stats dict, whose keys are {stats}.

    Returns
    -------
    ndarray, float32, the receivers' shape; with ``return_stats`` a ``(visibility, stats)`` tuple.

    Examples
    --------
    >>> import softshadows as ss
    >>> setup = ss.scenes.get("columns", width=32, height=32)
    >>> gb = ss.gbuffer(setup.scene, setup.camera)
    >>> samples = setup.light.samples(16)
    >>> vis = ss.mvr(setup.scene, setup.light, gb, samples=samples, resolution=256)
    >>> exact = ss.ray_traced(setup.scene, setup.light, gb, samples=samples)
    >>> bool(ss.metrics.rmse(vis, exact, gb.mask) < 0.05)  # the same samples, through depth maps
    True
    """
    receivers, inputs = _inputs(scene, light, receivers, casters)
    native_samples = _view_samples(light, samples, pattern=pattern, seed=seed, frame=frame)
    out = _core.mvr(*inputs, native_samples, *_multiview_options(resolution, pcf, bias), resolve_backend(backend, "mvr"))
    return _finish(receivers, out, return_stats)


def vwss(
    scene,
    light,
    receivers,
    *,
    samples=24,
    resolution: int = 1024,
    pcf: int = 5,
    mode: str = "buffered",
    parallel: str = "partial",
    views_per_pass: int = 8,
    cull_backfaces: bool = True,
    layered: bool = True,
    precision: str = "float32",
    source_view: str = "fitted",
    point_density: float | None = None,
    source_resolution: int | None = None,
    bias: float | None = None,
    pattern: str = "poisson",
    seed: int = 0,
    frame: int = 0,
    casters=None,
    backend: str = "cpu",
    return_stats: bool = False,
):
    """View-warped soft shadows (Marrs, Watson and Healey 2018): ``mvr``'s depth maps made by
    warping one multi-view point cloud instead of rasterizing the scene once per light sample.

    The scene is rasterized once from the light's center moved back along the view direction
    until its frustum contains every light sample's view (equations 1-2), at the resolution
    scaled by equation 3, with no depth test: every front-facing fragment along each ray becomes a
    point. The points are then projected into every light sample's depth map, snapped to the
    nearest texel and z-buffered by an atomic minimum; the lighting is ``mvr``'s, with the same
    depth bias.

    A texel keeps the nearest point anywhere inside it, so the shadows bloat slightly at every
    silhouette (Figure 6) and the occluders shadow themselves a little more than under ``mvr``
    (section 5.1). Against ``mvr`` on the same samples the difference is about RMSE 0.01 on one
    object; on a scene of many small objects, each a few dozen texels wide in the maps, the
    bloat is a larger share of every shadow (80 knots of 1536 triangles over a 12 x 12 ground:
    0.031 on the ground at 512² maps, 0.017 at 1024²; ``tests/test_vwss.py``). Larger maps shrink it; fewer points per texel
    (``point_density=1``) trade it for holes.

    A light among the receivers (a lamp in a room) is refused with a ValueError: the source view
    sits behind the light (section 3.1) and the paper leaves omni-directional lights to future
    work (section 5.2); ``mvr`` on the same samples handles it.

    Parameters
    ----------
    scene : Scene
    light : RectLight, DiskLight, SphereLight, EllipsoidLight or PointLight
    receivers : GBuffer or Receivers
    {params}
    mode : {"buffered", "unbuffered"}
        Store the points in a buffer and warp it (the paper's faster variant), or stream the
        rasterizer's fragments straight into the depth maps, rasterizing once per traversal.
    parallel : {"serial", "partial", "full"}
        Depth maps written per traversal of the points: one, ``views_per_pass``, or all.
    views_per_pass : int
        Maps per traversal with ``parallel="partial"`` (Listing 2: 8).
    cull_backfaces : bool
        Drop the fragments of closed meshes' triangles facing away from the source view (open,
        one-sided meshes always keep both sides); False keeps every back face too: more points,
        slightly more accurate.
    layered : bool
        Keep every fragment along each source ray (the method). False keeps only the nearest
        one: naive single-layer warping, which leaks light at disocclusions (Figure 4).
    precision : {"float32", "float16"}
        Storage of the buffered points' world positions.
    source_view : {"fitted", "paper"}
        How the source view is sized. ``"fitted"`` (default): pulled back just far enough that
        its frustum contains the actual light samples, with ``z_n`` of equation 3 the depth of
        the nearest occluder beyond the light. ``"paper"``: equations 1-3 as printed, ``d =
        max(l_w, l_h) / (2 tan(fov / 2))`` from the light's width and height (its extents along
        the views' axes; planar lights only) and ``z_n`` the light-sample views' near plane, as
        in Listing 1. Our
        views' near plane lies at 1/1000 of the receivers' depth, so the paper's equation 3 asks
        for about 1000 m and the cap of 8 m decides: far more points for the same maps.
    point_density : float, optional
        Points per target texel at depth ``z_n``: the source view's side is equation 3's
        ``m (z_n + d) / z_n`` times ``sqrt(point_density)`` (capped at 8 m). Default 2 with
        ``source_view="fitted"`` (at 1 the warped maps have holes that leak light; 2 closes them,
        see ``rust/core/src/methods/vwss/mod.rs``) and 1 with ``"paper"`` (the equation as printed).
    source_resolution : int, optional
        Side of the source view in texels, overriding ``point_density``.
    {casters}
    backend : {"cpu", "gpu", "auto"}
        Where the points are warped into the depth maps and lit: the CPU, or the GPU (wgpu; the
        paper's Listing 2 in ``rust/core/src/methods/vwss/vwss.wgsl``, buffered mode only, maps identical
        texel for texel; the lighting is ``multiview.wgsl``). The points are generated on the CPU
        either way. ``"auto"`` takes the GPU when an adapter exists, else the CPU with a warning.
    return_stats : bool
        Also return the stats dict, whose keys are {stats}: the columns of the paper's Tables
        1-2, plus ``source_resolution`` and ``pull_back`` (d of equation 1).

    Returns
    -------
    ndarray, float32, the receivers' shape; with ``return_stats`` a ``(visibility, stats)`` tuple.

    Examples
    --------
    >>> import softshadows as ss
    >>> setup = ss.scenes.get("columns", width=32, height=32)
    >>> gb = ss.gbuffer(setup.scene, setup.camera)
    >>> samples = setup.light.samples(16)
    >>> vis, stats = ss.vwss(setup.scene, setup.light, gb, samples=samples, resolution=256, return_stats=True)
    >>> peer = ss.mvr(setup.scene, setup.light, gb, samples=samples, resolution=256)
    >>> bool(ss.metrics.rmse(vis, peer, gb.mask) < 0.05), stats["points"] > 0
    (True, True)
    >>> _, printed = ss.vwss(setup.scene, setup.light, gb, samples=samples, resolution=256, source_view="paper",
    ...                      return_stats=True)
    >>> int(printed["source_resolution"])  # equation 3 with the views' near plane: the cap, 8 x 256
    2048
    """
    receivers, inputs = _inputs(scene, light, receivers, casters)
    native_samples = _view_samples(light, samples, pattern=pattern, seed=seed, frame=frame)
    source = None if source_resolution is None else v.positive_int("source_resolution", source_resolution)
    out = _core.vwss(
        *inputs,
        native_samples,
        *_multiview_options(resolution, pcf, bias),
        v.option("mode", mode),
        v.option("parallel", parallel),
        v.positive_int("views_per_pass", views_per_pass),
        v.flag("cull_backfaces", cull_backfaces),
        v.flag("layered", layered),
        v.option("precision", precision),
        v.option("source_view", source_view),
        v.positive("point_density", _point_density(source_view, point_density)),
        source,
        resolve_backend(backend, "vwss"),
    )
    return _finish(receivers, out, return_stats)


def _point_density(source_view, point_density):
    """``vwss``'s points per target texel: the one given, else 1 for the paper's equations as
    printed and 2 for the fitted source view."""
    if point_density is not None:
        return point_density
    return 1.0 if source_view == "paper" else 2.0


def pcss(
    scene,
    light,
    receivers,
    *,
    blocker_samples: int = 64,
    filter_samples: int = 96,
    resolution: int = 1024,
    bias: float | None = None,
    near: float | None = None,
    seed: int = 0,
    casters=None,
    backend: str = "cpu",
    return_stats: bool = False,
):
    """Percentage-closer soft shadows (Fernando 2005) from one depth map at the light's center.

    A Poisson-disk blocker search over the region where occluders could hide the light averages
    the blockers' depths; the parallel-planes estimate turns that into a penumbra width; PCF over
    that width gives the visibility. Marrs et al. 2018 configure 64 search and 96 filter taps.

    {cube}

    Parameters
    ----------
    scene : Scene
    light : RectLight, DiskLight, SphereLight, EllipsoidLight or PointLight
        Its center casts; its half extents along the map's axes set the search and filter sizes.
        A light with an emission texture is refused (ValueError): the filters cannot weight it.
    receivers : GBuffer or Receivers
    blocker_samples, filter_samples : int
        Poisson-disk taps of the blocker search and of the filter (at most 4096 each).
    resolution : int
        Depth-map side in texels.
    bias : float, optional
        Constant depth bias in world units. Default: every tap compares with the receiver's
        tangent plane.
    near : float, optional
        Near plane of the blocker search (linear depth from the light's center, world units);
        default the nearest depth in the map.
    seed : int
        Seed of the two tap patterns.
    {casters}
    backend : {"cpu", "gpu", "auto"}
        Where the blocker search and the filter run: the CPU, or the GPU (wgpu,
        ``rust/core/src/methods/pcss/pcss.wgsl``), equal to the CPU's. The depth map is rasterized on the
        CPU either way. ``"auto"``: the GPU when an adapter exists, else the CPU with a warning.
    return_stats : bool
        Also return the stats dict, whose keys are {stats}.

    Returns
    -------
    ndarray, float32, the receivers' shape; with ``return_stats`` a ``(visibility, stats)`` tuple.

    Examples
    --------
    >>> import softshadows as ss
    >>> setup = ss.scenes.get("columns", width=32, height=32)
    >>> gb = ss.gbuffer(setup.scene, setup.camera)
    >>> soft = ss.pcss(setup.scene, setup.light, gb, resolution=256)
    >>> bool(((soft > 0) & (soft < 1) & gb.mask).any())  # a penumbra, from one depth map
    True
    """
    receivers, inputs = _inputs(scene, light, receivers, casters)
    out = _core.pcss(
        *inputs,
        v.positive_int("resolution", resolution),
        v.positive_int("blocker_samples", blocker_samples),
        v.positive_int("filter_samples", filter_samples),
        None if bias is None else v.positive("bias", bias, allow_zero=True),
        None if near is None else v.positive("near", near),
        v.nonneg_int("seed", seed),
        resolve_backend(backend, "pcss"),
    )
    return _finish(receivers, out, return_stats)


def backprojection(
    scene,
    light,
    receivers,
    *,
    occluder: str = "micropatch",
    extend: bool = True,
    accumulation: str = "bitmask",
    bitmask_side: int = 16,
    accel: str = "ysm",
    ysm_resolution: int = 256,
    budget=None,
    level: int | None = None,
    blend: bool = True,
    smoothing: int = 11,
    resolution: int = 1024,
    bias: float | None = None,
    casters=None,
    return_levels: bool = False,
    return_counts: bool = False,
    return_stats: bool = False,
):
    """Backprojection soft shadow mapping with budgets and smooth quality scaling (Schwarz and Stamminger 2008).

    Micro-occluders built from one depth map at the light's center are backprojected from each
    receiver onto the light's plane (Guennebaud et al. 2006; Schwarz and Stamminger 2008). An
    acceleration structure (by default the Y shadow map of section 6) refines each receiver's
    search area and skips receivers in umbra or fully lit; a budget bounds the micro-occluders per
    light axis by choosing a coarser level, whose fractional value is smoothed across the image
    and blended between two levels. No receiver processes more than ``floor(b)**2`` micro-occluders
    at level ``ceil(l)`` and ``(2 floor(b))**2`` at ``floor(l)``. Stats report each acceleration
    structure's construction time and memory (Table 1) and the share of receivers that backproject
    with the micro-occluders they process (Table 2).

    {cube}

    Parameters
    ----------
    scene : Scene
    light : RectLight or DiskLight
        A planar area light: micro-occluders are backprojected onto its plane. One with an
        emission texture is refused (ValueError): the coverage is not weighted by it.
    receivers : GBuffer or Receivers
        With a multisampled G-buffer (``msaa > 1``), one backprojection per pixel and the
        resolve of :func:`resolve_msaa` (section 7); stats then add ``msaa_resolve_seconds`` and
        ``msaa_overhead`` (its cost relative to the rest).
    occluder : {"micropatch", "microquad", "microrect"}
        Texel squares at their depth; texel centers as a quad mesh; or the microrects of section
        5.2 (rectangles of level-0 texels merged greedily level by level).
    extend : bool
        Fill the gaps between a micropatch and its left and bottom neighbours where both occlude
        the receiver (Guennebaud et al. 2006; Schwarz and Stamminger 2008, section 3): the backprojection of the wall between
        their shared edge's two depths, where it falls outside the micropatch's.
    accumulation : {"bitmask", "area"}
        Occlusion bitmap over ``bitmask_side x bitmask_side`` jittered light samples, or the
        clamped sum of the backprojected areas.
    bitmask_side : int
        Light samples per axis of the bitmap (the paper: 16).
    accel : {"hsm", "mssm", "ysm"}
        The structure that bounds the search areas and classifies umbra and fully lit receivers
        (section 6): the min/max pyramid (HSM), the multi-scale shadow map of every power-of-two
        neighbourhood (MSSM, exact ranges, 8 bytes per texel and scale), or the Y shadow map (the
        HSM's levels down to ``ysm_resolution`` texels per side and an MSSM of that level).
    ysm_resolution : int
        Side of the YSM's MSSM part (the paper: 256).
    budget : float or array_like of shape (H, W), optional
        The micro-occluder budget ``b_mo`` per light axis (>= 1), or a per-receiver budget map;
        default none (always level 0).
    level : int, optional
        Use this shadow-map level for every receiver (no budget, no blending).
    blend : bool
        Blend the levels around the smoothed fractional level (section 4.2); ``False`` uses the
        budget's integer level and shows the transitions of Figure 1a.
    smoothing : int
        Side of the LOQ map's smoothing filter (odd; 1 disables it).
    resolution : int
        Depth-map side in texels.
    bias : float, optional
        Constant depth bias in world units; default the receiver's tangent plane.
    {casters}
    return_levels : bool
        Also return the smoothed LOQ map: each receiver's fractional shadow-map level, NaN where it
        backprojects nothing (umbra, fully lit, facing away; the level maps of Figure 8).
    return_counts : bool
        Also return the micro-occluders each receiver processed (uint32, both levels when
        blending, 0 where it backprojects nothing).
    return_stats : bool
        Also return the stats dict, whose keys are {stats} (Tables 1-2; ``processed_*`` and
        ``backprojected_*``: micro-occluders processed (read) and backprojected (in front of the receiver, projecting
        onto the light) per backprojecting receiver).

    Returns
    -------
    ndarray, float32, the receivers' shape; then the level map if ``return_levels``, the counts if
    ``return_counts`` and the stats dict if ``return_stats``, as a tuple.

    References
    ----------
    M. Schwarz and M. Stamminger, "Quality Scalability of Soft Shadow Mapping", Graphics Interface
    2008. G. Guennebaud, L. Barthe and M. Paulin, "Real-time Soft Shadow Mapping by
    Backprojection", Eurographics Symposium on Rendering 2006.

    Examples
    --------
    >>> import softshadows as ss
    >>> setup = ss.scenes.get("columns", width=32, height=32)
    >>> gb = ss.gbuffer(setup.scene, setup.camera)
    >>> vis, counts, stats = ss.backprojection(setup.scene, setup.light, gb, resolution=256, budget=5,
    ...                                        return_counts=True, return_stats=True)
    >>> bool(counts.max() <= 5**2 + 10**2), bool(stats["processed_max"] == counts.max())
    (True, True)
    """
    receivers, inputs = _inputs(scene, light, receivers, casters)
    if budget is not None:
        values = np.asarray(budget, dtype=np.float32)
        if values.ndim == 0:
            budget = [float(values)]
        elif values.shape == receivers.shape:
            budget = values.reshape(-1).tolist()
        else:
            raise ValueError(f"budget: expected a number or an array of the receivers' shape {receivers.shape}, got {values.shape}")
    out = _core.backprojection(
        *inputs,
        v.positive_int("resolution", resolution),
        v.option("occluder", occluder),
        v.flag("extend", extend),
        v.option("accumulation", accumulation),
        v.positive_int("bitmask_side", bitmask_side),
        v.option("accel", accel),
        v.positive_int("ysm_resolution", ysm_resolution),
        budget,
        None if level is None else v.nonneg_int("level", level),
        v.flag("blend", blend),
        v.positive_int("smoothing", smoothing),
        None if bias is None else v.positive("bias", bias, allow_zero=True),
    )
    vis, levels, counts, stats = out
    vis, stats = vis.reshape(receivers.shape), dict(stats)
    if getattr(receivers, "sample_depths", None) is not None:
        start = time.perf_counter()
        vis = resolve_msaa(vis, receivers)
        stats["msaa_resolve_seconds"] = time.perf_counter() - start
        total = sum(value for key, value in stats.items() if key.endswith("_seconds"))
        stats["msaa_overhead"] = stats["msaa_resolve_seconds"] / max(total - stats["msaa_resolve_seconds"], 1e-12)
    result = (vis,)
    if return_levels:
        result += (levels.reshape(receivers.shape),)
    if return_counts:
        result += (counts.reshape(receivers.shape),)
    if return_stats:
        result += (stats,)
    return result if len(result) > 1 else result[0]


def resolve_msaa(visibility, gbuffer, *, tau: float = 0.01) -> np.ndarray:
    """Applies one visibility per pixel to its MSAA samples and resolves them (Schwarz and Stamminger
    2008, Quality Scalability of Soft Shadow Mapping, section 7).

    A multisample whose camera depth is within ``tau`` (relative) of its pixel's center depth
    takes the pixel's visibility; any other takes the visibility of the 4-neighbour (or the pixel
    itself) whose center depth is closest to its own. The resolved visibility of a pixel is the
    mean over its samples that hit a surface.

    Parameters
    ----------
    visibility : ndarray, shape (H, W)
        One visibility per pixel, computed at the pixel centers of ``gbuffer``.
    gbuffer : GBuffer
        With ``msaa > 1`` (``sample_depths`` set).
    tau : float
        Relative camera-depth threshold under which a multisample counts as its pixel's.

    Returns
    -------
    ndarray, shape (H, W), float32: the resolved visibility (0 where no sample hits).

    Examples
    --------
    >>> import softshadows as ss
    >>> setup = ss.scenes.get("columns", width=32, height=32)
    >>> gb = ss.gbuffer(setup.scene, setup.camera, msaa=4)
    >>> vis = ss.shadow_map(setup.scene, setup.light, gb, resolution=256)
    >>> resolved = ss.resolve_msaa(vis, gb)
    >>> resolved.shape, bool(((resolved > 0) & (resolved < 1)).any())  # edges averaged over 4 samples
    ((32, 32), True)
    """
    v.instance("gbuffer", gbuffer, GBuffer, "a softshadows.GBuffer")
    if gbuffer.sample_depths is None:
        raise ValueError("gbuffer: resolve_msaa needs a G-buffer made with msaa > 1")
    # NaN or values outside [0, 1] would pass straight through to the resolved image.
    vis = v.array("visibility", visibility, np.float32, gbuffer.shape)
    if vis.size and (vis.min() < 0 or vis.max() > 1):
        raise ValueError(f"visibility: expected values in [0, 1], got [{vis.min()}, {vis.max()}]")
    tau = v.positive("tau", tau, allow_zero=True)
    h, w = gbuffer.shape
    center = np.where(gbuffer.mask, np.linalg.norm(gbuffer.positions - gbuffer.camera.eye, axis=-1), np.inf)
    samples = gbuffer.sample_depths.astype(np.float64)  # (H, W, S)
    # Candidates: the pixel itself and its 4-neighbours (edge pixels repeat themselves).
    pad_d = np.pad(center, 1, mode="edge")
    pad_v = np.pad(vis, 1, mode="edge")
    shifts = [(1, 1), (0, 1), (2, 1), (1, 0), (1, 2)]
    cand_d = np.stack([pad_d[y:y + h, x:x + w] for y, x in shifts], axis=-1)  # (H, W, 5)
    cand_v = np.stack([pad_v[y:y + h, x:x + w] for y, x in shifts], axis=-1)
    with np.errstate(invalid="ignore"):  # inf - inf: a sample or a candidate without a hit
        gap = np.nan_to_num(np.abs(samples[..., None] - cand_d[:, :, None, :]), nan=np.inf)  # (H, W, S, 5)
        own = np.abs(samples - center[..., None]) <= tau * center[..., None]
    nearest = np.take_along_axis(cand_v[:, :, None, :].repeat(samples.shape[2], 2), gap.argmin(-1)[..., None], -1)[..., 0]
    per_sample = np.where(own, vis[..., None], nearest)
    hit = np.isfinite(samples)
    count = hit.sum(-1)
    return np.where(count > 0, (per_sample * hit).sum(-1) / np.maximum(count, 1), 0.0).astype(np.float32)


def cssm(
    scene,
    light,
    receivers,
    *,
    order: int = 4,
    prefilter: str = "sat",
    resolution: int = 512,
    near: float | None = None,
    offset: float | None = None,
    scale: float = 1.0,
    sharpen_a: float = 0.0,
    sharpen_b: float = 10.0,
    casters=None,
    backend: str = "cpu",
    return_stats: bool = False,
):
    """Convolution soft shadow maps (Annen et al. 2008): constant-time soft shadows from one
    prefiltered depth map.

    The shadow test is expanded in a Fourier series of order ``order`` whose basis images are
    prefiltered (summed-area table or mipmap), so any box filter of the shadow test costs one
    lookup per image. The same expansion times depth (CSM-Z) gives the average blocker depth
    over the light's footprint through the search plane; the parallel-planes penumbra through
    that depth sizes the final filter. Ringing is suppressed by shifting the test by ``offset``
    and scaling it by ``scale`` before clamping; contact shadows are sharpened by
    ``V ** (1 + sharpen_a * exp(-sharpen_b * (d - z_avg)))`` (equation 9), depths normalized to the
    map's depth range.

    {cube}

    Parameters
    ----------
    scene : Scene
    light : RectLight, DiskLight, SphereLight, EllipsoidLight or PointLight
        Its center casts; its half extents along the map's axes size the filters (rectangular
        lights get rectangular filters). A light with an emission texture is refused
        (ValueError): prefiltered maps cannot carry it (section 4.2 of the paper).
    receivers : GBuffer or Receivers
    order : int
        Fourier order M (the paper: 4, or 16 for higher quality); ``4 M + 1`` basis images.
    prefilter : {"sat", "mipmap"}
        Summed-area table (exact box means) or mipmap (trilinear, cheaper, aliased at coarse levels).
    resolution : int
        Depth-map side in texels.
    near : float, optional
        Plane of the initial filter (linear depth from the light's center, world units); default
        the nearest depth in the map.
    offset : float, optional
        Shift of the shadow test towards the light, in normalized depth, in [0, 0.5) (the
        ringing suppression's shift, section 3.3). Default: where the truncated series
        ``S_M(t) = 1/2 + 2 sum_k sin(c_k t) / c_k`` of the step first reaches 1 (0.0763 at
        M = 4, 0.0192 at M = 16, about 0.3 / M): a receiver's own surface then tests exactly lit,
        so a filter half over lit texels reads 1/2 and the parallel-planes penumbra keeps its
        width (RMSE 0.0016 against 1024 ray-traced samples on the paper's exact case). The step's
        half width ``0.5 / M`` puts the own surface on the series' overshoot (1.09) instead, and
        the clamp narrows every penumbra by about 20%. Smaller shifts let a surface shadow itself.
    scale : float
        Scale of the filtered test about 1/2 before clamping to [0, 1] (any value > 0; default 1
        only clamps). Above 1 it pushes the ringing out of [0, 1] and narrows the penumbra by the
        same factor; below 1 it compensates a shift that overshoots.
    sharpen_a, sharpen_b : float
        A and B of equation 9 (the paper's Figure 4: A = 30, B = 5 to 20). The default
        ``sharpen_a=0`` is off: A = 30 darkens contacts as the paper shows, but also every
        self-shadowed pixel whose average blocker lies near it, and raised the RMSE on every
        scene we measured for B from 5 to 80 (see ``rust/core/src/methods/cssm/mod.rs``).
    {casters}
    backend : {"cpu", "gpu", "auto"}
        Where the basis images, their summed-area table and the lookups run: the CPU, or the GPU
        (wgpu, ``rust/core/src/methods/cssm/cssm.wgsl``; ``prefilter="sat"`` only; within 1e-3 of the CPU:
        f32 trigonometry, f64 tables). The shadow map is rasterized on the CPU either way.
        ``"auto"`` takes the GPU when an adapter exists, else the CPU with a warning.
    return_stats : bool
        Also return the stats dict, whose keys are {stats}.

    Returns
    -------
    ndarray, float32, the receivers' shape; with ``return_stats`` a ``(visibility, stats)`` tuple.

    Examples
    --------
    >>> import softshadows as ss
    >>> setup = ss.scenes.get("columns", width=32, height=32)
    >>> gb = ss.gbuffer(setup.scene, setup.camera)
    >>> vis = ss.cssm(setup.scene, setup.light, gb, resolution=256)
    >>> reference = ss.ray_traced(setup.scene, setup.light, gb, samples=64)
    >>> bool(ss.metrics.rmse(vis, reference, gb.mask) < 0.1)
    True
    """
    receivers, inputs = _inputs(scene, light, receivers, casters)
    out = _core.cssm(
        *inputs,
        v.positive_int("resolution", resolution),
        v.positive_int("order", order),
        v.option("prefilter", prefilter),
        None if near is None else v.positive("near", near),
        None if offset is None else float(offset),
        float(scale),
        float(sharpen_a),
        float(sharpen_b),
        resolve_backend(backend, "cssm"),
    )
    return _finish(receivers, out, return_stats)


def alias_free(
    scene,
    light,
    receivers,
    *,
    samples=256,
    resolution: int = 512,
    caster_faces: str = "backfacing",
    bias: float | None = None,
    lut="auto",
    hull_degree: int = 6,
    restrict_to_penumbra: bool = True,
    cut_at_supporting_plane: bool = True,
    pattern: str = "poisson",
    seed: int = 0,
    rotate: str | None = None,
    frame: int = 0,
    casters=None,
    backend: str = "cpu",
    return_stats: bool = False,
):
    """Sample-based visibility by alias-free shadow maps (Sintorn, Eisemann and Assarsson 2008).

    The receivers are stored in per-texel lists of the light's map; each caster triangle is
    rasterized conservatively over its influence region (its projection from every light point)
    and tests the receivers in the lists it covers exactly, so the result does not alias whatever
    the map's resolution. A point light gives hard shadows (one bit per receiver); an area or
    volume light gives a bitmask over ``samples`` light samples per receiver, set by AND-ing the
    masks of the planes through the receiver and the triangle's edges and OR-ing over triangles.
    On the same samples the exact mode (``lut=None``) computes ``ray_traced``'s visibility with
    the same ``caster_faces``: ``ray_traced(..., caster_faces="backfacing")`` for the default.

    On the CPU the time goes to the (view sample, triangle) pairs: the bunny at 512x512 with 256
    samples tests 41 million pairs (217 per view sample) and reads 2.1 plane masks per pair (3.3
    per pair left open), in 2.1-2.2x ``ray_traced``'s wall time with ``lut=64`` and 6.3-6.7x exact on two
    threads (``bench/alias_free.py``). Per band of rows of the map, a caster whose region there
    meets no view sample is passed over on the bounding box of its region's points; for the
    others, the triangle's own plane, its sphere test and its table entry (for unrotated samples)
    are set up, and per pair the three planes through the receiver and the triangle's edges are
    built and placed against the light's bounding sphere by squared distances, normalized and
    located in the table, for 8 receivers side by side in the CPU's vector registers (the same
    bits as one by one); the four masks of a pair left open are then AND-ed by their table codes
    without a branch. One thread's call spends about 21% on those planes and bins, 20% on the
    loop over the lists' entries, 10% on the table's reads and the masks' updates and 8% on the
    influence regions. Most pairs block nothing: 26 million are left open by every plane, 3.9
    million block a sample, and their masks must be read to know.

    Parameters
    ----------
    scene : Scene
    light : PointLight, RectLight, DiskLight, SphereLight or EllipsoidLight
    receivers : GBuffer or Receivers
    samples : int or array_like, shape (S, 3)
        1 to 1024 light samples shared by every receiver, anywhere (regions and tables bound
        them as well as the light). A point light has one sample, its position: explicit samples
        elsewhere are refused.
    resolution : int
        Side of the light's list map in texels (the paper: 512).
    caster_faces : {"backfacing", "all"}
        ``"backfacing"`` (the paper's scheme, section 3.3): closed meshes cast with their light
        back-facing triangles only, tested from the receiver itself, with no bias, for point and
        area lights alike (a closed triangle blocks only receivers strictly in front of its
        plane, so never the surface a receiver lies on); open meshes cast with every triangle,
        from the receiver moved ``bias``. ``"all"``: every triangle casts, from the moved
        receiver: ``ray_traced``'s default definition. The two differ only where the offset
        matters, near contact and where the light grazes a surface; there ``"backfacing"`` is
        the limit of ``"all"`` as ``bias`` goes to 0, and its oracle is
        ``ray_traced(..., caster_faces="backfacing")``. Measured at 128x128 on the columns, torus
        knot and bunny under rect, disk and sphere lights with 256 samples: ``"backfacing"``
        gives that oracle's bits on every pixel; ``"all"`` at ``scene.epsilon`` differs from it
        on 1.9-7.4% of the hit pixels, at ``scene.epsilon / 1000`` on 0-12 pixels of 12198-14564.
        Culling serves receivers outside every closed mesh only: from
        inside one a shadow ray leaves through a light front-facing triangle. So receivers found
        inside a closed mesh (within its bounds, an odd number of its faces on a ray from the
        receiver moved along its normal; stat ``inside_view_samples``), such as those whose
        normal points into it, are tested against every triangle, moved ``bias`` along their
        normal, as ``ray_traced``'s shadow rays start.
    bias : float, optional
        Offset of the receiver along its normal for casters that may be its own surface (open
        meshes, or every triangle with ``caster_faces="all"``); default ``scene.epsilon``, as
        ``ray_traced``.
    lut : "auto", int or None
        The plane-to-bitmask table's bins per parameter, or ``None`` to test every light sample
        against every plane exactly. A plane is binned by its distance from the light's center
        (``lut`` bins) and its unit normal: the paper's two angles (``lut``² bins) are here the
        normal's hemi-octahedral coordinates and its sign (2 floor(``lut``/√2)² bins, at most
        ``lut``²), whose bin is found by arithmetic, no search, and where a plane and its
        opposite fall in opposite bins, so that two triangles sharing an edge leave no sample
        between them. ``"auto"`` (the default) sizes
        it from the sample count as Sintorn et al. 2008 (section 4.3) do: 8 sqrt(S) bins rounded
        up to a multiple of 8, from the paper's typical 64 to 128, within 64 MiB (16, 64, 128,
        256, 512 and 1024 samples: 64, 64, 96, 128, 96 and 80 bins; stat ``lut_bins``), so that a
        bin stays about as wide as the samples' spacing on the light. Measured against exact tests on the same
        samples (128^2 receivers of the torus knot under a sphere light, the columns and the
        sphere on the ground; RMSE, then the mean error over the penumbra): at 64 samples the
        table's RMSE is 0.37-0.65 of the sampling error (against 4096 samples), at 256 samples
        (128 bins) 0.26-0.65, at 1024 (80 bins) 0.56-1.15, where a fixed 64^3 table gave
        0.75-1.33; its penumbrae come out darker by 0.001-0.003 on average at 256 and 1024
        samples (0.002-0.004 with 64 bins, 0.005-0.010 with 32), and its cost at 1024
        samples is about 1.5x that of 64 bins (those figures with the paper's two angles; the
        hemi-octahedral bins err 1.0-1.1x as much: on the ledger's torus knot at 64x64, 0.57x the
        sampling error sized from the samples against 0.55x, 0.79x against 0.71x with 64 bins; on
        the bunny at 512x512 with 256 samples, a mean error of 0.0039 against 0.0035 with 64
        bins). The table approximates, and darkens: its bins
        are relative to the light, so a binned plane misplaces a fixed part of the light, which
        looks the wider the nearer the light, and the binned planes of a triangle smaller than a
        bin in light space bound a triangle of about a bin's size, empty half the time and larger
        than the true one otherwise. A receiver nearer the light's center than 2.5 times the
        radius of the sphere holding its samples (the light fills a cone of 47 degrees or more,
        as under a light larger than the scene) tests its planes exactly instead (stat
        ``exact_view_samples``); the built-in scenes' default lights stay below 0.36 of that
        radius-to-distance ratio, against 0.4. (At 0.5, a sphere light of radius 1.16 just over
        a small closed sphere, 32 samples, put the table's mean error on the ground receivers at
        0.011; at 0.4, at most 0.005 around that case.) The exact tests read a table too, of
        per-bin bounds (the samples behind every plane of a bin, and those behind only some),
        and test only the samples left unsure: the same bits as testing every sample.
    hull_degree : int
        Sides of the bounding polygons of disk, sphere and ellipsoid lights (the paper: hexagons;
        ellipsoids by its virtual scaling to a sphere).
    restrict_to_penumbra : bool
        Section 4.3's restriction: only receivers inside the influence region of an edge that is
        a silhouette from some point of the light (or of a perforated caster) test every light
        sample; every other receiver sees all of the light or none of it, and one test against
        the light's center decides, tested only against the casters whose projection from the
        center covers its texel (the paper's hard-shadow test there). The result is the same.
        On the CPU the pairs tested hardly change (the columns and the torus knot at 96^2, 256
        samples: within 0.03%): a receiver in umbra stops testing once its mask is full, and lit
        receivers seldom lie in an influence region, while finding the silhouettes costs time.
    cut_at_supporting_plane : bool
        Section 4.3's cut of each caster's influence region at the triangle's supporting plane:
        where every light sample lies on one side of a triangle's plane, only receivers on the
        other side (or within ``bias`` of it) can be shadowed by it, and a closed mesh's light
        back-facing triangle only receivers in front of it, so the rest of its region is not
        tested. The result is the same. The cut is a half-plane on the light's list map, where
        a ray holds receivers at many depths: about 3% fewer pairs on the columns and the torus
        knot.
    pattern, seed, frame
        Choice of ``samples=n`` light samples, as in ``ray_traced``.
    rotate : {None, "per_receiver"}
        Decorrelate receivers by a random rotation of the samples about the light's center, as in
        ``ray_traced``: the lookups rotate the planes instead of the samples (Sintorn et al.
        2008, section 4.2), so only symmetric, untextured lights (disk, sphere) take it.
    backend : {"cpu", "gpu", "auto"}
        Where the lists, the influence regions' coverage and the per-texel tests run: the CPU,
        or the GPU (wgpu, ``rust/core/src/methods/alias_free/alias_free.wgsl``: lists by atomic counters and a
        scan, one thread per row of each caster's region over each band of rows, masks OR-ed by
        atomics), with the same bits as the CPU. The casters, their regions' polygons, the
        penumbra texels and the lookup table are set up on the CPU either way. ``"auto"``: the
        GPU when an adapter exists, else the CPU with a warning.
    {casters}
    return_stats : bool
        Also return the stats dict, whose keys are {stats}.

    Returns
    -------
    ndarray, float32, the receivers' shape; with ``return_stats`` a ``(visibility, stats)`` tuple.

    Examples
    --------
    >>> import numpy as np
    >>> import softshadows as ss
    >>> setup = ss.scenes.get("columns", width=32, height=32)
    >>> gb = ss.gbuffer(setup.scene, setup.camera)
    >>> samples = setup.light.samples(16)
    >>> exact = ss.alias_free(setup.scene, setup.light, gb, samples=samples, lut=None)
    >>> oracle = ss.ray_traced(setup.scene, setup.light, gb, samples=samples, caster_faces="backfacing")
    >>> bool(np.array_equal(exact, oracle))
    True
    """
    receivers, inputs = _inputs(scene, light, receivers, casters)
    native = _native_samples(light, samples, pattern=pattern, seed=seed, rotate=rotate, interleaved=1, frame=frame,
                             receivers=inputs[2])
    out = _core.alias_free(
        *inputs,
        native,
        v.positive_int("resolution", resolution),
        v.option("caster_faces", caster_faces),
        scene.epsilon if bias is None else v.positive("bias", bias, allow_zero=True),
        _lut(lut),
        v.positive_int("hull_degree", hull_degree),
        v.flag("restrict_to_penumbra", restrict_to_penumbra),
        v.flag("cut_at_supporting_plane", cut_at_supporting_plane),
        resolve_backend(backend, "alias_free"),
    )
    return _finish(receivers, out, return_stats)


_OBJECT_PARAMETERS = """samples : int or array_like, shape (S, 3)
        Light samples per receiver, or explicit world-space samples (each receiver's copy
        rotated as ``rotate`` says; Forest et al. 2009 use 16 or 64). A count ``n`` (without
        ``interleaved``) draws ``light.samples(n, pattern=pattern, seed=seed, frame=frame)``.
    pattern : {"poisson", "uniform", "stratified", "sobol", "halton"}
        Forest et al. 2009, section 4.1: uniform, stratified, Poisson disk (minimum distances 0.2456139 for
        16 and 0.1076681 for 64 samples), the (0, 2)-sequence (``"sobol"``).
    seed : int
    rotate : {"per_receiver", None}
        ``"per_receiver"`` (the default, as Forest et al. 2009, section 4.1, always sample): each
        receiver's copy of the samples, drawn or explicit, is decorrelated by a random rotation
        (a rigid rotation about the light's center for disk and sphere lights, a toroidal shift
        of a rectangle's parameters, a rotation of an ellipsoid's unit ball), so that the error
        is noise instead of the shared pattern's structured bands. The noise costs some RMSE on
        a rectangle: with 64 Poisson samples, 18-27% more on the evaluation's rect-light scenes
        (the toroidal shift keeps no minimum distance across the seam), 1-9% less on its disk
        lights. ``None`` gives every receiver the very same samples, e.g. to compare bit for bit
        with a reference on those samples.
    interleaved : int
        ``k x k`` interleaved patterns (Forest et al. 2009, Figure 5f).
    frame : int
        Temporal jitter, as in ``ray_traced``.
    epsilon : float, optional
        Offset of the receiver along its normal, as ``ray_traced``'s shadow rays; default
        ``scene.epsilon``.
    resolution : int
        Side of the light-space map that bins the receivers for the wedge passes.
    hull_degree : int
        Sides of the polygons bounding disk, sphere and ellipsoid lights in the wedge regions.
    {casters}"""


def _lut(lut):
    """``alias_free``'s ``lut=`` as the core takes it: None, "auto" or a bin count."""
    if lut is None or (isinstance(lut, str) and lut == "auto"):
        return lut
    if isinstance(lut, str):
        raise ValueError(f'lut: expected "auto", a number of bins or None, got {lut!r}')
    return v.positive_int("lut", lut)


def _object_inputs(scene, light, receivers, *, samples, pattern, seed, rotate, interleaved, frame, epsilon, resolution,
                   hull_degree, casters):
    """The common arguments of the object-based methods, as the core takes them."""
    receivers, inputs = _inputs(scene, light, receivers, casters)
    native_samples = _native_samples(
        light, samples, pattern=pattern, seed=seed, rotate=rotate, interleaved=interleaved, frame=frame, receivers=inputs[2]
    )
    eps = scene.epsilon if epsilon is None else v.number("epsilon", epsilon)  # its range: the core
    options = (eps, v.positive_int("resolution", resolution), v.positive_int("hull_degree", hull_degree))
    return receivers, (*inputs, native_samples, *options)


def _refuse_perforated(scene, method: str) -> None:
    """The opaque frameworks leave perforated meshes to ``stsv(opaque=method)``."""
    if any(m.perforated for m in scene.meshes):
        raise _core.UnsupportedSetup(f'scene: {method} casts from opaque meshes only; use stsv(..., opaque="{method}") for perforated ones')


def dcs(
    scene,
    light,
    receivers,
    *,
    samples=64,
    pattern: str = "poisson",
    seed: int = 0,
    rotate: str | None = "per_receiver",
    interleaved: int = 1,
    frame: int = 0,
    epsilon: float | None = None,
    resolution: int = 512,
    hull_degree: int = 6,
    casters=None,
    return_stats: bool = False,
):
    """Depth complexity sampling (Forest, Barthe and Paulin 2008; Forest et al. 2009, Soft
    Textured Shadow Volume, section 3.2).

    For every receiver and light sample, DCS counts the occluding faces between them: the count
    to the light's center (a hard shadow volume; here through the BVH), then, for every edge that
    is a silhouette from some point of the light and whose penumbra wedge holds the receiver, +1 or
    -1 per face for each sample the edge separates from the center. A sample with count 0 is
    visible. The counts are exact, so the result is ``ray_traced``'s on the same samples; only
    opaque meshes cast (perforated ones go through ``stsv(opaque="dcs")``).

    Parameters
    ----------
    scene : Scene
        Opaque meshes only.
    light : PointLight, RectLight, DiskLight, SphereLight or EllipsoidLight
    receivers : GBuffer or Receivers
    {object_params}
    return_stats : bool
        Also return the stats dict, whose keys are {stats}.

    Returns
    -------
    ndarray, float32, the receivers' shape; with ``return_stats`` a ``(visibility, stats)`` tuple.

    Examples
    --------
    >>> import numpy as np
    >>> import softshadows as ss
    >>> setup = ss.scenes.get("columns", width=32, height=32)
    >>> gb = ss.gbuffer(setup.scene, setup.camera)
    >>> samples = setup.light.samples(16)
    >>> vis = ss.dcs(setup.scene, setup.light, gb, samples=samples)
    >>> oracle = ss.ray_traced(setup.scene, setup.light, gb, samples=samples, rotate="per_receiver")
    >>> bool(np.array_equal(vis, oracle))
    True
    """
    _refuse_perforated(_casting(scene, casters), "dcs")
    receivers, args = _object_inputs(scene, light, receivers, samples=samples, pattern=pattern, seed=seed, rotate=rotate,
                                     interleaved=interleaved, frame=frame, epsilon=epsilon, resolution=resolution,
                                     hull_degree=hull_degree, casters=casters)
    return _finish(receivers, _core.dcs(*args), return_stats)


def penumbra_wedge(
    scene,
    light,
    receivers,
    *,
    samples=64,
    pattern: str = "poisson",
    seed: int = 0,
    rotate: str | None = "per_receiver",
    interleaved: int = 1,
    frame: int = 0,
    epsilon: float | None = None,
    resolution: int = 512,
    hull_degree: int = 6,
    casters=None,
    return_stats: bool = False,
):
    """Soft shadow volumes with penumbra wedges (Assarsson and Akenine-Möller 2003; Forest et al.
    2009, section 3.1).

    A visibility coefficient: the hard shadow of the light's center, plus, for each edge that is a
    silhouette from the center and whose penumbra wedge holds the receiver, the part of the light
    it hides or uncovers as seen from the receiver (measured on the light samples in front of the
    receiver's tangent plane). Approximate by design: silhouettes come from the center only, and
    the coverages of different edges add up, so overlapping occluders darken their common
    penumbra twice (Forest et al. 2009, Figure 4a). Opaque meshes only.

    Parameters
    ----------
    scene : Scene
        Opaque meshes only.
    light : PointLight, RectLight, DiskLight, SphereLight or EllipsoidLight
    receivers : GBuffer or Receivers
    {object_params}
    return_stats : bool
        Also return the stats dict, whose keys are {stats}.

    Returns
    -------
    ndarray, float32, the receivers' shape; with ``return_stats`` a ``(visibility, stats)`` tuple.

    Examples
    --------
    >>> import numpy as np
    >>> import softshadows as ss
    >>> setup = ss.scenes.get("columns", width=32, height=32)
    >>> gb = ss.gbuffer(setup.scene, setup.camera)
    >>> samples = setup.light.samples(16)
    >>> vis = ss.penumbra_wedge(setup.scene, setup.light, gb, samples=samples)
    >>> oracle = ss.ray_traced(setup.scene, setup.light, gb, samples=samples, rotate="per_receiver")
    >>> bool(np.abs(vis - oracle)[gb.mask].mean() < 0.01)  # exact up to its silhouette approximation
    True
    """
    _refuse_perforated(_casting(scene, casters), "penumbra_wedge")
    receivers, args = _object_inputs(scene, light, receivers, samples=samples, pattern=pattern, seed=seed, rotate=rotate,
                                     interleaved=interleaved, frame=frame, epsilon=epsilon, resolution=resolution,
                                     hull_degree=hull_degree, casters=casters)
    return _finish(receivers, _core.penumbra_wedge(*args), return_stats)


def stsv(
    scene,
    light,
    receivers,
    *,
    samples=64,
    opaque: str = "dcs",
    two_sided: bool = True,
    pattern: str = "poisson",
    seed: int = 0,
    rotate: str | None = "per_receiver",
    interleaved: int = 1,
    frame: int = 0,
    epsilon: float | None = None,
    resolution: int = 512,
    hull_degree: int = 6,
    casters=None,
    return_stats: bool = False,
):
    """Soft textured shadow volumes (Forest, Barthe, Guennebaud and Paulin 2009, Soft Textured Shadow
    Volume).

    Every triangle of a perforated mesh extrudes a volume that bounds its umbra and penumbra (its
    front cap moved towards the light, the outer quads of its edges' penumbra wedges, closed at the
    scene's bounds); for each receiver inside, each light sample is projected through the
    receiver onto the triangle (homogeneous barycentric and texture coordinates, equations 1-5)
    and blocked where the alpha texture is opaque. The opaque meshes cast through ``opaque``.

    Parameters
    ----------
    scene : Scene
        Perforated meshes (uvs and an alpha texture; uvs wrap) and opaque ones. A degenerate
        perforated triangle casts nothing; an all-transparent texture casts nothing and an
        all-opaque one casts as an opaque triangle.
    light : PointLight, RectLight, DiskLight, SphereLight or EllipsoidLight
    receivers : GBuffer or Receivers
    samples : int or array_like, shape (S, 3)
        1 to 1024 light samples per receiver (one bit each), or explicit world-space samples
        (Forest et al. 2009 use 16 or 64).
    opaque : {"dcs", "bitmask", "penumbra_wedge"}
        How the opaque meshes cast. The paper's two frameworks (Forest et al. 2009, section 3
        and Algorithm 2): ``"dcs"`` (the default) adds the blocked perforated samples to the
        depth complexities of ``dcs`` (exact, for every light and sampling option);
        ``"penumbra_wedge"`` adds the STSV's occluded fraction to the wedges' visibility
        coefficient (approximate: where opaque and perforated occluders overlap, the shadow is
        counted twice). ``"bitmask"`` ORs the STSV bitmasks with ``alias_free``'s (exact; one
        pattern shared by every receiver, no interleaving, and ``rotate="per_receiver"`` only
        for point, disk and sphere lights, whose rotations are rigid: pass ``rotate=None``
        with it for a rect or ellipsoid light).
    two_sided : bool
        Extrude a second volume on the far side of each perforated triangle that the light
        straddles, for the part of the light behind its plane. Default ``True``, a deliberate
        departure from the paper: its volumes are one-sided, and section 6 names the light
        behind a straddled triangle as their limit (leaves under an overhead light). One-sided
        volumes never block that part: on a vertical leaf card under an overhead light, 550 of
        6033 pixels were brighter than ``ray_traced`` on the same samples (up to 0.39), where
        two-sided volumes give its bits on every pixel. Only straddled triangles get a second
        volume, so the cost grows with them alone. ``False`` is the paper's variant.
    pattern, seed, rotate, interleaved, frame, epsilon, resolution, hull_degree
        As in ``dcs``.
    {casters}
    return_stats : bool
        Also return the stats dict, whose keys are {stats} (the paper's Figure 9), plus the
        opaque method's own.

    Returns
    -------
    ndarray, float32, the receivers' shape; with ``return_stats`` a ``(visibility, stats)`` tuple.

    Examples
    --------
    >>> import numpy as np
    >>> import softshadows as ss
    >>> setup = ss.scenes.get("fence", width=32, height=32)
    >>> gb = ss.gbuffer(setup.scene, setup.camera)
    >>> samples = setup.light.samples(16)
    >>> vis = ss.stsv(setup.scene, setup.light, gb, samples=samples)
    >>> oracle = ss.ray_traced(setup.scene, setup.light, gb, samples=samples, rotate="per_receiver")
    >>> bool(np.array_equal(vis, oracle))
    True
    """
    opaque = v.option("opaque", opaque)
    receivers, args = _object_inputs(scene, light, receivers, samples=samples, pattern=pattern, seed=seed, rotate=rotate,
                                     interleaved=interleaved, frame=frame, epsilon=epsilon, resolution=resolution,
                                     hull_degree=hull_degree, casters=casters)
    return _finish(receivers, _core.stsv(*args, opaque, v.flag("two_sided", two_sided)), return_stats)


def stsv_volumes(scene, light, receivers, *, two_sided: bool = True, hull_degree: int = 6):
    """The closed soft textured shadow volumes of the perforated triangles (Forest et al. 2009, Figure 3).

    Parameters
    ----------
    scene : Scene
    light : PointLight, RectLight, DiskLight, SphereLight or EllipsoidLight
    receivers : GBuffer or Receivers
        Each back cap lies parallel to its front cap, beyond the bounds of the scene and of these
        receivers, so that a closed volume holds every receiver its triangle can shadow.
    two_sided, hull_degree
        As in ``stsv``.

    Returns
    -------
    faces : ndarray, shape (V,), uint32
        The perforated triangle (global face id) of each volume.
    corners : ndarray, shape (V, 6, 3), float32
        The front cap t' (the triangle moved towards the light), then the back cap. Faces of a
        volume: ``[0, 1, 2]``, ``[3, 4, 5]`` and the quads ``[k, k + 1, k + 4, k + 3]`` (mod 3
        within each cap), as :data:`STSV_FACES` lists them.

    Examples
    --------
    >>> import softshadows as ss
    >>> setup = ss.scenes.get("fence", width=32, height=32)
    >>> gb = ss.gbuffer(setup.scene, setup.camera)
    >>> faces, corners = ss.methods.stsv_volumes(setup.scene, setup.light, gb)
    >>> corners.shape[1:], len(faces) == len(corners) > 0
    ((6, 3), True)
    """
    receivers, inputs = _inputs(scene, light, receivers)
    hull_degree = v.positive_int("hull_degree", hull_degree)
    faces, corners = _core.stsv_volumes(*inputs, hull_degree, v.flag("two_sided", two_sided))
    return faces, corners.reshape(-1, 6, 3)


#: The triangles of a closed volume of :func:`stsv_volumes` over its six corners.
STSV_FACES = np.array([[0, 2, 1], [3, 4, 5], [0, 1, 4], [0, 4, 3], [1, 2, 5], [1, 5, 4], [2, 0, 3], [2, 3, 5]], dtype=np.uint32)


#: The methods that sample the light: each takes its light samples as ``samples=`` (a count or
#: explicit points; the demo and the evaluation suite share one set among them). The other
#: methods filter one depth map from the light's center.
SAMPLED = frozenset({"ray_traced", "alias_free", "dcs", "penumbra_wedge", "stsv", "mvr", "vwss"})

#: Every method by name, for the CLI and the evaluation suite.
METHODS = {"ray_traced": ray_traced, "alias_free": alias_free, "stsv": stsv, "dcs": dcs, "penumbra_wedge": penumbra_wedge,
           "shadow_map": shadow_map, "pcss": pcss, "cssm": cssm, "backprojection": backprojection, "mvr": mvr, "vwss": vwss,
           "denoised": denoised}

for _name, _method in METHODS.items():
    _method.__doc__ = (_method.__doc__.replace("{object_params}", _OBJECT_PARAMETERS)
                       .replace("{params}", _MULTIVIEW_PARAMETERS).replace("{casters}", _CASTERS_PARAMETER)
                       .replace("{cube}", _CUBE_NOTE)
                       # the stats keys, declared once in the core (each method module's STATS)
                       .replace("{stats}", ", ".join(f"``{key}``" for key in _core.STATS[_name])))

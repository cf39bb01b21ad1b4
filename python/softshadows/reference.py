"""Mitsuba 3 references: the same scene as a Mitsuba scene, visibility by Mitsuba's own ray
queries, and path-traced direct illumination (docs/design.md section 4).

Choices made here (where the design is silent)
----------------------------------------------
* **Variant.** ``llvm_ad_rgb`` when it loads and runs, else ``scalar_rgb`` (whose ray queries
  run one ray at a time from Python: correct but slow, for tiny scenes only). The environment
  variable ``SOFTSHADOWS_MITSUBA_VARIANT`` forces one. The variant is selected lazily, at the first
  call that needs Mitsuba, and re-selected on every call (``mi.set_variant`` is process-global,
  so code that switches variants between our calls does not break us). :func:`variant` says
  which one is in use.
* **Textures.** Measured with Mitsuba 3.9: a ``bitmap`` texture built from an in-memory tensor
  maps row 0 to v in [0, 1/H) and a ``mi.Mesh``'s ``vertex_texcoords`` reach ``si.uv`` unchanged.
  That is already our convention (``alpha[i, j]`` covers v in [i/H, (i+1)/H), row 0 is v = 0),
  so no flip is applied. (The v flip people remember belongs to Mitsuba's OBJ/PLY loaders, which
  convert files' texture coordinates; images loaded from files have row 0 at the top.) Alpha is
  binarized at 0.5 before it becomes a ``mask`` opacity, with ``nearest`` filtering and
  ``repeat`` wrapping.
* **Surfaces.** Every mesh gets a ``twosided`` ``diffuse`` BSDF (our G-buffer shades the side the
  camera sees, and a bare Mitsuba ``diffuse`` is black from behind); meshes keep flat face
  normals (no vertex normals are passed).
* **Lights.** ``RectLight`` is a ``rectangle`` whose ``to_world`` maps local (a, b, 0) to
  ``center + a u + b v`` and local +z, the side an ``area`` emitter lights, to
  ``normalize(u x v)``. ``DiskLight`` is a ``disk`` (one-sided, facing ``normal``). ``SphereLight``
  is a ``sphere`` *surface* of uniform radiance: our sphere light emits from its volume, which
  matters for where visibility samples lie but not for shading, where a uniformly emitting sphere
  and a sphere surface of the same radiance give the same irradiance. ``EllipsoidLight`` is,
  likewise, its surface: a mesh (Mitsuba's ``sphere`` takes no non-uniform scale). ``PointLight`` is a
  ``point`` emitter of intensity ``intensity`` (W/sr). Area lights have radiance ``intensity``,
  times the emission texture of a textured ``RectLight`` (mapped through the rectangle's uv,
  which equals our (s, t) parameters; textured disks are refused: Mitsuba's disk uv is polar and
  cannot express our concentric map).
* **Units.** With radiance L (``intensity``) and reflectance ``albedo``, Mitsuba's rendered
  radiance of a lit diffuse point is ``albedo / pi * E`` with E the irradiance: the same scale as
  :func:`softshadows.shading.direct` (scale 1, checked in ``tests/test_shading.py``).
* **Light geometry in view.** The light's shape is part of the rendered scene (it must be, to
  emit); a camera ray that hits its back side sees black, not what lies behind it. Keep lights
  out of view or mask those pixels. The light's shape is never part of the visibility scene.
* **Visibility.** Section 3 of docs/design.md: ray origin ``p + eps n`` (n normalized, eps defaulting
  to ``scene.epsilon``), unit direction toward the sample and ``maxt = |y_s - origin| (1 - 1e-6)``
  so the segment stops just short of the sample, and v = 0 for samples with
  ``dot(y_s - p, n) <= 0`` (those rays are not traced). Textured lights weight their samples by
  ``light.weights`` (the core's emission lookup), giving a weighted mean (0 when the weights
  sum to 0, as in the core).
* **Speed.** In the vectorized variants the rays are built inside Dr.Jit, each gathering its
  receiver and sample, so that their set-up fuses into the kernel of ``ray_test`` (same float64
  arithmetic as the numpy set-up of ``scalar_rgb``, so the same rays), and without perforated
  meshes or an emission texture each receiver's clear rays are counted there too: no per-ray
  array reaches Python (with enough receivers to keep every thread busy, each gets a lane that
  loops over the samples, so nothing per ray is stored). The Mitsuba scenes of a softshadows scene are loaded once and kept
  with it (a weak reference, per variant): loading builds Embree's BVH, 0.3 s for the bunny.
* **Perforated meshes.** ``scene.ray_test`` treats a ``mask`` BSDF as opaque, so opaque meshes
  and perforated meshes go into two Mitsuba scenes: rays are first tested against the opaque one
  (``ray_test``), and survivors march through the perforated one with ``ray_intersect``, looking
  our alpha up at ``si.uv`` (nearest texel, repeat) and, at a transparent texel, restarting on
  the same line just past the hit (clearing the surface by a few float32 ulps, much less than
  Mitsuba's spawn offset, which steps over opaque texels of touching leaves; see ``_step_past``
  for how far and why not along the normal).
  A ray that is still crossing transparent texels after :data:`MAX_ALPHA_STEPS` hits counts as
  blocked, with a ``RuntimeWarning`` giving how many.
* **Renders.** ``integrator="auto"`` is ``path`` (max_depth 2: emitted plus direct light) for
  scenes without perforated meshes and ``volpath`` (max_depth 2) otherwise, because ``path`` and
  ``direct`` shadow rays are stopped by ``mask`` BSDFs whatever their opacity. Measured with
  Mitsuba 3.9 (64 spp, a fully transparent mask quad between a rect light and a lit floor):
  ``path``/``direct`` 0.0011 (as dark as an opaque quad), ``volpath`` 0.0528 against 0.0532
  without the quad (noise level), and ``volpath`` shadow rays are stopped by opaque texels.
* **Cache.** Results are ``.npz`` files in ``$SOFTSHADOWS_CACHE`` (default
  ``~/.cache/softshadows/reference``), named by a SHA-256 of every input: geometry and texture
  bytes, every attribute of the light, receivers, samples, options, the Mitsuba version, the
  variant and :data:`CACHE_VERSION`. Each file holds its key beside the result; an entry whose key,
  shape, dtype or values (finite, and in [0, 1] for visibility) are not what the call expects is
  ignored with a ``RuntimeWarning`` and recomputed. Files are written atomically (a temporary name
  per process and thread) and never edited; the folder is checked before any work, and a folder
  that cannot be written raises ``OSError`` naming it. Delete the directory to clear it.
"""

from __future__ import annotations

import functools
import hashlib
import os
import threading
import uuid
import warnings
import weakref
from pathlib import Path

import numpy as np

from . import _validate as v
from ._extras import require
from .camera import Camera, as_receivers
from .lights import DiskLight, EllipsoidLight, PointLight, RectLight, SphereLight
from .scene import Scene

__all__ = ["variant", "mitsuba_scene", "mitsuba_visibility", "mitsuba_render", "mitsuba_environment_render", "cache_dir", "CACHE_VERSION"]

#: Bumped whenever a change here changes results, so stale cache entries are never read.
CACHE_VERSION = 3
#: Transparent texels a shadow ray may cross before it counts as blocked.
MAX_ALPHA_STEPS = 64
#: Rays per Mitsuba call: large enough to amortize the JIT, small enough for memory (~200 MB).
RAYS_PER_CALL = 1 << 22
#: Dr.Jit's LLVM backend hands a kernel's lanes to its threads in blocks of this many.
_DRJIT_BLOCK = 16384
#: Shadow segments stop this fraction of their length short of the light sample.
_SEGMENT_SHRINK = 1e-6
#: How far a ray steps past a transparent hit, in units of (1 + max|p|): 2-4 float32 ulps of
#: the hit's coordinates (see _step_past). Measured on the leaves scene: at half this, rays
#: start landing back on the surface they left (then _grow_on_rehit lengthens their step).
_STEP_CLEARANCE = 2.0 ** -22

_VARIANTS = ("llvm_ad_rgb", "scalar_rgb")
_selected: str | None = None


# ----------------------------------------------------------------------------- variant


def variant() -> str:
    """The Mitsuba variant these references use, selecting it on first use.

    Returns
    -------
    str
        ``"llvm_ad_rgb"`` when it loads and runs, else ``"scalar_rgb"`` (or the value of the
        ``SOFTSHADOWS_MITSUBA_VARIANT`` environment variable).

    Examples
    --------
    >>> from softshadows import reference
    >>> reference.variant() in ("llvm_ad_rgb", "scalar_rgb")
    True
    """
    _mitsuba()
    return _selected


#: Serializes Mitsuba's import and variant selection: threads making a process's first calls
#: at once otherwise see a half-initialized module (no ``__version__``) or each other's variant.
_MITSUBA_LOCK = threading.RLock()


def _mitsuba():
    """Imports Mitsuba with our variant set, choosing it the first time (one thread at a time)."""
    with _MITSUBA_LOCK:
        return _select_variant()


def _select_variant():
    global _selected
    mi = require("mitsuba", extra="evaluation", for_="softshadows.reference")

    if _selected is None:
        forced = os.environ.get("SOFTSHADOWS_MITSUBA_VARIANT")
        errors = []
        for name in (forced,) if forced else _VARIANTS:
            try:
                mi.set_variant(name)
                _smoke_test(mi)
            except Exception as exc:  # a missing LLVM shows up at set_variant or at the first kernel
                errors.append(f"{name}: {exc}")
                continue
            _selected = name
            break
        else:
            raise RuntimeError("no usable Mitsuba variant: " + "; ".join(errors))
        if errors and not forced:  # the fast variant failed: say so once, and how to get it
            warnings.warn(
                f"Mitsuba's fast llvm_ad_rgb variant did not load ({errors[0].splitlines()[0]}); the Mitsuba "
                "references use scalar_rgb, which traces one ray at a time from Python: correct, but several times "
                "slower (minutes for the demo). For the fast variant install LLVM 19, on Debian/Ubuntu with "
                "`sudo apt-get install -y libllvm19` (elsewhere, set DRJIT_LIBLLVM_PATH to LLVM 19's libLLVM.so), "
                "and start Python again; SOFTSHADOWS_MITSUBA_VARIANT=scalar_rgb chooses scalar_rgb without this warning.",
                RuntimeWarning, stacklevel=4)
    elif mi.variant() != _selected:
        mi.set_variant(_selected)
    return mi


def _smoke_test(mi) -> None:
    """Runs one tiny ray query, so a variant that imports but cannot JIT is rejected here."""
    scene = mi.load_dict({"type": "scene", "s": {"type": "sphere", "center": [0, 0, 0], "radius": 1.0}})
    hit = scene.ray_test(mi.Ray3f(mi.Point3f(0, 0, -3), mi.Vector3f(0, 0, 1), 10.0))
    if not bool(np.all(np.asarray(hit))):
        raise RuntimeError("smoke test ray missed")


def _vectorized(mi) -> bool:
    return not mi.variant().startswith("scalar")


# ----------------------------------------------------------------------------- scenes


def mitsuba_scene(scene: Scene, light, camera: Camera | None = None, *, albedo: float = 0.8,
                  intensity: float = 1.0, spp: int = 64) -> dict:
    """The scene, its light and optionally a camera as a Mitsuba 3 scene dictionary.

    Parameters
    ----------
    scene : Scene
        Meshes become ``mi.Mesh`` objects built in memory (positions, faces, texcoords when the
        mesh has uvs) with a two-sided diffuse BSDF; perforated meshes wrap it in a ``mask`` BSDF
        whose opacity is the alpha texture binarized at 0.5 (nearest, repeat; see the module
        notes on the uv convention).
    light : PointLight, RectLight, DiskLight, SphereLight or EllipsoidLight
        Becomes a ``point`` emitter or an emitting ``rectangle``/``disk``/``sphere`` shape.
    camera : Camera, optional
        Adds a ``perspective`` sensor (vertical fov, box filter, RGB ``hdrfilm``) with an
        ``independent`` sampler of ``spp`` samples per pixel.
    albedo : float
        Diffuse reflectance in [0, 1].
    intensity : float
        Radiance of an area light (W m^-2 sr^-1) or intensity of a point light (W sr^-1).
    spp : int
        Samples per pixel of the sensor's sampler.

    Returns
    -------
    dict
        Pass it to ``mitsuba.load_dict``. It holds Mitsuba objects, so it belongs to the variant
        that :func:`variant` reports. Keys: ``mesh_000``, ... , ``light``, and ``sensor``.

    Examples
    --------
    >>> import softshadows as ss
    >>> setup = ss.scenes.get("columns", width=16, height=16)
    >>> d = ss.reference.mitsuba_scene(setup.scene, setup.light, setup.camera)
    >>> d["type"], sorted(d)
    ('scene', ['light', 'mesh_000', 'mesh_001', 'sensor', 'type'])
    """
    mi = _mitsuba()
    _check_scene(scene)
    albedo = _albedo(albedo)
    intensity = v.positive("intensity", intensity)
    spp = v.positive_int("spp", spp)
    d = {"type": "scene"}
    d.update(_mesh_shapes(mi, scene, range(len(scene.meshes)), albedo))
    d["light"] = _light_dict(mi, light, intensity)
    if camera is not None:
        d["sensor"] = _sensor_dict(mi, _check_camera(camera), spp)
    return d


def _mesh_shapes(mi, scene: Scene, indices, albedo: float) -> dict:
    return {f"mesh_{i:03d}": _mesh(mi, scene.meshes[i], f"mesh_{i:03d}", albedo) for i in indices}


def _mesh(mi, mesh, name: str, albedo: float):
    """One ``mi.Mesh`` from our arrays, with its BSDF attached."""
    has_uv = mesh.uvs is not None
    m = mi.Mesh(name, len(mesh.vertices), len(mesh.faces), has_vertex_texcoords=has_uv)
    params = mi.traverse(m)
    # The buffers' own types: mi.Float in JIT variants, dynamic ArrayXf/ArrayXu in scalar ones.
    for key, values in (("vertex_positions", mesh.vertices), ("faces", mesh.faces), ("vertex_texcoords", mesh.uvs)):
        if values is not None:
            params[key] = type(params[key])(values.reshape(-1))
    params.update()
    m.set_bsdf(mi.load_dict(_bsdf_dict(mesh, albedo)))
    return m


def _bsdf_dict(mesh, albedo: float) -> dict:
    surface = {"type": "twosided", "material": {"type": "diffuse", "reflectance": {"type": "rgb", "value": albedo}}}
    if mesh.alpha is None:
        return surface
    return {"type": "mask", "opacity": _texture(mesh.alpha >= 0.5), "material": surface}


def _texture(values: np.ndarray) -> dict:
    """A nearest/repeat bitmap of a (H, W) array, row 0 at v = 0 (Mitsuba's in-memory convention)."""
    mi = require("mitsuba", extra="evaluation", for_="softshadows.reference")

    data = np.ascontiguousarray(values, dtype=np.float32)[..., None]
    return {"type": "bitmap", "bitmap": mi.Bitmap(data), "filter_type": "nearest", "wrap_mode": "repeat", "raw": True}


def _light_dict(mi, light, intensity: float) -> dict:
    if isinstance(light, PointLight):
        return {"type": "point", "position": light.position.tolist(), "intensity": {"type": "rgb", "value": intensity}}
    radiance = {"type": "rgb", "value": intensity}
    if isinstance(light, RectLight):
        if light.emission is not None:
            radiance = _scaled_texture(light.emission, intensity)
        to_world = _frame(light.center, light.u, light.v, light.normal)
        return {"type": "rectangle", "to_world": to_world, "emitter": {"type": "area", "radiance": radiance}}
    if isinstance(light, DiskLight):
        if light.emission is not None:
            raise ValueError("light: a textured DiskLight has no Mitsuba equivalent (Mitsuba's disk uv is polar)")
        t, b = light.tangent_frame
        to_world = _frame(light.center, light.radius * t, light.radius * b, light.normal)
        return {"type": "disk", "to_world": to_world, "emitter": {"type": "area", "radiance": radiance}}
    if isinstance(light, SphereLight):
        return {"type": "sphere", "center": light.center.tolist(), "radius": float(light.radius),
                "emitter": {"type": "area", "radiance": radiance}}
    if isinstance(light, EllipsoidLight):
        return _ellipsoid_mesh(mi, light, radiance)
    raise ValueError(f"light: expected a PointLight, RectLight, DiskLight, SphereLight or EllipsoidLight, got {type(light).__name__}")


def _ellipsoid_mesh(mi, light, radiance: dict):
    """An emitting ``mi.Mesh``: a level-5 icosphere (20480 faces, within 3e-4 of the unit
    sphere) mapped by the axes. Mitsuba's ``sphere`` refuses non-uniform scales."""
    from .scenes import primitives

    vertices, faces = primitives.icosphere(5)
    axes = np.asarray(light.axes, np.float64)
    vertices = light.center + vertices @ axes
    if np.linalg.det(axes) < 0:  # a reflection turns the faces inwards: emit outwards again
        faces = faces[:, ::-1]
    props = mi.Properties()
    props["emitter"] = mi.load_dict({"type": "area", "radiance": radiance})
    mesh = mi.Mesh("light", len(vertices), len(faces), props=props)
    params = mi.traverse(mesh)
    params["vertex_positions"] = type(params["vertex_positions"])(vertices.astype(np.float32).reshape(-1))
    params["faces"] = type(params["faces"])(np.ascontiguousarray(faces, dtype=np.uint32).reshape(-1))
    params.update()
    return mesh


def _scaled_texture(emission: np.ndarray, intensity: float) -> dict:
    # The rectangle's uv is ((a+1)/2, (b+1)/2), which is our (s, t): row i covers t in band i.
    tex = _texture(emission * intensity)
    tex["filter_type"] = "nearest"
    tex["wrap_mode"] = "clamp"
    return tex


def _frame(center, x, y, z):
    """A ``ScalarTransform4f`` whose columns are x, y, z and the translation ``center``.

    Mitsuba transforms normals by the inverse transpose, so local +z becomes a vector
    orthogonal to x and y on the side of ``z`` (``z = normalize(x cross y)`` here): the
    emitting side stays ``normalize(u x v)`` even for non-orthogonal u, v.
    """
    mi = require("mitsuba", extra="evaluation", for_="softshadows.reference")

    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = x, y, z, center
    return mi.ScalarTransform4f(m.tolist())


def _sensor_dict(mi, camera: Camera, spp: int) -> dict:
    to_world = mi.ScalarTransform4f().look_at(origin=camera.eye.tolist(), target=camera.target.tolist(), up=camera.up.tolist())
    return {
        "type": "perspective",
        "fov": float(camera.fov_y),
        "fov_axis": "y",
        "to_world": to_world,
        "film": {"type": "hdrfilm", "width": int(camera.width), "height": int(camera.height), "pixel_format": "rgb",
                 "component_format": "float32", "rfilter": {"type": "box"}},
        "sampler": {"type": "independent", "sample_count": spp},
    }


# ----------------------------------------------------------------------------- visibility


def mitsuba_visibility(scene: Scene, light, receivers, samples, *, epsilon: float | None = None,
                       cache: bool = True, progress: bool = True) -> np.ndarray:
    """Visibility of light samples by Mitsuba's own ray queries (docs/design.md section 3).

    V(p) is the mean over samples y_s of v(p, y_s): 1 when the open segment from
    ``p + epsilon n`` to ``y_s`` hits no opaque surface (alpha-tested on perforated meshes)
    and ``dot(y_s - p, n) > 0``, else 0.

    Parameters
    ----------
    scene : Scene
        Occluders; the light's own geometry is never added.
    light : PointLight, RectLight, DiskLight, SphereLight or EllipsoidLight
        Used for ``light.samples(n)`` when ``samples`` is an int, and for the weights of a
        textured light.
    receivers : GBuffer or Receivers or (points, normals)
        A G-buffer (positions (H, W, 3), normals (H, W, 3), mask (H, W)) or explicit points
        (K, 3) and non-zero normals (K, 3), in world units.
    samples : int or array_like, shape (S, 3)
        World-space light points, or how many to draw with ``light.samples(n)`` (its
        defaults: pattern ``"poisson"``, seed 0).
    epsilon : float, optional
        Origin offset along the unit normal, world units; default ``scene.epsilon``.
    cache : bool
        Read and write the on-disk cache (see the module notes).
    progress : bool
        Show a tqdm progress bar over ray batches.

    Returns
    -------
    ndarray, shape (H, W) or (K,), float32
        In [0, 1]; 0 where the G-buffer mask is False.

    Examples
    --------
    >>> import numpy as np
    >>> import softshadows as ss
    >>> setup = ss.scenes.get("columns", width=16, height=16)
    >>> gb = ss.gbuffer(setup.scene, setup.camera)
    >>> samples = setup.light.samples(16)
    >>> theirs = ss.reference.mitsuba_visibility(setup.scene, setup.light, gb, samples, cache=False, progress=False)
    >>> bool(np.array_equal(theirs, ss.ray_traced(setup.scene, setup.light, gb, samples=samples)))
    True
    """
    _check_scene(scene)
    _check_light(light)
    rx = as_receivers(receivers)
    pts = _light_samples(light, samples)
    eps = scene.epsilon if epsilon is None else v.positive("epsilon", epsilon, allow_zero=True)
    weights = light.weights(pts).astype(np.float64) if getattr(light, "emission", None) is not None else None
    points, normals, mask = _receiver_arrays(rx)
    key = None
    if cache:
        _check_cache_dir()
        key = _cache_key("visibility", scene, light, points, normals, mask, pts, eps, weights)
        hit = _cache_read(key, rx.shape, unit=True)
        if hit is not None:
            return hit
    tracer = _tracer(scene)
    vis = np.zeros(len(mask), np.float32)
    vis[mask] = _visibility(tracer, points, normals, pts, eps, weights, progress)
    vis = vis.reshape(rx.shape)
    if key is not None:
        _cache_write(key, vis)
    return vis


def _light_samples(light, samples) -> np.ndarray:
    if isinstance(samples, (int, np.integer)) and not isinstance(samples, bool):
        return np.asarray(light.samples(v.positive_int("samples", samples)), np.float32)
    return v.light_points("samples", samples)


def _receiver_arrays(rx):
    """The hit receivers' points and unit normals, float64 (K, 3) each, and the hit mask."""
    flat = rx._flat()
    mask = np.array(flat.mask, bool)
    hit = np.flatnonzero(mask)
    points = np.take(flat.points, hit, axis=0).astype(np.float64)
    normals = np.take(flat.normals, hit, axis=0).astype(np.float64)
    if not np.all(np.isfinite(points)):
        raise ValueError("receivers: positions of hit pixels contain NaN or Inf")
    # np.linalg.norm's sum, left to right, column by column: the same bits in a quarter of the time.
    squares = normals * normals
    lengths = np.sqrt((squares[:, 0] + squares[:, 1]) + squares[:, 2])[:, None]
    if not np.all(np.isfinite(lengths) & (lengths > 0)):
        raise ValueError("receivers: normals of hit pixels must be finite and non-zero")
    return points, normals / lengths, mask


def _visibility(tracer, points, normals, samples, eps, weights, progress) -> np.ndarray:
    """Mean visibility of (K,) receivers over (S,) samples, in batches of about RAYS_PER_CALL rays."""
    from tqdm.auto import tqdm

    n_samples = len(samples)
    counted = weights is None and tracer.counts_in_kernel
    # Counting keeps no array per ray: a batch may hold enough receivers for a lane each.
    per_batch = max(1, RAYS_PER_CALL // n_samples, tracer.lanes_per_receiver_min if counted else 1)
    # V is a sum over samples, so they may go in any order: along a curve, a receiver's
    # consecutive rays (Embree's packets) stay close together.
    order = _remembered_order(samples.tobytes(), samples.shape, samples.dtype.str)
    ys = samples[order].astype(np.float64)
    weights = None if weights is None else weights[order]
    out = np.empty(len(points), np.float64)
    with tqdm(total=len(points) * n_samples, unit="ray", unit_scale=True, disable=None if progress else True,
              desc="mitsuba_visibility", leave=False) as bar:
        for k0 in range(0, len(points), per_batch):
            p, n = points[k0:k0 + per_batch], normals[k0:k0 + per_batch]
            if counted:
                out[k0:k0 + len(p)] = tracer.lit_counts(p, n, ys, eps) / n_samples
            else:
                visible = tracer.visible(p, n, ys, eps)
                if weights is None:
                    out[k0:k0 + len(p)] = visible.mean(axis=1)
                else:
                    total = weights.sum()  # zero when every sample sits on black texels: V = 0, as in the core
                    out[k0:k0 + len(p)] = visible @ weights / total if total > 0 else 0.0
            bar.update(len(p) * n_samples)
    return np.clip(out, 0, 1).astype(np.float32)


@functools.lru_cache(maxsize=16)
def _remembered_order(data: bytes, shape: tuple[int, ...], dtype: str) -> np.ndarray:
    """:func:`_coherent_order` of the samples whose bytes (C order, numpy type ``dtype``) are
    ``data``, kept for the next calls with the same samples (read-only): an evaluation traces
    many receiver sets to one sample set, and at 128x128 receivers the order took 2% of the call."""
    order = _coherent_order(np.frombuffer(data, dtype).reshape(shape))
    order.flags.writeable = False
    return order


def _coherent_order(samples: np.ndarray, *, bits: int = 10) -> np.ndarray:
    """The permutation that puts the (S, 3) light samples in Hilbert-curve order over their
    two widest principal axes, on a grid of 2**bits cells a side.

    Neighbours along a Hilbert curve are neighbours on the light (Hilbert 1891, "Ueber die
    stetige Abbildung einer Linie auf ein Flaechenstueck"), so a receiver's consecutive rays,
    which Mitsuba hands to Embree as one packet, start together and end close together. On the
    bunny (64 Poisson samples) Mitsuba's ``ray_test`` kernel takes 0.91-0.94x the time in this
    order (128x128 to 512x512 receivers).
    """
    centered = samples - samples.mean(axis=0)
    axes = np.linalg.eigh(centered.T @ centered)[1][:, 1:]  # eigenvalues ascend
    plane = centered @ axes
    span = np.ptp(plane, axis=0)
    side = 1 << bits
    x, y = (((plane - plane.min(axis=0)) / np.where(span > 0, span, 1)) * (side - 1)).astype(np.int64).T
    distance = np.zeros(len(samples), np.int64)
    half = side // 2
    while half:
        rx, ry = (x & half) > 0, (y & half) > 0
        distance += half * half * ((3 * rx) ^ ry)
        # Rotate the quadrant so that the curve's next level enters and leaves it in order.
        flip = ~ry & rx
        x, y = np.where(flip, side - 1 - x, x), np.where(flip, side - 1 - y, y)
        x, y = np.where(~ry, y, x), np.where(~ry, x, y)
        half //= 2
    return np.argsort(distance, kind="stable")


#: The Mitsuba scenes of every softshadows scene traced so far, per variant: loading one builds
#: Embree's BVH (0.3 s for the 56k-triangle bunny, more than tracing 128x128 receivers' rays),
#: and scenes are immutable, like the core's BVH cached on the scene.
_TRACERS = weakref.WeakKeyDictionary()


def _tracer(scene: Scene) -> _Tracer:
    """The :class:`_Tracer` of ``scene`` for the current variant, loaded once."""
    mi = _mitsuba()
    with _MITSUBA_LOCK:
        per_variant = _TRACERS.setdefault(scene, {})
        if _selected not in per_variant:
            per_variant[_selected] = _Tracer(mi, scene)
        return per_variant[_selected]


class _Tracer:
    """Shadow-segment queries against a softshadows scene, through Mitsuba.

    Opaque meshes go into one Mitsuba scene (``ray_test``), perforated ones into another
    (``ray_intersect`` plus our alpha lookup), so the common case never pays for the march.
    In the vectorized variants the rays are built inside Dr.Jit (:meth:`_clear_rays`), so
    that their set-up fuses into the kernel of Mitsuba's ``ray_test``; without perforated
    meshes the rays of each receiver are counted there too (:meth:`lit_counts`).
    """

    def __init__(self, mi, scene: Scene):
        self.mi = mi
        self.dr = require("drjit", extra="evaluation", for_="softshadows.reference") if _vectorized(mi) else None
        opaque = [i for i, m in enumerate(scene.meshes) if m.alpha is None and len(m.faces)]
        perforated = [i for i, m in enumerate(scene.meshes) if m.alpha is not None and len(m.faces)]
        self.opaque = self._load(scene, opaque)
        self.perforated = self._load(scene, perforated)
        # Alpha textures by the id Mitsuba reports in si.shape, binarized once.
        self.alpha = {}
        if self.perforated is not None:
            for shape in self.perforated.shapes():
                i = int(shape.id().split("_")[1])
                self.alpha[self._shape_id(shape)] = scene.meshes[i].alpha >= 0.5
        #: Whether :meth:`lit_counts` serves: the visibility of every ray is known in the kernel.
        self.counts_in_kernel = self.dr is not None and self.perforated is None
        #: Fewest receivers for which :meth:`lit_counts` gives each its own lane (four blocks of
        #: lanes per thread keep the threads busy to the end).
        self.lanes_per_receiver_min = 4 * _DRJIT_BLOCK * self.dr.thread_count() if self.dr is not None else 0

    def _load(self, scene, indices):
        if not indices:
            return None
        return self.mi.load_dict({"type": "scene", **_mesh_shapes(self.mi, scene, indices, 0.5)})

    def _shape_id(self, shape):
        if self.dr is not None:
            return int(np.asarray(self.dr.reinterpret_array(self.mi.UInt32, self.mi.ShapePtr(shape)))[0])
        return shape.id()

    def lit_counts(self, p, n, ys, eps) -> np.ndarray:
        """Per receiver (points p (k, 3), unit normals n), how many of the samples ys (S, 3) it
        sees; vectorized variants and scenes without perforated meshes only.

        Many receivers get a lane each, which loops over the samples: a receiver is gathered
        once, and no answer per ray is stored (6-10% less kernel time than a lane per ray for
        the bunny at 512x512). Fewer would leave threads idle: then every ray gets its lane.
        """
        mi, dr = self.mi, self.dr
        if len(p) < self.lanes_per_receiver_min:
            return np.asarray(dr.block_sum(mi.UInt32(self._clear_rays(p, n, ys, eps)), len(ys), mode="evaluated"), np.int64)
        point, normal = mi.Vector3d(p.T), mi.Vector3d(n.T)
        origin = point + dr.opaque(mi.Float64, eps) * normal
        targets, n_samples = mi.Float64(ys.ravel()), dr.opaque(mi.UInt32, len(ys))

        def step(s, count):
            front, rays = _shadow_ray(mi, dr, point, normal, origin, dr.gather(mi.Vector3d, targets, s))
            return s + 1, count + mi.UInt32(front & ~self.opaque.ray_test(rays, front))

        zeros = dr.zeros(mi.UInt32, len(p))
        _, count = dr.while_loop((zeros, zeros), lambda s, count: s < n_samples, step)
        return np.asarray(count, np.int64)

    def visible(self, p, n, ys, eps) -> np.ndarray:
        """(k, S) bool: whether sample ``ys[s]`` lies in front of receiver ``p[k]`` (unit normal
        ``n[k]``) and the segment from ``p[k] + eps n[k]`` to it hits no opaque surface."""
        if self.dr is not None:
            clear = np.asarray(self._clear_rays(p, n, ys, eps), bool).reshape(len(p), len(ys))
        else:
            clear = self._scalar_clear_rays(p, n, ys, eps)
        if self.perforated is not None:
            k, s = np.nonzero(clear)
            clear[k, s] = ~self._march((p + eps * n)[k], ys[s])
        return clear

    def _clear_rays(self, p, n, ys, eps):
        """Dr.Jit's (k S,) Bool, ray ``k S + s`` from receiver k to sample s (:func:`_jit_rays`):
        in front of the receiver's tangent plane and not blocked by an opaque mesh."""
        front, rays = _jit_rays(self.mi, self.dr, p, n, ys, eps)
        if self.opaque is None:
            return front
        return front & ~self.opaque.ray_test(rays, front)

    def _scalar_clear_rays(self, p, n, ys, eps) -> np.ndarray:
        """:meth:`_clear_rays` of the scalar variant as a (k, S) array: the rays set up in numpy
        and traced one at a time."""
        to_sample = ys[None, :, :] - p[:, None, :]  # (k, S, 3)
        clear = np.einsum("ksc,kc->ks", to_sample, n) > 0
        if self.opaque is not None:
            mi = self.mi
            k, s = np.nonzero(clear)
            o = (p + eps * n)[k]
            d, maxt = _segment(o, ys[s])
            clear[k, s] = [not self.opaque.ray_test(_ray(mi, mi.Point3f(*o[i]), mi.Vector3f(*d[i]), float(maxt[i])))
                           for i in range(len(o))]
        return clear

    def _march(self, origins, targets) -> np.ndarray:
        """Steps each segment through transparent texels of the perforated meshes."""
        blocked = np.zeros(len(origins), bool)
        alive = np.arange(len(origins))
        o = origins
        growth = np.ones(len(origins))  # step scale, grown while rays keep re-hitting where they left
        stepped = np.zeros(len(origins))  # length of the step that produced each origin
        for _ in range(MAX_ALPHA_STEPS):
            if not len(alive):
                return blocked
            d, maxt = _segment(o, targets[alive])
            hit, t, n, uv, shape = self._intersect(o, d, maxt)
            opaque = np.zeros(len(alive), bool)
            for sid, alpha in self.alpha.items():
                on = hit & (shape == sid)
                opaque[on] = _alpha_lookup(alpha, uv[on])
            blocked[alive[opaque]] = True
            go_on = hit & ~opaque
            growth = _grow_on_rehit(growth[go_on], t[go_on], stepped[go_on])
            alive, o, stepped = alive[go_on], *_step_past(o[go_on], d[go_on], t[go_on], n[go_on], growth)
        if len(alive):
            blocked[alive] = True
            warnings.warn(f"{len(alive)} shadow rays crossed more than {MAX_ALPHA_STEPS} transparent texels and count as blocked",
                          RuntimeWarning, stacklevel=3)
        return blocked

    def _intersect(self, o, d, maxt):
        """(hit, t, geometric normal, uv, shape id) of the first hit of each ray."""
        mi, dr = self.mi, self.dr
        if dr is not None:
            si = self.perforated.ray_intersect(_rays(mi, o, d, maxt), mi.RayFlags.Minimal | mi.RayFlags.UV, False)
            hit = np.asarray(si.is_valid(), bool).reshape(-1)
            shape = np.asarray(dr.reinterpret_array(mi.UInt32, si.shape), np.int64).reshape(-1)
            return (hit, np.asarray(si.t, np.float64).reshape(-1), np.asarray(si.n, np.float64).T,
                    np.asarray(si.uv, np.float64).T, shape)
        hit = np.zeros(len(o), bool)
        t, n, uv = np.zeros(len(o)), np.zeros((len(o), 3)), np.zeros((len(o), 2))
        shape = np.empty(len(o), object)
        for i in range(len(o)):
            si = self.perforated.ray_intersect(_ray(mi, mi.Point3f(*o[i]), mi.Vector3f(*d[i]), float(maxt[i])))
            if si.is_valid():
                hit[i], t[i], n[i], uv[i], shape[i] = True, float(si.t), np.array(si.n), np.array(si.uv), si.shape.id()
        return hit, t, n, uv, shape


def _jit_rays(mi, dr, p, n, ys, eps):
    """The shadow rays from receivers p (k, 3) with unit normals n to samples ys (S, 3), ray
    ``k S + s`` from receiver k to sample s, as Dr.Jit values: whether the sample lies in front
    of the receiver's tangent plane (the ray's active mask) and the ``Ray3f``.

    Each ray gathers its receiver and sample and is set up inside the kernel that traces it, by
    the very IEEE operations, in the same order, of the scalar path (:meth:`_Tracer._scalar_clear_rays`
    and :func:`_segment`, in float64, rounded to float32 at the end): both give the same rays.
    """
    n_samples = len(ys)
    ray = dr.arange(mi.UInt32, len(p) * n_samples)
    k = ray // n_samples
    s = ray - k * n_samples
    point = dr.gather(mi.Vector3d, mi.Float64(p.ravel()), k)
    normal = dr.gather(mi.Vector3d, mi.Float64(n.ravel()), k)
    # Opaque, so that every scene's epsilon reuses one compiled kernel.
    origin = point + dr.opaque(mi.Float64, eps) * normal
    return _shadow_ray(mi, dr, point, normal, origin, dr.gather(mi.Vector3d, mi.Float64(ys.ravel()), s))


def _shadow_ray(mi, dr, point, normal, origin, target):
    """Whether ``target`` lies in front of the tangent plane at ``point`` and the ``Ray3f``
    segment from ``origin`` to it (Dr.Jit float64 vectors in, float32 ray out): the
    arithmetic of :func:`_jit_rays`."""
    front = _dot(target - point, normal) > 0
    d = target - origin
    dist = dr.sqrt(_dot(d, d))
    direction = d / dr.select(dist > 0, dist, 1.0)
    return front, _ray(mi, mi.Point3f(origin), mi.Vector3f(direction), mi.Float(dist * (1 - _SEGMENT_SHRINK)))


def _dot(a, b):
    """``a . b`` of Dr.Jit vectors as numpy's ``einsum`` and ``norm`` sum three products: left to
    right, unfused (Dr.Jit's ``dot`` fuses them into FMAs, which round differently)."""
    return (a.x * b.x + a.y * b.y) + a.z * b.z


def _segment(o, targets):
    """Unit directions and maxt of the open segments o -> targets (stopping just short)."""
    d = targets - o
    dist = np.linalg.norm(d, axis=1)
    safe = np.where(dist > 0, dist, 1.0)
    return d / safe[:, None], dist * (1 - _SEGMENT_SHRINK)


def _rays(mi, o, d, maxt):
    return _ray(mi, mi.Point3f(np.ascontiguousarray(o.T, np.float32)), mi.Vector3f(np.ascontiguousarray(d.T, np.float32)),
                mi.Float(np.ascontiguousarray(maxt, np.float32)))


def _ray(mi, o, d, maxt):
    """The ``mi.Ray3f`` segment from ``o`` to ``o + maxt d``: its three-argument constructor
    would take ``maxt`` for the ray's time and leave the ray infinite."""
    ray = mi.Ray3f(o, d)
    ray.maxt = maxt
    return ray


def _step_past(o, d, t, n, growth):
    """A new origin on the same line just past the hit at ``o + t d`` (d unit), and the step length.

    Stepping along the ray (not along the normal, as Mitsuba's ``spawn_ray`` does) keeps the
    continued ray on the original segment, so later hits land where the segment crosses them:
    a normal offset shifts the ray sideways by ~1e-4 and moved texel lookups near texel edges.

    The step must be short: every surface it jumps over is never alpha-tested, and leaves that
    touch or cross put an opaque texel 1e-4 behind a transparent one. Mitsuba's spawn offset
    ``(1 + max|p|) * RayEpsilon`` (~2.7e-4 at |p| ~ 2) stepped over such texels, so the step
    clears the surface by only ``(1 + max|p|) *`` :data:`_STEP_CLEARANCE`, a few float32 ulps
    (the float32 rounding of the origin and of Mitsuba's t), measured along the normal and
    capped at 20x that length for grazing hits, times ``growth`` (see :func:`_grow_on_rehit`)
    for rays that still land on the surface they left.
    """
    p = o + t[:, None] * d
    clearance = (1 + np.abs(p).max(axis=1, initial=0)) * _STEP_CLEARANCE * growth
    cos = np.abs(np.einsum("ij,ij->i", n, d)) / np.maximum(np.linalg.norm(n, axis=1), 1e-30)
    step = clearance / np.maximum(cos, 0.05)
    return p + step[:, None] * d, step


def _grow_on_rehit(growth, t, stepped):
    """Step scales for rays that just crossed a transparent texel.

    A hit within twice the step that produced the origin may be the surface the ray just left
    (the float32 origin rounded back onto it): each such re-hit quadruples the next step, so a
    ray cannot stall there. A hit farther away is another surface, and the scale resets to 1.
    Every hit is alpha-tested either way; growth only lengthens the jump past a transparent texel.
    """
    return np.where(t < 2 * stepped, growth * 4, 1.0)


def _alpha_lookup(opaque_texels: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """Nearest-texel, repeat-wrapped lookup with our convention (row i covers v in [i/H, (i+1)/H))."""
    h, w = opaque_texels.shape
    frac = uv - np.floor(uv)
    j = np.minimum((frac[:, 0] * w).astype(np.int64), w - 1)
    i = np.minimum((frac[:, 1] * h).astype(np.int64), h - 1)
    return opaque_texels[i, j]


# ----------------------------------------------------------------------------- rendering

_INTEGRATORS = ("auto", "path", "direct", "volpath")


def mitsuba_render(scene: Scene, light, camera: Camera, *, spp: int = 64, integrator: str = "auto",
                   albedo: float = 0.8, intensity: float = 1.0, seed: int = 0, cache: bool = True) -> np.ndarray:
    """Path-traced direct illumination of the scene by Mitsuba 3.

    Parameters
    ----------
    scene : Scene
    light : PointLight, RectLight, DiskLight, SphereLight or EllipsoidLight
        See :func:`mitsuba_scene` for how each becomes a Mitsuba emitter.
    camera : Camera
        Row 0 of the result is the top of the image, as in the G-buffer.
    spp : int
        Samples per pixel.
    integrator : {"auto", "path", "direct", "volpath"}
        ``path`` and ``volpath`` run with max_depth 2 (emission plus direct light); ``direct``
        is Mitsuba's direct integrator (MIS of emitter and BSDF sampling). ``auto`` is
        ``volpath`` when the scene has perforated meshes (the only one whose shadow rays cross
        transparent texels) and ``path`` otherwise.
    albedo : float
        Diffuse reflectance of every surface, in [0, 1].
    intensity : float
        Area-light radiance or point-light intensity (see :func:`mitsuba_scene`).
    seed : int
        Sampler seed; the same seed gives the same image.
    cache : bool
        Read and write the on-disk cache.

    Returns
    -------
    ndarray, shape (H, W, 3), float32
        Linear RGB radiance (W m^-2 sr^-1 for radiance 1 lights); comparable with
        ``shading.direct(...)`` at the same ``albedo`` and ``intensity`` (scale 1).

    Examples
    --------
    >>> import softshadows as ss
    >>> setup = ss.scenes.get("columns", width=16, height=16)
    >>> image = ss.reference.mitsuba_render(setup.scene, setup.light, setup.camera, spp=4, cache=False)
    >>> image.shape, image.dtype, bool(image.min() >= 0)
    ((16, 16, 3), dtype('float32'), True)
    """
    _check_scene(scene)
    camera = _check_camera(camera)
    spp = v.positive_int("spp", spp)
    if integrator not in _INTEGRATORS:
        raise ValueError(f"integrator: expected one of {_INTEGRATORS}, got {integrator!r}")
    seed = v.nonneg_int("seed", seed, maximum=2**32 - 1)  # Mitsuba's sampler seed is a uint32
    albedo, intensity = _albedo(albedo), v.positive("intensity", intensity)
    _check_light(light)
    if integrator == "auto":
        integrator = "volpath" if any(m.alpha is not None for m in scene.meshes) else "path"
    key = None
    if cache:
        _check_cache_dir()
        key = _cache_key("render", scene, light, _camera_array(camera), spp, integrator, albedo, intensity, int(seed))
        hit = _cache_read(key, (camera.height, camera.width, 3))
        if hit is not None:
            return hit
    mi = _mitsuba()
    d = mitsuba_scene(scene, light, camera, albedo=albedo, intensity=intensity, spp=spp)
    d["integrator"] = {"type": "direct"} if integrator == "direct" else {"type": integrator, "max_depth": 2}
    image = np.asarray(mi.render(mi.load_dict(d), spp=spp, seed=int(seed)), np.float32)[..., :3]
    image = np.ascontiguousarray(image)
    if key is not None:
        _cache_write(key, image)
    return image


def mitsuba_environment_render(scene: Scene, env, camera: Camera, *, spp: int = 256, albedo: float = 0.8,
                               seed: int = 0, cache: bool = True) -> np.ndarray:
    """Path-traced direct illumination of the scene under an environment map, by Mitsuba 3.

    Parameters
    ----------
    scene : Scene
    env : array_like, shape (H, W, 3)
        Lat-long radiance in Mitsuba's ``envmap`` convention (the one of
        :mod:`softshadows.envmap`), used as is (``scale`` 1, no rotation).
    camera : Camera
    spp : int
        Samples per pixel.
    albedo : float
        Diffuse reflectance of every surface.
    seed : int
    cache : bool
        Read and write the on-disk cache.

    Returns
    -------
    ndarray, shape (H, W, 3), float32
        Linear RGB, comparable with :func:`softshadows.environment` at the same ``albedo``.

    Examples
    --------
    >>> import softshadows as ss
    >>> setup = ss.scenes.get("columns", width=16, height=16)
    >>> image = ss.reference.mitsuba_environment_render(setup.scene, ss.envmap.sky(16), setup.camera, spp=4,
    ...                                                 cache=False)
    >>> image.shape, bool(image.max() > 0)
    ((16, 16, 3), True)
    """
    _check_scene(scene)
    camera = _check_camera(camera)
    env = v.array("env", env, np.float32, (None, None, 3))
    if env.size == 0:
        raise ValueError(f"env: expected a non-empty lat-long map, got shape {env.shape}")
    if env.min() < 0:
        raise ValueError("env: radiance must be >= 0")
    spp, seed, albedo = v.positive_int("spp", spp), v.nonneg_int("seed", seed, maximum=2**32 - 1), _albedo(albedo)
    integrator = "volpath" if any(m.alpha is not None for m in scene.meshes) else "path"
    key = None
    if cache:
        _check_cache_dir()
        key = _cache_key("envrender", scene, None, env, _camera_array(camera), spp, integrator, albedo, int(seed))
        hit = _cache_read(key, (camera.height, camera.width, 3))
        if hit is not None:
            return hit
    mi = _mitsuba()
    d = {"type": "scene", **_mesh_shapes(mi, scene, range(len(scene.meshes)), albedo)}
    d["environment"] = {"type": "envmap", "bitmap": mi.Bitmap(np.ascontiguousarray(env))}
    d["sensor"] = _sensor_dict(mi, camera, spp)
    d["integrator"] = {"type": integrator, "max_depth": 2}
    image = np.ascontiguousarray(np.asarray(mi.render(mi.load_dict(d), spp=spp, seed=int(seed)), np.float32)[..., :3])
    if key is not None:
        _cache_write(key, image)
    return image


# ----------------------------------------------------------------------------- cache


def cache_dir() -> Path:
    """The reference cache directory: ``$SOFTSHADOWS_CACHE`` or ``~/.cache/softshadows/reference``.

    Examples
    --------
    >>> import os
    >>> from softshadows import reference
    >>> saved = dict(os.environ)
    >>> os.environ["SOFTSHADOWS_CACHE"] = "/tmp/softshadows-cache"
    >>> str(reference.cache_dir())
    '/tmp/softshadows-cache'
    >>> del os.environ["SOFTSHADOWS_CACHE"]
    >>> reference.cache_dir().parts[-3:]
    ('.cache', 'softshadows', 'reference')
    >>> os.environ.update(saved)
    """
    return Path(os.environ.get("SOFTSHADOWS_CACHE") or Path.home() / ".cache" / "softshadows" / "reference")


def _cache_key(kind: str, scene: Scene, light, *parts) -> str:
    mi = _mitsuba()
    h = hashlib.sha256()

    def add(x):
        if isinstance(x, np.ndarray):
            h.update(f"a{x.dtype.str}{x.shape}".encode())
            h.update(np.ascontiguousarray(x).tobytes())
        elif x is None or isinstance(x, (bool, int, float, str, np.integer, np.floating)):
            h.update(f"s{type(x).__name__}:{x!r};".encode())
        else:
            raise TypeError(f"cannot hash {type(x).__name__}")

    for x in (kind, CACHE_VERSION, mi.__version__, variant()):
        add(x)
    for m in scene.meshes:
        for x in (m.vertices, m.faces, m.uvs, m.alpha):
            add(x)
    add(type(light).__name__)
    # Every attribute, by name (less the cached core light): a light type's own (an ellipsoid's axes)
    # can never be left out.
    for attr, value in sorted(light.__getstate__().items() if light is not None else ()):
        add(attr)
        add(value)
    for x in parts:
        add(np.asarray(x) if isinstance(x, (list, tuple)) else x)
    return f"{kind}-{h.hexdigest()}"


def _cache_path(key: str) -> Path:
    return cache_dir() / f"{key}.npz"


def _check_cache_dir() -> None:
    """Makes sure the cache folder exists and can be written, before a reference is computed."""
    folder = cache_dir()
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OSError(f"reference cache: cannot create {folder} ({exc.strerror or exc}); set SOFTSHADOWS_CACHE to a "
                      "writable folder or pass cache=False") from None
    if not os.access(folder, os.W_OK | os.X_OK):
        raise OSError(f"reference cache: {folder} is not writable; set SOFTSHADOWS_CACHE to a writable folder or "
                      "pass cache=False")


def _cache_read(key: str, shape: tuple, *, unit: bool = False):
    """The cached float32 array of ``key`` and ``shape`` (values in [0, 1] with ``unit``, else
    finite and >= 0), or None: missing, unreadable (a crash, a 0-byte file) or not what the key
    promises (a warning says why, and the caller recomputes and overwrites it)."""
    path = _cache_path(key)
    if not path.exists():
        return None
    try:
        with np.load(path, allow_pickle=False) as entry:
            stored, value = str(entry["key"]), entry["value"]
    except Exception as exc:  # noqa: BLE001  np.load raises EOFError, ValueError, BadZipFile, KeyError, OSError
        problem = f"unreadable ({type(exc).__name__})"
    else:
        low, high = (0.0, 1.0) if unit else (0.0, np.inf)
        finite = value.dtype == np.float32 and bool(np.isfinite(value).all())
        problem = ("it holds another key" if stored != key else
                   f"shape {value.shape}, expected {tuple(shape)}" if value.shape != tuple(shape) else
                   f"dtype {value.dtype}, expected float32" if value.dtype != np.float32 else
                   "non-finite values" if not finite else
                   f"values outside [{low:g}, {high:g}]" if value.size and (value.min() < low or value.max() > high) else None)
        if problem is None:
            return value
    warnings.warn(f"ignoring the reference cache entry {path}: {problem}; recomputing it", RuntimeWarning, stacklevel=3)
    return None


def _cache_write(key: str, value: np.ndarray) -> None:
    path = _cache_path(key)
    path.parent.mkdir(parents=True, exist_ok=True)
    # A name of its own per process, thread and call: concurrent writers of one entry never share
    # a temporary file, and the last rename wins with a whole file.
    tmp = path.with_name(f"{path.stem}.{os.getpid()}.{threading.get_ident()}.{uuid.uuid4().hex}.tmp.npz")
    try:
        with open(tmp, "wb") as f:
            np.savez(f, key=np.array(key), value=value)
        os.replace(tmp, path)  # atomic: readers never see a partial file
    finally:
        tmp.unlink(missing_ok=True)


# ----------------------------------------------------------------------------- validation


def _check_scene(scene) -> None:
    v.instance("scene", scene, Scene, "a softshadows.Scene")


def _check_light(light) -> None:
    from .lights import _Light

    v.instance("light", light, _Light, "a PointLight, RectLight, DiskLight, SphereLight or EllipsoidLight")


def _check_camera(camera) -> Camera:
    return v.instance("camera", camera, Camera, "a softshadows.Camera")


def _albedo(albedo) -> float:
    a = v.positive("albedo", albedo, allow_zero=True)
    if a > 1:
        raise ValueError(f"albedo: must be in [0, 1], got {a}")
    return a


def _camera_array(camera: Camera) -> np.ndarray:
    return np.concatenate([camera.eye, camera.target, camera.up, [camera.fov_y, camera.width, camera.height]]).astype(np.float64)

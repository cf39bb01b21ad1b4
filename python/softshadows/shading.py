"""Factored direct lighting: unshadowed irradiance times visibility (docs/design.md section 3).

``direct`` shades Lambertian receivers as ``albedo / pi * E(p) * V(p)``, where ``E`` is the
irradiance the light would deliver without occluders and ``V`` the visibility a method computed.
It is the counterpart of :func:`softshadows.reference.mitsuba_render` for the shaded comparison.

Units and conventions
---------------------
* Area lights (rect, disk, sphere) have uniform radiance ``L = intensity`` (W m^-2 sr^-1), times
  the emission texture of a textured ``RectLight``; their power therefore grows with their area.
  A point light has radiant intensity ``I = intensity`` (W sr^-1).
* Mitsuba's ``area`` emitter ``radiance`` and ``point`` emitter ``intensity`` and its ``diffuse``
  ``reflectance`` use the same quantities, so ``direct(...)`` and ``mitsuba_render(...)`` agree
  at scale 1 (checked in ``tests/test_shading.py`` on an unoccluded plane).
* Lights are one-sided: planar lights emit toward ``normalize(u x v)`` (rect) or ``normal``
  (disk); a receiver on or behind the light's plane gets E = 0.

Irradiance formulas
-------------------
* **Rect**: Lambert's formula for a uniform polygon, ``E = L/2 sum_i theta_i n . g_i`` with
  ``g_i = normalize(v_i x v_{i+1})`` and ``theta_i`` the angle between the vertices ``v_i``
  (relative to the receiver), after clipping the polygon to the receiver's upper hemisphere:
  each edge is clipped to the tangent plane and the part of the horizon between the exit and
  entry points closes the polygon. Exact. A textured rect sums the formula over its texels
  (exact for the nearest-texel texture).
* **Disk**: the rect formula on an inscribed regular polygon of :data:`DISK_EDGES` edges whose
  circumradius is scaled so its area equals the disk's. Against the exact on-axis value
  ``pi L r^2 / (r^2 + h^2)`` the relative error is below 1e-5 (``tests/test_shading.py``).
  Textured disks are not supported (ValueError).
* **Sphere**: the irradiance from a sphere of uniform radiance seen from outside (a spherical
  cap of half-angle ``sigma``, ``sin sigma = r/d``): ``pi L sin^2 sigma cos theta`` when the cap
  is fully above the horizon, and Snyder's exact horizon-clipped expression otherwise (as in
  Lagarde & de Rousiers, "Moving Frostbite to PBR", 2014). Our ``SphereLight`` emits from its
  volume; shading treats it as a sphere of uniform radiance (what a uniformly emitting,
  optically thick ball looks like, and what Mitsuba's emitting ``sphere`` renders). A receiver
  inside the sphere gets ``pi L``.
* **Ellipsoid**: seen from outside, an ellipsoid's silhouette is a planar ellipse (the image of
  the unit sphere's silhouette circle under the axes, the virtual scaling of Sintorn et al. 2008): the rect
  formula on an area-matched :data:`DISK_EDGES`-gon of that ellipse, as for a disk. ``pi L``
  inside.
* **Point**: ``I max(0, cos theta) / r^2``.
"""

from __future__ import annotations

import numpy as np

from . import _core
from . import _validate as v
from .camera import as_receivers
from .lights import DiskLight, EllipsoidLight, PointLight, RectLight, SphereLight

__all__ = ["direct", "unshadowed_irradiance", "DISK_EDGES", "BEND_SHARPNESS"]

#: Edges of the regular polygon standing in for a disk light.
DISK_EDGES = 256
#: The sharpness c of the bent-normal blend alpha = min(1, max(c I_bend, 0)) (Sintorn et al.
#: 2008, section 4.3: "c := 3 works well").
BEND_SHARPNESS = 3.0
#: Receivers per vectorized batch (bounds temporaries to a few hundred MB for the disk polygon).
_BATCH = 8192


def direct(gbuffer, light, visibility, albedo=0.8, *, intensity: float = 1.0, bent_normals: bool = False,
           scene=None) -> np.ndarray:
    """Outgoing radiance of Lambertian receivers under ``light``, factored as ``albedo/pi * E * V``.

    With ``bent_normals=True`` the shading follows the smooth coherent model of
    Sintorn et al. 2008, Sample Based Visibility for Soft Shadows, section 4.3:
    each vertex gets the smallest ``max(0, n_f . l)`` over its adjacent faces ``f`` (``l`` from the
    vertex towards the light's center), and ``I_bend`` interpolates it over the receiver's face
    as ``I`` interpolates the face's own cosine; the shading is ``alpha I + (1 - alpha) I_bend``
    with ``alpha = min(1, max(c I_bend, 0))``, ``c =`` :data:`BEND_SHARPNESS` = 3, the paper's,
    applied here as the factor ``(alpha I + (1 - alpha) I_bend) / I`` on ``E``. Light
    back-facing triangles and the triangles touching them fade to black continuously, so light
    does not leak past the shadow terminator; faces whose darkest neighbour still sees the light
    at a cosine of 1/3 or more, and a flat mesh (all neighbours coplanar), are unchanged.

    Parameters
    ----------
    gbuffer : GBuffer or Receivers or (points, normals)
        Receivers: positions (H, W, 3) or (K, 3) with normals; G-buffer normals face the camera.
    light : PointLight, RectLight, DiskLight, SphereLight or EllipsoidLight
    visibility : array_like, shape (H, W) or (K,)
        Visibility in [0, 1] from any method, in the receivers' shape.
    albedo : float or array_like of shape (3,)
        Diffuse reflectance in [0, 1]; an RGB triple gives an RGB result.
    intensity : float
        Area-light radiance (W m^-2 sr^-1) or point-light intensity (W sr^-1).
    bent_normals : bool
        Use the smooth coherent shading above; needs a GBuffer (its face ids) and ``scene``.
    scene : Scene, optional
        The scene the G-buffer was made from (for ``bent_normals``).

    Returns
    -------
    ndarray, shape (H, W) or (K,) for a scalar albedo, with a trailing 3 for an RGB one, float32
        Radiance in W m^-2 sr^-1; 0 where the G-buffer mask is False. Often far below 1: write
        it for viewing with ``softshadows.io.write_png(path, radiance, exposure="auto")``.

    Examples
    --------
    A receiver 2 units below a point light of intensity 4 gets E = 4 / 2^2 = 1 W m^-2; half
    visible, with albedo 0.8, it sends 0.8 / pi x 1 x 0.5:

    >>> from softshadows import PointLight, shading
    >>> receiver = ([[0, 0, 0]], [[0, 0, 1]])                 # (points, normals)
    >>> shading.direct(receiver, PointLight((0, 0, 2)), [0.5], intensity=4.0).round(4)
    array([0.1273], dtype=float32)
    >>> shading.direct(receiver, PointLight((0, 0, 2)), [0.5], (0.8, 0.4, 0.2), intensity=4.0).round(4)
    array([[0.1273, 0.0637, 0.0318]], dtype=float32)
    """
    rx = as_receivers(gbuffer)
    vis = v.array("visibility", visibility, np.float64, rx.shape)
    if vis.size and (vis.min() < 0 or vis.max() > 1):
        raise ValueError(f"visibility: expected values in [0, 1], got [{vis.min()}, {vis.max()}]")
    try:
        alb = np.asarray(albedo, np.float64)
    except (TypeError, ValueError):
        alb = np.full(2, np.nan)  # refused below with the argument's name
    if alb.shape not in ((), (3,)) or not np.all(np.isfinite(alb)) or alb.min() < 0 or alb.max() > 1:
        raise ValueError(f"albedo: expected a number or an RGB triple in [0, 1], got {albedo!r}")
    points, normals, mask = _float64_receivers(rx)
    e = np.zeros(len(points))
    e[mask] = unshadowed_irradiance(points[mask], normals[mask], light, intensity=intensity)
    if bent_normals:
        e *= _bent_ratio(gbuffer, scene, light, points, normals, mask)
    radiance = (e.reshape(rx.shape) * vis / np.pi)[..., None] * alb if alb.ndim else e.reshape(rx.shape) * vis * alb / np.pi
    with np.errstate(over="ignore"):
        out = radiance.astype(np.float32)
    if not np.all(np.isfinite(out)):
        # A huge intensity, or a point light almost touching a receiver (E = I / r^2).
        raise ValueError(
            f"intensity: the radiance of {int(np.sum(~np.isfinite(out)))} receivers overflows float32 "
            f"(max {np.nanmax(radiance):.3g}); lower the intensity or move the light away from the receivers"
        )
    return out


def _bent_ratio(gbuffer, scene, light, points, normals, mask) -> np.ndarray:
    """Per receiver, the barycentric blend over its face's corners of the smallest adjacent-face
    cosine at the corner over the face's own cosine there (Sintorn et al. 2008, section 4.3)."""
    from .camera import GBuffer
    from .scene import Scene

    if not isinstance(gbuffer, GBuffer):
        raise ValueError("gbuffer: bent_normals needs a GBuffer (its face ids), not explicit receivers")
    v.instance("scene", scene, Scene, "the softshadows.Scene the G-buffer was made from")
    verts = np.concatenate([m.vertices for m in scene.meshes]).astype(np.float64)
    offsets = np.cumsum([0] + [len(m.vertices) for m in scene.meshes[:-1]])
    faces = np.concatenate([m.faces.astype(np.int64) + o for m, o in zip(scene.meshes, offsets)])
    if gbuffer.face_ids.size and int(gbuffer.face_ids.max()) >= len(faces):
        raise ValueError(
            f"scene: the G-buffer hits face {int(gbuffer.face_ids.max())} but the scene has {len(faces)} faces; "
            "pass the scene the G-buffer was made from"
        )
    center = np.asarray(light.center if hasattr(light, "center") else light.position, np.float64)
    tri = verts[faces]
    face_n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    face_n /= np.maximum(np.linalg.norm(face_n, axis=1, keepdims=True), 1e-300)
    to_light = center - verts
    to_light /= np.maximum(np.linalg.norm(to_light, axis=1, keepdims=True), 1e-300)
    vertex_min = np.ones(len(verts))
    for k in range(3):  # every face lowers the value of its three vertices
        cos = np.maximum(np.einsum("ij,ij->i", face_n, to_light[faces[:, k]]), 0.0)
        np.minimum.at(vertex_min, faces[:, k], cos)
    ids = gbuffer.face_ids.reshape(-1)
    ratio = np.zeros(len(points))
    hit = mask & (ids >= 0)
    f = faces[ids[hit]]
    a, b, c = verts[f[:, 0]], verts[f[:, 1]], verts[f[:, 2]]
    p = points[hit].astype(np.float64)
    n2 = np.einsum("ij,ij->i", *(2 * [np.cross(b - a, c - a)]))
    nrm = np.cross(b - a, c - a)
    b1 = np.einsum("ij,ij->i", np.cross(p - a, c - a), nrm) / n2
    b2 = np.einsum("ij,ij->i", np.cross(b - a, p - a), nrm) / n2
    weights = (1 - b1 - b2, b1, b2)
    own_n = face_n[ids[hit]]
    # Section 4.3: I, the face's own (Gouraud-interpolated) cosine; I_bend, the interpolated
    # smallest cosine of the corners' adjacent faces (<= I); the blend alpha I + (1 - alpha) I_bend
    # with alpha = min(1, max(c I_bend, 0)) is I where I_bend >= 1/c and falls to I_bend, 0 on the
    # light back-facing side, towards the terminator. E is scaled by the blend over I.
    own = sum(w * np.maximum(np.einsum("ij,ij->i", own_n, to_light[f[:, k]]), 0.0) for k, w in enumerate(weights))
    bend = sum(w * vertex_min[f[:, k]] for k, w in enumerate(weights))
    alpha = np.minimum(1.0, np.maximum(BEND_SHARPNESS * bend, 0.0))
    blended = alpha * own + (1 - alpha) * bend
    ratio[hit] = np.where(own > 0, blended / np.maximum(own, 1e-300), 0.0)
    return ratio


def unshadowed_irradiance(points, normals, light, *, intensity: float = 1.0) -> np.ndarray:
    """Irradiance the light delivers to each receiver when nothing occludes it.

    Parameters
    ----------
    points : array_like, shape (..., 3)
        Receiver positions, world units.
    normals : array_like, shape (..., 3)
        Receiver normals (normalized here; must be non-zero).
    light : PointLight, RectLight, DiskLight, SphereLight or EllipsoidLight
    intensity : float
        Area-light radiance (W m^-2 sr^-1) or point-light intensity (W sr^-1).

    Returns
    -------
    ndarray, shape (...), float64
        Irradiance in W m^-2 (>= 0).

    Examples
    --------
    >>> from softshadows import PointLight, RectLight, shading
    >>> shading.unshadowed_irradiance([[0, 0, 0]], [[0, 0, 1]], PointLight((0, 0, 2)), intensity=4.0)
    array([1.])
    >>> e = shading.unshadowed_irradiance([[0, 0, 0]], [[0, 0, 1]], RectLight((0, 0, 2), (1, 0, 0), (0, -1, 0)))
    >>> e.round(4)                                            # a 2 x 2 square light of unit radiance
    array([0.7523])
    """
    p = _float_array("points", points)
    if p.ndim < 1 or p.shape[-1] != 3:
        raise ValueError(f"points: expected shape (..., 3), got {p.shape}")
    n = _float_array("normals", normals)
    if n.shape != p.shape:
        raise ValueError(f"normals: expected shape {p.shape} like points, got {n.shape}")
    if not (np.all(np.isfinite(p)) and np.all(np.isfinite(n))):
        raise ValueError("points: points and normals must be finite")
    length = np.linalg.norm(n, axis=-1, keepdims=True)
    if np.any(length == 0):
        raise ValueError("normals: every normal must be non-zero")
    intensity = v.positive("intensity", intensity, allow_zero=True)
    shape = p.shape[:-1]
    p, n = p.reshape(-1, 3), (n / length).reshape(-1, 3)
    e = np.empty(len(p))
    for k in range(0, len(p), _BATCH):
        e[k:k + _BATCH] = _irradiance(p[k:k + _BATCH], n[k:k + _BATCH], light)
    return (intensity * e).reshape(shape)


def _float_array(name: str, value) -> np.ndarray:
    """A float64 array, or a ValueError naming the argument (strings, ragged lists)."""
    try:
        return np.asarray(value, np.float64)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name}: expected an array of numbers, got {type(value).__name__} ({exc})") from None


def _irradiance(p, n, light) -> np.ndarray:
    """Irradiance for unit radiance (or unit intensity), receivers (K, 3) with unit normals."""
    if isinstance(light, PointLight):
        to_light = light.position.astype(np.float64) - p
        r2 = np.einsum("ki,ki->k", to_light, to_light)
        cos = np.einsum("ki,ki->k", to_light, n) / np.sqrt(np.maximum(r2, 1e-300))
        return np.where(r2 > 0, np.maximum(cos, 0) / np.maximum(r2, 1e-300), 0.0)
    if isinstance(light, RectLight):
        c, u, w = (np.asarray(x, np.float64) for x in (light.center, light.u, light.v))
        if light.emission is None:
            return _one_sided(p, c, light.normal, _polygon_irradiance(p, n, _rect_corners(c, u, w)[None]))
        return _one_sided(p, c, light.normal, _textured_rect(p, n, c, u, w, light.emission))
    if isinstance(light, DiskLight):
        if light.emission is not None:
            raise _core.UnsupportedSetup("light: textured DiskLights are not supported by shading (only RectLight emission)")
        return _one_sided(p, light.center, light.normal, _polygon_irradiance(p, n, _disk_polygon(light)[None]))
    if isinstance(light, SphereLight):
        return _sphere_irradiance(p, n, np.asarray(light.center, np.float64), float(light.radius))
    if isinstance(light, EllipsoidLight):
        return _ellipsoid_irradiance(p, n, np.asarray(light.center, np.float64), np.asarray(light.axes, np.float64))
    raise ValueError(
        f"light: expected a PointLight, RectLight, DiskLight, SphereLight or EllipsoidLight, got {type(light).__name__}"
    )


def _one_sided(p, center, normal, e):
    """Zero for receivers on or behind the plane of a one-sided planar light."""
    front = (p - np.asarray(center, np.float64)) @ np.asarray(normal, np.float64) > 0
    return np.where(front, e, 0.0)


def _rect_corners(c, u, w):
    """Corners ordered counter-clockwise about u x v (the emitting side)."""
    return np.stack([c - u - w, c + u - w, c + u + w, c - u + w])


def _textured_rect(p, n, c, u, w, emission):
    """Sum of the polygon formula over the texels (row i: b in band i of [-1, 1])."""
    h, wd = emission.shape
    a = np.linspace(-1, 1, wd + 1)
    b = np.linspace(-1, 1, h + 1)
    total = np.zeros(len(p))
    for i in range(h):
        for j in range(wd):
            if emission[i, j] == 0:
                continue
            cc = c + 0.5 * (a[j] + a[j + 1]) * u + 0.5 * (b[i] + b[i + 1]) * w
            corners = _rect_corners(cc, 0.5 * (a[j + 1] - a[j]) * u, 0.5 * (b[i + 1] - b[i]) * w)
            total += float(emission[i, j]) * _polygon_irradiance(p, n, corners[None])
    return total


def _disk_polygon(light) -> np.ndarray:
    """A regular DISK_EDGES-gon with the disk's area, counter-clockwise about the disk normal."""
    t, b = light.tangent_frame
    k = DISK_EDGES
    radius = light.radius * np.sqrt(2 * np.pi / (k * np.sin(2 * np.pi / k)))
    phi = 2 * np.pi * np.arange(k) / k
    return np.asarray(light.center, np.float64) + radius * (np.cos(phi)[:, None] * t + np.sin(phi)[:, None] * b)


def _polygon_irradiance(p, n, polygon) -> np.ndarray:
    """Lambert's formula for a unit-radiance convex polygon clipped to each receiver's hemisphere.

    Parameters
    ----------
    p, n : ndarray, shape (K, 3)
        Receivers and unit normals.
    polygon : ndarray, shape (1, N, 3)
        Vertices counter-clockwise about the emitting side's normal; receivers must lie on
        that side (the caller zeroes the others).
    """
    a = polygon - p[:, None, :]                                # (K, N, 3)
    b = np.roll(a, -1, axis=1)
    ha = np.einsum("kni,ki->kn", a, n)                        # height above the tangent plane
    hb = np.roll(ha, -1, axis=1)
    ina, inb = ha > 0, hb > 0
    # Where an edge crosses the tangent plane, the crossing point (t = ha / (ha - hb)).
    denom = np.where(ina != inb, ha - hb, 1.0)
    x = a + (ha / denom)[..., None] * (b - a)
    a_c = np.where(ina[..., None], a, x)
    b_c = np.where(inb[..., None], b, x)
    total = np.where(ina | inb, _edge_term(a_c, b_c, n[:, None, :]), 0.0).sum(axis=1)
    # The horizon closes the clipped polygon: from where it leaves the hemisphere to where it re-enters.
    leaving, entering = ina & ~inb, ~ina & inb
    rows = np.arange(len(p))
    exit_pt = x[rows, np.argmax(leaving, axis=1)]
    entry_pt = x[rows, np.argmax(entering, axis=1)]
    total += np.where(leaving.any(axis=1), _edge_term(exit_pt, entry_pt, n), 0.0)
    # Counter-clockwise about the emitting normal is clockwise as seen from the lit side.
    return np.maximum(-0.5 * total, 0.0)


def _edge_term(a, b, n):
    """theta(a, b) * n . normalize(a x b), 0 for degenerate edges."""
    cross = np.cross(a, b)
    norm = np.linalg.norm(cross, axis=-1)
    theta = np.arctan2(norm, np.einsum("...i,...i->...", a, b))
    return np.where(norm > 0, theta * np.einsum("...i,...i->...", cross, n) / np.where(norm > 0, norm, 1.0), 0.0)


def _sphere_irradiance(p, n, center, radius):
    """Irradiance from a unit-radiance sphere, with exact horizon clipping (Snyder 1996)."""
    to_c = center - p
    d = np.linalg.norm(to_c, axis=1)
    inside = d <= radius
    d_safe = np.where(inside, 1.0, d)
    cos_t = np.clip(np.einsum("ki,ki->k", to_c, n) / d_safe, -1, 1)
    sin2_s = np.where(inside, 1.0, (radius / d_safe) ** 2)
    full = np.pi * sin2_s * np.maximum(cos_t, 0)
    # Partially below the horizon (cos^2 theta <= sin^2 sigma):
    sin_t = np.sqrt(np.maximum(1 - cos_t**2, 1e-300))
    x = np.sqrt(np.maximum(1 / sin2_s - 1, 0))               # cot sigma
    y = np.clip(-x * cos_t / sin_t, -1, 1)
    s = sin_t * np.sqrt(1 - y**2)
    partial = (cos_t * np.arccos(y) - x * s) * sin2_s + np.arctan2(s, x)
    e = np.where(cos_t**2 > sin2_s, full, partial)
    return np.where(inside, np.pi, np.maximum(e, 0.0))


def _ellipsoid_irradiance(p, n, center, axes, chunk: int = 2048):
    """Irradiance from a unit-radiance ellipsoid (semi-axes as rows of ``axes``) through the
    polygon of its silhouette ellipse, ``chunk`` receivers at a time (K x DISK_EDGES vertices)."""
    a = axes.T                                                 # columns: the semi-axes
    q = (p - center) @ np.linalg.inv(a).T                      # receivers where the light is the unit ball
    d2 = np.einsum("ki,ki->k", q, q)
    out = np.full(len(p), np.pi)                               # inside the light: pi L
    # Only receivers outside have a silhouette; at the centre (q = 0) its frame would be 0 / 0.
    outside = np.flatnonzero(d2 > 1)
    p, n, q = p[outside], n[outside], q[outside]
    d = np.sqrt(d2[outside])
    u = q / d[:, None]
    # The unit sphere's silhouette from q: a circle about u / |q| of radius sqrt(1 - 1/|q|^2),
    # counter-clockwise about u (the side facing the receiver); area-matched as the disk's.
    helper = np.where(np.abs(u[:, :1]) < 0.9, [[1.0, 0, 0]], [[0, 1.0, 0]])
    t = np.cross(u, helper)
    t /= np.linalg.norm(t, axis=1, keepdims=True)
    b = np.cross(u, t)
    k = DISK_EDGES
    radius = np.sqrt(1 - 1 / d**2) * np.sqrt(2 * np.pi / (k * np.sin(2 * np.pi / k)))
    phi = 2 * np.pi * np.arange(k) / k
    for s in range(0, len(p), chunk):
        r = slice(s, s + chunk)
        ring = np.cos(phi)[None, :, None] * t[r, None] + np.sin(phi)[None, :, None] * b[r, None]
        circle = (u[r] / d[r, None])[:, None] + radius[r, None, None] * ring
        polygon = center + circle @ a.T
        if np.linalg.det(a) < 0:                               # a reflection reverses the winding
            polygon = polygon[:, ::-1]
        out[outside[r]] = _polygon_irradiance(p[r], n[r], polygon)
    return out


def _float64_receivers(rx):
    """Flat float64 points (N, 3), normals (N, 3) and the bool mask (N,) of a GBuffer or Receivers."""
    flat = rx._flat()
    return np.asarray(flat.points, np.float64), np.asarray(flat.normals, np.float64), np.asarray(flat.mask, bool)

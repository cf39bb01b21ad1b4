"""Staging: the ground, the light and the camera framed around occluders, for the built-in
scenes (:func:`assemble`) and for any scene or mesh file (:func:`stage`)."""

from __future__ import annotations

import dataclasses
import os

import numpy as np

from .. import _validate as _v
from ..camera import Camera
from ..lights import DiskLight, EllipsoidLight, PointLight, RectLight, SphereLight, _facing_axes
from ..scene import Mesh, Scene
from . import _checks, primitives
from .setup import LIGHT_KINDS, Setup

__all__ = ["stage"]


def stage(
    scene,
    *,
    light: str = "rect",
    light_size: float | None = None,
    light_position=None,
    light_distance: float | None = None,
    ground: bool = True,
    camera: Camera | None = None,
    width: int = 256,
    height: int = 256,
    fov_y: float = 40.0,
    name: str | None = None,
) -> Setup:
    """Frames a light and a camera around any scene, as the built-in scenes are framed.

    The light faces the scene's centre from above and to the -x side (as :func:`load_model`'s),
    and the camera is moved back until the scene and its shadows, penumbrae included, fill the
    central 90% of the image. By default a ground square is added under the scene's lowest
    point, wide enough for the shadows. y is up.

    Parameters
    ----------
    scene : Scene or str or os.PathLike
        The scene, or a mesh file that :func:`softshadows.load` reads; a glTF file's own camera,
        if it has one, is kept (with its vertical field of view, at ``width`` x ``height``).
    light : {"rect", "disk", "sphere", "ellipsoid", "point"}
    light_size : float, optional
        As in the module docstring; default the scene's largest extent.
    light_position : array_like, shape (3,), optional
        The light's centre, anywhere (among the geometry too: a lamp in a room); default
        ``light_distance`` from the scene's centre.
    light_distance : float, optional
        Default three times the scene's largest extent.
    ground : bool
        Add the ground square (``Setup.ground``); False for a scene with a floor of its own.
    camera : Camera, optional
        Your own camera (inside a room, say), instead of the framed one and the file's.
    width, height, fov_y
        The framed camera's image size and vertical field of view in degrees.
    name : str, optional
        The set-up's name; default the file's stem, or ``"scene"``.

    Returns
    -------
    Setup

    Examples
    --------
    >>> import trimesh
    >>> import softshadows as ss
    >>> box = ss.Scene.from_trimesh(trimesh.creation.box(extents=(1, 1, 1)))
    >>> setup = ss.scenes.stage(box, width=32, height=32)
    >>> [m.name for m in setup.scene.meshes], float(setup.ground.vertices[:, 1].max())  # under the box
    (['ground', None], -0.5)
    >>> gb = ss.gbuffer(setup.scene, setup.camera)
    >>> vis = ss.ray_traced(setup.scene, setup.light, gb, samples=16)
    >>> bool((vis[gb.mask] < 0.5).any())  # the box's shadow is in view
    True
    """
    from pathlib import Path

    from ..scene import _read

    own = None
    if not isinstance(scene, Scene):
        name = name or Path(os.fspath(scene)).stem
        scene, own = _read(scene)
    if camera is not None:
        own = _v.instance("camera", camera, Camera, "a softshadows.Camera")
    lo, hi = scene.bounds.astype(np.float64)
    extent = float(np.max(hi - lo))
    if not extent > 0:
        raise ValueError(f"scene: its bounds {lo.tolist()}..{hi.tolist()} have no extent to frame")
    staged = assemble(
        name or "scene",
        scene.meshes,
        f"a user scene of {sum(len(m.faces) for m in scene.meshes)} triangles in {len(scene.meshes)} meshes",
        light=light, light_size=extent if light_size is None else light_size, light_position=light_position,
        light_distance=3 * extent if light_distance is None else light_distance,
        light_dir=(-60.0, 55.0), camera_dir=(25.0, 30.0), width=width, height=height, fov_y=fov_y, ground_size=None,
        floor=float(lo[1]), center_xz=(float(lo[0] + hi[0]) / 2, float(lo[2] + hi[2]) / 2), margin=0.5 * extent,
        ground=_v.flag("ground", ground), light_above=False,
    )
    if own is None:
        return staged
    if camera is None:  # the file's camera, at the image size asked for
        own = Camera.look_at(own.eye, own.target, own.up, own.fov_y, width, height)
    return dataclasses.replace(staged, camera=own)


def assemble(
    name, occluders, description, *, light, light_size, light_position, light_distance, light_dir, camera_dir,
    width, height, fov_y, ground_size, frame_by=None, floor=0.0, center_xz=(0.0, 0.0), margin=0.5, ground=True,
    light_above=True,
) -> Setup:
    """Adds the ground, places the light and frames the camera around occluders and shadow.

    ``frame_by``: meshes that stand in for the occluders when placing the light and the camera
    (``fence_mesh`` uses the textured fence's quads so that both get the same setup). The ground
    lies at height ``floor``, centred on ``center_xz``, ``margin`` wider than the shadows
    (``ground=False``: none is added); ``light_above`` refuses a light below the occluders' top.
    """
    meshes = list(occluders)
    framed = meshes if frame_by is None else list(frame_by)
    if light not in LIGHT_KINDS:
        raise ValueError(f"light: expected one of {LIGHT_KINDS}, got {light!r}")
    light_size = _checks.length("light_size", light_size)
    light_distance = _checks.length("light_distance", light_distance)
    width, height = _v.positive_int("width", width), _v.positive_int("height", height)
    fov_y = _v.fov_y(fov_y)
    if fov_y < _checks.MIN_FOV:
        # The camera backs away as 1 / tan(fov): at 1e-6 degrees it sits 1e8 units out, where
        # float32 rays can no longer tell the scene's pixels apart and every pixel misses.
        raise ValueError(f"fov_y: the scenes are framed in float32 and need at least {_checks.MIN_FOV:g} degrees, got {fov_y:g}")

    lo, hi = primitives.bounds(framed).astype(np.float64)
    target = (lo + hi) / 2
    if light_position is None:
        center = target + light_distance * _direction(*light_dir)
    else:
        center = _v.vec3("light_position", light_position).astype(np.float64)
        if np.abs(center).max() > _checks.MAX_LENGTH:
            raise ValueError(f"light_position: coordinates must be within +-{_checks.MAX_LENGTH:g} world units, got {center.tolist()}")
    if light_above and center[1] <= hi[1]:
        raise ValueError(
            f"light_position: the light must be above the occluders (y > {hi[1]:.4g}) to cast a shadow on the "
            f"ground, got y = {center[1]:.4g}"
        )
    try:
        lamp, extremes = _make_light(light, center, target, light_size)
    except ValueError as exc:  # e.g. a rect light whose float32 sides span no area
        raise ValueError(f"light_size: a {light} light of size {light_size:g} is degenerate ({exc})") from None

    # Points to frame: the occluders and their shadow on y = 0 cast from the light's extreme
    # points (which bounds the penumbra); a deterministic subsample of at most 4096 vertices.
    pts = np.concatenate([m.vertices[m.faces.reshape(-1)] for m in framed]).astype(np.float64)
    extreme = np.concatenate([pts.argmin(axis=0), pts.argmax(axis=0)])
    pts = np.concatenate([pts[:: max(1, len(pts) // 4096)], pts[extreme]])
    shadow = []
    for e in extremes:
        below = pts[(pts[:, 1] < e[1] - 1e-6) & (e[1] > floor)]
        t = (e[1] - floor) / (e[1] - below[:, 1])  # e + t (point - e) reaches y = floor
        shadow.append(e + t[:, None] * (below - e))
    shadow = np.concatenate(shadow)
    shadow[:, 1] = floor
    poi = np.concatenate([pts, shadow])
    camera = _frame(poi, _direction(*camera_dir), fov_y, width, height)
    if not ground:
        return Setup(name, Scene(meshes), lamp, camera, description, has_ground=False)

    cx, cz = center_xz
    if ground_size is None:
        half = 1.25 * float(np.max(np.abs(poi[:, [0, 2]] - [cx, cz]))) + margin
        half = float(np.ceil(half / margin) * margin)
    else:
        half = _checks.length("ground_size", ground_size)
    ground = Mesh(
        np.array([[cx - half, floor, cz - half], [cx + half, floor, cz - half], [cx + half, floor, cz + half],
                  [cx - half, floor, cz + half]], dtype=np.float32),
        np.array([[0, 2, 1], [0, 3, 2]], dtype=np.uint32),
        name="ground",
    )
    return Setup(name, Scene([ground, *meshes]), lamp, camera, description)


def _direction(azimuth: float, elevation: float) -> np.ndarray:
    """Unit vector at ``azimuth`` degrees about y (0 = +z, 90 = +x) and ``elevation`` above the ground."""
    a, e = np.radians(azimuth), np.radians(elevation)
    return np.array([np.sin(a) * np.cos(e), np.sin(e), np.cos(a) * np.cos(e)])


def _make_light(kind, center, target, size):
    """The light and a few of its extreme points (for framing its penumbra)."""
    d, e1, e2 = _facing_axes(center, target)
    h = size / 2
    if kind == "point":
        return PointLight(center), [center]
    if kind == "rect":
        lamp = RectLight.look_at(center, target, size)
    elif kind == "disk":
        lamp = DiskLight.look_at(center, target, h)
    elif kind == "ellipsoid":
        lamp = EllipsoidLight(center, [h * e1, 0.35 * h * e2, 0.35 * h * d])
    else:
        lamp = SphereLight(center, h)
    extremes = [center + h * s1 * e1 + h * s2 * e2 for s1 in (-1, 1) for s2 in (-1, 1)]
    if kind == "sphere":
        extremes += [center + h * np.array([0.0, 1.0, 0.0]), center - h * np.array([0.0, 1.0, 0.0])]
    return lamp, extremes


def _frame(points, to_eye, fov_y, width, height, margin=0.9) -> Camera:
    """A camera looking along ``-to_eye``, as close as it can be while ``points`` stay in the
    central ``margin`` of the image, and shifted so that their projection is centred."""
    f = -to_eye / np.linalg.norm(to_eye)
    r = np.cross(f, [0.0, 1.0, 0.0])
    r /= np.linalg.norm(r)
    u = np.cross(r, f)
    o = points - points.mean(axis=0)
    x, y, z = o @ r, o @ u, o @ f
    ty = np.tan(np.radians(fov_y) / 2) * margin
    tx = ty * width / height

    # With the eye at  mean - d f + a r + b u, a point is in view when |x - a| <= tx (z + d), and
    # likewise for y and b: an interval of feasible a for each d, non-empty from some d on.
    def interval(c, t, d):
        return float(np.max(c - t * (z + d))), float(np.min(c + t * (z + d)))

    def smallest(c, t):
        lo = 1e-3 - float(z.min())
        # The first step scales with the points: lo + 1.0 == lo once lo > 2**53, and doubling a
        # zero step would loop forever.
        step = max(1.0, abs(lo) * 2.0**-40)  # 1.0 for any ordinary scene, as before
        hi = lo + step
        while interval(c, t, hi)[0] > interval(c, t, hi)[1]:
            step *= 2
            hi = lo + step
            if not np.isfinite(hi):
                raise ValueError(f"fov_y: cannot frame the scene with a field of view of {fov_y:g} degrees")
        for _ in range(60):
            mid = (lo + hi) / 2
            a0, a1 = interval(c, t, mid)
            lo, hi = (lo, mid) if a0 <= a1 else (mid, hi)
        return hi

    d = max(smallest(x, tx), smallest(y, ty))
    a = sum(interval(x, tx, d)) / 2
    b = sum(interval(y, ty, d)) / 2
    eye = points.mean(axis=0) - d * f + a * r + b * u
    # Look at the point straight ahead at the depth of the points' mean (d > 0 as min(z) <= 0).
    try:
        return Camera.look_at(eye, eye + d * f, (0.0, 1.0, 0.0), fov_y, width, height)
    except ValueError as exc:  # a tiny field of view puts the eye so far that eye == target in float32
        raise ValueError(f"fov_y: cannot frame the scene with a field of view of {fov_y:g} degrees ({exc})") from None

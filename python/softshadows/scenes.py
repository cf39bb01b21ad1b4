"""Deterministic procedural test scenes that mirror the five papers' test cases.

Every public factory returns a :class:`Setup`: a :class:`~softshadows.Scene`, an area light and
a camera that frames the occluders *and* their shadows (umbra and penumbra) on the ground, so
that ``gbuffer(setup.scene, setup.camera)`` sees the penumbrae. ``SCENES`` maps a name to its
factory, and ``get(name, **options)`` calls it (the CLI and the evaluation suite use these).

Conventions chosen here (docs/design.md is silent on them):

* World units are metres-like: occluders are about 1 unit across and float about 0.5 unit above
  the ground. y is up. The ground is always ``scene.meshes[0]`` (named ``"ground"``): one square
  of 2 triangles at y = 0 facing +y, centred on the origin, sized to cover the whole shadow with a
  margin (``ground_size`` sets its half-extent). ``scene.meshes[1:]`` are the occluders.
* Closed occluders (``closed=True``) are two-manifold with consistently outward-facing triangles.
* Every factory takes the same keyword-only light and camera options:

  ``light`` : {"rect", "disk", "sphere", "ellipsoid", "point"}
      The light's kind. Rect and disk lights face the occluders' centre; the ellipsoid is a
      tube-like prolate one, its long axis across the direction to the occluders.
  ``light_size`` : float
      Edge length of the square rect light, diameter of a disk or sphere light, long diameter of
      the ellipsoid (its other two are 0.35 of it), ignored for a point light; in world units.
  ``light_position`` : array_like (3,), optional
      The light's centre; by default it is placed at ``light_distance`` from the occluders'
      centre, above and to one side (each factory documents where).
  ``light_distance`` : float
      Distance from the occluders' centre to the default light position.
  ``width``, ``height`` : int
      Image size of the camera (default 256 x 256).
  ``fov_y`` : float
      Vertical field of view in degrees.
  ``ground_size`` : float, optional
      Half-extent of the ground square; by default it covers the framed region with a margin.

* The camera looks from a fixed direction per scene (elevated 30-45 degrees, across the light
  direction so that the shadow is not hidden behind its occluder), shifted and moved back until
  the occluders' vertices and their shadow on the ground, including the penumbra cast from the
  light's extreme points, fit centred in the central 90% of the image. Its up vector is +y.
* Perforated meshes use binary alpha textures (values 0 and 1, float32) and per-vertex uvs
  following docs/design.md section 2 (``alpha[i, j]`` covers u in [j/W, (j+1)/W), v in [i/H, (i+1)/H);
  uvs repeat).
* Everything is deterministic: random scenes use ``numpy.random.default_rng(seed)`` only.

The real meshes of :func:`load_model` are read, never copied, from the sample meshes that the
PyPI package ``pymeshlab`` ships in ``pymeshlab/tests/sample_meshes`` (``bunny.obj``,
``bone.ply``, ``cow.obj``); ``pip install "softshadows[models]"`` installs it.
"""

from __future__ import annotations

import dataclasses
import functools
import importlib.util
import math
import os
from dataclasses import dataclass

import numpy as np

from . import _validate as _v
from .camera import Camera
from .lights import DiskLight, EllipsoidLight, PointLight, RectLight, SphereLight, _facing_axes
from .scene import Mesh, Scene

__all__ = [
    "Setup",
    "SCENES",
    "MODELS",
    "get",
    "ground_sphere",
    "columns",
    "torus_knot",
    "fence",
    "fence_mesh",
    "leaves",
    "hairball",
    "sword",
    "load_model",
    "stage",
    "fence_texture",
    "leaf_texture",
]

LIGHT_KINDS = ("rect", "disk", "sphere", "ellipsoid", "point")

#: Model name -> file name in pymeshlab's ``tests/sample_meshes`` folder.
MODELS = {"bunny": "bunny.obj", "bone": "bone.ply", "cow": "cow.obj"}

# Default gap under each model: the bone lies flat (0.18 of its length high), so resting on the
# ground it would cast almost no visible penumbra; it floats like Annen et al. 2008's bone instead.
_MODEL_ELEVATION = {"bunny": 0.0, "bone": 0.3, "cow": 0.0}


@dataclass(frozen=True, eq=False)
class Setup:
    """A ready-to-run test case: scene, light and camera.

    Attributes
    ----------
    name : str
        The scene's name (a key of ``SCENES``).
    scene : Scene
        ``scene.meshes[0]`` is the ground; the other meshes are the occluders.
    light : PointLight, RectLight, DiskLight, SphereLight or EllipsoidLight
        The default light.
    camera : Camera
        A view of the occluders and their shadow on the ground.
    description : str
        What the scene mirrors (paper and figure) and its triangle counts.

    Examples
    --------
    >>> import softshadows as ss
    >>> setup = ss.scenes.get("columns", width=32, height=32)
    >>> setup.name, setup.camera.width, type(setup.light).__name__
    ('columns', 32, 'RectLight')
    >>> [m.name for m in setup.occluders]  # every mesh but the ground
    ['columns']
    """

    name: str
    scene: Scene
    light: object
    camera: Camera
    description: str = ""
    #: Whether ``scene.meshes[0]`` is a ground added under the occluders (:func:`stage` can leave
    #: a scene with a floor of its own as it is).
    has_ground: bool = True

    @property
    def ground(self) -> Mesh | None:
        """The ground mesh (``scene.meshes[0]``), or None when the set-up added none."""
        return self.scene.meshes[0] if self.has_ground else None

    @property
    def occluders(self) -> list:
        """The occluder meshes (every mesh but the ground)."""
        return self.scene.meshes[1:] if self.has_ground else list(self.scene.meshes)

    @property
    def occluder_bounds(self) -> np.ndarray:
        """Axis-aligned bounds of the occluders, shape (2, 3): min and max."""
        return _bounds(self.occluders)

    def with_size(self, width: int, height: int) -> "Setup":
        """The same setup seen at another image size."""
        return dataclasses.replace(self, camera=self.camera.with_size(width, height))

    def with_light(self, light) -> "Setup":
        """The same scene and camera under another light."""
        from .lights import _Light

        _v.instance("light", light, _Light, "a PointLight, RectLight, DiskLight, SphereLight or EllipsoidLight")
        return dataclasses.replace(self, light=light)

    def __repr__(self) -> str:
        return f"Setup({self.name!r}, {self.scene!r}, {self.light!r})"


# ----------------------------------------------------------------------------------------------
# Scene factories
# ----------------------------------------------------------------------------------------------


def ground_sphere(
    *,
    radius: float = 0.5,
    elevation: float = 0.5,
    subdivisions: int = 3,
    light: str = "rect",
    light_size: float = 1.0,
    light_position=None,
    light_distance: float = 3.0,
    width: int = 256,
    height: int = 256,
    fov_y: float = 40.0,
    ground_size: float | None = None,
) -> Setup:
    """A sphere floating over the ground: the simplest soft-shadow case.

    The canonical sphere-over-a-plane configuration (not a figure of the papers): a smooth convex
    caster whose penumbra widens linearly with the light's size and the gap to the ground, the
    quantities the papers vary in their light-size experiments (Sintorn et
    al. 2008, Sample Based Visibility for Soft Shadows, Fig. 12; Marrs et al. 2018,
    View-warped Multi-view Soft Shadows, Fig. 8).

    Parameters
    ----------
    radius : float
        Sphere radius in world units.
    elevation : float
        Gap between the ground and the bottom of the sphere, in world units.
    subdivisions : int
        Icosphere subdivision level >= 0: the sphere has ``20 * 4**subdivisions`` triangles
        (1280 by default) and ``10 * 4**subdivisions + 2`` vertices.
    light, light_size, light_position, light_distance, width, height, fov_y, ground_size
        See the module docstring. The default light is up and to the -x side.

    Returns
    -------
    Setup
        Meshes ``ground`` (2 triangles) and ``sphere`` (closed).

    Examples
    --------
    >>> import softshadows as ss
    >>> ss.scenes.ground_sphere(width=32, height=32).scene
    Scene(2 meshes ['ground', 'sphere'], 1282 faces)
    """
    radius = _length("radius", radius)
    elevation = _length("elevation", elevation, allow_zero=True)
    subdivisions = _v.nonneg_int("subdivisions", subdivisions)
    _mesh_budget("subdivisions", "ground_sphere", 20.0 * 4.0 ** min(subdivisions, 64), 10.0 * 4.0 ** min(subdivisions, 64) + 2)
    verts, faces = _icosphere(subdivisions)
    verts = verts * radius + np.array([0.0, elevation + radius, 0.0])
    sphere = Mesh(verts, faces, closed=True, name="sphere")
    return _assemble(
        "ground_sphere",
        [sphere],
        f"Icosphere ({len(faces)} triangles, radius {radius:g}) floating {elevation:g} over the ground.",
        light=light, light_size=light_size, light_position=light_position, light_distance=light_distance,
        light_dir=(-50.0, 65.0), camera_dir=(20.0, 40.0),
        width=width, height=height, fov_y=fov_y, ground_size=ground_size,
    )


def parallel_plates(
    *,
    plate_size: float = 2.0,
    elevation: float = 1.0,
    light: str = "rect",
    light_size: float = 1.0,
    light_position=None,
    light_distance: float = 3.0,
    width: int = 256,
    height: int = 256,
    fov_y: float = 40.0,
    ground_size: float | None = None,
) -> Setup:
    """A square plate parallel to the ground under a parallel light: the case where filtered
    shadow maps are exact.

    Light, blocker and receiver planar and parallel is where the convolution of a shadow test
    with the light's shape is the exact soft shadow (Soler and Sillion 1998; the exact case of
    Annen et al. 2008, section 3, and of PCSS's penumbra estimate, Fernando 2005). The default
    light is straight above the plate with its sides along the plate's, so every edge casts a
    linear penumbra ``light_size * elevation / light_distance`` wide (1/3 by default).

    Parameters
    ----------
    plate_size : float
        Side of the square plate in world units.
    elevation : float
        Height of the plate over the ground.
    light, light_size, light_position, light_distance, width, height, fov_y, ground_size
        See the module docstring. The default light is straight above the plate.

    Returns
    -------
    Setup
        Meshes ``ground`` and ``plate`` (2 triangles each, facing up).

    Examples
    --------
    >>> from softshadows import scenes
    >>> setup = scenes.parallel_plates(width=32, height=32)
    >>> [m.name for m in setup.scene.meshes], setup.light.center.round(6).tolist()
    (['ground', 'plate'], [0.0, 4.0, 0.0])
    """
    half = _length("plate_size", plate_size) / 2
    elevation = _length("elevation", elevation)
    plate = Mesh(
        np.array([[-half, elevation, -half], [half, elevation, -half], [half, elevation, half], [-half, elevation, half]], np.float32),
        np.array([[0, 2, 1], [0, 3, 2]], dtype=np.uint32),
        name="plate",
    )
    return _assemble(
        "parallel_plates",
        [plate],
        f"A {2 * half:g} x {2 * half:g} plate {elevation:g} over the ground under a parallel light (the exact case of "
        "filtered shadow maps; Annen et al. 2008, section 3).",
        light=light, light_size=light_size, light_position=light_position, light_distance=light_distance,
        light_dir=(0.0, 90.0), camera_dir=(20.0, 55.0),
        width=width, height=height, fov_y=fov_y, ground_size=ground_size,
    )


def columns(
    *,
    n: int = 5,
    kind: str = "cylinder",
    segments: int = 42,
    radius: float = 0.1,
    column_height: float = 1.2,
    spacing: float = 0.45,
    light: str = "rect",
    light_size: float = 1.0,
    light_position=None,
    light_distance: float = 3.0,
    width: int = 256,
    height: int = 256,
    fov_y: float = 40.0,
    ground_size: float | None = None,
) -> Setup:
    """A row of closed columns standing on the ground.

    Mirrors the "columns" test scene of Sintorn et al. 2008, Sample Based Visibility for
    Soft Shadows (Section 5: "columns of 840 triangles"); the default (5 cylinders of 42
    segments) has exactly 840 triangles. Shadows of
    neighbouring columns overlap, and each shadow runs from hard at the column's foot to wide
    penumbra at its top.

    Parameters
    ----------
    n : int
        Number of columns, in a row along x centred on the origin.
    kind : {"cylinder", "box"}
        Column shape. A cylinder has ``4 * segments`` triangles (sides and two fan caps), a box 12.
    segments : int
        Cylinder segments around the axis (>= 3).
    radius : float
        Cylinder radius, or half the box's width, in world units.
    column_height : float
        Column height in world units (the columns stand on y = 0).
    spacing : float
        Distance between neighbouring column axes, in world units.
    light, light_size, light_position, light_distance, width, height, fov_y, ground_size
        See the module docstring. The default light is up, behind (-z) and to the -x side, so the
        shadows fall forward and to the right of the columns.

    Returns
    -------
    Setup
        Meshes ``ground`` and ``columns`` (closed; ``n * 4 * segments`` or ``n * 12`` triangles).

    Examples
    --------
    >>> import softshadows as ss
    >>> ss.scenes.columns(width=32, height=32).scene
    Scene(2 meshes ['ground', 'columns'], 842 faces)
    """
    n = _v.positive_int("n", n)
    if kind not in ("cylinder", "box"):
        raise ValueError(f"kind: expected 'cylinder' or 'box', got {kind!r}")
    segments = _v.positive_int("segments", segments)
    if segments < 3:
        raise ValueError(f"segments: expected an integer >= 3, got {segments}")
    radius = _length("radius", radius)
    column_height = _length("column_height", column_height)
    spacing = _length("spacing", spacing)
    per_column = (4 * segments, 2 * segments + 2) if kind == "cylinder" else (12, 8)
    _mesh_budget("n", "columns", float(n) * per_column[0], float(n) * per_column[1])
    parts = []
    for i in range(n):
        x = (i - (n - 1) / 2) * spacing
        if kind == "cylinder":
            parts.append(_cylinder((x, 0.0), radius, 0.0, column_height, segments))
        else:
            parts.append(_box((x - radius, 0.0, -radius), (x + radius, column_height, radius)))
    verts, faces = _merge(parts)
    mesh = Mesh(verts, faces, closed=True, name="columns")
    return _assemble(
        "columns",
        [mesh],
        f"{n} {kind} columns ({len(faces)} triangles), {column_height:g} high, standing on the ground "
        "(Sintorn et al. 2008, Section 5).",
        light=light, light_size=light_size, light_position=light_position, light_distance=light_distance,
        light_dir=(-150.0, 55.0), camera_dir=(20.0, 38.0),
        width=width, height=height, fov_y=fov_y, ground_size=ground_size,
    )


def torus_knot(
    *,
    p: int = 2,
    q: int = 3,
    tube_segments: int = 192,
    radial_segments: int = 16,
    radius: float = 0.6,
    tube_radius: float = 0.08,
    elevation: float = 0.6,
    light: str = "rect",
    light_size: float = 1.0,
    light_position=None,
    light_distance: float = 3.0,
    width: int = 256,
    height: int = 256,
    fov_y: float = 40.0,
    ground_size: float | None = None,
) -> Setup:
    """A (p, q) torus knot lying flat over the ground, of chosen tessellation.

    Mirrors the "torus-knot of varying tessellation degrees" of Sintorn et al. 2008, Sample
    Based Visibility for Soft Shadows (Fig. 11: 1.2k, 12k and 24k triangles; Fig. 12: 6k
    triangles). The default,
    192 x 16 segments, has 6144 triangles.

    Parameters
    ----------
    p, q : int
        Coprime winding numbers of the knot (p turns around the axis, q through the hole).
    tube_segments : int
        Segments along the knot's curve (>= 3).
    radial_segments : int
        Segments around the tube (>= 3). The mesh has ``2 * tube_segments * radial_segments``
        triangles and ``tube_segments * radial_segments`` vertices.
    radius : float
        Largest distance of the knot's centre curve from its axis, in world units.
    tube_radius : float
        Radius of the tube in world units (keep it below about ``0.27 * radius`` for the (2, 3)
        knot, or the tube intersects itself).
    elevation : float
        Gap between the ground and the lowest point of the tube, in world units.
    light, light_size, light_position, light_distance, width, height, fov_y, ground_size
        See the module docstring. The default light is up and to the -x side.

    Returns
    -------
    Setup
        Meshes ``ground`` and ``torus_knot`` (closed).

    Examples
    --------
    >>> import softshadows as ss
    >>> setup = ss.scenes.torus_knot(tube_segments=64, radial_segments=8, width=32, height=32)
    >>> setup.scene, bool(setup.occluders[0].closed)
    (Scene(2 meshes ['ground', 'torus_knot'], 1026 faces), True)
    """
    p, q = _v.positive_int("p", p), _v.positive_int("q", q)
    if math.gcd(p, q) != 1:  # np.gcd overflows for p or q >= 2**63
        raise ValueError(f"p: p and q must be coprime for a knot, got p={p}, q={q}")
    tube_segments = _at_least("tube_segments", tube_segments, 3)
    radial_segments = _at_least("radial_segments", radial_segments, 3)
    radius = _length("radius", radius)
    tube_radius = _length("tube_radius", tube_radius)
    elevation = _length("elevation", elevation, allow_zero=True)
    _mesh_budget("tube_segments", "torus_knot", 2.0 * tube_segments * radial_segments, float(tube_segments) * radial_segments)

    t = np.arange(tube_segments) * (2 * np.pi / tube_segments)
    s = radius / 3.0  # the curve's largest distance from the axis is 3 in curve units
    r = 2.0 + np.cos(q * t)
    # Curve in the x-z plane (lying flat), height along y.
    pts = s * np.stack([r * np.cos(p * t), -np.sin(q * t), r * np.sin(p * t)], axis=1)
    dr = -q * np.sin(q * t)
    tan = s * np.stack(
        [dr * np.cos(p * t) - r * p * np.sin(p * t), -q * np.cos(q * t), dr * np.sin(p * t) + r * p * np.cos(p * t)],
        axis=1,
    )
    tan /= np.linalg.norm(tan, axis=1, keepdims=True)
    # A periodic frame: the binormal is perpendicular to the tangent and the radial direction.
    b = np.cross(tan, pts)
    b /= np.linalg.norm(b, axis=1, keepdims=True)
    nrm = np.cross(b, tan)
    verts, faces = _tube(pts[None], tan[None], nrm[None], tube_radius, radial_segments, loop=True)
    verts[:, 1] += elevation + tube_radius + s  # the curve's lowest point is at y = -s
    mesh = Mesh(verts, faces, closed=True, name="torus_knot")
    return _assemble(
        "torus_knot",
        [mesh],
        f"({p}, {q}) torus knot, {tube_segments} x {radial_segments} segments ({len(faces)} triangles), "
        "floating over the ground (Sintorn et al. 2008, Figs. 11-12).",
        light=light, light_size=light_size, light_position=light_position, light_distance=light_distance,
        light_dir=(-50.0, 65.0), camera_dir=(20.0, 45.0),
        width=width, height=height, fov_y=fov_y, ground_size=ground_size,
    )


def fence(
    *,
    pattern: str = "slats",
    panels: int = 2,
    panel_width: float = 2.0,
    panel_height: float = 1.0,
    repeats=None,
    gap: float = 0.5,
    elevation: float = 0.0,
    light: str = "rect",
    light_size: float = 0.6,
    light_position=None,
    light_distance: float = 3.0,
    width: int = 256,
    height: int = 256,
    fov_y: float = 40.0,
    ground_size: float | None = None,
) -> Setup:
    """A fence of perforated (alpha-textured) vertical quads: the S-triangles of Forest et al. 2009.

    Mirrors the fences of Forest et al. 2009, Soft Textured Shadow Volume (Fig. 1, Fig. 4 and
    Fig. 11a: "a fence represented by 2 perforated triangles"). Each panel is one quad (2
    triangles) whose uvs run
    over [0, ku] x [0, kv], repeating a binary tile from :func:`fence_texture` ku x kv times.
    Panels stand one behind the other, staggered along x, so that their shadows overlap (the
    occluder-fusion case where summed visibility coefficients fail). :func:`fence_mesh` builds
    the same fence as explicit geometry.

    Parameters
    ----------
    pattern : {"slats", "grid"}
        ``"slats"``: a picket fence (pointed vertical slats and two horizontal rails; tile
        16 x 64 texels, W x H). ``"grid"``: a wire mesh of square holes (tile 8 x 8 texels,
        wires 2 texels thick).
    panels : int
        Number of quads; panel i is ``gap`` behind panel i - 1 (along -z) and shifted along +x
        by 0.6 panel widths.
    panel_width, panel_height : float
        Size of each panel in world units (along x and y).
    repeats : (int, int), optional
        Tile repeats (ku, kv) over a panel; default (10, 1) for slats, (40, 20) for grid.
    gap : float
        Distance between consecutive panels along z, in world units.
    elevation : float
        Height of the panels' bottom edge above the ground.
    light, light_size, light_position, light_distance, width, height, fov_y, ground_size
        See the module docstring. The default light is up and behind the fence (-z), so its
        shadow falls in front, toward the camera.

    Returns
    -------
    Setup
        Meshes ``ground`` and ``fence_0``, ``fence_1``, ... (2 triangles each, with uvs and alpha;
        not closed).

    Examples
    --------
    >>> import softshadows as ss
    >>> setup = ss.scenes.fence(width=32, height=32)
    >>> setup.scene, setup.scene.meshes[1].alpha.shape  # two quads, perforated by an alpha texture
    (Scene(3 meshes ['ground', 'fence_0', 'fence_1'], 6 faces), (64, 16))
    """
    panels_, tile, reps = _fence_layout(pattern, panels, panel_width, panel_height, repeats, gap, elevation)
    meshes = _fence_quads(panels_, tile, reps)
    return _assemble(
        "fence",
        meshes,
        f"{len(meshes)} perforated fence panels ({pattern}, {tile.shape[1]}x{tile.shape[0]} tile repeated "
        f"{reps[0]}x{reps[1]}; {2 * len(meshes)} triangles) (Forest et al. 2009, Figs. 1, 4, 11a).",
        light=light, light_size=light_size, light_position=light_position, light_distance=light_distance,
        light_dir=(195.0, 50.0), camera_dir=(15.0, 45.0),
        width=width, height=height, fov_y=fov_y, ground_size=ground_size,
    )


def fence_mesh(
    *,
    pattern: str = "slats",
    panels: int = 2,
    panel_width: float = 2.0,
    panel_height: float = 1.0,
    repeats=None,
    gap: float = 0.5,
    elevation: float = 0.0,
    light: str = "rect",
    light_size: float = 0.6,
    light_position=None,
    light_distance: float = 3.0,
    width: int = 256,
    height: int = 256,
    fov_y: float = 40.0,
    ground_size: float | None = None,
) -> Setup:
    """The fence of :func:`fence` modelled as explicit opaque geometry.

    Mirrors Forest et al. 2009, Soft Textured Shadow Volume, Fig. 11b ("the fence represented
    by its corresponding mesh") and the
    ray-traced mesh reference of Fig. 4c. The opaque texels of each panel are merged greedily
    into texel-aligned rectangles (runs along u, then identical runs stacked along v), each two
    triangles lying in the panel's plane, so the mesh covers exactly the opaque texels'
    footprint: with the same options, ``fence`` and ``fence_mesh`` cast identical shadows (up to
    nearest-texel lookups exactly on texel edges). Takes the same options as :func:`fence`, and
    with the same options gets the same light, ground and camera (framed on the panels' quads).

    Returns
    -------
    Setup
        Meshes ``ground`` and ``fence_0``, ``fence_1``, ... (opaque, zero thickness, not closed;
        124 triangles per panel for the default slats, 1640 for the default grid).

    Examples
    --------
    >>> import softshadows as ss
    >>> ss.scenes.fence_mesh(width=32, height=32).scene  # the same slats as geometry
    Scene(3 meshes ['ground', 'fence_0', 'fence_1'], 250 faces)
    """
    panels_, tile, reps = _fence_layout(pattern, panels, panel_width, panel_height, repeats, gap, elevation)
    texels = float(tile.size) * reps[0] * reps[1]
    # The opaque-texel mask, its padded rows and up to one rectangle (2 triangles) per texel.
    _mesh_budget("repeats", "fence_mesh", 2.0 * texels * len(panels_), 4.0 * texels * len(panels_), extra=80.0 * texels)
    full = np.tile(tile >= 0.5, (reps[1], reps[0]))  # rows: v texels, columns: u texels
    rects = _merge_rectangles(full)
    th, tw = tile.shape
    meshes = []
    for i, (origin, u_axis, v_axis) in enumerate(panels_):
        verts, faces = _rectangles_to_mesh(rects, origin, u_axis / (reps[0] * tw), v_axis / (reps[1] * th))
        meshes.append(Mesh(verts, faces, name=f"fence_{i}"))
    n_tri = sum(len(m.faces) for m in meshes)
    quads = _fence_quads(panels_, tile, reps)
    return _assemble(
        "fence_mesh",
        meshes,
        f"{len(meshes)} fence panels ({pattern}) as explicit opaque geometry ({n_tri} triangles) "
        "(Forest et al. 2009, Fig. 11b).",
        frame_by=quads,
        light=light, light_size=light_size, light_position=light_position, light_distance=light_distance,
        light_dir=(195.0, 50.0), camera_dir=(15.0, 45.0),
        width=width, height=height, fov_y=fov_y, ground_size=ground_size,
    )


def leaves(
    *,
    n: int = 1000,
    seed: int = 0,
    leaf_size: float = 0.16,
    crown_radius: float = 0.7,
    crown_height: float = 1.5,
    trunk_radius: float = 0.05,
    trunk_segments: int = 12,
    texture_size: int = 32,
    light: str = "rect",
    light_size: float = 1.0,
    light_position=None,
    light_distance: float = 3.0,
    width: int = 256,
    height: int = 256,
    fov_y: float = 40.0,
    ground_size: float | None = None,
) -> Setup:
    """A tree: a crown of many randomly oriented, alpha-textured leaf quads over a trunk.

    Mirrors the foliage of Forest et al. 2009, Soft Textured Shadow Volume (the "Greece"
    scene of Figs. 7c and 10: "26,150 S-triangles (two per leaf)") and the leaves of Sintorn et
    al. 2008, Sample Based Visibility for Soft Shadows, and of Schwarz and Stamminger 2008,
    Quality Scalability of Soft Shadow Mapping (Fig. 10, palm tree). Leaves are uniformly
    distributed in an ellipsoidal crown, with uniformly random
    normals and in-plane rotations; every leaf is one quad (2 triangles) with uvs over [0, 1]^2
    showing the mask of :func:`leaf_texture`.

    Parameters
    ----------
    n : int
        Number of leaves: the ``leaves`` mesh has ``2 * n`` triangles.
    seed : int
        Random seed; the same seed gives identical arrays.
    leaf_size : float
        Edge length of each leaf quad, in world units.
    crown_radius : float
        Horizontal radius of the ellipsoidal crown (its vertical radius is 0.75 of it).
    crown_height : float
        Height of the crown's centre above the ground; the trunk reaches up to it.
    trunk_radius : float
        Trunk radius, in world units.
    trunk_segments : int
        Segments around the trunk (>= 3): the trunk has ``4 * trunk_segments`` triangles.
    texture_size : int
        The leaf mask is ``texture_size`` x ``texture_size`` texels.
    light, light_size, light_position, light_distance, width, height, fov_y, ground_size
        See the module docstring. The default light is high and to the -x side.

    Returns
    -------
    Setup
        Meshes ``ground``, ``trunk`` (closed cylinder) and ``leaves`` (perforated, not closed).

    Examples
    --------
    >>> import softshadows as ss
    >>> ss.scenes.leaves(width=32, height=32).scene
    Scene(3 meshes ['ground', 'trunk', 'leaves'], 2050 faces)
    """
    n = _v.positive_int("n", n)
    rng = np.random.default_rng(_v.nonneg_int("seed", seed))
    leaf_size = _length("leaf_size", leaf_size)
    crown_radius = _length("crown_radius", crown_radius)
    crown_height = _length("crown_height", crown_height)
    trunk_radius = _length("trunk_radius", trunk_radius)
    trunk_segments = _at_least("trunk_segments", trunk_segments, 3)
    texture_size = _at_least("texture_size", texture_size, 4)
    _mesh_budget("n", "leaves", 2.0 * n + 4.0 * trunk_segments, 4.0 * n + 2.0 * trunk_segments + 2,
                 extra=600.0 * n + 40.0 * float(texture_size) ** 2)  # float64 leaf frames; the mask
    if crown_height <= 0.75 * crown_radius:
        raise ValueError(
            f"crown_height: must exceed the crown's vertical radius 0.75 * crown_radius = {0.75 * crown_radius:g}, "
            f"got {crown_height:g}"
        )

    radii = np.array([crown_radius, 0.75 * crown_radius, crown_radius])
    centers = _unit_ball(rng, n) * radii + np.array([0.0, crown_height, 0.0])
    normals = _unit_vectors(rng, n)
    helper = np.where(np.abs(normals[:, 1:2]) < 0.9, [[0.0, 1.0, 0.0]], [[1.0, 0.0, 0.0]])
    e1 = np.cross(normals, helper)
    e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
    e2 = np.cross(normals, e1)
    angle = rng.uniform(0.0, 2 * np.pi, n)[:, None]
    a = np.cos(angle) * e1 + np.sin(angle) * e2  # along the leaf (u)
    b = np.cross(normals, a)  # across the leaf (v)
    h = leaf_size / 2
    corners = np.stack(
        [centers - h * a - h * b, centers + h * a - h * b, centers + h * a + h * b, centers - h * a + h * b], axis=1
    )
    verts = corners.reshape(-1, 3)
    uvs = np.tile(np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=np.float32), (n, 1))
    base = 4 * np.arange(n, dtype=np.uint32)[:, None, None]
    faces = (np.array([[[0, 1, 2], [0, 2, 3]]], dtype=np.uint32) + base).reshape(-1, 3)
    leaf_mesh = Mesh(verts, faces, uvs=uvs, alpha=leaf_texture(texture_size), name="leaves")
    tv, tf = _cylinder((0.0, 0.0), trunk_radius, 0.0, crown_height, trunk_segments)
    trunk = Mesh(tv, tf, closed=True, name="trunk")
    return _assemble(
        "leaves",
        [trunk, leaf_mesh],
        f"Tree: {n} perforated leaf quads ({2 * n} triangles) in a crown over a trunk ({len(tf)} triangles) "
        "(Forest et al. 2009, Greece scene).",
        light=light, light_size=light_size, light_position=light_position, light_distance=light_distance,
        light_dir=(-50.0, 65.0), camera_dir=(20.0, 35.0),
        width=width, height=height, fov_y=fov_y, ground_size=ground_size,
    )


def hairball(
    *,
    strands: int = 400,
    segments: int = 8,
    sides: int = 3,
    seed: int = 0,
    radius: float = 0.6,
    strand_radius: float = 0.008,
    strand_length: float = 1.0,
    elevation: float = 0.4,
    light: str = "rect",
    light_size: float = 1.0,
    light_position=None,
    light_distance: float = 3.0,
    width: int = 256,
    height: int = 256,
    fov_y: float = 40.0,
    ground_size: float | None = None,
) -> Setup:
    """A ball of many thin random tubes: high depth complexity, a hard case for shadow maps.

    Mirrors the hairball of Sintorn et al. 2008, Sample Based Visibility for Soft Shadows
    (Section 5: a hairball of 44k triangles) and the thin geometry of Marrs et al. 2018,
    View-warped Multi-view Soft Shadows (Fig. 10: thin occluders fall between depth-map
    texels). Each
    strand is a smooth random walk inside the ball (reflected at its surface), swept as a closed
    tube of ``sides`` sides with flat end caps; strands intersect each other freely (the union of
    closed tubes is still a valid closed caster for back-face-only shadow casting).

    Parameters
    ----------
    strands : int
        Number of strands.
    segments : int
        Segments per strand.
    sides : int
        Sides of each tube's cross-section (>= 3). The mesh has
        ``strands * (2 * sides * segments + 2 * (sides - 2))`` triangles: 20,000 by default
        (400 x 50); ``strands=880`` gives Sintorn et al.'s 44k.
    seed : int
        Random seed; the same seed gives identical arrays.
    radius : float
        Radius of the ball, in world units.
    strand_radius : float
        Radius of each tube, in world units.
    strand_length : float
        Length of each strand, in world units.
    elevation : float
        Gap between the ground and the bottom of the ball.
    light, light_size, light_position, light_distance, width, height, fov_y, ground_size
        See the module docstring. The default light is up and to the -x side.

    Returns
    -------
    Setup
        Meshes ``ground`` and ``hairball`` (closed).

    Examples
    --------
    >>> import softshadows as ss
    >>> ss.scenes.hairball(width=32, height=32).scene
    Scene(2 meshes ['ground', 'hairball'], 20002 faces)
    """
    strands = _v.positive_int("strands", strands)
    segments = _v.positive_int("segments", segments)
    sides = _at_least("sides", sides, 3)
    rng = np.random.default_rng(_v.nonneg_int("seed", seed))
    radius = _length("radius", radius)
    strand_radius = _length("strand_radius", strand_radius)
    strand_length = _length("strand_length", strand_length)
    elevation = _length("elevation", elevation, allow_zero=True)
    if strand_radius >= radius:
        raise ValueError(f"strand_radius: must be below radius = {radius:g} (the strands stay inside the ball), got {strand_radius:g}")
    if strand_length / segments < 1e-9 * radius:
        # Consecutive points would coincide in float64: the tube frames would divide by zero.
        raise ValueError(
            f"strand_length: each of the {segments} segments must be at least 1e-9 x radius long, got {strand_length:g} in all"
        )
    _mesh_budget("strands", "hairball", float(strands) * (2 * sides * segments + 2 * (sides - 2)),
                 float(strands) * (segments + 1) * sides)

    inner = radius - strand_radius
    pos = _unit_ball(rng, strands) * (0.8 * inner)
    d = _unit_vectors(rng, strands)
    step = strand_length / segments
    pts = [pos]
    for _ in range(segments):
        d = d + 0.6 * rng.standard_normal((strands, 3))
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        nxt = pos + step * d
        out = np.linalg.norm(nxt, axis=1) > inner
        if out.any():  # reflect the direction at the ball's surface, then clamp inside
            nrm = nxt[out] / np.linalg.norm(nxt[out], axis=1, keepdims=True)
            dn = np.sum(d[out] * nrm, axis=1, keepdims=True)
            d[out] = d[out] - 2 * np.maximum(dn, 0) * nrm
            nxt[out] = pos[out] + step * d[out]
            norm = np.linalg.norm(nxt[out], axis=1, keepdims=True)
            nxt[out] *= np.minimum(1.0, inner / norm)
        pts.append(nxt)
        pos = nxt
    pts = np.stack(pts, axis=1)  # (strands, segments + 1, 3)
    tan, nrm = _transport_frames(pts)
    verts, faces = _tube(pts, tan, nrm, strand_radius, sides, loop=False)
    verts[:, 1] += elevation + radius
    mesh = Mesh(verts, faces, closed=True, name="hairball")
    return _assemble(
        "hairball",
        [mesh],
        f"Hairball: {strands} random tubes of {segments} segments and {sides} sides ({len(faces)} triangles) "
        "in a ball (Sintorn et al. 2008, Section 5).",
        light=light, light_size=light_size, light_position=light_position, light_distance=light_distance,
        light_dir=(-50.0, 65.0), camera_dir=(20.0, 40.0),
        width=width, height=height, fov_y=fov_y, ground_size=ground_size,
    )


def sword(
    *,
    blade_length: float = 1.6,
    blade_width: float = 0.03,
    blade_thickness: float = 0.01,
    tip_height: float = 0.1,
    tilt: float = 25.0,
    light: str = "rect",
    light_size: float = 1.0,
    light_position=None,
    light_distance: float = 3.0,
    width: int = 256,
    height: int = 256,
    fov_y: float = 40.0,
    ground_size: float | None = None,
) -> Setup:
    """A thin sword held tip down over the ground: the thin-occluder case of Marrs et al. 2018 (Figure 10).

    The blade is only a few shadow-map texels wide and rises from its tip near the ground to the
    hilt. A blocker search sized for the nearest occluder (PCSS) spreads its taps wide under the
    tip, steps over the blade and leaves holes in its shadow, while methods that test every light
    sample's own depth map (MVR, VWSS) keep it.

    Parameters
    ----------
    blade_length, blade_width, blade_thickness : float
        The blade: a closed box along x, its width along z and thickness along y (world units).
    tip_height : float
        Height of the blade's tip over the ground.
    tilt : float
        Angle of the blade over the horizontal in degrees (0 to 80), hilt up.
    light, light_size, light_position, light_distance, width, height, fov_y, ground_size
        See the module docstring.

    Returns
    -------
    Setup
        Meshes ``ground`` and ``sword`` (closed: the blade, a crossguard and a grip; 36 triangles).

    Examples
    --------
    >>> import softshadows as ss
    >>> ss.scenes.sword(width=32, height=32).scene
    Scene(2 meshes ['ground', 'sword'], 38 faces)
    """
    length = _length("blade_length", blade_length)
    w = _length("blade_width", blade_width)
    t = _length("blade_thickness", blade_thickness)
    tip = _length("tip_height", tip_height)
    tilt = _v.number("tilt", tilt)
    if not 0.0 <= tilt <= 80.0:
        raise ValueError(f"tilt: expected degrees in [0, 80], got {tilt}")
    guard = 4 * w
    parts = [  # the tip at the origin, the hilt towards -x
        _box((-length, -t / 2, -w / 2), (0.0, t / 2, w / 2)),
        _box((-length - 2 * t, -t, -guard), (-length, t, guard)),
        _box((-length * 1.12, -t, -w / 2), (-length - 2 * t, t, w / 2)),
    ]
    verts, faces = _merge(parts)
    a = np.radians(tilt)
    rot = np.array([[np.cos(a), np.sin(a), 0.0], [-np.sin(a), np.cos(a), 0.0], [0.0, 0.0, 1.0]])
    verts = verts @ rot.T + np.array([length / 2, tip, 0.0])
    mesh = Mesh(verts, faces, closed=True, name="sword")
    return _assemble(
        "sword",
        [mesh],
        f"A sword, blade {length:g} long and {w:g} wide, tip {tip:g} over the ground, tilted {tilt:g} degrees "
        "(Marrs et al. 2018, Figure 10).",
        light=light, light_size=light_size, light_position=light_position, light_distance=light_distance,
        light_dir=(-120.0, 60.0), camera_dir=(20.0, 45.0),
        width=width, height=height, fov_y=fov_y, ground_size=ground_size,
    )


def load_model(
    name: str,
    *,
    size: float = 1.0,
    elevation: float | None = None,
    yaw: float = 0.0,
    light: str = "rect",
    light_size: float = 1.0,
    light_position=None,
    light_distance: float = 3.0,
    width: int = 256,
    height: int = 256,
    fov_y: float = 40.0,
    ground_size: float | None = None,
) -> Setup:
    """A real scanned mesh on the ground, read from pymeshlab's sample meshes.

    The meshes stand in for the papers' models: the Stanford bunny (``bunny.obj``, 56,172
    triangles, watertight) for the single detailed closed caster of Sintorn et al. 2008, Annen
    et al. 2008 and Marrs et al. 2018; a
    bone (``bone.ply``, 3,022 triangles, watertight after merging duplicate vertices) for
    Annen et al.'s "foot bone model" (Fig. 9); a cow (``cow.obj``, 5,804 triangles, watertight) for
    an animal-like character with thin legs (Schwarz and Stamminger's dinosaur, Fig. 10; Marrs et
    al.'s characters, Figs. 8-10). The
    files are located with ``importlib.util.find_spec("pymeshlab")`` (pymeshlab itself is not
    imported) and loaded with trimesh, which merges duplicate vertices.

    Parameters
    ----------
    name : {"bunny", "bone", "cow"}
        Which model.
    size : float
        The model is scaled uniformly so that its largest bounding-box extent is ``size`` world
        units, centred on the y axis.
    elevation : float, optional
        Gap between the ground and the model's lowest point, in world units. By default the
        bunny and the cow rest on the ground (0) and the bone, which lies flat, floats 0.3 over it.
    yaw : float
        Rotation about the vertical axis, in degrees, applied before centring.
    light, light_size, light_position, light_distance, width, height, fov_y, ground_size
        See the module docstring. The default light is up and to the -x side.

    Returns
    -------
    Setup
        Meshes ``ground`` and the model (``closed`` from trimesh's ``is_watertight``).

    Raises
    ------
    ModuleNotFoundError
        When pymeshlab is not installed (``pip install "softshadows[models]"``).

    Examples
    --------
    >>> import softshadows as ss
    >>> setup = ss.scenes.load_model("bunny", width=32, height=32)  # needs pip install "softshadows[models]"
    >>> [m.name for m in setup.scene.meshes], bool(setup.occluders[0].closed)
    (['ground', 'bunny'], True)
    """
    if not isinstance(name, str) or name not in MODELS:
        raise ValueError(f"name: expected one of {sorted(MODELS)}, got {name!r}")
    size = _length("size", size)
    elevation = _MODEL_ELEVATION[name] if elevation is None else _length("elevation", elevation, allow_zero=True)
    yaw = _v.number("yaw", yaw)
    verts, faces, closed = _load_model_arrays(name)
    c, s = np.cos(np.radians(yaw)), np.sin(np.radians(yaw))
    verts = verts @ np.array([[c, 0.0, -s], [0.0, 1.0, 0.0], [s, 0.0, c]])
    lo, hi = verts.min(axis=0), verts.max(axis=0)
    scale = size / float(np.max(hi - lo))
    verts = (verts - np.array([(lo[0] + hi[0]) / 2, lo[1], (lo[2] + hi[2]) / 2])) * scale
    verts[:, 1] += elevation
    mesh = Mesh(verts, faces, closed=closed, name=name)
    return _assemble(
        name,
        [mesh],
        f"pymeshlab sample mesh {MODELS[name]} ({len(faces)} triangles, closed={closed}), "
        + ("resting on the ground." if elevation == 0 else f"{elevation:g} over the ground."),
        light=light, light_size=light_size, light_position=light_position, light_distance=light_distance,
        light_dir=(-60.0, 55.0), camera_dir=(25.0, 30.0),
        width=width, height=height, fov_y=fov_y, ground_size=ground_size,
    )


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

    from .scene import _read

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
    staged = _assemble(
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


def _model_factory(model: str):
    def factory(**options) -> Setup:
        return load_model(model, **options)

    factory.__name__ = factory.__qualname__ = model
    factory.__doc__ = f"``load_model({model!r}, **options)``: see :func:`load_model`."
    return factory


#: Scene name -> factory taking keyword-only options and returning a :class:`Setup`.
SCENES = {
    "ground_sphere": ground_sphere,
    "parallel_plates": parallel_plates,
    "columns": columns,
    "torus_knot": torus_knot,
    "fence": fence,
    "fence_mesh": fence_mesh,
    "leaves": leaves,
    "hairball": hairball,
    "sword": sword,
    **{model: _model_factory(model) for model in MODELS},
}


def get(name: str, **options) -> Setup:
    """Builds the scene registered as ``name`` in :data:`SCENES` with keyword ``options``.

    Parameters
    ----------
    name : str
        One of ``SCENES`` (``"ground_sphere"``, ``"parallel_plates"``, ``"columns"``, ``"torus_knot"``, ``"fence"``,
        ``"fence_mesh"``, ``"leaves"``, ``"hairball"``, ``"sword"``, ``"bunny"``, ``"bone"``, ``"cow"``).
    **options
        Keyword options of that factory, e.g. ``width=128, height=128``.

    Examples
    --------
    >>> import softshadows as ss
    >>> ss.scenes.get("sword", width=32, height=32).name
    'sword'
    >>> sorted(ss.scenes.SCENES)[:4]
    ['bone', 'bunny', 'columns', 'cow']
    """
    try:
        factory = SCENES[name]
    except (KeyError, TypeError):
        raise ValueError(f"name: expected one of {list(SCENES)}, got {name!r}") from None
    return factory(**options)


# ----------------------------------------------------------------------------------------------
# Textures
# ----------------------------------------------------------------------------------------------


def fence_texture(pattern: str = "slats") -> np.ndarray:
    """One tile of a fence's binary alpha texture (1 opaque, 0 hole), float32 (H, W).

    Row 0 is v = 0 (the bottom of the fence).

    Parameters
    ----------
    pattern : {"slats", "grid"}
        ``"slats"``: 64 x 16 (H x W) texels: one vertical slat 8 texels wide (columns 4-11) with a
        pointed top (rows 56-63), and two rails 6 texels high (rows 14-19 and 42-47) across the
        tile. ``"grid"``: 8 x 8 texels, opaque rows 0-1 and columns 0-1 (a wire mesh with square
        holes of 6 x 6 texels).

    Examples
    --------
    >>> import softshadows as ss
    >>> alpha = ss.scenes.fence_texture()
    >>> alpha.shape, alpha.dtype, sorted(set(alpha.ravel().tolist()))
    ((64, 16), dtype('float32'), [0.0, 1.0])
    """
    if pattern == "slats":
        h, w = 64, 16
        i = np.arange(h)[:, None]
        j = np.arange(w)[None, :]
        jc = np.abs(j + 0.5 - w / 2)  # distance of the texel centre from the slat's axis
        half = np.where(i < 56, 4.0, 4.0 * (64 - (i + 0.5)) / 8.0)  # the top tapers to a point
        slat = jc < half
        rails = ((i >= 14) & (i < 20)) | ((i >= 42) & (i < 48))
        return (slat | rails).astype(np.float32)
    if pattern == "grid":
        t = np.zeros((8, 8), dtype=np.float32)
        t[:2, :] = 1.0
        t[:, :2] = 1.0
        return t
    raise ValueError(f"pattern: expected 'slats' or 'grid', got {pattern!r}")


def leaf_texture(size: int = 32) -> np.ndarray:
    """A leaf-shaped binary alpha mask, float32 (size, size): 1 opaque, 0 transparent.

    The leaf runs along u (columns): its half-width across v is ``0.45 * sin(pi u')**0.7`` for
    the blade (u' in [0, 1] over u in [0.12, 1]) and a thin stem over u in [0, 0.12].

    Examples
    --------
    >>> import softshadows as ss
    >>> alpha = ss.scenes.leaf_texture(16)
    >>> alpha.shape, bool(0 < alpha.mean() < 1)  # a leaf's outline in a square card
    ((16, 16), True)
    """
    size = _at_least("size", size, 4)
    _v.memory("leaf_texture", 40.0 * float(size) ** 2)  # float64 coordinates and bool masks per texel
    c = (np.arange(size) + 0.5) / size
    u, v = c[None, :], c[:, None]
    blade_u = np.clip((u - 0.12) / 0.88, 0.0, 1.0)
    blade = (u >= 0.12) & (np.abs(v - 0.5) < 0.45 * np.sin(np.pi * blade_u) ** 0.7)
    stem = (u < 0.12) & (np.abs(v - 0.5) < max(0.04, 1.0 / size))
    return (blade | stem).astype(np.float32)


# ----------------------------------------------------------------------------------------------
# Assembly: ground, light and camera framing
# ----------------------------------------------------------------------------------------------


def _assemble(
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
    light_size = _length("light_size", light_size)
    light_distance = _length("light_distance", light_distance)
    width, height = _v.positive_int("width", width), _v.positive_int("height", height)
    fov_y = _v.fov_y(fov_y)
    if fov_y < MIN_FOV:
        # The camera backs away as 1 / tan(fov): at 1e-6 degrees it sits 1e8 units out, where
        # float32 rays can no longer tell the scene's pixels apart and every pixel misses.
        raise ValueError(f"fov_y: the scenes are framed in float32 and need at least {MIN_FOV:g} degrees, got {fov_y:g}")

    lo, hi = _bounds(framed).astype(np.float64)
    target = (lo + hi) / 2
    if light_position is None:
        center = target + light_distance * _direction(*light_dir)
    else:
        center = _v.vec3("light_position", light_position).astype(np.float64)
        if np.abs(center).max() > MAX_LENGTH:
            raise ValueError(f"light_position: coordinates must be within +-{MAX_LENGTH:g} world units, got {center.tolist()}")
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
        half = _length("ground_size", ground_size)
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


# ----------------------------------------------------------------------------------------------
# Geometry helpers (float64 internally; Mesh converts to float32 / uint32)
# ----------------------------------------------------------------------------------------------


def _bounds(meshes) -> np.ndarray:
    pts = np.concatenate([m.vertices[m.faces.reshape(-1)] for m in meshes if len(m.faces)])
    return np.stack([pts.min(axis=0), pts.max(axis=0)])


def _merge(parts):
    verts, faces, offset = [], [], 0
    for v, f in parts:
        verts.append(v)
        faces.append(f + offset)
        offset += len(v)
    return np.concatenate(verts), np.concatenate(faces).astype(np.uint32)


def _icosphere(subdivisions: int):
    """A unit icosphere with outward-facing triangles: 20 * 4**s faces, 10 * 4**s + 2 vertices."""
    t = (1.0 + 5.0**0.5) / 2.0
    verts = np.array(
        [[-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0], [0, -1, t], [0, 1, t],
         [0, -1, -t], [0, 1, -t], [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1]],
        dtype=np.float64,
    )
    faces = np.array(
        [[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4], [11, 10, 2],
         [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8], [3, 8, 9], [4, 9, 5],
         [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]],
        dtype=np.int64,
    )
    verts /= np.linalg.norm(verts, axis=1, keepdims=True)
    for _ in range(subdivisions):
        edges = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
        keys, inverse = np.unique(np.sort(edges, axis=1), axis=0, return_inverse=True)
        mid = verts[keys[:, 0]] + verts[keys[:, 1]]
        mid /= np.linalg.norm(mid, axis=1, keepdims=True)
        m = inverse.reshape(3, -1) + len(verts)  # midpoints of edges 01, 12, 20 of each face
        a, b, c = faces.T
        faces = np.concatenate(
            [np.stack(x, axis=1) for x in ((a, m[0], m[2]), (b, m[1], m[0]), (c, m[2], m[1]), (m[0], m[1], m[2]))]
        )
        verts = np.concatenate([verts, mid])
    return verts, faces.astype(np.uint32)


def _cylinder(center_xz, radius, y0, y1, segments):
    """A closed vertical cylinder with fan caps: 2 * segments + 2 vertices, 4 * segments faces."""
    th = np.arange(segments) * (2 * np.pi / segments)
    ring = np.stack(
        [center_xz[0] + radius * np.cos(th), np.zeros(segments), center_xz[1] + radius * np.sin(th)], axis=1
    )
    bottom, top = ring + [0.0, y0, 0.0], ring + [0.0, y1, 0.0]
    caps = np.array([[center_xz[0], y0, center_xz[1]], [center_xz[0], y1, center_xz[1]]])
    verts = np.concatenate([bottom, top, caps])
    j = np.arange(segments)
    k = (j + 1) % segments
    b, t = j, segments + j
    b1, t1 = k, segments + k
    cb, ct = np.full(segments, 2 * segments), np.full(segments, 2 * segments + 1)
    faces = np.concatenate(
        [np.stack(x, axis=1) for x in ((b, t1, b1), (b, t, t1), (ct, t1, t), (cb, b, b1))]
    )
    return verts, faces.astype(np.uint32)


def _box(lo, hi):
    """A closed axis-aligned box: 8 vertices, 12 outward-facing triangles."""
    x0, y0, z0 = lo
    x1, y1, z1 = hi
    verts = np.array(
        [[x0, y0, z0], [x1, y0, z0], [x1, y1, z0], [x0, y1, z0],
         [x0, y0, z1], [x1, y0, z1], [x1, y1, z1], [x0, y1, z1]],
        dtype=np.float64,
    )
    faces = np.array(
        [[0, 2, 1], [0, 3, 2], [4, 5, 6], [4, 6, 7], [0, 1, 5], [0, 5, 4],
         [3, 7, 6], [3, 6, 2], [0, 4, 7], [0, 7, 3], [1, 2, 6], [1, 6, 5]],
        dtype=np.uint32,
    )
    return verts, faces


def _tube(pts, tan, nrm, radius, sides, *, loop):
    """Tubes swept along S polylines of K points with frames (tan, nrm); outward-facing faces.

    ``loop=True`` joins each polyline's last point to its first (a torus topology,
    2 * K * sides faces); otherwise each tube gets two fan caps (2 * (K - 1) * sides + 2 * (sides - 2)
    faces).
    """
    s_count, k_count, _ = pts.shape
    binorm = np.cross(tan, nrm)
    th = np.arange(sides) * (2 * np.pi / sides)
    ring = np.cos(th)[:, None] * nrm[:, :, None, :] + np.sin(th)[:, None] * binorm[:, :, None, :]
    verts = (pts[:, :, None, :] + radius * ring).reshape(-1, 3)
    idx = np.arange(s_count * k_count * sides).reshape(s_count, k_count, sides)
    seg = k_count if loop else k_count - 1
    i0 = idx[:, :seg]
    i1 = np.roll(idx, -1, axis=1)[:, :seg]
    i0n, i1n = np.roll(i0, -1, axis=2), np.roll(i1, -1, axis=2)
    faces = [
        np.stack([i0, i1n, i1], axis=-1).reshape(s_count, -1, 3),
        np.stack([i0, i0n, i1n], axis=-1).reshape(s_count, -1, 3),
    ]
    if not loop:
        j = np.arange(sides - 2)
        first, last = idx[:, 0], idx[:, -1]
        start = np.stack([first[:, [0] * (sides - 2)], first[:, j + 2], first[:, j + 1]], axis=-1)
        end = np.stack([last[:, [0] * (sides - 2)], last[:, j + 1], last[:, j + 2]], axis=-1)
        faces += [start, end]
    return verts, np.concatenate(faces, axis=1).reshape(-1, 3).astype(np.uint32)


def _transport_frames(pts):
    """Tangents and parallel-transported normals along S open polylines (S, K, 3)."""
    tan = np.empty_like(pts)
    tan[:, 1:-1] = pts[:, 2:] - pts[:, :-2]
    tan[:, 0] = pts[:, 1] - pts[:, 0]
    tan[:, -1] = pts[:, -1] - pts[:, -2]
    tan /= np.linalg.norm(tan, axis=2, keepdims=True)
    nrm = np.empty_like(pts)
    t0 = tan[:, 0]
    helper = np.where(np.abs(t0[:, 1:2]) < 0.9, [[0.0, 1.0, 0.0]], [[1.0, 0.0, 0.0]])
    n = np.cross(t0, helper)
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    nrm[:, 0] = n
    for k in range(1, pts.shape[1]):
        t = tan[:, k]
        n = n - np.sum(n * t, axis=1, keepdims=True) * t
        bad = np.linalg.norm(n, axis=1) < 1e-6  # a U-turn: restart the frame
        if bad.any():
            h = np.where(np.abs(t[bad, 1:2]) < 0.9, [[0.0, 1.0, 0.0]], [[1.0, 0.0, 0.0]])
            n[bad] = np.cross(t[bad], h)
        n /= np.linalg.norm(n, axis=1, keepdims=True)
        nrm[:, k] = n
    return tan, nrm


def _unit_vectors(rng, n):
    d = rng.standard_normal((n, 3))
    return d / np.linalg.norm(d, axis=1, keepdims=True)


def _unit_ball(rng, n):
    """Uniform points in the unit ball."""
    return _unit_vectors(rng, n) * rng.uniform(0.0, 1.0, (n, 1)) ** (1.0 / 3.0)


# ----------------------------------------------------------------------------------------------
# Fence helpers
# ----------------------------------------------------------------------------------------------


def _fence_layout(pattern, panels, panel_width, panel_height, repeats, gap, elevation):
    """Panel frames (origin, u axis, v axis) in world units, the alpha tile and the repeats."""
    tile = fence_texture(pattern)
    panels = _v.positive_int("panels", panels)
    panel_width = _length("panel_width", panel_width)
    panel_height = _length("panel_height", panel_height)
    gap = _length("gap", gap, allow_zero=True)
    elevation = _length("elevation", elevation, allow_zero=True)
    if repeats is None:
        repeats = (10, 1) if pattern == "slats" else (40, 20)
    if not (isinstance(repeats, (tuple, list)) and len(repeats) == 2):
        raise ValueError(f"repeats: expected two positive integers (ku, kv), got {repeats!r}")
    reps = (_v.positive_int("repeats", repeats[0]), _v.positive_int("repeats", repeats[1]))
    # One Mesh (a few KB of Python objects and arrays) per panel.
    _v.memory("fence panels", 4096.0 * panels)
    frames = []
    for i in range(panels):
        c = i - (panels - 1) / 2
        origin = np.array([c * 0.6 * panel_width - panel_width / 2, elevation, -c * gap])
        frames.append((origin, np.array([panel_width, 0.0, 0.0]), np.array([0.0, panel_height, 0.0])))
    return frames, tile, reps


def _fence_quads(frames, tile, reps):
    """One perforated quad (2 triangles, uvs over [0, ku] x [0, kv]) per panel frame."""
    meshes = []
    uvs = np.array([[0, 0], [reps[0], 0], [reps[0], reps[1]], [0, reps[1]]], dtype=np.float32)
    faces = np.array([[0, 1, 2], [0, 2, 3]], dtype=np.uint32)
    for i, (origin, u_axis, v_axis) in enumerate(frames):
        verts = np.array([origin, origin + u_axis, origin + u_axis + v_axis, origin + v_axis])
        meshes.append(Mesh(verts, faces, uvs=uvs, alpha=tile, name=f"fence_{i}"))
    return meshes


def _merge_rectangles(mask):
    """Greedy cover of a boolean (rows, cols) mask by disjoint rectangles (i0, i1, j0, j1).

    Runs of True along each row are stacked with identical runs of the rows above.
    """
    rects, open_ = [], {}
    for i, row in enumerate(mask):
        padded = np.concatenate([[False], row, [False]])
        edges = np.flatnonzero(padded[1:] != padded[:-1])
        runs = set(zip(edges[0::2].tolist(), edges[1::2].tolist()))
        for run in list(open_):
            if run not in runs:
                rects.append((open_.pop(run), i, *run))
        for run in sorted(runs):
            open_.setdefault(run, i)
    rects += [(i0, len(mask), *run) for run, i0 in open_.items()]
    return sorted(rects)


def _rectangles_to_mesh(rects, origin, du, dv):
    """Two triangles per texel rectangle; texel (i, j) spans origin + [j, j+1] du + [i, i+1] dv."""
    r = np.asarray(rects, dtype=np.float64).reshape(-1, 4)
    i0, i1, j0, j1 = r.T
    corners = [(j0, i0), (j1, i0), (j1, i1), (j0, i1)]
    verts = np.stack([origin + a[:, None] * du + b[:, None] * dv for a, b in corners], axis=1).reshape(-1, 3)
    base = 4 * np.arange(len(r), dtype=np.uint32)[:, None, None]
    faces = (np.array([[[0, 1, 2], [0, 2, 3]]], dtype=np.uint32) + base).reshape(-1, 3)
    return verts, faces


# ----------------------------------------------------------------------------------------------
# Models
# ----------------------------------------------------------------------------------------------


def _sample_mesh_dir() -> str:
    """pymeshlab's ``tests/sample_meshes`` folder, located without importing pymeshlab."""
    spec = importlib.util.find_spec("pymeshlab")
    if spec is None:
        raise ModuleNotFoundError(
            "softshadows.scenes.load_model reads the sample meshes shipped with pymeshlab, which is not "
            'installed: pip install "softshadows[models]"',
            name="pymeshlab",
        )
    roots = list(spec.submodule_search_locations or []) or [os.path.dirname(spec.origin or "")]
    for root in roots:
        folder = os.path.join(root, "tests", "sample_meshes")
        if os.path.isdir(folder):
            return folder
    raise FileNotFoundError(
        f"pymeshlab is installed at {roots} but has no tests/sample_meshes folder; reinstall it with "
        'pip install --force-reinstall "softshadows[models]"'
    )


@functools.lru_cache(maxsize=None)
def _load_cached(path: str):
    import trimesh

    mesh = trimesh.load(path, force="mesh")  # process=True merges duplicate vertices
    verts = np.asarray(mesh.vertices, dtype=np.float64)
    faces = np.asarray(mesh.faces, dtype=np.uint32)
    verts.flags.writeable = False
    faces.flags.writeable = False
    return verts, faces, bool(mesh.is_watertight)


def _load_model_arrays(name: str):
    path = os.path.join(_sample_mesh_dir(), MODELS[name])
    if not os.path.isfile(path):
        raise FileNotFoundError(f"{MODELS[name]} is missing from pymeshlab's sample meshes ({path})")
    verts, faces, closed = _load_cached(path)
    return verts.copy(), faces.copy(), closed


# ----------------------------------------------------------------------------------------------
# Option checks
# ----------------------------------------------------------------------------------------------


#: The range of lengths (and the largest light coordinate) the factories take, in world units.
#: The occluders are about 1 unit across; beyond 1e6 float32 coordinates lose the unit's
#: precision (and near 1e38 overflow), below 1e-6 a shape's own differences vanish next to its
#: position (tangents of zero length, NaN frames).
MIN_LENGTH, MAX_LENGTH = 1e-6, 1e6
#: The smallest field of view (degrees) the factories frame a scene with.
MIN_FOV = 0.01
#: Peak bytes per triangle while building a mesh: float64 vertices and int64 faces, their
#: float32/uint32 copies in the Mesh, and the temporaries of the vectorized builders.
_BYTES_PER_TRIANGLE = 128.0


def _length(name, value, *, allow_zero: bool = False) -> float:
    """A length in world units in [MIN_LENGTH, MAX_LENGTH] (or 0 with ``allow_zero``)."""
    length = _v.positive(name, value, allow_zero=allow_zero, maximum=MAX_LENGTH)
    if 0 < length < MIN_LENGTH:
        raise ValueError(f"{name}: must be at least {MIN_LENGTH:g} world units{' (or 0)' if allow_zero else ''}, got {length:g}")
    return length


def _mesh_budget(name: str, what: str, triangles: float, vertices: float, *, extra: float = 0.0) -> None:
    """Refuses a mesh before building it: a ValueError naming the option that sizes it when its
    vertices would not fit uint32 indices, a MemoryError (as the core's) when its estimated peak
    memory exceeds ``softshadows.memory_limit()``. Counts are floats so that 4**(2**70) never
    has to be computed."""
    if vertices > 2**32 - 1:
        raise ValueError(f"{name}: the {what} mesh would have {vertices:.3g} vertices, more than uint32 indices address")
    _v.memory(f"{what} mesh", _BYTES_PER_TRIANGLE * triangles + extra)


def _at_least(name, value, low) -> int:
    value = _v.positive_int(name, value)
    if value < low:
        raise ValueError(f"{name}: expected an integer >= {low}, got {value}")
    return value


"""The procedural scenes after the five papers' test cases, and their alpha textures."""

from __future__ import annotations

import math

import numpy as np

from .. import _validate as _v
from ..scene import Mesh
from . import _checks, primitives, staging
from .setup import Setup

__all__ = ["ground_sphere", "parallel_plates", "columns", "torus_knot", "fence", "fence_mesh", "leaves", "hairball", "sword", "fence_texture", "leaf_texture"]


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
    radius = _checks.length("radius", radius)
    elevation = _checks.length("elevation", elevation, allow_zero=True)
    subdivisions = _v.nonneg_int("subdivisions", subdivisions)
    _checks.mesh_budget("subdivisions", "ground_sphere", 20.0 * 4.0 ** min(subdivisions, 64), 10.0 * 4.0 ** min(subdivisions, 64) + 2)
    verts, faces = primitives.icosphere(subdivisions)
    verts = verts * radius + np.array([0.0, elevation + radius, 0.0])
    sphere = Mesh(verts, faces, closed=True, name="sphere")
    return staging.assemble(
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
    half = _checks.length("plate_size", plate_size) / 2
    elevation = _checks.length("elevation", elevation)
    plate = Mesh(
        np.array([[-half, elevation, -half], [half, elevation, -half], [half, elevation, half], [-half, elevation, half]], np.float32),
        np.array([[0, 2, 1], [0, 3, 2]], dtype=np.uint32),
        name="plate",
    )
    return staging.assemble(
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
    radius = _checks.length("radius", radius)
    column_height = _checks.length("column_height", column_height)
    spacing = _checks.length("spacing", spacing)
    per_column = (4 * segments, 2 * segments + 2) if kind == "cylinder" else (12, 8)
    _checks.mesh_budget("n", "columns", float(n) * per_column[0], float(n) * per_column[1])
    parts = []
    for i in range(n):
        x = (i - (n - 1) / 2) * spacing
        if kind == "cylinder":
            parts.append(primitives.cylinder((x, 0.0), radius, 0.0, column_height, segments))
        else:
            parts.append(primitives.box((x - radius, 0.0, -radius), (x + radius, column_height, radius)))
    verts, faces = primitives.merge(parts)
    mesh = Mesh(verts, faces, closed=True, name="columns")
    return staging.assemble(
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
    tube_segments = _checks.at_least("tube_segments", tube_segments, 3)
    radial_segments = _checks.at_least("radial_segments", radial_segments, 3)
    radius = _checks.length("radius", radius)
    tube_radius = _checks.length("tube_radius", tube_radius)
    elevation = _checks.length("elevation", elevation, allow_zero=True)
    _checks.mesh_budget("tube_segments", "torus_knot", 2.0 * tube_segments * radial_segments, float(tube_segments) * radial_segments)

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
    verts, faces = primitives.tube(pts[None], tan[None], nrm[None], tube_radius, radial_segments, loop=True)
    verts[:, 1] += elevation + tube_radius + s  # the curve's lowest point is at y = -s
    mesh = Mesh(verts, faces, closed=True, name="torus_knot")
    return staging.assemble(
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
    return staging.assemble(
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
    _checks.mesh_budget("repeats", "fence_mesh", 2.0 * texels * len(panels_), 4.0 * texels * len(panels_), extra=80.0 * texels)
    full = np.tile(tile >= 0.5, (reps[1], reps[0]))  # rows: v texels, columns: u texels
    rects = _merge_rectangles(full)
    th, tw = tile.shape
    meshes = []
    for i, (origin, u_axis, v_axis) in enumerate(panels_):
        verts, faces = _rectangles_to_mesh(rects, origin, u_axis / (reps[0] * tw), v_axis / (reps[1] * th))
        meshes.append(Mesh(verts, faces, name=f"fence_{i}"))
    n_tri = sum(len(m.faces) for m in meshes)
    quads = _fence_quads(panels_, tile, reps)
    return staging.assemble(
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
    leaf_size = _checks.length("leaf_size", leaf_size)
    crown_radius = _checks.length("crown_radius", crown_radius)
    crown_height = _checks.length("crown_height", crown_height)
    trunk_radius = _checks.length("trunk_radius", trunk_radius)
    trunk_segments = _checks.at_least("trunk_segments", trunk_segments, 3)
    texture_size = _checks.at_least("texture_size", texture_size, 4)
    _checks.mesh_budget("n", "leaves", 2.0 * n + 4.0 * trunk_segments, 4.0 * n + 2.0 * trunk_segments + 2,
                 extra=600.0 * n + 40.0 * float(texture_size) ** 2)  # float64 leaf frames; the mask
    if crown_height <= 0.75 * crown_radius:
        raise ValueError(
            f"crown_height: must exceed the crown's vertical radius 0.75 * crown_radius = {0.75 * crown_radius:g}, "
            f"got {crown_height:g}"
        )

    radii = np.array([crown_radius, 0.75 * crown_radius, crown_radius])
    centers = primitives.unit_ball(rng, n) * radii + np.array([0.0, crown_height, 0.0])
    normals = primitives.unit_vectors(rng, n)
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
    tv, tf = primitives.cylinder((0.0, 0.0), trunk_radius, 0.0, crown_height, trunk_segments)
    trunk = Mesh(tv, tf, closed=True, name="trunk")
    return staging.assemble(
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
    sides = _checks.at_least("sides", sides, 3)
    rng = np.random.default_rng(_v.nonneg_int("seed", seed))
    radius = _checks.length("radius", radius)
    strand_radius = _checks.length("strand_radius", strand_radius)
    strand_length = _checks.length("strand_length", strand_length)
    elevation = _checks.length("elevation", elevation, allow_zero=True)
    if strand_radius >= radius:
        raise ValueError(f"strand_radius: must be below radius = {radius:g} (the strands stay inside the ball), got {strand_radius:g}")
    if strand_length / segments < 1e-9 * radius:
        # Consecutive points would coincide in float64: the tube frames would divide by zero.
        raise ValueError(
            f"strand_length: each of the {segments} segments must be at least 1e-9 x radius long, got {strand_length:g} in all"
        )
    _checks.mesh_budget("strands", "hairball", float(strands) * (2 * sides * segments + 2 * (sides - 2)),
                 float(strands) * (segments + 1) * sides)

    inner = radius - strand_radius
    pos = primitives.unit_ball(rng, strands) * (0.8 * inner)
    d = primitives.unit_vectors(rng, strands)
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
    tan, nrm = primitives.transport_frames(pts)
    verts, faces = primitives.tube(pts, tan, nrm, strand_radius, sides, loop=False)
    verts[:, 1] += elevation + radius
    mesh = Mesh(verts, faces, closed=True, name="hairball")
    return staging.assemble(
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
    length = _checks.length("blade_length", blade_length)
    w = _checks.length("blade_width", blade_width)
    t = _checks.length("blade_thickness", blade_thickness)
    tip = _checks.length("tip_height", tip_height)
    tilt = _v.number("tilt", tilt)
    if not 0.0 <= tilt <= 80.0:
        raise ValueError(f"tilt: expected degrees in [0, 80], got {tilt}")
    guard = 4 * w
    parts = [  # the tip at the origin, the hilt towards -x
        primitives.box((-length, -t / 2, -w / 2), (0.0, t / 2, w / 2)),
        primitives.box((-length - 2 * t, -t, -guard), (-length, t, guard)),
        primitives.box((-length * 1.12, -t, -w / 2), (-length - 2 * t, t, w / 2)),
    ]
    verts, faces = primitives.merge(parts)
    a = np.radians(tilt)
    rot = np.array([[np.cos(a), np.sin(a), 0.0], [-np.sin(a), np.cos(a), 0.0], [0.0, 0.0, 1.0]])
    verts = verts @ rot.T + np.array([length / 2, tip, 0.0])
    mesh = Mesh(verts, faces, closed=True, name="sword")
    return staging.assemble(
        "sword",
        [mesh],
        f"A sword, blade {length:g} long and {w:g} wide, tip {tip:g} over the ground, tilted {tilt:g} degrees "
        "(Marrs et al. 2018, Figure 10).",
        light=light, light_size=light_size, light_position=light_position, light_distance=light_distance,
        light_dir=(-120.0, 60.0), camera_dir=(20.0, 45.0),
        width=width, height=height, fov_y=fov_y, ground_size=ground_size,
    )


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
    size = _checks.at_least("size", size, 4)
    _v.memory("leaf_texture", 40.0 * float(size) ** 2)  # float64 coordinates and bool masks per texel
    c = (np.arange(size) + 0.5) / size
    u, v = c[None, :], c[:, None]
    blade_u = np.clip((u - 0.12) / 0.88, 0.0, 1.0)
    blade = (u >= 0.12) & (np.abs(v - 0.5) < 0.45 * np.sin(np.pi * blade_u) ** 0.7)
    stem = (u < 0.12) & (np.abs(v - 0.5) < max(0.04, 1.0 / size))
    return (blade | stem).astype(np.float32)


def _fence_layout(pattern, panels, panel_width, panel_height, repeats, gap, elevation):
    """Panel frames (origin, u axis, v axis) in world units, the alpha tile and the repeats."""
    tile = fence_texture(pattern)
    panels = _v.positive_int("panels", panels)
    panel_width = _checks.length("panel_width", panel_width)
    panel_height = _checks.length("panel_height", panel_height)
    gap = _checks.length("gap", gap, allow_zero=True)
    elevation = _checks.length("elevation", elevation, allow_zero=True)
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

"""The procedural test scenes: determinism, tessellation, closedness, texturing and framing."""

import dataclasses
import importlib.util

import numpy as np
import pytest
import trimesh

import softshadows as ss
from softshadows import scenes

HAVE_PYMESHLAB = importlib.util.find_spec("pymeshlab") is not None
needs_pymeshlab = pytest.mark.skipif(not HAVE_PYMESHLAB, reason='needs pip install "softshadows[models]"')

PROCEDURAL = ["ground_sphere", "parallel_plates", "columns", "torus_knot", "fence", "fence_mesh", "leaves", "hairball", "sword"]
MODELS = ["bunny", "bone", "cow"]
ALL = PROCEDURAL + [pytest.param(m, marks=needs_pymeshlab) for m in MODELS]

# Which occluder meshes are closed, by scene.
CLOSED = {
    "ground_sphere": {"sphere": True},
    "parallel_plates": {"plate": False},
    "columns": {"columns": True},
    "torus_knot": {"torus_knot": True},
    "fence": {"fence_0": False, "fence_1": False},
    "fence_mesh": {"fence_0": False, "fence_1": False},
    "leaves": {"trunk": True, "leaves": False},
    "hairball": {"hairball": True},
    "sword": {"sword": True},
    "bunny": {"bunny": True},
    "bone": {"bone": True},
    "cow": {"cow": True},
}
# Share of a 64x64 view the occluders cover at least; the sword is thin by design.
MIN_OCCLUDER_COVER = {"sword": 0.005}


def arrays(setup):
    """Every array of a setup, in a fixed order."""
    out = []
    for m in setup.scene.meshes:
        out += [m.vertices, m.faces] + [a for a in (m.uvs, m.alpha) if a is not None]
    cam, light = setup.camera, setup.light
    out += [cam.eye, cam.target, light.center] + [getattr(light, k) for k in ("u", "v") if hasattr(light, k)]
    return out


def project(camera, points):
    """Pixel coordinates (column, row) and depth of world points through a look-at pinhole camera."""
    eye, target, up = (np.asarray(a, dtype=np.float64) for a in (camera.eye, camera.target, camera.up))
    f = (target - eye) / np.linalg.norm(target - eye)
    r = np.cross(f, up)
    r /= np.linalg.norm(r)
    u = np.cross(r, f)
    d = np.asarray(points, dtype=np.float64) - eye
    z = d @ f
    ty = np.tan(np.radians(camera.fov_y) / 2)
    tx = ty * camera.width / camera.height
    col = ((d @ r) / (z * tx) + 1) / 2 * camera.width
    row = (1 - (d @ u) / (z * ty)) / 2 * camera.height
    return col, row, z


def inside(camera, points):
    col, row, z = project(camera, points)
    return (z > 0) & (col >= 0) & (col < camera.width) & (row >= 0) & (row < camera.height)


# ------------------------------------------------------------------------------------------------
# Registry and options
# ------------------------------------------------------------------------------------------------


def test_registry_lists_every_scene():
    assert set(scenes.SCENES) == set(PROCEDURAL) | set(MODELS)
    for factory in scenes.SCENES.values():
        assert callable(factory) and factory.__doc__


def test_get_passes_options_and_refuses_unknown_names():
    setup = scenes.get("columns", width=64, height=32, n=3)
    assert isinstance(setup, scenes.Setup) and setup.name == "columns"
    assert (setup.camera.width, setup.camera.height) == (64, 32)
    assert len(setup.occluders[0].faces) == 3 * 4 * 42
    with pytest.raises(ValueError, match="name: expected one of"):
        scenes.get("teapot")


def test_defaults_are_256_square_and_options_are_keyword_only():
    setup = scenes.ground_sphere()
    assert (setup.camera.width, setup.camera.height) == (256, 256)
    with pytest.raises(TypeError):
        scenes.ground_sphere(0.5)
    with pytest.raises(dataclasses.FrozenInstanceError):
        setup.name = "other"


@pytest.mark.parametrize(
    "call, match",
    [
        (lambda: scenes.columns(n=0), "n:"),
        (lambda: scenes.columns(kind="cone"), "kind:"),
        (lambda: scenes.columns(segments=2), "segments:"),
        (lambda: scenes.torus_knot(p=2, q=4), "coprime"),
        (lambda: scenes.ground_sphere(radius=-1), "radius:"),
        (lambda: scenes.fence(pattern="chainsaw"), "pattern:"),
        (lambda: scenes.fence(repeats=(0, 1)), "repeats:"),
        (lambda: scenes.leaves(seed=-1), "seed:"),
        (lambda: scenes.hairball(sides=2), "sides:"),
        (lambda: scenes.ground_sphere(light="area"), "light:"),
        (lambda: scenes.ground_sphere(light_position=(0, 0.2, 3)), "light_position:"),
        (lambda: scenes.ground_sphere(width=0), "width:"),
        (lambda: scenes.load_model("teapot"), "name:"),
    ],
)
def test_bad_options_raise_value_errors_naming_the_option(call, match):
    with pytest.raises(ValueError, match=match):
        call()


# ------------------------------------------------------------------------------------------------
# Determinism
# ------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("name", ALL)
def test_every_scene_is_deterministic(name):
    a, b = scenes.get(name, width=64, height=64), scenes.get(name, width=64, height=64)
    for x, y in zip(arrays(a), arrays(b), strict=True):
        assert x.dtype == y.dtype and np.array_equal(x, y)


@pytest.mark.parametrize("name", ["leaves", "hairball"])
def test_random_scenes_follow_their_seed(name):
    a, b, c = (scenes.get(name, seed=s, width=32, height=32) for s in (3, 3, 4))
    for x, y in zip(arrays(a), arrays(b), strict=True):
        assert np.array_equal(x, y)
    random_mesh = a.occluders[-1]
    other = c.occluders[-1]
    assert random_mesh.vertices.shape == other.vertices.shape
    assert not np.array_equal(random_mesh.vertices, other.vertices)


def test_arrays_have_the_core_dtypes():
    for name in PROCEDURAL:
        for m in scenes.get(name, width=32, height=32).scene.meshes:
            assert m.vertices.dtype == np.float32 and m.faces.dtype == np.uint32
            assert m.vertices.flags.c_contiguous and m.faces.flags.c_contiguous


# ------------------------------------------------------------------------------------------------
# Tessellation options and triangle counts
# ------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("s", [0, 1, 3])
def test_sphere_subdivisions(s):
    sphere = scenes.ground_sphere(subdivisions=s, width=32, height=32).occluders[0]
    assert len(sphere.faces) == 20 * 4**s and len(sphere.vertices) == 10 * 4**s + 2
    np.testing.assert_allclose(np.linalg.norm(sphere.vertices - [0, 1.0, 0], axis=1), 0.5, rtol=1e-5)


def test_columns_counts():
    assert len(scenes.columns().occluders[0].faces) == 840  # Sintorn et al. 2008's "columns of 840 triangles"
    assert len(scenes.columns(n=3, segments=10, width=32, height=32).occluders[0].faces) == 3 * 4 * 10
    assert len(scenes.columns(n=4, kind="box", width=32, height=32).occluders[0].faces) == 4 * 12
    bounds = scenes.columns(column_height=2.0, width=32, height=32).occluder_bounds
    assert bounds[0, 1] == 0 and bounds[1, 1] == pytest.approx(2.0)


@pytest.mark.parametrize("tube, radial", [(64, 8), (192, 16), (375, 32)])
def test_torus_knot_tessellation(tube, radial):
    knot = scenes.torus_knot(tube_segments=tube, radial_segments=radial, width=32, height=32).occluders[0]
    assert len(knot.faces) == 2 * tube * radial and len(knot.vertices) == tube * radial
    assert knot.vertices[:, 1].min() == pytest.approx(0.6, abs=0.02)  # floats `elevation` over the ground


def test_torus_knot_other_windings():
    a = scenes.torus_knot(p=3, q=2, width=32, height=32).occluders[0]
    b = scenes.torus_knot(p=2, q=3, width=32, height=32).occluders[0]
    assert len(a.faces) == len(b.faces) and not np.array_equal(a.vertices, b.vertices)


@pytest.mark.parametrize("strands, segments, sides", [(400, 8, 3), (50, 5, 4), (10, 12, 6)])
def test_hairball_counts(strands, segments, sides):
    ball = scenes.hairball(strands=strands, segments=segments, sides=sides, width=32, height=32).occluders[0]
    assert len(ball.faces) == strands * (2 * sides * segments + 2 * (sides - 2))
    centre = np.array([0, 0.4 + 0.6, 0])
    assert np.linalg.norm(ball.vertices - centre, axis=1).max() <= 0.6 + 1e-5  # inside the ball


def test_hairball_default_is_about_20k_triangles():
    assert len(scenes.hairball().occluders[0].faces) == 20_000


def test_leaves_counts():
    setup = scenes.leaves(n=250, trunk_segments=8, width=32, height=32)
    trunk, leaf = setup.occluders
    assert len(leaf.faces) == 2 * 250 and len(leaf.vertices) == 4 * 250
    assert len(trunk.faces) == 4 * 8


def test_ground_is_two_triangles_at_y0_facing_up():
    for name in PROCEDURAL:
        setup = scenes.get(name, width=32, height=32)
        g = setup.ground
        assert g.name == "ground" and len(g.faces) == 2
        assert np.all(g.vertices[:, 1] == 0)
        tri = g.vertices[g.faces].astype(np.float64)
        n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        assert np.all(n[:, 1] > 0)
        assert setup.occluder_bounds[0, 1] >= 0  # nothing below the ground


# ------------------------------------------------------------------------------------------------
# Closedness and perforation
# ------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("name", ALL)
def test_closed_flags_match_watertightness(name):
    setup = scenes.get(name, width=32, height=32)
    assert not setup.ground.closed
    assert {m.name: m.closed for m in setup.occluders} == CLOSED[name]
    for m in setup.occluders:
        tm = trimesh.Trimesh(m.vertices, m.faces, process=False)
        if m.closed:
            assert tm.is_watertight and tm.is_winding_consistent, m.name
            assert tm.volume > 0, f"{m.name}: triangles face inward"
        if m.perforated:
            assert not m.closed


@pytest.mark.parametrize("name", ["fence", "leaves"])
def test_perforated_meshes_have_uvs_and_a_binary_alpha(name):
    setup = scenes.get(name, width=32, height=32)
    perforated = [m for m in setup.occluders if m.perforated]
    assert perforated
    for m in perforated:
        assert m.uvs is not None and m.uvs.shape == (len(m.vertices), 2)
        assert set(np.unique(m.alpha).tolist()) == {0.0, 1.0}
        assert 0.1 < m.alpha.mean() < 0.9


def test_fence_uvs_repeat_the_tile():
    setup = scenes.fence(pattern="grid", repeats=(12, 5), width=32, height=32)
    for m in setup.occluders:
        assert len(m.faces) == 2
        assert m.uvs.min(axis=0).tolist() == [0, 0] and m.uvs.max(axis=0).tolist() == [12, 5]
        assert m.alpha.shape == (8, 8)


def test_leaf_uvs_span_the_mask():
    leaf = scenes.leaves(n=10, width=32, height=32).occluders[1]
    assert leaf.uvs.min() == 0 and leaf.uvs.max() == 1


# ------------------------------------------------------------------------------------------------
# The fence as perforated quads and as explicit geometry cover the same footprint
# ------------------------------------------------------------------------------------------------


def _uv_frame(quad):
    """The affine map world -> uv of a perforated quad: uv = (p - origin) @ M."""
    p = quad.vertices.astype(np.float64)
    uv = quad.uvs.astype(np.float64)
    a = np.hstack([p - p[0], np.ones((len(p), 1))])
    m, *_ = np.linalg.lstsq(a, uv - uv[0], rcond=None)
    normal = np.cross(p[1] - p[0], p[2] - p[0])
    return p[0], m[:3], uv[0], normal / np.linalg.norm(normal)


def _cross2(a, b):
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def _coverage(tris_uv, shape, texel, sub):
    """How many triangles cover each sub-texel sample point (sub x sub per texel)."""
    rows, cols = shape
    count = np.zeros((rows * sub, cols * sub), dtype=np.int32)
    offsets = (np.arange(sub) + 0.5) / sub
    for t in tris_uv:
        lo, hi = t.min(axis=0), t.max(axis=0)
        j0, j1 = int(np.floor(lo[0] / texel[0] * sub)), int(np.ceil(hi[0] / texel[0] * sub))
        i0, i1 = int(np.floor(lo[1] / texel[1] * sub)), int(np.ceil(hi[1] / texel[1] * sub))
        jj = np.arange(max(j0, 0), min(j1, cols * sub))
        ii = np.arange(max(i0, 0), min(i1, rows * sub))
        if not len(jj) or not len(ii):
            continue
        u = (jj // sub + offsets[jj % sub]) * texel[0]
        v = (ii // sub + offsets[ii % sub]) * texel[1]
        uu, vv = np.meshgrid(u, v)
        q = np.stack([uu, vv], axis=-1)
        e = [_cross2(t[(k + 1) % 3] - t[k], q - t[k]) for k in range(3)]
        within = (e[0] >= 0) & (e[1] >= 0) & (e[2] >= 0) | (e[0] <= 0) & (e[1] <= 0) & (e[2] <= 0)
        count[np.ix_(ii, jj)] += within
    return count


@pytest.mark.parametrize(
    "options",
    [dict(), dict(pattern="grid"), dict(pattern="slats", repeats=(3, 2), panels=3, panel_width=1.3)],
)
def test_fence_mesh_covers_exactly_the_opaque_texels(options):
    textured = scenes.fence(width=32, height=32, **options)
    explicit = scenes.fence_mesh(width=32, height=32, **options)
    assert len(textured.occluders) == len(explicit.occluders)
    for quad, mesh in zip(textured.occluders, explicit.occluders, strict=True):
        assert not mesh.perforated and mesh.uvs is None
        origin, m, uv0, normal = _uv_frame(quad)
        # Same plane: every explicit vertex lies in the quad's plane (an orthographic projection
        # along the quad's normal loses nothing) ...
        p = mesh.vertices.astype(np.float64)
        assert np.abs((p - origin) @ normal).max() < 1e-5
        # ... and inside the quad.
        uv = (p - origin) @ m + uv0
        ku, kv = quad.uvs.max(axis=0)
        assert uv.min() > -1e-4 and uv[:, 0].max() < ku + 1e-4 and uv[:, 1].max() < kv + 1e-4
        # The opaque footprint of the textured quad, texel by texel (the alpha tile repeated).
        h, w = quad.alpha.shape
        opaque = np.tile(quad.alpha >= 0.5, (int(kv), int(ku)))
        # Sample 3 x 3 points per texel: each opaque one covered exactly once, others never.
        count = _coverage(uv[mesh.faces.astype(np.int64)], opaque.shape, (1 / w, 1 / h), 3)
        expected = np.repeat(np.repeat(opaque, 3, axis=0), 3, axis=1).astype(np.int32)
        assert np.array_equal(count, expected)
        # And the areas agree (no slivers between sample points, no overlaps).
        t = uv[mesh.faces.astype(np.int64)]
        area = 0.5 * np.abs(_cross2(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])).sum()
        assert area == pytest.approx(opaque.sum() / (w * h), rel=1e-4)


@pytest.mark.parametrize("pattern", ["slats", "grid"])
def test_fence_and_fence_mesh_share_their_setup_and_cast_the_same_shadow(pattern):
    textured = scenes.fence(pattern=pattern, width=64, height=64)
    explicit = scenes.fence_mesh(pattern=pattern, width=64, height=64)
    for a, b in [
        (textured.camera.eye, explicit.camera.eye),
        (textured.camera.target, explicit.camera.target),
        (textured.light.center, explicit.light.center),
        (textured.light.u, explicit.light.u),
        (textured.ground.vertices, explicit.ground.vertices),
    ]:
        assert np.array_equal(a, b)
    gb = ss.gbuffer(textured.scene, textured.camera)
    assert np.array_equal(gb.mask, ss.gbuffer(explicit.scene, explicit.camera).mask)
    samples = textured.light.samples(32, pattern="poisson", seed=5)
    va = ss.ray_traced(textured.scene, textured.light, gb, samples=samples)
    vb = ss.ray_traced(explicit.scene, explicit.light, gb, samples=samples)
    hit = gb.mask
    assert np.mean((va[hit] > 0) & (va[hit] < 1)) > 0.02  # there are penumbrae to compare
    assert np.mean(va[hit] == vb[hit]) > 0.995  # identical but for rays through texel edges


def test_fence_mesh_is_far_heavier_than_the_perforated_fence():
    # Forest et al. 2009, Fig. 11: the textured fence needs 2 triangles per panel, the mesh many more.
    assert scenes.fence().scene.num_faces == 2 + 2 * 2
    assert scenes.fence_mesh(pattern="grid").scene.num_faces > 1000


# ------------------------------------------------------------------------------------------------
# Lights and cameras
# ------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("name", ALL)
def test_default_camera_sees_the_occluders_and_their_shadow(name):
    setup = scenes.get(name, width=96, height=64)
    cam, light = setup.camera, setup.light
    lo, hi = setup.occluder_bounds.astype(np.float64)
    centre = (lo + hi) / 2
    # The occluders' bounding-box centre and every occluder vertex are in the image.
    assert inside(cam, centre[None])[0]
    for m in setup.occluders:
        assert inside(cam, m.vertices).all(), m.name
    # The shadow of the occluders' centre (cast from the light's centre) is on the ground and
    # in the image too.
    lc = np.asarray(light.center, dtype=np.float64)
    assert lc[1] > hi[1]
    shadow = lc + lc[1] / (lc[1] - centre[1]) * (centre - lc)
    g = setup.ground.vertices
    assert g[:, 0].min() < shadow[0] < g[:, 0].max() and g[:, 2].min() < shadow[2] < g[:, 2].max()
    assert inside(cam, shadow[None])[0]
    # The camera is above the ground and looks down at it.
    assert cam.eye[1] > 0 and cam.target[1] < cam.eye[1]


@pytest.mark.parametrize("name", ALL)
def test_rendered_view_shows_occluders_ground_and_penumbra(name):
    setup = scenes.get(name, width=64, height=64)
    gb = ss.gbuffer(setup.scene, setup.camera)
    ground = gb.mask & (gb.face_ids < len(setup.ground.faces))  # the ground's faces come first
    occluder = gb.mask & (gb.face_ids >= len(setup.ground.faces))
    assert ground.mean() > 0.3 and occluder.mean() > MIN_OCCLUDER_COVER.get(name, 0.02)
    vis = ss.ray_traced(setup.scene, setup.light, gb, samples=16)
    assert np.mean(ground & (vis < 1)) > 0.05  # a sizeable shadow on the ground ...
    assert np.mean(ground & (vis > 0) & (vis < 1)) > 0.03  # ... with a wide penumbra


@pytest.mark.parametrize("name", PROCEDURAL)
def test_default_light_is_a_rect_light_facing_the_occluders(name):
    setup = scenes.get(name, width=32, height=32)
    light = setup.light
    assert isinstance(light, ss.RectLight)
    centre = setup.occluder_bounds.mean(axis=0)
    assert np.dot(light.normal, centre - light.center) > 0
    # Large enough for visibly soft shadows: a sizeable angle seen from the occluders.
    size = 2 * np.linalg.norm(light.u)
    assert size / np.linalg.norm(centre - light.center) > 0.15


@pytest.mark.parametrize(
    "kind, cls",
    [("rect", ss.RectLight), ("disk", ss.DiskLight), ("sphere", ss.SphereLight), ("ellipsoid", ss.EllipsoidLight),
     ("point", ss.PointLight)],
)
def test_light_kinds_and_sizes(kind, cls):
    setup = scenes.torus_knot(light=kind, light_size=0.8, width=32, height=32)
    assert isinstance(setup.light, cls)
    if kind == "rect":
        assert setup.light.area == pytest.approx(0.64, rel=1e-5)
    elif kind in ("disk", "sphere"):
        assert setup.light.radius == pytest.approx(0.4)
    elif kind == "ellipsoid":
        assert np.linalg.norm(setup.light.axes, axis=1) == pytest.approx([0.4, 0.14, 0.14], rel=1e-5)


def test_explicit_light_position_and_with_helpers():
    setup = scenes.columns(light_position=(0, 4, -2), width=32, height=32)
    np.testing.assert_array_equal(setup.light.center, np.float32([0, 4, -2]))
    small = setup.with_size(40, 30)
    assert (small.camera.width, small.camera.height) == (40, 30) and small.scene is setup.scene
    point = setup.with_light(ss.PointLight((0, 5, 0)))
    assert isinstance(point.light, ss.PointLight) and point.camera is setup.camera


# ------------------------------------------------------------------------------------------------
# Real models from pymeshlab's sample meshes
# ------------------------------------------------------------------------------------------------


@needs_pymeshlab
@pytest.mark.parametrize("name, faces", [("bunny", 56172), ("bone", 3022), ("cow", 5804)])
def test_load_model_normalizes_and_rests_on_the_ground(name, faces):
    setup = scenes.load_model(name, size=1.5, elevation=0.0, width=32, height=32)
    mesh = setup.occluders[0]
    assert setup.name == name and mesh.name == name and len(mesh.faces) == faces and mesh.closed
    lo, hi = setup.occluder_bounds
    assert lo[1] == pytest.approx(0.0, abs=1e-6)
    assert (hi - lo).max() == pytest.approx(1.5, rel=1e-5)
    assert abs(lo[0] + hi[0]) < 1e-5 and abs(lo[2] + hi[2]) < 1e-5
    raised = scenes.load_model(name, elevation=0.25, width=32, height=32)
    assert raised.occluder_bounds[0, 1] == pytest.approx(0.25, abs=1e-6)


@needs_pymeshlab
def test_load_model_does_not_write_into_the_cache():
    a = scenes.load_model("cow", yaw=90, width=32, height=32).occluders[0].vertices
    b = scenes.load_model("cow", width=32, height=32).occluders[0].vertices
    c = scenes.load_model("cow", width=32, height=32).occluders[0].vertices
    assert not np.allclose(a, b) and np.array_equal(b, c)


def test_load_model_without_pymeshlab_names_the_extra(monkeypatch):
    real = importlib.util.find_spec
    monkeypatch.setattr(
        importlib.util, "find_spec", lambda name, *args: None if name == "pymeshlab" else real(name, *args)
    )
    with pytest.raises(ModuleNotFoundError, match=r'pip install "softshadows\[models\]"'):
        scenes.load_model("bunny")
    with pytest.raises(ImportError):  # ModuleNotFoundError is an ImportError
        scenes.get("cow")

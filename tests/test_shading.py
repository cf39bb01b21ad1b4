"""Unshadowed irradiance and factored shading (shading.py): analytic formulas against numerical
integration, and the unit scale against Mitsuba renders of an unoccluded plane."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import softshadows as ss
from softshadows import shading
from softshadows.camera import Camera, GBuffer, Receivers
from softshadows.lights import DiskLight, EllipsoidLight, PointLight, RectLight, SphereLight
from softshadows.scene import Mesh, Scene


def unit(x):
    x = np.asarray(x, float)
    return x / np.linalg.norm(x)


def quadrature_rect(p, n, light, emission=None, grid=700):
    """Midpoint rule over the rectangle: E = integral L cos_r cos_l / r^2 dA."""
    s = (np.arange(grid) + 0.5) / grid * 2 - 1
    a, b = np.meshgrid(s, s)  # b varies along rows: row i of an emission texture is a band of b
    y = light.center + a[..., None] * light.u + b[..., None] * light.v
    d = y - p
    r2 = np.einsum("...i,...i", d, d)
    cos_r = np.maximum(d @ n, 0) / np.sqrt(r2)
    cos_l = np.maximum(-(d @ light.normal.astype(float)), 0) / np.sqrt(r2)
    radiance = 1.0
    if emission is not None:
        h, w = emission.shape
        i = np.minimum(((b + 1) / 2 * h).astype(int), h - 1)
        j = np.minimum(((a + 1) / 2 * w).astype(int), w - 1)
        radiance = emission[i, j]
    return light.area * np.mean(radiance * cos_r * cos_l / r2)


def quadrature_sphere(p, n, center, radius, grid=800):
    """Stratified integral of max(cos, 0) over the cone the sphere subtends."""
    axis = unit(np.asarray(center) - p)
    sin_s = radius / np.linalg.norm(np.asarray(center) - p)
    cos_s = np.sqrt(1 - sin_s**2)
    u = (np.arange(grid) + 0.5) / grid
    cos_a, phi = np.meshgrid(1 - u * (1 - cos_s), 2 * np.pi * u)
    sin_a = np.sqrt(1 - cos_a**2)
    t = unit(np.cross(axis, [0.3, 0.5, 0.8]))
    b = np.cross(axis, t)
    w = cos_a[..., None] * axis + (sin_a * np.cos(phi))[..., None] * t + (sin_a * np.sin(phi))[..., None] * b
    return 2 * np.pi * (1 - cos_s) * np.mean(np.maximum(w @ n, 0))


def quadrature_ellipsoid(p, n, light, grid=1000):
    """Stratified integral of max(cos, 0) over the directions that meet the ellipsoid, within
    the cone of its bounding sphere."""
    center, axes = light.center.astype(np.float64), light.axes.astype(np.float64)
    radius = np.linalg.norm(axes, axis=1).max()
    axis = unit(center - p)
    cos_s = np.sqrt(1 - (radius / np.linalg.norm(center - p)) ** 2)
    u = (np.arange(grid) + 0.5) / grid
    cos_a, phi = np.meshgrid(1 - u * (1 - cos_s), 2 * np.pi * u)
    sin_a = np.sqrt(1 - cos_a**2)
    t = unit(np.cross(axis, [0.3, 0.5, 0.8]))
    b = np.cross(axis, t)
    w = cos_a[..., None] * axis + (sin_a * np.cos(phi))[..., None] * t + (sin_a * np.sin(phi))[..., None] * b
    # The ray p + s w meets the unit ball in the frame where the light is one.
    inv = np.linalg.inv(axes)
    q0, dq = (p - center) @ inv, w @ inv
    qa, qb, qc = (dq * dq).sum(-1), (q0 * dq).sum(-1), q0 @ q0 - 1
    hit = (qb * qb - qa * qc >= 0) & (qb < 0)
    return 2 * np.pi * (1 - cos_s) * np.mean(np.maximum(w @ n, 0) * hit)


RECT = RectLight([0.1, -0.2, 1.5], [0.5, 0.0, 0.2], [0.0, -0.7, 0.1])  # faces mostly down

CASES = [  # (point, normal): above, off to the side, tilted, and straddling the horizon
    ([0.0, 0.0, 0.0], [0, 0, 1]),
    ([1.2, 0.7, 0.0], [0, 0, 1]),
    ([0.3, 0.1, 0.4], [0.5, -0.3, 0.6]),
    ([0.1, -0.2, 0.9], [1.0, 0.0, 0.02]),
    ([0.0, 0.3, 1.0], [0.2, 1.0, 0.1]),
]


@pytest.mark.parametrize("p, n", CASES)
def test_rect_irradiance_matches_numerical_integration(p, n):
    p, n = np.asarray(p, float), unit(n)
    e = shading.unshadowed_irradiance(p[None], n[None], RECT)[0]
    ref = quadrature_rect(p, n, RECT)
    assert ref > 1e-3  # every case receives light
    assert e == pytest.approx(ref, rel=3e-3)


def test_horizon_clipping_changes_the_answer():
    # Half of the light is below this receiver's horizon: without clipping the formula would
    # count negative cosines and give a different value.
    p, n = np.array([0.1, -0.2, 0.9]), unit([1.0, 0.0, 0.02])
    corners = shading._rect_corners(RECT.center.astype(float), RECT.u.astype(float), RECT.v.astype(float))
    heights = (corners - p) @ n
    assert heights.min() < 0 < heights.max()
    e = shading.unshadowed_irradiance(p[None], n[None], RECT)[0]
    assert e == pytest.approx(quadrature_rect(p, n, RECT), rel=3e-3)


def test_one_sided_lights_and_receivers_facing_away_get_nothing():
    pts = np.array([[0.0, 0.0, 3.0], [0.0, 0.0, 0.0], [0.1, -0.2, 1.5]])  # behind, facing away, in the plane
    normals = np.array([[0, 0, -1.0], [0, 0, -1.0], [0, 0, 1.0]])
    for light in (RECT, DiskLight(RECT.center, [0, 0, -1], 0.5)):
        np.testing.assert_array_equal(shading.unshadowed_irradiance(pts, normals, light), 0)


def test_disk_polygon_error_is_tiny():
    disk = DiskLight([0, 0, 2.0], [0, 0, -1], 0.7)
    on_axis = shading.unshadowed_irradiance(np.zeros((1, 3)), np.array([[0, 0, 1.0]]), disk)[0]
    exact = np.pi * 0.7**2 / (0.7**2 + 2.0**2)
    assert abs(on_axis / exact - 1) < 1e-5
    # Off axis and tilted: against the same formula with 16x more edges.
    p, n = np.array([[1.3, -0.4, 0.2]]), np.array([unit([0.2, 0.1, 1.0])])
    coarse = shading.unshadowed_irradiance(p, n, disk)[0]
    fine = shading._polygon_irradiance(p, n, _regular_polygon(disk, 4096)[None])[0]
    assert abs(coarse / fine - 1) < 1e-5


def _regular_polygon(disk, k):
    old = shading.DISK_EDGES
    try:
        shading.DISK_EDGES = k
        return shading._disk_polygon(disk)
    finally:
        shading.DISK_EDGES = old


@pytest.mark.parametrize(
    "center, radius, p, n",
    [
        ([0.0, 0.0, 1.0], 0.3, [0.3, 0.2, 0.0], [0, 0, 1]),  # fully above the horizon
        ([0.0, 0.0, 0.25], 0.4, [0.6, 0.0, 0.0], [0, 0, 1]),  # partly below (radius > height)
        ([0.0, 0.0, 0.25], 0.4, [1.0, 0.5, 0.0], [0, 0, 1]),
        ([0.0, 0.0, 0.25], 0.4, [1.5, 0.0, 0.0], [0, 0, 1]),
        ([0.0, 0.0, 0.25], 0.4, [0.0, 0.0, -0.5], [1, 0, 0.1]),
    ],
)
def test_sphere_irradiance_matches_numerical_integration(center, radius, p, n):
    center = np.asarray(center, float)
    light = SphereLight(center, radius)
    p, n = np.asarray(p, float), unit(n)
    cos_t, sin_s = unit(center - p) @ n, radius / np.linalg.norm(center - p)
    assert sin_s < 1
    e = shading.unshadowed_irradiance(p[None], n[None], light)[0]
    assert e > 0 and (cos_t > sin_s) == (e == pytest.approx(np.pi * sin_s**2 * cos_t))
    assert e == pytest.approx(quadrature_sphere(p, n, center, radius), rel=2e-3, abs=1e-6)


@pytest.mark.parametrize("p, n", CASES)
def test_ellipsoid_irradiance_matches_numerical_integration(p, n):
    light = EllipsoidLight([0.2, -0.1, 1.6], [[0.5, 0.1, 0.0], [-0.04, 0.2, 0.0], [0.0, 0.0, 0.12]])
    p, n = np.asarray(p, float), unit(n)
    e = shading.unshadowed_irradiance(p[None], n[None], light)[0]
    assert e == pytest.approx(quadrature_ellipsoid(p, n, light), rel=3e-3, abs=1e-6)
    # A round ellipsoid is the sphere.
    round_one = EllipsoidLight(light.center, np.eye(3) * 0.3)
    sphere = SphereLight(light.center, 0.3)
    assert shading.unshadowed_irradiance(p[None], n[None], round_one)[0] == pytest.approx(
        shading.unshadowed_irradiance(p[None], n[None], sphere)[0], rel=1e-5, abs=1e-8
    )


def test_sphere_inside_and_point_light():
    sphere = SphereLight([0, 0, 0], 1.0)
    assert shading.unshadowed_irradiance(np.zeros((1, 3)), np.array([[0, 0, 1.0]]), sphere)[0] == pytest.approx(np.pi)
    point = PointLight([0.0, 0.0, 2.0])
    pts = np.array([[0.0, 0, 0], [2.0, 0, 0], [0, 0, 3.0]])
    e = shading.unshadowed_irradiance(pts, np.tile([0, 0, 1.0], (3, 1)), point, intensity=4.0)
    np.testing.assert_allclose(e, [1.0, 4.0 * np.cos(np.pi / 4) / 8, 0.0])


def test_a_receiver_at_an_ellipsoids_centre_gets_pi_without_a_runtime_warning():
    light = EllipsoidLight([0.2, -0.1, 1.6], [[0.5, 0.1, 0.0], [-0.04, 0.2, 0.0], [0.0, 0.0, 0.12]])
    outside = np.array([[0.1, 0.3, 0.0]])
    pts = np.concatenate([[light.center, light.center + [0.05, 0, 0]], outside])
    normals = np.tile([0, 0, 1.0], (3, 1))
    with warnings.catch_warnings():
        # The centre once gave its silhouette a zero tangent: 0 / 0 in the frame, then discarded.
        warnings.simplefilter("error", RuntimeWarning)
        e = shading.unshadowed_irradiance(pts, normals, light)
    np.testing.assert_allclose(e[:2], np.pi)  # inside the light: pi L
    assert e[2] == shading.unshadowed_irradiance(outside, normals[:1], light)[0] > 0


def test_textured_rect_sums_texels():
    emission = np.array([[1.0, 0.0, 3.0], [0.5, 2.0, 0.0]])
    light = RectLight(RECT.center, RECT.u, RECT.v, emission=emission)
    for p, n in CASES[:3]:
        p, n = np.asarray(p, float), unit(n)
        e = shading.unshadowed_irradiance(p[None], n[None], light)[0]
        assert e == pytest.approx(quadrature_rect(p, n, light, emission), rel=3e-3)
    flat = RectLight(RECT.center, RECT.u, RECT.v, emission=np.full((2, 2), 0.5))
    p, n = np.zeros((1, 3)), np.array([[0, 0, 1.0]])
    assert shading.unshadowed_irradiance(p, n, flat)[0] == pytest.approx(0.5 * shading.unshadowed_irradiance(p, n, RECT)[0])


def test_direct_is_albedo_over_pi_times_irradiance_times_visibility():
    rng = np.random.default_rng(0)
    pts = np.c_[rng.uniform(-1, 1, (50, 2)), np.zeros(50)]
    normals = np.tile([0, 0, 1.0], (50, 1))
    vis = rng.uniform(size=50)
    out = shading.direct(Receivers(pts, normals), RECT, vis, 0.5, intensity=2.0)
    e = shading.unshadowed_irradiance(pts, normals, RECT)
    assert out.shape == (50,) and out.dtype == np.float32
    np.testing.assert_allclose(out, 0.5 / np.pi * 2.0 * e * vis, rtol=1e-6)
    rgb = shading.direct((pts, normals), RECT, vis, albedo=[0.2, 0.4, 0.8])
    assert rgb.shape == (50, 3)
    np.testing.assert_allclose(rgb[:, 1:], [2, 4] * rgb[:, :1], rtol=1e-6)
    np.testing.assert_allclose(rgb[:, 0], 0.2 / np.pi * e * vis, rtol=1e-6)


def test_direct_zeroes_masked_pixels_and_checks_arguments():
    gb = plane_gbuffer(camera(10, 8))
    assert (~gb.mask).any()
    out = shading.direct(gb, RECT, np.ones(gb.shape))
    assert out.shape == gb.shape and np.all(out[~gb.mask] == 0) and np.all(out[gb.mask] > 0)
    with pytest.raises(ValueError, match="visibility"):
        shading.direct(gb, RECT, np.ones((3, 3)))
    with pytest.raises(ValueError, match="visibility"):
        shading.direct(gb, RECT, np.full(gb.shape, 1.5))
    with pytest.raises(ValueError, match="albedo"):
        shading.direct(gb, RECT, np.ones(gb.shape), albedo=2.0)
    with pytest.raises(ValueError, match="normals"):
        shading.unshadowed_irradiance(np.zeros((2, 3)), np.zeros((2, 3)), RECT)


# ----------------------------------------------------------------------------- against Mitsuba

GROUND = Mesh([[-2, -2, 0], [2, -2, 0], [2, 2, 0], [-2, 2, 0]], [[0, 1, 2], [0, 2, 3]])


def camera(width=48, height=32):
    # Off-centre and looking sideways, so a mirrored or flipped image would not line up.
    return Camera(np.array([0.5, -3.0, 2.5], np.float32), np.array([0.3, 0.0, 0.0], np.float32),
                  np.array([0, 0, 1], np.float32), 50.0, width, height)


def pixel_rays(cam):
    """Unit directions through pixel centres: row 0 at the top, right = forward x up."""
    f = unit(cam.target - cam.eye)
    r = unit(np.cross(f, cam.up))
    u = np.cross(r, f)
    th = np.tan(np.radians(cam.fov_y) / 2)
    j, i = np.meshgrid(np.arange(cam.width), np.arange(cam.height))
    x = (2 * (j + 0.5) / cam.width - 1) * th * cam.width / cam.height
    y = (1 - 2 * (i + 0.5) / cam.height) * th
    d = f + x[..., None] * r + y[..., None] * u
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def plane_gbuffer(cam):
    """A G-buffer of the ground quad (z = 0, |x|, |y| < 2) by a pinhole camera: row 0 at the top,
    right = forward x up, rays through pixel centres."""
    d = pixel_rays(cam)
    t = -cam.eye[2] / d[..., 2]
    pos = cam.eye + t[..., None] * d
    mask = (t > 0) & (np.abs(pos[..., 0]) < 2) & (np.abs(pos[..., 1]) < 2)
    normals = np.broadcast_to(np.array([0, 0, 1], np.float32), pos.shape)
    return GBuffer(pos.astype(np.float32), normals.copy(), mask, np.where(mask, 0, -1), None, cam)


def sees_light(cam, light):
    """Pixels whose ray (or a neighbour's) meets a sphere light: they show the emitter."""
    if not isinstance(light, (SphereLight, EllipsoidLight)):
        return np.zeros((cam.height, cam.width), bool)
    d = pixel_rays(cam)
    oc = light.center - cam.eye
    t = np.maximum(d @ oc, 0)
    dist = np.linalg.norm(cam.eye + t[..., None] * d - light.center, axis=-1)
    return dist < 1.5 * light.extent


@pytest.mark.mitsuba
@pytest.mark.parametrize(
    "light",
    [
        RectLight([0.8, 0.5, 1.5], [0.5, 0, 0], [0, -0.3, 0.2]),
        RectLight([0.8, 0.5, 1.5], [0.5, 0, 0], [0, -0.3, 0.2], emission=np.array([[4.0, 0.0], [0.5, 1.0], [0.0, 2.0]])),
        DiskLight([-0.5, 0.5, 1.0], [0.3, -0.3, -1.0], 0.4),
        SphereLight([0.8, 0.5, 0.6], 0.3),
        EllipsoidLight([0.8, 0.5, 0.6], [[0.4, 0, 0], [0, 0.15, 0.1], [0, -0.1, 0.15]]),
        PointLight([0.5, 0.3, 1.0]),
    ],
    ids=["rect", "textured-rect", "disk", "sphere", "ellipsoid", "point"],
)
def test_direct_matches_a_mitsuba_render_of_an_unoccluded_plane(light, tmp_path, monkeypatch):
    reference = pytest.importorskip("softshadows.reference")
    monkeypatch.setenv("SOFTSHADOWS_CACHE", str(tmp_path))
    cam = camera()
    gb = plane_gbuffer(cam)
    ours = shading.direct(gb, light, np.ones(gb.shape), 0.8, intensity=1.5)
    # Mitsuba samples a mesh emitter (our ellipsoid) by area, not by solid angle: far noisier.
    spp = 4096 if isinstance(light, EllipsoidLight) else 256
    img = reference.mitsuba_render(Scene([GROUND]), light, cam, spp=spp, albedo=0.8, intensity=1.5, cache=False)
    # Pixels inside the plane (their whole footprint on it) that receive a fair amount of light.
    inner = gb.mask.copy()
    inner[1:-1, 1:-1] &= gb.mask[:-2, 1:-1] & gb.mask[2:, 1:-1] & gb.mask[1:-1, :-2] & gb.mask[1:-1, 2:]
    inner[[0, -1], :] = False
    inner[:, [0, -1]] = False
    lit = inner & (ours > 0.05 * ours.max()) & ~sees_light(cam, light)
    assert lit.sum() > 200
    ratio = img[..., 0][lit].sum() / ours[lit].sum()
    assert ratio == pytest.approx(1.0, abs=0.01)  # scale 1: same radiance and reflectance units
    per_pixel = img[..., 0][lit] / ours[lit]
    assert np.median(np.abs(per_pixel - 1)) < 0.03  # and the same picture, pixel by pixel


@pytest.mark.mitsuba
def test_mitsuba_camera_lines_up_with_the_core_gbuffer(tmp_path, monkeypatch):
    # The unit check above uses a numpy pinhole; this one uses the core's own G-buffer, so a
    # mirrored or shifted Mitsuba sensor would show up as a per-pixel mismatch.
    pytest.importorskip("softshadows._core")
    import softshadows as ss
    from softshadows import reference

    monkeypatch.setenv("SOFTSHADOWS_CACHE", str(tmp_path))
    cam = Camera.look_at([0.5, -3.0, 2.5], [0.3, 0.0, 0.0], up=(0, 0, 1), fov_y=50.0, width=48, height=32)
    light = RectLight([1.2, -0.5, 1.0], [0.3, 0, 0], [0, -0.2, 0.1])  # small and off-centre: a sharp hot spot
    gb = ss.gbuffer(Scene([GROUND]), cam)
    ours = shading.direct(gb, light, np.ones(gb.shape), 0.8)
    img = reference.mitsuba_render(Scene([GROUND]), light, cam, spp=256, cache=False)[..., 0]
    lit = gb.mask & (ours > 0.2 * ours.max())
    assert lit.sum() > 50
    assert np.median(np.abs(img[lit] / ours[lit] - 1)) < 0.03
    mirrored = ours[:, ::-1]
    assert np.median(np.abs(img[lit] / np.maximum(mirrored[lit], 1e-9) - 1)) > 0.2


def test_bent_normals_fade_faces_touching_the_terminator_and_keep_flat_ground():
    setup = ss.scenes.get("ground_sphere", width=96, height=96)
    gb = ss.gbuffer(setup.scene, setup.camera)
    vis = ss.ray_traced(setup.scene, setup.light, gb, samples=64)
    plain = ss.shading.direct(gb, setup.light, vis)
    bent = ss.shading.direct(gb, setup.light, vis, bent_normals=True, scene=setup.scene)
    ground = gb.mask & (gb.face_ids < len(setup.ground.faces))
    sphere = gb.mask & ~ground
    np.testing.assert_array_equal(bent[ground], plain[ground])
    assert np.all(bent <= plain + 1e-7)
    # Lit sphere pixels darkened by more than 10% lie nearer the shadow terminator than the rest.
    lit = sphere & (plain > 0)
    faded = lit & (bent < 0.9 * plain)
    assert 0 < faded.sum() < lit.sum()
    center = np.asarray(setup.light.center)
    to_light = center - gb.positions
    cos = np.einsum("...i,...i->...", gb.normals, to_light) / np.linalg.norm(to_light, axis=-1)
    assert np.median(cos[faded]) < np.median(cos[lit & ~faded])
    with pytest.raises(ValueError, match="scene"):
        ss.shading.direct(gb, setup.light, vis, bent_normals=True)


def test_bent_normals_blend_as_section_4_3_writes_it():
    # A hinge: a floor triangle and a wall triangle sharing the edge x = 0 (vertices 0 and 1),
    # a point light up and in front of the floor. Written out independently: at a floor point
    # with barycentrics b, I = sum b_k max(n_floor . l_k, 0), I_bend = sum b_k min over the
    # vertex's faces of max(n_f . l_k, 0), alpha = min(1, 3 I_bend), shading alpha I + (1 - alpha) I_bend.
    floor = np.array([[0, 0, -1], [0, 0, 1], [1, 0, 0]], np.float32)      # normal +y
    wall = np.array([[0, 0, -1], [0, 0, 1], [0, -1, 0]], np.float32)      # the shared edge, then down
    # Adjacent faces share vertices (indices 0 and 1), as the paper's triangles with adjacency.
    scene = ss.Scene([ss.Mesh(np.concatenate([floor, wall[2:]]), np.uint32([[0, 1, 2], [0, 3, 1]]))])
    light = ss.PointLight((2.0, 1.0, 0.3))
    camera = ss.Camera.look_at((0.6, 2.0, 0.1), (0.4, 0.0, 0.0), (0, 0, 1), 60.0, 24, 24)
    gb = ss.gbuffer(scene, camera)
    on_floor = gb.mask & (gb.face_ids == 0)
    assert on_floor.sum() > 50
    plain = ss.shading.direct(gb, light, np.ones(gb.shape))
    bent = ss.shading.direct(gb, light, np.ones(gb.shape), bent_normals=True, scene=scene)

    normals = {"floor": np.array([0, 1.0, 0]), "wall": np.cross(wall[2] - wall[0], wall[1] - wall[0])}
    normals["wall"] /= np.linalg.norm(normals["wall"])
    assert normals["wall"] @ (np.asarray(light.position) - wall[2]) < 0  # the wall faces away from the light

    def cosine(n, vertex):
        l = np.asarray(light.position, np.float64) - vertex
        return max(float(n @ l / np.linalg.norm(l)), 0.0)

    own = [cosine(normals["floor"], v) for v in floor]
    darkest = [min(cosine(normals["floor"], v), cosine(normals["wall"], v)) for v in floor[:2]] + [own[2]]
    p = gb.positions[on_floor].astype(np.float64)
    # Barycentrics of the floor points in the xz plane (the floor is y = 0).
    t = np.linalg.solve(np.array([[floor[0, 0] - floor[2, 0], floor[1, 0] - floor[2, 0]],
                                  [floor[0, 2] - floor[2, 2], floor[1, 2] - floor[2, 2]]]),
                        np.stack([p[:, 0] - floor[2, 0], p[:, 2] - floor[2, 2]]))
    b = np.stack([t[0], t[1], 1 - t[0] - t[1]], 1)
    i, i_bend = b @ own, b @ darkest
    alpha = np.minimum(1, 3 * i_bend)
    expected = plain[on_floor] * (alpha * i + (1 - alpha) * i_bend) / i
    np.testing.assert_allclose(bent[on_floor], expected, rtol=2e-4, atol=1e-7)
    assert bent[on_floor].min() < 0.5 * plain[on_floor].min()  # the floor fades towards the wall's edge

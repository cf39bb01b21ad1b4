"""Mitsuba references (reference.py) against a brute-force numpy oracle on tiny scenes.

The oracle below implements docs/design.md section 3 directly: every segment is tested against every
triangle (Moller-Trumbore in float64), perforated triangles alpha-tested at the interpolated uv.
It does not need the compiled core.
"""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("mitsuba")

from softshadows import reference  # noqa: E402
from softshadows.camera import Camera, GBuffer, Receivers  # noqa: E402
from softshadows.lights import PointLight, RectLight  # noqa: E402
from softshadows.scene import Mesh, Scene  # noqa: E402

pytestmark = pytest.mark.mitsuba


# ----------------------------------------------------------------------------- oracle


def quad(center, half_u, half_v, *, uv_scale=(1.0, 1.0), alpha=None) -> Mesh:
    c, u, w = (np.asarray(x, float) for x in (center, half_u, half_v))
    verts = [c - u - w, c + u - w, c + u + w, c - u + w]
    su, sv = uv_scale
    uvs = [[0, 0], [su, 0], [su, sv], [0, sv]]
    return Mesh(verts, [[0, 1, 2], [0, 2, 3]], uvs=uvs if alpha is not None else None, alpha=alpha)


def texel_opaque(alpha, uv):
    """Our convention: alpha[i, j] covers u in [j/W, (j+1)/W), v in [i/H, (i+1)/H), repeat, nearest."""
    h, w = alpha.shape
    f = uv - np.floor(uv)
    j = np.minimum((f[..., 0] * w).astype(int), w - 1)
    i = np.minimum((f[..., 1] * h).astype(int), h - 1)
    return alpha[i, j] >= 0.5


def segment_hits(o, d, tri):
    """Moller-Trumbore: barycentrics and t of (K,) segments o + t d against (T, 3, 3) triangles."""
    v0, e1, e2 = tri[:, 0], tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    pvec = np.cross(d[:, None, :], e2[None])
    det = np.einsum("kti,ti->kt", pvec, e1)
    ok = np.abs(det) > 1e-14
    inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
    tvec = o[:, None, :] - v0[None]
    b1 = np.einsum("kti,kti->kt", tvec, pvec) * inv
    qvec = np.cross(tvec, e1[None])
    b2 = np.einsum("ki,kti->kt", d, qvec) * inv
    t = np.einsum("kti,ti->kt", qvec, e2) * inv
    inside = ok & (b1 >= 0) & (b2 >= 0) & (b1 + b2 <= 1)
    return inside, t, b1, b2


def brute_force_visibility(scene, points, normals, samples, eps):
    points, samples = np.asarray(points, float), np.asarray(samples, float)
    n = np.asarray(normals, float)
    n = n / np.linalg.norm(n, axis=1, keepdims=True)
    origins = points + eps * n
    vis = np.zeros(len(points))
    for y in samples:
        d = y - origins  # segment parameter t in (0, 1 - 1e-6) in units of d
        blocked = np.zeros(len(points), bool)
        for mesh in scene.meshes:
            tri = mesh.vertices[mesh.faces].astype(float)
            inside, t, b1, b2 = segment_hits(origins, d, tri)
            hit = inside & (t > 0) & (t < 1 - 1e-6)
            if mesh.alpha is not None:
                uv = mesh.uvs[mesh.faces].astype(float)  # (T, 3, 2)
                interp = ((1 - b1 - b2)[..., None] * uv[None, :, 0] + b1[..., None] * uv[None, :, 1]
                          + b2[..., None] * uv[None, :, 2])
                hit &= texel_opaque(mesh.alpha, interp)
            blocked |= hit.any(axis=1)
        front = np.einsum("ki,ki->k", y - points, n) > 0
        vis += front & ~blocked
    return vis / len(samples)


# ----------------------------------------------------------------------------- fixtures

GROUND = quad([0, 0, 0], [2, 0, 0], [0, 2, 0])
LIGHT = RectLight([0.1, -0.2, 2.0], [0.6, 0.1, 0.0], [0.0, -0.5, 0.05])  # faces down (u x v has z < 0)


@pytest.fixture(autouse=True)
def cache_dir(tmp_path, monkeypatch):
    """Every test gets an empty cache, so no test reads another's results."""
    monkeypatch.setenv("SOFTSHADOWS_CACHE", str(tmp_path / "cache"))
    return tmp_path / "cache"


def light_samples(n, seed=0):
    rng = np.random.default_rng(seed)
    a, b = rng.uniform(-1, 1, (2, n))
    return LIGHT.center + a[:, None] * LIGHT.u + b[:, None] * LIGHT.v


def ground_receivers(k, seed=1, *, extent=1.6):
    rng = np.random.default_rng(seed)
    pts = np.c_[rng.uniform(-extent, extent, (k, 2)), np.zeros(k)]
    normals = np.tile([0.0, 0.0, 1.0], (k, 1))
    # A few tilted normals put some samples behind the tangent plane.
    normals[: k // 5] = np.c_[rng.uniform(-2, 2, (k // 5, 2)), np.ones(k // 5)]
    return pts, normals


def assert_matches_oracle(vis, ref, n_samples):
    diff = np.abs(vis - ref)
    # Only samples within float precision of an edge may differ: one sample at most, rarely.
    assert diff.max() <= 1.0 / n_samples + 1e-6, diff.max()
    assert np.mean(diff > 1e-6) < 0.01, np.mean(diff > 1e-6)


# ----------------------------------------------------------------------------- visibility


def test_variant_is_selected_lazily_and_usable():
    assert reference.variant() in ("llvm_ad_rgb", "scalar_rgb")
    assert reference.variant() == reference.variant()  # chosen once, then stable


def test_opaque_quad_matches_brute_force():
    scene = Scene([GROUND, quad([0.2, 0.1, 1.0], [0.5, 0.2, 0.0], [-0.1, 0.4, 0.1])])
    pts, normals = ground_receivers(500)
    samples = light_samples(32)
    vis = reference.mitsuba_visibility(scene, LIGHT, Receivers(pts, normals), samples, cache=False)
    ref = brute_force_visibility(scene, pts, normals, samples, scene.epsilon)
    assert vis.shape == (500,) and vis.dtype == np.float32
    assert 0.05 < np.mean(ref < 1) < 0.95  # the scene has both shadow and light
    assert_matches_oracle(vis, ref, 32)


def test_perforated_quads_match_brute_force_and_not_a_flipped_texture():
    # Asymmetric textures (no flip maps them onto themselves), values either side of 0.5,
    # uvs past 1 (repeat) and two layers, so rays step through several transparent texels.
    a1 = np.array([[0.9, 0.1, 0.1, 0.1], [0.2, 0.0, 0.7, 0.5], [1.0, 0.6, 0.3, 0.0]])
    a2 = np.array([[0.0, 1.0], [0.0, 0.0], [0.49, 0.0]])
    fence = quad([0.0, 0.0, 0.8], [0.9, 0.0, 0.0], [0.0, 0.8, 0.0], uv_scale=(2.0, 1.0), alpha=a1)
    top = quad([0.1, 0.0, 1.2], [0.7, 0.1, 0.0], [0.0, 0.7, 0.05], uv_scale=(1.0, 3.0), alpha=a2)
    scene = Scene([GROUND, fence, top])
    pts, normals = ground_receivers(400)
    samples = light_samples(24, seed=3)
    vis = reference.mitsuba_visibility(scene, LIGHT, Receivers(pts, normals), samples, cache=False)
    ref = brute_force_visibility(scene, pts, normals, samples, scene.epsilon)
    assert_matches_oracle(vis, ref, 24)
    flipped = Scene([GROUND, Mesh(fence.vertices, fence.faces, uvs=fence.uvs, alpha=a1[::-1]),
                     Mesh(top.vertices, top.faces, uvs=top.uvs, alpha=a2[::-1])])
    wrong = brute_force_visibility(flipped, pts, normals, samples, scene.epsilon)
    assert np.abs(vis - wrong).mean() > 0.05  # the comparison above can tell a v flip apart


@pytest.mark.parametrize("gap", [1e-4, 1e-5])
def test_opaque_texel_just_behind_a_transparent_one_blocks(gap):
    # Touching leaves: a fully transparent quad and, `gap` above it, a second perforated quad
    # (a checkerboard). Rays crossing the first must still be alpha-tested against the second:
    # stepping past a transparent hit by Mitsuba's spawn offset (~1.8e-4 here) jumped over it.
    clear = quad([0, 0, 1.0], [1.5, 0, 0], [0, 1.5, 0], alpha=np.zeros((2, 2)))
    checker = quad([0, 0, 1.0 + gap], [1.5, 0, 0], [0, 1.5, 0], uv_scale=(3.0, 3.0), alpha=np.array([[1.0, 0], [0, 1]]))
    scene = Scene([GROUND, clear, checker])
    pts, normals = ground_receivers(300)
    samples = light_samples(16, seed=4)
    vis = reference.mitsuba_visibility(scene, LIGHT, Receivers(pts, normals), samples, cache=False)
    ref = brute_force_visibility(scene, pts, normals, samples, scene.epsilon)
    assert 0.2 < ref.mean() < 0.8  # the checker blocks about half the rays
    assert_matches_oracle(vis, ref, 16)


def test_fully_transparent_mesh_casts_no_shadow_and_opaque_alpha_does():
    pts, normals = ground_receivers(200)
    samples = light_samples(16)
    clear = quad([0, 0, 1.0], [1.5, 0, 0], [0, 1.5, 0], alpha=np.zeros((2, 2)))
    solid = quad([0, 0, 1.0], [1.5, 0, 0], [0, 1.5, 0], alpha=np.ones((2, 2)))
    rx = Receivers(pts, normals)
    unoccluded = reference.mitsuba_visibility(Scene([GROUND]), LIGHT, rx, samples, cache=False)
    through = reference.mitsuba_visibility(Scene([GROUND, clear]), LIGHT, rx, samples, cache=False)
    blocked = reference.mitsuba_visibility(Scene([GROUND, solid]), LIGHT, rx, samples, cache=False)
    np.testing.assert_array_equal(through, unoccluded)
    assert unoccluded.mean() > 0.5
    np.testing.assert_array_equal(blocked, np.zeros_like(blocked))


def test_samples_behind_the_tangent_plane_count_as_occluded():
    pts = np.array([[0.0, 0.0, 0.0], [0.5, 0.5, 0.0], [0.0, 0.0, 0.5]])
    normals = np.array([[0.0, 0.0, -1.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])
    samples = np.array([[-1.0, 0.0, 1.0], [1.0, 0.0, 1.0], [2.0, 0.0, 1.0], [-2.0, 0.0, 1.0]])
    vis = reference.mitsuba_visibility(Scene([GROUND]), LIGHT, (pts, normals), samples, cache=False)
    np.testing.assert_allclose(vis, [0.0, 1.0, 0.5])


def test_sample_order_is_a_curve_remembered_per_sample_set():
    # Hilbert order on a 4 x 4 grid of samples: consecutive samples are grid neighbours.
    grid = np.array([[x, 2.0, z] for x in range(4) for z in range(4)], np.float32)
    order = reference._coherent_order(grid)
    assert sorted(order) == list(range(16))
    steps = np.abs(np.diff(grid[order][:, [0, 2]], axis=0)).sum(axis=1)
    assert np.all(steps == 1)
    kept = reference._remembered_order(grid.tobytes(), grid.shape, grid.dtype.str)
    np.testing.assert_array_equal(kept, order)
    assert reference._remembered_order(grid.tobytes(), grid.shape, grid.dtype.str) is kept
    assert not kept.flags.writeable
    # Other samples, or the same values in another type, are not taken for these.
    for other in (grid[::-1].copy(), grid.astype(np.float64)[::-1].copy()):
        np.testing.assert_array_equal(reference._remembered_order(other.tobytes(), other.shape, other.dtype.str),
                                      reference._coherent_order(other))


def test_gbuffer_input_keeps_its_shape_and_zeroes_masked_pixels():
    h, w = 6, 5
    rng = np.random.default_rng(2)
    pos = np.zeros((h, w, 3), np.float32)
    pos[..., :2] = rng.uniform(-1, 1, (h, w, 2))
    nrm = np.zeros((h, w, 3), np.float32)
    nrm[..., 2] = 1
    mask = rng.uniform(size=(h, w)) < 0.7
    pos[~mask] = np.nan  # garbage where nothing was hit must be ignored
    cam = Camera(np.zeros(3, np.float32), np.ones(3, np.float32), np.array([0, 0, 1], np.float32), 45.0, w, h)
    gb = GBuffer(pos, nrm, mask, np.where(mask, 0, -1), None, cam)
    vis = reference.mitsuba_visibility(Scene([GROUND]), LIGHT, gb, light_samples(8), cache=False)
    assert vis.shape == (h, w) and vis.dtype == np.float32
    assert np.all(vis[~mask] == 0) and np.all(vis[mask] == 1)


def test_point_light_hard_shadow_edge():
    scene = Scene([GROUND, quad([0, 0, 1.0], [0.5, 0, 0], [0, 0.5, 0])])
    light = PointLight([0.0, 0.0, 2.0])
    # The quad's shadow from a point at height 2 is the square |x|, |y| < 1 on the ground.
    pts = np.array([[0.9, 0, 0], [1.1, 0, 0], [0, -0.95, 0], [0, -1.05, 0]])
    vis = reference.mitsuba_visibility(scene, light, (pts, np.tile([0, 0, 1.0], (4, 1))), light.position[None], cache=False)
    np.testing.assert_array_equal(vis, [0, 1, 0, 1])


def test_epsilon_controls_self_shadowing_of_a_receiver_inside_a_thin_slab():
    # A receiver 1e-3 below a ceiling quad: an offset of 1e-2 along its normal starts the ray
    # above the quad, so nothing blocks it; the default offset (1e-4 x the diagonal) does not.
    scene = Scene([GROUND, quad([0, 0, 1.0], [0.3, 0, 0], [0, 0.3, 0])])
    pts, normals = np.array([[0.0, 0.0, 0.999]]), np.array([[0.0, 0.0, 1.0]])
    samples = light_samples(8)
    default = reference.mitsuba_visibility(scene, LIGHT, (pts, normals), samples, cache=False)
    large = reference.mitsuba_visibility(scene, LIGHT, (pts, normals), samples, epsilon=1e-2, cache=False)
    assert default[0] == 0 and large[0] == 1


def test_bad_arguments_name_themselves():
    scene = Scene([GROUND])
    rx = Receivers(np.zeros((2, 3)), np.tile([0, 0, 1.0], (2, 1)))
    with pytest.raises(ValueError, match="samples"):
        reference.mitsuba_visibility(scene, LIGHT, rx, np.zeros((4, 2)))
    with pytest.raises(ValueError, match="receivers"):
        reference.mitsuba_visibility(scene, LIGHT, np.zeros((2, 3)), light_samples(4))
    with pytest.raises(ValueError, match="scene"):
        reference.mitsuba_visibility([GROUND], LIGHT, rx, light_samples(4))
    with pytest.raises(ValueError, match="epsilon"):
        reference.mitsuba_visibility(scene, LIGHT, rx, light_samples(4), epsilon=-1)


# ----------------------------------------------------------------------------- cache


def test_cache_hit_returns_the_stored_array_without_tracing(cache_dir, monkeypatch):
    scene = Scene([GROUND, quad([0, 0, 1.0], [0.5, 0, 0], [0, 0.5, 0])])
    pts, normals = ground_receivers(100)
    rx = Receivers(pts, normals)
    first = reference.mitsuba_visibility(scene, LIGHT, rx, light_samples(8))
    files = sorted(cache_dir.glob("visibility-*.npz"))
    assert len(files) == 1
    with np.load(files[0]) as entry:
        np.testing.assert_array_equal(entry["value"], first)
        assert str(entry["key"]) == files[0].stem

    def fail(*args, **kwargs):
        raise AssertionError("a cache hit must not trace rays")

    monkeypatch.setattr(reference, "_tracer", fail)
    second = reference.mitsuba_visibility(scene, LIGHT, rx, light_samples(8))
    np.testing.assert_array_equal(second, first)
    assert second.shape == first.shape and second.dtype == first.dtype
    with pytest.raises(AssertionError, match="cache hit"):  # other samples: another key, a miss
        reference.mitsuba_visibility(scene, LIGHT, rx, light_samples(8, seed=5))
    with pytest.raises(AssertionError, match="cache hit"):  # cache=False never reads
        reference.mitsuba_visibility(scene, LIGHT, rx, light_samples(8), cache=False)


def test_cache_key_depends_on_every_input():
    scene = Scene([GROUND])
    rx = Receivers(*ground_receivers(10))
    s = light_samples(4)
    base = reference._cache_key("visibility", scene, LIGHT, rx.points, rx.normals, rx.mask, s, 1e-3, None)
    other_light = RectLight(LIGHT.center, LIGHT.u, -LIGHT.v)
    other_scene = Scene([quad([0, 0, 0], [2, 0, 0], [0, 2.001, 0])])
    variants = [
        reference._cache_key("visibility", scene, other_light, rx.points, rx.normals, rx.mask, s, 1e-3, None),
        reference._cache_key("visibility", other_scene, LIGHT, rx.points, rx.normals, rx.mask, s, 1e-3, None),
        reference._cache_key("visibility", scene, LIGHT, rx.points + 1, rx.normals, rx.mask, s, 1e-3, None),
        reference._cache_key("visibility", scene, LIGHT, rx.points, rx.normals, rx.mask, s[:3], 1e-3, None),
        reference._cache_key("visibility", scene, LIGHT, rx.points, rx.normals, rx.mask, s, 2e-3, None),
    ]
    assert base == reference._cache_key("visibility", scene, LIGHT, rx.points, rx.normals, rx.mask, s, 1e-3, None)
    assert len({base, *variants}) == 6


def test_cache_key_holds_every_light_attribute():
    from softshadows.lights import EllipsoidLight

    scene, rx, s = Scene([GROUND]), Receivers(*ground_receivers(10)), light_samples(4)
    keys = {reference._cache_key("visibility", scene, EllipsoidLight([0, 0, 3], np.diag(d)), rx.points, rx.normals, rx.mask, s, 1e-3, None)
            for d in ([0.5, 0.5, 0.5], [0.5, 0.2, 0.5])}
    assert len(keys) == 2


def small_case():
    scene = Scene([GROUND, quad([0, 0, 1.0], [0.5, 0, 0], [0, 0.5, 0])])
    return scene, Receivers(*ground_receivers(100)), light_samples(8)


@pytest.mark.parametrize("entry", ["wrong shape", "wrong dtype", "nan", "out of range", "other key", "empty file", "not a zip"])
def test_a_cache_entry_that_is_not_what_its_key_promises_is_recomputed(cache_dir, entry):
    scene, rx, s = small_case()
    truth = reference.mitsuba_visibility(scene, LIGHT, rx, s, cache=False)
    points, normals, mask = reference._receiver_arrays(rx)
    key = reference._cache_key("visibility", scene, LIGHT, points, normals, mask, reference._light_samples(LIGHT, s), scene.epsilon, None)
    path = reference._cache_path(key)
    path.parent.mkdir(parents=True)
    key, value = path.stem, truth.copy()
    if entry == "wrong shape":
        value = value[:10]
    elif entry == "wrong dtype":
        value = value.astype(np.float64)
    elif entry == "nan":
        value[3] = np.nan
    elif entry == "out of range":
        value[3] = 2.0
    elif entry == "other key":
        key, value = "visibility-0000", 1 - value
    if entry == "empty file":
        path.write_bytes(b"")
    elif entry == "not a zip":
        np.save(path.with_suffix(".tmp.npy"), value)
        path.with_suffix(".tmp.npy").rename(path)
    else:
        with open(path, "wb") as f:
            np.savez(f, key=np.array(key), value=value)
    with pytest.warns(RuntimeWarning, match="ignoring the reference cache entry"):
        again = reference.mitsuba_visibility(scene, LIGHT, rx, s)
    np.testing.assert_array_equal(again, truth)
    # The recomputed entry replaced the bad one and now hits.
    np.testing.assert_array_equal(reference.mitsuba_visibility(scene, LIGHT, rx, s), truth)


def test_threads_writing_one_cache_entry_never_collide(cache_dir):
    from concurrent.futures import ThreadPoolExecutor

    value = np.linspace(0, 1, 1000, dtype=np.float32)
    with ThreadPoolExecutor(8) as pool:
        list(pool.map(lambda _: reference._cache_write("visibility-shared", value), range(64)))
    assert [p.name for p in cache_dir.iterdir()] == ["visibility-shared.npz"]
    np.testing.assert_array_equal(reference._cache_read("visibility-shared", value.shape, unit=True), value)


def test_an_unwritable_cache_folder_fails_before_any_work(tmp_path, monkeypatch):
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    monkeypatch.setenv("SOFTSHADOWS_CACHE", str(blocker / "reference"))

    def fail(*args, **kwargs):
        raise AssertionError("no reference may be computed before the cache folder is checked")

    monkeypatch.setattr(reference, "_tracer", fail)
    scene, rx, s = small_case()
    with pytest.raises(OSError, match=str(blocker)):
        reference.mitsuba_visibility(scene, LIGHT, rx, s)


def test_threads_making_the_first_mitsuba_calls_all_succeed():
    # A fresh process: four threads ask for the variant and a cache key at once.
    import subprocess
    import sys

    code = """
import threading, numpy as np
from softshadows import reference
from softshadows.lights import RectLight
from softshadows.scene import Mesh, Scene
ground = Mesh(np.float32([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]]), np.uint32([[0, 1, 2], [0, 2, 3]]))
light = RectLight([0, 0, 3], [0.5, 0, 0], [0, 0.5, 0])
errors, barrier = [], threading.Barrier(4)
def call():
    barrier.wait()
    try:
        reference._cache_key("visibility", Scene([ground]), light, np.zeros(3))
    except Exception as exc:
        errors.append(repr(exc))
threads = [threading.Thread(target=call) for _ in range(4)]
[t.start() for t in threads]; [t.join() for t in threads]
print(errors)
"""
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0 and out.stdout.strip() == "[]", out.stdout + out.stderr


# ----------------------------------------------------------------------------- scene dict and renders


def test_mitsuba_scene_mask_opacity_follows_our_uv_convention():
    mi = reference._mitsuba()
    alpha = np.array([[1.0, 0, 0, 0], [0, 0, 1, 0.6], [1, 0.3, 1, 0]])
    occ = quad([0.5, 0.5, 1.0], [0.5, 0, 0], [0, 0.5, 0], alpha=alpha)
    scene = mi.load_dict(reference.mitsuba_scene(Scene([occ]), LIGHT))
    xy = np.random.default_rng(0).uniform(0.01, 0.99, (300, 2))
    if not mi.variant().startswith("llvm"):
        pytest.skip("needs the vectorized llvm_ad_rgb variant (install libllvm19); scalar_rgb traces one ray per call")
    o = np.c_[xy, np.full(len(xy), 1.5)].T.astype(np.float32)
    si = scene.ray_intersect(mi.Ray3f(mi.Point3f(o), mi.Vector3f(0, 0, -1)))
    assert np.all(np.asarray(si.is_valid()))
    opacity = 1 - np.asarray(si.bsdf().eval_null_transmission(si))[0]
    np.testing.assert_array_equal(opacity, texel_opaque(alpha, xy).astype(float))


def test_rect_light_emits_toward_u_cross_v():
    down = RectLight([0, 0, 1.0], [0.3, 0, 0], [0, -0.3, 0])
    up = RectLight([0, 0, 1.0], [0.3, 0, 0], [0, 0.3, 0])
    # The camera is below the light's plane: it sees the ground and the light's underside.
    cam = Camera(np.array([0, -2.5, 0.8], np.float32), np.zeros(3, np.float32), np.array([0, 0, 1], np.float32), 40.0, 16, 12)
    lit = reference.mitsuba_render(Scene([GROUND]), down, cam, spp=16, cache=False)
    dark = reference.mitsuba_render(Scene([GROUND]), up, cam, spp=16, cache=False)
    assert lit.shape == (12, 16, 3) and lit.dtype == np.float32
    assert lit.mean() > 0.005 and dark.max() == 0


def test_volpath_render_sees_and_lights_through_transparent_texels():
    # A fully transparent quad in view and between the light and the ground must change nothing;
    # a fully opaque one must render like the same quad without a texture.
    cam = Camera(np.array([0, -1.0, 3.0], np.float32), np.zeros(3, np.float32), np.array([0, 1, 0], np.float32), 50.0, 24, 24)
    light = RectLight([0.0, 2.0, 2.0], [0.5, 0, 0], [0, -0.3, 0.3])  # faces -y and down, out of view
    clear = quad([0, 0, 1.0], [0.6, 0, 0], [0, 0.6, 0], alpha=np.zeros((2, 2)))
    solid = quad([0, 0, 1.0], [0.6, 0, 0], [0, 0.6, 0], alpha=np.ones((2, 2)))
    kw = dict(spp=128, cache=False)
    bare = reference.mitsuba_render(Scene([GROUND]), light, cam, integrator="volpath", **kw)
    through = reference.mitsuba_render(Scene([GROUND, clear]), light, cam, **kw)  # auto: volpath
    blocked = reference.mitsuba_render(Scene([GROUND, solid]), light, cam, **kw)
    plain = reference.mitsuba_render(Scene([GROUND, Mesh(solid.vertices, solid.faces)]), light, cam, **kw)
    assert abs(through.mean() / bare.mean() - 1) < 0.03
    assert abs(blocked.mean() / plain.mean() - 1) < 0.03
    assert abs(plain.mean() / bare.mean() - 1) > 0.1  # the quad does change the picture
    path = reference.mitsuba_render(Scene([GROUND, clear]), light, cam, integrator="path", **kw)
    assert path.mean() < 0.9 * bare.mean()  # documented: path treats mask BSDFs as opaque


def test_render_cache_and_seed(cache_dir):
    cam = Camera(np.array([0, -2.5, 2.0], np.float32), np.zeros(3, np.float32), np.array([0, 0, 1], np.float32), 40.0, 8, 8)
    light = RectLight([0, 0, 1.0], [0.3, 0, 0], [0, -0.3, 0])
    a = reference.mitsuba_render(Scene([GROUND]), light, cam, spp=4)
    b = reference.mitsuba_render(Scene([GROUND]), light, cam, spp=4)
    c = reference.mitsuba_render(Scene([GROUND]), light, cam, spp=4, seed=1)
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, c)
    assert len(list(cache_dir.glob("render-*.npz"))) == 2
    with pytest.raises(ValueError, match="integrator"):
        reference.mitsuba_render(Scene([GROUND]), light, cam, integrator="bdpt")


def test_scalar_variant_fallback_gives_the_same_bits(tmp_path):
    # The variant is process-global, so the scalar run happens in a child process.
    import json
    import os
    import subprocess
    import sys

    a1 = [[0.9, 0.1, 0.1, 0.1], [0.2, 0.0, 0.7, 0.5], [1.0, 0.6, 0.3, 0.0]]
    code = f"""
import json, numpy as np
from softshadows import reference
from softshadows.scene import Mesh, Scene
from softshadows.lights import RectLight
quad = lambda v, **kw: Mesh(v, [[0, 1, 2], [0, 2, 3]], **kw)
scene = Scene([quad([[-2, -2, 0], [2, -2, 0], [2, 2, 0], [-2, 2, 0]]),
               quad([[-0.9, -0.8, 0.8], [0.9, -0.8, 0.8], [0.9, 0.8, 0.8], [-0.9, 0.8, 0.8]],
                    uvs=[[0, 0], [2, 0], [2, 1], [0, 1]], alpha=np.array({a1})),
               quad([[-3, -3, 2.6], [3, -3, 2.6], [3, 3, 2.6], [-3, 3, 2.6]])])
light = RectLight({LIGHT.center.tolist()}, {LIGHT.u.tolist()}, {LIGHT.v.tolist()})
pts, normals, samples = (np.array(x) for x in json.loads(input()))
vis = reference.mitsuba_visibility(scene, light, (pts, normals), samples, cache=False, progress=False)
print(json.dumps([reference.variant(), vis.tolist()]))
"""
    pts, normals = ground_receivers(60)
    samples = light_samples(8)
    env = dict(os.environ, SOFTSHADOWS_MITSUBA_VARIANT="scalar_rgb", PYTHONPATH=os.pathsep.join(sys.path))
    out = subprocess.run([sys.executable, "-c", code], input=json.dumps([pts.tolist(), normals.tolist(), samples.tolist()]),
                         capture_output=True, text=True, env=env, timeout=120)
    assert out.returncode == 0, out.stderr
    used, scalar = json.loads(out.stdout.strip().splitlines()[-1])
    assert used == "scalar_rgb"
    fence = quad([0.0, 0.0, 0.8], [0.9, 0.0, 0.0], [0.0, 0.8, 0.0], uv_scale=(2.0, 1.0), alpha=np.array(a1))
    ceiling = quad([0, 0, 2.6], [3, 0, 0], [0, 3, 0])  # beyond the light: blocks no segment
    scene = Scene([GROUND, fence, ceiling])
    here = reference.mitsuba_visibility(scene, LIGHT, (pts, normals), samples, cache=False)
    np.testing.assert_array_equal(np.float32(scalar), here)
    assert 0 < here.mean() < 1


def test_rays_past_the_alpha_step_limit_count_as_blocked_with_a_warning(monkeypatch):
    layers = [quad([0, 0, 0.5 + 0.01 * k], [1.5, 0, 0], [0, 1.5, 0], alpha=np.zeros((1, 1))) for k in range(6)]
    scene = Scene([GROUND, *layers])
    rx = Receivers(*ground_receivers(20))
    samples = light_samples(4)
    free = reference.mitsuba_visibility(scene, LIGHT, rx, samples, cache=False)
    assert free.mean() > 0.5  # six transparent layers: everything passes
    monkeypatch.setattr(reference, "MAX_ALPHA_STEPS", 5)
    with pytest.warns(RuntimeWarning, match="transparent texels"):
        limited = reference.mitsuba_visibility(scene, LIGHT, rx, samples, cache=False)
    np.testing.assert_array_equal(limited, 0)


def vectorized_tracer(scene):
    tracer = reference._tracer(scene)
    if tracer.dr is None:
        pytest.skip("only Mitsuba's vectorized llvm_ad_rgb variant builds the rays in Dr.Jit; without libllvm19 "
                    "it falls back to scalar_rgb, whose rays are built in numpy instead: install libllvm19 "
                    "(scripts/test.sh and CI do) to run this test")
    return tracer


@pytest.mark.parametrize("scale", [1.0, 1e-3, 1e4])
def test_rays_built_in_drjit_are_the_numpy_rays_bit_for_bit(scale):
    # The kernel sets its rays up from the receivers and samples; the scalar variant (and the
    # bench's bare ray_test) set them up in numpy. Same float64 operations, same float32 rays.
    tracer = vectorized_tracer(Scene([GROUND]))
    rng = np.random.default_rng(3)
    p = rng.normal(size=(700, 3)) * scale
    n = rng.normal(size=(700, 3))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    ys = rng.normal(size=(33, 3)) * scale
    ys[0] = p[0]  # a zero-length segment: a sample on the receiver
    eps = 1e-4 * scale
    front, rays = reference._jit_rays(tracer.mi, tracer.dr, p, n, ys, eps)
    front = np.asarray(front, bool).reshape(len(p), len(ys))
    expected = np.einsum("ksc,kc->ks", ys[None] - p[:, None], n) > 0
    np.testing.assert_array_equal(front, expected)
    assert 0.3 < front.mean() < 0.7
    k, s = np.nonzero(front)
    o = (p + eps * n)[k]
    d, maxt = reference._segment(o, ys[s])
    ray = k * len(ys) + s
    np.testing.assert_array_equal(np.asarray(rays.o).T[ray], o.astype(np.float32))
    np.testing.assert_array_equal(np.asarray(rays.d).T[ray], d.astype(np.float32))
    np.testing.assert_array_equal(np.asarray(rays.maxt)[ray], maxt.astype(np.float32))


def test_counts_in_the_kernel_equal_the_per_ray_answers(monkeypatch):
    blocker = quad([0.2, 0.1, 0.9], [0.5, 0, 0], [0, 0.4, 0])
    tracer = vectorized_tracer(Scene([GROUND, blocker]))
    assert tracer.counts_in_kernel
    pts, normals = ground_receivers(300)
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    ys = light_samples(24)
    visible = tracer.visible(pts, normals, ys, 1e-4)
    np.testing.assert_array_equal(tracer.lit_counts(pts, normals, ys, 1e-4), visible.sum(axis=1))
    # Past a few blocks of lanes per thread every receiver gets a lane of its own: same counts.
    assert len(pts) < tracer.lanes_per_receiver_min
    monkeypatch.setattr(tracer, "lanes_per_receiver_min", len(pts))
    np.testing.assert_array_equal(tracer.lit_counts(pts, normals, ys, 1e-4), visible.sum(axis=1))
    per_receiver = visible.mean(axis=1)
    assert np.mean((per_receiver > 0) & (per_receiver < 1)) > 0.1  # penumbrae: the order of the rays matters


def test_the_mitsuba_scene_is_loaded_once_per_scene(monkeypatch):
    loads = []
    real = reference._Tracer
    monkeypatch.setattr(reference, "_Tracer", lambda *a: loads.append(1) or real(*a))
    rx, samples = Receivers(*ground_receivers(20)), light_samples(4)
    scene = Scene([GROUND, quad([0.2, 0.1, 0.9], [0.5, 0, 0], [0, 0.4, 0])])
    first = reference.mitsuba_visibility(scene, LIGHT, rx, samples, cache=False)
    again = reference.mitsuba_visibility(scene, LIGHT, rx, light_samples(5), cache=False)
    assert len(loads) == 1 and first.shape == again.shape
    reference.mitsuba_visibility(Scene(scene.meshes), LIGHT, rx, samples, cache=False)
    assert len(loads) == 2


@pytest.mark.parametrize("alpha", [None, np.ones((2, 2))])
def test_surfaces_beyond_the_light_samples_block_nothing(alpha):
    # A ceiling above the light: every segment ends at its sample, short of the ceiling
    # (opaque, or perforated with opaque texels, which takes the march through ray_intersect).
    ceiling = quad([0, 0, 2.6], [3, 0, 0], [0, 3, 0], alpha=alpha)
    blocker = quad([0.2, 0.1, 0.9], [0.5, 0, 0], [0, 0.4, 0])
    rx, samples = Receivers(*ground_receivers(60)), light_samples(12)
    without = reference.mitsuba_visibility(Scene([GROUND, blocker]), LIGHT, rx, samples, cache=False)
    with_ceiling = reference.mitsuba_visibility(Scene([GROUND, blocker, ceiling]), LIGHT, rx, samples, cache=False)
    np.testing.assert_array_equal(with_ceiling, without)
    assert without.mean() > 0.5


@pytest.mark.parametrize("alpha", [None, "checker"])
def test_visibility_does_not_depend_on_the_samples_order(alpha):
    # The samples are traced in an order of their own (along a curve over the light): any order
    # given must give the same bits, weights of a textured light and per-ray marching included.
    checker = None if alpha is None else np.kron(np.eye(2), np.ones((4, 4)))
    blocker = quad([0.2, 0.1, 0.9], [0.5, 0, 0], [0, 0.4, 0], alpha=checker)
    scene = Scene([GROUND, blocker])
    textured = RectLight(LIGHT.center, LIGHT.u, LIGHT.v, emission=np.array([[0.0, 1.0, 3.0], [2.0, 0.5, 0.25]]))
    rx = Receivers(*ground_receivers(300))
    samples = light_samples(40)
    shuffled = samples[np.random.default_rng(3).permutation(len(samples))]
    for light in (LIGHT, textured):
        vis = reference.mitsuba_visibility(scene, light, rx, samples, cache=False)
        assert np.mean((vis > 0) & (vis < 1)) > 0.1  # penumbrae, where the order could matter
        np.testing.assert_array_equal(reference.mitsuba_visibility(scene, light, rx, shuffled, cache=False), vis)

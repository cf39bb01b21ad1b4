"""Property-based tests (hypothesis): adversarial scenes, lights and receivers never crash the
process; every call either refuses with a ValueError naming an argument or returns visibility in
[0, 1] without NaN, and the exact methods keep the oracle's bits on well-conditioned soups."""

import numpy as np
import pytest

hypothesis = pytest.importorskip("hypothesis", reason='needs pip install "softshadows[test]" (hypothesis)')
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

import softshadows as ss  # noqa: E402
# Shared with tests/test_properties_api.py: the same adversarial inputs for every public function.
from strategies import COORD, check_visibility, ground_receivers, meshes, refusal_names_an_argument  # noqa: E402

SETTINGS = settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])


@SETTINGS
@given(meshes(), st.sampled_from(["ray_traced", "shadow_map", "pcss", "dcs", "alias_free", "backprojection"]))
def test_adversarial_meshes_are_refused_or_shadowed(mesh, method):
    vertices, faces = mesh
    try:
        scene = ss.Scene([ss.Mesh(vertices, faces)])
        light = ss.RectLight((0, 3, 0), (0.5, 0, 0), (0, 0, 0.5))
        vis = ss.METHODS[method](scene, light, ground_receivers())
    except ValueError as error:
        refusal_names_an_argument(error)
        return
    check_visibility(vis)


@SETTINGS
@given(st.tuples(COORD, COORD, COORD), st.one_of(st.floats(0, 4), st.sampled_from([0.0, -1.0, 1e-30, 1e30, np.nan])),
       st.sampled_from(["rect", "disk", "sphere"]))
def test_adversarial_lights_are_refused_or_shadowed(center, size, kind):
    scene = ss.scenes.ground_sphere(width=8, height=8).scene
    try:
        light = {"rect": lambda: ss.RectLight(center, (size, 0, 0), (0, 0, size)),
                 "disk": lambda: ss.DiskLight(center, (0, -1, 0), size),
                 "sphere": lambda: ss.SphereLight(center, size)}[kind]()
        vis = ss.ray_traced(scene, light, ground_receivers(), samples=8)
    except ValueError as error:
        refusal_names_an_argument(error)
        return
    check_visibility(vis)


@SETTINGS
@given(st.integers(0, 2**32 - 1), st.sampled_from(["dcs", "alias_free"]))
def test_exact_methods_keep_the_oracles_bits_on_random_soups(seed, method):
    rng = np.random.default_rng(seed)
    centers = rng.uniform([-1, 0.3, -1], [1, 1.5, 1], (12, 1, 3))
    soup = (centers + rng.uniform(-0.3, 0.3, (12, 3, 3))).reshape(-1, 3).astype(np.float32)
    ground = ss.Mesh(np.float32([[-3, 0, -3], [3, 0, -3], [3, 0, 3], [-3, 0, 3]]), np.uint32([[0, 2, 1], [0, 3, 2]]))
    scene = ss.Scene([ground, ss.Mesh(soup, np.arange(36, dtype=np.uint32).reshape(12, 3))])
    light = ss.RectLight((0.2, 3, 0.1), (0.6, 0, 0), (0, 0, -0.6))
    xs = np.linspace(-2, 2, 24, dtype=np.float32)
    grid = np.stack(np.meshgrid(xs, xs), -1).reshape(-1, 2)
    receivers = ss.Receivers(np.stack([grid[:, 0], np.zeros(len(grid), np.float32), grid[:, 1]], 1), np.tile(np.float32([0, 1, 0]), (len(grid), 1)))
    samples = light.samples(32, seed=int(seed % 1000))
    exact = ss.ray_traced(scene, light, receivers, samples=samples)
    options = {"lut": None} if method == "alias_free" else {}
    vis = ss.METHODS[method](scene, light, receivers, samples=samples, **options)
    assert np.mean(vis == exact) >= 0.99


@SETTINGS
@given(st.integers(0, 2), st.sampled_from([(1, 1), (0, 0), (0, 3), (2, 5)]), st.floats(-5, 5), st.booleans())
def test_alpha_textures_and_uvs_of_any_size_and_range(kind, shape, offset, contiguous):
    ground = ss.Mesh(np.float32([[-3, 0, -3], [3, 0, -3], [3, 0, 3], [-3, 0, 3]]), np.uint32([[0, 2, 1], [0, 3, 2]]))
    quad = np.float32([[-0.5, 1, -0.5], [0.5, 1, -0.5], [0.5, 1, 0.5], [-0.5, 1, 0.5]])
    uvs = np.float32([[0, 0], [1, 0], [1, 1], [0, 1]]) * 3 + offset
    if not contiguous:
        uvs = np.asfortranarray(np.repeat(uvs, 2, axis=0)[::2])
    alpha = np.ones(shape, np.float32) if kind == 0 else np.indices(shape).sum(0).astype(np.float32) % 2 if shape[0] else np.ones(shape)
    light = ss.RectLight((0, 3, 0), (0.4, 0, 0), (0, 0, 0.4))
    try:
        card = ss.Mesh(quad, np.uint32([[0, 2, 1], [0, 3, 2]]), uvs=uvs, alpha=alpha)
        scene = ss.Scene([ground, card])
        samples = light.samples(16)
        exact = ss.ray_traced(scene, light, ground_receivers(), samples=samples)
        vis = ss.stsv(scene, light, ground_receivers(), samples=samples, two_sided=True)
    except ValueError as error:
        refusal_names_an_argument(error)
        assert 0 in shape, "only an empty texture is refused"
        return
    check_visibility(vis)
    assert np.mean(vis == exact) >= 0.99


@SETTINGS
@given(st.sampled_from(["empty", "on_surface", "wrong_dtype", "nan_normal", "zero_normal"]),
       st.sampled_from(["ray_traced", "alias_free", "dcs", "stsv", "cssm", "mvr", "vwss", "backprojection"]))
def test_odd_receivers(kind, method):
    setup = ss.scenes.ground_sphere(width=8, height=8)
    points = np.float32([[0.3, 0, 0.2], [-0.2, 0, 0.4], [0.1, 0, -0.3]])
    normals = np.tile(np.float32([0, 1, 0]), (3, 1))
    if kind == "empty":
        points, normals = points[:0], normals[:0]
    elif kind == "on_surface":
        top = setup.scene.meshes[1].vertices.max(axis=0)
        points = np.repeat(top[None], 3, axis=0).astype(np.float32)  # on the sphere, exactly
    elif kind == "wrong_dtype":
        points, normals = points.astype(np.float64), normals.astype(np.int32)
    elif kind == "nan_normal":
        normals = normals.copy()
        normals[1] = np.nan
    elif kind == "zero_normal":
        normals = normals.copy()
        normals[2] = 0
    try:
        vis = ss.METHODS[method](setup.scene, setup.light, ss.Receivers(points, normals))
    except ValueError as error:
        refusal_names_an_argument(error)
        return
    assert vis.shape == (len(points),)
    check_visibility(vis)

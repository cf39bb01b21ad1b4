"""Penumbra wedges: near exact for one convex occluder, over-darkened where occluders overlap."""

import numpy as np
import pytest

import softshadows as ss
from softshadows.scenes.primitives import icosphere


def sphere(center, radius):
    vertices, faces = icosphere(3)
    return ss.Mesh((vertices * radius + center).astype(np.float32), faces.astype(np.uint32), closed=True)


def spheres_scene(*spheres):
    ground = ss.Mesh(np.array([[-3, 0, -3], [3, 0, -3], [3, 0, 3], [-3, 0, 3]], np.float32), np.array([[0, 2, 1], [0, 3, 2]], np.uint32))
    return ss.Scene([ground, *spheres])


CAMERA = ss.Camera.look_at((0, 5, 3), (0, 0, 0), (0, 1, 0), fov_y=40, width=96, height=96)
LIGHT = ss.RectLight((0, 4, 0), (0.6, 0, 0), (0, 0, -0.6))


def errors(scene):
    gb = ss.gbuffer(scene, CAMERA)
    samples = LIGHT.samples(64, seed=1)
    exact = ss.ray_traced(scene, LIGHT, gb, samples=samples, rotate="per_receiver")  # penumbra_wedge's default
    wedge, stats = ss.penumbra_wedge(scene, LIGHT, gb, samples=samples, return_stats=True)
    assert np.mean((exact > 0) & (exact < 1) & gb.mask) > 0.05, "needs a penumbra"
    assert stats["silhouette_edges"] > 0 and stats["wedge_tests"] > 0
    return (wedge - exact)[gb.mask]


def test_one_convex_occluder_is_nearly_exact():
    err = errors(spheres_scene(sphere(np.array([0, 1.0, 0]), 0.4)))
    # Only the silhouette seen from the center stands for the silhouettes seen from the samples.
    assert np.sqrt(np.mean(err**2)) < 0.01


def test_overlapping_occluders_are_counted_twice():
    err = errors(spheres_scene(sphere(np.array([0, 1.0, 0]), 0.4), sphere(np.array([0.35, 2.0, 0]), 0.25)))
    # Forest et al. 2009, section 3.1: where the silhouettes overlap, the occluded area counts twice.
    assert err.min() < -0.15 and np.sqrt(np.mean(err**2)) > 0.03


def test_point_lights_give_the_hard_shadow():
    scene = spheres_scene(sphere(np.array([0, 1.0, 0]), 0.4))
    gb = ss.gbuffer(scene, CAMERA)
    light = ss.PointLight(LIGHT.center)
    hard = ss.penumbra_wedge(scene, light, gb)
    np.testing.assert_array_equal(hard[gb.mask], ss.ray_traced(scene, light, gb, samples=1)[gb.mask])


def test_perforated_meshes_are_left_to_stsv():
    setup = ss.scenes.fence(width=16, height=16)
    with pytest.raises(ValueError, match="stsv"):
        ss.penumbra_wedge(setup.scene, setup.light, ss.gbuffer(setup.scene, setup.camera))


def test_unlit_receivers_get_positive_zero():
    # Rust's f64 sum starts from -0.0: a receiver with no sample in front of its tangent plane
    # got -0.0 (3 of the ground_sphere's 24x24 pixels under its sphere light).
    setup = ss.scenes.ground_sphere(width=24, height=24, light="sphere")
    gb = ss.gbuffer(setup.scene, setup.camera)
    vis = ss.penumbra_wedge(setup.scene, setup.light, gb)
    assert np.any(vis[gb.mask] == 0) and not np.signbit(vis).any()
    assert not np.signbit(ss.stsv(setup.scene, setup.light, gb, opaque="penumbra_wedge")).any()

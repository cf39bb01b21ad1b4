"""Placing lights and cameras without hand-made vectors: look_at lights, cameras from matrices."""

import numpy as np
import pytest

import softshadows as ss


@pytest.mark.parametrize("center, target", [((0, 4, 0), (0, 0, 0)), ((3, 2, -1), (0, 0.5, 0)), ((0, -2, 0), (0, 1, 0))])
def test_look_at_lights_face_their_target_with_the_size_asked(center, target):
    d = np.subtract(target, center) / np.linalg.norm(np.subtract(target, center))
    rect = ss.RectLight.look_at(center, target, (1.0, 0.5))
    np.testing.assert_allclose(rect.normal, d, atol=1e-6)
    assert rect.area == pytest.approx(0.5, rel=1e-6)
    assert np.linalg.norm(rect.u) == pytest.approx(0.5) and np.linalg.norm(rect.v) == pytest.approx(0.25)
    disk = ss.DiskLight.look_at(center, target, 0.3)
    np.testing.assert_allclose(disk.normal, d, atol=1e-6)
    assert disk.radius == pytest.approx(0.3)


def test_a_look_at_light_lights_what_it_faces():
    setup = ss.scenes.get("columns", width=32, height=32)
    gb = ss.gbuffer(setup.scene, setup.camera)
    light = ss.RectLight.look_at((0, 3, 0), (0, 0, 0), 0.5)
    lit = ss.shading.direct(gb, light, ss.ray_traced(setup.scene, light, gb, samples=16), 0.8)
    assert lit[gb.mask].max() > 0


def test_look_at_refuses_a_target_at_the_center():
    with pytest.raises(ValueError, match="target"):
        ss.RectLight.look_at((0, 1, 0), (0, 1, 0), 1.0)


def test_a_camera_from_its_world_matrix_is_the_look_at_camera():
    """A camera node's world matrix (glTF: looking down -z, +y up), here turned 30 degrees about
    y and tilted down 20, sees what look_at with the same eye, direction and up sees."""
    yaw, pitch = np.radians(30), np.radians(-20)
    ry = np.array([[np.cos(yaw), 0, np.sin(yaw)], [0, 1, 0], [-np.sin(yaw), 0, np.cos(yaw)]])
    rx = np.array([[1, 0, 0], [0, np.cos(pitch), -np.sin(pitch)], [0, np.sin(pitch), np.cos(pitch)]])
    m = np.eye(4)
    m[:3, :3] = ry @ rx
    m[:3, 3] = (2.0, 2.5, 4.0)
    camera = ss.Camera.from_matrix(m, fov_y=40.0, width=32, height=32)
    expected = ss.Camera.look_at(m[:3, 3], m[:3, 3] - m[:3, 2], m[:3, 1], 40.0, 32, 32)
    setup = ss.scenes.get("columns", width=32, height=32)
    a, b = ss.gbuffer(setup.scene, camera), ss.gbuffer(setup.scene, expected)
    assert a.mask.any()
    np.testing.assert_array_equal(a.face_ids, b.face_ids)


def test_a_camera_matrix_must_be_affine():
    m = np.eye(4)
    m[3, 2] = 1
    with pytest.raises(ValueError, match="world_from_camera: expected an affine"):
        ss.Camera.from_matrix(m)

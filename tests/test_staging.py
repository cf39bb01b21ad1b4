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


def boxes(offset=(0.0, 0.0, 0.0)):
    """Two boxes side by side, the pair moved by ``offset``: a scene away from the origin."""
    import trimesh

    parts = [trimesh.creation.box(extents=(1, 1, 1)), trimesh.creation.box(extents=(0.5, 2, 0.5))]
    parts[1].apply_translation((1.5, 0.5, 0))
    for p in parts:
        p.apply_translation(offset)
    return ss.Scene.from_trimesh(trimesh.Scene(parts))


@pytest.mark.parametrize("offset", [(0, 0, 0), (10, 5, -3)])
def test_stage_frames_the_scene_and_its_shadow_on_a_ground_under_it(offset):
    scene = boxes(offset)
    setup = ss.scenes.stage(scene, width=48, height=48)
    lo, hi = scene.bounds
    assert setup.has_ground and setup.occluders == scene.meshes
    assert np.allclose(setup.ground.vertices[:, 1], lo[1])
    ground_lo, ground_hi = setup.ground.vertices.min(axis=0), setup.ground.vertices.max(axis=0)
    assert np.all(ground_lo[[0, 2]] < lo[[0, 2]]) and np.all(ground_hi[[0, 2]] > hi[[0, 2]])
    # The light faces the scene's centre from above.
    center = (lo + hi) / 2
    to_scene = (center - setup.light.center) / np.linalg.norm(center - setup.light.center)
    assert setup.light.normal @ to_scene > 0.999 and setup.light.center[1] > hi[1]
    gb = ss.gbuffer(setup.scene, setup.camera)
    vis = ss.ray_traced(setup.scene, setup.light, gb, samples=32)
    on_ground = gb.mask & (gb.face_ids < 2)
    assert gb.mask.mean() > 0.5 and np.sum(vis[on_ground] < 0.5) > 30, "the shadows must be in view"


def test_stage_reads_a_file_and_names_the_set_up_after_it(tmp_path):
    import trimesh

    path = tmp_path / "crate.glb"
    trimesh.Scene({"crate": trimesh.creation.box()}).export(path)
    setup = ss.scenes.stage(path, light="disk", width=16, height=16)
    assert setup.name == "crate" and [m.name for m in setup.scene.meshes] == ["ground", "crate"]
    assert isinstance(setup.light, ss.DiskLight)


def test_stage_leaves_a_room_with_its_own_floor_and_a_lamp_inside_it():
    """A closed box seen from inside (its faces turned inward) with the lamp under its ceiling."""
    import trimesh

    room = trimesh.creation.box(extents=(4, 3, 4))
    room.invert()
    table = trimesh.creation.box(extents=(1, 0.8, 1))
    table.apply_translation((0, -1.1, 0))
    scene = ss.Scene.from_trimesh(trimesh.Scene([room, table]))
    setup = ss.scenes.stage(scene, ground=False, light="sphere", light_size=0.2, light_position=(0, 1.2, 0),
                            width=24, height=24)
    assert not setup.has_ground and setup.ground is None and setup.occluders == scene.meshes
    rx = ss.Receivers([[0, -1.5, 0], [1.8, -1.5, 1.8]], [[0, 1, 0], [0, 1, 0]])  # under the table, in a corner
    vis = ss.ray_traced(setup.scene, setup.light, rx, samples=64)
    assert vis[0] == 0 and vis[1] > 0.9


def test_stage_keeps_a_gltf_files_own_camera(tmp_path):
    import trimesh

    scene = trimesh.Scene({"box": trimesh.creation.box()})
    scene.camera.fov = (60.0, 45.0)
    pose = np.eye(4)
    pose[:3, 3] = (0.5, 1.0, 6.0)
    scene.camera_transform = pose
    path = tmp_path / "with_camera.glb"
    scene.export(path)
    setup = ss.scenes.stage(path, width=40, height=30)
    np.testing.assert_allclose(setup.camera.eye, (0.5, 1.0, 6.0), atol=1e-6)
    np.testing.assert_allclose(setup.camera.target - setup.camera.eye, (0, 0, -1), atol=1e-6)
    assert setup.camera.fov_y == pytest.approx(45.0) and (setup.camera.width, setup.camera.height) == (40, 30)
    plain = tmp_path / "plain.glb"
    trimesh.Scene({"box": trimesh.creation.box()}).export(plain)
    framed = ss.scenes.stage(plain, width=40, height=30).camera
    assert not np.allclose(framed.eye, (0.5, 1.0, 6.0))

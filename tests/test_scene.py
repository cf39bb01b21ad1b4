"""Scenes from arrays and from trimesh; G-buffers."""

import numpy as np
import pytest
import trimesh

import softshadows as ss


def test_from_trimesh_sets_closed_and_keeps_geometry():
    box = trimesh.creation.box((1, 1, 1))
    plane = trimesh.Trimesh([[0, 0, 0], [1, 0, 0], [0, 0, 1]], [[0, 1, 2]])
    path = trimesh.load_path(np.array([[0.0, 0, 0], [1, 1, 1]]))
    scene = ss.Scene.from_trimesh(trimesh.Scene([box, plane, path]))
    closed = sorted(m.closed for m in scene.meshes)
    assert closed == [False, True]
    assert scene.num_faces == 12 + 1
    with pytest.raises(ValueError, match="mesh"):
        ss.Scene.from_trimesh(np.zeros((3, 3)))


def test_from_trimesh_with_alpha_makes_a_perforated_mesh():
    quad = trimesh.Trimesh([[0, 0, 0], [1, 0, 0], [1, 0, 1], [0, 0, 1]], [[0, 1, 2], [0, 2, 3]], process=False)
    quad.visual = trimesh.visual.TextureVisuals(uv=np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=float))
    scene = ss.Scene.from_trimesh(quad, alpha=np.eye(4))
    assert scene.meshes[0].perforated and scene.meshes[0].uvs.shape == (4, 2)
    with pytest.raises(ValueError, match="uvs"):
        ss.Scene.from_trimesh(trimesh.creation.box(), alpha=np.eye(4))


def test_gbuffer_sees_the_right_faces_and_msaa_depths():
    v = np.array([[-1, 0, -1], [1, 0, -1], [1, 0, 1], [-1, 0, 1]], dtype=np.float32)
    scene = ss.Scene([ss.Mesh(v, [[0, 2, 1], [0, 3, 2]])])
    cam = ss.Camera.look_at((0, 3, 0.01), (0, 0, 0), fov_y=30, width=32, height=32, up=(0, 0, -1))
    gb = ss.gbuffer(scene, cam, msaa=4)
    assert gb.mask.all() and set(np.unique(gb.face_ids)) == {0, 1}
    np.testing.assert_allclose(gb.positions[..., 1], 0, atol=1e-6)
    np.testing.assert_allclose(gb.normals[..., 1], 1, atol=1e-6)  # facing the camera
    assert gb.sample_depths.shape == (32, 32, 4)
    center_depth = np.linalg.norm(gb.positions - cam.eye, axis=-1)
    assert np.all(np.abs(gb.sample_depths.mean(-1) - center_depth) < 0.1)


def test_mesh_repr_separates_the_name_from_the_counts():
    tri = ss.Mesh([[0, 0, 0], [1, 0, 0], [0, 0, 1]], [[0, 1, 2]], name="ground")
    assert repr(tri) == "Mesh('ground', 3 vertices, 1 face, closed=False)"  # was "Mesh(ground3 vertices, 1 faces, ...)"
    quad = trimesh.creation.box()
    perforated = ss.Mesh(quad.vertices, quad.faces, uvs=np.zeros((8, 2)), alpha=np.ones((64, 16)), closed=True)
    assert repr(perforated) == "Mesh(8 vertices, 12 faces, alpha 64x16, closed=True)"


def test_scene_repr_names_its_first_meshes():
    tri = ss.Mesh([[0, 0, 0], [1, 0, 0], [0, 0, 1]], [[0, 1, 2]])
    named = [ss.Mesh(tri.vertices, tri.faces, name=f"m{k}") for k in range(6)]
    assert repr(ss.Scene(named[:1])) == "Scene(1 mesh ['m0'], 1 face)"
    assert repr(ss.Scene(named)) == "Scene(6 meshes ['m0', 'm1', 'm2', 'm3', ...], 6 faces)"


def test_gbuffer_repr_gives_its_size_not_its_arrays():
    setup = ss.scenes.get("parallel_plates", width=40, height=30)
    gb = ss.gbuffer(setup.scene, setup.camera)
    assert repr(gb) == f"GBuffer(40x30 pixels, {int(gb.mask.sum())} hit, msaa=1)"  # was every array in full


def test_epsilon_is_1e4_of_the_referenced_vertices_diagonal_per_scene():
    # Computed once per scene (every method's default offset reads it): each scene keeps its
    # own value, 1e-4 x the diagonal of the bounds of the vertices its faces use, in float64
    # (an unused far vertex does not count).
    small = np.array([[0, 0, 0], [1, 0, 0], [0, 2, 0], [1e6, 1e6, 1e6]], dtype=np.float32)
    large = np.array([[-3, 0, 0], [5, 1, 0], [0, 0, 7]], dtype=np.float32)
    scenes = [ss.Scene([ss.Mesh(v, [[0, 1, 2]])]) for v in (small, large)]
    for scene, v in zip(scenes, (small[:3], large)):
        d = v.astype(np.float64).max(axis=0) - v.astype(np.float64).min(axis=0)
        assert scene.epsilon == 1e-4 * np.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])

"""softshadows.load: mesh files through trimesh, alpha-tested materials as perforated meshes."""

import os
import warnings

import numpy as np
import pytest

import softshadows as ss

trimesh = pytest.importorskip("trimesh")
Image = pytest.importorskip("PIL.Image")

#: The card's corners (y = 1) and their uvs: u runs with x, v with z.
CARD = np.array([[-1, 1, -1], [1, 1, -1], [1, 1, 1], [-1, 1, 1]], dtype=np.float64)
CARD_UV = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=np.float64)
CARD_FACES = np.array([[0, 1, 2], [0, 2, 3]])
#: One receiver under each quarter of the card, and the light far above.
RECEIVERS = ss.Receivers([[-0.5, 0, 0.5], [0.5, 0, 0.5], [-0.5, 0, -0.5], [0.5, 0, -0.5]], [[0, 1, 0]] * 4)
LIGHT = ss.PointLight((0, 100, 0))
#: An image file's top-left texel is the uv corner (0, 1) (OBJ and glTF as trimesh reads them):
#: opaque there only, the card shadows the receiver at x < 0, z > 0 and no other.
ORACLE = [0.0, 1.0, 1.0, 1.0]


def ground():
    return trimesh.Trimesh([[-3, 0, -3], [3, 0, -3], [3, 0, 3], [-3, 0, 3]], [[0, 2, 1], [0, 3, 2]], process=False)


def top_left_opaque(mode="RGBA"):
    alpha = np.array([[255, 0], [0, 0]], dtype=np.uint8)
    if mode == "L":
        return Image.fromarray(alpha, "L")
    rgba = np.zeros((2, 2, 4), dtype=np.uint8)
    rgba[..., 1], rgba[..., 3] = 200, alpha
    return Image.fromarray(rgba, "RGBA")


def write_glb(folder, **material):
    from trimesh.visual.material import PBRMaterial
    from trimesh.visual.texture import TextureVisuals

    card = trimesh.Trimesh(CARD, CARD_FACES, process=False,
                           visual=TextureVisuals(uv=CARD_UV, material=PBRMaterial(baseColorTexture=top_left_opaque(), **material)))
    path = os.path.join(folder, "card.glb")
    trimesh.Scene({"ground": ground(), "card": card}).export(path)
    return path


def test_a_gltf_masked_card_becomes_a_perforated_mesh_the_right_way_up(tmp_path):
    scene = ss.load(write_glb(tmp_path, alphaMode="MASK", alphaCutoff=0.5))
    card = {m.name: m for m in scene.meshes}["card"]
    assert card.perforated and not {m.name: m for m in scene.meshes}["ground"].perforated
    np.testing.assert_array_equal(ss.ray_traced(scene, LIGHT, RECEIVERS, samples=1), ORACLE)


def test_the_cutoff_and_the_factor_decide_coverage(tmp_path):
    # Alpha 255 x factor 0.4 = 0.4: under a cutoff of 0.5 nothing is opaque, under 0.3 the texel is.
    factor = [255, 255, 255, 102]
    none = ss.load(write_glb(tmp_path, alphaMode="MASK", alphaCutoff=0.5, baseColorFactor=factor))
    np.testing.assert_array_equal(ss.ray_traced(none, LIGHT, RECEIVERS, samples=1), [1.0] * 4)
    some = ss.load(write_glb(tmp_path, alphaMode="MASK", alphaCutoff=0.3, baseColorFactor=factor))
    np.testing.assert_array_equal(ss.ray_traced(some, LIGHT, RECEIVERS, samples=1), ORACLE)


def test_an_opaque_gltf_material_stays_opaque_and_blend_is_cut_out_with_a_warning(tmp_path):
    opaque = ss.load(write_glb(tmp_path))
    assert not any(m.perforated for m in opaque.meshes)
    np.testing.assert_array_equal(ss.ray_traced(opaque, LIGHT, RECEIVERS, samples=1), [0.0] * 4)
    with pytest.warns(ss.SetupWarning, match="BLEND"):
        blended = ss.load(write_glb(tmp_path, alphaMode="BLEND"))
    np.testing.assert_array_equal(ss.ray_traced(blended, LIGHT, RECEIVERS, samples=1), ORACLE)


@pytest.mark.parametrize("mode", ["L", "RGBA"])
def test_an_obj_map_d_perforates_its_mesh(tmp_path, mode):
    lines = ["mtllib card.mtl", *(f"v {x} {y} {z}" for x, y, z in CARD), *(f"vt {u} {w}" for u, w in CARD_UV),
             "usemtl leaf", "f 1/1 2/2 3/3", "f 1/1 3/3 4/4"]
    (tmp_path / "card.obj").write_text("\n".join(lines) + "\n")
    (tmp_path / "card.mtl").write_text("newmtl leaf\nKd 0.2 0.6 0.2\nd 1.0\nmap_d alpha.png\n")
    top_left_opaque(mode).save(tmp_path / "alpha.png")
    scene = ss.load(tmp_path / "card.obj")
    assert scene.meshes[0].perforated
    np.testing.assert_array_equal(ss.ray_traced(scene, LIGHT, RECEIVERS, samples=1), ORACLE)


@pytest.mark.parametrize("extension", [".ply", ".stl", ".off", ".obj", ".glb"])
def test_every_format_reads_a_closed_box(tmp_path, extension):
    path = tmp_path / f"box{extension}"
    trimesh.creation.box(extents=(1, 2, 3)).export(path)
    scene = ss.load(path)
    assert sum(len(m.faces) for m in scene.meshes) == 12 and all(m.closed for m in scene.meshes)
    np.testing.assert_allclose(scene.bounds, [[-0.5, -1, -1.5], [0.5, 1, 1.5]])


def test_files_that_cannot_be_read_say_which_and_why(tmp_path):
    with pytest.raises(FileNotFoundError, match="nothing.obj"):
        ss.load(tmp_path / "nothing.obj")
    (tmp_path / "notes.txt").write_text("hello")
    with pytest.raises(ValueError, match=r"notes.txt has the extension '.txt'; load reads .obj"):
        ss.load(tmp_path / "notes.txt")
    (tmp_path / "broken.glb").write_bytes(b"glTF not really")
    with pytest.raises(ValueError, match="trimesh could not read .*broken.glb"):
        ss.load(tmp_path / "broken.glb")

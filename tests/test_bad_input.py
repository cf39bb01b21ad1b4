"""Bad input is refused with a ValueError naming the argument; too-large requests with MemoryError."""

import numpy as np
import pytest
from conftest import up_receivers

import softshadows as ss

V = np.array([[0, 0, 0], [1, 0, 0], [0, 0, 1]], dtype=np.float32)
F = np.array([[0, 1, 2]], dtype=np.uint32)


@pytest.mark.parametrize(
    "kwargs, arg",
    [
        (dict(vertices=np.array([[0, 0, 0], [np.nan, 0, 0], [0, 0, 1]]), faces=F), "vertices"),
        (dict(vertices=V, faces=np.array([[0, 1, 3]])), "faces"),
        (dict(vertices=V[:, :2], faces=F), "vertices"),
        (dict(vertices=V, faces=np.array([0, 1, 2])), "faces"),
        (dict(vertices=V.astype(str), faces=F), "vertices"),
        (dict(vertices=V, faces=np.array([[0, 1, 2.5]])), "faces"),
        (dict(vertices=V, faces=np.array([[0, 1, -2]])), "faces"),
        (dict(vertices=V, faces=np.array([[0, 1, 2**32]])), "faces"),  # would wrap to 0 as uint32
        (dict(vertices=V, faces=F, alpha=np.ones((2, 2))), "uvs"),
        (dict(vertices=V, faces=F, uvs=np.zeros((2, 2)), alpha=np.ones((2, 2))), "uvs"),
        (dict(vertices=V, faces=F, uvs=np.zeros((3, 2)), alpha=np.ones((0, 0))), "alpha"),
    ],
)
def test_bad_meshes(kwargs, arg):
    with pytest.raises(ValueError, match=arg):
        ss.Mesh(kwargs.pop("vertices"), kwargs.pop("faces"), **kwargs)


def test_float64_int64_and_non_contiguous_input_is_converted():
    big = np.zeros((3, 6))
    big[:, ::2] = V
    m = ss.Mesh(big[:, ::2], F.astype(np.int64))
    assert m.vertices.dtype == np.float32 and m.vertices.flags.c_contiguous and m.faces.dtype == np.uint32
    np.testing.assert_array_equal(m.vertices, V)


def test_empty_scene():
    with pytest.raises(ValueError, match="meshes"):
        ss.Scene([])
    with pytest.raises(ValueError, match="meshes"):
        ss.Scene([ss.Mesh(np.zeros((0, 3)), np.zeros((0, 3)))])


@pytest.mark.parametrize(
    "make, arg",
    [
        (lambda: ss.RectLight((0, 1, 0), (1, 0, 0), (2, 0, 0)), "u"),
        (lambda: ss.RectLight((0, 1, 0), (0, 0, 0), (0, 0, 1)), "u"),
        (lambda: ss.DiskLight((0, 1, 0), (0, -1, 0), -1.0), "radius"),
        (lambda: ss.DiskLight((0, 1, 0), (0, -1, 0), 0.0), "radius"),
        (lambda: ss.DiskLight((0, 1, 0), (0, 0, 0), 1.0), "normal"),
        (lambda: ss.SphereLight((0, 1, 0), -0.5), "radius"),
        (lambda: ss.PointLight((0, np.inf, 0)), "position"),
        (lambda: ss.RectLight((0, 1), (1, 0, 0), (0, 0, 1)), "center"),
        (lambda: ss.RectLight((0, 1, 0), (1, 0, 0), (0, 0, 1), emission=np.zeros((2, 2))), "emission"),
    ],
)
def test_bad_lights(make, arg):
    with pytest.raises(ValueError, match=arg):
        make()


@pytest.mark.parametrize(
    "kwargs, arg",
    [
        (dict(width=0), "width"),
        (dict(height=0), "height"),
        (dict(fov_y=0.0), "fov_y"),
        (dict(fov_y="wide"), "fov_y"),
        (dict(target=(0, 5, 5)), "target"),
        (dict(up=(0, -1, -1)), "up"),
    ],
)
def test_bad_cameras(kwargs, arg):
    args = dict(eye=(0, 5, 5), target=(0, 0, 0), up=(0, 1, 0), fov_y=45.0, width=8, height=8) | kwargs
    with pytest.raises(ValueError, match=arg):
        ss.Camera.look_at(**args)


def test_bad_method_arguments(ground):
    scene = ss.Scene([ground])
    light = ss.RectLight((0, 4, 0), (1, 0, 0), (0, 0, -1))
    rx = up_receivers([0.0, 1.0])
    with pytest.raises(ValueError, match="samples"):
        ss.ray_traced(scene, light, rx, samples=0)
    with pytest.raises(ValueError, match="samples"):
        ss.ray_traced(scene, light, rx, samples=np.zeros((4, 2)))
    with pytest.raises(ValueError, match="rotate"):
        ss.ray_traced(scene, light, rx, rotate="sometimes")
    with pytest.raises(ValueError, match="^caster_faces: .*backfacing"):
        ss.ray_traced(scene, light, rx, caster_faces="front")
    with pytest.raises(ValueError, match="^casters: "):
        ss.ray_traced(scene, light, rx, casters=["front"])
    with pytest.raises(ValueError, match="receivers"):
        ss.ray_traced(scene, light, np.zeros((3, 3)))
    with pytest.raises(ValueError, match="normals"):
        ss.Receivers([[0, 0, 0]], [[0, 0, 0]])
    with pytest.raises(ValueError, match="msaa"):
        ss.gbuffer(scene, ss.Camera.look_at((0, 5, 5), (0, 0, 0), width=4, height=4), msaa=3)
    with pytest.raises(ValueError, match="resolution"):
        ss.shadow_map(scene, light, rx, resolution=0)
    with pytest.raises(ValueError, match="frame"):
        ss.ray_traced(scene, light, rx, samples=light.samples(4), frame=1)
    with pytest.raises(ValueError, match="^scene:"):
        ss.ray_traced([ground], light, rx)
    with pytest.raises(ValueError, match="^light:"):
        ss.shadow_map(scene, (0, 4, 0), rx)
    cam = ss.Camera.look_at((0, 5, 5), (0, 0, 0), width=4, height=4)
    for msaa in (2.0, True):
        with pytest.raises(ValueError, match="msaa"):
            ss.gbuffer(scene, cam, msaa=msaa)
    with pytest.raises(ValueError, match="^camera:"):
        ss.gbuffer(scene, None)


ENUM_OPTIONS = [  # (method, option, a value it takes), every string option of every method
    ("ray_traced", "caster_faces", "all"), ("ray_traced", "pattern", "sobol"),
    ("alias_free", "caster_faces", "all"), ("cssm", "prefilter", "mipmap"),
    ("vwss", "mode", "unbuffered"), ("vwss", "parallel", "full"), ("vwss", "precision", "float16"),
    ("vwss", "source_view", "paper"), ("stsv", "opaque", "dcs"), ("backprojection", "occluder", "microquad"),
    ("backprojection", "accumulation", "area"), ("backprojection", "accel", "mssm"),
]


@pytest.mark.parametrize("method, option, good", ENUM_OPTIONS)
def test_a_misspelt_or_non_string_option_names_itself_and_its_values(ground, method, option, good):
    scene = ss.Scene([ground])
    light = ss.RectLight((0, 4, 0), (1, 0, 0), (0, 0, 1))  # facing the receivers
    rx = up_receivers([0.0, 1.0])
    call = getattr(ss, method)
    call(scene, light, rx, **{option: good})
    with pytest.raises(ValueError, match=f"^{option}: expected one of .*{good!r}.*got {good[:-1] + 'x'!r}".replace("'", '"')):
        call(scene, light, rx, **{option: good[:-1] + "x"})
    with pytest.raises(ValueError, match=f"^{option}: expected a string, got int"):
        call(scene, light, rx, **{option: 3})


def test_a_request_too_large_raises_memory_error_before_allocating(ground):
    scene = ss.Scene([ground])
    light = ss.RectLight((0, 4, 0), (1, 0, 0), (0, 0, -1))
    try:
        ss.set_memory_limit(1 << 20)
        with pytest.raises(MemoryError, match="set_memory_limit"):
            light.samples(1 << 20)
        with pytest.raises(MemoryError, match="set_memory_limit"):
            ss.shadow_map(scene, light, up_receivers([0.0]), resolution=1 << 14)
        for bad in (-1, 0, "1G"):
            with pytest.raises(ValueError, match="bytes"):
                ss.set_memory_limit(bad)
        cam = ss.Camera.look_at((0, 5, 5), (0, 0, 0), width=1 << 20, height=1 << 20)
        with pytest.raises(MemoryError, match="G-buffer"):
            ss.gbuffer(scene, cam)
        # 12 TiB of samples would be refused at the default limit too: nothing is allocated.
        ss.set_memory_limit(None)
        with pytest.raises(MemoryError):
            light.samples(1 << 40)
    finally:
        ss.set_memory_limit(None)


@pytest.mark.parametrize("call", [
    lambda s, gb: ss.backprojection(s.scene, s.light, gb, extend="False"),
    lambda s, gb: ss.backprojection(s.scene, s.light, gb, blend="no"),
    lambda s, gb: ss.stsv(s.scene, s.light, gb, two_sided="False"),
    lambda s, gb: ss.Mesh(np.eye(3, dtype=np.float32), np.uint32([[0, 1, 2]]), closed="False"),
])
def test_strings_are_not_booleans(call):
    # bool("False") is True: a string where a flag is expected is refused by name.
    setup = ss.scenes.get("ground_sphere", width=8, height=8)
    with pytest.raises(ValueError, match="expected True or False"):
        call(setup, ss.gbuffer(setup.scene, setup.camera))


@pytest.mark.parametrize("value", ["0.01", b"1", True])
def test_strings_and_bools_are_not_numbers(value):
    setup = ss.scenes.get("ground_sphere", width=8, height=8)
    with pytest.raises(ValueError, match="bias"):
        ss.backprojection(setup.scene, setup.light, ss.gbuffer(setup.scene, setup.camera), bias=value)


def test_an_eye_far_from_its_target_is_not_told_they_coincide():
    # 1e30 away: a camera (its squared distance overflowed float32 and read as "the same point").
    camera = ss.Camera.look_at((1e30, 0, 0), (0, 0, 0), fov_y=40, width=8, height=8)
    assert camera.width == 8
    with pytest.raises(ValueError, match="^eye: .*too far apart"):
        ss.Camera.look_at((3e38, 0, 0), (-3e38, 0, 0), fov_y=40, width=8, height=8)
    with pytest.raises(ValueError, match="^target: must differ"):
        ss.Camera.look_at((1, 2, 3), (1, 2, 3), fov_y=40, width=8, height=8)


@pytest.mark.parametrize("method", ["dcs", "stsv", "penumbra_wedge"])
def test_an_offset_longer_than_the_scene_blames_epsilon_not_the_light(method):
    setup = ss.scenes.get("ground_sphere", width=8, height=8)
    with pytest.raises(ValueError, match="^epsilon: must be at most the size of the scene"):
        getattr(ss, method)(setup.scene, setup.light, ss.gbuffer(setup.scene, setup.camera), epsilon=1e30)


def test_alpha_outside_the_unit_interval_is_refused():
    verts, faces, uvs = np.eye(3, dtype=np.float32), np.uint32([[0, 1, 2]]), np.zeros((3, 2), np.float32)
    with pytest.raises(ValueError, match=r"^alpha: values must be in \[0, 1\]"):
        ss.Mesh(verts, faces, uvs=uvs, alpha=np.full((2, 2), 255.0))


def test_the_memory_limit_takes_exact_integers_and_no_bools():
    try:
        ss.set_memory_limit(2**64 - 1)  # the documented maximum (float(2**64 - 1) is 2**64)
        assert ss.memory_limit() == 2**64 - 1
        with pytest.raises(ValueError, match="bytes"):
            ss.set_memory_limit(True)
        with pytest.raises(ValueError, match="bytes"):
            ss.set_memory_limit(2**64)
    finally:
        ss.set_memory_limit(None)


def test_a_camera_built_directly_takes_any_array_like_and_checks_its_fields():
    # Camera(...) passed its fields to the core as given: float64 arrays raised "type mismatch
    # from=float64, to=float32" there, and a zero width was not refused by name.
    direct = ss.Camera(np.float64([2.5, 2.5, 2.5]), [0, 0.3, 0], (0, 1, 0), 45, 16, 12)
    looked = ss.Camera.look_at((2.5, 2.5, 2.5), (0, 0.3, 0), fov_y=45, width=16, height=12)
    assert direct.eye.dtype == np.float32 and np.array_equal(direct.eye, looked.eye)
    scene = ss.scenes.get("columns").scene
    np.testing.assert_array_equal(ss.gbuffer(scene, direct).positions, ss.gbuffer(scene, looked).positions)
    with pytest.raises(ValueError, match="^width:"):
        ss.Camera(direct.eye, direct.target, direct.up, 45, 0, 12)
    with pytest.raises(ValueError, match="^eye:"):
        ss.Camera([0, np.nan, 0], direct.target, direct.up, 45, 16, 12)

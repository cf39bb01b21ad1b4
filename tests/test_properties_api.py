"""Property-based tests (hypothesis) of every public function outside the methods.

``tests/test_properties.py`` covers the visibility methods (``softshadows.METHODS``) and the scene
model they read; this module covers the rest of the public API with the same adversarial inputs
(``tests/strategies.py``): constructors (``Mesh``, ``Scene``, ``Scene.from_trimesh``,
``Camera.look_at``, ``Receivers``, the lights), ``gbuffer``, light samples, ``resolve_msaa``,
``stsv_volumes``, ``metrics``, ``shading``, ``io``, ``scenes``, ``envmap``, ``plot``,
``evaluation``, ``reference`` (argument checks only: nothing is rendered) and the thread and
memory settings.

Invariant
---------
Every call returns a valid result (finite, in range, of the documented shape and dtype) or
refuses as ``strategies.result_or_refusal`` allows: a ValueError or TypeError naming the
offending argument, a MemoryError pointing to ``set_memory_limit``, an OSError naming a path.

Most properties draw their arguments with ``strategies.arguments``: all ordinary in about half
the examples, so that results get checked and not only refusals. Sizes that would take long are
refused early by running the builders under a 64 MiB memory limit (:func:`low_memory`).
Known core bugs (Rust) are strict xfail tests with the failing input, left out of the properties.

Inputs tried
------------
Each property counts its inputs (``strategies.tried``) and the outcome of each call (a result,
or the kind of refusal); the table per function is printed when the module finishes, past
pytest's capture. ``SOFTSHADOWS_PROPERTY_SCALE=10`` runs ten times as many inputs.
"""

from __future__ import annotations

import contextlib
import functools
import inspect
import math
import os

import numpy as np
import pytest

hypothesis = pytest.importorskip("hypothesis", reason='needs pip install "softshadows[test]" (hypothesis)')
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

import softshadows as ss  # noqa: E402
from strategies import (  # noqa: E402
    COUNT_MOSTLY, INT, JUNK, ORDINARY_COORD, ORDINARY_FLOATS, ORDINARY_VEC3, OUTCOMES, REFUSED, SIZE, SIZE_MOSTLY, TRIED,
    VEC3, VEC3_MOSTLY, arguments, arrays, check_visibility, junk_or, lights, meshes, refusal_names_an_argument,
    result_or_refusal, tried,
)


#: ``SOFTSHADOWS_PROPERTY_SCALE=10`` multiplies every count below, for a longer search.
SCALE = int(os.environ.get("SOFTSHADOWS_PROPERTY_SCALE", "1"))


def examples(n: int):
    """``n`` inputs per run (times SCALE); no deadline (the first call of a builder fills caches)."""
    return settings(max_examples=n * SCALE, deadline=None,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large, HealthCheck.filter_too_much])


@contextlib.contextmanager
def low_memory(limit: int = 64 * 2**20):
    """Huge sizes are refused before anything is built (and the default restored after)."""
    ss.set_memory_limit(limit)
    try:
        yield
    finally:
        ss.set_memory_limit(None)


def params(function) -> set:
    """The names of ``function``'s parameters: a refusal must start with one of them."""
    return set(inspect.signature(function).parameters)


@functools.lru_cache(maxsize=None)
def setup(name: str = "ground_sphere"):
    return ss.scenes.get(name, width=8, height=8)


@functools.lru_cache(maxsize=None)
def gbuffer(msaa: int = 1, name: str = "ground_sphere"):
    return ss.gbuffer(setup(name).scene, setup(name).camera, msaa)


@pytest.fixture(scope="module", autouse=True)
def report_inputs_tried(request):
    """Writes the inputs tried per function (this module's properties) when the module ends."""
    yield
    kinds = ("result", "ValueError", "TypeError", "MemoryError", "OSError")
    lines = ["", "hypothesis inputs tried per function (tests/test_properties_api.py):",
             f"  {'function':<38} {'tried':>6} " + " ".join(f"{k:>11}" for k in kinds)]
    for name, count in sorted(TRIED.items()):
        lines.append(f"  {name:<38} {count:>6} " + " ".join(f"{OUTCOMES[name, k] or '':>11}" for k in kinds))
    lines.append(f"  {'total':<38} {sum(TRIED.values()):>6}")
    # Past pytest's output capture, which would otherwise swallow a fixture's teardown output.
    capture = request.config.pluginmanager.getplugin("capturemanager")
    with capture.global_and_fixture_disabled() if capture else contextlib.nullcontext():
        print("\n".join(lines), flush=True)


@pytest.fixture(scope="module")
def outdir(tmp_path_factory):
    return tmp_path_factory.mktemp("properties_api")


@pytest.fixture(scope="module", autouse=True)
def isolated_reference_cache(tmp_path_factory):
    """A reference that slipped past argument checks must not write to the user's cache."""
    old = os.environ.get("SOFTSHADOWS_CACHE")
    os.environ["SOFTSHADOWS_CACHE"] = str(tmp_path_factory.mktemp("reference_cache"))
    yield
    if old is None:
        del os.environ["SOFTSHADOWS_CACHE"]
    else:
        os.environ["SOFTSHADOWS_CACHE"] = old


def finite(a) -> bool:
    return bool(np.all(np.isfinite(np.asarray(a, np.float64))))


# ----------------------------------------------------------------------------------------------
# The scene model: Mesh, Scene, Scene.from_trimesh
# ----------------------------------------------------------------------------------------------

FACE_VALUES = st.one_of(st.integers(0, 2).map(float), st.integers(-1, 5).map(float), st.sampled_from([2.0**32, 0.5, np.nan, 1e30]))
# Meshes whose vertices are mostly ordinary and whose faces are in range, and fully adversarial ones.
GOOD_MESHES = meshes(ORDINARY_COORD, past_end=0).filter(lambda mesh: len(mesh[0]) and len(mesh[1]))
SOME_MESHES = st.one_of(GOOD_MESHES, meshes())


TEXTURE_SHAPES = st.sampled_from([(1, 1), (0, 0), (0, 3), (2, 5), (2, 2, 2)])


@examples(150)
@given(kw=arguments(
    vertices=(arrays(st.sampled_from([(3, 3), (4, 3), (0, 3)]), elements=ORDINARY_FLOATS),
              st.one_of(arrays(st.sampled_from([(0, 3), (3, 3), (4, 3), (3, 2), (3,), (2, 3, 3)])), JUNK)),
    faces=(arrays(st.sampled_from([(0, 3), (1, 3), (2, 3)]), elements=st.integers(0, 2).map(float)),
           st.one_of(arrays(st.sampled_from([(0, 3), (1, 3), (2, 3), (3,)]), elements=FACE_VALUES), JUNK)),
    uvs=(st.sampled_from([None, "match"]), st.one_of(st.none(), st.just("match"), arrays(st.sampled_from([(3, 2), (4, 2), (3, 3)])), JUNK)),
    alpha=(st.one_of(st.none(), arrays(st.sampled_from([(1, 1), (2, 5)]), elements=st.floats(0, 1))),
           st.one_of(st.none(), arrays(TEXTURE_SHAPES), JUNK)),
    closed=(st.booleans(), junk_or(st.booleans())),
    name=(st.one_of(st.none(), st.text(max_size=3)), st.one_of(st.none(), st.text(max_size=3), JUNK)),
))
def test_mesh_constructor(kw):
    tried("Mesh")
    vertices, faces, uvs, alpha, closed, name = (kw[k] for k in ("vertices", "faces", "uvs", "alpha", "closed", "name"))
    if isinstance(uvs, str):  # "match": one (u, v) per vertex, out of [0, 1] (they wrap)
        uvs = np.linspace(-5, 5, 2 * len(vertices)).reshape(-1, 2) if isinstance(vertices, np.ndarray) and vertices.ndim else None
    mesh = result_or_refusal(lambda: ss.Mesh(vertices, faces, uvs=uvs, alpha=alpha, closed=closed, name=name),
                             {"vertices", "faces", "uvs", "alpha", "closed"}, label="Mesh")
    if mesh is REFUSED:
        return
    assert mesh.vertices.dtype == np.float32 and mesh.vertices.flags.c_contiguous and finite(mesh.vertices)
    assert mesh.faces.dtype == np.uint32 and mesh.faces.flags.c_contiguous
    assert mesh.faces.size == 0 or int(mesh.faces.max()) < len(mesh.vertices)
    if mesh.alpha is not None:
        assert mesh.alpha.size and finite(mesh.alpha) and mesh.uvs.shape == (len(mesh.vertices), 2)
    repr(mesh)


@examples(120)
@given(kw=arguments(
    parts=(st.lists(GOOD_MESHES, min_size=1, max_size=4),
           st.one_of(st.lists(st.one_of(SOME_MESHES, SOME_MESHES, SOME_MESHES, JUNK), max_size=4), JUNK)),
    keys=(st.lists(st.one_of(st.integers(0, 1), st.just("m0")), max_size=3),
          st.one_of(st.lists(st.one_of(st.integers(-2, 5), st.sampled_from(["m0", "m1", "nope"]), JUNK), max_size=4), JUNK)),
))
def test_scene_constructor_subset_and_bounds(kw):
    tried("Scene", "Scene.subset", "Scene.bounds")
    parts, keys = kw["parts"], kw["keys"]
    if isinstance(parts, list):
        built = []
        for i, part in enumerate(parts):
            if isinstance(part, tuple) and len(part) == 2 and isinstance(part[0], np.ndarray):
                part = result_or_refusal(lambda: ss.Mesh(*part, name=f"m{i}"), {"vertices", "faces"})
                if part is REFUSED:
                    continue
            built.append(part)
        parts = built
    scene = result_or_refusal(lambda: ss.Scene(parts), {"meshes"}, label="Scene")
    if scene is REFUSED:
        return
    lo, hi = scene.bounds
    assert finite(lo) and finite(hi) and np.all(lo <= hi)
    assert math.isfinite(scene.epsilon) and scene.epsilon >= 0 and scene.num_faces > 0
    sub = result_or_refusal(lambda: scene.subset(keys), {"meshes"}, label="Scene.subset")
    if sub is not REFUSED:
        assert all(any(m is n for n in scene.meshes) for m in sub.meshes)


@examples(60)
@given(kw=arguments(
    mesh=(GOOD_MESHES, SOME_MESHES),
    kind=(st.sampled_from(["trimesh", "scene", "scene with points"]), st.sampled_from(["trimesh", "scene", "junk"])),
    alpha=(st.one_of(st.none(), arrays(st.sampled_from([(1, 1), (2, 2)]), elements=st.floats(0, 1), layouts=False)),
           st.one_of(st.none(), arrays(st.sampled_from([(1, 1), (0, 0), (2, 2)]), layouts=False))),
    with_uvs=(st.just(True), st.booleans()),
), closed=st.sampled_from([None, True, False]))
def test_scene_from_trimesh(kw, closed):
    import trimesh

    tried("Scene.from_trimesh")
    mesh, kind, alpha, with_uvs = kw["mesh"], kw["kind"], kw["alpha"], kw["with_uvs"]
    vertices, faces = mesh
    part = trimesh.Trimesh(vertices, faces, process=False, validate=False)
    if with_uvs:
        part.visual = trimesh.visual.TextureVisuals(uv=np.zeros((len(vertices), 2)))
    source = {"trimesh": part, "junk": [part]}.get(kind)
    if source is None:
        source = trimesh.Scene([part, part.copy()])
        if kind == "scene with points":
            source.add_geometry(trimesh.PointCloud(np.zeros((3, 3))))
    scene = result_or_refusal(lambda: ss.Scene.from_trimesh(source, alpha=alpha, closed=closed),
                              {"mesh", "alpha", "meshes", "vertices", "faces", "uvs"}, label="Scene.from_trimesh")
    if scene is REFUSED:
        return
    assert scene.num_faces > 0 and all(finite(m.vertices) for m in scene.meshes)
    assert all((m.alpha is None) == (alpha is None) for m in scene.meshes)


# ----------------------------------------------------------------------------------------------
# Cameras, G-buffers, receivers
# ----------------------------------------------------------------------------------------------

FOV = junk_or(st.one_of(st.floats(1, 170), st.floats(-10, 200), st.sampled_from([0.0, 180.0, 1e-30, 179.9999, np.nan, np.inf])))


@examples(200)
@given(kw=arguments(
    eye=(ORDINARY_VEC3, junk_or(VEC3)), target=(ORDINARY_VEC3, st.one_of(VEC3, st.just("eye"))),
    up=(st.one_of(st.just((0, 1, 0)), ORDINARY_VEC3), st.one_of(VEC3, st.sampled_from(["parallel", "zero"]), JUNK)),
    fov=(st.floats(1, 170), FOV), width=(st.integers(1, 64), INT), height=(st.integers(1, 64), INT),
    resize=(st.tuples(st.integers(1, 64), st.integers(1, 64)), st.tuples(INT, INT)),
))
def test_camera_look_at(kw):
    tried("Camera.look_at", "Camera.with_size")
    eye, target, up, fov, width, height, resize = (kw[k] for k in ("eye", "target", "up", "fov", "width", "height", "resize"))
    if isinstance(target, str):
        target = eye  # eye == target
    if up == "parallel":  # along the view direction
        with np.errstate(all="ignore"):
            up = np.subtract(target, eye) if isinstance(eye, tuple) and len(eye) == 3 else (0, 1, 0)
    elif up == "zero":
        up = (0, 0, 0)
    names = {"eye", "target", "up", "fov_y", "width", "height"}
    camera = result_or_refusal(lambda: ss.Camera.look_at(eye, target, up, fov, width, height), names, label="Camera.look_at")
    if camera is REFUSED:
        return
    assert camera.width == width >= 1 and camera.height == height >= 1 and 0 < camera.fov_y < 180
    assert all(finite(a) and a.dtype == np.float32 for a in (camera.eye, camera.target, camera.up))
    assert not np.array_equal(camera.eye, camera.target)
    resized = result_or_refusal(lambda: camera.with_size(*resize), names, label="Camera.with_size")
    if resized is not REFUSED:
        assert (resized.width, resized.height) == resize and np.array_equal(resized.eye, camera.eye)


@examples(80)
@given(kw=arguments(
    msaa=(st.sampled_from([1, 2, 4, 8, 16, np.int64(4)]), st.sampled_from([0, 1, 2, 3, 4, 8, 16, 32, -1, True, 2.0, "4", None])),
    size=(st.tuples(st.integers(1, 12), st.integers(1, 12)),
          st.sampled_from([(1, 1), (2, 3), (16, 1), (2**20, 2**20), (2**31, 2**31), (2**33, 1)])),
    scene=(st.sampled_from(["ground_sphere", "fence"]), st.sampled_from(["ground_sphere", "fence", "junk"])),
    camera_is_junk=(st.just(False), st.booleans()),
))
def test_gbuffer(kw):
    tried("gbuffer")
    msaa, size, scene, camera_is_junk = kw["msaa"], kw["size"], kw["scene"], kw["camera_is_junk"]
    base = setup("ground_sphere" if scene == "junk" else scene)
    camera = "camera" if camera_is_junk else base.camera.with_size(*size)
    with low_memory():
        gb = result_or_refusal(lambda: ss.gbuffer(base.scene if scene != "junk" else [base.scene], camera, msaa),
                               {"msaa", "scene", "camera", "width"}, label="gbuffer")
    if gb is REFUSED:
        return
    h, w = size[1], size[0]
    assert gb.shape == (h, w) and gb.positions.shape == gb.normals.shape == (h, w, 3)
    hit = gb.mask
    assert np.array_equal(hit, gb.face_ids >= 0) and int(gb.face_ids.max()) < base.scene.num_faces
    assert finite(gb.positions[hit]) and np.allclose(np.linalg.norm(gb.normals[hit], axis=-1), 1, atol=1e-4)
    if int(msaa) > 1:
        assert gb.sample_depths.shape == (h, w, int(msaa)) and np.all(gb.sample_depths > 0)
    else:
        assert gb.sample_depths is None


RECEIVER_SHAPES = st.sampled_from([(0, 3), (1, 3), (5, 3), (5, 2), (3,), (2, 2, 3)])


@examples(150)
@given(ordinary=st.booleans(), k=st.integers(0, 6), data=st.data())
def test_receivers(ordinary, k, data):
    tried("Receivers")
    if ordinary:  # any dtype or layout; normals need not be unit length
        points = data.draw(arrays(st.just((k, 3)), elements=ORDINARY_FLOATS))
        normals = data.draw(arrays(st.just((k, 3)), elements=st.floats(0.125, 2, width=32), dtypes=st.sampled_from([np.float16, np.float32, np.float64])))
    else:
        points = data.draw(st.one_of(arrays(RECEIVER_SHAPES), JUNK))
        same = st.just(points.shape) if isinstance(points, np.ndarray) else RECEIVER_SHAPES
        normals = data.draw(st.one_of(arrays(same), arrays(RECEIVER_SHAPES), JUNK))
    rx = result_or_refusal(lambda: ss.Receivers(points, normals), {"points", "normals"}, label="Receivers")
    if rx is REFUSED:
        return
    assert rx.points.dtype == rx.normals.dtype == np.float32 and rx.points.flags.c_contiguous
    assert finite(rx.points) and finite(rx.normals) and np.all(np.linalg.norm(rx.normals, axis=1) > 0)
    assert rx.shape == (len(rx.points),) and rx.mask.all()
    # Whatever Receivers accepts, a method takes.
    vis = ss.ray_traced(setup().scene, setup().light, rx, samples=4)
    assert vis.shape == rx.shape
    check_visibility(vis)


# ----------------------------------------------------------------------------------------------
# Lights: constructors, samples, weights
# ----------------------------------------------------------------------------------------------

LIGHT_ARGUMENTS = {"position", "center", "u", "v", "normal", "radius", "axes", "emission"}


@examples(300)
@given(light=lights())
def test_light_constructors(light):
    kind, light = light
    tried(kind)
    OUTCOMES[kind, type(light).__name__ if isinstance(light, Exception) else "result"] += 1
    if isinstance(light, Exception):
        refusal_names_an_argument(light, LIGHT_ARGUMENTS)
        return
    center = light.center
    assert finite(center) and center.dtype == np.float32
    assert math.isfinite(light.extent) and light.extent >= 0
    if hasattr(light, "area"):
        assert math.isfinite(light.area) and light.area > 0
    repr(light)


@examples(300)
@given(light=lights(), n=COUNT_MOSTLY, pattern=junk_or(st.sampled_from(ss.lights.PATTERNS)), seed=INT,
       frame=st.one_of(st.just(0), INT))
def test_light_samples_and_weights(light, n, pattern, seed, frame):
    kind, light = light
    if isinstance(light, Exception):
        return
    tried(f"{kind}.samples")
    with low_memory():
        pts = result_or_refusal(lambda: light.samples(n, pattern=pattern, seed=seed, frame=frame), {"n", "pattern", "seed", "frame"}, label=f"{kind}.samples")
    if pts is REFUSED:
        return
    assert pts.shape == (n, 3) and pts.dtype == np.float32 and finite(pts)
    offset = np.linalg.norm(pts.astype(np.float64) - light.center, axis=1)
    scale = float(np.abs(light.center).max())
    assert np.all(offset <= light.extent * (1 + 1e-5) + 1e-6 * scale + 1e-30), "samples lie on the light"
    assert np.array_equal(pts, light.samples(n, pattern=pattern, seed=seed, frame=frame)), "the same seed, the same samples"
    weights = light.weights(pts)
    assert weights.shape == (n,) and finite(weights) and np.all(weights >= 0)


# Regression: the core solved a rectangle's parameters in float32, so frame > 0 (and
# rotate="per_receiver") gave NaN samples for sides below ~1e-22 or above ~1e19.
@pytest.mark.parametrize("u, v", [(0.5, 1e-30), (1e20, 1.0)])
def test_rect_samples_of_extreme_sides_rotate_to_finite_points(u, v):
    assert finite(ss.RectLight((0, 3, 0), (u, 0, 0), (0, 0, v)).samples(16, frame=1))


# ----------------------------------------------------------------------------------------------
# resolve_msaa, stsv_volumes
# ----------------------------------------------------------------------------------------------


@examples(120)
@given(kw=arguments(
    visibility=(arrays(st.just((8, 8)), elements=st.floats(0, 1, width=32)),
                st.one_of(arrays(st.sampled_from([(8, 8), (8, 7), (64,), (8, 8, 1)])), JUNK)),
    msaa=(st.sampled_from([2, 4, 8, 16]), st.sampled_from([1, 2, 4, 8, 16, "junk"])),
    tau=(st.floats(0, 1), junk_or(SIZE)),
))
def test_resolve_msaa(kw):
    tried("resolve_msaa")
    visibility, msaa, tau = kw["visibility"], kw["msaa"], kw["tau"]
    gb = "gbuffer" if msaa == "junk" else gbuffer(msaa)
    out = result_or_refusal(lambda: ss.resolve_msaa(visibility, gb, tau=tau), {"visibility", "gbuffer", "tau"}, label="resolve_msaa")
    if out is REFUSED:
        return
    assert out.shape == (8, 8) and out.dtype == np.float32
    check_visibility(out)
    assert np.all(out[gb.sample_depths.min(axis=-1) == np.inf] == 0), "0 where no sample hits"


# Receivers up to 1e15 from the scene: from 1e20 on the core's back caps overflow (see below).
STSV_COORDS = st.one_of(st.floats(-2, 2, width=32), st.sampled_from([0.0, 1e-30, 1e15, -1e15, np.nan, np.inf]))


@examples(80)
@given(kw=arguments(
    light=(lights(adversarial=st.just(False)), lights()),
    points=(arrays(st.sampled_from([(1, 3), (5, 3)]), elements=st.floats(-2, 2, width=32), dtypes=st.just(np.float32)),
            st.one_of(arrays(RECEIVER_SHAPES, elements=STSV_COORDS, dtypes=st.just(np.float32)), JUNK)),
    hull_degree=(st.integers(3, 64), INT), two_sided=(st.booleans(), junk_or(st.booleans())),
))
def test_stsv_volumes(kw):
    tried("stsv_volumes")
    light, points, hull_degree, two_sided = kw["light"], kw["points"], kw["hull_degree"], kw["two_sided"]
    kind, light = light
    scene = setup("fence").scene
    receivers = (points, np.ones_like(points)) if isinstance(points, np.ndarray) else points
    out = result_or_refusal(lambda: ss.methods.stsv_volumes(scene, light, receivers, hull_degree=hull_degree, two_sided=two_sided),
                            params(ss.methods.stsv_volumes) | {"points", "normals"}, label="stsv_volumes")
    if out is REFUSED:
        return
    faces, corners = out
    perforated = np.concatenate([np.full(len(m.faces), m.perforated) for m in scene.meshes])
    assert corners.shape == (len(faces), 6, 3) and finite(corners)
    assert np.all(perforated[faces.astype(np.int64)]), "volumes only for perforated triangles"


def test_stsv_volumes_of_far_receivers_are_refused_rather_than_infinite():
    # Receivers 1e20 from the light push the back caps past float32's range.
    rx = ss.Receivers([[1e20, 0, 0]], [[0, 1, 0]])
    with pytest.raises(ValueError, match="^receivers:.*float32"):
        ss.methods.stsv_volumes(setup("fence").scene, ss.PointLight((0, 0, 0)), rx)


# ----------------------------------------------------------------------------------------------
# metrics
# ----------------------------------------------------------------------------------------------

IMAGE_SHAPES = st.sampled_from([(7, 7), (8, 9), (9, 8, 3), (1, 1), (0, 0), (5,), (7, 7, 4), (3, 3, 3), (0, 7)])
MASK_KINDS = st.sampled_from(["none", "random", "empty", "int", "float", "wrong shape", "junk"])


@st.composite
def image_pairs(draw):
    """(test, ref, mask): ordinary images in [0, 1] of one shape with an ordinary mask in half the
    examples; otherwise adversarial images (ref sometimes of another shape) and masks of every kind."""
    if draw(st.booleans()):
        shape = draw(st.sampled_from([(7, 7), (8, 9), (9, 8, 3), (12, 10)]))
        pixels = shape[:2]
        test, ref = (draw(arrays(st.just(shape), elements=st.floats(0, 1, width=32), dtypes=st.sampled_from([np.float32, np.float64]))) for _ in "tr")
        mask = draw(st.one_of(st.none(), st.lists(st.booleans(), min_size=math.prod(pixels), max_size=math.prod(pixels))
                              .filter(any).map(lambda m: np.array(m).reshape(pixels))))
        return test, ref, mask
    test = draw(arrays(IMAGE_SHAPES))
    ref = draw(arrays(st.just(test.shape))) if draw(st.booleans()) else draw(arrays(IMAGE_SHAPES))
    pixels = test.shape[:2] if test.ndim == 3 else test.shape
    kind = draw(MASK_KINDS)
    mask = {
        "none": None,
        "random": draw(st.lists(st.booleans(), min_size=math.prod(pixels), max_size=math.prod(pixels))),
        "empty": np.zeros(pixels, bool),
        "int": np.ones(pixels, np.int32),
        "float": np.ones(pixels, np.float64),
        "wrong shape": np.ones((2, 2), bool),
        "junk": draw(JUNK),
    }[kind]
    if kind == "random":
        mask = np.array(mask, bool).reshape(pixels)
    return test, ref, mask


METRIC_ARGUMENTS = {"test", "ref", "mask", "dynamic_range", "vmax", "cmap"}


@examples(250)
@given(images=image_pairs())
def test_rmse(images):
    tried("metrics.rmse")
    test, ref, mask = images
    value = result_or_refusal(lambda: ss.metrics.rmse(test, ref, mask), METRIC_ARGUMENTS, label="metrics.rmse")
    if value is not REFUSED:
        assert math.isfinite(value) and value >= 0
        assert ss.metrics.rmse(test, test, mask) == 0


@examples(120)
@given(images=image_pairs())
def test_ssim(images):
    tried("metrics.ssim")
    test, ref, mask = images
    value = result_or_refusal(lambda: ss.metrics.ssim(test, ref, mask), METRIC_ARGUMENTS, label="metrics.ssim")
    if value is not REFUSED:
        assert math.isfinite(value) and -1 - 1e-6 <= value <= 1 + 1e-6


@examples(120)
@given(images=image_pairs(), dynamic_range=junk_or(st.sampled_from(["LDR", "HDR"])))
def test_flip(images, dynamic_range):
    tried("metrics.flip")
    test, ref, mask = images
    # A reference FLIP cannot take would exit the process (flip_evaluator calls exit()), not raise.
    value = result_or_refusal(lambda: ss.metrics.flip(test, ref, mask, dynamic_range=dynamic_range), METRIC_ARGUMENTS, label="metrics.flip")
    if value is not REFUSED:
        assert math.isfinite(value) and 0 <= value <= 1


@examples(120)
@given(images=image_pairs(), vmax=st.one_of(st.none(), SIZE, JUNK), signed=junk_or(st.booleans()),
       cmap=st.one_of(st.none(), st.sampled_from(["magma", "viridis", "nope"]), JUNK))
def test_error_heatmap(images, vmax, signed, cmap):
    tried("metrics.error_heatmap")
    test, ref, mask = images
    rgb = result_or_refusal(lambda: ss.metrics.error_heatmap(test, ref, mask, vmax=vmax, signed=signed, cmap=cmap), METRIC_ARGUMENTS, label="metrics.error_heatmap")
    if rgb is REFUSED:
        return
    pixels = test.shape[:2] if np.ndim(test) == 3 else np.shape(test)
    assert rgb.shape == (*pixels, 3) and rgb.dtype == np.float32 and finite(rgb) and rgb.min() >= 0 and rgb.max() <= 1


SUMMARY_REGIONS = [k for k in ss.metrics.SUMMARY_KEYS if k.startswith("rmse.")]


@examples(50)
@given(images=image_pairs())
def test_summary(images):
    tried("metrics.summary")
    test, ref, mask = images
    out = result_or_refusal(lambda: ss.metrics.summary(test, ref, mask), METRIC_ARGUMENTS, label="metrics.summary")
    if out is not REFUSED:
        assert tuple(out) == ss.metrics.SUMMARY_KEYS and math.isfinite(out["rmse"]) and not math.isnan(out["psnr"])
        # SSIM and FLIP need an image; a (K,) receiver list gets NaN for them.
        assert np.ndim(test) == 1 or (math.isfinite(out["ssim"]) and math.isfinite(out["flip"]))
        # A region with no receiver has no RMSE (NaN); every other is a finite error.
        assert all(math.isnan(out[k]) or 0 <= out[k] < math.inf for k in SUMMARY_REGIONS)


# ----------------------------------------------------------------------------------------------
# shading
# ----------------------------------------------------------------------------------------------

ALBEDO_VALUE = st.one_of(st.floats(-0.5, 1.5), st.just(np.nan))
ALBEDO = junk_or(st.one_of(st.floats(0, 1), st.tuples(*[st.floats(0, 1)] * 3), ALBEDO_VALUE, st.tuples(*[ALBEDO_VALUE] * 3),
                           st.just((0.1, 0.2))))


@examples(150)
@given(kw=arguments(
    light=(lights(adversarial=st.just(False)), lights()),
    receivers=(st.sampled_from(["gbuffer", "receivers", "tuple"]), st.sampled_from(["gbuffer", "receivers", "tuple", "junk"])),
    visibility=(st.sampled_from(["ones", "random"]), st.sampled_from(["random", "nan", "out of range", "wrong shape", "junk"])),
    albedo=(st.one_of(st.floats(0, 1), st.tuples(*[st.floats(0, 1)] * 3)), ALBEDO),
    intensity=(st.floats(0, 100), junk_or(SIZE)),
    bent_normals=(st.booleans(), st.booleans()), scene=(st.just("right"), st.sampled_from(["right", "other", None])),
), data=st.data())
def test_shading_direct(kw, data):
    tried("shading.direct")
    light, receivers, visibility, albedo, intensity, bent_normals, scene = (
        kw[k] for k in ("light", "receivers", "visibility", "albedo", "intensity", "bent_normals", "scene"))
    kind, light = light
    if receivers == "gbuffer":
        rx = gbuffer()
    elif receivers == "junk":
        rx = data.draw(JUNK)
    else:
        points = data.draw(arrays(st.sampled_from([(0, 3), (4, 3)]), dtypes=st.just(np.float64)))
        normals = np.tile([0.0, 1.0, 0.0], (len(points), 1))
        rx = (points, normals) if receivers == "tuple" else result_or_refusal(lambda: ss.Receivers(points, normals), {"points"})
        if rx is REFUSED:
            return
    shape = rx.shape if hasattr(rx, "shape") else (len(rx[0]),) if receivers == "tuple" else (3,)
    rng = np.random.default_rng(0)
    vis = {"ones": np.ones(shape), "random": rng.random(shape), "nan": np.full(shape, np.nan), "out of range": np.full(shape, 2.0),
           "wrong shape": np.ones((2, 5)), "junk": "visibility"}[visibility]
    scene = {"right": setup().scene, "other": setup("sword").scene, None: None}[scene]
    out = result_or_refusal(
        lambda: ss.shading.direct(rx, light, vis, albedo, intensity=intensity, bent_normals=bent_normals, scene=scene),
        params(ss.shading.direct) | {"receivers", "points", "normals"}, label="shading.direct",
    )
    if out is REFUSED:
        return
    assert out.shape[: len(shape)] == shape and out.dtype == np.float32 and finite(out) and np.all(out >= 0)
    if receivers == "gbuffer":
        assert np.all(out[~rx.mask] == 0)


@examples(120)
@given(light=lights(), points=st.one_of(arrays(st.sampled_from([(0, 3), (3, 3), (2, 2, 3), (3,), (4, 2)])), JUNK),
       normals=st.one_of(st.sampled_from(["up", "up", "same"]), JUNK), intensity=junk_or(SIZE_MOSTLY))
def test_unshadowed_irradiance(light, points, normals, intensity):
    tried("shading.unshadowed_irradiance")
    kind, light = light
    shape = points.shape if isinstance(points, np.ndarray) else (2,)
    if normals == "up":
        normals = np.broadcast_to([0.0, 1.0, 0.0], shape) if shape[-1:] == (3,) else np.ones(2)
    elif normals == "same":
        normals = points
    e = result_or_refusal(lambda: ss.shading.unshadowed_irradiance(points, normals, light, intensity=intensity),
                          params(ss.shading.unshadowed_irradiance), label="shading.unshadowed_irradiance")
    if e is not REFUSED:
        assert e.shape == shape[:-1] and finite(e) and np.all(e >= 0)


# ----------------------------------------------------------------------------------------------
# io: EXR and PNG round trips
# ----------------------------------------------------------------------------------------------

EXR_SHAPES = st.sampled_from([(1, 1), (2, 3), (3, 2, 3), (2, 2, 4), (12, 2, 3), (0, 3), (2, 2, 2), (4,), (1, 1, 1, 1)])
ODD_DTYPES = st.sampled_from([np.float32, np.float64, np.float16, np.int64, np.uint8, np.bool_])


@examples(100)
@given(image=st.one_of(arrays(EXR_SHAPES, dtypes=ODD_DTYPES), JUNK, st.just(np.zeros((2, 2), complex))),
       path=st.sampled_from(["ok", "ok", "ok", "missing folder", "junk"]), layout=junk_or(st.sampled_from(["latlong", "cube"])))
def test_exr_round_trip(outdir, image, path, layout):
    tried("io.write_exr", "io.read_exr", "io.read_environment")
    target = {"ok": outdir / "image.exr", "missing folder": outdir / "missing" / "image.exr", "junk": None}[path]
    written = result_or_refusal(lambda: ss.io.write_exr(target, image), {"image", "path"}, paths=True, label="io.write_exr")
    if written is REFUSED:
        return
    back = ss.io.read_exr(target)
    expected = np.asarray(image).astype(np.float32)
    assert back.dtype == np.float32 and back.shape == expected.shape and np.array_equal(back, expected)
    env = result_or_refusal(lambda: ss.io.read_environment(target, layout=layout), {"layout", "path"}, label="io.read_environment")
    if env is not REFUSED:
        assert env.shape[-1] == 3 and finite(env) and env.min() >= 0
        assert env.ndim == (4 if layout == "cube" else 3)


@examples(15)
@given(path=st.sampled_from(["missing", "folder", "png", "text", "junk"]))
def test_read_exr_of_what_is_not_an_exr(outdir, path):
    tried("io.read_exr")
    (outdir / "text.txt").write_text("not an image")
    ss.io.write_png(outdir / "image.png", np.zeros((2, 2)))
    target = {"missing": outdir / "nope.exr", "folder": outdir, "png": outdir / "image.png", "text": outdir / "text.txt", "junk": 5}[path]
    assert result_or_refusal(lambda: ss.io.read_exr(target), {"path"}, paths=True, label="io.read_exr") is REFUSED


@examples(80)
@given(kw=arguments(
    image=(arrays(st.sampled_from([(1, 1), (2, 3), (3, 2, 3), (2, 2, 4)]), dtypes=ODD_DTYPES, elements=ORDINARY_FLOATS),
           st.one_of(arrays(EXR_SHAPES, dtypes=ODD_DTYPES), JUNK)),
    vmin=(st.floats(-2, 0), junk_or(SIZE.map(lambda x: -x))), vmax=(st.floats(0.5, 2), junk_or(SIZE)),
    cmap=(st.just(None), st.one_of(st.none(), st.sampled_from(["magma", "nope"]), JUNK)),
    path=(st.just("ok"), st.sampled_from(["ok", "missing folder", "junk"])),
))
def test_write_png(outdir, kw):
    import matplotlib.image

    tried("io.write_png")
    image, vmin, vmax, cmap, path = (kw[k] for k in ("image", "vmin", "vmax", "cmap", "path"))
    target = {"ok": outdir / "image.png", "missing folder": outdir / "missing" / "image.png", "junk": None}[path]
    written = result_or_refusal(lambda: ss.io.write_png(target, image, vmin=vmin, vmax=vmax, cmap=cmap),
                                {"image", "path", "vmin", "vmax", "cmap"}, paths=True, label="io.write_png")
    if written is not REFUSED:
        assert matplotlib.image.imread(target).shape[:2] == np.shape(image)[:2]


# ----------------------------------------------------------------------------------------------
# scenes: every procedural builder with adversarial options
# ----------------------------------------------------------------------------------------------

PROCEDURAL = ["ground_sphere", "parallel_plates", "columns", "torus_knot", "fence", "fence_mesh", "leaves", "hairball", "sword"]
CHOICES = {"light": ss.scenes.LIGHT_KINDS, "kind": ("cylinder", "box"), "pattern": ("slats", "grid")}


def option_values(name: str, default):
    """Adversarial values for a builder option, by the type of its default."""
    if name in CHOICES:
        return junk_or(st.sampled_from(CHOICES[name]))
    if name == "light_position":
        return junk_or(st.one_of(VEC3, st.tuples(*[st.floats(-4, 4)] * 2, st.floats(2, 4))))
    if name == "repeats":
        return junk_or(st.tuples(INT, INT))
    if name == "fov_y":
        return FOV
    if isinstance(default, bool):
        return junk_or(st.booleans())
    # Ordinary values near the default, adversarial ones and junk.
    if isinstance(default, int):
        return st.one_of(st.integers(1, max(2 * default, 4)), INT, JUNK)
    return st.one_of(st.floats(0.5 * default, 2 * default) if default else st.floats(0, 1), SIZE, JUNK)


def check_setup(setup_, options=()):
    assert isinstance(setup_, ss.scenes.Setup) and setup_.scene.meshes[0].name == "ground"
    assert all(finite(m.vertices) and len(m.faces) for m in setup_.scene.meshes)
    assert isinstance(setup_.light, ss.lights._Light) and isinstance(setup_.camera, ss.Camera)
    assert setup_.light.center[1] > setup_.occluder_bounds[1, 1], "the light is above the occluders"
    # At the default 8x8 the framed ground fills the view; not with a ground made small on purpose
    # (a perforated fence alone may leave every pixel center in a hole) or an image of 1x8 pixels
    # (far apart in the view's long direction, its 8 centers may all straddle the scene).
    if not {"ground_size", "width", "height"} & set(options) and setup_.scene.num_faces <= 50_000:
        assert ss.gbuffer(setup_.scene, setup_.camera).mask.any(), "the camera sees the scene"


@examples(400)
@given(name=st.sampled_from(PROCEDURAL), data=st.data())
def test_scene_builders(name, data):
    factory = ss.scenes.SCENES[name]
    tried(f"scenes.{name}")
    signature = inspect.signature(factory).parameters
    chosen = data.draw(st.lists(st.sampled_from(sorted(signature)), max_size=3, unique=True))
    options = {"width": 8, "height": 8}
    options.update({k: data.draw(option_values(k, signature[k].default)) for k in chosen})
    with low_memory():
        built = result_or_refusal(lambda: factory(**options), set(signature), label=f"scenes.{name}")
        if built is not REFUSED:
            check_setup(built, options)


@examples(30)
@given(options=st.fixed_dictionaries({}, optional={"size": junk_or(SIZE), "elevation": junk_or(SIZE), "yaw": junk_or(SIZE),
                                                   "light": junk_or(st.sampled_from(ss.scenes.LIGHT_KINDS))}),
       name=junk_or(st.sampled_from(["bone", "teapot"])))
def test_load_model(options, name):
    pytest.importorskip("pymeshlab")
    tried("scenes.load_model")
    built = result_or_refusal(lambda: ss.scenes.load_model(name, width=8, height=8, **options), params(ss.scenes.load_model), label="scenes.load_model")
    if built is not REFUSED:
        check_setup(built, options)


@examples(80)
@given(name=junk_or(st.sampled_from([*PROCEDURAL, "nope"])), pattern=junk_or(st.sampled_from(["slats", "grid", "x"])),
       size=INT, resize=st.tuples(INT, INT), light=st.one_of(st.just("light"), JUNK))
def test_scene_helpers(name, pattern, size, resize, light):
    tried("scenes.get", "scenes.fence_texture", "scenes.leaf_texture", "Setup.with_size", "Setup.with_light")
    with low_memory():
        got = result_or_refusal(lambda: ss.scenes.get(name, width=4, height=4), {"name"}, label="scenes.get")
        if got is not REFUSED:
            assert got.name == name
            resized = result_or_refusal(lambda: got.with_size(*resize), {"width", "height"}, label="Setup.with_size")
            if resized is not REFUSED:
                assert (resized.camera.width, resized.camera.height) == resize
            relit = result_or_refusal(lambda: got.with_light(got.light if light == "light" else light), {"light"}, label="Setup.with_light")
            if relit is not REFUSED:
                assert isinstance(relit.light, ss.lights._Light)
        tile = result_or_refusal(lambda: ss.scenes.fence_texture(pattern), {"pattern"}, label="scenes.fence_texture")
        if tile is not REFUSED:
            assert tile.ndim == 2 and set(np.unique(tile)) <= {0.0, 1.0}
        leaf = result_or_refusal(lambda: ss.scenes.leaf_texture(size), {"size"}, label="scenes.leaf_texture")
        if leaf is not REFUSED:
            assert leaf.shape == (size, size) and set(np.unique(leaf)) <= {0.0, 1.0} and leaf.any()


# ----------------------------------------------------------------------------------------------
# envmap: sky, cube_from_latlong, fit_area_lights, EnvironmentLight.area_light, environment
# ----------------------------------------------------------------------------------------------

ORDINARY_RGB = st.tuples(*[st.floats(0, 2)] * 3)
RGB = junk_or(st.one_of(ORDINARY_RGB, st.tuples(SIZE, SIZE, SIZE)))


@examples(100)
@given(kw=arguments(
    height=(st.integers(1, 32), INT), sun_direction=(ORDINARY_VEC3.filter(any), junk_or(VEC3)),
    sun_radiance=(st.floats(0.1, 5000), junk_or(SIZE)), sun_radius=(st.floats(0.1, 20), junk_or(SIZE)),
    zenith=(ORDINARY_RGB, RGB), horizon=(ORDINARY_RGB, RGB), ground=(ORDINARY_RGB, RGB),
))
def test_sky(kw):
    tried("envmap.sky")
    height, sun_direction, sun_radiance, sun_radius, zenith, horizon, ground = (
        kw[k] for k in ("height", "sun_direction", "sun_radiance", "sun_radius", "zenith", "horizon", "ground"))
    with low_memory():
        env = result_or_refusal(lambda: ss.envmap.sky(height, sun_direction=sun_direction, sun_radiance=sun_radiance,
                                                      sun_radius=sun_radius, zenith=zenith, horizon=horizon, ground=ground),
                                params(ss.envmap.sky), label="envmap.sky")
    if env is not REFUSED:
        assert env.shape == (height, 2 * height, 3) and env.dtype == np.float32 and finite(env) and env.min() >= 0


RADIANCE = st.floats(0, 4, width=32)
LATLONG = arrays(st.sampled_from([(4, 8, 3), (1, 1, 3), (2, 4, 3), (0, 0, 3), (0, 4, 3), (2, 2), (3, 5, 3)]), ordinary=RADIANCE)


@examples(100)
@given(env=st.one_of(LATLONG, JUNK), n=st.one_of(st.integers(1, 8), INT), supersample=st.one_of(st.integers(1, 4), INT))
def test_cube_from_latlong(env, n, supersample):
    tried("envmap.cube_from_latlong")
    with low_memory():
        cube = result_or_refusal(lambda: ss.envmap.cube_from_latlong(env, n, supersample=supersample), {"env", "n", "supersample"}, label="envmap.cube_from_latlong")
    if cube is not REFUSED:
        assert cube.shape == (6, n, n, 3) and finite(cube)


@examples(120)
@given(kw=arguments(
    env=(arrays(st.sampled_from([(4, 8, 3), (2, 4, 3), (6, 2, 2, 3), (6, 3, 3, 3)]), elements=RADIANCE),
         st.one_of(LATLONG, arrays(st.sampled_from([(6, 1, 1, 3), (6, 0, 0, 3), (6, 2, 3, 3), (5, 2, 2, 3)]), ordinary=RADIANCE), JUNK)),
    threshold=(st.floats(0.005, 0.5), junk_or(st.one_of(st.floats(0, 1), SIZE))),
    max_lights=(st.integers(6, 40), INT), resolution=(st.integers(1, 6), INT), square=(st.booleans(), junk_or(st.booleans())),
))
def test_fit_area_lights(kw):
    tried("envmap.fit_area_lights")
    env, threshold, max_lights, resolution, square = (kw[k] for k in ("env", "threshold", "max_lights", "resolution", "square"))
    with low_memory():
        fit = result_or_refusal(lambda: ss.envmap.fit_area_lights(env, threshold=threshold, max_lights=max_lights,
                                                                  resolution=resolution, square=square),
                                params(ss.envmap.fit_area_lights), paths=True, label="envmap.fit_area_lights")  # a str env is an EXR file's path
    if fit is REFUSED:
        return
    assert finite(fit.energy) and np.all(fit.energy >= 0) and finite(fit.cube)
    for light in fit.lights:
        assert np.isclose(np.linalg.norm(light.direction), 1) and light.solid_angle > 0
        assert finite(light.radiance) and np.all(light.radiance >= 0)
    total = sum((light.energy for light in fit.lights), np.zeros(3))
    assert np.allclose(total, fit.energy, rtol=1e-3, atol=1e-30 + 1e-6 * fit.energy.max()), "the lights carry the map's energy"


@functools.lru_cache(maxsize=None)
def small_fit():
    return ss.envmap.fit_area_lights(ss.envmap.sky(8), resolution=4, max_lights=6)


@examples(100)
@given(light=st.integers(0, 5), center=junk_or(VEC3_MOSTLY), distance=junk_or(SIZE_MOSTLY))
def test_environment_light_area_light(light, center, distance):
    tried("EnvironmentLight.area_light")
    env_light = small_fit().lights[light]
    rect = result_or_refusal(lambda: env_light.area_light(center, distance), {"center", "distance"}, label="EnvironmentLight.area_light")
    if rect is not REFUSED:
        assert isinstance(rect, ss.RectLight) and rect.area > 0 and finite(rect.center)
        assert np.dot(rect.normal, env_light.direction) < 0, "the light faces the scene"


@examples(40)
@given(kw=arguments(
    lights_=(st.sampled_from(["fit", "list"]), st.sampled_from(["fit", "list", "empty", "junk"])),
    receivers=(st.sampled_from(["gbuffer", "receivers"]), st.sampled_from(["gbuffer", "receivers", "junk"])),
    method=(st.sampled_from(["ray_traced", "shadow_map", "pcss"]), junk_or(st.sampled_from(["ray_traced", "shadow_map", "nope"]))),
    albedo=(st.one_of(st.floats(0, 1), st.tuples(*[st.floats(0, 1)] * 3)), ALBEDO),
    distance=(st.one_of(st.none(), st.floats(20, 100)), st.one_of(st.none(), junk_or(SIZE))),
    scene=(st.just("scene"), st.sampled_from(["scene", None])),
))
def test_environment(kw):
    tried("environment")
    lights_, receivers, method, albedo, distance, scene = (kw[k] for k in ("lights_", "receivers", "method", "albedo", "distance", "scene"))
    fit = small_fit()
    lights_ = {"fit": fit, "list": fit.lights[:2], "empty": [], "junk": "lights"}[lights_]
    rx = {"gbuffer": gbuffer(), "receivers": ss.Receivers(np.zeros((3, 3)), np.tile([0, 1, 0], (3, 1))), "junk": None}[receivers]
    options = {"samples": 4} if method == "ray_traced" else {"resolution": 64} if method in ("shadow_map", "pcss") else {}
    out = result_or_refusal(lambda: ss.environment(setup().scene if scene else None, lights_, rx, method=method, albedo=albedo,
                                                   distance=distance, progress=False, **options),
                            params(ss.environment) | set(options), label="environment")
    if out is not REFUSED:
        assert out.shape == rx.shape + (3,) and out.dtype == np.float32 and finite(out) and out.min() >= 0


# ----------------------------------------------------------------------------------------------
# plot
# ----------------------------------------------------------------------------------------------


@examples(15)
@given(kw=arguments(
    reference=(arrays(st.sampled_from([(6, 6), (4, 5)]), elements=st.floats(0, 1)),
               st.one_of(arrays(st.sampled_from([(6, 6), (0, 0), (6,)]), elements=st.floats(0, 1)), JUNK)),
    results=(st.sampled_from(["one", "two", "empty"]), st.sampled_from(["one", "wrong shape", "nan", "int keys", "junk"])),
    mask=(st.sampled_from([None, "random"]), st.sampled_from([None, "random", "empty", "wrong"])),
    vmax=(st.floats(0.01, 1), junk_or(SIZE)),
))
def test_comparison_grid(kw):
    import matplotlib.pyplot as plt

    tried("plot.comparison_grid")
    reference, results, mask, vmax = kw["reference"], kw["results"], kw["mask"], kw["vmax"]
    shape = reference.shape if isinstance(reference, np.ndarray) else (4, 4)
    results = {"one": {"a": np.zeros(shape)}, "two": {"a": np.zeros(shape), "b": np.ones(shape)}, "empty": {},
               "wrong shape": {"a": np.zeros((3, 5))}, "nan": {"a": np.full(shape, np.nan)}, "int keys": {1: np.zeros(shape)},
               "junk": None}[results]
    mask = {None: None, "random": np.indices(shape).sum(0) % 2 == 0 if len(shape) == 2 else None,
            "empty": np.zeros(shape, bool), "wrong": np.ones((2, 2), bool)}[mask]
    fig = result_or_refusal(lambda: ss.plot.comparison_grid(reference, results, mask, vmax=vmax), params(ss.plot.comparison_grid), label="plot.comparison_grid")
    if fig is not REFUSED:
        assert len(fig.axes) == 2 * (1 + len(results))
        plt.close(fig)


@examples(40)
@given(light=lights(), samples=st.one_of(arrays(st.sampled_from([(0, 3), (1, 3), (5, 3), (5, 2)])), JUNK))
def test_show_samples(light, samples):
    import matplotlib.pyplot as plt

    tried("plot.show_samples")
    kind, light = light
    ax = result_or_refusal(lambda: ss.plot.show_samples(light, samples), params(ss.plot.show_samples), label="plot.show_samples")
    if ax is not REFUSED:
        plt.close(ax.figure)


# ----------------------------------------------------------------------------------------------
# evaluation: argument checks (nothing is rendered: every call gets at least one bad argument)
# ----------------------------------------------------------------------------------------------

BAD_COUNT = st.one_of(st.integers(-3, 0), st.sampled_from([2**64, 2**70, 1.5, "8", None, True]))
BAD_NAMES = st.sampled_from([None, "sword", ["nope"], [5], [["x"]], 5, {"x"}])
BAD = {
    # methods=None means every method: not a bad value.
    "scenes": BAD_NAMES, "methods": BAD_NAMES.filter(lambda x: x is not None), "lights": BAD_NAMES, "size": BAD_COUNT,
    "samples": BAD_COUNT,
    "reference_samples": BAD_COUNT, "repeat": BAD_COUNT, "render_spp": BAD_COUNT,
    "options": st.sampled_from([5, "x", {"nope": {}}, {"ray_traced": 5}, {"ray_traced": {1: 2}}]),
    "method": st.sampled_from([None, "nope", ["ray_traced"], 5]),
    "parameters": st.sampled_from([None, 5, {"samples": 8}, {"samples": "8"}, {1: [8]}, ["samples"]]),
    "executor": st.sampled_from([5, "pool", object()]),
}


@examples(60)
@given(bad=st.lists(st.sampled_from(["scenes", "methods", "lights", "size", "samples", "reference_samples", "repeat",
                                     "render_spp", "options"]), min_size=1, max_size=2, unique=True), data=st.data())
def test_evaluate_refuses_bad_arguments_up_front(bad, data):
    tried("evaluate")
    kwargs = {"scenes": ("sword",), "methods": ["ray_traced"], "size": 8, "samples": 4, "reference_samples": 4, "repeat": 1,
              "progress": False}
    kwargs.update({k: data.draw(BAD[k]) for k in bad})
    with pytest.raises(ValueError) as refusal:
        ss.evaluate(**kwargs)
    refusal_names_an_argument(refusal.value, set(bad))
    OUTCOMES["evaluate", "ValueError"] += 1


@examples(60)
@given(bad=st.lists(st.sampled_from(["method", "parameters", "scenes", "lights", "size", "samples", "reference_samples",
                                     "executor"]), min_size=1, max_size=2, unique=True), data=st.data())
def test_sweep_refuses_bad_arguments_up_front(bad, data):
    tried("sweep")
    kwargs = {"method": "ray_traced", "parameters": {"samples": [4]}, "scenes": ("sword",), "size": 8, "samples": 4,
              "reference_samples": 4, "progress": False}
    kwargs.update({k: data.draw(BAD[k]) for k in bad})
    with pytest.raises(ValueError) as refusal:
        ss.sweep(**kwargs)
    refusal_names_an_argument(refusal.value, set(bad))
    OUTCOMES["sweep", "ValueError"] += 1


@st.composite
def result_frames(draw):
    """Frames like evaluate()'s: random groups, NaN and infinite metrics, sometimes a column short."""
    import pandas as pd

    n = draw(st.integers(0, 8))
    metric = st.one_of(st.floats(0, 10), st.sampled_from([np.nan, np.inf, 0.0]))
    frame = pd.DataFrame({
        "scene": draw(st.lists(st.sampled_from(["a", "b"]), min_size=n, max_size=n)),
        "light": draw(st.lists(st.sampled_from(["rect", "disk"]), min_size=n, max_size=n)),
        "method": draw(st.lists(st.sampled_from(["m1", "m2", "m3"]), min_size=n, max_size=n)),
        **{c: draw(st.lists(metric, min_size=n, max_size=n)) for c in ("rmse", "ssim", "flip", "seconds")},
        "error": [None] * n,
    })
    drop = draw(st.sampled_from([None, None, None, "rmse", "seconds", "scene"]))
    return frame.drop(columns=[drop]) if drop else frame


@examples(150)
@given(frame=st.one_of(result_frames(), JUNK), x=st.sampled_from(["seconds", "flip", "nope"]), y=st.sampled_from(["rmse", "ssim"]))
def test_pareto_front(frame, x, y):
    tried("evaluation.pareto_front")
    front = result_or_refusal(lambda: ss.evaluation.pareto_front(frame, x, y), {"frame", "x", "y"}, label="evaluation.pareto_front")
    if front is REFUSED:
        return
    assert front.dtype == bool and front.index.equals(frame.index)
    values = frame[[x, y]].to_numpy(float)
    ok = np.isfinite(values).all(axis=1)
    assert not front[~ok].any(), "rows with NaN are not on the front"
    for a in values[front.to_numpy()]:
        assert not np.any(ok & np.all(values <= a, axis=1) & np.any(values < a, axis=1)), "no front row is dominated"
    assert front.any() or not ok.any()


@examples(100)
@given(frame=st.one_of(result_frames(), JUNK), markers=st.booleans())
def test_results_table_and_update_readme(outdir, frame, markers):
    tried("evaluation.results_table", "evaluation.update_readme")
    table = result_or_refusal(lambda: ss.evaluation.results_table(frame), {"frame"}, label="evaluation.results_table")
    if table is not REFUSED:
        assert table.count("\n") == 1 + frame["method"].nunique()
    readme = outdir / "README.md"
    start, end = ss.evaluation.README_MARKERS
    readme.write_text(f"# x\n{start}\nold\n{end}\ntail\n" if markers else "# x\n")
    done = result_or_refusal(lambda: ss.evaluation.update_readme(frame, readme), {"frame", "path"}, label="evaluation.update_readme")
    if done is not REFUSED:
        text = readme.read_text()
        assert text.startswith("# x\n") and text.endswith("tail\n") and "old" not in text


@examples(10)
@given(frame=st.one_of(result_frames().filter(lambda f: "scene" not in f or "rmse" not in f), JUNK))
def test_report_refuses_frames_it_cannot_read(outdir, frame):
    tried("evaluation.report")
    assert result_or_refusal(lambda: ss.evaluation.report(frame, outdir / "report"), {"frame", "out"}, label="evaluation.report") is REFUSED


# ----------------------------------------------------------------------------------------------
# Threads and memory
# ----------------------------------------------------------------------------------------------


@examples(60)
@given(threads=st.one_of(INT, JUNK, st.sampled_from([None, 0, 1, 2, 3, 1024, 1025, 10**5])))
def test_set_num_threads(threads):
    tried("set_num_threads", "num_threads")
    try:
        done = result_or_refusal(lambda: ss.set_num_threads(threads), {"threads"}, label="set_num_threads")
        # Only small pools are built here: 1024 threads would take seconds to start.
        if done is not REFUSED and isinstance(threads, int) and 1 <= threads <= 4:
            assert ss.num_threads() == threads
            check_visibility(ss.ray_traced(setup().scene, setup().light, gbuffer(), samples=4))
    finally:
        ss.set_num_threads(None)
    assert ss.num_threads() == os.cpu_count() or ss.num_threads() >= 1


@examples(80)
@given(limit=st.one_of(INT, SIZE, JUNK, st.sampled_from([None, 1, 100, 2**30, 2**64 - 1, "100"])))
def test_set_memory_limit(limit):
    tried("set_memory_limit", "memory_limit")
    default = ss.memory_limit()
    try:
        done = result_or_refusal(lambda: ss.set_memory_limit(limit), {"bytes"}, label="set_memory_limit")
        if done is not REFUSED:
            exact = isinstance(limit, (int, np.integer))  # an int is taken exactly (float(2**64 - 1) is 2**64)
            assert ss.memory_limit() == (default if limit is None else int(limit) if exact else int(float(limit)))
            if ss.memory_limit() < 4096:
                with pytest.raises(MemoryError, match="set_memory_limit"):
                    ss.SphereLight((0, 0, 0), 1).samples(1024)
    finally:
        ss.set_memory_limit(None)
    assert ss.memory_limit() == default


# ----------------------------------------------------------------------------------------------
# reference: argument checks only (Mitsuba is slow: every call gets at least one bad argument)
# ----------------------------------------------------------------------------------------------

REFERENCE_BAD = {
    "scene": st.sampled_from([None, "scene", []]),
    "light": st.sampled_from([None, "light", 5]),
    "camera": st.sampled_from(["camera", 5]),
    "receivers": st.sampled_from([None, "rx", (np.zeros((2, 3)),)]),
    "samples": st.sampled_from([0, -1, 2**70, "x", np.zeros((0, 3)), np.full((2, 3), np.nan), True]),
    "epsilon": st.sampled_from([-1.0, np.nan, "x"]),
    "spp": BAD_COUNT,
    "seed": st.sampled_from([-1, 2**32, 2**70, 1.5, "x"]),
    "albedo": st.sampled_from([-0.1, 1.5, np.nan, "x"]),
    "intensity": st.sampled_from([0.0, -1.0, np.inf, "x"]),
    "integrator": st.sampled_from(["nope", None, 5]),
    "env": st.sampled_from([np.zeros((0, 0, 3)), -np.ones((2, 4, 3)), np.full((2, 4, 3), np.nan), np.ones((2, 4)), "x"]),
}


@examples(100)
@given(function=st.sampled_from(["mitsuba_scene", "mitsuba_visibility", "mitsuba_render", "mitsuba_environment_render"]),
       data=st.data())
def test_reference_refuses_bad_arguments_before_rendering(function, data):
    pytest.importorskip("mitsuba")
    tried(f"reference.{function}")
    base = setup("sword")
    valid = {"scene": base.scene, "light": base.light, "camera": base.camera.with_size(4, 4), "spp": 1,
             "receivers": ss.Receivers(np.zeros((2, 3)), np.tile([0, 1, 0], (2, 1))), "samples": 4, "env": ss.envmap.sky(4)}
    call = getattr(ss.reference, function)
    names = [k for k in params(call) if k in REFERENCE_BAD]
    bad = data.draw(st.lists(st.sampled_from(names), min_size=1, max_size=2, unique=True))
    kwargs = {k: valid[k] for k in params(call) if k in valid}
    kwargs.update({k: data.draw(REFERENCE_BAD[k]) for k in bad})
    if "cache" in params(call):
        kwargs["cache"] = False
    if "progress" in params(call):
        kwargs["progress"] = False
    with pytest.raises(ValueError) as refusal:
        call(**kwargs)
    refusal_names_an_argument(refusal.value, set(bad))
    OUTCOMES[f"reference.{function}", "ValueError"] += 1

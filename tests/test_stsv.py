"""Soft textured shadow volumes against the ray-traced oracle (with alpha test) on the same samples."""

import numpy as np
import pytest

import softshadows as ss
from conftest import quad
from softshadows.methods import STSV_FACES, stsv_volumes


def case(name, size=96, **options):
    setup = ss.scenes.get(name, width=size, height=size, **options)
    return setup, ss.gbuffer(setup.scene, setup.camera)


def mixed(size=96, **options):
    """The columns (opaque, closed) with the fence's two perforated quads among them."""
    columns, fence = ss.scenes.get("columns", width=size, height=size, **options), ss.scenes.get("fence")
    scene = ss.Scene(columns.scene.meshes + [m for m in fence.scene.meshes if m.perforated])
    return columns.light, scene, ss.gbuffer(scene, columns.camera)


def scenes():
    for name in ("fence", "leaves"):
        setup, gb = case(name)
        yield name, setup.light, setup.scene, gb
    yield ("mixed", *mixed())


#: The rotation each exact framework is tested with on the scenes' rect lights: dcs decorrelates
#: per receiver (the default, Forest et al. 2009, section 4.1); alias_free's bitmasks share one
#: pattern for a rectangle (its decorrelation is not a rigid rotation).
ROTATE = {"dcs": "per_receiver", "bitmask": None}


@pytest.mark.parametrize("opaque", ["bitmask", "dcs"])
def test_exact_combinations_give_the_oracles_bits(opaque):
    for name, light, scene, gb in scenes():
        samples = light.samples(64, pattern="poisson", seed=3)
        rotate = ROTATE[opaque]
        exact = ss.ray_traced(scene, light, gb, samples=samples, rotate=rotate)
        assert np.mean((exact > 0) & (exact < 1) & gb.mask) > 0.05, f"{name} needs a penumbra"
        vis, stats = ss.stsv(scene, light, gb, samples=samples, opaque=opaque, rotate=rotate, return_stats=True)
        np.testing.assert_array_equal(vis, exact, err_msg=name)
        assert stats["volumes"] > 0 and stats["receivers_inside"] > 0
        assert stats["receivers_tested"] >= stats["receivers_inside"]


def test_one_sided_volumes_miss_the_light_behind_a_triangle():
    # Forest et al. 2009, section 6: leaves straddled by the light only block the part on their center's side.
    setup, gb = case("leaves")
    samples = setup.light.samples(64, seed=3)
    exact = ss.ray_traced(setup.scene, setup.light, gb, samples=samples, rotate="per_receiver")
    one, one_stats = ss.stsv(setup.scene, setup.light, gb, samples=samples, two_sided=False, return_stats=True)
    two, two_stats = ss.stsv(setup.scene, setup.light, gb, samples=samples, return_stats=True)
    assert two_stats["volumes"] > one_stats["volumes"]
    assert np.all(one[gb.mask] >= exact[gb.mask]) and np.any(one[gb.mask] > exact[gb.mask])
    np.testing.assert_array_equal(two, exact)


def test_penumbra_wedges_with_volumes_are_close():
    light, scene, gb = mixed()
    samples = light.samples(64, seed=3)
    exact = ss.ray_traced(scene, light, gb, samples=samples, rotate="per_receiver")
    approx = ss.stsv(scene, light, gb, samples=samples, opaque="penumbra_wedge", two_sided=True)
    err = (approx - exact)[gb.mask]
    # Approximate (opaque and perforated shadows add up where they overlap), yet close.
    assert 0 < np.sqrt(np.mean(err**2)) < 0.05


def test_two_perforated_triangles_match_the_explicit_fence():
    quads, mesh = ss.scenes.get("fence", width=96, height=96), ss.scenes.get("fence_mesh", width=96, height=96)
    gb, gb_mesh = ss.gbuffer(quads.scene, quads.camera), ss.gbuffer(mesh.scene, mesh.camera)
    samples = quads.light.samples(64, seed=1)
    perforated = ss.stsv(quads.scene, quads.light, gb, samples=samples)
    explicit = ss.dcs(mesh.scene, mesh.light, gb_mesh, samples=samples)
    both = gb.mask & gb_mesh.mask
    assert sum(len(m.faces) for m in mesh.scene.meshes) > 50 * sum(len(m.faces) for m in quads.scene.meshes if m.perforated)
    # The two G-buffers' points differ by float round-off (2.4e-7 here), and no sample of this
    # scene lies that close to an edge: every pixel agrees.
    np.testing.assert_array_equal(perforated[both], explicit[both])


def textured_quad_scene(alpha, uvs=None):
    ground = quad((0, 0), 3.0, 0.0, name="ground")
    card = quad((0.1, -0.2), 0.6, 1.0, uvs=True, alpha=alpha, name="card")
    if uvs is not None:
        card = ss.Mesh(card.vertices, card.faces, uvs=uvs, alpha=alpha, name="card")
    light = ss.RectLight((0, 3, 0), (0.5, 0, 0), (0, 0, 0.5))  # facing down
    cam = ss.Camera.look_at((0, 4, 2.5), (0, 0, 0), fov_y=50, width=64, height=64)
    scene = ss.Scene([ground, card])
    return scene, light, ss.gbuffer(scene, cam)


def test_all_transparent_and_all_opaque_textures():
    scene, light, gb = textured_quad_scene(np.zeros((4, 4), np.float32))
    samples = light.samples(64, seed=2)
    assert np.all(ss.stsv(scene, light, gb, samples=samples)[gb.mask] == ss.dcs(ss.Scene(scene.meshes[:1]), light, gb, samples=samples)[gb.mask])
    scene, light, gb = textured_quad_scene(np.ones((4, 4), np.float32))
    solid = ss.Scene([scene.meshes[0], ss.Mesh(scene.meshes[1].vertices, scene.meshes[1].faces)])
    vis = ss.stsv(scene, light, gb, samples=samples)
    np.testing.assert_array_equal(vis, ss.dcs(solid, light, gb, samples=samples))
    assert vis[gb.mask].min() == 0


def test_uvs_outside_the_unit_square_wrap():
    checker = np.indices((8, 8)).sum(axis=0) % 2
    uvs = np.array([[-1.25, 0.5], [2.75, 0.5], [2.75, 4.5], [-1.25, 4.5]], np.float32)
    scene, light, gb = textured_quad_scene(checker.astype(np.float32), uvs=uvs)
    samples = light.samples(64, seed=2)
    exact = ss.ray_traced(scene, light, gb, samples=samples, rotate="per_receiver")
    np.testing.assert_array_equal(ss.stsv(scene, light, gb, samples=samples), exact)


def test_degenerate_perforated_triangles_cast_nothing():
    scene, light, gb = textured_quad_scene(np.ones((4, 4), np.float32))
    flat = scene.meshes[1].vertices.copy()
    flat[2] = flat[0] + 0.5 * (flat[1] - flat[0])  # triangle [0, 2, 1] collapses onto an edge
    flat[3] = flat[0]  # triangle [0, 3, 2] collapses too
    card = ss.Mesh(flat, scene.meshes[1].faces, uvs=scene.meshes[1].uvs, alpha=scene.meshes[1].alpha)
    degenerate = ss.Scene([scene.meshes[0], card])
    vis, stats = ss.stsv(degenerate, light, gb, samples=16, return_stats=True)
    assert stats["volumes"] == 0 and np.all(vis[gb.mask] == ss.ray_traced(degenerate, light, gb, samples=16)[gb.mask])


def test_volumes_are_closed_and_hold_the_shadowed_receivers():
    setup, gb = case("fence", size=48)
    faces, corners = stsv_volumes(setup.scene, setup.light, gb)
    assert len(faces) == 4 and corners.shape == (4, 6, 3)
    import trimesh

    volumes = [trimesh.Trimesh(c, STSV_FACES, process=False) for c in corners]
    for volume in volumes:
        assert volume.is_watertight and volume.volume > 0
    # A receiver that a perforated triangle hides part of the light from lies in that triangle's
    # volume (Forest et al. 2009, section 3: the volume bounds every such point). Only the
    # perforated quads cast here, so the oracle's shadowed receivers are exactly those. They sit
    # on the ground, where the back caps are clamped: lifted off it by 1e-4 along the normal.
    shadowed = gb.mask & (ss.ray_traced(setup.scene, setup.light, gb, samples=256, rotate=None) < 1)
    points = (gb.positions + 1e-4 * gb.normals)[shadowed]
    inside = np.zeros(len(points), bool)
    for volume in volumes:
        inside |= volume.contains(points)
    outside = np.flatnonzero(~inside)
    assert len(points) > 100 and len(outside) == 0, f"{len(outside)} of {len(points)} shadowed receivers lie outside every volume"
    lit = (gb.positions + 1e-4 * gb.normals)[gb.mask & ~shadowed]
    assert not np.logical_or.reduce([volume.contains(lit) for volume in volumes]).all()  # the volumes are bounded


@pytest.mark.parametrize("options, match", [({"opaque": "shadow_map"}, "opaque"), ({"samples": 1025}, "samples"),
                                            ({"resolution": 0}, "resolution"), ({"hull_degree": 2}, "hull_degree")])
def test_bad_options_name_the_argument(options, match):
    setup, gb = case("fence", size=16)
    with pytest.raises(ValueError, match=match):
        ss.stsv(setup.scene, setup.light, gb, **options)


@pytest.mark.parametrize("opaque", ["bitmask", "dcs"])
@pytest.mark.parametrize("kind", ["rect", "disk", "sphere"])
def test_samples_off_the_light_give_the_oracles_bits(opaque, kind):
    # Samples of a light twice as large: the volumes, their influence regions and the opaque
    # part's regions bounded the light, not the samples given (hundreds of pixels differed).
    light, scene, gb = mixed(size=32, light=kind)
    center = np.asarray(light.center, np.float32)
    samples = center + 2 * (light.samples(32, seed=3) - center)
    rotate = ROTATE[opaque] if kind == "rect" else "per_receiver"
    exact = ss.ray_traced(scene, light, gb, samples=samples, rotate=rotate)
    vis = ss.stsv(scene, light, gb, samples=samples, opaque=opaque, two_sided=True, rotate=rotate)
    np.testing.assert_array_equal(vis, exact)


@pytest.mark.parametrize("kind", ["rect", "disk", "sphere", "ellipsoid"])
@pytest.mark.parametrize("scale", [1, 2])
def test_shared_samples_give_the_oracles_bits_on_and_off_every_light(kind, scale):
    # Samples shared by every receiver are binned in the light's plane and only those in the box
    # of a triangle's cone from the receiver are projected: volumetric lights and samples off
    # the light lie off that plane, and the box widens by the samples' distance from it.
    light, scene, gb = mixed(size=32, light=kind)
    center = np.asarray(light.center, np.float32)
    samples = center + scale * (light.samples(32, seed=3) - center)
    exact = ss.ray_traced(scene, light, gb, samples=samples, rotate=None)
    assert np.mean((exact > 0) & (exact < 1) & gb.mask) > 0.02, "the case needs a penumbra"
    vis = ss.stsv(scene, light, gb, samples=samples, opaque="dcs", rotate=None)
    np.testing.assert_array_equal(vis, exact)


def leaf_card_under_an_overhead_light(size=96):
    """A vertical leaf card over a ground quad, its plane through the overhead light's center."""
    ground = ss.Mesh(np.float32([[-2, 0, -2], [2, 0, -2], [2, 0, 2], [-2, 0, 2]]), np.uint32([[0, 2, 1], [0, 3, 2]]))
    card = ss.Mesh(np.float32([[0, 0.4, -0.6], [0, 0.4, 0.6], [0, 1.6, 0.6], [0, 1.6, -0.6]]),
                   np.uint32([[0, 1, 2], [0, 2, 3]]), uvs=np.float32([[0, 0], [1, 0], [1, 1], [0, 1]]),
                   alpha=ss.scenes.leaf_texture(64))
    scene = ss.Scene([ground, card])
    light = ss.RectLight((0.05, 3.0, 0.0), (0.6, 0, 0), (0, 0, 0.6))  # facing down
    camera = ss.Camera(np.float32([2.5, 2.5, 2.5]), np.float32([0, 0.3, 0]), np.float32([0, 1, 0]), 45.0, size, size)
    return scene, light, ss.gbuffer(scene, camera)


@pytest.mark.parametrize("opaque", ["bitmask", "dcs"])
def test_the_default_is_exact_for_a_card_the_light_straddles(opaque):
    # The light lies on both sides of the card's plane: the paper's one-sided volumes never
    # block the part behind it (550 of 6033 pixels brighter than the oracle, up to 0.39), and
    # were the default; two-sided volumes are, and give the oracle's bits on every pixel.
    scene, light, gb = leaf_card_under_an_overhead_light()
    samples = light.samples(64, seed=3)
    rotate = ROTATE[opaque]
    exact = ss.ray_traced(scene, light, gb, samples=samples, rotate=rotate)
    np.testing.assert_array_equal(ss.stsv(scene, light, gb, samples=samples, opaque=opaque, rotate=rotate), exact)
    one_sided = ss.stsv(scene, light, gb, samples=samples, opaque=opaque, rotate=rotate, two_sided=False)
    assert np.all(one_sided[gb.mask] >= exact[gb.mask]) and np.sum((one_sided > exact) & gb.mask) > 300


@pytest.mark.parametrize("kind", ["disk", "sphere", "ellipsoid"])
@pytest.mark.parametrize("options", [{"rotate": "per_receiver"}, {"rotate": None, "interleaved": 4},
                                     {"rotate": "per_receiver", "interleaved": 2, "frame": 3}])
def test_every_light_and_sampling_option_gives_the_oracles_bits(kind, options):
    # The perforated quads among the closed columns, under each volumetric or round light, with
    # the decorrelations of Forest et al. 2009, section 4.1 and Figure 5f, and temporal jitter.
    light, scene, gb = mixed(size=48, light=kind)
    exact = ss.ray_traced(scene, light, gb, samples=32, pattern="poisson", seed=5, **options)
    assert np.mean((exact > 0) & (exact < 1) & gb.mask) > 0.02, "the case needs a penumbra"
    vis = ss.stsv(scene, light, gb, samples=32, pattern="poisson", seed=5, opaque="dcs", **options)
    np.testing.assert_array_equal(vis, exact)


@pytest.mark.parametrize("samples", [64, 128])
def test_within_penumbra_wedges_stsv_adds_one_bit_per_sample_and_receiver(samples):
    # Forest et al. 2009, section 5.1: the light sample buffer, one bit per sample and receiver
    # ("64 x 1024^2 x 1 bit"); the rest of stsv's own memory grows with the perforated
    # triangles and the light samples (the paper's "64 x 16 bits" of sample pattern: ours keeps
    # the pattern's coordinates in the light's plane and its bins), not with the receivers.
    extra = {}
    for size in (64, 96):
        setup, gb = case("fence", size=size)
        _, with_stsv = ss.stsv(setup.scene, setup.light, gb, samples=samples, opaque="penumbra_wedge",
                               two_sided=False, return_stats=True)
        opaque = ss.Scene([m for m in setup.scene.meshes if not m.perforated])
        _, alone = ss.penumbra_wedge(opaque, setup.light, gb, samples=samples, return_stats=True)
        extra[gb.mask.size] = with_stsv["peak_bytes"] - alone["peak_bytes"]
    (small, low), (large, high) = sorted(extra.items())
    assert (high - low) / (large - small) == samples / 8
    assert 0 < low - small * samples / 8 < 4096 + 128 * samples, \
        "the four perforated triangles' volumes and edges, and at most 128 bytes per light sample"

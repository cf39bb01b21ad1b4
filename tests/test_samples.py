"""Sample patterns: counts, bounds on the light, Poisson distance, determinism, decorrelation."""

import numpy as np
import pytest

import softshadows as ss

LIGHTS = {
    "rect": ss.RectLight((0, 5, 0), (0.5, 0, 0), (0, 0, 0.5)),
    "disk": ss.DiskLight((1, 4, 2), (0, -1, 0), 0.75),
    "sphere": ss.SphereLight((0, 3, 0), 0.4),
    "ellipsoid": ss.EllipsoidLight((0, 3, 1), [[0.6, 0.6, 0], [-0.2, 0.2, 0], [0, 0, 0.3]]),
}


def on_light(name, pts):
    """Whether every point lies on (in) the light."""
    light = LIGHTS[name]
    d = pts.astype(np.float64) - light.center
    tol = 1e-5
    if name == "rect":
        return np.all(np.abs(d[:, 1]) < tol) and np.all(np.abs(d[:, [0, 2]]) <= 0.5 + tol)
    if name == "disk":
        return np.all(np.abs(d @ light.normal) < tol) and np.all(np.linalg.norm(d, axis=1) <= 0.75 + tol)
    if name == "ellipsoid":
        x = d @ np.linalg.inv(light.axes.astype(np.float64))
        return np.all(np.linalg.norm(x, axis=1) <= 1 + tol)
    return np.all(np.linalg.norm(d, axis=1) <= 0.4 + tol)


@pytest.mark.parametrize("pattern", ss.lights.PATTERNS)
@pytest.mark.parametrize("name", LIGHTS)
def test_counts_bounds_and_determinism(name, pattern):
    light = LIGHTS[name]
    a = light.samples(50, pattern=pattern, seed=3)
    assert a.shape == (50, 3) and a.dtype == np.float32
    assert on_light(name, a)
    np.testing.assert_array_equal(a, light.samples(50, pattern=pattern, seed=3))
    assert not np.array_equal(a, light.samples(50, pattern=pattern, seed=4))
    assert len(np.unique(a.round(6), axis=0)) == 50


@pytest.mark.parametrize("n, r", [(16, 0.2456139), (64, 0.1076681)])
def test_poisson_minimum_distance_of_seed_001(n, r):
    # A unit square light: parameter distances equal world distances.
    pts = LIGHTS["rect"].samples(n, pattern="poisson", seed=9)[:, [0, 2]].astype(np.float64)
    d = np.linalg.norm(pts[:, None] - pts[None], axis=-1) + np.eye(n) * 10
    assert d.min() >= r * (1 - 1e-5)


def test_stratified_square_counts_fill_every_cell():
    pts = LIGHTS["rect"].samples(64, pattern="stratified", seed=2)[:, [0, 2]] + 0.5
    cells = np.floor(pts * 8).astype(int)
    assert len({tuple(c) for c in cells}) == 64


def test_uniform_samples_cover_the_light_evenly():
    pts = LIGHTS["disk"].samples(20000, pattern="uniform", seed=1).astype(np.float64)
    r = np.linalg.norm(pts - LIGHTS["disk"].center, axis=1) / 0.75
    # Area-uniform on a disk: P(r < 1/sqrt2) = 1/2.
    assert abs(np.mean(r < np.sqrt(0.5)) - 0.5) < 0.015


def test_ellipsoid_samples_fill_its_volume_evenly():
    light = LIGHTS["ellipsoid"]
    pts = light.samples(20000, pattern="uniform", seed=1).astype(np.float64)
    x = (pts - light.center) @ np.linalg.inv(light.axes.astype(np.float64))
    # Volume-uniform: P(|x| < 1/2) = 1/8 in the unit ball, and the ball's octants are even.
    assert abs(np.mean(np.linalg.norm(x, axis=1) < 0.5) - 0.125) < 0.01
    assert np.all(np.abs(np.mean(x > 0, axis=0) - 0.5) < 0.015)


def test_frame_jitter_moves_the_pattern_but_keeps_it_on_the_light():
    light = LIGHTS["disk"]
    f0, f1 = light.samples(32, frame=0), light.samples(32, frame=1)
    assert not np.allclose(f0, f1)
    assert on_light("disk", f1)
    np.testing.assert_array_equal(f1, light.samples(32, frame=1))


@pytest.mark.parametrize("bad, arg", [(dict(pattern="blue"), "pattern"), (dict(seed=-1), "seed"), (dict(frame=1.5), "frame")])
def test_bad_sampling_options_name_the_argument(bad, arg):
    with pytest.raises(ValueError, match=arg):
        LIGHTS["rect"].samples(16, **bad)
    with pytest.raises(ValueError, match="^n:"):
        LIGHTS["rect"].samples(0)


EMISSION = np.arange(1, 7, dtype=np.float32).reshape(3, 2)  # 3 rows (bands of b) x 2 columns (bands of a)


def documented_weights(light, ab):
    """lights.RectLight's docstring: row i covers b in the i-th of H bands from -1 to 1, column j of a."""
    h, w = EMISSION.shape
    i = np.minimum(((ab[:, 1] + 1) / 2 * h).astype(int), h - 1)
    j = np.minimum(((ab[:, 0] + 1) / 2 * w).astype(int), w - 1)
    return EMISSION[i, j]


@pytest.mark.parametrize("v", [(0.0, -0.7, 0.0), (0.0, -0.7, 0.1)], ids=["orthogonal", "parallelogram"])
def test_emission_texture_orientation_matches_the_docstring(v):
    light = ss.RectLight((0.3, 2.0, 0.1), (0.5, 0.0, 0.2), v, emission=EMISSION)
    ab = np.random.default_rng(0).uniform(-0.98, 0.98, (500, 2))
    points = light.center + ab[:, :1] * light.u + ab[:, 1:] * light.v
    np.testing.assert_array_equal(light.weights(points), documented_weights(light, ab))


MASK64 = 2**64 - 1


def splitmix64(state):
    """One step of the core's SplitMix64 generator (``Rng`` in rust/core/src/light/sampling.rs):
    the new state and the output."""
    state = (state + 0x9E3779B97F4A7C15) & MASK64
    z = ((state ^ (state >> 30)) * 0xBF58476D1CE4E5B9) & MASK64
    z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & MASK64
    return state, z ^ (z >> 31)


def pattern_seed(seed, j):
    """The seed of interleaved pattern ``j`` of ``seed``: stream ``j`` of the generator (its first
    output skipped), as ``SampleSet`` draws it, for ``light.samples`` to build the pattern alone."""
    state, _ = splitmix64(seed ^ ((0x9E3779B97F4A7C15 * (j + 1)) & MASK64))
    return splitmix64(state)[1]


@pytest.fixture
def small_penumbra():
    """A 7 x 5 image of a sphere's soft shadow, a third of its pixels partly lit."""
    setup = ss.scenes.ground_sphere(width=7, height=5, light_size=3.0)
    yield setup, ss.gbuffer(setup.scene, setup.camera)
    ss.set_memory_limit(None)


@pytest.mark.parametrize("rotate", [None, "per_receiver"])
def test_interleaving_builds_only_the_patterns_of_the_pixels(small_penumbra, rotate):
    setup, gb = small_penumbra
    native = ss._core.NativeSamples.generate(
        setup.light.native(), 16, "poisson", 7, 1000, rotate is not None, 0, gb.native()
    )
    assert native.patterns == 7 * 5
    assert ss._core.NativeSamples.generate(setup.light.native(), 16, "poisson", 7, 3, False, 0).patterns == 9
    # 10^6 patterns of 16 samples would need 192 MB; the 35 the pixels use, a few kB.
    ss.set_memory_limit(1 << 20)
    vis = ss.ray_traced(setup.scene, setup.light, gb, samples=16, seed=7, interleaved=1000, rotate=rotate)
    assert np.sum((vis > 0) & (vis < 1)) >= 10
    for y in range(5):
        for x in range(7):
            # Pixel (x, y) uses pattern x + 1000 y: built alone, then shared by every receiver.
            own = setup.light.samples(16, pattern="poisson", seed=pattern_seed(7, x + 1000 * y))
            expected = ss.ray_traced(setup.scene, setup.light, gb, samples=own, seed=7, rotate=rotate)
            assert vis[y, x] == expected[y, x], (x, y)


@pytest.mark.parametrize("method", ["ray_traced", "alias_free", "dcs", "stsv"])
@pytest.mark.parametrize("frame", [0, 3])
def test_a_sample_count_draws_the_pattern_of_light_samples(small_penumbra, method, frame):
    # samples=n without interleaving is light.samples(n, pattern=, seed=, frame=) itself, so a
    # count and the drawn array compare bit for bit (the frames of Sintorn et al. 2008, Figure 7,
    # accumulate to the union of their patterns).
    setup, gb = small_penumbra
    options = {"rotate": None, "lut": None} if method == "alias_free" else {"rotate": None}
    drawn = setup.light.samples(16, pattern="halton", seed=5, frame=frame)
    counted = ss.METHODS[method](setup.scene, setup.light, gb, samples=16, pattern="halton", seed=5, frame=frame, **options)
    np.testing.assert_array_equal(counted, ss.METHODS[method](setup.scene, setup.light, gb, samples=drawn, **options))


def test_a_rect_light_takes_its_documented_keywords():
    by_name = ss.RectLight(center=(0, 3, 0), u=(0.5, 0, 0), v=(0, 0, 0.25))
    np.testing.assert_array_equal(by_name.samples(8), ss.RectLight((0, 3, 0), (0.5, 0, 0), (0, 0, 0.25)).samples(8))
    assert "v=[0.0, 0.0, 0.25]" in repr(by_name)

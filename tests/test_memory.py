"""Every method estimates its whole peak memory before allocating (docs/design.md section 6).

Each run reports its estimate as the stat ``peak_bytes``. With the limit one byte below it, the
same call raises MemoryError naming the method, the estimate and the knob; with the limit at it,
the call runs: no stage inside asks for more than the method's peak.
"""

import pytest

import softshadows as ss

# Each method with option sets that change which buffers it holds.
CASES = [
    ("ray_traced", {}),
    ("shadow_map", {"resolution": 128}),
    ("pcss", {"resolution": 128}),
    ("mvr", {"resolution": 64, "samples": 4}),
    ("vwss", {"resolution": 64, "samples": 4}),
    ("vwss", {"resolution": 64, "samples": 4, "layered": False, "precision": "float16"}),
    ("vwss", {"resolution": 64, "samples": 4, "mode": "unbuffered"}),
    ("cssm", {"resolution": 128}),
    ("cssm", {"resolution": 128, "prefilter": "mipmap"}),
    ("alias_free", {"samples": 64, "resolution": 64}),
    ("alias_free", {"samples": 64, "resolution": 64, "lut": None, "restrict_to_penumbra": False}),
    ("dcs", {"samples": 32}),
    ("penumbra_wedge", {"samples": 32}),
    ("stsv", {"samples": 32}),
    ("stsv", {"samples": 32, "opaque": "dcs"}),
    ("stsv", {"samples": 32, "opaque": "penumbra_wedge"}),
    ("backprojection", {"resolution": 128}),
    ("backprojection", {"resolution": 128, "occluder": "microrect", "accel": "mssm"}),
    ("backprojection", {"resolution": 128, "accel": "ysm", "ysm_resolution": 32}),
    ("denoised", {}),
    ("denoised", {"spp": 4, "max_radius": 64}),
]


@pytest.fixture(scope="module")
def setup():
    s = ss.scenes.get("columns").with_size(24, 24)
    return s, ss.gbuffer(s.scene, s.camera)


@pytest.fixture(autouse=True)
def default_limit():
    yield
    ss.set_memory_limit(None)


def test_every_method_is_covered():
    assert {name for name, _ in CASES} == set(ss.METHODS)


@pytest.mark.parametrize(("method", "options"), CASES, ids=[f"{m}-{i}" for i, (m, _) in enumerate(CASES)])
def test_peak_estimate_is_checked_before_allocating(setup, method, options):
    s, receivers = setup
    run = ss.METHODS[method]
    _, stats = run(s.scene, s.light, receivers, return_stats=True, **options)
    peak = int(stats["peak_bytes"])
    assert peak >= 4 * 24 * 24, "the estimate holds at least the visibility"
    ss.set_memory_limit(peak - 1)
    with pytest.raises(MemoryError, match=rf"^{method} needs about .*\({peak} bytes\).*set_memory_limit"):
        run(s.scene, s.light, receivers, **options)
    ss.set_memory_limit(peak)
    vis = run(s.scene, s.light, receivers, **options)
    assert vis.shape == (24, 24)

"""Every method's stats keys are the ones the core declares (``softshadows._core.STATS``), on
every path (options, backends, early exits), and its docstring lists them."""

import numpy as np
import pytest

import softshadows as ss
from softshadows import _core

OBJECT_BASED = ("dcs", "penumbra_wedge", "alias_free")

VARIANTS = {
    "ray_traced": [{}, {"caster_faces": "all"}],
    "shadow_map": [{}, {"pcf": 3}],
    "mvr": [{}],
    "vwss": [{}, {"mode": "unbuffered"}, {"parallel": "full"}],
    "pcss": [{}],
    "backprojection": [{}, {"accel": "ysm"}, {"accel": "mssm"}, {"accumulation": "area"}, {"budget": 4}],
    "cssm": [{}, {"prefilter": "mipmap"}],
    "alias_free": [{}, {"lut": None}, {"lut": 16}],
    "dcs": [{}],
    "penumbra_wedge": [{}],
    "stsv": [{"opaque": "bitmask", "rotate": None}, {"opaque": "dcs"}, {"opaque": "penumbra_wedge"}],
    "denoised": [{}, {"spp": 4, "history": ss.History()}],
}
GPU_METHODS = ("shadow_map", "mvr", "vwss", "pcss", "cssm", "alias_free")
# Keys the Python layer adds after the core: backprojection's multisample resolve (section 7).
PYTHON_KEYS = {"backprojection": {"msaa_resolve_seconds", "msaa_overhead"}}


@pytest.fixture(scope="module")
def columns():
    setup = ss.scenes.get("columns", width=12, height=12)
    return setup, ss.gbuffer(setup.scene, setup.camera)


@pytest.fixture(scope="module")
def gpu_adapter():
    try:
        return ss.gpu_info()
    except RuntimeError as error:
        pytest.skip(f"no GPU adapter: {error}")


def allowed(method, options):
    """The keys a call may return: its own, and for stsv its opaque method's."""
    keys = set(_core.STATS[method]) | PYTHON_KEYS.get(method, set())
    if method == "stsv":
        keys |= set(_core.STATS["alias_free" if options["opaque"] == "bitmask" else options["opaque"]])
    return keys


def check_keys(method, stats, options):
    assert set(stats) <= allowed(method, options), set(stats) - allowed(method, options)
    assert set(_core.STATS[method]) <= set(stats), set(_core.STATS[method]) - set(stats)


def test_every_method_is_declared_and_common_keys_come_last():
    assert set(_core.STATS) == set(VARIANTS)
    for keys in _core.STATS.values():
        assert keys[-2:] == ("peak_bytes", "work") and len(set(keys)) == len(keys)


@pytest.mark.parametrize("method, options", [(m, o) for m, vs in VARIANTS.items() for o in vs])
def test_a_call_returns_its_declared_keys(columns, method, options):
    setup, gb = columns
    _, stats = getattr(ss, method)(setup.scene, setup.light, gb, return_stats=True, **options)
    check_keys(method, stats, options)


@pytest.mark.parametrize("method", sorted(VARIANTS))
def test_an_early_exit_returns_the_declared_keys_too(columns, method):
    setup, _ = columns
    if method == "denoised":  # a G-buffer only: one of the sky, where no pixel hits
        nothing = ss.gbuffer(setup.scene, ss.Camera.look_at((0, 50, 0), (0, 100, 0), up=(1, 0, 0), width=4, height=4))
    else:
        nothing = ss.Receivers(np.zeros((1, 3)), [[0, 1, 0]])
        nothing.mask[:] = False  # no valid receiver: the methods return before their stages
    options = VARIANTS[method][0]
    _, stats = getattr(ss, method)(setup.scene, setup.light, nothing, return_stats=True, **options)
    check_keys(method, stats, options)


@pytest.mark.gpu
@pytest.mark.parametrize("method", GPU_METHODS)
def test_the_gpu_backend_returns_the_declared_keys(columns, method, gpu_adapter):
    setup, gb = columns
    _, stats = getattr(ss, method)(setup.scene, setup.light, gb, return_stats=True, backend="gpu")
    check_keys(method, stats, {})


@pytest.mark.parametrize("method", sorted(VARIANTS))
def test_the_docstring_lists_every_declared_key(method):
    doc = getattr(ss, method).__doc__
    missing = [key for key in _core.STATS[method] if f"``{key}``" not in doc]
    assert not missing, missing


# The work counters (issue: cost per unit of work): each is the count its paper names, checked
# against an identity the method's structure implies.


def stats_of(method, setup, gb, **options):
    return getattr(ss, method)(setup.scene, setup.light, gb, return_stats=True, **options)[1]


@pytest.mark.parametrize("method", ["dcs", "penumbra_wedge"])
def test_the_wedge_methods_test_each_light_sample_once_per_wedge_test(columns, method):
    setup, gb = columns
    stats = stats_of(method, setup, gb, samples=setup.light.samples(48, pattern="poisson", seed=1))
    assert stats["wedge_tests"] > 0
    assert stats["sample_tests"] == stats["wedge_tests"] * 48


def test_vwss_warps_every_point_into_every_map_of_each_traversal(columns):
    setup, gb = columns
    stats = stats_of("vwss", setup, gb)
    assert stats["points"] > 0
    assert stats["point_warps"] == stats["points"] * stats["maps_per_traversal"] * stats["traversals"]


def test_pcss_reads_its_sample_counts_per_searched_and_filtered_receiver(columns):
    setup, gb = columns
    stats = stats_of("pcss", setup, gb, blocker_samples=16, filter_samples=32)
    filtered = round(gb.mask.sum() * (1 - stats["no_blocker"]))
    assert filtered > 0
    assert stats["filter_taps"] == filtered * 32
    searched, rest = divmod(stats["search_taps"], 16)
    assert rest == 0 and filtered <= searched <= gb.mask.sum()


def test_cssm_reads_one_box_per_stage_from_the_table_and_more_from_the_mipmap(columns):
    setup, gb = columns
    sat = stats_of("cssm", setup, gb)["taps"]
    mipmap = stats_of("cssm", setup, gb, prefilter="mipmap")["taps"]
    assert 0 < sat <= 2 * gb.mask.sum()
    assert mipmap > sat


def test_backprojection_backprojects_some_of_what_it_processes(columns):
    setup, gb = columns
    stats = stats_of("backprojection", setup, gb)
    assert 0 < stats["backprojected"] < stats["processed"]
    receivers = round(gb.mask.sum() * stats["backprojecting_percent"] / 100)
    assert stats["processed"] == pytest.approx(stats["processed_mean"] * receivers, rel=1e-6)


def test_alias_free_tests_more_pairs_with_more_casters():
    setup = ss.scenes.get("columns", width=12, height=12)
    gb = ss.gbuffer(setup.scene, setup.camera)
    floor_only = ss.alias_free(ss.Scene([setup.scene.meshes[0]]), setup.light, gb, return_stats=True)[1]
    stats = stats_of("alias_free", setup, gb)
    assert 0 <= floor_only["pair_tests"] < stats["pair_tests"]
    # A pair needs at most the triangle's four bounding planes (section 4.1).
    assert 0 < stats["plane_mask_ops"] <= 4 * stats["pair_tests"]


def test_stsv_projects_only_the_light_samples_a_volume_can_hide():
    # Per receiver inside a volume, equations 1-5 project the samples that count and are not
    # blocked yet; samples shared by the receivers are projected only where they lie in the
    # bounding box of the triangle's cone from the receiver on the light: small leaves hide a
    # small part of a large light.
    setup = ss.scenes.get("leaves", n=40, width=24, height=24)
    gb = ss.gbuffer(setup.scene, setup.camera)
    samples = setup.light.samples(64, pattern="poisson", seed=0)
    for rotate, most in (("per_receiver", 1.0), (None, 0.25)):
        stats = stats_of("stsv", setup, gb, samples=samples, rotate=rotate)
        assert 0 < stats["sample_projections"] <= most * 64 * stats["receivers_inside"], rotate


@pytest.mark.gpu
@pytest.mark.parametrize("method, keys", [("alias_free", ("pair_tests", "plane_mask_ops")), ("cssm", ("taps",))])
def test_counters_the_shaders_do_not_keep_are_nan_on_the_gpu(columns, method, keys, gpu_adapter):
    setup, gb = columns
    stats = stats_of(method, setup, gb, backend="gpu")
    assert all(np.isnan(stats[k]) for k in keys)

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
}
GPU_METHODS = ("shadow_map", "mvr", "vwss", "pcss", "cssm", "alias_free")
# Keys the Python layer adds after the core: backprojection's multisample resolve (section 7).
PYTHON_KEYS = {"backprojection": {"msaa_resolve_seconds", "msaa_overhead"}}


@pytest.fixture(scope="module")
def columns():
    setup = ss.scenes.get("columns", width=12, height=12)
    return setup, ss.gbuffer(setup.scene, setup.camera)


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
    nothing = ss.Receivers(np.zeros((1, 3)), [[0, 1, 0]])
    nothing.mask[:] = False  # no valid receiver: the methods return before their stages
    options = VARIANTS[method][0]
    _, stats = getattr(ss, method)(setup.scene, setup.light, nothing, return_stats=True, **options)
    check_keys(method, stats, options)


@pytest.mark.gpu
@pytest.mark.parametrize("method", GPU_METHODS)
def test_the_gpu_backend_returns_the_declared_keys(columns, method):
    try:
        ss.gpu_info()
    except RuntimeError as error:
        pytest.skip(f"no GPU adapter: {error}")
    setup, gb = columns
    _, stats = getattr(ss, method)(setup.scene, setup.light, gb, return_stats=True, backend="gpu")
    check_keys(method, stats, {})


@pytest.mark.parametrize("method", sorted(VARIANTS))
def test_the_docstring_lists_every_declared_key(method):
    doc = getattr(ss, method).__doc__
    missing = [key for key in _core.STATS[method] if f"``{key}``" not in doc]
    assert not missing, missing

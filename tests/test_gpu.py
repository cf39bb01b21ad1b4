"""The GPU backend (wgpu) against the CPU on the same samples; skipped only where no adapter exists
(CI has Mesa's lavapipe). Texel-for-texel map equality and the splitting of large inputs under
forced-low limits are checked in ``rust/core/tests/gpu.rs``."""

import os
import pickle
import select
import signal
import subprocess
import sys
import textwrap
import time
import warnings
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

import softshadows as ss

pytestmark = pytest.mark.gpu


@pytest.fixture(scope="module")
def adapter():
    try:
        return ss.gpu_info()
    except RuntimeError as error:
        pytest.skip(f"no GPU adapter: {error}")


def test_gpu_info_names_the_adapter_and_its_limits(adapter):
    assert adapter["name"] and adapter["backend"] in {"vulkan", "metal", "dx12"}
    assert adapter["max_workgroups_per_dimension"] >= 1 and adapter["max_storage_binding_bytes"] >= 1 << 20
    assert isinstance(adapter["timestamp_queries"], bool)


@pytest.mark.parametrize(
    ("scene", "options"),
    [
        ("columns", {}),
        ("columns", {"precision": "float16", "parallel": "full"}),
        ("fence", {"layered": False}),
        ("torus_knot", {"parallel": "serial", "samples": 6}),
    ],
)
def test_vwss_on_the_gpu_equals_the_cpu(adapter, scene, options):
    s = ss.scenes.get(scene).with_size(64, 64)
    gb = ss.gbuffer(s.scene, s.camera)
    options = {"resolution": 256, "samples": 12, **options}
    cpu, cpu_stats = ss.vwss(s.scene, s.light, gb, backend="cpu", return_stats=True, **options)
    gpu, gpu_stats = ss.vwss(s.scene, s.light, gb, backend="gpu", return_stats=True, **options)
    assert np.abs(gpu - cpu).max() <= 1e-6
    assert ((cpu > 0) & (cpu < 1)).any(), "the scene must have penumbrae"
    assert set(gpu_stats) == set(cpu_stats)
    assert gpu_stats["points"] == cpu_stats["points"] and gpu_stats["traversals"] == cpu_stats["traversals"]


@pytest.mark.parametrize(
    ("scene", "options"),
    [
        ("columns", {}),
        ("torus_knot", {"order": 16}),
        ("fence", {"resolution": 1024}),
        ("columns", {"sharpen_a": 30.0, "scale": 1.5}),
        # 257 channels of 256 texels: a row's prefix sums over every channel would take more
        # loop steps than llvmpipe runs (65535).
        ("columns", {"order": 64, "resolution": 256}),
    ],
)
def test_cssm_on_the_gpu_is_within_1e3_of_the_cpu(adapter, scene, options):
    s = ss.scenes.get(scene).with_size(64, 64)
    gb = ss.gbuffer(s.scene, s.camera)
    cpu, cpu_stats = ss.cssm(s.scene, s.light, gb, backend="cpu", return_stats=True, **options)
    gpu, gpu_stats = ss.cssm(s.scene, s.light, gb, backend="gpu", return_stats=True, **options)
    assert np.abs(gpu - cpu).max() <= 1e-3
    assert ((cpu > 0.05) & (cpu < 0.95)).any(), "the scene must have penumbrae"
    assert set(gpu_stats) == set(cpu_stats)


@pytest.mark.parametrize("options", [{}, {"pcf": 5}, {"pcf": 3, "bias": 0.02, "resolution": 2048}])
def test_shadow_map_on_the_gpu_equals_the_cpu(adapter, options):
    s = ss.scenes.get("torus_knot").with_size(64, 64)
    gb = ss.gbuffer(s.scene, s.camera)
    cpu = ss.shadow_map(s.scene, s.light, gb, backend="cpu", **options)
    gpu = ss.shadow_map(s.scene, s.light, gb, backend="gpu", **options)
    assert np.array_equal(cpu, gpu)
    assert (cpu == 0).any() and (cpu == 1).any(), "the scene must have shadows"


@pytest.mark.parametrize(
    ("scene", "options"), [("columns", {}), ("torus_knot", {"bias": 0.02, "blocker_samples": 16}), ("fence", {"near": 1.0})]
)
def test_pcss_on_the_gpu_equals_the_cpu(adapter, scene, options):
    s = ss.scenes.get(scene).with_size(64, 64)
    gb = ss.gbuffer(s.scene, s.camera)
    cpu, cpu_stats = ss.pcss(s.scene, s.light, gb, backend="cpu", return_stats=True, **options)
    gpu, gpu_stats = ss.pcss(s.scene, s.light, gb, backend="gpu", return_stats=True, **options)
    assert np.array_equal(cpu, gpu)
    assert ((cpu > 0) & (cpu < 1)).any(), "the scene must have penumbrae"
    assert gpu_stats["no_blocker"] == cpu_stats["no_blocker"] and set(gpu_stats) == set(cpu_stats)


def test_cssm_mipmaps_are_refused_on_the_gpu(adapter):
    s = ss.scenes.get("columns").with_size(8, 8)
    with pytest.raises(ValueError, match="^prefilter:"):
        ss.cssm(s.scene, s.light, ss.gbuffer(s.scene, s.camera), backend="gpu", prefilter="mipmap")


@pytest.mark.parametrize(("scene", "options"), [("columns", {}), ("torus_knot", {"pcf": 1, "samples": 6}), ("bunny", {"resolution": 512})])
def test_mvr_on_the_gpu_equals_the_cpu(adapter, scene, options):
    s = ss.scenes.get(scene).with_size(64, 64)
    gb = ss.gbuffer(s.scene, s.camera)
    options = {"resolution": 256, "samples": 12, **options}
    cpu, cpu_stats = ss.mvr(s.scene, s.light, gb, backend="cpu", return_stats=True, **options)
    gpu, gpu_stats = ss.mvr(s.scene, s.light, gb, backend="gpu", return_stats=True, **options)
    assert np.abs(gpu - cpu).max() <= 1e-6
    assert ((cpu > 0) & (cpu < 1)).any(), "the scene must have penumbrae"
    assert gpu_stats["fragments"] == cpu_stats["fragments"] and set(gpu_stats) == set(cpu_stats)


def test_mvr_refuses_perforated_meshes_on_the_gpu(adapter):
    s = ss.scenes.get("fence").with_size(8, 8)
    with pytest.raises(ValueError, match="^backend:.*alpha"):
        ss.mvr(s.scene, s.light, ss.gbuffer(s.scene, s.camera), backend="gpu", resolution=64, samples=4)


@pytest.mark.parametrize(
    ("scene", "light", "options"),
    [
        ("columns", "rect", {}),
        ("columns", "disk", {"lut": None, "rotate": "per_receiver", "samples": 64}),
        ("fence", "rect", {"samples": 100}),
        ("torus_knot", "sphere", {"restrict_to_penumbra": False, "hull_degree": 8}),
        ("leaves", "rect", {"lut": None, "samples": 64}),
        ("columns", "point", {"caster_faces": "all"}),
    ],
)
def test_alias_free_on_the_gpu_equals_the_cpu_bit_for_bit(adapter, scene, light, options):
    s = ss.scenes.get(scene, light=light).with_size(64, 64)
    gb = ss.gbuffer(s.scene, s.camera)
    options = {"resolution": 128, **options}
    cpu, cpu_stats = ss.alias_free(s.scene, s.light, gb, backend="cpu", return_stats=True, **options)
    gpu, gpu_stats = ss.alias_free(s.scene, s.light, gb, backend="gpu", return_stats=True, **options)
    assert np.array_equal(gpu.view(np.uint32), cpu.view(np.uint32))
    if light != "point":
        assert ((cpu > 0) & (cpu < 1)).any(), "the scene must have penumbrae"
    assert set(gpu_stats) == set(cpu_stats)
    for key in ("view_samples", "casters", "average_list_length", "max_list_length", "occupied_texels_percent"):
        assert gpu_stats[key] == cpu_stats[key], key


def test_alias_free_on_the_gpu_around_a_lamp_in_a_room(adapter):
    # One GPU pass per cube face around the light, each face's receivers their own lists.
    from test_lights_among_geometry import LIGHTS, room, wall_receivers

    scene, light, rx = room(), LIGHTS["rect"], wall_receivers(12)
    samples = light.samples(64, pattern="poisson", seed=5)
    exact = ss.ray_traced(scene, light, rx, samples=samples)
    gpu, stats = ss.alias_free(scene, light, rx, samples=samples, lut=None, backend="gpu", return_stats=True)
    assert stats["light_faces"] == 6
    np.testing.assert_array_equal(gpu, exact)


def test_depth_map_lookups_on_the_gpu_around_a_lamp_equal_the_cpu(adapter):
    # One map per cube face; each face's receivers looked up on the GPU as for one fitted map.
    from test_lights_among_geometry import LIGHTS, room, wall_receivers

    scene, light, rx = room(), LIGHTS["rect"], wall_receivers(12)
    for method, tolerance in ((ss.shadow_map, 0.0), (ss.pcss, 0.0), (ss.cssm, 1e-3)):
        cpu = method(scene, light, rx, resolution=256, backend="cpu")
        gpu, stats = method(scene, light, rx, resolution=256, backend="gpu", return_stats=True)
        assert stats["light_faces"] == 6
        assert np.abs(gpu - cpu).max() <= tolerance, method.__name__


def test_gpu_calls_from_8_threads_at_once_equal_serial_calls(adapter):
    s = ss.scenes.get("columns").with_size(32, 32)
    gb = ss.gbuffer(s.scene, s.camera)
    calls = [
        lambda: ss.vwss(s.scene, s.light, gb, backend="gpu", resolution=128, samples=6),
        lambda: ss.mvr(s.scene, s.light, gb, backend="gpu", resolution=128, samples=6),
        lambda: ss.cssm(s.scene, s.light, gb, backend="gpu", resolution=128),
        lambda: ss.pcss(s.scene, s.light, gb, backend="gpu", resolution=128),
        lambda: ss.alias_free(s.scene, s.light, gb, backend="gpu", resolution=64, samples=32),
    ] * 2
    serial = [call() for call in calls]
    with ThreadPoolExecutor(8) as pool:
        concurrent = list(pool.map(lambda call: call(), calls))
    for a, b in zip(serial, concurrent):
        assert np.array_equal(a, b)


def _every_gpu_method():
    s = ss.scenes.get("columns").with_size(32, 32)
    gb = ss.gbuffer(s.scene, s.camera)
    return {
        "vwss": lambda: ss.vwss(s.scene, s.light, gb, backend="gpu", resolution=128, samples=6),
        "mvr": lambda: ss.mvr(s.scene, s.light, gb, backend="gpu", resolution=128, samples=6),
        "cssm": lambda: ss.cssm(s.scene, s.light, gb, backend="gpu", resolution=128),
        "pcss": lambda: ss.pcss(s.scene, s.light, gb, backend="gpu", resolution=128),
        "alias_free": lambda: ss.alias_free(s.scene, s.light, gb, backend="gpu", resolution=64, samples=32),
    }


def _fork_and_run(calls):
    """Forks; the child runs ``calls`` and pickles their results (or its error's repr) into a
    pipe, then exits. Returns the child's payload, or ``None`` when the child has not closed the
    pipe after :data:`_FORK_TIMEOUT` seconds (it is then killed)."""
    reader, writer = os.pipe()
    with warnings.catch_warnings():
        # Python 3.12+ warns that forking a process with threads may deadlock the child: the
        # very case under test.
        warnings.filterwarnings("ignore", message=".*fork.*", category=DeprecationWarning)
        pid = os.fork()
    if pid == 0:
        try:
            os.close(reader)
            try:
                payload = {"info": ss.gpu_info(), **{name: call() for name, call in calls.items()}}
            except BaseException as error:
                payload = repr(error)
            with os.fdopen(writer, "wb") as out:
                pickle.dump(payload, out)
        finally:
            os._exit(0)  # never back into the parent's pytest
    os.close(writer)
    try:
        data = _read_until_closed(reader, time.monotonic() + _FORK_TIMEOUT)
    finally:
        os.close(reader)
        if data is None:
            os.kill(pid, signal.SIGKILL)
        os.waitpid(pid, 0)
    return None if data is None else pickle.loads(data)


_FORK_TIMEOUT = 60.0


def _read_until_closed(reader, deadline):
    """Every byte from ``reader`` until the writer closes it, or ``None`` past ``deadline``."""
    chunks = []
    while (left := deadline - time.monotonic()) > 0:
        if select.select([reader], [], [], left)[0]:
            chunk = os.read(reader, 1 << 16)
            if not chunk:
                return b"".join(chunks)
            chunks.append(chunk)
    return None


@pytest.mark.skipif(not hasattr(os, "fork"), reason="os.fork does not exist on this platform (Windows); the test forks a child after GPU calls, which only POSIX systems can do")
def test_a_forked_child_builds_its_own_gpu_context_and_gets_the_parents_results(adapter):
    calls = _every_gpu_method()
    # The parent's context and every method's pipelines exist before the fork.
    parent = {name: call() for name, call in calls.items()}
    child = _fork_and_run(calls)
    assert child is not None, f"the forked child's GPU calls did not return within {_FORK_TIMEOUT:.0f} s"
    assert isinstance(child, dict), f"the forked child's GPU calls failed: {child}"
    assert child["info"] == adapter
    for name in calls:
        assert np.array_equal(child[name], parent[name]), name


def test_unbuffered_mode_is_refused_on_the_gpu(adapter):
    s = ss.scenes.get("columns").with_size(8, 8)
    with pytest.raises(ValueError, match="^mode:"):
        ss.vwss(s.scene, s.light, ss.gbuffer(s.scene, s.camera), backend="gpu", mode="unbuffered")


def test_bad_backend_is_refused():
    s = ss.scenes.get("columns").with_size(8, 8)
    with pytest.raises(ValueError, match="^backend:"):
        ss.vwss(s.scene, s.light, ss.gbuffer(s.scene, s.camera), backend="cuda")


def test_without_an_adapter_gpu_raises_and_auto_falls_back_with_a_warning():
    # WGPU_BACKEND=metal asks for a backend this Linux build lacks: no adapter, whatever the machine.
    script = textwrap.dedent(
        """
        import warnings, numpy as np, softshadows as ss
        s = ss.scenes.get("columns").with_size(16, 16)
        gb = ss.gbuffer(s.scene, s.camera)
        try:
            ss.vwss(s.scene, s.light, gb, backend="gpu", resolution=64, samples=4)
            raise SystemExit("backend='gpu' ran without an adapter")
        except RuntimeError as error:
            assert "mesa-vulkan-drivers" in str(error), error
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            auto = ss.vwss(s.scene, s.light, gb, backend="auto", resolution=64, samples=4)
        assert any("runs on the CPU" in str(w.message) for w in caught), caught
        assert np.array_equal(auto, ss.vwss(s.scene, s.light, gb, resolution=64, samples=4))
        print("ok")
        """
    )
    env = {**os.environ, "WGPU_BACKEND": "metal"}
    result = subprocess.run([sys.executable, "-c", script], env=env, capture_output=True, text=True, timeout=300)
    assert result.returncode == 0 and result.stdout.strip() == "ok", result.stdout + result.stderr

"""CPU against GPU (wgpu) per method, side by side in one run, on the same receivers and samples.

For each method with a GPU path it runs ``backend="cpu"`` and ``backend="gpu"`` alternately
(best of ``--repeat``), and prints the seconds of each stage, the total, the ratio CPU / GPU
(above 1: the GPU is faster) and the largest difference between the two visibilities. The
stages are the methods' own stats: ``vwss`` point generation (CPU either way), depth maps
(warping) and lighting; ``cssm`` basis images, prefilter (summed-area table) and lookup;
``shadow_map`` render and lookup (5x5 PCF); ``pcss`` depth map and lookups (blocker search and
filter); ``mvr`` depth maps (rasterized on the GPU) and lighting; ``alias_free`` list build,
rasterization (the casters and their regions' polygons, on the CPU either way) and visibility
(the per-texel tests), with the paper's 512x512 lists and 256 samples. The single shadow maps of
``cssm``, ``shadow_map`` and ``pcss`` are rasterized on the CPU either way.

``gpu_info()`` names the adapter: on a machine without a GPU that is Mesa's lavapipe, a Vulkan
driver that runs the shaders on the CPU, and the ratios then compare two CPU implementations.

Usage: ``python bench/gpu.py [--size 1024] [--scene bunny] [--views 24] [--repeat 2]``
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

import softshadows as ss

STAGES = {
    "vwss": ["point_generation_seconds", "depth_maps_seconds", "lighting_seconds"],
    "cssm": ["basis_seconds", "prefilter_seconds", "lookup_seconds"],
    "shadow_map": ["render_seconds", "lookup_seconds"],
    "pcss": ["depth_map_seconds", "lighting_seconds"],
    "mvr": ["depth_maps_seconds", "lighting_seconds"],
    "alias_free": ["list_build_seconds", "rasterization_seconds", "visibility_seconds"],
}


def setup(name: str, size: int):
    try:
        return ss.scenes.get(name).with_size(size, size)
    except ImportError as error:  # bunny needs pymeshlab
        print(f"{name}: {error}; using the torus knot")
        return ss.scenes.get("torus_knot").with_size(size, size)


def timed(run):
    """(seconds, visibility, stats) of one run."""
    start = time.perf_counter()
    vis, stats = run()
    return time.perf_counter() - start, vis, stats


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=1024, help="receivers: a size x size G-buffer")
    parser.add_argument("--scene", default="bunny")
    parser.add_argument("--views", type=int, default=24, help="vwss light samples")
    parser.add_argument("--repeat", type=int, default=2)
    parser.add_argument("--methods", nargs="*", default=list(STAGES), choices=list(STAGES))
    args = parser.parse_args()
    info = ss.gpu_info()
    print(f"GPU: {info['name']} ({info['backend']}, {info['device_type']}); CPU: {os.cpu_count()} threads")
    s = setup(args.scene, args.size)
    gb = ss.gbuffer(s.scene, s.camera)
    print(f"{s.name}: {args.size}x{args.size} receivers, {s.scene.num_faces} triangles")
    calls = {
        "vwss": lambda backend: ss.vwss(s.scene, s.light, gb, samples=args.views, backend=backend, return_stats=True),
        "cssm": lambda backend: ss.cssm(s.scene, s.light, gb, backend=backend, return_stats=True),
        "shadow_map": lambda backend: ss.shadow_map(s.scene, s.light, gb, pcf=5, backend=backend, return_stats=True),
        "pcss": lambda backend: ss.pcss(s.scene, s.light, gb, backend=backend, return_stats=True),
        "mvr": lambda backend: ss.mvr(s.scene, s.light, gb, samples=args.views, backend=backend, return_stats=True),
        "alias_free": lambda backend: ss.alias_free(s.scene, s.light, gb, backend=backend, return_stats=True),
    }
    header = f"{'method':>10} {'backend':>7} " + " ".join(f"{'stage ' + str(k + 1) + ' ms':>11}" for k in range(3))
    print(header + f" {'total ms':>9} {'CPU/GPU':>8} {'max |diff|':>10}")
    for method in args.methods:
        call = calls[method]
        call("gpu")  # warm up: device, pipelines, thread pool
        results = {}
        for _ in range(args.repeat):  # alternating, so both see the same machine load
            for backend in ("cpu", "gpu"):
                run = timed(lambda: call(backend))
                if backend not in results or run[0] < results[backend][0]:
                    results[backend] = run
        ratio = results["cpu"][0] / results["gpu"][0]
        diff = float(np.abs(results["cpu"][1] - results["gpu"][1]).max())
        for backend, (seconds, _, stats) in results.items():
            stages = " ".join(f"{1e3 * stats[k]:>11.1f}" for k in STAGES[method]).rjust(35)
            tail = f" {ratio:>8.2f} {diff:>10.2e}" if backend == "gpu" else ""
            print(f"{method:>10} {backend:>7} {stages} {1e3 * seconds:>9.1f}{tail}")
    print("stages: vwss point generation, depth maps, lighting; cssm basis, prefilter, lookup;")
    print("shadow_map render (CPU either way), lookup (5x5 PCF); pcss depth map (CPU), lookups;")
    print("mvr depth maps, lighting; alias_free list build, rasterization (CPU either way), visibility.")


if __name__ == "__main__":
    main()

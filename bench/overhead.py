"""The Python layer's cost per method call: a method called through ``softshadows`` against the
very same core call made directly on inputs converted once, side by side in one run.

On a 128x128 G-buffer of the columns scene, each round times the public call and the bare core
call on the same arguments, interleaved, so that the machine's noise hits both alike. The
difference of their medians is what the Python layer adds (argument checks, the conversion of
the scene, light and receivers into the core, the reshape of the result); it prints it in
milliseconds and as a fraction of the call.

Usage: ``python bench/overhead.py [--size 128] [--rounds 30]``
"""

from __future__ import annotations

import argparse
import statistics
import time

import softshadows as ss
from softshadows import _core, scenes
from softshadows.methods import _inputs, _native_samples


def timed(fn):
    start = time.perf_counter()
    fn()
    return time.perf_counter() - start


def cases(setup, gb):
    """(name, public call, bare core call) for a cheap and a costly method."""
    scene, light = setup.scene, setup.light
    _, inputs = _inputs(scene, light, gb)
    samples = _native_samples(light, 16, pattern="poisson", seed=0, rotate=None, interleaved=1, frame=0, receivers=inputs[2])
    eps = scene.epsilon
    yield (
        "ray_traced, 16 samples",
        lambda: ss.ray_traced(scene, light, gb, samples=16),
        lambda: _core.ray_traced(*inputs, samples, eps, "all"),
    )
    yield (
        "shadow_map, 256^2",
        lambda: ss.shadow_map(scene, light, gb, resolution=256),
        lambda: _core.shadow_map(*inputs, 256, None, 1, "cpu"),
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=128)
    parser.add_argument("--rounds", type=int, default=30)
    args = parser.parse_args()
    setup = scenes.get("columns", width=args.size, height=args.size)
    gb = ss.gbuffer(setup.scene, setup.camera)
    print(f"Python layer per call, columns, {args.size}x{args.size} G-buffer, median of {args.rounds} rounds")
    for name, public, core in cases(setup, gb):
        public(), core()  # warm caches (the set-up check runs once per set-up)
        times = [(timed(public), timed(core)) for _ in range(args.rounds)]
        whole = statistics.median(t for t, _ in times)
        bare = statistics.median(t for _, t in times)
        print(f"  {name:24s} call {whole * 1e3:8.2f} ms   core {bare * 1e3:8.2f} ms   "
              f"Python layer {(whole - bare) * 1e3:6.2f} ms ({(whole - bare) / whole:.1%} of the call)")


if __name__ == "__main__":
    main()

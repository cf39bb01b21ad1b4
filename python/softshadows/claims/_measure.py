"""What the claims' measurements share: a timer, a ray-traced reference, errors over the hit pixels."""

from __future__ import annotations

import functools
import time

import numpy as np


def best_of(repeat: int, fn):
    """The fastest of ``repeat`` runs of ``fn()`` in seconds, and the last result.

    The machines are shared and noisy: the minimum is the run least disturbed by other work.
    """
    times, out = [], None
    for _ in range(max(1, int(repeat))):
        start = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - start)
    return min(times), out


def reference(setup, gb, samples: int = 1024):
    """``ray_traced`` visibility on ``samples`` Sobol samples (seed 1): the high-sample reference
    of the approximate methods' errors."""
    import softshadows as ss

    return ss.ray_traced(setup.scene, setup.light, gb, samples=setup.light.samples(samples, pattern="sobol", seed=1))


def rmse(vis, ref, mask) -> float:
    """RMSE over the hit pixels."""
    from softshadows import metrics

    return float(metrics.rmse(vis, ref, mask))


@functools.lru_cache(maxsize=8)
def staged(name: str, size: int, **options):
    """A built-in scene at ``size`` x ``size`` receivers with its G-buffer, built once per run
    of the ledger (claims of one paper share their scenes)."""
    import softshadows as ss

    setup = ss.scenes.get(name, width=size, height=size, **options)
    return setup, ss.gbuffer(setup.scene, setup.camera)


def identical_fraction(a, b, mask) -> float:
    """The share of hit pixels where ``a`` and ``b`` are the same bits."""
    return float(np.mean((np.asarray(a) == np.asarray(b))[mask]))

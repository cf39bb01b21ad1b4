"""Backprojection soft shadow mapping (Schwarz and Stamminger 2008): budgets, gap filling,
micro-occluders and acceleration structures, side by side in one run.

On one scene at 512x512 receivers with a 1024^2 shadow map, it times ``backprojection`` and
measures its RMSE against 1024 ray-traced Sobol samples for budgets infinite, 12 and 5, each with
and without the gap filling of Guennebaud et al. 2006 and with microrects, and for the HSM, MSSM
and YSM; every row is a ratio to the default (gap-filled micropatches, YSM, budget infinite),
measured in the same run. It also prints the micro-occluders processed per backprojecting pixel
(mean and max, Table 2's count) and the share of pixels that backproject. The paper: a budget of
5 is 3.5x faster than an infinite one on its Figure 1 scene (Table 2).

Usage: ``python bench/backprojection.py [--scene columns] [--size 512] [--repeat 3]``
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

import softshadows as ss
from softshadows import metrics, scenes

sys.path.insert(0, str(Path(__file__).parent))
from shadow_rays import best_of  # noqa: E402  (the benches' shared timer)

DEFAULT = "budget inf, gap filling (default)"
ROWS = {
    DEFAULT: {},
    "budget inf, plain micropatches": {"extend": False},
    "budget inf, microrects": {"occluder": "microrect"},
    "budget 12, gap filling": {"budget": 12},
    "budget 12, plain micropatches": {"budget": 12, "extend": False},
    "budget 12, microrects": {"budget": 12, "occluder": "microrect"},
    "budget 5, gap filling": {"budget": 5},
    "budget 5, plain micropatches": {"budget": 5, "extend": False},
    "budget 5, microrects": {"budget": 5, "occluder": "microrect"},
    "budget inf, HSM": {"accel": "hsm"},
    "budget inf, MSSM": {"accel": "mssm"},
    "budget 5, HSM": {"budget": 5, "accel": "hsm"},
    "budget 5, MSSM": {"budget": 5, "accel": "mssm"},
    "budget inf, microquads": {"occluder": "microquad"},
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", default="columns")
    parser.add_argument("--size", type=int, default=512)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    setup = scenes.get(args.scene, width=args.size, height=args.size)
    gb = ss.gbuffer(setup.scene, setup.camera)
    reference = ss.ray_traced(setup.scene, setup.light, gb, samples=1024, pattern="sobol", seed=1)
    print(f"{os.cpu_count()} CPU threads; {args.scene}, {args.size}^2 receivers, 1024^2 map; best of {args.repeat}")
    results = {}
    for name, options in ROWS.items():
        seconds, (vis, stats) = best_of(args.repeat, lambda: ss.backprojection(setup.scene, setup.light, gb, return_stats=True, **options))
        results[name] = (seconds, metrics.rmse(vis, reference, gb.mask), stats)
    base_s, base_e, _ = results[DEFAULT]
    print(f"\n{'setting':<34} {'seconds':>8} {'x time':>7} {'RMSE':>7} {'x RMSE':>7} {'backproj':>9} {'processed':>10} {'max':>6} {'accel MB':>9}")
    for name, (s, e, st) in results.items():
        print(f"{name:<34} {s:8.3f} {s / base_s:7.2f} {e:7.4f} {e / base_e:7.2f} {st['backprojecting_percent']:8.1f}% "
              f"{st['processed_mean']:10.1f} {st['processed_max']:6.0f} {st['acceleration_bytes'] / 1e6:9.1f}")


if __name__ == "__main__":
    main()

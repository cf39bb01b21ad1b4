"""Backprojection soft shadow mapping (seed 003): budgets, acceleration structures and
micro-occluders, side by side in one run.

On one scene at 512x512 receivers with a 1024^2 shadow map, it times ``backprojection`` and
measures its RMSE against 1024 ray-traced Sobol samples for budgets 5, 12 and infinite, for the
HSM, MSSM and YSM, and for micropatches (extended), microquads and microrects; every row is a
ratio to the default (extended micropatches, HSM, budget infinite). The paper: a budget of 5 is
3.5x faster than an infinite one on its Figure 1 scene (Table 2).

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

ROWS = {
    "budget inf (micropatch+ext, HSM)": {},
    "budget 12": {"budget": 12},
    "budget 5": {"budget": 5},
    "accel MSSM": {"accel": "mssm"},
    "accel YSM": {"accel": "ysm"},
    "budget 5, YSM": {"budget": 5, "accel": "ysm"},
    "microquad": {"occluder": "microquad", "extend": False},
    "microrect": {"occluder": "microrect", "extend": False},
    "micropatch (plain)": {"extend": False},
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
        options = {"extend": True, **options}
        seconds, (vis, stats) = best_of(args.repeat, lambda: ss.backprojection(setup.scene, setup.light, gb, return_stats=True, **options))
        results[name] = (seconds, metrics.rmse(vis, reference, gb.mask), stats)
    base_s, base_e, _ = results["budget inf (micropatch+ext, HSM)"]
    print(f"\n{'setting':<34} {'seconds':>8} {'x time':>7} {'RMSE':>7} {'x RMSE':>7} {'backproj':>9} {'occluders':>10} {'accel MB':>9}")
    for name, (s, e, st) in results.items():
        print(f"{name:<34} {s:8.3f} {s / base_s:7.2f} {e:7.4f} {e / base_e:7.2f} {st['backprojecting_percent']:8.1f}% "
              f"{st['occluders_mean']:10.1f} {st['acceleration_bytes'] / 1e6:9.1f}")


if __name__ == "__main__":
    main()

"""Convolution soft shadow maps (Annen et al. 2008) against PCSS, a hard shadow map and ray
tracing, side by side in one run.

On the parallel-plates case (where the method is exact up to its series) and on one scene, at
512x512 receivers, it times ``cssm`` (order 4 and 16, summed-area table and mipmap, the default
ringing suppression), ``pcss`` (64 + 96 taps), ``shadow_map`` (5x5 PCF) and ``ray_traced`` (64
Poisson samples) and measures each one's RMSE against 1024 ray-traced Sobol samples; it prints
seconds and RMSE as ratios to ``cssm`` (order 4, SAT). Then it grows the light 16x in area (side
x1, x2, x4) and prints the cost of ``cssm`` and its peers relative to the smallest light (the
paper's claim: constant).

Usage: ``python bench/cssm.py [--scene columns] [--size 512] [--repeat 3]``
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

import numpy as np

import softshadows as ss
from softshadows import metrics, scenes

sys.path.insert(0, str(Path(__file__).parent))
from shadow_rays import best_of  # noqa: E402  (the benches' shared timer)


def methods(setup, light, gb):
    """Name -> a call computing visibility under ``light``."""
    return {
        "cssm M=4 sat": lambda: ss.cssm(setup.scene, light, gb),
        "cssm M=4 mipmap": lambda: ss.cssm(setup.scene, light, gb, prefilter="mipmap"),
        "cssm M=16 sat": lambda: ss.cssm(setup.scene, light, gb, order=16),
        "pcss": lambda: ss.pcss(setup.scene, light, gb, resolution=512),
        "shadow_map pcf 5": lambda: ss.shadow_map(setup.scene, light, gb, resolution=512, pcf=5),
        "ray_traced 64": lambda: ss.ray_traced(setup.scene, light, gb, samples=64),
    }


def compare(name, setup, gb, repeat):
    """Seconds and RMSE of every method on one scene, as ratios to cssm (order 4, SAT)."""
    reference = ss.ray_traced(setup.scene, setup.light, gb, samples=1024, pattern="sobol", seed=1)
    rows = {}
    for method, run in methods(setup, setup.light, gb).items():
        seconds, vis = best_of(repeat, run)
        rows[method] = (seconds, metrics.rmse(vis, reference, gb.mask))
    base_s, base_e = rows["cssm M=4 sat"]
    print(f"\n{name}\n{'method':<17} {'seconds':>8} {'x cssm time':>11} {'RMSE':>7} {'x cssm RMSE':>11}")
    for method, (s, e) in rows.items():
        print(f"{method:<17} {s:>8.3f} {s / base_s:>11.2f} {e:>7.4f} {e / base_e:>11.2f}")


def scaled(light, k: float):
    return ss.RectLight(light.center, np.asarray(light.u) * k, np.asarray(light.v) * k)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", default="columns")
    parser.add_argument("--size", type=int, default=512)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    print(f"{os.cpu_count()} CPU threads; {args.size}^2 receivers; best of {args.repeat}")
    for name in ("parallel_plates", args.scene):
        setup = scenes.get(name, width=args.size, height=args.size)
        gb = ss.gbuffer(setup.scene, setup.camera)
        compare(name, setup, gb, args.repeat)

    print("\nlight side x1, x2, x4 (area x1, x4, x16): seconds relative to the x1 light")
    sides = (1.0, 2.0, 4.0)
    costs = {name: [] for name in methods(setup, setup.light, gb)}
    for k in sides:
        for name, run in methods(setup, scaled(setup.light, k), gb).items():
            costs[name].append(best_of(args.repeat, run)[0])
    print(f"{'method':<16} " + " ".join(f"{f'x{k * k:g} area':>10}" for k in sides))
    for name, c in costs.items():
        print(f"{name:<16} " + " ".join(f"{s / c[0]:>10.2f}" for s in c))


if __name__ == "__main__":
    main()

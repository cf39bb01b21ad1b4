"""Alias-free shadow maps against brute-force shadow rays on the same samples (Sintorn et al. 2008).

One run on one scene: ``alias_free`` (plane lookup table and exact tests), ``ray_traced`` and
Mitsuba's ``ray_test`` (the rays of ``bench/shadow_rays.py``) on the same shared Poisson light
samples, as seconds and ratios, with how often ``alias_free`` gives ``ray_traced``'s visibility.
The paper's goal is to beat brute-force shadow rays at identical output.

Usage: ``python bench/alias_free.py [--scene bunny] [--size 512] [--samples 256] [--repeat 1]``
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

import numpy as np

import softshadows as ss
from softshadows import scenes

sys.path.insert(0, str(Path(__file__).parent))
from shadow_rays import best_of, mitsuba, shadow_rays  # noqa: E402  (the shared Mitsuba harness)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", default="bunny")
    parser.add_argument("--size", type=int, default=512)
    parser.add_argument("--samples", type=int, default=256)
    parser.add_argument("--repeat", type=int, default=1)
    args = parser.parse_args()
    setup = scenes.get(args.scene, width=args.size, height=args.size)
    gb = ss.gbuffer(setup.scene, setup.camera)
    samples = setup.light.samples(args.samples, pattern="poisson", seed=0)
    eps = setup.scene.epsilon
    print(f"{args.scene}: {setup.scene.num_faces} triangles, {args.size}^2 receivers x {args.samples} samples; "
          f"{os.cpu_count()} CPU threads")
    t_rt, exact = best_of(args.repeat, lambda: ss.ray_traced(setup.scene, setup.light, gb, samples=samples))
    o, d, maxt, _ = shadow_rays(gb, samples, eps)
    t_mi, _ = mitsuba(setup, o, d, maxt, args.repeat)
    rows = [("ray_traced", t_rt, exact), ("mitsuba ray_test", t_mi, None)]
    for lut in (64, None):
        t, (vis, stats) = best_of(
            args.repeat, lambda: ss.alias_free(setup.scene, setup.light, gb, samples=samples, lut=lut, return_stats=True)
        )
        rows.append((f"alias_free lut={lut}", t, vis))
    print(f"  lists: {stats['average_list_length']:.2f} average, {stats['max_list_length']:.0f} max, "
          f"{stats['occupied_texels_percent']:.1f}% of texels occupied; {stats['casters']:.0f} casters")
    print(f"{'method':<22} {'seconds':>8} {'x ray_traced':>12} {'x mitsuba':>10} {'identical':>10}")
    for name, seconds, vis in rows:
        same = "" if vis is None else f"{np.mean((vis == exact)[gb.mask]):.2%}"
        print(f"{name:<22} {seconds:>8.3f} {seconds / t_rt:>12.2f} {seconds / t_mi:>10.2f} {same:>10}")


if __name__ == "__main__":
    main()

"""``denoised`` at 1, 2 and 4 rays per pixel beside ``ray_traced`` at the same rays per pixel
(unfiltered, each pixel's samples rotated per receiver), ``ray_traced`` at 256 samples and
``pcss``, in one run: seconds and RMSE against the 256-sample result, as ratios.

The peers run side by side in one process on the same scene and G-buffer (the machine is shared
and noisy: each time is the fastest of ``--repeat`` runs). ``x ref`` is the time over
``ray_traced`` at 256 samples; ``x raw`` the time and ``x raw RMSE`` the RMSE over ``ray_traced``
at the same rays per pixel (unfiltered), so an RMSE ratio below 1 means the denoiser beats its own
rays. The RMSE of a stochastic method is averaged over
``--seeds`` seeds.

Usage: ``python bench/denoised.py [--scene columns] [--size 256] [--repeat 3] [--seeds 4]``
"""

from __future__ import annotations

import argparse

import numpy as np
from shadow_rays import best_of as fastest  # bench/ is on the path of a script run from it

import softshadows as ss


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", default="columns")
    parser.add_argument("--size", type=int, default=256)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--seeds", type=int, default=4)
    args = parser.parse_args(argv)

    setup = ss.scenes.get(args.scene, width=args.size, height=args.size)
    gb = ss.gbuffer(setup.scene, setup.camera)
    scene, light = setup.scene, setup.light
    ray_traced = lambda **kw: ss.ray_traced(scene, light, gb, **kw)  # noqa: E731
    ref_seconds, reference = fastest(args.repeat, lambda: ray_traced(samples=256))

    def rmse(run):
        return float(np.mean([ss.metrics.rmse(run(seed), reference, gb.mask) for seed in range(args.seeds)]))

    rows = []
    for spp in (1, 2, 4):
        raw = lambda seed, spp=spp: ray_traced(samples=spp, rotate="per_receiver", seed=seed)  # noqa: E731
        den = lambda seed, spp=spp: ss.denoised(scene, light, gb, spp=spp, seed=seed)  # noqa: E731
        raw_seconds, _ = fastest(args.repeat, lambda: raw(0))
        den_seconds, _ = fastest(args.repeat, lambda: den(0))
        raw_rmse = rmse(raw)
        rows.append((f"ray_traced {spp} spp", raw_seconds, raw_rmse, (raw_seconds, raw_rmse)))
        rows.append((f"denoised {spp} spp", den_seconds, rmse(den), (raw_seconds, raw_rmse)))
    pcss_seconds, pcss_vis = fastest(args.repeat, lambda: ss.pcss(scene, light, gb))
    pcss_rmse = ss.metrics.rmse(pcss_vis, reference, gb.mask)
    rows.append(("pcss", pcss_seconds, pcss_rmse, (float("nan"), float("nan"))))

    print(f"{args.scene}, {args.size}x{args.size} receivers, {ss.num_threads()} threads; "
          f"reference ray_traced 256 samples: {ref_seconds:.4f} s")
    print(f"{'method':<18} {'seconds':>9} {'x ref':>7} {'x raw':>7} {'RMSE':>8} {'x raw RMSE':>10}")
    for name, seconds, error, (raw_seconds, raw_rmse) in rows:
        print(f"{name:<18} {seconds:9.4f} {seconds / ref_seconds:7.3f} {seconds / raw_seconds:7.2f} {error:8.4f} "
              f"{error / raw_rmse:10.3f}")


if __name__ == "__main__":
    main()

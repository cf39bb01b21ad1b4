"""View-warped soft shadows against multi-view rasterization and PCSS (Marrs et al. 2018, Tables 1-2).

For torus knots of growing tessellation (50k to 1M triangles) over a ground plane, one run
measures side by side, on the same 24 or 128 Poisson light samples and the same receivers:

- ``mvr``: one rasterized depth map per light sample;
- ``vwss``: one source rasterization warped into every light sample's depth map (buffered,
  partially parallel, 8 maps per traversal: the paper's configuration);
- ``vwss-eq``: the same with the source view sized by equations 1-3 as printed
  (``source_view="paper"``: pull-back from the light's width and height, ``z_n`` the views' near
  plane, so the source side reaches its cap of 8x the maps');
- ``pcss``: one depth map, 64 blocker-search and 96 filter taps.

As in the paper, only the knot is rendered into the depth maps (``casters``): the ground
receives but casts nothing. It prints the columns of Tables 1-2 (points, depth-map and lighting
seconds, total), the ratios ``mvr / vwss`` for depth maps and total time (paper, on a GPU:
depth maps 2-5x faster at 24 views and 4-13x at 128, total up to 3x), the RMSE of each
against 256 ray-traced samples, and its RMSE against ``mvr``: every method uses the same depth
bias (the receiver plane less half a texel of gradient), so that column is the difference the
method makes on the same samples.

Usage: ``python bench/vwss.py [--triangles 50000 200000 1000000] [--views 24 128]
[--resolution 1024] [--size 256]``
"""

from __future__ import annotations

import argparse
import os

import numpy as np

import softshadows as ss
from softshadows import metrics, scenes


def knot(triangles: int, size: int):
    """A (2, 3) torus knot with about ``triangles`` triangles (tube:radial segments 12:1)."""
    radial = max(3, round(np.sqrt(triangles / 24)))
    tube = max(3, round(triangles / (2 * radial)))
    return scenes.torus_knot(tube_segments=tube, radial_segments=radial, width=size, height=size)


def run(setup, gb, views: int, resolution: int):
    """One row per method: stats and visibility on the same samples."""
    samples = setup.light.samples(views, pattern="poisson", seed=0)
    casters = [m.name for m in setup.occluders]
    common = dict(samples=samples, resolution=resolution, casters=casters, return_stats=True)
    rows = {}
    for name, method, options in [("mvr", ss.mvr, {}), ("vwss", ss.vwss, {}),
                                  ("vwss-eq", ss.vwss, {"source_view": "paper"})]:
        rows[name] = method(setup.scene, setup.light, gb, **common, **options)
    vis, stats = ss.pcss(setup.scene, setup.light, gb, resolution=resolution, casters=casters, return_stats=True)
    rows["pcss"] = (vis, {**stats, "depth_maps_seconds": stats["depth_map_seconds"]})
    return rows


def total(stats) -> float:
    """Point generation, depth maps and lighting: the stages of Tables 1-2 after the G-buffer."""
    return stats.get("point_generation_seconds", 0.0) + stats["depth_maps_seconds"] + stats["lighting_seconds"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--triangles", type=int, nargs="+", default=[50_000, 200_000, 1_000_000])
    parser.add_argument("--views", type=int, nargs="+", default=[24, 128])
    parser.add_argument("--resolution", type=int, default=1024, help="depth-map side in texels")
    parser.add_argument("--size", type=int, default=256, help="receivers: a size x size G-buffer")
    args = parser.parse_args()
    print(f"{os.cpu_count()} CPU threads; depth maps {args.resolution}^2; {args.size}^2 receivers")
    header = (
        f"{'triangles':>9} {'views':>5} {'method':>7} {'points':>9} {'points s':>8} {'maps s':>8} "
        f"{'light s':>8} {'total s':>8} {'x depth':>7} {'x total':>7} {'RMSE':>7} {'vs mvr':>7}"
    )
    print(header)
    print("-" * len(header))
    for triangles in args.triangles:
        setup = knot(triangles, args.size)
        gb = ss.gbuffer(setup.scene, setup.camera)
        reference = ss.ray_traced(setup.scene, setup.light, gb, samples=256, pattern="sobol", seed=1)
        if triangles == args.triangles[0]:
            run(setup, gb, max(args.views), args.resolution)  # warm up: thread pool, first page faults
        for views in args.views:
            rows = run(setup, gb, views, args.resolution)
            mvr_vis, mvr = rows["mvr"]
            for name, (vis, stats) in rows.items():
                speed_depth = mvr["depth_maps_seconds"] / stats["depth_maps_seconds"]
                speed_total = total(mvr) / total(stats)
                print(
                    f"{setup.scene.meshes[1].faces.shape[0]:>9} {views:>5} {name:>7} "
                    f"{stats.get('points', 0):>9.0f} {stats.get('point_generation_seconds', 0):>8.3f} "
                    f"{stats['depth_maps_seconds']:>8.3f} {stats['lighting_seconds']:>8.3f} {total(stats):>8.3f} "
                    f"{speed_depth:>7.2f} {speed_total:>7.2f} {metrics.rmse(vis, reference, gb.mask):>7.4f} "
                    f"{metrics.rmse(vis, mvr_vis, gb.mask):>7.4f}"
                )
    print("x depth, x total: mvr's seconds over the method's (higher is faster than mvr); "
          "vs mvr: RMSE against mvr on the same samples and bias.")


if __name__ == "__main__":
    main()

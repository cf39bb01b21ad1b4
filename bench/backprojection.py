"""Backprojection soft shadow mapping (Schwarz and Stamminger 2008): budgets, gap filling,
micro-occluders and acceleration structures, side by side in one run.

On one scene at 512x512 receivers with a 1024^2 shadow map, it times ``backprojection`` and
measures its RMSE against 1024 ray-traced Sobol samples for budgets infinite, 12 and 5, each with
and without the gap filling of Guennebaud et al. 2006 and with microrects, and for the HSM, MSSM
and YSM; every row is a ratio to the default (gap-filled micropatches, YSM, budget infinite),
measured in the same run. It also prints the micro-occluders processed per backprojecting pixel
(mean and max, Table 2's count) and the share of pixels that backproject. The paper: a budget of
5 is 3.5x faster than an infinite one on its Figure 1 scene (Table 2).

First it prints what one micro-occluder costs, at the unbounded budget with area accumulation and
with occlusion bitmaps (the default), beside ``ray_traced`` on the same receivers with 64 Poisson
light samples (as ``bench/work.py`` runs it) timed in the same run: the seconds, their ratio to
``ray_traced``'s (``x time``), the micro-occluders backprojected (summed over the receivers), the
nanoseconds per backprojected micro-occluder and their ratio to ``ray_traced``'s nanoseconds per
shadow ray (``x ray``), and the nanoseconds per processed micro-occluder; then the same per
backprojected micro-occluder in CPU time (all threads' together, the fastest run's) and its ratio
to ``ray_traced``'s CPU time per ray, the figures least moved by a busy machine (wall time on a
shared machine measures the other processes too). ``--cost`` prints only that table.

Usage: ``python bench/backprojection.py [--scene columns] [--size 512] [--repeat 3] [--cost]``
"""

from __future__ import annotations

import argparse
import os
import sys
import time
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


#: The settings whose cost per micro-occluder is printed first (budget inf, gap filling).
COST_ROWS = {"area": {"accumulation": "area"}, "bitmask (default)": {}}


def best_wall_and_cpu(repeat: int, fn):
    """The fastest of ``repeat`` runs in wall seconds and in CPU seconds, and the last result."""
    cpu = []

    def timed():
        start = time.process_time()
        out = fn()
        cpu.append(time.process_time() - start)
        return out

    seconds, out = best_of(repeat, timed)
    return seconds, min(cpu), out


def cost_per_micro_occluder(setup, gb, repeat: int) -> None:
    """Seconds and nanoseconds per backprojected micro-occluder, beside ray_traced in this run."""
    samples = setup.light.samples(64, pattern="poisson", seed=0)
    ray_s, ray_cpu, (_, rays) = best_wall_and_cpu(
        repeat, lambda: ss.ray_traced(setup.scene, setup.light, gb, samples=samples, return_stats=True))
    per_ray, cpu_per_ray = ray_s / rays["rays"] * 1e9, ray_cpu / rays["rays"] * 1e9
    print(f"ray_traced with 64 Poisson samples: {ray_s:.3f} s, {per_ray:.2f} ns per ray, {cpu_per_ray:.2f} CPU ns per ray")
    print(f"\n{'accumulation':<18} {'seconds':>8} {'x time':>7} {'backprojected':>13} {'ns/backproj':>11} {'x ray':>6} "
          f"{'processed':>10} {'ns/processed':>12} {'CPU ns/backproj':>15} {'x CPU ray':>9}")
    for name, options in COST_ROWS.items():
        seconds, cpu, (_, st) = best_wall_and_cpu(
            repeat, lambda: ss.backprojection(setup.scene, setup.light, gb, return_stats=True, **options))
        ns, cpu_ns = seconds / st["backprojected"] * 1e9, cpu / st["backprojected"] * 1e9
        print(f"{name:<18} {seconds:8.3f} {seconds / ray_s:7.1f} {st['backprojected']:13.4g} {ns:11.1f} {ns / per_ray:6.1f} "
              f"{st['processed']:10.4g} {seconds / st['processed'] * 1e9:12.1f} {cpu_ns:15.1f} {cpu_ns / cpu_per_ray:9.1f}",
              flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", default="columns")
    parser.add_argument("--size", type=int, default=512)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--cost", action="store_true", help="print only the cost per micro-occluder")
    args = parser.parse_args()
    setup = scenes.get(args.scene, width=args.size, height=args.size)
    gb = ss.gbuffer(setup.scene, setup.camera)
    print(f"{os.cpu_count()} CPU threads; {args.scene}, {args.size}^2 receivers, 1024^2 map; best of {args.repeat}")
    cost_per_micro_occluder(setup, gb, args.repeat)
    if args.cost:
        return
    reference = ss.ray_traced(setup.scene, setup.light, gb, samples=1024, pattern="sobol", seed=1)
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

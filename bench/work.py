"""Every method's cost per unit of its own work, side by side with ray_traced in one run.

Each method runs at its defaults on one scene (the columns under a rectangle light; ``stsv``,
whose occluders are perforated triangles, on the slats fence of Forest et al. 2009), with the same
64 Poisson light samples where a method takes samples. Its stats count the work its paper names
(``pair_tests`` of the alias-free shadow maps, ``processed`` micro-occluders of backprojection,
``taps`` of PCSS and CSSM, ...). For each method this prints the seconds (best of ``--repeat``),
the ratio to ``ray_traced``'s seconds on the same scene and samples (``x time``), the count, the
nanoseconds per unit and how many shadow rays one unit costs (``x ray``: ns per unit over
``ray_traced``'s ns per ray).

``--profile`` says what bounds each method. The machines this runs on have no hardware counters,
so each method runs again in a child process under valgrind's cachegrind, which simulates the
caches and the branch predictor and counts per unit of work: instructions (``Ir``), first-level
data-cache misses (``D1``), last-level misses (``LL``) and mispredicted branches (``Bm``). The
child runs the method ``--calls`` times and once with no call; the difference is the method's.
The estimated cycles ``Ir + 10 D1 + 100 LL + 20 Bm`` (rough latencies of a desktop x86 core)
split into shares, and ``bound`` names the largest: ``instructions`` (arithmetic and control
work itself), ``cache`` (D1 misses served by the last level), ``memory`` (LL misses) or
``branches``. It is a model, not a measurement of the real core, and takes minutes (valgrind runs
the code some 50 times slower); use a smaller ``--size``.

Usage: ``python bench/work.py [--size 256] [--samples 64] [--repeat 3] [--profile [--calls 2]]
[--only NAME]``
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time

import softshadows as ss
from softshadows import scenes

#: Each method's unit of work: the stats keys whose sum it is.
UNITS = {
    "ray_traced": ("rays",),
    "shadow_map": ("fragments",),
    "mvr": ("fragments",),
    "vwss": ("point_warps",),
    "pcss": ("search_taps", "filter_taps"),
    "cssm": ("taps",),
    "backprojection": ("processed",),
    "alias_free": ("pair_tests",),
    "dcs": ("sample_tests",),
    "penumbra_wedge": ("sample_tests",),
    "stsv": ("sample_projections",),
}

#: Counters printed beside the unit, where a method has a second one.
ALSO = {
    "cssm": "basis_images",
    "alias_free": "plane_mask_ops",
    "backprojection": "backprojected",
    "dcs": "wedge_tests",
    "penumbra_wedge": "wedge_tests",
    "stsv": "receivers_tested",
}

#: The methods given the shared light samples (the others sample the light their own way).
SAMPLED = {"ray_traced", "mvr", "vwss", "alias_free", "dcs", "penumbra_wedge", "stsv"}

#: Cachegrind's summary lines: event name -> the regular expression of its count.
EVENTS = {
    "Ir": r"I\s+refs:\s+([\d,]+)",
    "D1": r"D1\s+misses:\s+([\d,]+)",
    "LL": r"LLd\s+misses:\s+([\d,]+)",
    "Bm": r"Mispredicts:\s+([\d,]+)",
}

#: Rough cycles per event of the cost model (an instruction, an L1 miss served by the last
#: level, a last-level miss, a mispredicted branch).
CYCLES = {"Ir": 1, "D1": 10, "LL": 100, "Bm": 20}
BOUND = {"Ir": "instructions", "D1": "cache", "LL": "memory", "Bm": "branches"}


class Bench:
    """The two scenes at ``size``², their G-buffers and shared light samples."""

    def __init__(self, size: int, samples: int):
        self.columns = scenes.columns(width=size, height=size)
        self.fence = scenes.fence(width=size, height=size)
        self._gbuffers = {s.name: ss.gbuffer(s.scene, s.camera) for s in (self.columns, self.fence)}
        self._samples = {s.name: s.light.samples(samples, pattern="poisson", seed=0) for s in (self.columns, self.fence)}

    def setup_of(self, name: str):
        return self.fence if name == "stsv" else self.columns

    def call(self, name: str, setup=None):
        """Seconds and stats of one call of method ``name`` (on its scene, or on ``setup``)."""
        setup = setup or self.setup_of(name)
        kwargs = {"samples": self._samples[setup.name]} if name in SAMPLED else {}
        gb = self._gbuffers[setup.name]
        start = time.perf_counter()
        _, stats = getattr(ss, name)(setup.scene, setup.light, gb, return_stats=True, **kwargs)
        return time.perf_counter() - start, stats

    def best(self, name: str, repeat: int, setup=None):
        return min((self.call(name, setup) for _ in range(repeat)), key=lambda run: run[0])


def units_of(name: str, stats) -> float:
    return sum(stats[k] for k in UNITS[name])


def cachegrind(name: str, args, calls: int) -> dict[str, int]:
    """Cachegrind's event counts of a child process that makes ``calls`` calls of ``name``."""
    with tempfile.TemporaryDirectory() as tmp:
        child = [sys.executable, __file__, "--only", name, "--size", str(args.size),
                 "--samples", str(args.samples), "--calls", str(calls)]
        done = subprocess.run(
            ["valgrind", "--tool=cachegrind", "--cache-sim=yes", "--branch-sim=yes",
             f"--cachegrind-out-file={tmp}/out", *child],
            capture_output=True, text=True, env={**os.environ, "OPENBLAS_NUM_THREADS": "1"})
    if done.returncode != 0:
        raise RuntimeError(f"valgrind on {name} failed:\n{done.stderr[-2000:]}")
    return {event: int(re.search(pattern, done.stderr).group(1).replace(",", ""))
            for event, pattern in EVENTS.items()}


def profile_row(name: str, args, units: float, baseline: dict[str, int]) -> str:
    """Per unit of work: each event's count, the cost model's shares and what bounds it."""
    counts = cachegrind(name, args, args.calls)
    per_unit = {e: (counts[e] - baseline[e]) / (args.calls * units) for e in EVENTS}
    cycles = {e: CYCLES[e] * max(per_unit[e], 0.0) for e in EVENTS}
    total = sum(cycles.values())
    shares = " ".join(f"{e} {100 * cycles[e] / total:3.0f}%" for e in EVENTS)
    counted = " ".join(f"{e} {per_unit[e]:8.2f}" for e in EVENTS)
    return f"{'':<15} per unit: {counted}   cycles ~{total:7.1f}: {shares}   bound: {BOUND[max(cycles, key=cycles.get)]}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=256)
    parser.add_argument("--samples", type=int, default=64)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--profile", action="store_true", help="say what bounds each method (needs valgrind)")
    parser.add_argument("--calls", type=int, default=2, help="calls per method in a --profile child")
    parser.add_argument("--only", choices=sorted(UNITS), help="make --calls calls of one method (a --profile child)")
    args = parser.parse_args()
    bench = Bench(args.size, args.samples)
    if args.only:
        for _ in range(args.calls):
            bench.call(args.only)
        return
    if args.profile and shutil.which("valgrind") is None:
        sys.exit("bench/work.py --profile needs valgrind: apt-get install valgrind")
    baseline = cachegrind("ray_traced", args, calls=0) if args.profile else None
    rays = {s.name: bench.best("ray_traced", args.repeat, s) for s in (bench.columns, bench.fence)}
    per_ray = {scene: seconds / stats["rays"] * 1e9 for scene, (seconds, stats) in rays.items()}
    print(f"columns and fence at {args.size}^2, {args.samples} Poisson samples, best of {args.repeat}; "
          f"ray_traced's ns per ray: columns {per_ray['columns']:.1f}, fence {per_ray['fence']:.1f}")
    print(f"{'method':<15} {'seconds':>8} {'x time':>7} {'unit':<26} {'units':>10} {'ns/unit':>8} {'x ray':>6}  also")
    for name in UNITS:
        scene = bench.setup_of(name).name
        seconds, stats = rays[scene] if name == "ray_traced" else bench.best(name, args.repeat)
        units = units_of(name, stats)
        ns = seconds / units * 1e9 if units else float("nan")
        also = f"{ALSO[name]} {stats[ALSO[name]]:.4g}" if name in ALSO else ""
        print(f"{name:<15} {seconds:>8.3f} {seconds / rays[scene][0]:>7.2f} {'+'.join(UNITS[name]):<26} "
              f"{units:>10.4g} {ns:>8.1f} {ns / per_ray[scene]:>6.2f}  {also}", flush=True)
        if args.profile and units:
            print(profile_row(name, args, units, baseline), flush=True)


if __name__ == "__main__":
    main()

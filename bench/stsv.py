"""Soft textured shadow volumes (Forest et al. 2009) against explicit geometry, side by side in one run.

The paper's Figure 11: a fence as perforated triangles (``stsv``) against the same fence as an
explicit mesh (``ray_traced`` and ``dcs`` on it), and ``ray_traced`` on the perforated triangles
(alpha-tested shadow rays); then the leaves scene (many perforated quads and an opaque trunk).
The grid fence also at the paper's scale: one perforated quad against its explicit mesh of
233,288 triangles (the paper's 233,358), with Mitsuba's ``ray_test`` on the mesh's shadow rays.
All at the same receivers and the same 64 Poisson samples, shared by every receiver
(``rotate=None``, so that every output can be compared; ``stsv``'s default rotates them per
receiver, Forest et al. 2009, section 4.1); it prints seconds, each as a ratio to ``stsv``, and
the share of pixels identical to the oracle.

Usage: ``python bench/stsv.py [--size 512] [--samples 64] [--repeat 3]``
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
from shadow_rays import best_of, mitsuba, shadow_rays  # noqa: E402  (the benches' shared timer and Mitsuba harness)

#: The tile repeats of the paper's Figure 11 fence: 233,288 triangles as an explicit mesh.
PAPER_REPEATS = (483, 241)


def table(title, rows, oracle, mask):
    """Prints the rows (name -> (seconds, visibility)) as ratios to the first."""
    base = next(iter(rows.values()))[0]
    print(f"\n{title}\n{'method':<34} {'seconds':>8} {'x stsv':>7} {'identical':>9}")
    for name, (seconds, vis) in rows.items():
        same = "" if vis is None else f"{np.mean((vis == oracle)[mask]):.2%}"
        print(f"{name:<34} {seconds:8.3f} {seconds / base:7.2f} {same:>9}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=512)
    parser.add_argument("--samples", type=int, default=64)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    print(f"{os.cpu_count()} CPU threads; {args.size}^2 receivers x {args.samples} samples; best of {args.repeat}")
    fences = {"slats": {"pattern": "slats"}, "grid": {"pattern": "grid"},
              "grid, the paper's scale": {"pattern": "grid", "panels": 1, "repeats": PAPER_REPEATS}}
    for title, options in fences.items():
        quads = scenes.fence(width=args.size, height=args.size, **options)
        mesh = scenes.fence_mesh(width=args.size, height=args.size, **options)
        gb = ss.gbuffer(quads.scene, quads.camera)
        samples = quads.light.samples(args.samples, seed=1)
        triangles = sum(len(m.faces) for m in mesh.scene.meshes[1:])
        rays = shadow_rays(gb, samples, mesh.scene.epsilon)[:3]
        rows = {
            "stsv (2 perforated triangles/panel)": best_of(args.repeat, lambda: ss.stsv(quads.scene, quads.light, gb, samples=samples, rotate=None)),
            "ray_traced (perforated, alpha test)": best_of(args.repeat, lambda: ss.ray_traced(quads.scene, quads.light, gb, samples=samples)),
            f"ray_traced (mesh, {triangles} tris)": best_of(args.repeat, lambda: ss.ray_traced(mesh.scene, mesh.light, gb, samples=samples)),
            "mitsuba ray_test (mesh)": (mitsuba(mesh, *rays, args.repeat)[0], None),
            f"dcs (mesh, {triangles} tris)": best_of(1, lambda: ss.dcs(mesh.scene, mesh.light, gb, samples=samples, rotate=None)),
        }
        oracle = rows["ray_traced (perforated, alpha test)"][1]
        table(f"fence ({title})", rows, oracle, gb.mask)
    leaves = scenes.get("leaves", width=args.size, height=args.size)
    gb = ss.gbuffer(leaves.scene, leaves.camera)
    samples = leaves.light.samples(args.samples, seed=1)
    run = lambda **o: best_of(args.repeat, lambda: ss.stsv(leaves.scene, leaves.light, gb, samples=samples, rotate=None, **o))  # noqa: E731
    rows = {
        "stsv two-sided (bitmask)": run(opaque="bitmask"),
        "stsv two-sided (dcs)": run(opaque="dcs"),
        "stsv two-sided (penumbra_wedge)": run(opaque="penumbra_wedge"),
        "ray_traced (alpha test)": best_of(args.repeat, lambda: ss.ray_traced(leaves.scene, leaves.light, gb, samples=samples)),
    }
    perforated = sum(len(m.faces) for m in leaves.scene.meshes if m.perforated)
    table(f"leaves ({perforated} perforated triangles)", rows, rows["ray_traced (alpha test)"][1], gb.mask)


if __name__ == "__main__":
    main()

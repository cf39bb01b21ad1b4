"""Soft textured shadow volumes (Forest et al. 2009) against explicit geometry, side by side in one run.

The paper's Figure 11: a fence as perforated triangles (``stsv``) against the same fence as an
explicit mesh (``ray_traced`` and ``dcs`` on it), and ``ray_traced`` on the perforated triangles
(alpha-tested shadow rays); then the leaves scene (many perforated quads and an opaque trunk).
All at the same receivers and the same 64 Poisson samples; it prints seconds, each as a ratio
to ``stsv``, and the share of pixels identical to the oracle.

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
from shadow_rays import best_of  # noqa: E402  (the benches' shared timer)


def table(title, rows, oracle, mask):
    """Prints the rows (name -> (seconds, visibility)) as ratios to the first."""
    base = next(iter(rows.values()))[0]
    print(f"\n{title}\n{'method':<34} {'seconds':>8} {'x stsv':>7} {'identical':>9}")
    for name, (seconds, vis) in rows.items():
        print(f"{name:<34} {seconds:8.3f} {seconds / base:7.2f} {np.mean((vis == oracle)[mask]):9.2%}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=512)
    parser.add_argument("--samples", type=int, default=64)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    print(f"{os.cpu_count()} CPU threads; {args.size}^2 receivers x {args.samples} samples; best of {args.repeat}")
    for pattern in ("slats", "grid"):
        quads = scenes.fence(pattern=pattern, width=args.size, height=args.size)
        mesh = scenes.fence_mesh(pattern=pattern, width=args.size, height=args.size)
        gb = ss.gbuffer(quads.scene, quads.camera)
        samples = quads.light.samples(args.samples, seed=1)
        triangles = sum(len(m.faces) for m in mesh.scene.meshes[1:])
        rows = {
            "stsv (2 perforated triangles/panel)": best_of(args.repeat, lambda: ss.stsv(quads.scene, quads.light, gb, samples=samples)),
            "ray_traced (perforated, alpha test)": best_of(args.repeat, lambda: ss.ray_traced(quads.scene, quads.light, gb, samples=samples)),
            f"ray_traced (mesh, {triangles} tris)": best_of(args.repeat, lambda: ss.ray_traced(mesh.scene, mesh.light, gb, samples=samples)),
            f"dcs (mesh, {triangles} tris)": best_of(args.repeat, lambda: ss.dcs(mesh.scene, mesh.light, gb, samples=samples)),
        }
        oracle = rows["ray_traced (perforated, alpha test)"][1]
        table(f"fence ({pattern})", rows, oracle, gb.mask)
    leaves = scenes.get("leaves", width=args.size, height=args.size)
    gb = ss.gbuffer(leaves.scene, leaves.camera)
    samples = leaves.light.samples(args.samples, seed=1)
    run = lambda **o: best_of(args.repeat, lambda: ss.stsv(leaves.scene, leaves.light, gb, samples=samples, two_sided=True, **o))  # noqa: E731
    rows = {
        "stsv two-sided (bitmask)": run(),
        "stsv two-sided (dcs)": run(opaque="dcs"),
        "stsv two-sided (penumbra_wedge)": run(opaque="penumbra_wedge"),
        "ray_traced (alpha test)": best_of(args.repeat, lambda: ss.ray_traced(leaves.scene, leaves.light, gb, samples=samples)),
    }
    perforated = sum(len(m.faces) for m in leaves.scene.meshes if m.perforated)
    table(f"leaves ({perforated} perforated triangles)", rows, rows["ray_traced (alpha test)"][1], gb.mask)


if __name__ == "__main__":
    main()

"""Soft textured shadow volumes (Forest et al. 2009) against explicit geometry, side by side in one run.

The paper's Figure 11: a fence as perforated triangles (``stsv``) against the same fence as an
explicit mesh (``ray_traced`` and ``dcs`` on it), and ``ray_traced`` on the perforated triangles
(alpha-tested shadow rays); then the leaves scene (many perforated quads and an opaque trunk).
The grid fence also at the paper's scale: one perforated quad against its explicit mesh of
233,288 triangles (the paper's 233,358), with Mitsuba's ``ray_test`` on the mesh's shadow rays.
All at the same receivers and the same 64 Poisson samples, shared by every receiver
(``rotate=None``, so that every output can be compared), then ``stsv``'s default, which rotates
them per receiver (Forest et al. 2009, section 4.1), against ``ray_traced`` on the same rotated
samples on the leaves and the slats fence; the contenders run in turn, round after round, and it
prints each one's fastest round in seconds (wall, and CPU: every thread of the process), as
ratios to ``stsv``, and the share of pixels identical to the oracle.

Usage: ``python bench/stsv.py [--size 512] [--samples 64] [--repeat 3] [--no-paper-scale]``
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
from shadow_rays import mitsuba, shadow_rays, side_by_side  # noqa: E402  (the benches' shared timer and Mitsuba harness)

#: The tile repeats of the paper's Figure 11 fence: 233,288 triangles as an explicit mesh.
PAPER_REPEATS = (483, 241)


def table(title, repeat, contenders, oracle, mask, images=True):
    """Runs the contenders (name -> function) side by side and prints their seconds (wall and CPU)
    as ratios to the first, and the share of pixels identical to the contender named ``oracle``
    for those whose ``images`` flag (name -> bool, or True for all) is set."""
    cpu = {}
    seconds, results = side_by_side(repeat, contenders, cpu=cpu)
    base, base_cpu = next(iter(seconds.values())), next(iter(cpu.values()))
    print(f"\n{title}\n{'method':<34} {'seconds':>8} {'x stsv':>7} {'cpu s':>7} {'x stsv':>7} {'identical':>9}")
    for name in contenders:
        image = images is True or images.get(name, True)
        same = f"{np.mean((results[name] == results[oracle])[mask]):.2%}" if image else ""
        print(f"{name:<34} {seconds[name]:8.3f} {seconds[name] / base:7.2f} {cpu[name]:7.3f} "
              f"{cpu[name] / base_cpu:7.2f} {same:>9}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=512)
    parser.add_argument("--samples", type=int, default=64)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--paper-scale", action=argparse.BooleanOptionalAction, default=True,
                        help="the fence at the paper's scale too (minutes: dcs on its 233,288 triangles)")
    args = parser.parse_args()
    print(f"{os.cpu_count()} CPU threads; {args.size}^2 receivers x {args.samples} samples; best of {args.repeat}")
    fences = {"slats": {"pattern": "slats"}, "grid": {"pattern": "grid"},
              "grid, the paper's scale": {"pattern": "grid", "panels": 1, "repeats": PAPER_REPEATS}}
    if not args.paper_scale:
        del fences["grid, the paper's scale"]
    for title, options in fences.items():
        quads = scenes.fence(width=args.size, height=args.size, **options)
        mesh = scenes.fence_mesh(width=args.size, height=args.size, **options)
        gb = ss.gbuffer(quads.scene, quads.camera)
        samples = quads.light.samples(args.samples, seed=1)
        triangles = sum(len(m.faces) for m in mesh.scene.meshes[1:])
        rays = shadow_rays(gb, samples, mesh.scene.epsilon)[:3]
        contenders = {
            "stsv (2 perforated triangles/panel)": lambda: ss.stsv(quads.scene, quads.light, gb, samples=samples, rotate=None),
            "ray_traced (perforated, alpha test)": lambda: ss.ray_traced(quads.scene, quads.light, gb, samples=samples),
            f"ray_traced (mesh, {triangles} tris)": lambda: ss.ray_traced(mesh.scene, mesh.light, gb, samples=samples),
            "mitsuba ray_test (mesh)": mitsuba(mesh, *rays),
            f"dcs (mesh, {triangles} tris)": lambda: ss.dcs(mesh.scene, mesh.light, gb, samples=samples, rotate=None),
        }
        table(f"fence ({title})", args.repeat, contenders, "ray_traced (perforated, alpha test)", gb.mask,
              images={"mitsuba ray_test (mesh)": False})
    leaves = scenes.get("leaves", width=args.size, height=args.size)
    gb = ss.gbuffer(leaves.scene, leaves.camera)
    samples = leaves.light.samples(args.samples, seed=1)

    def run(**o):
        return lambda: ss.stsv(leaves.scene, leaves.light, gb, samples=samples, rotate=None, **o)

    contenders = {
        "stsv two-sided (bitmask)": run(opaque="bitmask"),
        "stsv two-sided (dcs)": run(opaque="dcs"),
        "stsv two-sided (penumbra_wedge)": run(opaque="penumbra_wedge"),
        "ray_traced (alpha test)": lambda: ss.ray_traced(leaves.scene, leaves.light, gb, samples=samples),
    }
    perforated = sum(len(m.faces) for m in leaves.scene.meshes if m.perforated)
    table(f"leaves ({perforated} perforated triangles)", args.repeat, contenders, "ray_traced (alpha test)", gb.mask)
    rotated(args, {"leaves": leaves, "fence (slats)": scenes.fence(width=args.size, height=args.size, pattern="slats")})


def rotated(args, setups):
    """``stsv``'s default, samples rotated per receiver (Forest et al. 2009, section 4.1), against
    ``ray_traced`` on the same rotated samples, per scene (name -> setup)."""
    for title, setup in setups.items():
        gb = ss.gbuffer(setup.scene, setup.camera)
        samples = setup.light.samples(args.samples, seed=1)
        contenders = {
            "stsv (default: rotate=per_receiver)": lambda: ss.stsv(setup.scene, setup.light, gb, samples=samples),
            "ray_traced (rotate=per_receiver)": lambda: ss.ray_traced(setup.scene, setup.light, gb, samples=samples,
                                                                      rotate="per_receiver"),
        }
        table(f"{title}, samples rotated per receiver", args.repeat, contenders, "ray_traced (rotate=per_receiver)",
              gb.mask)


if __name__ == "__main__":
    main()

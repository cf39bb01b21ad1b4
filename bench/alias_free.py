"""Alias-free shadow maps against brute-force shadow rays on the same samples (Sintorn et al. 2008).

One run on one scene: ``alias_free`` (plane lookup table and exact tests), ``ray_traced`` and
Mitsuba's ``ray_test`` (the rays of ``bench/shadow_rays.py``) on the same shared Poisson light
samples, as seconds and ratios, with how often ``alias_free`` gives ``ray_traced``'s visibility.
The paper's goal is to beat brute-force shadow rays at identical output.

Then a lamp among the geometry: a sphere light inside a closed room with five boxes around it,
seen from a corner, where the object-based methods find their receivers through the six faces
of a cube about the light (Sintorn et al. 2008 use six maps for an omni-directional light):
``alias_free`` (exact tests), ``dcs`` and ``stsv`` against ``ray_traced`` and Mitsuba on the same
shared samples (``rotate=None`` throughout, so that every method's output can be compared).

Usage: ``python bench/alias_free.py [--scene bunny] [--size 512] [--samples 256] [--repeat 1]``
"""

from __future__ import annotations

import argparse
import os
import sys
import types
from pathlib import Path

import numpy as np

import softshadows as ss
from softshadows import scenes
from softshadows.scenes.primitives import box

sys.path.insert(0, str(Path(__file__).parent))
from shadow_rays import mitsuba, shadow_rays, side_by_side  # noqa: E402  (the shared Mitsuba harness)


def print_rows(rows, exact, mask, t_rt, t_mi):
    """One line per (name, seconds, visibility or None): ratios to ray_traced and Mitsuba."""
    print(f"{'method':<30} {'seconds':>8} {'x ray_traced':>12} {'x mitsuba':>10} {'identical':>10}")
    for name, seconds, vis in rows:
        same = "" if vis is None else f"{np.mean((vis == exact)[mask]):.2%}"
        print(f"{name:<30} {seconds:>8.3f} {seconds / t_rt:>12.2f} {seconds / t_mi:>10.2f} {same:>10}")


def lamp_room(size: int):
    """A closed 4-unit room (inward faces), five boxes and a sphere lamp off its center; a camera in a corner."""
    verts, faces = box((-2.0,) * 3, (2.0,) * 3)
    meshes = [ss.Mesh(verts, faces[:, ::-1].copy(), name="room")]
    boxes = [((0.9, -0.3, -0.4), (1.3, 0.5, 0.4)), ((-0.4, 1.0, -0.3), (0.3, 1.2, 0.5)),
             ((-0.5, -1.1, -0.6), (0.6, -0.8, 0.2)), ((-0.3, -0.2, 0.9), (0.4, 0.6, 1.4)),
             ((-1.4, 0.0, -1.3), (-0.9, 0.7, -0.8))]
    meshes += [ss.Mesh(*box(lo, hi), closed=True, name=f"box{k}") for k, (lo, hi) in enumerate(boxes)]
    camera = ss.Camera.look_at((1.9, 1.8, 1.9), (0, 0, 0), (0, 1, 0), 100.0, size, size)
    return types.SimpleNamespace(scene=ss.Scene(meshes), light=ss.SphereLight((0.13, 0.21, -0.07), 0.25), camera=camera)


def room_section(size: int, n_samples: int, repeat: int) -> None:
    setup = lamp_room(size)
    gb = ss.gbuffer(setup.scene, setup.camera)
    samples = setup.light.samples(n_samples, pattern="poisson", seed=0)
    print(f"\nlamp in a room: {setup.scene.num_faces} triangles, {size}^2 receivers x {n_samples} samples")
    runs = {"ray_traced": lambda: ss.ray_traced(setup.scene, setup.light, gb, samples=samples),
            "mitsuba ray_test": mitsuba(setup, *shadow_rays(gb, samples, setup.scene.epsilon)[:3]),
            "alias_free lut=None": lambda: ss.alias_free(setup.scene, setup.light, gb, samples=samples, lut=None,
                                                         return_stats=True),
            "dcs": lambda: ss.dcs(setup.scene, setup.light, gb, samples=samples, rotate=None, return_stats=True),
            "stsv": lambda: ss.stsv(setup.scene, setup.light, gb, samples=samples, rotate=None, return_stats=True)}
    seconds, out = side_by_side(repeat, runs)
    t_rt, t_mi, exact = seconds["ray_traced"], seconds["mitsuba ray_test"], out["ray_traced"]
    rows = [("ray_traced", t_rt, exact), ("mitsuba ray_test", t_mi, None)]
    for name in list(runs)[2:]:
        vis, stats = out[name]
        rows.append((f"{name} ({stats['light_faces']:.0f} faces)", seconds[name], vis))
    print_rows(rows, exact, gb.mask, t_rt, t_mi)


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
    runs = {"ray_traced": lambda: ss.ray_traced(setup.scene, setup.light, gb, samples=samples),
            "mitsuba ray_test": mitsuba(setup, *shadow_rays(gb, samples, eps)[:3])}
    for lut in (64, None):
        runs[f"alias_free lut={lut}"] = lambda lut=lut: ss.alias_free(setup.scene, setup.light, gb, samples=samples,
                                                                      lut=lut, return_stats=True)
    seconds, out = side_by_side(args.repeat, runs)
    t_rt, t_mi, exact = seconds["ray_traced"], seconds["mitsuba ray_test"], out["ray_traced"]
    rows = [("ray_traced", t_rt, exact), ("mitsuba ray_test", t_mi, None)]
    rows += [(name, seconds[name], out[name][0]) for name in list(runs)[2:]]
    stats = out["alias_free lut=None"][1]
    print(f"  lists: {stats['average_list_length']:.2f} average, {stats['max_list_length']:.0f} max, "
          f"{stats['occupied_texels_percent']:.1f}% of texels occupied; {stats['casters']:.0f} casters")
    print_rows(rows, exact, gb.mask, t_rt, t_mi)
    room_section(args.size, min(args.samples, 1024), args.repeat)


if __name__ == "__main__":
    main()

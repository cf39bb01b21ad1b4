"""Shadow-ray throughput: ``ray_traced`` against Mitsuba's ``ray_test`` and Embree (embreex).

All three trace the very same rays in one run, side by side: every hit pixel of the bunny scene
at 512x512 receivers times 64 shared Poisson light samples (the rays of docs/design.md section 3:
origin p + eps n, ending just short of the sample; samples behind the tangent plane are not
traced). It prints rays per second of each and the ratios, plus how often the three agree.

Usage: ``python bench/shadow_rays.py [--size 512] [--samples 64] [--repeat 3]``
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

import softshadows as ss
from softshadows import reference, scenes


def shadow_rays(gb, samples, eps):
    """Origins, unit directions and lengths of every traced ray, grouped by receiver."""
    p = gb.positions[gb.mask].astype(np.float64)
    n = gb.normals[gb.mask].astype(np.float64)
    y = samples.astype(np.float64)
    front = ((y[None] - p[:, None]) * n[:, None]).sum(-1) > 0
    o = np.broadcast_to((p + eps * n)[:, None], (len(p), len(y), 3))[front]
    d = np.broadcast_to(y[None], (len(p), len(y), 3))[front] - o
    length = np.linalg.norm(d, axis=1)
    return o.astype(np.float32), (d / length[:, None]).astype(np.float32), (length * (1 - 1e-6)).astype(np.float32), front


def best_of(repeat, fn):
    """The fastest of ``repeat`` runs (seconds) and the last result."""
    times, out = [], None
    for _ in range(repeat):
        start = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - start)
    return min(times), out


def ours(setup, gb, samples, eps, repeat):
    seconds, (vis, stats) = best_of(
        repeat, lambda: ss.ray_traced(setup.scene, setup.light, gb, samples=samples, epsilon=eps, return_stats=True)
    )
    return seconds, vis


def mitsuba(setup, o, d, maxt, repeat):
    mi = reference._mitsuba()
    desc = reference.mitsuba_scene(setup.scene, setup.light)
    desc.pop("light", None)
    mscene = mi.load_dict(desc)
    ray = mi.Ray3f(mi.Point3f(o[:, 0], o[:, 1], o[:, 2]), mi.Vector3f(d[:, 0], d[:, 1], d[:, 2]))
    ray.maxt = mi.Float(maxt)

    def trace():
        hit = mscene.ray_test(ray)
        return np.array(hit, dtype=bool)

    trace()  # the first call compiles the kernel
    return best_of(repeat, trace)


def embree(setup, o, d, maxt, repeat):
    from embreex import rtcore_scene as rtcs
    from embreex.mesh_construction import TriangleMesh

    escene = rtcs.EmbreeScene()
    tris = np.concatenate([m.vertices[m.faces] for m in setup.scene.meshes]).astype(np.float32)
    TriangleMesh(escene, tris)
    return best_of(repeat, lambda: escene.run(o, d, query="OCCLUDED", dists=maxt) >= 0)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", default="bunny")
    parser.add_argument("--size", type=int, default=512)
    parser.add_argument("--samples", type=int, default=64)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args(argv)

    setup = scenes.get(args.scene, width=args.size, height=args.size)
    gb = ss.gbuffer(setup.scene, setup.camera)
    samples = setup.light.samples(args.samples, pattern="poisson", seed=0)
    eps = setup.scene.epsilon
    o, d, maxt, front = shadow_rays(gb, samples, eps)
    rays = len(o)
    print(f"{args.scene}: {setup.scene.num_faces} triangles, {int(gb.mask.sum())} hit pixels x {args.samples} samples "
          f"= {rays} shadow rays; {os.cpu_count()} cores; Mitsuba variant {reference.variant()}")

    t_ours, vis = ours(setup, gb, samples, eps, args.repeat)
    t_mi, hit_mi = mitsuba(setup, o, d, maxt, args.repeat)
    t_em, hit_em = embree(setup, o, d, maxt, args.repeat)

    def visibility(hits):
        blocked = np.zeros(front.shape, dtype=bool)
        blocked[front] = hits
        return ((~blocked) & front).mean(axis=1)

    for name, seconds in [("ray_traced", t_ours), ("mitsuba ray_test", t_mi), ("embreex (1 thread)", t_em)]:
        print(f"  {name:<20} {rays / seconds / 1e6:8.2f} Mrays/s  ({seconds:.3f} s)")
    print(f"  ratio ray_traced / mitsuba ray_test: {t_mi / t_ours:.2f}x")
    print(f"  ratio ray_traced / embreex:          {t_em / t_ours:.2f}x")
    ours_hit = vis[gb.mask]
    print(f"  identical visibility: vs mitsuba {np.mean(ours_hit == visibility(hit_mi)):.4%} of pixels, "
          f"vs embree {np.mean(ours_hit == visibility(hit_em)):.4%}")


if __name__ == "__main__":
    main()

"""Shadow-ray throughput: ``ray_traced`` against Mitsuba's ``ray_test`` and Embree (embreex), and
our Mitsuba reference ``mitsuba_visibility`` against the bare ``ray_test`` it wraps.

All of them trace the very same rays in one run, side by side: every hit pixel of the bunny scene
at 512x512 receivers times 64 shared Poisson light samples (the rays of docs/design.md section 3:
origin p + eps n, ending just short of the sample; samples behind the tangent plane are not
traced). Each round runs every contender once, in turn, so that the machine's noise hits them
alike; each one's fastest round counts, in wall and in CPU time. ``ray_test`` and embreex get the
rays prebuilt, the other two build them from the receivers and samples. It prints rays per second
of each and the ratios, how many receivers took each path of ``ray_traced`` (its packets cost the
most per ray), plus how often the answers agree.

``--threads N`` runs ``ray_traced``, ``ray_test`` and ``mitsuba_visibility`` on N threads each (ours
through :func:`softshadows.set_num_threads`, Mitsuba's through Dr.Jit's thread pool; default: one per
core): with one thread the ratios compare the work per ray alone, without the threads' scaling.

Usage: ``python bench/shadow_rays.py [--size 512] [--samples 64] [--repeat 3] [--threads N]``
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


#: Pause before each timed call (seconds): the worker threads of the call before (rayon's, Dr.Jit's)
#: spin a while after their work before they sleep, and would otherwise take cores from the next.
PAUSE = 0.05


def side_by_side(repeat, contenders, cpu=None):
    """Runs every contender (name -> function) once per round for ``repeat`` rounds, in turn,
    each after a short pause (:data:`PAUSE`); returns each one's fastest round (seconds) and its
    last result. A dict ``cpu`` gets each one's fastest CPU time of the process (seconds, all
    threads: steadier than wall time on a shared machine)."""
    seconds, results = {name: float("inf") for name in contenders}, {}
    cpu = {} if cpu is None else cpu
    cpu.update({name: float("inf") for name in contenders})
    for _ in range(repeat):
        for name, fn in contenders.items():
            time.sleep(PAUSE)
            start, start_cpu = time.perf_counter(), time.process_time()
            results[name] = fn()
            seconds[name] = min(seconds[name], time.perf_counter() - start)
            cpu[name] = min(cpu[name], time.process_time() - start_cpu)
    return seconds, results


def best_of(repeat, fn):
    """The fastest of ``repeat`` runs of one function (seconds) and its last result."""
    seconds, results = side_by_side(repeat, {"run": fn})
    return seconds["run"], results["run"]


#: The paths of ``ray_traced``'s receivers, cheapest per ray first (its stats ``<path>_receivers``).
PATHS = ("shaft_lit", "frustum_lit", "candidate", "diverging", "converging")


def ours(setup, gb, samples, eps):
    return lambda: ss.ray_traced(setup.scene, setup.light, gb, samples=samples, epsilon=eps)


def reference_visibility(setup, gb, samples, eps):
    def trace():
        return reference.mitsuba_visibility(setup.scene, setup.light, gb, samples, epsilon=eps, cache=False,
                                            progress=False)

    trace()  # the first call loads the Mitsuba scene (kept with the scene) and compiles the kernels
    return trace


def mitsuba(setup, o, d, maxt):
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
    return trace


def embree(setup, o, d, maxt):
    from embreex import rtcore_scene as rtcs
    from embreex.mesh_construction import TriangleMesh

    escene = rtcs.EmbreeScene()
    tris = np.concatenate([m.vertices[m.faces] for m in setup.scene.meshes]).astype(np.float32)
    TriangleMesh(escene, tris)
    return lambda: escene.run(o, d, query="OCCLUDED", dists=maxt) >= 0


def set_threads(threads):
    """Runs ours and Mitsuba's kernels on ``threads`` threads each (0: one per core); returns the
    count."""
    ss.set_num_threads(threads or None)
    reference._mitsuba()  # selects the variant; a vectorized one brings Dr.Jit's thread pool
    if not reference.variant().startswith("scalar"):
        import drjit as dr

        dr.set_thread_count(threads or os.cpu_count())
    return ss.num_threads()


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", default="bunny")
    parser.add_argument("--size", type=int, default=512)
    parser.add_argument("--samples", type=int, default=64)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--threads", type=int, default=0, help="threads of ours and Mitsuba's (0: one per core)")
    args = parser.parse_args(argv)
    threads = set_threads(args.threads)

    setup = scenes.get(args.scene, width=args.size, height=args.size)
    gb = ss.gbuffer(setup.scene, setup.camera)
    samples = setup.light.samples(args.samples, pattern="poisson", seed=0)
    eps = setup.scene.epsilon
    o, d, maxt, front = shadow_rays(gb, samples, eps)
    rays = len(o)
    print(f"{args.scene}: {setup.scene.num_faces} triangles, {int(gb.mask.sum())} hit pixels x {args.samples} samples "
          f"= {rays} shadow rays; {os.cpu_count()} cores, {threads} threads; Mitsuba variant {reference.variant()}")

    cpu = {}
    seconds, results = side_by_side(args.repeat, {
        "ray_traced": ours(setup, gb, samples, eps),
        "mitsuba ray_test": mitsuba(setup, o, d, maxt),
        "mitsuba_visibility": reference_visibility(setup, gb, samples, eps),
        "embreex (1 thread)": embree(setup, o, d, maxt),
    }, cpu=cpu)

    def visibility(hits):
        blocked = np.zeros(front.shape, dtype=bool)
        blocked[front] = hits
        return ((~blocked) & front).mean(axis=1)

    for name, t in seconds.items():
        print(f"  {name:<20} {rays / t / 1e6:8.2f} Mrays/s  ({t:.3f} s, {cpu[name]:.3f} s CPU)")
    t_mi = seconds["mitsuba ray_test"]
    print(f"  ratio ray_traced / mitsuba ray_test:         {t_mi / seconds['ray_traced']:.2f}x "
          f"(CPU time {cpu['mitsuba ray_test'] / cpu['ray_traced']:.2f}x)")
    print(f"  ratio ray_traced / embreex:                  {seconds['embreex (1 thread)'] / seconds['ray_traced']:.2f}x")
    print(f"  ratio mitsuba_visibility / mitsuba ray_test: {t_mi / seconds['mitsuba_visibility']:.2f}x")
    _, stats = ss.ray_traced(setup.scene, setup.light, gb, samples=samples, epsilon=eps, return_stats=True)
    paths = {path: int(stats[f"{path}_receivers"]) for path in PATHS}
    print("  ray_traced's receivers by path: " + ", ".join(f"{path} {count}" for path, count in paths.items()))
    ours_hit = results["ray_traced"][gb.mask]
    print(f"  identical visibility: vs mitsuba {np.mean(ours_hit == visibility(results['mitsuba ray_test'])):.4%} of pixels, "
          f"vs embree {np.mean(ours_hit == visibility(results['embreex (1 thread)'])):.4%}, mitsuba_visibility vs "
          f"mitsuba {np.mean(results['mitsuba_visibility'][gb.mask] == visibility(results['mitsuba ray_test'])):.4%}")


if __name__ == "__main__":
    main()

"""The ``softshadows`` command line.

``softshadows demo [--out DIR]`` runs every method on a built-in scene against a Mitsuba
reference and writes a picture grid, EXR files and a metrics table (Markdown and JSON).
``softshadows evaluate --scenes A,B --methods X,Y --lights rect,disk --out DIR`` runs the
evaluation suite (:mod:`softshadows.evaluation`) and writes its report.
``softshadows reproduce [--papers KEYS] [--tier fast|paper] [--out DIR]`` measures the claims
ledger (:mod:`softshadows.claims`) and writes ``claims.md``, ``claims.csv`` and the figures.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path


def _run_methods(setup, gb, samples, progress):
    """Each method's visibility and seconds on the shared light samples."""
    from .methods import METHODS, SAMPLE_KEYWORDS

    results, seconds = {}, {}
    for name, method in METHODS.items():
        progress.set_description(name)
        start = time.perf_counter()
        kwargs = {SAMPLE_KEYWORDS[name]: samples} if name in SAMPLE_KEYWORDS else {}
        results[name] = method(setup.scene, setup.light, gb, **kwargs)
        seconds[name] = time.perf_counter() - start
        progress.update()
    return results, seconds


def demo(out: Path, *, scene: str = "columns", size: int = 256, samples: int = 64, reference_samples: int = 1024) -> dict:
    """Runs the demo and returns the metrics table as a dict of method name to metrics.

    Parameters
    ----------
    out : Path
        Output folder (created).
    scene : str
        A name from ``softshadows.scenes.SCENES``.
    size : int
        Image width and height in pixels.
    samples : int
        Light samples for the sample-based methods (Poisson, seed 0, shared by all).
    reference_samples : int
        Light samples of the Mitsuba ``ray_test`` reference.
    """
    from tqdm.auto import tqdm

    from . import io, metrics, plot, reference, scenes
    from .camera import gbuffer
    from .methods import METHODS

    out.mkdir(parents=True, exist_ok=True)
    setup = scenes.get(scene, width=size, height=size)
    with tqdm(total=len(METHODS) + 2, desc="gbuffer", unit="step") as progress:
        gb = gbuffer(setup.scene, setup.camera)
        progress.update()
        progress.set_description("mitsuba reference")
        ref_samples = setup.light.samples(reference_samples, pattern="sobol", seed=1)
        ref = reference.mitsuba_visibility(setup.scene, setup.light, gb, ref_samples)
        progress.update()
        shared = setup.light.samples(samples, pattern="poisson", seed=0)
        results, seconds = _run_methods(setup, gb, shared, progress)

    table = {}
    for name, vis in results.items():
        table[name] = {**metrics.summary(vis, ref, gb.mask), "seconds": seconds[name]}
        io.write_exr(out / f"{name}.exr", vis)
    io.write_exr(out / "reference.exr", ref)
    titles = {n: f"RMSE {m['rmse']:.4f}" for n, m in table.items()}
    plot.comparison_grid(ref, results, gb.mask, path=out / "demo.png", titles=titles)
    meta = {"scene": scene, "size": size, "samples": samples, "reference": f"mitsuba ray_test, {reference_samples} samples"}
    (out / "metrics.json").write_text(json.dumps({"setup": meta, "methods": table}, indent=2))
    (out / "metrics.md").write_text(_markdown(meta, table))
    return table


def _markdown(meta: dict, table: dict) -> str:
    lines = [
        f"# softshadows demo: `{meta['scene']}`, {meta['size']}x{meta['size']}",
        "",
        f"Reference: {meta['reference']}. Sample-based methods: {meta['samples']} Poisson samples.",
        "",
        "| method | RMSE | SSIM | FLIP | seconds |",
        "|---|---|---|---|---|",
    ]
    for name, m in table.items():
        lines.append(f"| {name} | {m['rmse']:.4f} | {m['ssim']:.4f} | {m['flip']:.4f} | {m['seconds']:.3f} |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="softshadows", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    d = sub.add_parser("demo", help="run every method on a built-in scene against Mitsuba")
    d.add_argument("--out", type=Path, default=Path("demo"), help="output folder (default: ./demo)")
    d.add_argument("--scene", default="columns", help="scene name from softshadows.scenes.SCENES")
    d.add_argument("--size", type=int, default=256, help="image width and height in pixels")
    d.add_argument("--samples", type=int, default=64, help="light samples for sample-based methods")
    d.add_argument("--reference-samples", type=int, default=1024, help="light samples of the Mitsuba reference")
    e = sub.add_parser("evaluate", help="every method on every scene and light against Mitsuba, as a report")
    e.add_argument("--scenes", default="columns", help="comma-separated scene names (default: columns)")
    e.add_argument("--methods", default=None, help="comma-separated method names (default: all)")
    e.add_argument("--lights", default="rect", help="comma-separated light kinds (default: rect)")
    e.add_argument("--size", type=int, default=128, help="image width and height in pixels")
    e.add_argument("--samples", type=int, default=64, help="light samples for sample-based methods")
    e.add_argument("--reference-samples", type=int, default=4096, help="light samples of the Mitsuba reference")
    e.add_argument("--out", type=Path, default=Path("evaluation"), help="output folder (default: ./evaluation)")
    e.add_argument("--readme", type=Path, default=None, help="also rewrite the results table of this README")
    r = sub.add_parser("reproduce", help="measure every claim of the five papers (the claims ledger)",
                       formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    r.add_argument("--papers", default=None, help="comma-separated paper keys (sintorn08, forest09, annen08, schwarz08, marrs18); default all")
    r.add_argument("--ids", default=None, help="comma-separated claim ids; default all of the papers'")
    r.add_argument("--tier", choices=("fast", "paper"), default="fast",
                   help="fast: small sizes, minutes; paper: the papers' own sizes, up to an hour")
    r.add_argument("--out", type=Path, default=Path("claims"), help="output folder for claims.md, claims.csv and the figures")
    r.add_argument("--no-figures", action="store_true", help="skip the figures")
    r.add_argument("--record", type=Path, default=None, help="also record the fast tier's values as the tests' expectations (a CSV)")
    r.add_argument("--readme", type=Path, default=None, help="also rewrite the claims block of this README")
    args = parser.parse_args(argv)
    if args.command == "evaluate":
        return _evaluate(args)
    if args.command == "reproduce":
        return _reproduce(args, parser)
    table = demo(args.out, scene=args.scene, size=args.size, samples=args.samples, reference_samples=args.reference_samples)
    width = max(map(len, table))
    for name, m in table.items():
        print(f"{name:<{width}}  RMSE {m['rmse']:.4f}  SSIM {m['ssim']:.4f}  FLIP {m['flip']:.4f}  {m['seconds']:.3f} s")
    print(f"wrote {args.out / 'demo.png'}, metrics.md, metrics.json and EXR files")
    return 0


def _evaluate(args) -> int:
    from .evaluation import evaluate, report, update_readme

    split = lambda text: [t.strip() for t in text.split(",") if t.strip()]  # noqa: E731
    frame = evaluate(
        split(args.scenes),
        None if args.methods is None else split(args.methods),
        lights=split(args.lights),
        size=args.size,
        samples=args.samples,
        reference_samples=args.reference_samples,
        keep_images=True,
    )
    page = report(frame, args.out)
    if args.readme is not None:
        update_readme(frame, args.readme)
    print(frame[["scene", "light", "method", "rmse", "ssim", "flip", "seconds"]].to_string(index=False, float_format="%.4f"))
    print(f"wrote {page}, results.csv, pareto.png and the comparison grids")
    return 0


def _reproduce(args, parser) -> int:
    from . import claims

    split = lambda text: None if text is None else [t.strip() for t in text.split(",") if t.strip()]  # noqa: E731
    if args.record is not None and args.tier != "fast":
        parser.error("--record: only the fast tier is recorded as the tests' expectations")
    try:
        frame = claims.reproduce(split(args.papers), tier=args.tier, ids=split(args.ids), out=args.out,
                                 figures=not args.no_figures)
    except ValueError as err:
        parser.error(str(err))
    print(frame[["id", "ours", "verdict"]].to_string(index=False, max_colwidth=70))
    print(f"wrote {args.out / 'claims.md'}, claims.csv and the figures")
    broken = frame[~frame["verdict"].isin(claims.VERDICTS)]
    for _, row in broken.iterrows():
        print(f"error in {row['id']}: {row['note']}")
    if not broken.empty:
        return 1
    if args.record is not None:
        print(f"recorded {claims.record_expected(frame, args.record)}")
    if args.readme is not None:
        claims.update_readme(frame, args.readme)
        print(f"updated the claims block of {args.readme}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

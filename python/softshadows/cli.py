"""The ``softshadows`` command line.

``softshadows demo [--out DIR]`` runs every method on a built-in scene against a Mitsuba
reference and writes a picture grid, EXR files and a metrics table (Markdown and JSON).
``softshadows evaluate --scenes A,B --methods X,Y --lights rect,disk --out DIR [--latex]`` runs
the evaluation suite (:mod:`softshadows.evaluation`) and writes its report.
``softshadows reproduce [--papers KEYS] [--tier fast|paper] [--out DIR]`` measures the claims
ledger (:mod:`softshadows.claims`) and writes ``claims.md``, ``claims.csv`` and the figures.
``softshadows demo --mesh FILE`` and ``softshadows evaluate --mesh FILE`` run them on a mesh file
of your own, staged by :func:`softshadows.scenes.stage`; ``softshadows scenes`` lists the built-in
scenes and light kinds. ``softshadows --version`` prints the version; ``--help`` on any command
lists its options with their defaults.

Names (scenes, methods, lights, papers, claim ids) and sizes are checked before anything is
written or rendered: a bad one ends the command with a usage message listing the valid choices.
Progress bars are drawn only when stderr is a terminal, one per command, so that logs of a run
hold no carriage-return lines.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

from . import __version__
from . import _validate as v
from ._extras import MissingExtraError, require


def _run_methods(setup, gb, samples, progress):
    """Each method's visibility and seconds on the shared light samples."""
    from .methods import METHODS, SAMPLED

    results, seconds = {}, {}
    for name, method in METHODS.items():
        progress.set_description(name)
        start = time.perf_counter()
        kwargs = {"samples": samples} if name in SAMPLED else {}
        results[name] = method(setup.scene, setup.light, gb, **kwargs)
        seconds[name] = time.perf_counter() - start
        progress.update()
    return results, seconds


def demo(out, *, scene: str = "columns", size: int = 256, samples: int = 64, reference_samples: int = 1024,
         progress: bool = True, mesh=None, light: str = "rect") -> dict:
    """Runs the demo and returns the metrics table as a dict of method name to metrics.

    Writes into ``out``: ``demo.png`` (the comparison grid), ``<method>.exr`` and
    ``reference.exr`` (visibility), ``metrics.md`` and ``metrics.json``. The arguments are checked
    before ``out`` is created, and so is the ``evaluation`` extra (Mitsuba, scikit-image,
    flip-evaluator, OpenEXR, matplotlib): without it a ``ModuleNotFoundError`` names it.
    Without LLVM the Mitsuba reference runs on the slower ``scalar_rgb`` variant, with a warning
    saying how to get the fast one (:func:`softshadows.reference.variant`).

    Parameters
    ----------
    out : str or Path
        Output folder (created).
    scene : str
        A name from ``softshadows.scenes.SCENES``.
    size : int
        Image width and height in pixels.
    samples : int
        Light samples for the sample-based methods (Poisson, seed 0, shared by all).
    reference_samples : int
        Light samples of the Mitsuba ``ray_test`` reference.
    progress : bool
        Show a progress bar, only when stderr is a terminal.
    mesh : str or os.PathLike, optional
        A mesh file of your own instead of ``scene`` (:func:`softshadows.load`), staged by
        :func:`softshadows.scenes.stage`.
    light : {"rect", "disk", "sphere", "ellipsoid", "point"}
        The light's kind, placed as the scene places it.

    Returns
    -------
    dict of str to dict
        Per method, :func:`softshadows.metrics.summary` against the reference over the hit
        pixels and ``seconds``. In ``metrics.json`` a non-finite value (the infinite PSNR of an
        exact result, the NaN of a region without pixels) is ``null``, so that the file is JSON.

    Examples
    --------
    >>> from softshadows import cli
    >>> cli.demo("demo", scene="column")
    Traceback (most recent call last):
    ...
    ValueError: scene: expected a name from ['ground_sphere', ...], got 'column'
    """
    from tqdm.auto import tqdm

    from . import io, metrics, plot, reference, scenes
    from .camera import gbuffer
    from .methods import METHODS

    if mesh is None and (not isinstance(scene, str) or scene not in scenes.SCENES):
        raise ValueError(f"scene: expected a name from {list(scenes.SCENES)}, got {scene!r}")
    if light not in scenes.LIGHT_KINDS:
        raise ValueError(f"light: expected one of {scenes.LIGHT_KINDS}, got {light!r}")
    size, samples = v.positive_int("size", size), v.positive_int("samples", samples)
    reference_samples = v.positive_int("reference_samples", reference_samples)
    try:
        out = Path(out)
    except TypeError:
        raise TypeError(f"out: expected a str or os.PathLike, got {type(out).__name__}") from None
    for module in ("mitsuba", "skimage", "flip_evaluator", "OpenEXR", "matplotlib"):  # before any work
        require(module, extra="evaluation", for_="softshadows demo")
    if mesh is None:
        setup = scenes.get(scene, light=light, width=size, height=size)
    else:
        setup = scenes.stage(mesh, light=light, width=size, height=size)
    out.mkdir(parents=True, exist_ok=True)
    # disable=None: tqdm draws only on a terminal.
    with tqdm(total=len(METHODS) + 2, desc="gbuffer", unit="step", disable=None if progress else True) as bar:
        gb = gbuffer(setup.scene, setup.camera)
        bar.update()
        bar.set_description("mitsuba reference")
        ref_samples = setup.light.samples(reference_samples, pattern="sobol", seed=1)
        # Its own bar would nest in this one: one bar per command.
        ref = reference.mitsuba_visibility(setup.scene, setup.light, gb, ref_samples, progress=False)
        bar.update()
        shared = setup.light.samples(samples, pattern="poisson", seed=0)
        results, seconds = _run_methods(setup, gb, shared, bar)

    table = {}
    for name, vis in results.items():
        table[name] = {**metrics.summary(vis, ref, gb.mask), "seconds": seconds[name]}
        io.write_exr(out / f"{name}.exr", vis)
    io.write_exr(out / "reference.exr", ref)
    titles = {n: f"RMSE {m['rmse']:.4f}" for n, m in table.items()}
    plot.comparison_grid(ref, results, gb.mask, path=out / "demo.png", titles=titles)
    meta = {"scene": setup.name, "light": light, "size": size, "samples": samples, "reference": f"mitsuba ray_test, {reference_samples} samples"}
    strict = {name: {k: x if math.isfinite(x) else None for k, x in m.items()} for name, m in table.items()}
    (out / "metrics.json").write_text(json.dumps({"setup": meta, "methods": strict}, indent=2, allow_nan=False))
    (out / "metrics.md").write_text(_markdown(meta, table))
    return table


#: The demo table's columns: key, heading, decimals.
_DEMO_COLUMNS = (("rmse", "RMSE", 4), ("psnr", "PSNR (dB)", 2), ("ssim", "SSIM", 4), ("flip", "FLIP", 4),
                 ("rmse.umbra", "RMSE umbra", 4), ("rmse.penumbra", "RMSE penumbra", 4), ("rmse.lit", "RMSE lit", 4),
                 ("seconds", "seconds", 3))


def _markdown(meta: dict, table: dict) -> str:
    lines = [
        f"# softshadows demo: `{meta['scene']}`, {meta['size']}x{meta['size']}",
        "",
        f"Reference: {meta['reference']}. Sample-based methods: {meta['samples']} Poisson samples. Umbra, penumbra "
        "and lit: pixels by their reference visibility (softshadows.metrics.regions); a dash where a region has no pixels.",
        "",
        "| method | " + " | ".join(heading for _, heading, _ in _DEMO_COLUMNS) + " |",
        "|---|" + "---|" * len(_DEMO_COLUMNS),
    ]
    for name, m in table.items():
        cells = ("-" if math.isnan(m[key]) else f"{m[key]:.{digits}f}" for key, _, digits in _DEMO_COLUMNS)
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


class _Formatter(argparse.ArgumentDefaultsHelpFormatter):
    """``--help`` with each option's default, except options without one (``None``: the help says
    what happens then) and flags (off unless given)."""

    def _get_help_string(self, action):
        if action.default is None or action.default is False:
            return action.help
        return super()._get_help_string(action)


def _name_list(allowed, what: str):
    """An argparse ``type``: comma-separated names, each from ``allowed``, as a list."""

    def parse(text: str) -> list:
        names = [t.strip() for t in text.split(",") if t.strip()]
        unknown = [n for n in names if n not in allowed]
        if unknown:
            raise argparse.ArgumentTypeError(f"unknown {what} {', '.join(map(repr, unknown))}; choose from {', '.join(allowed)}")
        if not names:
            raise argparse.ArgumentTypeError(f"expected comma-separated {what} names from {', '.join(allowed)}")
        return names

    return parse


def _method_list(text: str) -> list:
    """An argparse ``type``: comma-separated built-in or registered method names and
    ``module:function`` imports, as names and callables."""
    import importlib

    from .evaluation import REGISTERED
    from .methods import METHODS

    methods = []
    for item in (t.strip() for t in text.split(",")):
        if not item:
            continue
        if item in METHODS or item in REGISTERED:
            methods.append(item)
            continue
        module, _, function = item.partition(":")
        if not function:
            raise argparse.ArgumentTypeError(f"unknown method {item!r}; choose from {', '.join(METHODS)}, or give "
                                             "module:function")
        try:
            methods.append(getattr(importlib.import_module(module), function))
        except (ImportError, AttributeError) as err:
            raise argparse.ArgumentTypeError(f"cannot import the method {item!r}: {err}") from None
    if not methods:
        raise argparse.ArgumentTypeError(f"expected comma-separated method names from {', '.join(METHODS)}")
    return methods


def _mesh_file(text: str) -> Path:
    """An argparse ``type``: an existing file in one of the formats :func:`softshadows.load` reads."""
    from .scene import FORMATS

    path = Path(text)
    if path.suffix.lower() not in FORMATS:
        raise argparse.ArgumentTypeError(f"{text!r} is not a mesh file: expected one of {', '.join(FORMATS)}")
    if not path.is_file():
        raise argparse.ArgumentTypeError(f"{text!r} does not exist")
    return path


def _scenes() -> int:
    """Prints the built-in scenes (name and what each mirrors) and the light kinds."""
    from .scenes import LIGHT_KINDS, SCENES, get

    width = max(map(len, SCENES))
    for name in SCENES:
        try:
            about = get(name, width=1, height=1).description
        except ModuleNotFoundError as missing:  # the models need pymeshlab
            about = str(missing)
        print(f"{name:<{width}}  {about}")
    print(f"lights: {', '.join(LIGHT_KINDS)}")
    return 0


def _positive_int(text: str) -> int:
    """An argparse ``type``: a positive integer."""
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {text!r}")
    return value


def main(argv=None) -> int:
    """The ``softshadows`` command: parses ``argv`` and runs the chosen command.

    Parameters
    ----------
    argv : list of str, optional
        The arguments after the program name; default ``sys.argv[1:]``.

    Returns
    -------
    int
        The exit status: 0 on success, 1 when a claim's measurement broke (``reproduce``) or an
        optional package the command needs is missing (a message on stderr names the extra to
        install, ``pip install 'softshadows[evaluation]'``). Bad arguments exit through
        ``SystemExit(2)`` with a usage message, as argparse does.

    Examples
    --------
    >>> from softshadows import cli
    >>> try:
    ...     cli.main(["--version"])
    ... except SystemExit as done:
    ...     print("exit status", done.code)
    softshadows ...
    exit status 0
    """
    from . import claims
    from .methods import METHODS
    from .scenes import LIGHT_KINDS, SCENES

    parser = argparse.ArgumentParser(prog="softshadows", formatter_class=_Formatter,
                                     description="Real-time soft-shadow methods, measured against exact and Mitsuba references.")
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)
    d = sub.add_parser("demo", help="run every method on a built-in scene against Mitsuba", formatter_class=_Formatter)
    d.add_argument("--out", type=Path, default=Path("demo"), help="output folder")
    d.add_argument("--scene", default="columns", choices=list(SCENES), metavar="SCENE",
                   help=f"scene name, one of {', '.join(SCENES)}")
    d.add_argument("--mesh", type=_mesh_file, default=None, help="a mesh file of your own instead of --scene")
    d.add_argument("--light", default="rect", choices=LIGHT_KINDS, help="the light's kind")
    d.add_argument("--size", type=_positive_int, default=256, help="image width and height in pixels")
    d.add_argument("--samples", type=_positive_int, default=64, help="light samples for sample-based methods")
    d.add_argument("--reference-samples", type=_positive_int, default=1024, help="light samples of the Mitsuba reference")
    e = sub.add_parser("evaluate", help="every method on every scene and light against Mitsuba, as a report", formatter_class=_Formatter)
    e.add_argument("--scenes", type=_name_list(SCENES, "scene"), default=None,
                   help=f"comma-separated scene names from {', '.join(SCENES)}; default columns, or none with --mesh")
    e.add_argument("--mesh", type=_mesh_file, action="append", default=[],
                   help="a mesh file of your own (repeat for more), staged under each of --lights")
    e.add_argument("--methods", type=_method_list, default=None,
                   help=f"comma-separated method names from {', '.join(METHODS)}, methods registered with "
                        "softshadows.evaluation.register_method, or module:function of your own; default all")
    e.add_argument("--lights", type=_name_list(LIGHT_KINDS, "light"), default="rect",
                   help=f"comma-separated light kinds from {', '.join(LIGHT_KINDS)}")
    e.add_argument("--size", type=_positive_int, default=128, help="image width and height in pixels")
    e.add_argument("--samples", type=_positive_int, default=64, help="light samples for sample-based methods")
    e.add_argument("--reference-samples", type=_positive_int, default=4096, help="light samples of the Mitsuba reference")
    e.add_argument("--out", type=Path, default=Path("evaluation"), help="output folder")
    e.add_argument("--latex", action="store_true", help="also write the results as a LaTeX table, results.tex")
    e.add_argument("--readme", type=Path, default=None, help="also rewrite the results table of this README")
    sub.add_parser("scenes", help="list the built-in scenes and the light kinds", formatter_class=_Formatter)
    r = sub.add_parser("reproduce", help="measure every claim of the five papers (the claims ledger)", formatter_class=_Formatter)
    r.add_argument("--papers", type=_name_list(claims.SECTIONS, "paper"), default=None,
                   help=f"comma-separated section keys from {', '.join(claims.SECTIONS)} (a paper's, or beyond the "
                        "papers); default all")
    r.add_argument("--ids", type=_name_list(claims.CLAIMS, "claim id"), default=None,
                   help="comma-separated claim ids (softshadows.claims.CLAIMS); default all of the papers'")
    r.add_argument("--tier", choices=("fast", "paper"), default="fast",
                   help="fast: small sizes, minutes; paper: the papers' own sizes, up to an hour")
    r.add_argument("--out", type=Path, default=Path("claims"), help="output folder for claims.md, claims.csv and the figures")
    r.add_argument("--no-figures", action="store_true", help="skip the figures")
    r.add_argument("--record", type=Path, default=None, help="also record the fast tier's values as the tests' expectations (a CSV)")
    r.add_argument("--readme", type=Path, default=None, help="also rewrite the claims block of this README")
    args = parser.parse_args(argv)
    try:
        if args.command == "evaluate":
            return _evaluate(args)
        if args.command == "reproduce":
            return _reproduce(args, r)
        if args.command == "scenes":
            return _scenes()
        return _demo(args)
    except MissingExtraError as exc:  # the core is installed without the evaluation stack
        print(exc, file=sys.stderr)  # e.g. "softshadows demo needs mitsuba: pip install ..."
        return 1


def _demo(args) -> int:
    table = demo(args.out, scene=args.scene, size=args.size, samples=args.samples, reference_samples=args.reference_samples,
                 mesh=args.mesh, light=args.light)
    width = max(map(len, table))
    for name, m in table.items():
        print(f"{name:<{width}}  RMSE {m['rmse']:.4f}  PSNR {m['psnr']:.2f} dB  SSIM {m['ssim']:.4f}  FLIP {m['flip']:.4f}  "
              f"{m['seconds']:.3f} s")
    print(f"wrote {args.out / 'demo.png'}, metrics.md, metrics.json and EXR files")
    return 0


def _evaluate(args) -> int:
    from .evaluation import evaluate, report, update_readme

    named = args.scenes if args.scenes is not None else ([] if args.mesh else ["columns"])
    frame = evaluate(named + args.mesh, args.methods, lights=args.lights, size=args.size, samples=args.samples,
                     reference_samples=args.reference_samples, keep_images=True)
    page = report(frame, args.out, latex=args.latex)
    if args.readme is not None:
        update_readme(frame, args.readme)
    print(frame[["scene", "light", "method", "rmse", "psnr", "ssim", "flip", "seconds"]].to_string(index=False, float_format="%.4f"))
    print(f"wrote {page}, results.csv, {'results.tex, ' if args.latex else ''}pareto.png and the comparison grids")
    return 0


def _reproduce(args, parser) -> int:
    from . import claims

    if args.record is not None and args.tier != "fast":
        parser.error("--record: only the fast tier is recorded as the tests' expectations")
    if args.papers is not None and args.ids is not None:
        outside = [i for i in args.ids if claims.CLAIMS[i].paper.key not in args.papers]
        if outside:
            parser.error(f"--ids: {', '.join(outside)} not among the claims of --papers {','.join(args.papers)}")
    frame = claims.reproduce(args.papers, tier=args.tier, ids=args.ids, out=args.out, figures=not args.no_figures)
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

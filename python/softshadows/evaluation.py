"""The evaluation suite: every method on every scene against a Mitsuba reference.

Users pick a soft-shadow method by its error and its cost on their kind of scene; :func:`evaluate`
measures both on the same receivers, light samples and reference, and :func:`report` turns the
table into a Markdown page, comparison grids and a time-versus-error chart with the Pareto front,
and :func:`latex_table` into a table for a paper. ``softshadows evaluate`` on the command line runs
both.

Each row holds every metric of :func:`softshadows.metrics.summary`: RMSE, PSNR, SSIM and FLIP over
the hit pixels, and the RMSE over the umbra, the penumbra and the lit pixels of the reference
(:func:`softshadows.metrics.regions`), where soft-shadow methods differ most.

The reference of each scene and light is Mitsuba's own ``ray_test`` on ``reference_samples``
Sobol samples (:func:`softshadows.reference.mitsuba_visibility`), cached on disk by input hash,
so a second evaluation of the same setups does not call Mitsuba again.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import os
import time
from pathlib import Path

import numpy as np

from . import _core
from . import _validate as v
from ._extras import require

__all__ = ["evaluate", "evaluate_sequence", "OverTime", "sweep", "report", "latex_table", "pareto_front", "results_table", "update_readme"]

#: The metric columns of :func:`report` and :func:`latex_table`: column, heading, decimals.
_TABLE_COLUMNS = (
    ("rmse", "RMSE", 4),
    ("psnr", "PSNR (dB)", 2),
    ("ssim", "SSIM", 4),
    ("flip", "FLIP", 4),
    ("rmse.umbra", "RMSE umbra", 4),
    ("rmse.penumbra", "RMSE penumbra", 4),
    ("rmse.lit", "RMSE lit", 4),
    ("seconds", "seconds", 3),
)

#: The columns :func:`report` and :func:`latex_table` need.
_REPORT_COLUMNS = ("scene", "light", "method", "error") + tuple(c for c, _, _ in _TABLE_COLUMNS)


def evaluate(
    scenes=("columns",),
    methods=None,
    *,
    lights=("rect",),
    size: int = 128,
    samples: int = 64,
    reference_samples: int = 4096,
    options: dict | None = None,
    repeat: int = 2,
    shaded: bool = False,
    render_spp: int = 256,
    keep_images: bool = False,
    progress: bool = True,
):
    """Every method on every scene and light against the Mitsuba reference.

    Parameters
    ----------
    scenes : sequence of str, Setup or path
        Names from ``softshadows.scenes.SCENES`` and mesh files (staged by
        :func:`softshadows.scenes.stage`), each under every kind of ``lights``; and
        :class:`~softshadows.scenes.Setup` objects, each under its own light.
    methods : sequence or dict, optional
        Names from ``softshadows.METHODS`` and user callables ``f(scene, light, receivers, *,
        samples, **options) -> visibility`` (labelled by ``__name__``, or by their keys in a
        dict of label to callable or name); default every built-in method. A callable gets the
        shared light samples and ``options`` under its label.
    lights : sequence of {"rect", "disk", "sphere", "ellipsoid", "point"}
        Light kinds, each at the scene's default placement and size (not for Setups).
    size : int
        Image width and height in pixels.
    samples : int
        Light samples of the sample-based methods (Poisson, seed 0, shared by all of them).
    reference_samples : int
        Sobol samples of the reference.
    options : dict of str to dict, optional
        Keyword options per method, e.g. ``{"backprojection": {"budget": 8}}``.
    repeat : int
        Runs per method; ``seconds`` is the fastest (the machines are shared and noisy).
    shaded : bool
        Also compare shaded images: each visibility through :func:`softshadows.shading.direct`
        (albedo 0.8) against Mitsuba's path-traced direct light
        (:func:`softshadows.reference.mitsuba_render`, ``render_spp`` samples per pixel), as the
        ``shaded.rmse`` and ``shaded.flip`` columns.
    render_spp : int
        Samples per pixel of the shaded reference.
    keep_images : bool
        Keep every visibility image, the reference and the mask in ``frame.attrs["images"]``
        (keyed by ``(scene, light)``) for :func:`report`'s grids.
    progress : bool
        Show one progress bar for the whole run (the references' own bars are off), and only when
        stderr is a terminal, so that logs get no carriage-return lines.

    Returns
    -------
    pandas.DataFrame
        One row per scene, light and method: ``scene``, ``light``, ``method``, the metrics of
        :func:`softshadows.metrics.summary` over the hit pixels (``rmse``, ``psnr``, ``ssim``,
        ``flip``, ``rmse.umbra``, ``rmse.penumbra``, ``rmse.lit``; a region without pixels is
        NaN), ``seconds`` (wall-clock, fastest of ``repeat`` runs),
        ``shaded.rmse`` and ``shaded.flip`` with ``shaded``, ``error`` (why a method refused the setup by
        :class:`softshadows.UnsupportedSetup`, e.g. a non-planar light for ``backprojection``;
        metrics are NaN then; any other error stops the evaluation, as a bug should) and every stat the
        method reports, as ``stats.<name>`` columns.

    Examples
    --------
    Every name is checked before the first reference, which can take minutes:

    >>> import softshadows as ss
    >>> ss.evaluate(["columns"], ["ray_trace"])
    Traceback (most recent call last):
    ...
    ValueError: methods: unknown ['ray_trace']; expected callables or names from ['ray_traced', ...]
    """
    pd = require("pandas", extra="evaluation", for_="softshadows.evaluate")
    from tqdm.auto import tqdm

    from . import metrics, reference, shading
    from . import scenes as scene_library

    # Everything is checked before the first Mitsuba reference, which can take minutes.
    chosen = _methods(methods)
    names = list(chosen)
    scenes = _scene_items(scenes)
    lights = _names("lights", lights, scene_library.LIGHT_KINDS)
    size, samples = v.positive_int("size", size), v.positive_int("samples", samples)
    reference_samples = v.positive_int("reference_samples", reference_samples)
    repeat, render_spp = v.positive_int("repeat", repeat), v.positive_int("render_spp", render_spp)
    options = _options(options, chosen)
    rows, images = [], {}
    setups = [(item, k) for item in scenes for k in _lights_of(item, lights)]
    # disable=None: tqdm draws only on a terminal.
    with tqdm(total=len(setups) * (len(names) + 1), desc="evaluate", unit="run", disable=None if progress else True) as bar:
        for item, kind in setups:
            scene_name = _scene_label(item)
            bar.set_description(f"{scene_name}/{kind}: reference")
            case = _Case.build(item, kind, size, samples=samples, reference_samples=reference_samples)
            bar.update()
            gb, ref = case.gbuffer, case.reference
            render = reference.mitsuba_render(case.setup.scene, case.setup.light, case.setup.camera, spp=render_spp)[..., 0] if shaded else None
            kept = {"reference": ref, "mask": gb.mask}
            for name in names:
                bar.set_description(f"{scene_name}/{kind}: {name}")
                record, vis = case.run(chosen[name], options.get(name, {}), repeat=repeat)
                row = {"scene": scene_name, "light": kind, "method": name, **record}
                if vis is not None:
                    if render is not None:
                        image = shading.direct(gb, case.setup.light, vis)
                        row.update({"shaded.rmse": metrics.rmse(image, render, gb.mask), "shaded.flip": metrics.flip(image, render, gb.mask)})
                    kept[name] = vis
                rows.append(row)
                bar.update()
            if keep_images:
                images[(scene_name, kind)] = kept
    frame = pd.DataFrame(rows)
    if keep_images:
        frame.attrs["images"] = images
    frame.attrs["setup"] = {"size": size, "samples": samples, "reference": f"mitsuba ray_test, {reference_samples} Sobol samples"}
    return frame


#: Sweep parameters that shape the setup rather than the method's call.
SETUP_PARAMETERS = ("light_size", "samples")


def sweep(method, parameters: dict, *, scenes=("columns",), lights=("rect",), size: int = 96,
          samples: int = 64, reference_samples: int = 1024, executor=None, progress: bool = True,
          name: str | None = None):
    """One method over a grid of parameters, every combination on every scene and light, run on
    any :class:`concurrent.futures.Executor`.

    Parameters
    ----------
    method : str or callable
        A name from ``softshadows.METHODS``, or a callable ``f(scene, light, receivers, *,
        samples, **parameters) -> visibility`` that pickles to the workers (a module-level
        function, or a ``functools.partial`` of one).
    parameters : dict of str to sequence
        The values of each parameter; every combination is one task. The method's keyword
        options (``budget``, ``order``, ``lut``, ...), plus ``samples`` (the number of light
        samples of the sample-based methods) and ``light_size`` (the scene's light size).
    scenes, lights, size, samples, reference_samples
        As in :func:`evaluate` (``samples`` is the default when ``parameters`` has none).
    executor : concurrent.futures.Executor, optional
        Where the tasks run: by default a local process pool (spawned workers, one per core); a
        Dask ``distributed.Client(...).get_executor()`` runs them on a cluster. Workers share
        the on-disk reference cache when they share a file system.
    progress : bool
        Show a progress bar over the tasks, only when stderr is a terminal.
    name : str, optional
        The ``method`` column of a callable; default its ``__name__``.

    Returns
    -------
    pandas.DataFrame
        One row per task, in grid order: ``scene``, ``light``, ``method``, the parameters, the
        metrics of :func:`softshadows.metrics.summary` (as in :func:`evaluate`), ``seconds`` and
        ``error``.

    Examples
    --------
    The grid is checked before any worker starts:

    >>> import softshadows as ss
    >>> ss.sweep("backprojection", {"budget": 8})
    Traceback (most recent call last):
    ...
    ValueError: parameters: 'budget' needs a sequence of values, got 8
    """
    import itertools
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    pd = require("pandas", extra="evaluation", for_="softshadows.sweep")
    from tqdm.auto import tqdm

    from . import scenes as scene_library

    (label, method), = _methods({name: method} if name is not None else [method], argument="method").items()
    # Checked here: a bad value would otherwise surface from a worker process, after the spawn.
    if not isinstance(parameters, dict) or not all(isinstance(k, str) for k in parameters):
        raise ValueError(f"parameters: expected a dict of option name to a sequence of values, got {parameters!r}")
    for key, values in parameters.items():
        if isinstance(values, (str, bytes, dict)) or not hasattr(values, "__iter__"):
            raise ValueError(f"parameters: {key!r} needs a sequence of values, got {values!r}")
    scenes = _scene_items(scenes)
    lights = _names("lights", lights, scene_library.LIGHT_KINDS)
    if "light_size" in parameters and any(isinstance(item, scene_library.Setup) for item in scenes):
        raise ValueError("parameters: light_size re-stages a scene, which a Setup given as it is cannot be; pass the "
                         "scene's name or file instead")
    size, samples = v.positive_int("size", size), v.positive_int("samples", samples)
    reference_samples = v.positive_int("reference_samples", reference_samples)
    if executor is not None and not callable(getattr(executor, "map", None)):
        raise ValueError(f"executor: expected a concurrent.futures.Executor, got {type(executor).__name__}")
    keys = list(parameters)
    grid = list(itertools.product(*(list(parameters[k]) for k in keys)))
    tasks = [(scene, light, label, method, dict(zip(keys, values)), size, samples, reference_samples)
             for scene in scenes for light in _lights_of(scene, lights) for values in grid]
    own = executor is None
    if own:
        # Spawned, not forked: a forked child would inherit a thread pool without its threads.
        executor = ProcessPoolExecutor(max_workers=os.cpu_count(), mp_context=multiprocessing.get_context("spawn"))
    try:
        records = list(tqdm(executor.map(_sweep_task, tasks), total=len(tasks), desc=f"sweep {label}",
                            disable=None if progress else True))
    finally:
        if own:
            executor.shutdown()
    return pd.DataFrame(records)


def _sweep_task(task) -> dict:
    """One sweep task (a top-level function, so that it pickles to any executor's workers)."""
    item, light, label, method, params, size, samples, reference_samples = task
    case = _Case.build(item, light, size, samples=params.get("samples", samples), reference_samples=reference_samples,
                       **{k: v for k, v in params.items() if k == "light_size"})
    record, _ = case.run(method, {k: v for k, v in params.items() if k not in SETUP_PARAMETERS})
    return {"scene": _scene_label(item), "light": light, "method": label, **params, **record}


@dataclasses.dataclass(frozen=True)
class OverTime:
    """A method entry of :func:`evaluate_sequence` run the way a real-time renderer runs it over
    frames: with temporal jitter, and with its frames accumulated.

    A plain name or callable in ``methods`` runs on the same light samples in every frame; an
    ``OverTime`` entry changes that.

    Parameters
    ----------
    method : str or callable
        A name from ``softshadows.METHODS`` (or :func:`register_method`), or a callable as
        :func:`evaluate` takes them.
    jitter : bool
        Jitter over time (Sintorn et al. 2008, section 4.3): frame ``i`` gets the shared light
        samples of ``light.samples(n, frame=i)``, each frame's whole pattern rotated, so that
        noise changes from frame to frame instead of standing still; a built-in method that
        takes ``frame=`` rather than light samples gets ``frame=i``.
    accumulate : bool or float
        Accumulate the frames: each frame's visibility goes through
        :func:`softshadows.accumulate` with one :class:`softshadows.History` for the sequence, an
        exponential moving average of the frames reprojected into the current one; a float is
        its ``alpha``, the current frame's weight (True: its default).
    history : bool
        Pass one :class:`softshadows.History` for the sequence to the method as ``history=``,
        for a method with a temporal stage of its own (``denoised``).

    Examples
    --------
    >>> import softshadows as ss
    >>> from softshadows.evaluation import OverTime
    >>> OverTime("alias_free").label, OverTime("alias_free", accumulate=0.1).label
    ('alias_free+jitter', 'alias_free+jitter+accumulate(0.1)')

    Entries are checked before the first reference:

    >>> ss.evaluate_sequence(ss.sequence(ss.scenes.get("columns"), frames=2), [OverTime("pcss")])
    Traceback (most recent call last):
    ...
    ValueError: methods: 'pcss+jitter' jitters over frames, but pcss takes neither light samples nor frame=; ...
    """

    method: object
    jitter: bool = True
    accumulate: bool | float = False
    history: bool = False

    def __post_init__(self):
        object.__setattr__(self, "jitter", v.flag("jitter", self.jitter))
        object.__setattr__(self, "history", v.flag("history", self.history))
        if not isinstance(self.accumulate, (bool, np.bool_)):
            object.__setattr__(self, "accumulate", v.number("accumulate", self.accumulate))  # its range: accumulate's

    @property
    def label(self) -> str:
        """The entry's ``method`` column: the method's name and how it runs over time."""
        name = self.method if isinstance(self.method, str) else getattr(self.method, "__name__", repr(self.method))
        alpha = self.accumulate
        parts = [name] + ["jitter"] * self.jitter + ["history"] * self.history
        parts += [] if alpha is False else ["accumulate" if alpha is True else f"accumulate({alpha:g})"]
        return "+".join(parts)

    def _checked(self, label: str) -> "OverTime":
        """This entry (its method resolved to a callable), refused when it asks the method for
        what it cannot take."""
        from .methods import SAMPLED

        builtin = _builtin_name(self.method)
        if self.jitter and builtin is not None and not (builtin in SAMPLED or _takes(self.method, "frame")):
            raise ValueError(f"methods: {label!r} jitters over frames, but {builtin} takes neither light samples nor frame=; "
                             f"pass OverTime(..., jitter=False) or a method that samples the light ({sorted(SAMPLED)})")
        if self.history and not _takes(self.method, "history"):
            raise ValueError(f"methods: {label!r} passes a History, but {builtin or label} takes no history=; accumulate "
                             "any method's frames with OverTime(..., accumulate=True)")
        return self

    def _frame(self, case, index: int, options: dict, histories: dict) -> tuple:
        """``(record, visibility)`` of frame ``index`` of a sequence, ``histories`` holding
        this entry's state over the sequence."""
        from .methods import SAMPLED

        options = dict(options)
        if self.jitter:
            case = case.at_frame(index)
            if _builtin_name(self.method) not in SAMPLED and _takes(self.method, "frame"):
                options["frame"] = index
        if self.history:
            options["history"] = histories["method"]
        then = None
        if self.accumulate is not False:
            from .temporal import accumulate

            alpha = {} if self.accumulate is True else {"alpha": self.accumulate}
            then = functools.partial(accumulate, gbuffer=case.gbuffer, history=histories["accumulated"], **alpha)
        return case.run(self.method, options, then=then)


def _takes(method, keyword: str) -> bool:
    """Whether the callable ``method`` has a parameter named ``keyword``."""
    import inspect

    try:
        return keyword in inspect.signature(method).parameters
    except (TypeError, ValueError):  # a callable without a signature
        return False


def evaluate_sequence(
    sequences,
    methods=None,
    *,
    size: int = 128,
    samples: int = 64,
    reference_samples: int = 1024,
    options: dict | None = None,
    executor=None,
    keep_images: bool = False,
    progress: bool = True,
):
    """Methods over animations, frame by frame against each frame's reference, and how steady
    their error is over time.

    Each frame is measured as :func:`evaluate` measures a set-up (the same G-buffer, Mitsuba
    reference and shared light samples, through the same case runner); the frames of each method
    then give the temporal metrics of :mod:`softshadows.metrics`: ``temporal.std``, the mean over
    pixels of the standard deviation over frames of the error (noise that moves), and
    ``temporal.flicker``, the mean change of the result from frame to frame against the
    reference's own change.

    Parameters
    ----------
    sequences : Sequence or sequence of Sequence
        From :func:`softshadows.sequence`, with distinct names.
    methods : sequence or dict, optional
        As in :func:`evaluate` (names, callables, a dict of label to either), plus
        :class:`OverTime` entries: a method with temporal jitter, its frames accumulated, or with
        a history of its own (labelled by ``OverTime.label``, or by their keys in a dict). A
        plain entry runs on the same light samples in every frame. Default every built-in method.
    size : int
        Image width and height in pixels.
    samples : int
        Light samples of the sample-based methods (Poisson, seed 0, shared by all of them).
    reference_samples : int
        Sobol samples of each frame's reference (the same pattern in every frame).
    options : dict of str to dict, optional
        Keyword options per method label, e.g. ``{"alias_free": {"lut": None}}``.
    executor : concurrent.futures.Executor, optional
        Where the work runs: by default in this process; a process pool or a Dask
        ``distributed.Client(...).get_executor()`` runs the frames' references in parallel, then
        each method over each sequence (its frames in order, as its history needs). The
        records are the same wherever they run, but for the wall times.
    keep_images : bool
        Keep every frame's visibility, reference and mask in ``frame.attrs["images"]`` (keyed by
        sequence name, each a dict of (F, H, W) stacks: ``"reference"``, ``"mask"`` and one per
        method that ran) for :func:`softshadows.plot.animation`.
    progress : bool
        Show a progress bar over the frames (references, then every method's), only when stderr
        is a terminal.

    Returns
    -------
    pandas.DataFrame
        One row per sequence and method: ``sequence``, ``method``, ``frames``, the mean over
        the frames of each metric of :func:`softshadows.metrics.summary` (``rmse``, ``psnr``,
        ``ssim``, ``flip``, ``rmse.umbra``, ``rmse.penumbra``, ``rmse.lit``; a region over the
        frames that have it), ``temporal.std`` and ``temporal.flicker`` (NaN with fewer than two
        frames or when a frame was refused), ``seconds`` (the mean per frame, accumulation
        included) and ``error`` (the first refusal, as in :func:`evaluate`).
        ``frame.attrs["frames"]`` holds one row per sequence, method and frame, as
        :func:`evaluate`'s rows (``frame`` is its index; its stats as ``stats.<name>``), with
        the frame's ``flicker`` against the frame before it (NaN in the first).

    Examples
    --------
    A static sequence: the exact oracle's error does not change over time.

    >>> import softshadows as ss
    >>> still = ss.sequence(ss.scenes.get("columns"), frames=3)
    >>> summary = ss.evaluate_sequence(still, ["ray_traced"], size=24, reference_samples=64, progress=False)
    >>> summary[["method", "frames", "temporal.std", "temporal.flicker"]].to_dict("records")
    [{'method': 'ray_traced', 'frames': 3, 'temporal.std': 0.0, 'temporal.flicker': 0.0}]
    >>> summary.attrs["frames"]["frame"].tolist()
    [0, 1, 2]
    """
    pd = require("pandas", extra="evaluation", for_="softshadows.evaluate_sequence")
    from tqdm.auto import tqdm

    # Everything is checked before the first Mitsuba reference, which can take minutes.
    sequences = _sequence_items(sequences)
    entries = _entries(methods)
    size, samples = v.positive_int("size", size), v.positive_int("samples", samples)
    reference_samples = v.positive_int("reference_samples", reference_samples)
    options = _options(options, entries)
    keep_images = v.flag("keep_images", keep_images)
    if executor is not None and not callable(getattr(executor, "map", None)):
        raise ValueError(f"executor: expected a concurrent.futures.Executor, got {type(executor).__name__}")
    run_all = map if executor is None else executor.map
    frames = sum(len(s) for s in sequences)
    with tqdm(total=frames * (1 + len(entries)), desc="evaluate_sequence: references", unit="frame",
              disable=None if progress else True) as bar:
        cases = []
        for case in run_all(_sequence_case, [(setup, size, samples, reference_samples) for s in sequences for setup in s]):
            cases.append(case)
            bar.update()
        bounds = np.cumsum([0] + [len(s) for s in sequences])
        framed = [(s.name, cases[a:b]) for s, a, b in zip(sequences, bounds[:-1], bounds[1:])]
        tasks = [(name, label, entry, frames_of, options.get(label, {}), keep_images)
                 for name, frames_of in framed for label, entry in entries.items()]
        results = []
        if executor is None:  # in this process: the bar moves frame by frame
            for task in tasks:
                bar.set_description(f"evaluate_sequence: {task[0]}/{task[1]}")
                results.append(_sequence_runs(task, tick=bar.update))
        else:
            bar.set_description("evaluate_sequence: methods")
            for result in executor.map(_sequence_runs, tasks):
                results.append(result)
                bar.update(len(result[1]))
    summary = pd.DataFrame([row for row, _, _ in results])
    summary.attrs["frames"] = pd.DataFrame([r for _, rows, _ in results for r in rows])
    if keep_images:
        summary.attrs["images"] = {name: _kept_images(name, frames_of, results) for name, frames_of in framed}
    summary.attrs["setup"] = {"size": size, "samples": samples, "reference": f"mitsuba ray_test, {reference_samples} Sobol samples"}
    return summary


def _sequence_case(task):
    """One frame's case (a top-level function, so that it pickles to any executor's workers)."""
    setup, size, samples, reference_samples = task
    return _Case.build(setup, setup.light.kind, size, samples=samples, reference_samples=reference_samples)


def _sequence_runs(task, tick=None) -> tuple:
    """One method entry over one sequence's frames, in order (a top-level function, so that it
    pickles to any executor's workers): ``(summary row, frame rows, visibility stack or None)``;
    ``tick()`` after each frame."""
    from . import metrics

    from .temporal import History

    name, label, entry, cases, options, keep = task
    histories = {"method": History(), "accumulated": History()}  # the entry's state over the sequence
    records, images = [], []
    for index, case in enumerate(cases):
        record, vis = entry._frame(case, index, options, histories)
        records.append({"sequence": name, "method": label, "frame": index, **record})
        images.append(vis)
        if tick is not None:
            tick()
    temporal, changes = dict.fromkeys(metrics.TEMPORAL_KEYS, np.nan), [np.nan] * len(cases)
    if len(cases) >= 2 and all(vis is not None for vis in images):
        stacks = (np.stack(images), np.stack([c.reference for c in cases]), np.stack([c.gbuffer.mask for c in cases]))
        temporal = {"temporal.std": metrics.temporal_std(*stacks), "temporal.flicker": metrics.flicker(*stacks)}
        changes = metrics.flicker(*stacks, per_frame=True)
    for record, change in zip(records, changes):
        record["flicker"] = float(change)
    errors = [r["error"] for r in records if r["error"] is not None]
    row = {"sequence": name, "method": label, "frames": len(cases),
           **{k: _mean(r[k] for r in records) for k in metrics.SUMMARY_KEYS}, **temporal,
           "seconds": _mean(r["seconds"] for r in records), "error": errors[0] if errors else None}
    return row, records, np.stack(images) if keep and not errors else None


def _mean(values) -> float:
    """The mean of the finite-or-infinite values, NaN when every one is NaN (a region no frame has)."""
    values = np.array(list(values), dtype=float)
    values = values[~np.isnan(values)]
    return float(values.mean()) if len(values) else math.nan


def _kept_images(name, cases, results) -> dict:
    """One sequence's stacks for :func:`softshadows.plot.animation`."""
    kept = {"reference": np.stack([c.reference for c in cases]), "mask": np.stack([c.gbuffer.mask for c in cases])}
    kept.update({row["method"]: stack for row, _, stack in results if row["sequence"] == name and stack is not None})
    return kept


def _sequence_items(sequences) -> list:
    """The sequences to evaluate, checked: one Sequence or several, with distinct names."""
    from .scenes import Sequence

    items = [sequences] if isinstance(sequences, Sequence) else sequences
    if isinstance(items, (str, bytes)) or not hasattr(items, "__iter__"):
        raise ValueError(f"sequences: expected a Sequence from softshadows.sequence, or a list of them, got {sequences!r}")
    items = list(items)
    bad = [x for x in items if not isinstance(x, Sequence)]
    if bad or not items:
        raise ValueError(f"sequences: expected Sequences from softshadows.sequence, got {bad or items!r}")
    names = [s.name for s in items]
    if len(set(names)) < len(names):
        raise ValueError(f"sequences: the names {names} repeat; give each its own with softshadows.sequence(..., name=...)")
    return items


def _entries(methods) -> dict:
    """The method entries by label, as :class:`OverTime` (a plain entry without jitter), each
    method resolved by :func:`_methods` and checked."""
    from collections.abc import Mapping

    if isinstance(methods, OverTime):
        raise ValueError(f"methods: expected a sequence or dict of entries, got one {methods!r}; pass [{methods!r}]")
    if methods is None or isinstance(methods, (str, bytes)) or callable(methods) or not hasattr(methods, "__iter__"):
        plain = _methods(methods)  # every built-in method, or the refusal of a bare name
        return {label: OverTime(method, jitter=False) for label, method in plain.items()}
    pairs = list(methods.items()) if isinstance(methods, Mapping) else [
        (m.label if isinstance(m, OverTime) else getattr(m, "__name__", m), m) for m in methods]
    specs = {label: m if isinstance(m, OverTime) else OverTime(m, jitter=False) for label, m in pairs}
    resolved = _methods({label: spec.method for label, spec in specs.items()})
    return {label: dataclasses.replace(specs[label], method=method)._checked(label) for label, method in resolved.items()}


class _Case:
    """One scene under one light, ready for methods: the set-up, its G-buffer, the Mitsuba
    reference on Sobol samples and the Poisson samples every sampled method shares. The one
    pipeline of :func:`evaluate` and :func:`sweep`."""

    def __init__(self, setup, gbuffer, reference, shared):
        self.setup, self.gbuffer, self.reference, self.shared = setup, gbuffer, reference, shared

    @classmethod
    def build(cls, item, light, size, *, samples, reference_samples, **staging):
        from . import reference
        from .camera import gbuffer

        setup = _build(item, light, size, **staging)
        gb = gbuffer(setup.scene, setup.camera)
        ref_samples = setup.light.samples(reference_samples, pattern="sobol", seed=1)
        # Its own bar would nest in the caller's: one bar per run.
        ref = reference.mitsuba_visibility(setup.scene, setup.light, gb, ref_samples, progress=False)
        return cls(setup, gb, ref, _shared_samples(setup.light, samples))

    def at_frame(self, frame: int) -> "_Case":
        """This case with the shared samples of frame ``frame`` of a temporally jittered
        sequence (Sintorn et al. 2008, section 4.3: each frame rotates the whole pattern)."""
        return _Case(self.setup, self.gbuffer, self.reference, _shared_samples(self.setup.light, len(self.shared), frame))

    def run(self, method, options, *, repeat: int = 1, then=None) -> tuple:
        """``(record, visibility)`` of ``method`` here: the metrics over the hit pixels, the
        fastest of ``repeat`` runs in seconds and the method's stats as ``stats.<name>``; or, when
        it refuses the set-up (:class:`softshadows.UnsupportedSetup`), NaN metrics, the refusal
        as ``error`` and no visibility. Any other error propagates.

        ``then`` maps the visibility once more after the runs, its time added to ``seconds``: a
        frame accumulation, which updates its history and so must not be repeated."""
        from . import metrics

        seconds = []
        try:
            for _ in range(max(1, repeat)):
                start = time.perf_counter()
                vis, stats = _run(method, self.setup, self.gbuffer, self.shared, options)
                seconds.append(time.perf_counter() - start)
        except _core.UnsupportedSetup as refusal:
            return {**dict.fromkeys(metrics.SUMMARY_KEYS, np.nan), "seconds": np.nan, "error": str(refusal)}, None
        spent = min(seconds)
        if then is not None:
            start = time.perf_counter()
            vis = then(vis)
            spent += time.perf_counter() - start
        summary = metrics.summary(vis, self.reference, self.gbuffer.mask)
        stats = {f"stats.{k}": value for k, value in stats.items()}
        return {**summary, "seconds": spent, "error": None, **stats}, vis


def _shared_samples(light, n: int, frame: int = 0):
    """The light samples every sampled method shares in one evaluation (and in one frame)."""
    return light.samples(n, pattern="poisson", seed=0, frame=frame)


#: Methods registered by :func:`register_method`, by name.
REGISTERED: dict = {}


def register_method(name: str, method) -> None:
    """Makes a method of your own known by ``name`` to :func:`evaluate`, :func:`sweep` and the
    command line's ``--methods`` (in this process; the command line also takes
    ``module:function``). Pools and clusters receive the callable itself, so it must pickle: a
    module-level function, or a ``functools.partial`` of one.

    Parameters
    ----------
    name : str
        Not a built-in method's name.
    method : callable
        ``method(scene, light, receivers, *, samples, **options) -> visibility``.

    Examples
    --------
    >>> import softshadows as ss
    >>> from softshadows import evaluation
    >>> evaluation.register_method("oracle_again", ss.ray_traced)
    >>> list(evaluation._methods(["pcss", "oracle_again"]))
    ['pcss', 'oracle_again']
    >>> del evaluation.REGISTERED["oracle_again"]
    """
    from .methods import METHODS

    if not isinstance(name, str) or not name or name in METHODS:
        raise ValueError(f"name: expected a new method name, not one of {list(METHODS)}, got {name!r}")
    if not callable(method):
        raise ValueError(f"method: expected a callable f(scene, light, receivers, *, samples), got {method!r}")
    REGISTERED[name] = method


def _methods(methods, argument: str = "methods") -> dict:
    """The methods to run by label: built-in names (their functions), and user callables
    ``f(scene, light, receivers, *, samples, **options) -> visibility``, labelled by their
    ``__name__`` in a sequence or by their key in a mapping."""
    from collections.abc import Mapping

    from .methods import METHODS

    if methods is None:
        return dict(METHODS)
    if isinstance(methods, (str, bytes)) or callable(methods) or not hasattr(methods, "__iter__"):
        raise ValueError(f"{argument}: expected a sequence of names from {list(METHODS)} or callables, got {methods!r}")
    pairs = list(methods.items()) if isinstance(methods, Mapping) else [(getattr(m, "__name__", m), m) for m in methods]
    chosen, unknown = {}, []
    for label, m in pairs:
        if isinstance(m, str) and (m in METHODS or m in REGISTERED):
            chosen[label] = METHODS.get(m) or REGISTERED[m]
        elif callable(m):
            if not isinstance(label, str) or label in chosen or (label in METHODS and METHODS[label] is not m):
                raise ValueError(f"{argument}: the callable {m!r} needs a name of its own, not {label!r}: pass "
                                 "methods={'my_method': f, ...}")
            chosen[label] = m
        else:
            unknown.append(m)
    if unknown:
        raise ValueError(f"{argument}: unknown {unknown}; expected callables or names from {list(METHODS)}")
    return chosen


def _builtin_name(method) -> str | None:
    """The name of a built-in method, None for a user's callable."""
    from .methods import METHODS

    return next((name for name, f in METHODS.items() if f is method), None)


def _run(method, setup, gb, shared, options) -> tuple:
    """``(visibility, stats)`` of one method on a set-up: a built-in one with its stats and the
    shared light samples if it samples the light; a user callable with the samples, and no stats."""
    from .methods import SAMPLED

    builtin = _builtin_name(method)
    if builtin is None:
        return np.asarray(method(setup.scene, setup.light, gb, samples=shared, **options), dtype=np.float32), {}
    kwargs = {"samples": shared} if builtin in SAMPLED else {}
    return method(setup.scene, setup.light, gb, return_stats=True, **kwargs, **options)


def _scene_items(scenes) -> list:
    """The scenes to evaluate, checked: built-in names, :class:`~softshadows.scenes.Setup`
    objects (under their own light) and mesh files (staged by :func:`softshadows.scenes.stage`)."""
    from .scene import FORMATS
    from .scenes import SCENES, Setup

    if isinstance(scenes, (str, bytes, os.PathLike, Setup)) or not hasattr(scenes, "__iter__"):
        raise ValueError(f"scenes: expected a sequence of names from {list(SCENES)}, Setups or mesh files, got {scenes!r}")
    items = list(scenes)

    def known(x):
        if isinstance(x, Setup) or (isinstance(x, str) and x in SCENES):
            return True
        return isinstance(x, (str, os.PathLike)) and Path(x).suffix.lower() in FORMATS and Path(x).is_file()

    unknown = [x for x in items if not known(x)]
    if unknown:
        raise ValueError(f"scenes: unknown {unknown}; expected names from {list(SCENES)}, Setup objects, or mesh files "
                         f"({', '.join(FORMATS)}) that exist")
    return items


def _scene_label(item) -> str:
    """The ``scene`` column of a scene item: its name, or its file's stem."""
    from .scenes import SCENES, Setup

    if isinstance(item, Setup):
        return item.name
    return item if isinstance(item, str) and item in SCENES else Path(item).stem


def _lights_of(item, lights) -> list:
    """The light kinds a scene item runs under: a Setup's own, else each of ``lights``."""
    from .scenes import Setup

    return [item.light.kind] if isinstance(item, Setup) else list(lights)


def _build(item, light: str, size: int, **setup_options):
    """The Setup of a scene item under the light kind ``light``, seen at ``size`` x ``size``."""
    from . import scenes as scene_library

    if isinstance(item, scene_library.Setup):
        return item.with_size(size, size)
    if isinstance(item, str) and item in scene_library.SCENES:
        return scene_library.get(item, light=light, width=size, height=size, **setup_options)
    return scene_library.stage(item, light=light, width=size, height=size, **setup_options)


def pareto_front(frame, x: str = "seconds", y: str = "rmse"):
    """Whether each row is on the Pareto front of ``(x, y)`` among its rows: no other row is at
    least as low in both and lower in one (faster and as accurate, or as fast and more accurate).
    Rows with NaN are not. Returns a boolean Series; :func:`report` applies it per scene and light.

    Parameters
    ----------
    frame : pandas.DataFrame
        Rows to compare, with numeric columns ``x`` and ``y``.
    x, y : str
        The two costs, lower is better (default seconds and RMSE).

    Returns
    -------
    pandas.Series of bool
        On ``frame``'s index.

    Examples
    --------
    >>> import pandas as pd
    >>> from softshadows import evaluation
    >>> frame = pd.DataFrame({"seconds": [1.0, 2.0, 3.0], "rmse": [0.2, 0.1, 0.1]})
    >>> evaluation.pareto_front(frame).tolist()  # the third is as accurate as the second, and slower
    [True, True, False]
    """
    _columns(frame, (x, y))
    try:
        values = frame[[x, y]].to_numpy(dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"frame: columns {x!r} and {y!r} must hold numbers") from None
    ok = np.isfinite(values).all(axis=1)
    front = []
    for i, (a, b) in enumerate(values):
        dominated = ok & (values[:, 0] <= a) & (values[:, 1] <= b) & ((values[:, 0] < a) | (values[:, 1] < b))
        front.append(bool(ok[i] and not dominated.any()))
    pd = require("pandas", extra="evaluation", for_="softshadows.evaluation.pareto_front")

    return pd.Series(front, index=frame.index, name="pareto", dtype=bool)  # bool even with no rows


def report(frame, out, *, latex: bool = False) -> Path:
    """Writes the evaluation report: ``report.md`` (a table per scene and light, the Pareto-front
    methods in bold), ``results.csv``, ``pareto.png`` (seconds against RMSE, one point per row,
    the front joined), when ``frame`` kept its images one comparison grid per scene and light, and
    with ``latex`` the table for a paper, ``results.tex`` (:func:`latex_table`).

    Parameters
    ----------
    frame : pandas.DataFrame
        From :func:`evaluate`.
    out : str or Path
        Output folder (created).
    latex : bool
        Also write ``results.tex``.

    Returns
    -------
    Path
        The Markdown page.

    Examples
    --------
    >>> import tempfile
    >>> import numpy as np, pandas as pd
    >>> from softshadows import evaluation, metrics
    >>> ref = np.tile(np.linspace(0, 1, 8), (8, 1))
    >>> rows = [{"scene": "ramp", "light": "rect", "method": name, **metrics.summary(vis, ref), "seconds": seconds,
    ...          "error": None} for name, vis, seconds in [("exact", ref, 2.0), ("hard", 1.0 * (ref > 0.5), 0.1)]]
    >>> with tempfile.TemporaryDirectory() as out:
    ...     page = evaluation.report(pd.DataFrame(rows), out, latex=True)
    ...     print(sorted(p.name for p in page.parent.iterdir()))
    ...     print(next(line for line in page.read_text().splitlines() if "exact" in line))
    ['pareto.png', 'report.md', 'results.csv', 'results.tex']
    | **exact** | 0.0000 | inf | 1.0000 | 0.0000 | 0.0000 | 0.0000 | 0.0000 | 2.000 |
    """
    plt = require("matplotlib.pyplot", extra="evaluation", for_="softshadows.evaluation.report")

    from . import metrics, plot

    _columns(frame, _REPORT_COLUMNS)
    try:
        out = Path(out)
    except TypeError:
        raise TypeError(f"out: expected a str or os.PathLike, got {type(out).__name__}") from None
    out.mkdir(parents=True, exist_ok=True)
    frame = _with_pareto(frame)
    frame.to_csv(out / "results.csv", index=False)
    if latex:
        (out / "results.tex").write_text(latex_table(frame) + "\n")
    setup = frame.attrs.get("setup", {})
    lines = ["# softshadows evaluation", ""]
    if setup:
        lines += [f"{setup['size']}x{setup['size']} receivers; sample-based methods: {setup['samples']} Poisson samples; "
                  f"reference: {setup['reference']}. Bold: on the time-versus-RMSE Pareto front of its scene and light.", ""]
    threshold = metrics.REGION_THRESHOLD
    lines += [f"Umbra, penumbra and lit: pixels whose reference visibility is <= {threshold:g}, between, and >= {1 - threshold:g} "
              "(`softshadows.metrics.regions`); a dash where a region has no pixels.", ""]
    headings = [heading for _, heading, _ in _TABLE_COLUMNS]
    for (scene, light), group in frame.groupby(["scene", "light"], sort=False):
        lines += [f"## {scene}, {light} light", "", "| method | " + " | ".join(headings) + " |",
                  "|---|" + "---|" * len(headings)]
        for _, r in group.iterrows():
            if r["error"] is not None and isinstance(r["error"], str):
                lines.append(f"| {r['method']} | refused: {r['error']} |" + " |" * (len(headings) - 1))
                continue
            name = f"**{r['method']}**" if r["pareto"] else r["method"]
            lines.append(f"| {name} | " + " | ".join(_number(r[c], digits) for c, _, digits in _TABLE_COLUMNS) + " |")
        images = frame.attrs.get("images", {}).get((scene, light))
        if images:
            grid = f"{scene}_{light}.png"
            results = {k: v for k, v in images.items() if k not in ("reference", "mask")}
            titles = {k: f"RMSE {_rmse_of(group, k):.4f}" for k in results}
            plot.comparison_grid(images["reference"], results, images["mask"], path=out / grid, titles=titles)
            plt.close("all")
            lines += ["", f"![{scene}, {light}]({grid})"]
        lines.append("")
    fig, ax = plt.subplots(figsize=(6, 4))
    ok = frame.dropna(subset=["seconds", "rmse"])
    for (scene, light), group in ok.groupby(["scene", "light"], sort=False):
        dots = ax.scatter(group["seconds"], group["rmse"], label=f"{scene}/{light}", s=18)
        for _, r in group.iterrows():
            ax.annotate(r["method"], (r["seconds"], r["rmse"]), fontsize=6, xytext=(2, 2), textcoords="offset points")
        front = group[group["pareto"]].sort_values("seconds")
        ax.plot(front["seconds"], front["rmse"], "--", lw=1, color=dots.get_facecolor()[0])
    ax.set(xscale="log", xlabel="seconds", ylabel="RMSE against the reference", title="time against error (dashed: Pareto fronts)")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out / "pareto.png", dpi=150)
    plt.close(fig)
    lines += ["## Time against error", "", "![time against error](pareto.png)", ""]
    page = out / "report.md"
    page.write_text("\n".join(lines))
    return page


def latex_table(frame) -> str:
    r"""The results as a LaTeX ``tabular`` for a paper: one row per scene, light and method, the
    columns of the Markdown report (RMSE, PSNR, SSIM, FLIP, the RMSE over umbra, penumbra and lit
    pixels, seconds), the methods on the time-versus-RMSE Pareto front of their scene and light in
    bold.

    The rules are booktabs' (``\usepackage{booktabs}`` in the preamble); a method that refused a
    setup and a region without pixels read ``--``. Made by pandas' ``Styler.to_latex``, which
    needs jinja2.

    Parameters
    ----------
    frame : pandas.DataFrame
        From :func:`evaluate` or :func:`sweep` (all of :func:`softshadows.metrics.summary`'s
        columns, ``seconds`` and ``error``).

    Returns
    -------
    str
        The ``tabular`` environment, to ``\input`` inside a ``table``.

    Examples
    --------
    >>> import numpy as np, pandas as pd
    >>> from softshadows import evaluation, metrics
    >>> ref = np.tile(np.linspace(0, 1, 8), (8, 1))
    >>> rows = [{"scene": "ramp", "light": "rect", "method": name, **metrics.summary(vis, ref), "seconds": seconds,
    ...          "error": None} for name, vis, seconds in [("ray_traced", ref, 2.0), ("shadow_map", 1.0 * (ref > 0.5), 0.1)]]
    >>> print(evaluation.latex_table(pd.DataFrame(rows)))  # doctest: +NORMALIZE_WHITESPACE
    \begin{tabular}{lllrrrrrrrr}
    \toprule
    scene & light & method & RMSE & PSNR (dB) & SSIM & FLIP & RMSE umbra & RMSE penumbra & RMSE lit & seconds \\
    \midrule
    ramp & rect & \bfseries ray\_traced & 0.0000 & $\infty$ & 1.0000 & 0.0000 & 0.0000 & 0.0000 & 0.0000 & 2.000 \\
    ramp & rect & \bfseries shadow\_map & ... \\
    \bottomrule
    \end{tabular}
    """
    require("jinja2", extra="evaluation", for_="softshadows.evaluation.latex_table")  # pandas' Styler.to_latex
    _columns(frame, _REPORT_COLUMNS)
    frame = _with_pareto(frame)
    headings = {column: heading for column, heading, _ in _TABLE_COLUMNS}
    table = frame[["scene", "light", "method", *headings]].rename(columns=headings).reset_index(drop=True)
    formats = {heading: _latex_formatter(digits) for column, heading, digits in _TABLE_COLUMNS}
    bold = ["font-weight: bold;" if front else "" for front in frame["pareto"]]
    styler = (table.style.format(formats, na_rep="--", escape="latex").format_index(escape="latex", axis=1)
              .apply(lambda _: bold, subset=["method"]).hide(axis="index"))
    return styler.to_latex(hrules=True, convert_css=True, column_format="lll" + "r" * len(_TABLE_COLUMNS)).rstrip("\n")


def _latex_formatter(digits: int):
    """A cell formatter with ``digits`` decimals, and the exact result's infinite PSNR as a symbol."""
    return lambda x: r"$\infty$" if x == np.inf else f"{x:.{digits}f}"


def _number(value, digits: int) -> str:
    """A Markdown cell: ``digits`` decimals, a dash for NaN (a region without pixels)."""
    return "-" if np.isnan(value) else f"{value:.{digits}f}"


def _with_pareto(frame):
    """``frame`` with a ``pareto`` column: on the time-versus-RMSE front of its scene and light."""
    pd = require("pandas", extra="evaluation", for_="softshadows.evaluation")

    fronts = [pareto_front(group) for _, group in frame.groupby(["scene", "light"], sort=False)]
    return frame.assign(pareto=pd.concat(fronts).reindex(frame.index))


def _rmse_of(group, method: str) -> float:
    """The RMSE of one method's row in a scene and light's rows."""
    return float(group.loc[group["method"] == method, "rmse"].iloc[0])


#: The markers around the results table in the README, which :func:`update_readme` rewrites.
README_MARKERS = ("<!-- evaluation:start -->", "<!-- evaluation:end -->")


def results_table(frame) -> str:
    """A Markdown table of each method's RMSE, SSIM and seconds, one column group per scene and
    light (refusals as a dash).

    Examples
    --------
    >>> import pandas as pd
    >>> from softshadows import evaluation
    >>> frame = pd.DataFrame({"scene": ["columns", "columns"], "light": ["rect", "rect"], "method": ["ray_traced", "pcss"],
    ...                       "rmse": [0.0101, 0.0301], "ssim": [0.993, 0.969], "seconds": [0.013, 0.010]})
    >>> print(evaluation.results_table(frame))
    | method | columns / rect: RMSE, SSIM, s |
    |---|---|
    | ray_traced | 0.0101, 0.993, 0.013 |
    | pcss | 0.0301, 0.969, 0.010 |
    """
    _columns(frame, ("scene", "light", "method", "rmse", "ssim", "seconds"))
    groups = list(frame.groupby(["scene", "light"], sort=False))
    head = "| method | " + " | ".join(f"{s} / {k}: RMSE, SSIM, s" for (s, k), _ in groups) + " |"
    lines = [head, "|---|" + "---|" * len(groups)]
    for method in dict.fromkeys(frame["method"]):
        cells = []
        for _, group in groups:
            r = group[group["method"] == method]
            ok = len(r) and np.isfinite(r["rmse"].iloc[0])
            cells.append(f"{r['rmse'].iloc[0]:.4f}, {r['ssim'].iloc[0]:.3f}, {r['seconds'].iloc[0]:.3f}" if ok else "-")
        lines.append(f"| {method} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def update_readme(frame, path) -> None:
    """Replaces the block between :data:`README_MARKERS` in the file ``path`` with
    :func:`results_table` and the setup it was measured on.

    Examples
    --------
    >>> import os, tempfile
    >>> import pandas as pd
    >>> from softshadows import evaluation
    >>> frame = pd.DataFrame({"scene": ["columns"], "light": ["rect"], "method": ["pcss"], "rmse": [0.0301],
    ...                       "ssim": [0.969], "seconds": [0.010]})
    >>> folder = tempfile.TemporaryDirectory()
    >>> path = os.path.join(folder.name, "README.md")
    >>> start, end = evaluation.README_MARKERS
    >>> with open(path, "w") as f:
    ...     _ = f.write(os.linesep.join(["# Results", start, end, ""]))
    >>> evaluation.update_readme(frame, path)
    >>> print(open(path).read().splitlines()[4])
    | pcss | 0.0301, 0.969, 0.010 |
    """
    _columns(frame, ("scene", "light", "method", "rmse", "ssim", "seconds"))
    try:
        path = Path(path)
    except TypeError:
        raise TypeError(f"path: expected a str or os.PathLike, got {type(path).__name__}") from None
    text = path.read_text()
    start, end = README_MARKERS
    if start not in text or end not in text:
        raise ValueError(f"path: {path} has no {start} ... {end} block to fill")
    setup = frame.attrs.get("setup", {})
    note = (f"*{setup.get('size')}x{setup.get('size')} receivers, {setup.get('samples')} light samples, against "
            f"{setup.get('reference')}; written by `softshadows evaluate --readme`.*") if setup else ""
    block = f"{start}\n{results_table(frame)}\n\n{note}\n{end}"
    head, rest = text.split(start, 1)
    path.write_text(head + block + rest.split(end, 1)[1])


def _names(name: str, values, allowed) -> list:
    """A list of names from ``allowed``; a bare string is refused (it would iterate as letters)."""
    if isinstance(values, (str, bytes)) or not hasattr(values, "__iter__"):
        raise ValueError(f"{name}: expected a sequence of names from {list(allowed)}, got {values!r}")
    values = list(values)
    unknown = [x for x in values if not isinstance(x, str) or x not in allowed]
    if unknown:
        raise ValueError(f"{name}: unknown {unknown}; expected names from {list(allowed)}")
    return values


def _options(options, methods) -> dict:
    """``{method name: {keyword: value}}``, checked for its shape (the methods check the values)."""
    if options is None:
        return {}
    if not isinstance(options, dict):
        raise ValueError(f"options: expected a dict of method name to a dict of keyword options, got {options!r}")
    _names("options", list(options), methods)
    bad = {k: o for k, o in options.items() if not isinstance(o, dict) or not all(isinstance(key, str) for key in o)}
    if bad:
        raise ValueError(f"options: each method's options must be a dict of keyword to value, got {bad!r}")
    return dict(options)


def _columns(frame, columns) -> None:
    """A pandas DataFrame with ``columns``, or a ValueError naming the missing ones."""
    pd = require("pandas", extra="evaluation", for_="softshadows.evaluation")

    if not isinstance(frame, pd.DataFrame):
        raise ValueError(f"frame: expected a pandas.DataFrame from evaluate() or sweep(), got {type(frame).__name__}")
    missing = [c for c in columns if c not in frame.columns]
    if missing:
        raise ValueError(f"frame: missing columns {missing}; expected the columns of evaluate()")

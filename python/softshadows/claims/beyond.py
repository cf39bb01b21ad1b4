"""Beyond the papers: where today's baseline sits among the five papers' methods, still and over
time.

The five papers predate what engines ship for soft shadows today: a few stochastic shadow rays
per pixel and a spatio-temporal denoiser (``softshadows.denoised``, after Boksansky, Wimmer and
Bittner 2019 and Schied et al. 2017), which ray-tracing hardware made affordable a decade after
them. None of them could ask where it stands among their methods; the evaluation can, on the same
scenes and against the same references. Each claim here is a hypothesis a reader of the papers
would hold, measured and judged as the papers' claims are. The competitors are every built-in
method but the oracle: the papers' methods and the baselines they measured themselves against
(``shadow_map``, ``pcss``, ``mvr``), each at its default settings, the sample-based ones on the
evaluation's shared light samples.

What a CPU timing says and does not. Every second here is this package's CPU implementation on
the machine of the run, measured side by side in one run: the papers' methods are CPU ports of
GPU algorithms (software rasterization of depth maps, per-texel lists), and the baseline's rays
run through a CPU BVH where engines have ray-tracing hardware. The time axis ranks these
implementations on this CPU; it does not predict a GPU frame time, where rasterization and ray
tracing each have hardware of their own and the ratios change (the last claim says so, and why it
is not measured here). The error axis carries over: the same visibility against the same
reference, whatever runs it.

References
----------
.. [1] J. Boksansky, M. Wimmer and J. Bittner, "Ray Traced Shadows: Maintaining Real-Time Frame
   Rates", Ray Tracing Gems, 2019.
.. [2] C. Schied, A. Kaplanyan, C. Wyman, A. Patney, C. R. A. Chaitanya, J. Burgess, S. Liu,
   C. Dachsbacher, A. Lefohn and M. Salvi, "Spatiotemporal Variance-Guided Filtering: Real-Time
   Reconstruction for Path-Traced Global Illumination", High-Performance Graphics, 2017.
"""

from __future__ import annotations

import functools

import numpy as np

from .ledger import TIMING, AtLeast, AtMost, Measured, NotMeasurable, Tier, claim

#: The baseline, and the method left out of the competitors (the oracle is no real-time method).
BASELINE, ORACLE = "denoised", "ray_traced"
#: Where the baseline comes from, for the ledger's "where" column.
PRACTICE = "Today's practice (Boksansky, Wimmer and Bittner 2019; Schied et al. 2017)"
#: The light's turn over a sequence, in degrees, and the entries that run over time beside the
#: papers' methods: Sintorn et al. 2008's own temporal jitter with accumulation (section 4.3), and
#: the baseline with its temporal stage, as engines run it.
TURN = 30.0
OVER_TIME = {"alias_free+jitter+accumulate": ("alias_free", {"accumulate": True}), BASELINE: (BASELINE, {"history": True})}
#: Values that rest on which method was faster (the front, the shares): the machine's load moves them.
_CLOCKED = {key: TIMING for key in ("front_share", "faster_share", "dominated_share", "cpu_seconds_ratio")}


def _settings(tier) -> dict:
    """Scenes and sizes: two scenes at 64² in the fast tier; every built-in scene at the
    evaluation's defaults (128², 64 samples, 4096 reference samples) in the paper tier."""
    import softshadows as ss

    return tier.pick(
        dict(scenes=("columns", "fence"), size=64, samples=32, reference_samples=512, repeat=2,
             sequences=("columns",), frames=8, sequence_size=48),
        dict(scenes=tuple(ss.scenes.SCENES), size=128, samples=64, reference_samples=4096, repeat=3,
             sequences=("columns", "fence", "torus_knot"), frames=24, sequence_size=96),
    )


def _front_values(groups) -> dict:
    """Where the baseline sits in each group of rows (one scene, or one sequence): on the
    seconds-versus-RMSE front or not, the share of competitors slower than it and of those it
    dominates (slower and less accurate), and its RMSE over the best competitor's."""
    from softshadows import evaluation

    on_front, faster, dominated, ratio = [], [], [], []
    for rows in groups:
        rows = rows[rows["method"] != ORACLE].dropna(subset=["seconds", "rmse"]).reset_index(drop=True)
        mine = rows[rows["method"] == BASELINE].iloc[0]
        others = rows[rows["method"] != BASELINE]
        on_front.append(bool(evaluation.pareto_front(rows)[rows["method"] == BASELINE].iloc[0]))
        faster.append(float(np.mean(others["seconds"] > mine["seconds"])))
        dominated.append(float(np.mean((others["seconds"] >= mine["seconds"]) & (others["rmse"] >= mine["rmse"]))))
        ratio.append(float(mine["rmse"] / others["rmse"].min()))
    return {"front_share": float(np.mean(on_front)), "faster_share": float(np.mean(faster)),
            "dominated_share": float(np.mean(dominated)), "rmse_ratio": float(np.median(ratio)), "groups": float(len(ratio))}


def _pareto_figure(groups, title: str, x: str = "seconds"):
    """One panel per scene: every competitor at its seconds and RMSE, the front dashed, the
    baseline in red."""
    from matplotlib.figure import Figure

    from softshadows import evaluation

    figure = Figure(figsize=(3.2 * len(groups), 3.0), layout="constrained")
    for ax, (name, rows) in zip(figure.subplots(1, len(groups), squeeze=False)[0], groups.items()):
        rows = rows[rows["method"] != ORACLE].dropna(subset=[x, "rmse"]).reset_index(drop=True)
        front = rows[evaluation.pareto_front(rows, x=x)].sort_values(x)
        ax.plot(front[x], front["rmse"], "--", lw=1, color="0.5")
        for _, r in rows.iterrows():
            mine = r["method"] == BASELINE
            ax.scatter(r[x], r["rmse"], s=30 if mine else 12, color="tab:red" if mine else "0.3", zorder=3)
            ax.annotate(r["method"], (r[x], r["rmse"]), fontsize=5, xytext=(2, 2), textcoords="offset points")
        ax.set(xscale="log", title=name, xlabel=f"{x} (CPU)", ylabel="RMSE")
        ax.title.set_fontsize(8)
    figure.suptitle(title, fontsize=9)
    return figure


@functools.lru_cache(maxsize=2)
def _still(tier_name: str):
    """Every built-in method on every scene of the tier, under its rect light: evaluate's rows."""
    import softshadows as ss

    s = _settings(Tier(tier_name))
    return ss.evaluate(s["scenes"], size=s["size"], samples=s["samples"], reference_samples=s["reference_samples"],
                       repeat=s["repeat"], progress=False)


@functools.lru_cache(maxsize=2)
def _over_time(tier_name: str):
    """Every built-in method, alias_free jittered and accumulated and the baseline with its
    history, frame by frame under a light turning about the occluders: evaluate_sequence's rows."""
    import softshadows as ss
    from softshadows.evaluation import OverTime

    s = _settings(Tier(tier_name))
    turning = [ss.sequence(ss.scenes.get(name), frames=s["frames"], light_path=ss.scenes.Orbit(TURN)) for name in s["sequences"]]
    plain = {name: name for name in ss.METHODS if name != BASELINE}
    entries = {**plain, **{label: OverTime(method, **options) for label, (method, options) in OVER_TIME.items()}}
    return ss.evaluate_sequence(turning, entries, size=s["sequence_size"], samples=s["samples"],
                                reference_samples=s["reference_samples"], progress=False)


def _front_claim(tier, groups: dict, title: str, note: str) -> Measured:
    """The baseline's place on each group's time-versus-RMSE chart (a scene, or a sequence)."""
    figure = _pareto_figure(groups, title) if tier.figures else None
    return Measured(_front_values(groups.values()), figure=figure, note=f"{note} {_HONEST}")


def _turning_note(s) -> str:
    return (f"{', '.join(s['sequences'])}: the rect light turns {TURN:g}° about the occluders over {s['frames']} frames, "
            f"{s['sequence_size']}² receivers")


_HONEST = ("Seconds are CPU seconds of this package's implementations, side by side in one run: they rank "
           "implementations on this CPU, not GPU frame times (see the module's note).")


@claim(
    "beyond.denoised_on_the_still_front",
    where=PRACTICE,
    statement="A denoised ray tracer with one shadow ray per pixel, the soft-shadow baseline of today's engines, is on the "
              "time-versus-error Pareto front of every scene against the five papers' methods.",
    paper_value="a hypothesis (the papers predate it): on the front of every scene",
    rule=AtLeast("front_share", 1.0, in_kind=0.5),
    ours="on the front of {front_share:.0%} of {groups:.0f} scenes; faster than {faster_share:.0%} of the methods, "
         "dominates {dominated_share:.0%}; RMSE {rmse_ratio:.1f}x the most accurate method's (median)",
    tolerance=_CLOCKED,
)
def _on_the_still_front(tier):
    """The baseline's place on each scene's time-versus-RMSE chart."""
    s = _settings(tier)
    return _front_claim(tier, dict(tuple(_still(tier.name).groupby("scene", sort=False))),
                        "one frame: denoised (red) among the papers' methods",
                        f"{len(s['scenes'])} scenes ({', '.join(s['scenes'])}) under their rect light, {s['size']}² receivers, "
                        f"{s['samples']} shared light samples, reference: Mitsuba ray_test on {s['reference_samples']} Sobol "
                        f"samples; seconds: the fastest of {s['repeat']} runs.")


@claim(
    "beyond.denoised_on_the_front_over_time",
    where=PRACTICE,
    statement="Under a moving light, the denoised baseline with its temporal stage stays on the time-versus-error front "
              "against the papers' methods, Sintorn et al. 2008's temporal jitter with accumulation among them.",
    paper_value="a hypothesis (the papers predate it): on the front of every sequence",
    rule=AtLeast("front_share", 1.0, in_kind=0.5),
    ours="on the front of {front_share:.0%} of {groups:.0f} sequences; faster than {faster_share:.0%} of the entries, "
         "dominates {dominated_share:.0%}; mean RMSE {rmse_ratio:.1f}x the most accurate entry's (median)",
    tolerance=_CLOCKED,
)
def _on_the_front_over_time(tier):
    """The baseline's place on each sequence's chart of seconds per frame against mean RMSE."""
    s = _settings(tier)
    return _front_claim(tier, dict(tuple(_over_time(tier.name).groupby("sequence", sort=False))),
                        "over time: denoised with its history (red), seconds per frame",
                        f"{_turning_note(s)}, {s['samples']} shared light samples, each frame against Mitsuba ray_test on "
                        f"{s['reference_samples']} Sobol samples; mean RMSE and seconds per frame over the frames.")


@claim(
    "beyond.denoised_flickers_least",
    where=PRACTICE,
    statement="Under a moving light, the denoised baseline with its temporal stage flickers no more than the papers' "
              "methods do.",
    paper_value="a hypothesis: flicker at most the steadiest method's",
    rule=AtMost("flicker_ratio", 1.0, in_kind=2.0),
    ours="flicker {flicker:.4f}, {flicker_ratio:.1f}x the steadiest entry's; temporal std {temporal_std:.4f}",
)
def _flickers_least(tier):
    """The baseline's flicker (metrics.flicker) against the steadiest competitor's, per sequence."""
    s = _settings(tier)
    summary = _over_time(tier.name)
    ratios, mine, steadiest = [], [], []
    for _, rows in summary.groupby("sequence", sort=False):
        rows = rows[rows["method"] != ORACLE].dropna(subset=["temporal.flicker"]).set_index("method")
        others = rows.drop(index=BASELINE)["temporal.flicker"]
        ratios.append(rows.loc[BASELINE, "temporal.flicker"] / others.min())
        mine.append(rows.loc[BASELINE, ["temporal.flicker", "temporal.std"]].to_numpy(float))
        steadiest.append(others.idxmin())
    values = {"flicker_ratio": float(np.median(ratios)), "flicker": float(np.mean([m[0] for m in mine])),
              "temporal_std": float(np.mean([m[1] for m in mine]))}
    note = (f"{_turning_note(s)}; flicker: the mean change of a pixel from frame to frame against the "
            f"reference's own change; the steadiest entries: {', '.join(steadiest)}.")
    return Measured(values, note=note)


@claim(
    "beyond.denoised_fastest_on_a_gpu",
    where=PRACTICE,
    statement="On a GPU with ray-tracing hardware, the denoised baseline renders a frame faster than the papers' methods "
              "at the same error.",
    paper_value="a hypothesis: engines ship it because it is",
    rule=NotMeasurable("this package traces rays on the CPU only (ray_traced and denoised have no GPU backend) and the "
                       "machine has no ray-tracing hardware; CPU seconds rank CPU implementations and do not predict it"),
    ours="on this CPU: {cpu_seconds_ratio:.2f}x pcss's seconds (median over the scenes)",
    tolerance=_CLOCKED,
)
def _fastest_on_a_gpu(tier):
    """What can be measured: the baseline's CPU seconds over pcss's, the cheapest soft filter."""
    frame = _still(tier.name).set_index(["scene", "method"])["seconds"]
    ratios = [frame[(scene, BASELINE)] / frame[(scene, "pcss")] for scene in dict.fromkeys(s for s, _ in frame.index)]
    return Measured({"cpu_seconds_ratio": float(np.median(ratios))},
                    note="pcss filters one depth map per frame, as GPUs do in fixed-function hardware; denoised traces a "
                         "ray per pixel, which ray-tracing hardware accelerates and a CPU BVH does not.")

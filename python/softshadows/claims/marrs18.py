"""Claims of Marrs, Watson and Healey 2018, "View-warped Multi-view Soft Shadows for Local Area
Lights" (Journal of Computer Graphics Techniques 7(3)).

View-warped soft shadows (``vwss``) rasterize the occluders once into a multi-view point cloud and
warp it into every light sample's depth map; multi-view rasterization (``mvr``) rasterizes every
triangle into every map; ``pcss`` is the single-view approximation both are compared with. The
paper's experiments use 1024² depth maps, 5-tap PCF per map, Poisson light samples shared by MVR
and VWSS, and PCSS with 64 blocker-search and 96 filter taps; these settings are passed
explicitly below (the fast tier shrinks the maps to 512² where its notes say so). Its times are a GTX Titan X's, ours a CPU's: only ratios measured side by side
carry over, and our CPU rasterizer is far slower per triangle than a GPU's.
"""

from __future__ import annotations

import functools
import math
import time

import numpy as np

from ._measure import reference, rmse, staged
from .ledger import TIMING, WALL_CLOCK, AllOf, AtLeast, AtMost, Between, Measured, NotMeasurable, claim

#: The paper's depth-map side (section 4).
PAPER_MAPS = 1024
#: Light samples of Table 1 and Table 2.
TABLE_VIEWS = (24, 128)
#: The paper's shadow test: the texel and its four neighbours (5 taps) on every map.
PCF_TAPS = 5
#: The paper's PCSS ("Ultra" preset): 64 blocker-search and 96 filter taps.
PCSS_TAPS = dict(blocker_samples=64, filter_samples=96)
#: The paper's traversal: buffered, partially parallel, 8 maps per traversal (Listing 2).
PAPER_VWSS = dict(mode="buffered", parallel="partial", views_per_pass=8, cull_backfaces=True, layered=True,
                  precision="float32")


# ----------------------------------------------------------------------------------------------
# Shared helpers
# ----------------------------------------------------------------------------------------------

@functools.lru_cache(maxsize=8)
def _knot(triangles: int, size: int):
    """A (2, 3) torus knot of about ``triangles`` triangles (tube : radial segments 12 : 1) over the
    ground, with its G-buffer: the Tables' scenes of growing geometric complexity."""
    import softshadows as ss

    radial = max(3, round(math.sqrt(triangles / 24)))
    tube = max(3, round(triangles / (2 * radial)))
    setup = ss.scenes.torus_knot(tube_segments=tube, radial_segments=radial, width=size, height=size)
    return setup, ss.gbuffer(setup.scene, setup.camera)


def _casters(setup):
    """Only the occluders go into the depth maps, as in the paper (section 3.1): the ground receives."""
    return [m.name for m in setup.occluders]


def _views(light, n: int):
    """``n`` Poisson light samples, shared by every multi-view method (section 4)."""
    return light.samples(n, pattern="poisson", seed=0)


def _fastest(run, stages, *, repeat: int = 5, budget: float = 1.5):
    """The least total of the ``stages`` seconds over up to ``repeat`` runs of ``run()`` (which
    returns ``(visibility, stats)``), stopping once the runs took ``budget`` seconds: sub-second
    work is repeated, multi-second work is not. Returns (seconds, visibility, stats)."""
    best, spent = None, 0.0
    for _ in range(repeat):
        start = time.perf_counter()
        vis, stats = run()
        spent += time.perf_counter() - start
        seconds = sum(stats[f"{s}_seconds"] for s in stages)
        if best is None or seconds < best[0]:
            best = (seconds, vis, stats)
        if spent > budget:
            break
    return best


def _mvr(setup, gb, views, resolution, *, casters=None, **options):
    """``mvr`` with the paper's PCF, the occluders in the maps unless ``casters`` says otherwise."""
    import softshadows as ss

    return ss.mvr(setup.scene, setup.light, gb, samples=views, resolution=resolution, pcf=PCF_TAPS,
                  casters=casters or _casters(setup), return_stats=True, **options)


def _vwss(setup, gb, views, resolution, *, casters=None, **options):
    """``vwss`` with the paper's PCF and traversal, ``options`` overriding them."""
    import softshadows as ss

    return ss.vwss(setup.scene, setup.light, gb, samples=views, resolution=resolution, pcf=PCF_TAPS,
                   casters=casters or _casters(setup), return_stats=True, **{**PAPER_VWSS, **options})


def _pcss(setup, gb, resolution, *, casters=None, **options):
    """``pcss`` with the paper's 64 blocker-search and 96 filter taps."""
    import softshadows as ss

    return ss.pcss(setup.scene, setup.light, gb, resolution=resolution, casters=casters or _casters(setup),
                   return_stats=True, **PCSS_TAPS, **options)


#: Stages of Tables 1-2 after the G-buffer (which every method shares): the depth maps (VWSS's
#: point generation included, as in the paper's "x faster depth" column) and PCSS's whole frame.
MVR_DEPTH, VWSS_DEPTH, PCSS_TOTAL = ("depth_maps",), ("point_generation", "depth_maps"), ("depth_map", "lighting")


def _shadow(vis, mask) -> float:
    """The shadow's mass: the light missing, summed over the hit pixels."""
    return float(np.sum(1.0 - np.asarray(vis, dtype=np.float64)[mask]))


def _frame_rmse_8bit(vis, ref, mask) -> float:
    """RMSE over the whole frame (missed pixels count as exact) in 8-bit levels: our reading of
    the paper's unstated RMSE unit."""
    err = np.where(mask, np.asarray(vis, dtype=np.float64) - ref, 0.0)
    return float(255.0 * np.sqrt(np.mean(err**2)))


def _figure():
    """A small figure that leaves the user's matplotlib backend alone."""
    from matplotlib.figure import Figure

    return Figure(figsize=(5, 3.2))


def _image_row(title: str, mask, shown: dict, differences: dict):
    """Panels of visibility images (``shown``) then of signed differences (red: lighter)."""
    from matplotlib.figure import Figure

    panels = [(name, img, "gray", 0.0, 1.0) for name, img in shown.items()]
    panels += [(name, img, "RdBu_r", -0.5, 0.5) for name, img in differences.items()]
    fig = Figure(figsize=(2.2 * len(panels), 2.6))
    for ax, (name, img, cmap, lo, hi) in zip(fig.subplots(1, len(panels), squeeze=False)[0], panels):
        ax.imshow(np.where(mask, img, np.nan), cmap=cmap, vmin=lo, vmax=hi)
        ax.set_title(name, fontsize=8)
        ax.set_axis_off()
    fig.suptitle(title, fontsize=9)
    return fig


# ----------------------------------------------------------------------------------------------
# Tables 1-2 and Figure 12: MVR, VWSS and PCSS side by side on knots of growing complexity
# ----------------------------------------------------------------------------------------------

def _table_sizes(tier):
    """(knots in triangles, receivers side, map side, triangle counts run at 128 views)."""
    return tier.pick(
        # Small knots and 512² maps keep the fast tier's ratios far from the paper's bounds.
        ((10_000, 50_000, 100_000), 64, 512, (10_000, 50_000)),
        # The paper's four scenes' triangle counts (Challenger, Volund, Warriors, Cliffside).
        ((90_007, 240_186, 510_523, 672_927), 256, PAPER_MAPS, (90_007, 240_186, 510_523, 672_927)),
    )


@functools.lru_cache(maxsize=2)
def _tables(tier_name: str):
    """One row per (knot, views): stage seconds and RMSE of mvr, vwss and pcss on shared samples."""
    from .ledger import Tier

    knots, size, res, at_128 = _table_sizes(Tier(tier_name))
    rows = []
    for triangles in knots:
        setup, gb = _knot(triangles, size)
        ref = reference(setup, gb)
        mask = gb.mask
        t_pcss, v_pcss, s_pcss = _fastest(lambda: _pcss(setup, gb, res), PCSS_TOTAL)
        for views in TABLE_VIEWS:
            if views != TABLE_VIEWS[0] and triangles not in at_128:
                continue
            samples = _views(setup.light, views)
            t_mvr, v_mvr, s_mvr = _fastest(lambda: _mvr(setup, gb, samples, res), MVR_DEPTH)
            t_vw, v_vw, s_vw = _fastest(lambda: _vwss(setup, gb, samples, res), VWSS_DEPTH)
            rows.append({
                "triangles": setup.occluders[0].faces.shape[0], "views": views, "points": s_vw["points"],
                "mvr_depth": t_mvr, "vwss_depth": t_vw,
                "mvr_total": t_mvr + s_mvr["lighting_seconds"], "vwss_total": t_vw + s_vw["lighting_seconds"],
                "pcss_total": t_pcss,
                "rmse_mvr": rmse(v_mvr, ref, mask), "rmse_vwss": rmse(v_vw, ref, mask),
                "rmse_pcss": rmse(v_pcss, ref, mask), "rmse_vwss_mvr": rmse(v_vw, v_mvr, mask),
                "rmse_vwss_8bit": _frame_rmse_8bit(v_vw, ref, mask),
                "rmse_mvr_8bit": _frame_rmse_8bit(v_mvr, ref, mask),
            })
    return rows, size, res


def _table_rows(tier, views: int):
    """The rows of Table 1 (24 views) or Table 2 (128), with the receivers' and maps' sides."""
    rows, size, res = _tables(tier.name)
    return [r for r in rows if r["views"] == views], size, res


def _table_note(size, res, extra: str = "") -> str:
    """The set-up of the Tables' runs, then ``extra``."""
    return (f"Torus knots over the ground, only the knot rendered into the depth maps; {size}² receivers, "
            f"{res}² maps, {PCF_TAPS}-tap PCF, shared Poisson samples; vwss buffered, partially parallel, "
            f"8 maps per traversal; times are CPU stage seconds (the least of up to 5 runs), depth maps "
            f"including vwss's point generation as the paper's 'x faster depth' column does. {extra}").strip()


def _speedups(tier, views: int):
    """Depth-map and total speed-ups of vwss over mvr at the smallest and largest knot."""
    rows, size, res = _table_rows(tier, views)
    small, large = rows[0], rows[-1]
    values = {
        "speedup_smallest": small["mvr_depth"] / small["vwss_depth"],
        "speedup_largest": large["mvr_depth"] / large["vwss_depth"],
        "total_speedup_largest": large["mvr_total"] / large["vwss_total"],
        "triangles_smallest": small["triangles"], "triangles_largest": large["triangles"],
        "points_largest": large["points"],
    }
    return values, size, res


_SPEEDUP_TOLERANCE = {k: TIMING for k in ("speedup_smallest", "speedup_largest", "total_speedup_largest")}


@claim(
    "marrs18.depth_maps_faster_24_views",
    where="Section 4.1, Table 1",
    statement="With 24 depth maps of 1024², VWSS renders the multi-view depth maps (point generation "
              "included) about 2-5x faster than multi-view rasterization.",
    paper_value="2.15x-5.04x faster depth maps (90k-673k triangles, GTX Titan X)",
    # The paper's range; our CPU rasterizer's much larger ratio is the direction, not the size.
    rule=AllOf(Between("speedup_smallest", 2.0, 5.1, in_kind=(1.2, math.inf)),
               Between("speedup_largest", 2.0, 5.1, in_kind=(1.2, math.inf))),
    ours="{speedup_smallest:.1f}x ({triangles_smallest:.0f} triangles) to {speedup_largest:.1f}x "
         "({triangles_largest:.0f} triangles)",
    tolerance=_SPEEDUP_TOLERANCE,
)
def _depth_maps_24(tier):
    """Table 1's 'x faster depth' column on knots of growing tessellation."""
    values, size, res = _speedups(tier, 24)
    return Measured(values, note=_table_note(size, res, "The ratio is our CPU rasterizer's: it pays per "
                                                      "triangle and view far more than a GPU, so the speed-up "
                                                      "grows with the triangles well past the paper's."))


@claim(
    "marrs18.depth_maps_faster_128_views",
    where="Section 4.1, Table 2",
    statement="With 128 depth maps of 1024², VWSS renders the depth maps about 4-13x faster than "
              "multi-view rasterization.",
    paper_value="4.38x-12.82x faster depth maps (90k-673k triangles, GTX Titan X)",
    rule=AllOf(Between("speedup_smallest", 4.0, 13.0, in_kind=(1.2, math.inf)),
               Between("speedup_largest", 4.0, 13.0, in_kind=(1.2, math.inf))),
    ours="{speedup_smallest:.1f}x ({triangles_smallest:.0f} triangles) to {speedup_largest:.1f}x "
         "({triangles_largest:.0f} triangles)",
    tolerance=_SPEEDUP_TOLERANCE,
)
def _depth_maps_128(tier):
    """Table 2's 'x faster depth' column."""
    values, size, res = _speedups(tier, 128)
    return Measured(values, note=_table_note(size, res, "The ratio is our CPU rasterizer's (see the 24-view row)."))


@claim(
    "marrs18.total_time_faster",
    where="Section 4.1, Tables 1-2",
    statement="VWSS improves on MVR's total rendering time up to 2.5x with 24 depth maps and up to 3x "
              "with 128.",
    paper_value="total 1.26x-2.48x faster (24 maps), 1.46x-3.37x (128 maps)",
    rule=AllOf(Between("total_speedup_24", 1.2, 2.5, in_kind=(1.05, math.inf)),
               Between("total_speedup_128", 1.4, 3.4, in_kind=(1.05, math.inf))),
    ours="{total_speedup_24:.1f}x (24 maps), {total_speedup_128:.1f}x (128 maps) on {triangles:.0f} triangles",
    tolerance={"total_speedup_24": TIMING, "total_speedup_128": TIMING},
)
def _total_time(tier):
    """Tables 1-2's 'x faster total' column on the largest knot run at both view counts."""
    v24, size, res = _speedups(tier, 24)
    v128, _, _ = _speedups(tier, 128)
    return Measured(
        {"total_speedup_24": v24["total_speedup_largest"], "total_speedup_128": v128["total_speedup_largest"],
         "triangles": v128["triangles_largest"]},
        note=_table_note(size, res, "Total: depth maps and lighting (the G-buffer is shared). The lighting's share "
                                    "follows the receivers' count, so the total ratio is this tier's, not the paper's "
                                    "frame's."),
    )


@claim(
    "marrs18.rmse_close_to_mvr",
    where="Section 4.1, Table 1 (RMSE column)",
    statement="With 24 depth maps VWSS's error against the reference is close to MVR's.",
    paper_value="RMSE 1.316 vs MVR's 1.129 (Cliffside); VWSS 0.72x-1.20x MVR's over the four scenes",
    rule=AtMost("rmse_ratio_worst", 1.25, in_kind=2.0),
    ours="RMSE {rmse_vwss:.4f} vs MVR's {rmse_mvr:.4f} ({rmse_ratio_worst:.2f}x at worst over the knots); "
         "{rmse_vwss_8bit:.2f} vs {rmse_mvr_8bit:.2f} in 8-bit levels over our frame",
)
def _rmse_close(tier):
    """Table 1's RMSE column: vwss's and mvr's error against 1024 ray-traced samples."""
    rows, size, res = _table_rows(tier, 24)
    worst = max(rows, key=lambda r: r["rmse_vwss"] / r["rmse_mvr"])
    first = rows[0]
    return Measured(
        {"rmse_vwss": first["rmse_vwss"], "rmse_mvr": first["rmse_mvr"],
         "rmse_ratio_worst": worst["rmse_vwss"] / worst["rmse_mvr"],
         "rmse_vwss_8bit": first["rmse_vwss_8bit"], "rmse_mvr_8bit": first["rmse_mvr_8bit"],
         "rmse_vwss_vs_mvr_smallest": first["rmse_vwss_mvr"], "rmse_vwss_vs_mvr_largest": rows[-1]["rmse_vwss_mvr"]},
        note=_table_note(size, res,
                         "Reference: 1024 ray-traced Sobol samples (the paper's: MVR with 512 maps and 5-tap PCF); "
                         "RMSE of visibility over the hit pixels, first values on the smallest knot. The paper gives "
                         "no unit; its values (0.26 to 3.6, PCSS's largest) fit 8-bit levels of the whole shaded "
                         "frame, so 1.3 is about 0.005 on a 0-1 scale; our 8-bit frame value counts unlit "
                         "visibility, not shading. The default biases differ: both compare with the receiver's "
                         "tangent plane, but vwss allows 1 texel of its depth gradient where mvr allows 0.5 (a "
                         "warped texel keeps the nearest point anywhere inside it). VWSS's extra error is mostly its "
                         "slight bloat, larger on smaller maps (slight_bloat_shrinks_with_resolution). RMSE of vwss "
                         f"against mvr itself: {first['rmse_vwss_mvr']:.4f} on the smallest knot, "
                         f"{rows[-1]['rmse_vwss_mvr']:.4f} on the largest: it does not grow with the triangles, but "
                         "with the light's size (similar_to_mvr_as_light_grows)."),
    )


@claim(
    "marrs18.more_views_lower_error",
    where="Section 4.1, Table 2",
    statement="128 depth maps lower VWSS's error well below its 24-map error.",
    paper_value="VWSS RMSE 1.32-1.80 (24 maps) to 0.70-1.13 (128 maps): 0.43x-0.86x",
    rule=AtMost("rmse_128_over_24", 0.9, in_kind=1.0),
    ours="{rmse_128_over_24:.2f}x the 24-map RMSE ({rmse_vwss_128:.4f}); MVR's at 128: {rmse_mvr_128:.4f}",
)
def _more_views(tier):
    """Table 2 against Table 1: vwss's RMSE at 128 views over its RMSE at 24 on the same knot."""
    rows24, size, res = _table_rows(tier, 24)
    rows128, _, _ = _table_rows(tier, 128)
    r128 = rows128[0]
    r24 = next(r for r in rows24 if r["triangles"] == r128["triangles"])
    return Measured(
        {"rmse_128_over_24": r128["rmse_vwss"] / r24["rmse_vwss"], "rmse_vwss_128": r128["rmse_vwss"],
         "rmse_vwss_24": r24["rmse_vwss"], "rmse_mvr_128": r128["rmse_mvr"]},
        note=_table_note(size, res, f"{r128['triangles']} triangles; reference: 1024 ray-traced Sobol samples. The "
                                    "paper's VWSS stays 1.7x-4.4x above MVR at 128 maps."),
    )


@claim(
    "marrs18.less_error_than_pcss",
    where="Section 4.1, Table 1",
    statement="With 24 depth maps VWSS's error is well below PCSS's.",
    paper_value="PCSS's RMSE 1.53x-2.46x VWSS's (2.50-3.61 against 1.32-1.80)",
    rule=AtLeast("pcss_over_vwss_rmse", 1.5, in_kind=1.1),
    ours="PCSS's RMSE {pcss_over_vwss_rmse:.2f}x VWSS's ({rmse_pcss:.4f} against {rmse_vwss:.4f})",
)
def _less_error_than_pcss(tier):
    """Table 1's RMSE column, PCSS against VWSS on the largest knot."""
    rows, size, res = _table_rows(tier, 24)
    r = rows[-1]
    return Measured(
        {"pcss_over_vwss_rmse": r["rmse_pcss"] / r["rmse_vwss"], "rmse_pcss": r["rmse_pcss"],
         "rmse_vwss": r["rmse_vwss"]},
        note=_table_note(size, res, f"{r['triangles']} triangles; PCSS: one {res}² map, 64 blocker-search and 96 filter "
                                    "taps; reference: 1024 ray-traced Sobol samples."),
    )


@claim(
    "marrs18.matches_pcss_time",
    where="Section 4.1, Table 1",
    statement="With 24 depth maps VWSS matches PCSS's total rendering time.",
    paper_value="VWSS's total 0.89x-1.07x PCSS's (GTX Titan X)",
    rule=NotMeasurable("an equality of GPU frame times, set by the GPU's balance of rasterization, point "
                       "rendering and lighting; on a CPU that balance is another, and moves with the triangles"),
    ours="VWSS takes {vwss_over_pcss_time:.2f}x PCSS's time ({triangles:.0f} triangles); "
         "{vwss_over_pcss_time_smallest:.2f}x on {triangles_smallest:.0f}",
    tolerance={"vwss_over_pcss_time": TIMING, "vwss_over_pcss_time_smallest": TIMING},
)
def _matches_pcss_time(tier):
    """Table 1's total times, VWSS over PCSS, on the smallest and largest knot."""
    rows, size, res = _table_rows(tier, 24)
    small, large = rows[0], rows[-1]
    return Measured(
        {"vwss_over_pcss_time": large["vwss_total"] / large["pcss_total"],
         "vwss_over_pcss_time_smallest": small["vwss_total"] / small["pcss_total"],
         "triangles": large["triangles"], "triangles_smallest": small["triangles"]},
        note=_table_note(size, res, "Totals: VWSS's point generation, depth maps and lighting; PCSS's depth map and "
                                    "lighting (64 + 96 taps)."),
    )


@claim(
    "marrs18.cost_follows_points_not_triangles",
    where="Section 4.1, Figure 12",
    statement="MVR's depth-map time rises linearly with the triangle count while VWSS's is weakly linked to "
              "the geometry (it follows the number of points).",
    paper_value="MVR 0.86 to 5.15 ms from 90k to 673k triangles; VWSS 0.40 to 1.38 ms, a rise 0.23x MVR's "
                "(with 8.6x the points)",
    # Slope 1 is linear; MVR's fixed cost per map bends it below 1 for small meshes (the paper's own
    # MVR: 0.89). "Weakly linked": VWSS's rise at most the paper's own share of MVR's.
    rule=AllOf(AtLeast("mvr_slope", 0.6, in_kind=0.35), AtMost("vwss_rise_over_mvr_rise", 0.25, in_kind=0.5)),
    ours="MVR's time grows with slope {mvr_slope:.2f} against the triangles (log-log); VWSS's rise is "
         "{vwss_rise_over_mvr_rise:.1%} of MVR's ({points_growth:.2f}x the points)",
    tolerance={"mvr_slope": TIMING, "vwss_rise_over_mvr_rise": TIMING},
)
def _cost_follows_points(tier):
    """Figure 12: MVR's log-log slope against the triangles, and VWSS's rise in seconds over MVR's."""
    rows, size, res = _table_rows(tier, 24)
    small, large = rows[0], rows[-1]
    values = {
        "mvr_slope": math.log(large["mvr_depth"] / small["mvr_depth"])
                     / math.log(large["triangles"] / small["triangles"]),
        "vwss_rise_over_mvr_rise": (large["vwss_depth"] - small["vwss_depth"])
                                   / (large["mvr_depth"] - small["mvr_depth"]),
        "points_growth": large["points"] / small["points"],
    }
    figure = None
    if tier.figures:
        figure = _figure()
        ax = figure.subplots()
        tri = [r["triangles"] for r in rows]
        ax.plot(tri, [r["mvr_depth"] for r in rows], "s-", color="tab:red", label="MVR: depth maps")
        ax.plot(tri, [r["vwss_depth"] for r in rows], "o-", color="tab:blue", label="VWSS: points + depth maps")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("triangles")
        ax.set_ylabel("CPU seconds (24 maps)")
        ax.legend(fontsize=8)
    return Measured(values, figure=figure,
                    note=_table_note(size, res, f"24 maps, knots of {small['triangles']} to {large['triangles']} "
                                                "triangles; the knot's points stay nearly constant as its tessellation "
                                                "grows, so VWSS's rise is its one source rasterization of the "
                                                "triangles, against MVR's one per map."))


# ----------------------------------------------------------------------------------------------
# Section 3: the point cloud (Figures 4 and 6, back faces)
# ----------------------------------------------------------------------------------------------

def _leak_share(vis, peer, mask) -> float:
    """The share of hit pixels lit more than 0.1 above ``peer``."""
    return float(np.mean((np.asarray(vis) - peer)[mask] > 0.1))


@claim(
    "marrs18.layered_points_stop_leaks",
    where="Section 3.1, Figures 4-5",
    statement="Warping only the nearest surface of the source view leaks light at disocclusions; keeping "
              "every front-facing fragment along each source ray eliminates the leaks.",
    paper_value="light leaks with naive warping, eliminated by the layered points (images)",
    rule=AllOf(AtLeast("leak_naive", 0.02), AtMost("leak_layered", 0.005, in_kind=0.02)),
    ours="{leak_naive:.1%} of pixels leak naively, {leak_layered:.2%} with every layer "
         "({points_naive:.0f} vs {points_layered:.0f} points)",
)
def _layered_points(tier):
    """Figure 4 on the hairball: vwss with ``layered=False`` and ``True`` against mvr on the same samples."""
    size, res = tier.pick(64, 256), tier.pick(512, PAPER_MAPS)
    setup, gb = staged("hairball", size)
    samples = _views(setup.light, 24)
    peer = _mvr(setup, gb, samples, res)[0]
    naive, s_naive = _vwss(setup, gb, samples, res, layered=False)
    layered, s_layered = _vwss(setup, gb, samples, res)
    values = {"leak_naive": _leak_share(naive, peer, gb.mask), "leak_layered": _leak_share(layered, peer, gb.mask),
              "points_naive": s_naive["points"], "points_layered": s_layered["points"]}
    figure = None
    if tier.figures:
        figure = _image_row("Figure 4: naive warping leaks light (red), every layer does not", gb.mask, {"MVR": peer},
                            {"naive - MVR": naive - peer, "VWSS - MVR": layered - peer})
    return Measured(values, figure=figure,
                    note=f"Hairball, {size}² receivers, 24 shared Poisson samples, {res}² maps, only the hairball in "
                         "the maps; a leak is a pixel lit more than 0.1 above MVR on the same samples. The source "
                         "view pulled back to contain every light sample (Figure 4's a, c) is always on here.")


@claim(
    "marrs18.source_view_equations",
    where="Section 3.1, equations 1-3, Listing 1",
    statement="Pulling the source view back behind the light (equations 1-2) and raising its resolution by "
              "equation 3 gives the warped depth maps of every light sample a sampling rate like MVR's.",
    paper_value="equations 1-3 (no number); VWSS's RMSE close to MVR's (Table 1)",
    rule=AtMost("rmse_paper_vs_mvr", 0.02, in_kind=0.03),
    ours="as printed: RMSE {rmse_paper_vs_mvr:.4f} against MVR on the same samples, a {side_paper:.0f}² source, "
         "{points_paper:.0f} points; fitted (our default): RMSE {rmse_fitted_vs_mvr:.4f}, {side_fitted:.0f}², "
         "{points_fitted:.0f} points, pull-back {pull_back_fitted_over_paper:.2f}x eq. 1's, depth maps "
         "{seconds_paper_over_fitted:.1f}x faster; eq. 1's pull-back at the fitted side: RMSE "
         "{rmse_paper_pull_back_vs_mvr:.4f}",
    tolerance={"seconds_paper_over_fitted": TIMING, "seconds_paper": WALL_CLOCK, "seconds_fitted": WALL_CLOCK},
)
def _source_view_equations(tier):
    """vwss with ``source_view="paper"`` and ``"fitted"`` against mvr on the Tables' knot."""
    triangles, size, res = tier.pick((10_000, 64, 512), (90_007, 256, PAPER_MAPS))
    setup, gb = _knot(triangles, size)
    samples = _views(setup.light, 24)
    peer = _mvr(setup, gb, samples, res)[0]
    runs = {view: _fastest(lambda: _vwss(setup, gb, samples, res, source_view=view), VWSS_DEPTH, repeat=3)
            for view in ("paper", "fitted")}
    values = {}
    for view, (seconds, vis, stats) in runs.items():
        values.update({f"rmse_{view}_vs_mvr": rmse(vis, peer, gb.mask), f"side_{view}": stats["source_resolution"],
                       f"points_{view}": stats["points"], f"pull_back_{view}": stats["pull_back"],
                       f"seconds_{view}": seconds})
    # Eq. 1's pull-back at the fitted side: what the pull-back alone changes, apart from eq. 3's z_n.
    values["rmse_paper_pull_back_vs_mvr"] = rmse(
        _vwss(setup, gb, samples, res, source_view="paper", source_resolution=int(values["side_fitted"]))[0],
        peer, gb.mask)
    values["pull_back_fitted_over_paper"] = values["pull_back_fitted"] / values["pull_back_paper"]
    values["seconds_paper_over_fitted"] = values["seconds_paper"] / values["seconds_fitted"]
    return Measured(values, note=(
        f"Torus knot of {setup.occluders[0].faces.shape[0]} triangles, only the knot in the maps; {size}² receivers, "
        f"{res}² maps, 24 shared Poisson samples, the same depth bias for both methods. As printed: d from the "
        "light's side (eq. 1), z_n the light views' near plane (Listing 1's nearZ), one point per texel; our views' "
        "near plane lies at 1/1000 of the receivers' depth, so eq. 3 asks for ~1000x the side and the cap of 8x "
        "decides: dozens of points per texel, which bloat the shadows as conservative rasterization would "
        "(Figure 6). Fitted: d just holds the actual samples, z_n the nearest occluder's depth, two points per "
        "texel there. The verdict reads the equations as printed."))


def _shadow_excess(vis, peer, mask) -> float:
    """How much larger ``vis``'s shadow is than ``peer``'s (0.02: 2% more shadow)."""
    return _shadow(vis, mask) / _shadow(peer, mask) - 1.0


@claim(
    "marrs18.slight_bloat_shrinks_with_resolution",
    where="Section 3.2, Figure 6",
    statement="Point-rendered depth maps bloat the shadows very slightly against MVR's, and the bloat "
              "shrinks as the depth maps' resolution grows.",
    paper_value="'very slight bloating', decreasing with depth-map resolution (no number)",
    rule=AllOf(Between("bloat_1024", 0.0, 0.05, in_kind=(-0.02, 0.15)),
               AtMost("bloat_1024_over_256", 0.6, in_kind=0.9)),
    ours="{bloat_256:+.1%} shadow at 256², {bloat_512:+.1%} at 512², {bloat_1024:+.1%} at 1024²; at 512² by "
         "points per texel 1 / 2 / 4: {bloat_density_1:+.1%} / {bloat_density_2:+.1%} / {bloat_density_4:+.1%}",
)
def _bloat(tier):
    """Figure 6: the extra shadow of vwss over mvr by map resolution, and by point density at 512²."""
    size = tier.pick(64, 256)
    setup, gb = staged("torus_knot", size)
    samples = _views(setup.light, 24)
    values, peers = {}, {}
    for res in (256, 512, PAPER_MAPS):
        peers[res] = _mvr(setup, gb, samples, res)[0]
        vis = _vwss(setup, gb, samples, res, point_density=2.0)[0]
        values[f"bloat_{res}"] = _shadow_excess(vis, peers[res], gb.mask)
    for density in (1.0, 2.0, 4.0):
        vis = _vwss(setup, gb, samples, 512, point_density=density)[0]
        values[f"bloat_density_{density:g}"] = _shadow_excess(vis, peers[512], gb.mask)
    values["bloat_1024_over_256"] = values["bloat_1024"] / values["bloat_256"]
    figure = None
    if tier.figures:
        from matplotlib.figure import Figure

        figure = Figure(figsize=(7, 3))
        by_side, by_density = figure.subplots(1, 2, sharey=True)
        by_side.plot([256, 512, PAPER_MAPS], [100 * values[f"bloat_{r}"] for r in (256, 512, PAPER_MAPS)], "o-")
        by_side.set_xscale("log", base=2)
        by_side.set_xlabel("depth-map side (2 points per texel)")
        by_side.set_ylabel("VWSS shadow over MVR's (%)")
        by_density.plot([1, 2, 4], [100 * values[f"bloat_density_{d}"] for d in (1, 2, 4)], "o-")
        by_density.set_xscale("log", base=2)
        by_density.set_xlabel("points per target texel (512² maps)")
        for ax in (by_side, by_density):
            ax.axhline(0, color="gray", lw=0.5)
        figure.suptitle("Figure 6: VWSS's bloat against MVR", fontsize=9)
    return Measured(values, figure=figure,
                    note=f"Torus knot (6144 triangles), {size}² receivers, 24 shared Poisson samples, only the knot in "
                         "the maps. Bloat: VWSS's shadow mass (light missing, summed over the hit pixels) over MVR's, "
                         "less 1. The resolution series uses our default 2 points per target texel at the nearest "
                         "occluder; at 1, equation 3's own rate, the warped maps have holes and VWSS's shadow comes "
                         "out lighter than MVR's instead, and more points per texel bloat more (the paper's "
                         "'mildly oversampled' points).")


@claim(
    "marrs18.back_faces_not_worth_it",
    where="Section 3.1",
    statement="Keeping back-facing fragments too doubles the points for an improvement in depth-map accuracy "
              "that is not worth the cost.",
    paper_value="'a doubling of the point count', accuracy gain not worth it (no number)",
    rule=AllOf(Between("points_ratio", 1.8, 2.2, in_kind=(1.3, 3.0)), AtLeast("rmse_both_over_culled", 0.9)),
    ours="{points_ratio:.2f}x the points, {rmse_both_over_culled:.2f}x the RMSE against MVR, "
         "{time_ratio:.2f}x the depth-map time",
    tolerance={"time_ratio": TIMING},
)
def _back_faces(tier):
    """``cull_backfaces`` off against on: points, agreement with mvr's maps, and time."""
    size, res = tier.pick(64, 256), PAPER_MAPS
    setup, gb = staged("torus_knot", size)
    samples = _views(setup.light, 24)
    peer = _mvr(setup, gb, samples, res)[0]
    t_culled, culled, s_culled = _fastest(lambda: _vwss(setup, gb, samples, res), VWSS_DEPTH)
    t_both, both, s_both = _fastest(lambda: _vwss(setup, gb, samples, res, cull_backfaces=False), VWSS_DEPTH)
    return Measured(
        {"points_ratio": s_both["points"] / s_culled["points"],
         "rmse_both_over_culled": rmse(both, peer, gb.mask) / rmse(culled, peer, gb.mask),
         "time_ratio": t_both / t_culled, "rmse_culled": rmse(culled, peer, gb.mask)},
        note=f"Torus knot of {s_culled['points']:.0f} points ({setup.occluders[0].faces.shape[0]} triangles, closed), "
             f"{size}² receivers, 24 shared Poisson samples, {res}² maps; accuracy: RMSE against MVR's rasterized "
             "maps on the same samples. Here the back faces bring no improvement at all: their points add to the "
             "bloat, and VWSS moves further from MVR.",
    )


# ----------------------------------------------------------------------------------------------
# Figure 8: the light grows, views are added at a constant rate
# ----------------------------------------------------------------------------------------------

def _grown(light, scale: float):
    """The rect light with both sides ``scale`` times as long."""
    import softshadows as ss

    return ss.RectLight(light.center, np.asarray(light.u) * scale, np.asarray(light.v) * scale)


def _vwss_vs_mvr_by_area(setup, gb, res, scales, *, denser: float | None = None):
    """RMSE of vwss against mvr on the same samples, 8 views per unit of relative area; with
    ``denser``, also the RMSE at the largest light with that many points per texel."""
    out, dense = [], None
    for scale in scales:
        lit = setup.with_light(_grown(setup.light, scale))
        samples = _views(lit.light, 8 * scale**2)
        peer = _mvr(lit, gb, samples, res)[0]
        out.append(rmse(_vwss(lit, gb, samples, res)[0], peer, gb.mask))
    if denser is not None:
        dense = rmse(_vwss(lit, gb, samples, res, point_density=denser)[0], peer, gb.mask)
    return out, dense


@claim(
    "marrs18.similar_to_mvr_as_light_grows",
    where="Section 4.1, Figure 8",
    statement="As the area light grows to 64x its area (light samples added at a constant rate), VWSS's "
              "shadows stay very similar to MVR's although the new samples lie further from the source view.",
    paper_value="'very similar results' from 8 to 512 samples, 1x to 64x the area (images)",
    rule=AtMost("rmse_growth", 1.5, in_kind=3.0),
    ours="RMSE against MVR {rmse_1x:.4f} at 1x, {rmse_64x:.4f} at 64x the area ({rmse_growth:.2f}x; "
         "{rmse_64x_density_8:.4f} with 8 points per texel); a light of a quarter the side: {small_rmse_growth:.2f}x",
)
def _light_grows(tier):
    """Figure 8 on the torus knot: the scene's light and one of a quarter its side, each grown 8x per side."""
    size, res = tier.pick(64, 128), tier.pick(512, PAPER_MAPS)
    setup, gb = staged("torus_knot", size)
    scales = (1, 8) if not tier.figures else (1, 2, 4, 8)
    default, dense = _vwss_vs_mvr_by_area(setup, gb, res, scales, denser=8.0)
    small, _ = _vwss_vs_mvr_by_area(setup.with_light(_grown(setup.light, 0.25)), gb, res, scales)
    values = {"rmse_1x": default[0], "rmse_64x": default[-1], "rmse_growth": default[-1] / default[0],
              "small_rmse_growth": small[-1] / small[0], "rmse_64x_density_8": dense}
    figure = None
    if tier.figures:
        figure = _figure()
        ax = figure.subplots()
        areas = [s**2 for s in scales]
        ax.plot(areas, default, "o-", label="the scene's light (side 1 to 8)")
        ax.plot(areas, small, "s--", label="a quarter of its side (0.25 to 2)")
        ax.set_xscale("log", base=2)
        ax.set_xlabel("light area (x), 8 views per unit")
        ax.set_ylabel("RMSE of VWSS against MVR")
        ax.legend(fontsize=8)
    return Measured(values, figure=figure,
                    note=f"Torus knot, light 3 units away, {size}² receivers, {res}² maps, 8 to 512 shared Poisson "
                         "samples (the paper's 1 per 2 units of area), only the knot in the maps, our default 2 "
                         "points per target texel. The scene's light grows to 8 units a side, wider than its "
                         "distance: the corner samples see the knot's surfaces far more frontally than the pulled-back "
                         "source view, which sampled them sparsely, so their warped maps have holes and VWSS's shadow "
                         "comes out lighter than MVR's. A light of a quarter the side (0.25 to 2) stays close. More "
                         "points per texel close the holes: at 64x the area, 8 points per texel bring the RMSE "
                         f"against MVR to {dense:.4f}.")


# ----------------------------------------------------------------------------------------------
# Figure 10: where PCSS fails and the multi-view methods do not
# ----------------------------------------------------------------------------------------------

def _hole_share(vis, ref, mask) -> float:
    """The share of the pixels the reference shadows (below 0.9) that a method leaves fully lit."""
    shadowed = mask & (ref < 0.9)
    return float(np.mean(np.asarray(vis)[shadowed] >= 0.999))


def _sword(width: float, size: int, res: int):
    """PCSS, VWSS and MVR on a sword whose blade is ``width`` wide; returns them, the reference and the mask."""
    import softshadows as ss

    setup = ss.scenes.sword(blade_width=width, blade_thickness=min(width, 0.01), width=size, height=size)
    gb = ss.gbuffer(setup.scene, setup.camera)
    samples = _views(setup.light, 24)
    images = {"PCSS": _pcss(setup, gb, res)[0], "VWSS": _vwss(setup, gb, samples, res)[0],
              "MVR": _mvr(setup, gb, samples, res)[0]}
    return images, reference(setup, gb), gb.mask


@claim(
    "marrs18.pcss_misses_thin_occluders",
    where="Section 4.1, Figure 10 (top)",
    statement="Thin geometry that falls between depth-map texels escapes PCSS's blocker search and leaves "
              "holes in its shadow; VWSS, with the same number of samples per pixel, has no such failure.",
    paper_value="'noticeable holes' in PCSS's sword shadow, none in VWSS's (images)",
    rule=AllOf(AtLeast("pcss_holes", 0.05), AtMost("vwss_holes", 0.01)),
    ours="PCSS leaves {pcss_holes:.1%} of the sword's shadow fully lit, VWSS {vwss_holes:.1%}, MVR {mvr_holes:.1%}",
)
def _thin_occluders(tier):
    """Figure 10 (top): a sword whose blade is about one texel of the 1024² maps wide, and the built-in one."""
    size, res = tier.pick(128, 512), PAPER_MAPS
    values = {}
    for label, width in (("", 0.005), ("default_", 0.03)):
        images, ref, mask = _sword(width, size, res)
        for name, vis in images.items():
            values[f"{label}{name.lower()}_holes"] = _hole_share(vis, ref, mask)
            values[f"{label}rmse_{name.lower()}"] = rmse(vis, ref, mask)
        if not label:
            values["vwss_shadow_excess"] = _shadow_excess(images["VWSS"], ref, mask)
            values["pcss_shadow_excess"] = _shadow_excess(images["PCSS"], ref, mask)
            thin = (images, ref, mask)
    figure = None
    if tier.figures:
        images, ref, mask = thin
        figure = _image_row("Figure 10 (top): a one-texel blade", mask, {"reference": ref},
                            {f"{k} - ref": v - ref for k, v in images.items()})
    return Measured(values, figure=figure,
                    note=f"Sword with a blade 0.005 wide and thick, about one texel of the {res}² maps at its depth; "
                         f"{size}² receivers; reference 1024 ray-traced Sobol samples; a hole is a pixel the reference "
                         "shadows below 0.9 left fully lit. PCSS: 64 blocker-search and 96 filter taps; VWSS and MVR: "
                         "24 shared Poisson samples, 5-tap PCF. The built-in sword's 0.03 blade (about 5 texels) "
                         f"leaves PCSS almost no holes ({values['default_pcss_holes']:.2%}). VWSS splats the thin blade "
                         f"onto whole texels: its shadow is {values['vwss_shadow_excess']:+.0%} against the reference's "
                         f"(PCSS {values['pcss_shadow_excess']:+.0%}), RMSE {values['rmse_vwss']:.4f} against PCSS's "
                         f"{values['rmse_pcss']:.4f} and MVR's {values['rmse_mvr']:.4f}: no holes, but not closer to "
                         "the reference than PCSS.")


def _box(lo, hi, name: str):
    """A closed axis-aligned box with outward-facing triangles."""
    import softshadows as ss

    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])],
                       dtype=np.float32)
    # Corner index 4 ix + 2 iy + iz; each side's corners in counter-clockwise order seen from outside.
    sides = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    faces = np.array([t for a, b, c, d in sides for t in ((a, b, c), (a, c, d))], dtype=np.uint32)
    return ss.Mesh(corners, faces, closed=True, name=name)


@functools.lru_cache(maxsize=2)
def _fusion_scene(size: int):
    """Occluders at two depths whose shadows overlap: a plate high under the light, a block on the
    ground beside its edge. Returns the setup, its G-buffer and the pixels where both occlude."""
    import softshadows as ss

    ground = ss.Mesh(np.array([[-3, 0, -3], [3, 0, -3], [3, 0, 3], [-3, 0, 3]], dtype=np.float32),
                     np.array([[0, 2, 1], [0, 3, 2]], dtype=np.uint32), name="ground")
    plate = _box((-1.5, 1.2, -1.0), (0.1, 1.25, 1.0), "plate")
    block = _box((0.2, 0.0, -0.3), (0.6, 0.15, 0.3), "block")
    scene = ss.Scene([ground, plate, block])
    light = ss.RectLight((0.0, 3.0, 0.0), (0.4, 0.0, 0.0), (0.0, 0.0, 0.4))
    camera = ss.Camera.look_at((1.2, 2.5, 1.8), (0.2, 0.0, 0.0), fov_y=45.0, width=size, height=size)
    setup = ss.scenes.Setup("occluder_fusion", scene, light, camera, "a plate 1.2 over the ground beside a 0.15 block")
    gb = ss.gbuffer(scene, camera)
    samples = light.samples(1024, pattern="sobol", seed=1)
    alone = [ss.ray_traced(scene.subset(["ground", name]), light, gb, samples=samples) for name in ("plate", "block")]
    both = gb.mask & (alone[0] < 0.99) & (alone[1] < 0.99)
    return setup, gb, both


@claim(
    "marrs18.occluder_fusion",
    where="Section 2.1, Figure 10 (bottom)",
    statement="PCSS's average blocker depth mishandles occluder fusion where occluders at different depths "
              "overlap; VWSS z-buffers its points into every light sample's map and handles it like MVR.",
    paper_value="PCSS wrong where occluders fuse, VWSS similar to MVR (images)",
    rule=AllOf(AtLeast("pcss_over_vwss", 2.0, in_kind=1.25), AtMost("vwss_over_mvr", 1.5, in_kind=2.5)),
    ours="RMSE where both occluders shadow: PCSS {rmse_pcss:.3f}, VWSS {rmse_vwss:.3f}, MVR {rmse_mvr:.3f}",
)
def _occluder_fusion(tier):
    """Figure 10 (bottom) on a scene built for it: errors where both occluders block part of the light."""
    size, res = tier.pick(64, 256), tier.pick(512, PAPER_MAPS)
    setup, gb, both = _fusion_scene(size)
    ref = reference(setup, gb)
    samples = _views(setup.light, 24)
    images = {"PCSS": _pcss(setup, gb, res)[0], "VWSS": _vwss(setup, gb, samples, res)[0],
              "MVR": _mvr(setup, gb, samples, res)[0]}
    err = {k: rmse(v, ref, both) for k, v in images.items()}
    figure = None
    if tier.figures:
        figure = _image_row("Figure 10 (bottom): occluders at two depths", gb.mask, {"reference": ref},
                            {f"{k} - ref": v - ref for k, v in images.items()})
    return Measured(
        {"rmse_pcss": err["PCSS"], "rmse_vwss": err["VWSS"], "rmse_mvr": err["MVR"],
         "pcss_over_vwss": err["PCSS"] / err["VWSS"], "vwss_over_mvr": err["VWSS"] / err["MVR"]},
        figure=figure,
        note=f"A plate 1.2 over the ground beside a block 0.15 high under a 0.8 x 0.8 light 3 up; {size}² receivers, "
             f"{res}² maps; RMSE against 1024 ray-traced Sobol samples over the {int(both.sum())} pixels that each "
             "occluder alone would partly shadow. PCSS: 64 + 96 taps; VWSS and MVR: 24 shared Poisson samples.",
    )


# ----------------------------------------------------------------------------------------------
# Figure 11: constant-bias self-shadowing
# ----------------------------------------------------------------------------------------------

#: Constant depth biases in world units (the bunny is 1 unit long): roughly 1, 2 and 4 texels of
#: the 1024² maps at its depth.
BIASES = (0.01, 0.02, 0.04)


def _self_shadowing(vis, ref, lit) -> float:
    """The light a method takes from pixels the reference lights fully: mean darkening over ``lit``."""
    return float(np.mean(1.0 - np.asarray(vis, dtype=np.float64)[lit]))


def _geometric_mean(ratios) -> float:
    """The geometric mean: ratios measured at several biases weigh alike."""
    return float(np.exp(np.mean(np.log(ratios))))


@claim(
    "marrs18.constant_bias_banding",
    where="Sections 4.1 and 5.1, Figure 11",
    statement="With a constant depth bias VWSS self-shadows the occluder in bands, since its samples of the "
              "occluder come from a single view, where MVR, rasterizing every view anew, does not.",
    paper_value="self-shadow banding in VWSS (as in PCSS), none in MVR (images)",
    rule=AtLeast("vwss_over_mvr", 1.5, in_kind=1.1),
    ours="false self-shadowing over MVR's: VWSS {vwss_over_mvr:.2f}x, PCSS {pcss_over_mvr:.2f}x "
         "(VWSS {vwss_over_mvr_0_04:.1f}x at the largest bias, where MVR darkens its lit pixels by {mvr_0_04:.2%})",
)
def _banding(tier):
    """Figure 11 on the bunny: how much each method darkens the bunny's fully lit pixels under constant biases."""
    size, res = tier.pick(128, 256), PAPER_MAPS
    setup, gb = staged("bunny", size)
    ref = reference(setup, gb)
    samples = _views(setup.light, 24)
    on_bunny = gb.mask & (gb.face_ids >= setup.ground.faces.shape[0])
    lit = on_bunny & (ref >= 0.999)
    dark = {"mvr": [], "vwss": [], "pcss": []}
    for bias in BIASES:
        runs = {"mvr": _mvr(setup, gb, samples, res, bias=bias), "vwss": _vwss(setup, gb, samples, res, bias=bias),
                "pcss": _pcss(setup, gb, res, bias=bias)}
        for name, (vis, _) in runs.items():
            dark[name].append(_self_shadowing(vis, ref, lit))
    tag = lambda b: str(b).replace(".", "_")  # noqa: E731
    values = {f"{name}_{tag(b)}": d for name in dark for b, d in zip(BIASES, dark[name])}
    values["vwss_over_mvr"] = _geometric_mean([v / m for v, m in zip(dark["vwss"], dark["mvr"])])
    values["pcss_over_mvr"] = _geometric_mean([p / m for p, m in zip(dark["pcss"], dark["mvr"])])
    values["vwss_over_mvr_0_04"] = dark["vwss"][-1] / dark["mvr"][-1]
    figure = None
    if tier.figures:
        figure = _figure()
        ax = figure.subplots()
        for name, style in (("mvr", "s-"), ("vwss", "o-"), ("pcss", "^-")):
            ax.plot(BIASES, dark[name], style, label=name.upper())
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("constant depth bias (world units)")
        ax.set_ylabel("mean darkening of lit pixels")
        ax.legend(fontsize=8)
    return Measured(values, figure=figure,
                    note=f"Bunny on the ground, only the bunny in the maps, {size}² receivers, {res}² maps, 24 shared "
                         f"Poisson samples, constant biases {', '.join(map(str, BIASES))}; self-shadowing: the mean "
                         f"darkening of the {int(lit.sum())} bunny pixels the reference lights fully, ratios the "
                         "geometric mean over the biases. MVR self-shadows too at the smaller biases, less than VWSS; on "
                         "the bunny's own surface PCSS, whose single map is the light's center view, self-shadows less "
                         "than MVR at the smaller biases, so 'as in PCSS' holds only at the largest.")


# ----------------------------------------------------------------------------------------------
# Figure 13 and Section 5: the implementation variants, and where MVR wins
# ----------------------------------------------------------------------------------------------

#: Figure 13's implementations: point storage (mode) and depth maps per traversal (schedule).
_VARIANTS = {
    "buffered_serial": dict(mode="buffered", parallel="serial"),
    "buffered_partial": dict(mode="buffered", parallel="partial"),
    "buffered_full": dict(mode="buffered", parallel="full"),
    "unbuffered_partial": dict(mode="unbuffered", parallel="partial"),
    "unbuffered_full": dict(mode="unbuffered", parallel="full"),
}


@functools.lru_cache(maxsize=2)
def _variants(tier_name: str):
    """VWSS's point-generation plus depth-map seconds for every mode and schedule, by view count."""
    from .ledger import Tier

    tier = Tier(tier_name)
    size, res, counts = 64, tier.pick(512, PAPER_MAPS), tier.pick((8, 64), (8, 32, 128))
    setup, gb = _knot(tier.pick(50_000, 240_186), size)
    seconds = {}
    for views in counts:
        samples = _views(setup.light, views)
        for name, options in _VARIANTS.items():
            seconds[name, views] = _fastest(lambda: _vwss(setup, gb, samples, res, **options), VWSS_DEPTH, repeat=3)[0]
    return seconds, counts, res, setup.occluders[0].faces.shape[0]


def _variants_figure(seconds, counts, names, title):
    """Seconds against the number of depth maps, one line per variant in ``names``."""
    figure = _figure()
    ax = figure.subplots()
    for name in names:
        ax.plot(counts, [seconds[name, n] for n in counts], "o-", label=name.replace("_", ", "))
    ax.set_xlabel("depth maps")
    ax.set_ylabel("CPU seconds (points + maps)")
    ax.set_title(title, fontsize=9)
    ax.legend(fontsize=7)
    return figure


@claim(
    "marrs18.buffered_faster_than_unbuffered",
    where="Sections 3 and 5, Figure 13 (top)",
    statement="The buffered implementation is faster than the unbuffered one, whose fully parallel single "
              "pass saturates GPU memory bandwidth as the number of depth maps grows.",
    paper_value="unbuffered slower, increasingly so with more depth maps (GTX Titan X)",
    rule=NotMeasurable("the unbuffered penalty is contention for GPU memory bandwidth between the rasterizer's "
                       "stream and the pixel shaders' writes; a CPU has no such pipeline"),
    ours="unbuffered over buffered, fully parallel: {full_fewest:.2f}x ({fewest:.0f} maps) to {full_most:.2f}x "
         "({most:.0f} maps); partially parallel: {partial_fewest:.2f}x to {partial_most:.2f}x",
    tolerance={k: TIMING for k in ("full_fewest", "full_most", "partial_fewest", "partial_most")},
)
def _buffered(tier):
    """Figure 13 (top): unbuffered over buffered time at the fewest and most depth maps."""
    seconds, counts, res, triangles = _variants(tier.name)
    lo, hi = counts[0], counts[-1]
    ratio = lambda schedule, n: seconds[f"unbuffered_{schedule}", n] / seconds[f"buffered_{schedule}", n]  # noqa: E731
    values = {"full_fewest": ratio("full", lo), "full_most": ratio("full", hi), "partial_fewest": ratio("partial", lo),
              "partial_most": ratio("partial", hi), "fewest": lo, "most": hi}
    figure = None
    if tier.figures:
        figure = _variants_figure(seconds, counts, [n for n in _VARIANTS if n != "buffered_serial"],
                                  "Figure 13 (top): buffered and unbuffered")
    return Measured(values, figure=figure,
                    note=f"Torus knot of {triangles} triangles, 64² receivers, {res}² maps, {lo} to {hi} maps; CPU seconds "
                         "of point generation plus depth maps, the least of up to 3 runs. Fully parallel, the two do the "
                         "same work on a CPU (one source rasterization, every map per point), and the unbuffered mode, "
                         "which writes no point buffer, is as fast or faster; partially parallel, our unbuffered mode "
                         "rasterizes the source again for every traversal, which is what makes it slower there.")


@claim(
    "marrs18.compute_point_rendering",
    where="Sections 3.2 and 5, Figure 13 (bottom)",
    statement="Rendering the points in GPU Compute is faster than through the graphics pipeline in every "
              "schedule (serial, partially and fully parallel), and unlike the pipeline Compute writes several "
              "maps per traversal without losing speed.",
    paper_value="GPU Compute faster in every configuration (GTX Titan X)",
    rule=NotMeasurable("it compares GPU Compute with the GPU graphics pipeline; this CPU implementation has "
                       "neither"),
    ours="on the CPU, partially parallel takes {partial_over_serial:.2f}x and fully parallel {full_over_serial:.2f}x "
         "the serial schedule's time ({most:.0f} maps)",
    tolerance={"partial_over_serial": TIMING, "full_over_serial": TIMING},
)
def _schedules(tier):
    """Figure 13 (bottom): the buffered schedules' times on the CPU, at the most depth maps."""
    seconds, counts, res, triangles = _variants(tier.name)
    hi = counts[-1]
    values = {"partial_over_serial": seconds["buffered_partial", hi] / seconds["buffered_serial", hi],
              "full_over_serial": seconds["buffered_full", hi] / seconds["buffered_serial", hi], "most": hi}
    figure = None
    if tier.figures:
        figure = _variants_figure(seconds, counts, ["buffered_serial", "buffered_partial", "buffered_full"],
                                  "Figure 13 (bottom): traversal schedules (CPU)")
    return Measured(values, figure=figure,
                    note=f"Torus knot of {triangles} triangles, 64² receivers, {res}² maps, buffered; 8 maps per "
                         "traversal when partially parallel. On the CPU one map at a time stays in cache, while "
                         "several maps per traversal scatter each point's writes over more memory.")


@claim(
    "marrs18.few_polygons_favor_mvr",
    where="Section 5.1",
    statement="When a few occluding polygons generate many points, brute-force rasterization is the better "
              "choice.",
    paper_value="MVR better for few polygons generating many points (no number)",
    rule=AtMost("speedup", 0.8, in_kind=1.25),
    ours="VWSS's depth maps {speedup:.2f}x as fast as MVR's ({triangles:.0f} triangles, {points:.0f} points)",
    tolerance={"speedup": TIMING},
)
def _few_polygons(tier):
    """A sphere of 1280 triangles: VWSS's depth-map speed-up over MVR (below 1: MVR is faster)."""
    size, res = tier.pick(64, 256), PAPER_MAPS
    setup, gb = staged("ground_sphere", size)
    samples = _views(setup.light, 24)
    t_mvr, _, s_mvr = _fastest(lambda: _mvr(setup, gb, samples, res), MVR_DEPTH)
    t_vw, _, s_vw = _fastest(lambda: _vwss(setup, gb, samples, res), VWSS_DEPTH)
    return Measured(
        {"speedup": t_mvr / t_vw, "triangles": setup.occluders[0].faces.shape[0], "points": s_vw["points"]},
        note=f"Sphere over the ground, only the sphere in the maps, {size}² receivers, 24 shared Poisson samples, "
             f"{res}² maps; depth-map seconds (VWSS's point generation included), the least of up to 5 runs. Most of "
             "VWSS's time here is clearing and copying its 24 atomic maps, which MVR's few triangles undercut. Holds "
             "when MVR is clearly faster (VWSS at most 0.8x its speed); in kind at parity (up to 1.25x), where the "
             "two trade places from run to run on an idle machine (0.93-1.03x measured).",
    )

"""Makes docs/figures/shaded_comparison.png, the README's picture: a shaded scene, four methods
against the exact reference, and where each one errs.

Top row: direct light only (``softshadows.shading.direct``), every image at the reference's
exposure (``softshadows.io.auto_exposure``), sRGB-encoded (``softshadows.io.tonemap``). Bottom
row: the reference's visibility, then each method's signed visibility error (red: too bright,
blue: too dark), titled with its RMSE over the pixels that hit a surface. The figure is 9 in
wide, laid out for about 900 pixels (README width), and saved at twice that for sharp screens.

Run from the repository root: ``python scripts/make_readme_figure.py [--out PATH]`` (about 15 s
on two cores).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import matplotlib
import numpy as np
from matplotlib.cm import ScalarMappable
from matplotlib.colors import Normalize
from matplotlib.figure import Figure

import softshadows as ss
from softshadows import io, metrics, plot, scenes, shading

#: Scene, image size (pixels per side) and the light samples the sample-based methods share.
SCENE, SIZE, SAMPLES, VIEWS = "torus_knot", 360, 64, 24
#: Light samples of the reference (exact ray-traced visibility, Sobol' points).
REFERENCE_SAMPLES = 1024
#: Diffuse reflectance of the ground and of the occluder, linear RGB.
GROUND, OCCLUDER = (0.72, 0.70, 0.66), (0.85, 0.42, 0.16)
#: Visibility error shown as full red or blue.
ERROR_SCALE = 0.25


def render():
    """The G-buffer, the reference visibility and each method's visibility."""
    setup = scenes.get(SCENE, width=SIZE, height=SIZE)
    gb = ss.gbuffer(setup.scene, setup.camera)
    reference = ss.ray_traced(setup.scene, setup.light, gb, samples=REFERENCE_SAMPLES, pattern="sobol", seed=1)
    samples = setup.light.samples(SAMPLES, pattern="poisson", seed=0)
    views = setup.light.samples(VIEWS, pattern="poisson", seed=0)
    methods = {
        "pcss": ss.pcss(setup.scene, setup.light, gb),
        "cssm": ss.cssm(setup.scene, setup.light, gb),
        f"alias_free, {SAMPLES} samples": ss.alias_free(setup.scene, setup.light, gb, samples=samples),
        f"vwss, {VIEWS} views": ss.vwss(setup.scene, setup.light, gb, samples=views),
    }
    return setup, gb, reference, methods


def shaded(setup, gb, visibility) -> np.ndarray:
    """Linear RGB radiance (H, W, 3): the ground and the occluder each in its own colour."""
    ground = gb.face_ids < len(setup.scene.meshes[0].faces)  # ground is mesh 0: faces numbered first
    radiance = [shading.direct(gb, setup.light, visibility, albedo, bent_normals=True, scene=setup.scene)
                for albedo in (GROUND, OCCLUDER)]
    return np.where(ground[..., None], radiance[0], radiance[1])


def figure(setup, gb, reference, methods) -> Figure:
    """Two rows: shaded images over their visibility errors, the reference first."""
    images = {"reference (ray_traced)": reference, **methods}
    radiance = {name: shaded(setup, gb, vis) for name, vis in images.items()}
    exposure = io.auto_exposure(radiance["reference (ray_traced)"])
    fig = Figure(figsize=(9, 4.6), layout="constrained")
    grid = fig.add_gridspec(3, len(images), height_ratios=[1, 1, 0.06])
    gray = matplotlib.colormaps["gray"].with_extremes(bad=plot.NO_HIT)
    for k, (name, vis) in enumerate(images.items()):
        top, bottom = fig.add_subplot(grid[0, k]), fig.add_subplot(grid[1, k])
        shown = np.where(gb.mask[..., None], io.tonemap(radiance[name], exposure=exposure), plot.NO_HIT)
        top.imshow(shown, interpolation="antialiased")
        top.set_title(name, fontsize=9)
        if k == 0:
            bottom.imshow(np.where(gb.mask, vis, np.nan), cmap=gray, vmin=0, vmax=1, interpolation="antialiased")
            bottom.set_title("its visibility", fontsize=9)
        else:
            error = metrics.error_heatmap(vis, reference, gb.mask, vmax=ERROR_SCALE)
            bottom.imshow(error, interpolation="antialiased")
            bottom.set_title(f"error, RMSE {metrics.rmse(vis, reference, gb.mask):.3f}", fontsize=9)
        top.set_axis_off()
        bottom.set_axis_off()
    bar = fig.add_subplot(grid[2, 1:])
    # The diverging map of metrics.error_heatmap, over the same range.
    fig.colorbar(ScalarMappable(Normalize(-ERROR_SCALE, ERROR_SCALE), "RdBu_r"), cax=bar, orientation="horizontal")
    bar.tick_params(labelsize=8)
    bar.set_xlabel("visibility error against the reference (red: too bright, blue: too dark)", fontsize=8)
    return fig


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("docs/figures/shaded_comparison.png"),
                        help="where to write the PNG (default: docs/figures/shaded_comparison.png)")
    args = parser.parse_args(argv)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    figure(*render()).savefig(args.out, dpi=200)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()

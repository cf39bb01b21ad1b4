"""Makes docs/figures/shadows_over_time.gif, the README's "Shadows over time" picture: the
columns under a square light that turns 40 degrees about them over 24 frames, evaluated frame by
frame (``softshadows.evaluate_sequence``).

Panels, left to right: the reference (Mitsuba's ``ray_test`` on 1024 Sobol samples, in every
frame), then ``alias_free`` with 16 light samples three ways: the same samples in every frame,
jittered from frame to frame (Sintorn et al. 2008, section 4.3), and jittered with its frames
accumulated (``softshadows.accumulate``); below each, its signed error (red: too bright, blue:
too dark). Each title gives the mean RMSE over the frames and the flicker, the mean change from
one frame to the next against the reference's own change. The table it prints is the README's.

Run from the repository root: ``python scripts/make_sequence_figure.py [--out PATH]`` (about a
minute on two cores, most of it the references).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import softshadows as ss
from softshadows.evaluation import OverTime

#: The scene, the image size (pixels per side), the frames, the light's turn in degrees and the
#: light samples of alias_free.
SCENE, SIZE, FRAMES, DEGREES, SAMPLES = "columns", 96, 24, 40.0, 16
#: Light samples of each frame's reference.
REFERENCE_SAMPLES = 1024
#: The three ways of running alias_free over time, by panel title.
ENTRIES = {
    "same samples": "alias_free",
    "jittered": OverTime("alias_free"),
    "jittered, accumulated": OverTime("alias_free", accumulate=True),
}
#: Frames per second of the animation and pixels per inch of its panels (the file stays small).
FPS, DPI = 8, 56


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=Path("docs/figures/shadows_over_time.gif"))
    args = parser.parse_args()
    turning = ss.sequence(ss.scenes.get(SCENE), frames=FRAMES, light_path=ss.scenes.Orbit(DEGREES))
    summary = ss.evaluate_sequence(turning, ENTRIES, size=SIZE, samples=SAMPLES, reference_samples=REFERENCE_SAMPLES,
                                   keep_images=True)
    images = summary.attrs["images"][SCENE]
    titles = {r["method"]: f"RMSE {r['rmse']:.4f}, flicker {r['temporal.flicker']:.4f}" for _, r in summary.iterrows()}
    args.out.parent.mkdir(parents=True, exist_ok=True)
    ss.plot.animation(images["reference"], {name: images[name] for name in ENTRIES}, images["mask"], path=args.out,
                      fps=FPS, titles=titles, dpi=DPI)
    columns = ["rmse", "ssim", "flip", "temporal.std", "temporal.flicker", "seconds"]
    print("| alias_free | " + " | ".join(columns) + " |\n|---|" + "---|" * len(columns))
    for _, r in summary.iterrows():
        print(f"| {r['method']} | " + " | ".join(f"{r[c]:.4f}" for c in columns) + " |")
    print(f"wrote {args.out} ({args.out.stat().st_size / 1024:.0f} KiB)")


if __name__ == "__main__":
    main()

"""Pictures: visibility and error side by side, the way people compare shadow methods.

The figures are ``matplotlib.figure.Figure`` objects made without pyplot: importing or calling
this module never changes the matplotlib backend, and no figure is left registered with pyplot
(nothing to close). In Jupyter a returned figure shows as the cell's value or with
``display(fig)``; to show one with ``plt.show()`` in a window, draw it into a pyplot figure
(``comparison_grid(..., figure=plt.figure())``, ``show_samples(..., ax=plt.gca())``).
"""

from __future__ import annotations

import numpy as np

from ._extras import require

__all__ = ["comparison_grid", "animation", "show_samples", "setup", "NO_HIT", "MAX_COLUMNS", "MAX_WIDTH"]

#: The colour of pixels that hit no surface, so they never read as shadow.
NO_HIT = (0.55, 0.68, 0.82)
#: Columns of a comparison grid before it wraps into another row of panels.
MAX_COLUMNS = 5
#: Width of a comparison grid in inches: it fits a notebook cell (about 12 in at 100 dpi).
MAX_WIDTH = 12.0
#: Width of one column in inches when few columns leave room for it.
_COLUMN_WIDTH = 2.6
#: Inches for the titles above a pair of panels (up to two lines) and the error panel's title.
_TITLES_HEIGHT = 0.9


def comparison_grid(reference, results: dict, mask=None, *, path=None, titles: dict | None = None, vmax: float = 0.25,
                    figure=None):
    """One panel per method: visibility on top, signed error against the reference below it.

    Panels run left to right, the reference first, and wrap after :data:`MAX_COLUMNS` into
    further rows (balanced: 13 panels make 3 rows of 5, 5 and 3); the figure is at most
    :data:`MAX_WIDTH` inches wide.

    Parameters
    ----------
    reference : ndarray, shape (H, W)
        Reference visibility in [0, 1].
    results : dict of str to ndarray, shape (H, W)
        Each method's visibility.
    mask : ndarray, shape (H, W), bool, optional
        Pixels that hit a surface; others are drawn in :data:`NO_HIT` blue on top and gray below.
    path : str or Path, optional
        Where to save the PNG (110 dpi); the figure is returned either way.
    titles : dict of str to str, optional
        Extra text under each panel title (e.g. the RMSE).
    vmax : float
        Error magnitude mapped to full red / blue.
    figure : matplotlib.figure.Figure, optional
        A figure to draw into, e.g. ``plt.figure()`` to show it with ``plt.show()``; it is
        cleared and resized. By default a new figure that pyplot does not know about.

    Returns
    -------
    matplotlib.figure.Figure
        Two axes per panel (visibility, then its error), in panel order.

    Examples
    --------
    >>> import numpy as np
    >>> from softshadows import plot
    >>> reference = np.tile(np.linspace(0, 1, 16), (16, 1))
    >>> results = {f"method {k}": np.clip(reference + 0.02 * k, 0, 1) for k in range(12)}
    >>> fig = plot.comparison_grid(reference, results)
    >>> len(fig.axes), fig.get_size_inches().round(1).tolist()     # 13 panels: 3 rows of at most 5
    (26, [12.0, 17.1])
    >>> fig.canvas.manager is None                                  # not registered with pyplot
    True
    """
    matplotlib = require("matplotlib", extra="evaluation", for_="softshadows.plot.comparison_grid")
    Figure = require("matplotlib.figure", extra="evaluation", for_="softshadows.plot.comparison_grid").Figure

    from . import _validate as v
    from .metrics import _inputs, error_heatmap

    # Checked here, so that a refusal names this function's arguments, not error_heatmap's.
    reference, results = _panels(reference, results, frames=False)
    if mask is not None:
        mask = _inputs(reference, reference, mask)[2]  # as the metrics take it: bool or 0/1, (H, W), not empty
    vmax = v.positive("vmax", vmax)
    if figure is not None and not isinstance(figure, Figure):
        raise ValueError(f"figure: expected a matplotlib.figure.Figure such as plt.figure(), got {type(figure).__name__}")
    panels = {"reference": reference, **results}
    rows = -(-len(panels) // MAX_COLUMNS)
    cols = -(-len(panels) // rows)
    width = min(_COLUMN_WIDTH, MAX_WIDTH / cols)
    # A strip-shaped image would otherwise make a figure hundreds of inches tall (or flat).
    aspect = min(max(reference.shape[0] / reference.shape[1], 0.25), 4.0)
    size = (cols * width, rows * (2 * width * aspect + _TITLES_HEIGHT))
    if figure is None:
        fig = Figure(figsize=size, layout="constrained")
    else:
        fig = figure
        fig.clear()
        fig.set_size_inches(size)
        fig.set_layout_engine("constrained")
    cmap = matplotlib.colormaps["gray"].with_extremes(bad=NO_HIT)
    grid = fig.add_gridspec(2 * rows, cols)
    for k, (name, vis) in enumerate(panels.items()):
        row, col = divmod(k, cols)
        top, bottom = fig.add_subplot(grid[2 * row, col]), fig.add_subplot(grid[2 * row + 1, col])
        sub = (titles or {}).get(name, "")
        top.imshow(vis if mask is None else np.where(mask, vis, np.nan), cmap=cmap, vmin=0, vmax=1, interpolation="nearest")
        top.set_title(name + (f"\n{sub}" if sub else ""), fontsize=9)
        bottom.imshow(error_heatmap(vis, reference, mask, vmax=vmax), interpolation="nearest")
        bottom.set_title("error" if name != "reference" else f"error scale ±{vmax}", fontsize=8)
        top.set_axis_off()
        bottom.set_axis_off()
    if path is not None:
        fig.savefig(path, dpi=110)
    return fig


def animation(reference, results: dict, mask=None, *, path, fps: float = 8.0, titles: dict | None = None, vmax: float = 0.25,
              dpi: float = 72.0):
    """A comparison grid over time: each frame drawn as :func:`comparison_grid` draws one
    (reference, then each method, with its signed error below it), written as an animated GIF
    or an MP4 video.

    Parameters
    ----------
    reference : ndarray, shape (F, H, W)
        Reference visibility in each of F frames.
    results : dict of str to ndarray, shape (F, H, W)
        Each method's visibility in each frame.
    mask : ndarray, shape (F, H, W), bool, optional
        Each frame's hit pixels.
    path : str or Path
        ``.gif`` (written by Pillow, which matplotlib installs) or ``.mp4`` (needs the
        ``ffmpeg`` program on the PATH).
    fps : float
        Frames per second.
    titles : dict of str to str, optional
        Extra text under each panel title, the same in every frame (e.g. the flicker).
    vmax : float
        Error magnitude mapped to full red / blue.
    dpi : float
        Pixels per inch of the panels (:func:`comparison_grid` sizes them in inches).

    Returns
    -------
    Path
        ``path``.

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> import numpy as np
    >>> from softshadows import plot
    >>> ramp = np.tile(np.linspace(0, 1, 16), (16, 1))
    >>> reference = np.stack([np.roll(ramp, k, axis=1) for k in range(4)])  # a ramp scrolling sideways
    >>> noisy = np.clip(reference + np.random.default_rng(0).normal(0, 0.05, reference.shape), 0, 1)
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     gif = plot.animation(reference, {"noisy": noisy}, path=Path(folder) / "ramp.gif", fps=4)
    ...     from PIL import Image
    ...     Image.open(gif).n_frames
    4
    """
    require("matplotlib", extra="evaluation", for_="softshadows.plot.animation")
    Figure = require("matplotlib.figure", extra="evaluation", for_="softshadows.plot.animation").Figure
    writers = require("matplotlib.animation", extra="evaluation", for_="softshadows.plot.animation")

    from pathlib import Path

    from . import _validate as v

    reference, results = _panels(reference, results, frames=True)
    if mask is not None:
        mask = v.array("mask", mask, bool, reference.shape)
    fps, dpi = v.positive("fps", fps), v.positive("dpi", dpi)
    path = Path(path)
    if path.suffix.lower() == ".gif":
        writer = writers.PillowWriter(fps=fps)
    elif path.suffix.lower() == ".mp4" and writers.FFMpegWriter.isAvailable():
        writer = writers.FFMpegWriter(fps=fps)
    else:
        raise ValueError(f"path: expected a .gif, or a .mp4 with the ffmpeg program installed (sudo apt-get install ffmpeg), "
                         f"got {str(path)!r}")
    fig = Figure()

    def draw(frame):
        comparison_grid(reference[frame], {k: r[frame] for k, r in results.items()}, None if mask is None else mask[frame],
                        titles=titles, vmax=vmax, figure=fig)
        fig.suptitle(f"frame {frame + 1} of {len(reference)}", fontsize=9)

    draw(0)  # the writer takes its frame size from the figure's
    with writer.saving(fig, path, dpi):
        for frame in range(len(reference)):
            if frame:
                draw(frame)
            writer.grab_frame()
    return path


def _panels(reference, results, *, frames: bool) -> tuple:
    """The reference and each method's images, as float64 arrays: a non-empty (H, W) reference,
    or with ``frames`` an (F, H, W) stack, and a dict of results of its shape."""
    from . import _validate as v

    reference = v.array("reference", reference, np.float64, (None,) * (3 if frames else 2))
    if reference.size == 0:
        what = "(F, H, W) stack" if frames else "(H, W) image"
        raise ValueError(f"reference: expected a non-empty {what}, got shape {reference.shape}")
    if not isinstance(results, dict) or not all(isinstance(k, str) for k in results):
        raise ValueError(f"results: expected a dict of method name to visibility, got {type(results).__name__}")
    return reference, {k: v.array("results", r, np.float64, reference.shape) for k, r in results.items()}


def show_samples(light, samples, *, ax=None, title: str | None = None):
    """Scatter-plots light samples in the light's plane (the two largest principal axes).

    Parameters
    ----------
    light : a light
        Its ``center`` (or a point light's ``position``) is the origin of the plot.
    samples : ndarray, shape (S, 3)
        Points on the light, world units.
    ax : matplotlib.axes.Axes, optional
        Where to plot, e.g. ``plt.gca()``; by default the axes of a new 3 x 3 in figure that
        pyplot does not know about.
    title : str, optional
        Default: the number of samples.

    Returns
    -------
    matplotlib.axes.Axes

    Examples
    --------
    >>> import softshadows as ss
    >>> light = ss.RectLight((0, 5, 0), (2, 0, 0), (0, 0, 0.5))
    >>> ax = ss.plot.show_samples(light, light.samples(16, seed=0))
    >>> ax.get_title(), ax.figure.canvas.manager is None
    ('16 samples', True)
    """
    Figure = require("matplotlib.figure", extra="evaluation", for_="softshadows.plot.show_samples").Figure

    from . import _validate as v

    center = getattr(light, "center", getattr(light, "position", None))
    if center is None:
        raise ValueError(f"light: expected a softshadows light, got {type(light).__name__}")
    pts = v.array("samples", samples, np.float64, (None, 3)) - np.asarray(center, dtype=np.float64)
    _, _, vt = np.linalg.svd(pts if len(pts) > 1 else np.eye(3), full_matrices=False)
    xy = pts @ vt[:2].T
    if ax is None:
        ax = Figure(figsize=(3, 3), layout="constrained").add_subplot()
    ax.scatter(xy[:, 0], xy[:, 1], s=6)
    ax.set_aspect("equal")
    ax.set_title(title or f"{len(pts)} samples", fontsize=9)
    return ax


def setup(staged, *, ax=None, size: int = 192):
    """A preview of a set-up before a long run: the scene from its camera, lit by the light's
    centre with hard shadows, and the light drawn where it is, its outline and the way it faces,
    with the light frusta of the depth-map methods (``shadow_map``, ``pcss``, ``cssm``,
    ``backprojection``) for the pixels the camera sees: one fitted to them, or one per face of a
    cube around a light among them (a lamp in a room).

    Parameters
    ----------
    staged : Setup
        A :class:`~softshadows.scenes.Setup` (built-in, or from :func:`softshadows.scenes.stage`).
    ax : matplotlib.axes.Axes, optional
        Where to draw, e.g. ``plt.gca()``; by default the axes of a new figure that pyplot does
        not know about.
    size : int
        The preview's larger side in pixels (the camera's aspect is kept).

    Returns
    -------
    matplotlib.axes.Axes
        Its title names the light, says when the light faces away from every receiver or no
        receiver sees its centre (a :class:`~softshadows.SetupWarning`), and counts the light
        frusta.

    Examples
    --------
    >>> import softshadows as ss
    >>> ax = ss.plot.setup(ss.scenes.get("columns"), size=48)
    >>> ax.get_title()
    'RectLight (rect) at [-0.86, 3.06, -1.49], facing the scene, 1 light frustum'
    """
    import warnings

    Figure = require("matplotlib.figure", extra="evaluation", for_="softshadows.plot.setup").Figure

    from . import _validate as v
    from .camera import gbuffer
    from .methods import SetupWarning, ray_traced
    from .scenes import Setup

    v.instance("staged", staged, Setup, "a softshadows.scenes.Setup")
    size = v.positive_int("size", size)
    cam = staged.camera
    scale = size / max(cam.width, cam.height)
    view = cam.with_size(max(1, round(cam.width * scale)), max(1, round(cam.height * scale)))
    gb = gbuffer(staged.scene, view)
    light = staged.light
    center = np.asarray(light.center, dtype=np.float64)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", SetupWarning)
        seen = ray_traced(staged.scene, light, gb, samples=center[None, :].astype(np.float32))
    problems = [w for w in caught if issubclass(w.category, SetupWarning)]
    to_light = center - gb.positions
    to_light /= np.maximum(np.linalg.norm(to_light, axis=-1, keepdims=True), 1e-12)
    shade = 0.25 + 0.75 * np.clip(np.sum(gb.normals * to_light, axis=-1), 0, 1) * seen
    image = np.where(gb.mask[..., None], shade[..., None], np.asarray(NO_HIT))
    if ax is None:
        ax = Figure(figsize=(5, 5 * view.height / view.width), layout="constrained").add_subplot()
    ax.imshow(np.clip(image, 0, 1), interpolation="nearest")
    outline = view.project(_outline(light)) - 0.5  # imshow puts pixel centres on integers
    ax.plot(outline[:, 0], outline[:, 1], color="gold", lw=1.5)
    # The facing arrow reaches a third of the way to the scene's centre.
    tip = center + _facing(light) * np.linalg.norm(staged.scene.bounds.mean(axis=0) - center) / 3
    (cx, cy), (tx, ty) = view.project(np.stack([center, tip])) - 0.5
    ax.plot([cx], [cy], marker="*", color="gold", markersize=10)
    if np.isfinite([cx, cy, tx, ty]).all() and (tx, ty) != (cx, cy):
        ax.annotate("", xy=(tx, ty), xytext=(cx, cy), arrowprops={"arrowstyle": "->", "color": "gold"})
    frusta = _frusta(light, gb)
    for edge in _frustum_edges(frusta):
        xy = view.project(edge) - 0.5
        ax.plot(xy[:, 0], xy[:, 1], color="deepskyblue", lw=0.6, alpha=0.8)
    # The light is often outside the camera's view: widen the canvas to hold it too.
    shown = outline[np.isfinite(outline).all(axis=1)]
    box = np.concatenate([shown, [[-0.5, -0.5], [view.width - 0.5, view.height - 0.5]]])
    lo, hi = box.min(axis=0), box.max(axis=0)
    pad = 0.05 * (hi - lo)
    ax.set_xlim(lo[0] - pad[0], hi[0] + pad[0])
    ax.set_ylim(hi[1] + pad[1], lo[1] - pad[1])
    ax.set_axis_off()
    where = ", ".join(f"{x:.2f}" for x in center)
    messages = " ".join(str(w.message) for w in problems)
    state = ("faces away from every receiver" if "lies behind it" in messages else
             "its centre hidden from every receiver" if "no receiver sees" in messages else "facing the scene")
    count = f"{len(frusta)} light frust{'um' if len(frusta) == 1 else 'a'}"
    ax.set_title(f"{type(light).__name__} ({light.kind}) at [{where}], {state}, {count}", fontsize=8)
    return ax


def _frusta(light, receivers) -> np.ndarray:
    """The depth-map methods' light frusta for ``receivers``, shape (K, 5, 3): each one's eye and
    the four corners of its far plane."""
    return light.native().frusta(receivers.native())


def _frustum_edges(frusta: np.ndarray, steps: int = 64):
    """The edges of every frustum (eye to each far corner, and the far rectangle) as polylines
    of ``steps`` world points, so that the parts behind the camera drop out alone."""
    t = np.linspace(0.0, 1.0, steps)[:, None]
    for eye, *corners in frusta:
        for a, b in [(eye, c) for c in corners] + list(zip(corners, corners[1:] + corners[:1])):
            yield a + t * (b - a)


def _outline(light) -> np.ndarray:
    """Points along a light's silhouette, world units: a rect's edges, a disk's rim, a ball's
    equator and meridian; a point light's position."""
    c = np.asarray(light.center, dtype=np.float64)
    t = np.linspace(0, 2 * np.pi, 49)[:, None]
    if light.kind == "rect":
        u, w = light.u.astype(np.float64), light.v.astype(np.float64)
        return np.stack([c - u - w, c + u - w, c + u + w, c - u + w, c - u - w])
    if light.kind == "disk":
        a, b = light.tangent_frame
        return c + light.radius * (np.cos(t) * a + np.sin(t) * b)
    if light.kind in ("sphere", "ellipsoid"):
        axes = light.radius * np.eye(3) if light.kind == "sphere" else light.axes.astype(np.float64)
        ring = np.cos(t) * axes[0] + np.sin(t) * axes[2]
        return c + np.concatenate([ring, np.cos(t) * axes[1] + np.sin(t) * axes[2]])
    return c[None, :]


def _facing(light) -> np.ndarray:
    """The direction a one-sided light emits toward; 0 for lights that emit every way."""
    if light.kind in ("rect", "disk"):
        return np.asarray(light.normal, dtype=np.float64)
    return np.zeros(3)

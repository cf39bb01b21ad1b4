"""Pictures: visibility and error side by side, the way people compare shadow methods."""

from __future__ import annotations

import numpy as np

__all__ = ["comparison_grid", "show_samples"]

#: The colour of pixels that hit no surface, so they never read as shadow.
NO_HIT = (0.55, 0.68, 0.82)


def _pyplot():
    import matplotlib

    if matplotlib.get_backend().lower() not in ("agg", "module://matplotlib_inline.backend_inline"):
        matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def comparison_grid(reference, results: dict, mask=None, *, path=None, titles: dict | None = None, vmax: float = 0.25):
    """A grid with one column per method: visibility on top, signed error against the reference below.

    Parameters
    ----------
    reference : ndarray, shape (H, W)
        Reference visibility in [0, 1].
    results : dict of str to ndarray, shape (H, W)
        Each method's visibility.
    mask : ndarray, shape (H, W), bool, optional
        Pixels that hit a surface; others are drawn in :data:`NO_HIT` blue on top and gray below.
    path : str or Path, optional
        Where to save the PNG; the figure is returned either way.
    titles : dict of str to str, optional
        Extra text under each column title (e.g. the RMSE).
    vmax : float
        Error magnitude mapped to full red / blue.

    Returns
    -------
    matplotlib.figure.Figure
    """
    from .metrics import _inputs, error_heatmap

    from . import _validate as v

    # Checked here, so that a refusal names this function's arguments, not error_heatmap's.
    reference = v.array("reference", reference, np.float64, (None, None))
    if reference.size == 0:
        raise ValueError(f"reference: expected a non-empty (H, W) image, got shape {reference.shape}")
    if not isinstance(results, dict) or not all(isinstance(k, str) for k in results):
        raise ValueError(f"results: expected a dict of method name to visibility, got {type(results).__name__}")
    results = {k: v.array("results", r, np.float64, reference.shape) for k, r in results.items()}
    if mask is not None:
        mask = _inputs(reference, reference, mask)[2]  # as the metrics take it: bool or 0/1, (H, W), not empty
    vmax = v.positive("vmax", vmax)
    plt = _pyplot()
    cols = {"reference": reference, **results}
    cmap = plt.get_cmap("gray").with_extremes(bad=NO_HIT)
    fig, axes = plt.subplots(2, len(cols), figsize=(2.6 * len(cols), 5.6), squeeze=False)
    for k, (name, vis) in enumerate(cols.items()):
        sub = (titles or {}).get(name, "")
        shown = vis if mask is None else np.where(mask, vis, np.nan)
        axes[0, k].imshow(shown, cmap=cmap, vmin=0, vmax=1, interpolation="nearest")
        axes[0, k].set_title(name + (f"\n{sub}" if sub else ""), fontsize=9)
        axes[1, k].imshow(error_heatmap(vis, reference, mask, vmax=vmax), interpolation="nearest")
        axes[1, k].set_title("error" if name != "reference" else f"error scale ±{vmax}", fontsize=8)
    for ax in axes.ravel():
        ax.set_axis_off()
    fig.tight_layout()
    if path is not None:
        fig.savefig(path, dpi=110)
        plt.close(fig)
    return fig


def show_samples(light, samples, *, ax=None, title: str | None = None):
    """Scatter-plots light samples in the light's plane (the two largest principal axes).

    Parameters
    ----------
    light : a light
    samples : ndarray, shape (S, 3)
    """
    from . import _validate as v

    center = getattr(light, "center", getattr(light, "position", None))
    if center is None:
        raise ValueError(f"light: expected a softshadows light, got {type(light).__name__}")
    pts = v.array("samples", samples, np.float64, (None, 3)) - np.asarray(center, dtype=np.float64)
    plt = _pyplot()
    _, _, vt = np.linalg.svd(pts if len(pts) > 1 else np.eye(3), full_matrices=False)
    xy = pts @ vt[:2].T
    if ax is None:
        _, ax = plt.subplots(figsize=(3, 3))
    ax.scatter(xy[:, 0], xy[:, 1], s=6)
    ax.set_aspect("equal")
    ax.set_title(title or f"{len(pts)} samples", fontsize=9)
    return ax

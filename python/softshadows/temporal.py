"""Temporal accumulation of any method's visibility over a sequence of frames.

A :class:`History` is the state of one method over one sequence: make one per (method,
sequence) and pass it to every frame in order. :func:`accumulate` blends a frame's visibility
with the reprojected history; ``denoised(..., history=h)`` runs the same code as its temporal
stage (``rust/core/src/temporal.rs``).
"""

from __future__ import annotations

import numpy as np

from . import _core
from . import _validate as v
from .camera import GBuffer

__all__ = ["History", "accumulate"]


class History:
    """The state of one method over one sequence of frames, updated in place by each frame.

    It holds the previous frame's accumulated visibility, each pixel's history length in frames
    and the previous frame's G-buffer with its camera (for reprojection). Make one per
    (method, sequence) and pass it to every frame in order, to :func:`accumulate` or to
    ``denoised(..., history=...)``; a method that accumulates reads it and updates it. It
    pickles (a sequence can be resumed in another process).

    Attributes
    ----------
    visibility : ndarray, shape (H, W), float32, or None
        The accumulated visibility of the last frame (None before the first).
    length : ndarray, shape (H, W), float32, or None
        Frames accumulated at each pixel (1 where the last frame restarted it, 0 off the
        surfaces), bilinearly reprojected, so fractional at the edges of a move.
    gbuffer : GBuffer or None
        The last frame's G-buffer, with its camera.
    frames : int
        Frames accumulated so far.

    Examples
    --------
    >>> import pickle
    >>> import softshadows as ss
    >>> h = ss.History()
    >>> h.frames, h.visibility is None
    (0, True)
    >>> pickle.loads(pickle.dumps(h)).frames
    0
    """

    def __init__(self):
        self.visibility = None
        self.length = None
        self.gbuffer = None
        self.frames = 0

    def __repr__(self) -> str:
        if self.gbuffer is None:
            return "History(no frame yet)"
        h, w = self.gbuffer.shape
        return f"History({self.frames} frames, {w}x{h} pixels)"

    def native(self):
        """The previous frame as the core reads it, or None before the first frame."""
        if self.gbuffer is None:
            return None
        return _core.NativeHistory(self.gbuffer.camera.native(), self.gbuffer.native(), self.visibility.reshape(-1),
                                   self.length.reshape(-1))

    def record(self, gbuffer: GBuffer, visibility, length) -> None:
        """Makes ``gbuffer``'s frame, with its accumulated ``visibility`` and history ``length``
        (flat, in pixel order), the previous one."""
        self.visibility = np.asarray(visibility, dtype=np.float32).reshape(gbuffer.shape)
        self.length = np.asarray(length, dtype=np.float32).reshape(gbuffer.shape)
        self.gbuffer = gbuffer
        self.frames += 1


def sequence_inputs(gbuffer, history) -> tuple:
    """Checks a frame's G-buffer and history; returns the core's (receivers, previous frame)."""
    v.instance("gbuffer", gbuffer, GBuffer, "a softshadows.GBuffer (a sequence is a camera's frames)")
    v.instance("history", history, History, "a softshadows.History (one per method and sequence)")
    return gbuffer.native(), history.native()


def temporal_options(alpha, depth_tolerance, normal_tolerance) -> tuple:
    """The temporal stage's options as the core takes them (their ranges: the core)."""
    return v.number("alpha", alpha), v.number("depth_tolerance", depth_tolerance), v.number("normal_tolerance", normal_tolerance)


def accumulate(visibility, gbuffer, history, *, alpha: float = 0.1, depth_tolerance: float = 0.02,
               normal_tolerance: float = 25.0, return_stats: bool = False):
    """Accumulates one frame of any method's visibility over a sequence (temporal filtering).

    The previous frame's accumulated visibility is reprojected into ``gbuffer``: each pixel's
    world point is projected into the previous camera and read bilinearly from the four nearest
    previous pixels, each rejected where its surface disagrees (its point lies off the pixel's
    tangent plane, or the pixel's off its own, by more than ``depth_tolerance`` times the
    distance from the previous eye, or the normals differ by more than ``normal_tolerance``
    degrees). It is blended with this frame by an exponential moving average of weight
    ``alpha`` (Schied et al. 2017, section 4.1), which is the plain mean while a pixel's history
    is shorter than ``1 / alpha`` frames; a pixel whose consistent taps carry less than 1% of
    the bilinear weight (new on screen, disoccluded, or whose surface changed) restarts from
    this frame. ``history`` is then
    updated in place to this frame.

    The G-buffer has no motion vectors: a point of a moving object is looked up where it lay in
    world space, which the tests reject unless the object moves within its own surface.

    Parameters
    ----------
    visibility : array_like, shape (H, W)
        This frame's visibility in [0, 1], from any method, on ``gbuffer``.
    gbuffer : GBuffer
        This frame's G-buffer (its camera may differ from the previous frame's).
    history : History
        The sequence's state; None of the previous frames' is needed besides it.
    alpha : float
        Weight of the current frame in (0, 1] once the history is ``1 / alpha`` frames long.
    depth_tolerance : float
        Largest plane distance between a pixel's point and a previous tap's, relative to the
        point's distance from the previous camera, > 0.
    normal_tolerance : float
        Largest angle between their normals in degrees, in [0, 180].
    return_stats : bool
        Also return the stats dict, whose keys are {stats}: ``reprojected`` counts the hit
        pixels that took a history, ``restarted`` those that did not.

    Returns
    -------
    ndarray, shape (H, W), float32: the accumulated visibility (also ``history.visibility``);
    with ``return_stats`` a ``(visibility, stats)`` tuple.

    References
    ----------
    C. Schied, A. Kaplanyan, C. Wyman, A. Patney, C. R. A. Chaitanya, J. Burgess, S. Liu,
    C. Dachsbacher, A. Lefohn and M. Salvi. Spatiotemporal Variance-Guided Filtering: Real-Time
    Reconstruction for Path-Traced Global Illumination. High-Performance Graphics 2017.

    Examples
    --------
    >>> import numpy as np
    >>> import softshadows as ss
    >>> setup = ss.scenes.get("columns", width=32, height=32)
    >>> gb = ss.gbuffer(setup.scene, setup.camera)
    >>> history = ss.History()
    >>> frames = [ss.ray_traced(setup.scene, setup.light, gb, samples=4, frame=f) for f in range(8)]
    >>> for vis in frames:
    ...     acc = ss.accumulate(vis, gb, history)
    >>> history.frames, bool(np.allclose(acc, np.mean(frames, axis=0), atol=1e-4))  # a still view: the mean
    (8, True)
    """
    receivers, previous = sequence_inputs(gbuffer, history)
    vis = v.array("visibility", visibility, np.float32, gbuffer.shape)
    out, length, stats = _core.accumulate(vis.reshape(-1), receivers, previous,
                                          *temporal_options(alpha, depth_tolerance, normal_tolerance))
    history.record(gbuffer, out, length)
    result = history.visibility.copy()
    return (result, dict(stats)) if return_stats else result


# The stats keys, declared once in the core (rust/core/src/temporal.rs).
accumulate.__doc__ = accumulate.__doc__.replace("{stats}", ", ".join(f"``{key}``" for key in _core.TEMPORAL_STATS))

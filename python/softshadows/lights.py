"""Lights and their sample patterns (docs/design.md section 2).

Every light has ``samples(n, pattern=..., seed=..., frame=...)`` returning world-space light
points of shape (n, 3), so patterns can be plotted and two methods can run on the same samples.
The patterns, their defaults and the per-receiver rotation are documented in
``rust/core/src/light/sampling.rs``; in short:

* ``"uniform"``, ``"stratified"`` (jittered grid, or n-rooks when n is not a square),
* ``"poisson"`` (Poisson disk; minimum distances 0.2456139 and 0.1076681 for 16 and 64 samples,
  Forest et al. 2009, Soft Textured Shadow Volume, section 4.1),
* ``"sobol"`` (a digitally shifted (0,2)-sequence), ``"halton"`` (bases 2, 3, 5).

Methods additionally take ``rotate="per_receiver"`` (a random rotation per receiver: about the
axis of disks, in 3D for spheres, a toroidal shift of a rectangle's parameters) and
``interleaved=k`` (k x k patterns tiled over the screen).
"""

from __future__ import annotations

import abc

import numpy as np

from . import _core, _validate

__all__ = ["PointLight", "RectLight", "DiskLight", "SphereLight", "EllipsoidLight", "PATTERNS"]

#: The sample patterns by name, as the core spells them.
PATTERNS = _core.PATTERNS


class _Light(abc.ABC):
    """Common behaviour: the core light and sampling."""

    kind = ""

    @abc.abstractmethod
    def _to_core(self):
        """This light as the core's, built by the ``_core.NativeLight`` constructor of its kind."""

    def native(self):
        """The core light, built once and cached (the light is treated as immutable, as a Scene is)."""
        cached = self.__dict__.get("_native")
        if cached is None:
            cached = self.__dict__["_native"] = self._to_core()
        return cached

    def __getstate__(self):
        # The core copy stays behind: an unpickled light (in a sweep's worker) builds its own.
        return {k: v for k, v in self.__dict__.items() if k != "_native"}

    @property
    def extent(self) -> float:
        """Largest distance from the center to a point of the light, in world units (computed
        by the core, in float64)."""
        return self.native().extent

    def samples(self, n: int, *, pattern: str = "poisson", seed: int = 0, frame: int = 0) -> np.ndarray:
        """World-space light samples.

        Parameters
        ----------
        n : int
            Number of samples.
        pattern : {"uniform", "stratified", "poisson", "sobol", "halton"}
            Sample pattern over the light's area (volume for spheres and ellipsoids).
        seed : int
            Any non-negative integer; the same seed gives the same samples.
        frame : int
            Temporal jitter (Sintorn et al. 2008, section 4.3): frame ``i > 0`` rotates the whole pattern.

        Returns
        -------
        ndarray, shape (n, 3), float32
        """
        n = _validate.positive_int("n", n)
        return self.native().samples(n, _validate.option("pattern", pattern), _validate.nonneg_int("seed", seed), _validate.nonneg_int("frame", frame))

    def weights(self, samples) -> np.ndarray:
        """Emission weights of world-space light points, shape (S,): 1 without an emission texture."""
        pts = _validate.array("samples", samples, np.float32, (None, 3))
        return self.native().weights(pts)

    def transformed(self, matrix) -> "_Light":
        """The same light moved rigidly: turned and carried along with everything it is made of
        (its sides, normal or axes), its size and emission texture unchanged. The sample
        patterns of point, rect and ellipsoid lights, laid out along their own axes, move with
        them; a disk's and a sphere's keep their orientation in the world.

        Parameters
        ----------
        matrix : array_like, shape (4, 4)
            A rigid transform: a rotation, then a translation (last row 0 0 0 1).

        Returns
        -------
        A light of the same kind.

        Examples
        --------
        >>> import numpy as np
        >>> import softshadows as ss
        >>> quarter_turn = np.array([[0, 0, 1, 0], [0, 1, 0, 0], [-1, 0, 0, 0], [0, 0, 0, 1.0]])  # about +y
        >>> light = ss.RectLight((1, 4, 0), (0.5, 0, 0), (0, 0, 0.25)).transformed(quarter_turn)
        >>> light.center.tolist(), light.u.tolist(), light.area
        ([0.0, 4.0, -1.0], [0.0, 0.0, -0.5], 0.5)
        """
        rotation, offset = _validate.rigid("matrix", matrix)
        return self._moved(rotation, offset)

    @abc.abstractmethod
    def _moved(self, rotation: np.ndarray, offset: np.ndarray) -> "_Light":
        """This light with its points mapped by ``rotation @ x + offset`` (float64)."""


def _facing_axes(center, target) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The unit direction ``d`` from ``center`` to ``target`` and two unit axes ``e1, e2``
    across it with ``e1 x e2 = d`` (float64): a rect light on them faces the target, with ``e1``
    level (across world +y, or +x when ``d`` is nearly vertical)."""
    _validate.vec3("center", center), _validate.vec3("target", target)
    center = np.asarray(center, np.float64)  # unrounded: the built-in scenes' lights keep their bits
    d = np.asarray(target, np.float64) - center
    length = np.linalg.norm(d)
    if not length > 0:
        raise ValueError(f"target: must differ from center {center.tolist()}")
    d /= length
    helper = np.array([0.0, 1.0, 0.0]) if abs(d[1]) < 0.99 else np.array([1.0, 0.0, 0.0])
    e1 = np.cross(d, helper)
    e1 /= np.linalg.norm(e1)
    return d, e1, np.cross(d, e1)


def _emission(emission):
    if emission is None:
        return None
    e = _validate.array("emission", emission, np.float32, (None, None))
    if e.size == 0 or (e < 0).any() or not e.any():
        raise ValueError(f"emission: expected a non-empty (H, W) array of values >= 0, not all zero, got shape {e.shape}")
    return e


class PointLight(_Light):
    """A point light.

    Parameters
    ----------
    position : array_like, shape (3,)

    Examples
    --------
    >>> import softshadows as ss
    >>> light = ss.PointLight((0, 4, 0))
    >>> light.samples(3).tolist()  # every sample is the point itself
    [[0.0, 4.0, 0.0], [0.0, 4.0, 0.0], [0.0, 4.0, 0.0]]
    """

    kind = "point"

    def __init__(self, position):
        self.position = _validate.vec3("position", position)

    @property
    def center(self) -> np.ndarray:
        return self.position

    def _to_core(self):
        return _core.NativeLight.point(self.position)

    def _moved(self, rotation, offset):
        return PointLight(rotation @ self.position + offset)

    def __repr__(self):
        return f"PointLight(position={self.position.tolist()})"


class RectLight(_Light):
    """A one-sided rectangular area light.

    Parameters
    ----------
    center : array_like, shape (3,)
    u, v : array_like, shape (3,)
        Half-extent vectors; the light covers ``center + a u + b v`` for a, b in [-1, 1] and
        emits toward ``normalize(u x v)``.
    emission : array_like, shape (H, W), optional
        Relative emitted radiance over the rectangle: row i covers b in the i-th of H bands from
        -1 to 1, column j the j-th band of a. Samples are weighted by it (a textured light).

    Examples
    --------
    >>> import softshadows as ss
    >>> light = ss.RectLight((0, 4, 0), (0.5, 0, 0), (0, 0, 0.25))  # 1 x 0.5, facing down (u x v)
    >>> light.area, light.normal.tolist()
    (0.5, [0.0, -1.0, 0.0])
    >>> samples = light.samples(64, pattern="sobol", seed=1)
    >>> samples.shape, bool(abs(samples[:, 0]).max() <= 0.5)
    ((64, 3), True)
    """

    kind = "rect"

    def __init__(self, center, u, v, *, emission=None):
        self.center = _validate.vec3("center", center)
        self.u = _validate.vec3("u", u)
        self.v = _validate.vec3("v", v)
        if np.linalg.norm(np.cross(self.u.astype(np.float64), self.v.astype(np.float64))) == 0:
            raise ValueError(f"u: u = {self.u.tolist()} and v = {self.v.tolist()} span zero area")
        self.emission = _emission(emission)
        self.native()  # the core works in float32: it refuses an area that underflows there

    @classmethod
    def look_at(cls, center, target, size, *, emission=None) -> "RectLight":
        """A rect light at ``center`` facing ``target``, ``size`` wide (a square) or ``(width,
        height)``, its width level.

        Examples
        --------
        >>> import softshadows as ss
        >>> light = ss.RectLight.look_at((0, 4, 0), (0, 0, 0), (1.0, 0.5))
        >>> light.normal.tolist(), light.area
        ([0.0, -1.0, 0.0], 0.5)
        """
        width, height = (size, size) if np.ndim(size) == 0 else size
        width, height = _validate.positive("size", width), _validate.positive("size", height)
        _, e1, e2 = _facing_axes(center, target)
        return cls(center, width / 2 * e1, height / 2 * e2, emission=emission)

    @property
    def normal(self) -> np.ndarray:
        n = np.cross(self.u.astype(np.float64), self.v.astype(np.float64))  # float32 u x v overflows for sides ~1e19
        return (n / np.linalg.norm(n)).astype(np.float32)

    @property
    def area(self) -> float:
        return float(4 * np.linalg.norm(np.cross(self.u.astype(np.float64), self.v.astype(np.float64))))

    def _to_core(self):
        return _core.NativeLight.rect(self.center, self.u, self.v, self.emission)

    def _moved(self, rotation, offset):
        return RectLight(rotation @ self.center + offset, rotation @ self.u, rotation @ self.v, emission=self.emission)

    def __repr__(self):
        return f"RectLight(center={self.center.tolist()}, u={self.u.tolist()}, v={self.v.tolist()})"


class DiskLight(_Light):
    """A one-sided disk area light.

    Parameters
    ----------
    center, normal : array_like, shape (3,)
        The disk emits toward ``normal`` (normalized here).
    radius : float
        Radius in world units, > 0.
    emission : array_like, shape (H, W), optional
        Relative radiance over the disk through Shirley's concentric map of the unit square:
        column j covers the j-th of W bands of ``s`` and row i the i-th of H bands of ``t``, where
        the disk point ``center + radius (x t_axis + y b_axis)`` is the concentric image of
        ``(s, t)`` and ``t_axis = normalize(normal x X)`` (``normal x Y`` when ``|normal_x| >= 0.9``),
        ``b_axis = normal x t_axis``.

    Examples
    --------
    >>> import softshadows as ss
    >>> light = ss.DiskLight((0, 4, 0), (0, -2, 0), 0.5)
    >>> light.normal.tolist(), round(light.area, 4)
    ([0.0, -1.0, 0.0], 0.7854)
    """

    kind = "disk"

    def __init__(self, center, normal, radius, *, emission=None):
        self.center = _validate.vec3("center", center)
        n = _validate.vec3("normal", normal).astype(np.float64)  # float32 |n|^2 underflows for |n| ~ 1e-23
        if not np.any(n):
            raise ValueError("normal: must be non-zero")
        self.normal = (n / np.linalg.norm(n)).astype(np.float32)
        self.radius = _validate.positive("radius", radius)
        self.emission = _emission(emission)
        self.native()  # the core works in float32: it refuses a radius that is 0 or inf there

    @classmethod
    def look_at(cls, center, target, radius, *, emission=None) -> "DiskLight":
        """A disk light at ``center`` facing ``target``.

        Examples
        --------
        >>> import softshadows as ss
        >>> ss.DiskLight.look_at((0, 4, 0), (0, 0, 0), 0.5).normal.tolist()
        [0.0, -1.0, 0.0]
        """
        d, _, _ = _facing_axes(center, target)
        return cls(center, d, radius, emission=emission)

    @property
    def area(self) -> float:
        return float(np.pi * self.radius**2)

    @property
    def tangent_frame(self) -> tuple[np.ndarray, np.ndarray]:
        """The orthonormal axes ``(t, b)``, float64 (3,) each, across the disk with
        ``t x b = normal``, as the core orients the disk's samples and its emission texture
        (the concentric map's ``(x, y)`` lands at ``center + radius (x t + y b)``): the Mitsuba
        reference and the analytic shading use the same frame.

        Examples
        --------
        >>> import softshadows as ss
        >>> t, b = ss.DiskLight((0, 4, 0), (0, -1, 0), 0.5).tangent_frame
        >>> (t + 0.0).tolist(), (b + 0.0).tolist()  # + 0.0 turns -0.0 into 0.0
        ([0.0, 0.0, 1.0], [-1.0, 0.0, 0.0])
        """
        t, b = self.native().tangent_frame
        return np.asarray(t, np.float64), np.asarray(b, np.float64)

    def _to_core(self):
        return _core.NativeLight.disk(self.center, self.normal, self.radius, self.emission)

    def _moved(self, rotation, offset):
        return DiskLight(rotation @ self.center + offset, rotation @ self.normal, self.radius, emission=self.emission)

    def __repr__(self):
        return f"DiskLight(center={self.center.tolist()}, normal={self.normal.tolist()}, radius={self.radius})"


class SphereLight(_Light):
    """A volumetric spherical light that emits from its whole volume.

    The spherical light of Sintorn et al. 2008, Sample Based Visibility for Soft Shadows.

    Parameters
    ----------
    center : array_like, shape (3,)
    radius : float
        Radius in world units, > 0.

    Examples
    --------
    >>> import numpy as np
    >>> import softshadows as ss
    >>> light = ss.SphereLight((0, 4, 0), 0.5)
    >>> samples = light.samples(256)
    >>> bool(np.all(np.linalg.norm(samples - light.center, axis=1) <= 0.5 + 1e-6))  # the whole ball emits
    True
    """

    kind = "sphere"

    def __init__(self, center, radius):
        self.center = _validate.vec3("center", center)
        self.radius = _validate.positive("radius", radius)
        self.native()  # the core works in float32: it refuses a radius that is 0 or inf there

    def _to_core(self):
        return _core.NativeLight.sphere(self.center, self.radius)

    def _moved(self, rotation, offset):
        return SphereLight(rotation @ self.center + offset, self.radius)

    def __repr__(self):
        return f"SphereLight(center={self.center.tolist()}, radius={self.radius})"


class EllipsoidLight(_Light):
    """A volumetric ellipsoidal light that emits from its whole volume.

    The points ``center + axes.T @ x`` with ``|x| <= 1`` (Sintorn et al. 2008, Sample Based
    Visibility for Soft Shadows, section 4.1). Its samples are the unit ball's mapped
    by the axes (still volume-uniform). ``alias_free`` bounds its influence regions by the
    paper's virtual scaling: in the frame where the ellipsoid is a sphere, the sphere's bounding
    polygons are exact, and the axes map them back.

    Parameters
    ----------
    center : array_like, shape (3,)
    axes : array_like, shape (3, 3)
        The three semi-axis vectors, one per row, in world units: non-zero and mutually
        orthogonal (relative tolerance 1e-4).

    Examples
    --------
    >>> import numpy as np
    >>> import softshadows as ss
    >>> light = ss.EllipsoidLight((0, 4, 0), [[1.0, 0, 0], [0, 0.2, 0], [0, 0, 0.5]])
    >>> samples = light.samples(256) - light.center
    >>> bool(np.all((samples / [1.0, 0.2, 0.5]) ** 2 @ np.ones(3) <= 1 + 1e-5))
    True
    """

    kind = "ellipsoid"

    def __init__(self, center, axes):
        self.center = _validate.vec3("center", center)
        self.axes = _validate.array("axes", axes, np.float32, (3, 3))
        self.native()  # the core checks the axes and names the argument

    def _to_core(self):
        return _core.NativeLight.ellipsoid(self.center, self.axes)

    def _moved(self, rotation, offset):
        return EllipsoidLight(rotation @ self.center + offset, self.axes @ rotation.T)  # one semi-axis a row

    def __repr__(self):
        return f"EllipsoidLight(center={self.center.tolist()}, axes={self.axes.tolist()})"

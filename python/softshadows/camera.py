"""Cameras, G-buffers and explicit receivers: the points whose visibility methods compute."""

from __future__ import annotations

import abc
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from . import _validate as v
from .scene import Scene

__all__ = ["Camera", "GBuffer", "Receivers", "gbuffer"]


@dataclass(frozen=True, eq=False)  # array fields: field-wise == and hash() would raise
class Camera:
    """A pinhole camera. Build it with :meth:`Camera.look_at`.

    Attributes
    ----------
    eye, target, up : ndarray, shape (3,)
    fov_y : float
        Vertical field of view in degrees.
    width, height : int
        Image size in pixels; row 0 is the top of the image.

    Examples
    --------
    >>> import softshadows as ss
    >>> camera = ss.Camera.look_at((0, 3, 5), (0, 0, 0), fov_y=40.0, width=64, height=48)
    >>> camera.width, camera.height, camera.fov_y
    (64, 48, 40.0)
    >>> camera.with_size(32, 24).height
    24
    """

    eye: np.ndarray
    target: np.ndarray
    up: np.ndarray
    fov_y: float
    width: int
    height: int

    def __post_init__(self):
        # Built directly as well as through look_at: any array_like of 3 finite numbers (a
        # float64 array raised a TypeError in the core's conversion) and checked sizes.
        for name in ("eye", "target", "up"):
            object.__setattr__(self, name, v.vec3(name, getattr(self, name)))
        object.__setattr__(self, "fov_y", v.fov_y(self.fov_y))
        object.__setattr__(self, "width", v.positive_int("width", self.width))
        object.__setattr__(self, "height", v.positive_int("height", self.height))

    @classmethod
    def look_at(cls, eye, target, up=(0, 1, 0), fov_y: float = 45.0, width: int = 512, height: int = 512) -> "Camera":
        """A camera at ``eye`` looking at ``target``.

        Parameters
        ----------
        eye, target, up : array_like, shape (3,)
        fov_y : float
            Vertical field of view in degrees, in (0, 180).
        width, height : int
            Resolution in pixels, >= 1.
        """
        cam = cls(eye, target, up, fov_y, width, height)
        cam.native()  # validates eye != target and up not parallel to the view direction
        return cam

    @classmethod
    def from_matrix(cls, world_from_camera, *, fov_y: float = 45.0, width: int = 512, height: int = 512) -> "Camera":
        """A camera from its 4 x 4 world-from-camera transform, looking down its -z axis with
        +y up (the glTF and OpenGL convention, as a glTF camera node's world matrix gives it).

        Examples
        --------
        >>> import numpy as np
        >>> import softshadows as ss
        >>> m = np.eye(4)
        >>> m[:3, 3] = (0, 1, 5)  # 5 units along +z, looking back down -z
        >>> camera = ss.Camera.from_matrix(m, fov_y=40.0, width=64, height=48)
        >>> camera.eye.tolist(), camera.target.tolist()
        ([0.0, 1.0, 5.0], [0.0, 1.0, 4.0])
        """
        m = v.array("world_from_camera", world_from_camera, np.float64, (4, 4))
        if not np.allclose(m[3], [0, 0, 0, 1]):
            raise ValueError(f"world_from_camera: expected an affine transform (last row 0 0 0 1), got {m[3].tolist()}")
        forward = -m[:3, 2]
        if not np.linalg.norm(forward) > 0:
            raise ValueError("world_from_camera: its z axis is zero")
        eye = m[:3, 3]
        return cls.look_at(eye, eye + forward / np.linalg.norm(forward), m[:3, 1], fov_y, width, height)

    def project(self, points) -> np.ndarray:
        """Continuous pixel coordinates ``(x, y)`` of world points (``y`` down, pixel ``(i, j)``'s
        centre at ``(j + 0.5, i + 0.5)``), NaN for points behind the camera.

        Parameters
        ----------
        points : array_like, shape (N, 3)

        Returns
        -------
        ndarray, shape (N, 2), float64

        Examples
        --------
        >>> import softshadows as ss
        >>> camera = ss.Camera.look_at((0, 0, 5), (0, 0, 0), fov_y=90.0, width=100, height=100)
        >>> camera.project([[0, 0, 0], [5, 0, 0], [0, 0, 9]]).tolist()  # centre, right edge, behind
        [[50.0, 50.0], [100.0, 50.0], [nan, nan]]
        """
        pts = v.array("points", points, np.float64, (None, 3))
        eye, target = self.eye.astype(np.float64), self.target.astype(np.float64)
        forward = (target - eye) / np.linalg.norm(target - eye)
        right = np.cross(forward, self.up.astype(np.float64))
        right /= np.linalg.norm(right)
        up = np.cross(right, forward)
        d = pts - eye
        z = d @ forward
        tan_half = np.tan(np.radians(self.fov_y) / 2)
        with np.errstate(divide="ignore", invalid="ignore"):
            sx = (d @ right) / (z * tan_half * self.width / self.height)
            sy = (d @ up) / (z * tan_half)
        xy = np.stack([(sx + 1) * self.width / 2, (1 - sy) * self.height / 2], axis=1)
        xy[z <= 0] = np.nan
        return xy

    def native(self):
        """The core camera."""
        from . import _core

        return _core.NativeCamera(self.eye, self.target, self.up, self.fov_y, self.width, self.height)

    def with_size(self, width: int, height: int) -> "Camera":
        """The same view at another resolution."""
        return Camera.look_at(self.eye, self.target, self.up, self.fov_y, width, height)

    def transformed(self, matrix) -> "Camera":
        """The same camera moved rigidly: its eye and target carried, its up vector turned.

        Parameters
        ----------
        matrix : array_like, shape (4, 4)
            A rigid transform: a rotation, then a translation (last row 0 0 0 1).

        Examples
        --------
        >>> import numpy as np
        >>> import softshadows as ss
        >>> back = np.eye(4)
        >>> back[:3, 3] = (0, 0, 2)
        >>> camera = ss.Camera.look_at((0, 3, 5), (0, 0, 0), width=64, height=48).transformed(back)
        >>> camera.eye.tolist(), camera.target.tolist(), camera.width
        ([0.0, 3.0, 7.0], [0.0, 0.0, 2.0], 64)
        """
        rotation, offset = v.rigid("matrix", matrix)
        return Camera.look_at(rotation @ self.eye + offset, rotation @ self.target + offset, rotation @ self.up, self.fov_y,
                              self.width, self.height)


class Flat(NamedTuple):
    """Receivers as flat arrays: what the core takes, and what per-receiver code loops over."""

    points: np.ndarray
    """(K, 3) float32 world positions."""
    normals: np.ndarray
    """(K, 3) float32 normals."""
    mask: np.ndarray
    """(K,) bool: whether the receiver is valid (a G-buffer pixel that hit a surface)."""
    width: int
    """Image width (K for explicit receivers)."""
    height: int
    """Image height (1 for explicit receivers)."""


class _ReceiverSet(abc.ABC):
    """What GBuffer and Receivers share: flat arrays and one conversion into the core."""

    @abc.abstractmethod
    def _flat(self) -> Flat:
        """The receivers as flat arrays, the form every method and the core read."""

    def native(self):
        """The core receivers, converted once and cached (the receivers are treated as
        immutable, as a Scene is: a method called again on them does not copy them again)."""
        cached = self.__dict__.get("_native")
        if cached is None:
            from . import _core

            flat = self._flat()
            cached = _core.NativeReceivers(
                v.array("points", flat.points, np.float32, (None, 3), finite=False),
                v.array("normals", flat.normals, np.float32, (None, 3), finite=False),
                np.ascontiguousarray(flat.mask, dtype=bool),
                flat.width,
                flat.height,
            )
            self.__dict__["_native"] = cached
        return cached

    def __getstate__(self):
        # The core copy stays behind: unpickled receivers (in a sweep's worker) convert their own.
        return {k: value for k, value in self.__dict__.items() if k != "_native"}


class Receivers(_ReceiverSet):
    """Explicit receivers: points with normals.

    Parameters
    ----------
    points : array_like, shape (K, 3)
    normals : array_like, shape (K, 3)
        Need not be unit length; must be non-zero.

    Examples
    --------
    >>> import softshadows as ss
    >>> setup = ss.scenes.get("columns", width=16, height=16)
    >>> rx = ss.Receivers([[0, 0, 0], [2.5, 0, 2.5]], [[0, 1, 0], [0, 1, 0]])  # two points on the ground
    >>> vis = ss.ray_traced(setup.scene, setup.light, rx, samples=16)
    >>> vis.shape, vis.dtype
    ((2,), dtype('float32'))
    """

    def __init__(self, points, normals):
        self.points = v.array("points", points, np.float32, (None, 3))
        self.normals = v.array("normals", normals, np.float32, (len(self.points), 3))
        # The length in float32, as the core computes it: |n|^2 under- or overflows there for
        # |n| < 1e-19 or > 1.8e19, and the core would then refuse the normal at the first method.
        with np.errstate(over="ignore", under="ignore"):
            lengths = np.linalg.norm(self.normals, axis=1)
        if len(self.normals) and not np.all(np.isfinite(lengths) & (lengths > 0)):
            raise ValueError("normals: every normal must be non-zero, with a length that squares within float32 (1e-19 to 1.8e19)")
        self.mask = np.ones(len(self.points), dtype=bool)

    @property
    def shape(self) -> tuple:
        return (len(self.points),)

    def _flat(self) -> Flat:
        return Flat(self.points, self.normals, self.mask, len(self.points), 1)


@dataclass(eq=False)
class GBuffer(_ReceiverSet):
    """A G-buffer: what each pixel of a camera sees.

    Attributes
    ----------
    positions : ndarray, shape (H, W, 3), float32
        World position of the visible surface at each pixel center.
    normals : ndarray, shape (H, W, 3), float32
        Unit geometric normals facing the camera.
    mask : ndarray, shape (H, W), bool
        Whether the pixel center hit a surface (metrics are computed over it).
    face_ids : ndarray, shape (H, W), int64
        Global face id of the hit, -1 for none.
    sample_depths : ndarray, shape (H, W, msaa), float32 or None
        Distances along each MSAA sample's ray (inf for no hit), when ``msaa > 1``.
    camera : Camera

    Examples
    --------
    >>> import softshadows as ss
    >>> setup = ss.scenes.get("columns", width=32, height=32)
    >>> gb = ss.gbuffer(setup.scene, setup.camera)
    >>> gb.shape, gb.positions.shape, gb.face_ids.dtype
    ((32, 32), (32, 32, 3), dtype('int64'))
    >>> bool(gb.mask.any()) and bool((gb.face_ids[~gb.mask] == -1).all())
    True
    """

    positions: np.ndarray
    normals: np.ndarray
    mask: np.ndarray
    face_ids: np.ndarray
    sample_depths: np.ndarray | None
    camera: Camera
    _native: object = field(default=None, init=False, repr=False)

    @property
    def shape(self) -> tuple:
        return self.mask.shape

    def __repr__(self) -> str:
        # The arrays are the bulk of a G-buffer: its size and coverage say what a reader needs.
        h, w = self.mask.shape
        msaa = 1 if self.sample_depths is None else self.sample_depths.shape[2]
        return f"GBuffer({w}x{h} pixels, {int(self.mask.sum())} hit, msaa={msaa})"

    def _flat(self) -> Flat:
        h, w = self.mask.shape
        return Flat(self.positions.reshape(-1, 3), self.normals.reshape(-1, 3), self.mask.reshape(-1), w, h)


def gbuffer(scene, camera: Camera, msaa: int = 1) -> GBuffer:
    """Ray-casts a G-buffer of ``scene`` seen by ``camera``.

    Parameters
    ----------
    scene : Scene
    camera : Camera
    msaa : {1, 2, 4, 8, 16}
        Samples per pixel (standard D3D positions); with more than one, ``sample_depths`` is set.

    Returns
    -------
    GBuffer

    Examples
    --------
    >>> from softshadows import gbuffer, scenes
    >>> setup = scenes.get("parallel_plates", width=32, height=24)
    >>> gbuffer(setup.scene, setup.camera, msaa=4)
    GBuffer(32x24 pixels, 655 hit, msaa=4)
    """
    if isinstance(msaa, bool) or not isinstance(msaa, (int, np.integer)) or msaa not in (1, 2, 4, 8, 16):
        raise ValueError(f"msaa: expected one of 1, 2, 4, 8, 16, got {msaa!r}")
    v.instance("scene", scene, Scene, "a softshadows.Scene")
    v.instance("camera", camera, Camera, "a softshadows.Camera")
    msaa = int(msaa)
    pos, nrm, mask, ids, depths = scene.native().gbuffer(camera.native(), msaa)
    h, w = camera.height, camera.width
    return GBuffer(
        pos.reshape(h, w, 3),
        nrm.reshape(h, w, 3),
        mask.reshape(h, w),
        ids.reshape(h, w),
        None if msaa == 1 else depths.reshape(h, w, msaa),
        camera,
    )


def as_receivers(receivers):
    """Accepts a GBuffer or Receivers (or an ``(points, normals)`` tuple) for a method call."""
    if isinstance(receivers, (GBuffer, Receivers)):
        return receivers
    if isinstance(receivers, tuple) and len(receivers) == 2:
        return Receivers(*receivers)
    raise ValueError(f"receivers: expected a GBuffer, a Receivers or a (points, normals) tuple, got {type(receivers).__name__}")

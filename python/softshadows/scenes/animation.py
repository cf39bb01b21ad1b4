"""Sequences: a short animation described as one :class:`Setup` per frame (:func:`sequence`).

All five papers render dynamic scenes in real time, and what a viewer sees first is how a shadow
behaves from one frame to the next: flicker, ghosting, the convergence of temporal jitter.
:func:`softshadows.evaluate_sequence` measures that on the frames made here.

Conventions chosen here:

* Frame ``i`` of ``n`` is at time ``t = i / (n - 1)`` (0 for a single frame): the first frame is
  the set-up as given, the last one has moved along the whole path.
* A path is an :class:`Orbit` (a turn about an axis), a :class:`Slide` (a straight move), or an
  array of shape (frames, 3) of positions, one a frame, that the object is carried to without
  turning: the light's centre, the camera's eye (the camera keeps its direction) or the centre of
  the moving mesh's bounds.
* Every frame is made from the given set-up, not from the previous frame, so that float32
  rounding does not pile up; what does not move is the very same object in every frame (the same
  Scene, its BVH built once, when no mesh moves).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from .. import _validate as _v
from ..scene import Scene
from .setup import Setup

__all__ = ["Orbit", "Slide", "Sequence", "sequence"]


@dataclass(frozen=True)
class Orbit:
    """A turn by ``degrees`` over the whole sequence about ``axis`` through ``center``.

    Parameters
    ----------
    degrees : float
        The angle turned between the first and the last frame (counter-clockwise looking down
        ``axis``).
    axis : array_like, shape (3,)
        The direction of the axis; default world up, +y.
    center : array_like, shape (3,), optional
        A point on the axis. By default the centre of the set-up's occluders for the light, the
        camera's target for the camera, and the centre of its own bounds for a mesh (which then
        spins in place).

    Examples
    --------
    >>> import numpy as np
    >>> import softshadows as ss
    >>> half_turn = ss.scenes.Orbit(180).matrix(0.5, pivot=(0, 0, 0))  # half-way: a quarter turn
    >>> (half_turn[:3, :3] @ [1.0, 0.0, 0.0]).round(6).tolist()
    [0.0, 0.0, -1.0]
    """

    degrees: float
    axis: tuple = (0.0, 1.0, 0.0)
    center: tuple | None = None

    def __post_init__(self):
        axis = _v.array("axis", self.axis, np.float64, (3,))
        if not np.linalg.norm(axis) > 0:
            raise ValueError(f"axis: must be non-zero, got {axis.tolist()}")
        object.__setattr__(self, "degrees", _v.number("degrees", self.degrees))
        object.__setattr__(self, "axis", tuple(axis.tolist()))
        if self.center is not None:
            object.__setattr__(self, "center", tuple(_v.array("center", self.center, np.float64, (3,)).tolist()))

    def matrix(self, t: float, pivot) -> np.ndarray:
        """The rigid transform at time ``t`` in [0, 1], shape (4, 4): the turn by ``t * degrees``
        about the axis through ``center``, or through ``pivot`` when ``center`` is None."""
        k = np.asarray(self.axis) / np.linalg.norm(self.axis)
        angle = np.radians(self.degrees * t)
        cross = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
        rotation = np.eye(3) + np.sin(angle) * cross + (1 - np.cos(angle)) * cross @ cross  # Rodrigues' formula
        c = np.asarray(pivot if self.center is None else self.center, np.float64)
        return _rigid(rotation, c - rotation @ c)


@dataclass(frozen=True)
class Slide:
    """A straight move by ``offset`` over the whole sequence.

    Parameters
    ----------
    offset : array_like, shape (3,)
        The displacement between the first and the last frame, in world units.

    Examples
    --------
    >>> import softshadows as ss
    >>> ss.scenes.Slide((1, 0, 0)).matrix(0.25, pivot=(0, 0, 0))[:3, 3].tolist()
    [0.25, 0.0, 0.0]
    """

    offset: tuple

    def __post_init__(self):
        object.__setattr__(self, "offset", tuple(_v.array("offset", self.offset, np.float64, (3,)).tolist()))

    def matrix(self, t: float, pivot) -> np.ndarray:
        """The translation by ``t * offset`` at time ``t`` in [0, 1], shape (4, 4) (``pivot`` unused)."""
        return _rigid(np.eye(3), t * np.asarray(self.offset))


@dataclass(frozen=True, eq=False)
class Sequence:
    """A short animation: one :class:`Setup` per frame, made by :func:`sequence`.

    Iterating gives the frames' set-ups in order; ``len`` is the number of frames.

    Attributes
    ----------
    name : str
        The label of the sequence in evaluation tables.
    setups : tuple of Setup
        One set-up per frame.
    description : str
        What moves, and along which path.

    Examples
    --------
    >>> import softshadows as ss
    >>> seq = ss.sequence(ss.scenes.get("columns", width=32, height=32), frames=3, camera_path=ss.scenes.Slide((0, 0.5, 0)))
    >>> seq
    Sequence('columns', 3 frames: camera Slide(offset=(0.0, 0.5, 0.0)))
    >>> [round(float(setup.camera.eye[1] - seq[0].camera.eye[1]), 3) for setup in seq]
    [0.0, 0.25, 0.5]
    """

    name: str
    setups: tuple
    description: str = ""

    def __len__(self) -> int:
        return len(self.setups)

    def __getitem__(self, frame: int) -> Setup:
        return self.setups[frame]

    def __iter__(self):
        return iter(self.setups)

    def __repr__(self) -> str:
        return f"Sequence({self.name!r}, {len(self)} frames: {self.description})"


def sequence(setup, *, frames: int = 16, light_path=None, camera_path=None, moving=None, name: str | None = None) -> Sequence:
    """A short animation of a set-up: its light, its camera and any of its meshes moving along paths.

    Parameters
    ----------
    setup : Setup
        The first frame (from :func:`softshadows.scenes.get`, a scene factory or
        :func:`softshadows.scenes.stage`).
    frames : int
        The number of frames.
    light_path, camera_path : Orbit, Slide or array_like of shape (frames, 3), optional
        How the light (its centre, sides and normal alike) and the camera move; an array gives
        the light's centre or the camera's eye in each frame. None: they stay.
    moving : dict, optional
        The meshes that move, by name or index in ``setup.scene.meshes``, each to its path (an
        array gives the centre of its bounds in each frame).
    name : str, optional
        Default the set-up's name.

    Returns
    -------
    Sequence

    Examples
    --------
    The light of the columns turns a sixth of the way around them, and the columns slide sideways:

    >>> import numpy as np
    >>> import softshadows as ss
    >>> setup = ss.scenes.get("columns", width=32, height=32)
    >>> seq = ss.sequence(setup, frames=5, light_path=ss.scenes.Orbit(60), moving={"columns": ss.scenes.Slide((0.5, 0, 0))})
    >>> len(seq), seq[0].light.center.tolist() == setup.light.center.tolist()
    (5, True)
    >>> pivot = setup.occluder_bounds.mean(axis=0)
    >>> radius = [float(np.linalg.norm((s.light.center - pivot)[[0, 2]])) for s in seq]
    >>> bool(np.allclose(radius, radius[0], rtol=1e-5))  # the light keeps its distance from the columns' axis
    True
    >>> float(seq[-1].occluders[0].vertices[0, 0] - setup.occluders[0].vertices[0, 0])
    0.5
    >>> seq[2].camera is setup.camera  # what does not move stays the same object
    True
    """
    _v.instance("setup", setup, Setup, "a softshadows.scenes.Setup (from scenes.get, a scene factory or scenes.stage)")
    frames = _v.positive_int("frames", frames)
    times = np.arange(frames) / max(frames - 1, 1)
    lights = _moves("light_path", light_path, times, anchor=setup.light.center, pivot=setup.occluder_bounds.mean(axis=0))
    cameras = _moves("camera_path", camera_path, times, anchor=setup.camera.eye, pivot=setup.camera.target)
    moved = _moving_meshes(setup.scene, moving)
    meshes = {}
    for index, path in moved.items():
        lo, hi = setup.scene.subset([index]).bounds.astype(np.float64)
        meshes[index] = _moves(f"moving[{index}]", path, times, anchor=(lo + hi) / 2, pivot=(lo + hi) / 2)
    setups = []
    for i in range(frames):
        scene = setup.scene
        if meshes:
            scene = Scene([m.transformed(meshes[k][i]) if k in meshes else m for k, m in enumerate(setup.scene.meshes)])
        light = setup.light if lights is None else setup.light.transformed(lights[i])
        camera = setup.camera if cameras is None else setup.camera.transformed(cameras[i])
        setups.append(dataclasses.replace(setup, scene=scene, light=light, camera=camera))
    paths = {"light": light_path, "camera": camera_path, **{f"mesh {setup.scene.meshes[k].name or k}": p for k, p in moved.items()}}
    what = "; ".join(f"{thing} {_describe(path)}" for thing, path in paths.items() if path is not None)
    return Sequence(setup.name if name is None else str(name), tuple(setups), what or "static")


def _moves(argument: str, path, times, *, anchor, pivot) -> list | None:
    """One rigid transform per frame for ``path`` (None for no path): an Orbit or Slide at each
    time, or the translation carrying ``anchor`` to each of an array's positions."""
    if path is None:
        return None
    if isinstance(path, (Orbit, Slide)):
        return [path.matrix(t, pivot) for t in times]
    if isinstance(path, (str, bytes)) or not hasattr(path, "__len__"):
        raise ValueError(f"{argument}: expected a scenes.Orbit, a scenes.Slide or positions of shape ({len(times)}, 3), "
                         f"got {path!r}")
    positions = _v.array(argument, path, np.float64, (len(times), 3))
    return [_rigid(np.eye(3), p - np.asarray(anchor, np.float64)) for p in positions]


def _moving_meshes(scene, moving) -> dict:
    """``moving`` with each key resolved to its mesh's index."""
    if moving is None:
        return {}
    if not isinstance(moving, dict):
        raise ValueError(f"moving: expected a dict of mesh name or index to its path, got {type(moving).__name__}")
    names = [m.name for m in scene.meshes]
    resolved = {}
    for key, path in moving.items():
        if isinstance(key, str) and names.count(key) == 1:
            resolved[names.index(key)] = path
        elif isinstance(key, (int, np.integer)) and not isinstance(key, bool) and 0 <= key < len(names):
            resolved[int(key)] = path
        else:
            raise ValueError(f"moving: no single mesh {key!r}; the scene's meshes are {names} (a name, or an index "
                             f"in [0, {len(names)}))")
    return resolved


def _describe(path) -> str:
    return f"through {len(path)} positions" if not isinstance(path, (Orbit, Slide)) else repr(path)


def _rigid(rotation, translation) -> np.ndarray:
    m = np.eye(4)
    m[:3, :3], m[:3, 3] = rotation, translation
    return m

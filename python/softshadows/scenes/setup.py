"""A ready-to-run test case: a scene, a light and a camera (:class:`Setup`)."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from .. import _validate as _v
from ..camera import Camera
from ..scene import Mesh, Scene
from . import primitives

__all__ = ["Setup", "LIGHT_KINDS"]


LIGHT_KINDS = ("rect", "disk", "sphere", "ellipsoid", "point")


@dataclass(frozen=True, eq=False)
class Setup:
    """A ready-to-run test case: scene, light and camera.

    Attributes
    ----------
    name : str
        The scene's name (a key of ``SCENES``).
    scene : Scene
        ``scene.meshes[0]`` is the ground; the other meshes are the occluders.
    light : PointLight, RectLight, DiskLight, SphereLight or EllipsoidLight
        The default light.
    camera : Camera
        A view of the occluders and their shadow on the ground.
    description : str
        What the scene mirrors (paper and figure) and its triangle counts.

    Examples
    --------
    >>> import softshadows as ss
    >>> setup = ss.scenes.get("columns", width=32, height=32)
    >>> setup.name, setup.camera.width, type(setup.light).__name__
    ('columns', 32, 'RectLight')
    >>> [m.name for m in setup.occluders]  # every mesh but the ground
    ['columns']
    """

    name: str
    scene: Scene
    light: object
    camera: Camera
    description: str = ""
    #: Whether ``scene.meshes[0]`` is a ground added under the occluders (:func:`stage` can leave
    #: a scene with a floor of its own as it is).
    has_ground: bool = True

    @property
    def ground(self) -> Mesh | None:
        """The ground mesh (``scene.meshes[0]``), or None when the set-up added none."""
        return self.scene.meshes[0] if self.has_ground else None

    @property
    def occluders(self) -> list:
        """The occluder meshes (every mesh but the ground)."""
        return self.scene.meshes[1:] if self.has_ground else list(self.scene.meshes)

    @property
    def occluder_bounds(self) -> np.ndarray:
        """Axis-aligned bounds of the occluders, shape (2, 3): min and max."""
        return primitives.bounds(self.occluders)

    def with_size(self, width: int, height: int) -> "Setup":
        """The same setup seen at another image size."""
        return dataclasses.replace(self, camera=self.camera.with_size(width, height))

    def with_light(self, light) -> "Setup":
        """The same scene and camera under another light."""
        from ..lights import _Light

        _v.instance("light", light, _Light, "a PointLight, RectLight, DiskLight, SphereLight or EllipsoidLight")
        return dataclasses.replace(self, light=light)

    def __repr__(self) -> str:
        return f"Setup({self.name!r}, {self.scene!r}, {self.light!r})"

"""The bunny, bone and cow: real meshes read at run time from the sample meshes that the PyPI
package ``pymeshlab`` ships (``pip install "softshadows[models]"``), never copied."""

from __future__ import annotations

import functools
import importlib.util
import os

import numpy as np

from .. import _validate as _v
from ..scene import Mesh
from . import _checks, staging
from .setup import Setup

__all__ = ["MODELS", "load_model"]


#: Model name -> file name in pymeshlab's ``tests/sample_meshes`` folder.
MODELS = {"bunny": "bunny.obj", "bone": "bone.ply", "cow": "cow.obj"}


# Default gap under each model: the bone lies flat (0.18 of its length high), so resting on the
# ground it would cast almost no visible penumbra; it floats like Annen et al. 2008's bone instead.
_MODEL_ELEVATION = {"bunny": 0.0, "bone": 0.3, "cow": 0.0}


def load_model(
    name: str,
    *,
    size: float = 1.0,
    elevation: float | None = None,
    yaw: float = 0.0,
    light: str = "rect",
    light_size: float = 1.0,
    light_position=None,
    light_distance: float = 3.0,
    width: int = 256,
    height: int = 256,
    fov_y: float = 40.0,
    ground_size: float | None = None,
) -> Setup:
    """A real scanned mesh on the ground, read from pymeshlab's sample meshes.

    The meshes stand in for the papers' models: the Stanford bunny (``bunny.obj``, 56,172
    triangles, watertight) for the single detailed closed caster of Sintorn et al. 2008, Annen
    et al. 2008 and Marrs et al. 2018; a
    bone (``bone.ply``, 3,022 triangles, watertight after merging duplicate vertices) for
    Annen et al.'s "foot bone model" (Fig. 9); a cow (``cow.obj``, 5,804 triangles, watertight) for
    an animal-like character with thin legs (Schwarz and Stamminger's dinosaur, Fig. 10; Marrs et
    al.'s characters, Figs. 8-10). The
    files are located with ``importlib.util.find_spec("pymeshlab")`` (pymeshlab itself is not
    imported) and loaded with trimesh, which merges duplicate vertices.

    Parameters
    ----------
    name : {"bunny", "bone", "cow"}
        Which model.
    size : float
        The model is scaled uniformly so that its largest bounding-box extent is ``size`` world
        units, centred on the y axis.
    elevation : float, optional
        Gap between the ground and the model's lowest point, in world units. By default the
        bunny and the cow rest on the ground (0) and the bone, which lies flat, floats 0.3 over it.
    yaw : float
        Rotation about the vertical axis, in degrees, applied before centring.
    light, light_size, light_position, light_distance, width, height, fov_y, ground_size
        See the module docstring. The default light is up and to the -x side.

    Returns
    -------
    Setup
        Meshes ``ground`` and the model (``closed`` from trimesh's ``is_watertight``).

    Raises
    ------
    ModuleNotFoundError
        When pymeshlab is not installed (``pip install "softshadows[models]"``).

    Examples
    --------
    >>> import softshadows as ss
    >>> setup = ss.scenes.load_model("bunny", width=32, height=32)  # needs pip install "softshadows[models]"
    >>> [m.name for m in setup.scene.meshes], bool(setup.occluders[0].closed)
    (['ground', 'bunny'], True)
    """
    if not isinstance(name, str) or name not in MODELS:
        raise ValueError(f"name: expected one of {sorted(MODELS)}, got {name!r}")
    size = _checks.length("size", size)
    elevation = _MODEL_ELEVATION[name] if elevation is None else _checks.length("elevation", elevation, allow_zero=True)
    yaw = _v.number("yaw", yaw)
    verts, faces, closed = _load_model_arrays(name)
    c, s = np.cos(np.radians(yaw)), np.sin(np.radians(yaw))
    verts = verts @ np.array([[c, 0.0, -s], [0.0, 1.0, 0.0], [s, 0.0, c]])
    lo, hi = verts.min(axis=0), verts.max(axis=0)
    scale = size / float(np.max(hi - lo))
    verts = (verts - np.array([(lo[0] + hi[0]) / 2, lo[1], (lo[2] + hi[2]) / 2])) * scale
    verts[:, 1] += elevation
    mesh = Mesh(verts, faces, closed=closed, name=name)
    return staging.assemble(
        name,
        [mesh],
        f"pymeshlab sample mesh {MODELS[name]} ({len(faces)} triangles, closed={closed}), "
        + ("resting on the ground." if elevation == 0 else f"{elevation:g} over the ground."),
        light=light, light_size=light_size, light_position=light_position, light_distance=light_distance,
        light_dir=(-60.0, 55.0), camera_dir=(25.0, 30.0),
        width=width, height=height, fov_y=fov_y, ground_size=ground_size,
    )


def scene_factory(model: str):
    def factory(**options) -> Setup:
        return load_model(model, **options)

    factory.__name__ = factory.__qualname__ = model
    factory.__doc__ = f"``load_model({model!r}, **options)``: see :func:`load_model`."
    return factory


def _sample_mesh_dir() -> str:
    """pymeshlab's ``tests/sample_meshes`` folder, located without importing pymeshlab."""
    spec = importlib.util.find_spec("pymeshlab")
    if spec is None:
        raise ModuleNotFoundError(
            "softshadows.scenes.load_model reads the sample meshes shipped with pymeshlab, which is not "
            'installed: pip install "softshadows[models]"',
            name="pymeshlab",
        )
    roots = list(spec.submodule_search_locations or []) or [os.path.dirname(spec.origin or "")]
    for root in roots:
        folder = os.path.join(root, "tests", "sample_meshes")
        if os.path.isdir(folder):
            return folder
    raise FileNotFoundError(
        f"pymeshlab is installed at {roots} but has no tests/sample_meshes folder; reinstall it with "
        'pip install --force-reinstall "softshadows[models]"'
    )


@functools.lru_cache(maxsize=None)
def _load_cached(path: str):
    import trimesh

    mesh = trimesh.load(path, force="mesh")  # process=True merges duplicate vertices
    verts = np.asarray(mesh.vertices, dtype=np.float64)
    faces = np.asarray(mesh.faces, dtype=np.uint32)
    verts.flags.writeable = False
    faces.flags.writeable = False
    return verts, faces, bool(mesh.is_watertight)


def _load_model_arrays(name: str):
    path = os.path.join(_sample_mesh_dir(), MODELS[name])
    if not os.path.isfile(path):
        raise FileNotFoundError(f"{MODELS[name]} is missing from pymeshlab's sample meshes ({path})")
    verts, faces, closed = _load_cached(path)
    return verts.copy(), faces.copy(), closed

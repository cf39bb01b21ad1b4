"""Deterministic procedural test scenes that mirror the five papers' test cases.

Every public factory returns a :class:`Setup`: a :class:`~softshadows.Scene`, an area light and
a camera that frames the occluders *and* their shadows (umbra and penumbra) on the ground, so
that ``gbuffer(setup.scene, setup.camera)`` sees the penumbrae. ``SCENES`` maps a name to its
factory, and ``get(name, **options)`` calls it (the CLI and the evaluation suite use these).

Conventions chosen here (docs/design.md is silent on them):

* World units are metres-like: occluders are about 1 unit across and float about 0.5 unit above
  the ground. y is up. The ground is always ``scene.meshes[0]`` (named ``"ground"``): one square
  of 2 triangles at y = 0 facing +y, centred on the origin, sized to cover the whole shadow with a
  margin (``ground_size`` sets its half-extent). ``scene.meshes[1:]`` are the occluders.
* Closed occluders (``closed=True``) are two-manifold with consistently outward-facing triangles.
* Every factory takes the same keyword-only light and camera options:

  ``light`` : {"rect", "disk", "sphere", "ellipsoid", "point"}
      The light's kind. Rect and disk lights face the occluders' centre; the ellipsoid is a
      tube-like prolate one, its long axis across the direction to the occluders.
  ``light_size`` : float
      Edge length of the square rect light, diameter of a disk or sphere light, long diameter of
      the ellipsoid (its other two are 0.35 of it), ignored for a point light; in world units.
  ``light_position`` : array_like (3,), optional
      The light's centre; by default it is placed at ``light_distance`` from the occluders'
      centre, above and to one side (each factory documents where).
  ``light_distance`` : float
      Distance from the occluders' centre to the default light position.
  ``width``, ``height`` : int
      Image size of the camera (default 256 x 256).
  ``fov_y`` : float
      Vertical field of view in degrees.
  ``ground_size`` : float, optional
      Half-extent of the ground square; by default it covers the framed region with a margin.

* The camera looks from a fixed direction per scene (elevated 30-45 degrees, across the light
  direction so that the shadow is not hidden behind its occluder), shifted and moved back until
  the occluders' vertices and their shadow on the ground, including the penumbra cast from the
  light's extreme points, fit centred in the central 90% of the image. Its up vector is +y.
* Perforated meshes use binary alpha textures (values 0 and 1, float32) and per-vertex uvs
  following docs/design.md section 2 (``alpha[i, j]`` covers u in [j/W, (j+1)/W), v in [i/H, (i+1)/H);
  uvs repeat).
* Everything is deterministic: random scenes use ``numpy.random.default_rng(seed)`` only.

The real meshes of :func:`load_model` are read, never copied, from the sample meshes that the
PyPI package ``pymeshlab`` ships in ``pymeshlab/tests/sample_meshes`` (``bunny.obj``,
``bone.ply``, ``cow.obj``); ``pip install "softshadows[models]"`` installs it.
"""

from __future__ import annotations

from . import primitives
from .animation import Orbit, Sequence, Slide, sequence
from .library import (
    columns,
    fence,
    fence_mesh,
    fence_texture,
    ground_sphere,
    hairball,
    leaf_texture,
    leaves,
    parallel_plates,
    sword,
    torus_knot,
)
from .models import MODELS, load_model, scene_factory
from .setup import LIGHT_KINDS, Setup
from .staging import stage

__all__ = [
    "LIGHT_KINDS",
    "primitives",
    "Orbit",
    "Slide",
    "Sequence",
    "sequence",
    "Setup",
    "SCENES",
    "MODELS",
    "get",
    "ground_sphere",
    "parallel_plates",
    "columns",
    "torus_knot",
    "fence",
    "fence_mesh",
    "leaves",
    "hairball",
    "sword",
    "load_model",
    "stage",
    "fence_texture",
    "leaf_texture",
]


#: Scene name -> factory taking keyword-only options and returning a :class:`Setup`.
SCENES = {
    "ground_sphere": ground_sphere,
    "parallel_plates": parallel_plates,
    "columns": columns,
    "torus_knot": torus_knot,
    "fence": fence,
    "fence_mesh": fence_mesh,
    "leaves": leaves,
    "hairball": hairball,
    "sword": sword,
    **{model: scene_factory(model) for model in MODELS},
}


def get(name: str, **options) -> Setup:
    """Builds the scene registered as ``name`` in :data:`SCENES` with keyword ``options``.

    Parameters
    ----------
    name : str
        One of ``SCENES`` (``"ground_sphere"``, ``"parallel_plates"``, ``"columns"``, ``"torus_knot"``, ``"fence"``,
        ``"fence_mesh"``, ``"leaves"``, ``"hairball"``, ``"sword"``, ``"bunny"``, ``"bone"``, ``"cow"``).
    **options
        Keyword options of that factory, e.g. ``width=128, height=128``.

    Examples
    --------
    >>> import softshadows as ss
    >>> ss.scenes.get("sword", width=32, height=32).name
    'sword'
    >>> sorted(ss.scenes.SCENES)[:4]
    ['bone', 'bunny', 'columns', 'cow']
    """
    try:
        factory = SCENES[name]
    except (KeyError, TypeError):
        raise ValueError(f"name: expected one of {list(SCENES)}, got {name!r}") from None
    return factory(**options)

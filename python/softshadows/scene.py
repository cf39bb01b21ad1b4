"""Scenes: triangle meshes, optionally perforated by a binary alpha texture (docs/design.md section 2)."""

from __future__ import annotations

import os
import warnings
from pathlib import Path

import numpy as np

from . import _validate as v

__all__ = ["Mesh", "Scene", "load"]

#: The formats :func:`load` reads, by extension (all through trimesh).
FORMATS = (".obj", ".ply", ".stl", ".off", ".gltf", ".glb")


class Mesh:
    """A triangle mesh, optionally perforated by an alpha texture.

    Parameters
    ----------
    vertices : array_like, shape (N, 3)
        Vertex positions in world units; converted to float32.
    faces : array_like, shape (M, 3)
        Vertex indices of each triangle; converted to uint32.
    uvs : array_like, shape (N, 2), optional
        Per-vertex texture coordinates; they wrap (repeat).
    alpha : array_like, shape (H, W), optional
        Alpha texture in [0, 1]; a texel with alpha >= 0.5 is opaque. ``alpha[i, j]`` covers
        u in [j/W, (j+1)/W) and v in [i/H, (i+1)/H) (row 0 is v = 0); lookups are nearest-texel.
        Requires ``uvs``.
    closed : bool
        The mesh is two-manifold and closed; methods may then let only light back-facing
        triangles cast shadows and skip their depth bias.
    name : str, optional
        A label for reports.

    Examples
    --------
    >>> from softshadows import Mesh
    >>> Mesh([[0, 0, 0], [1, 0, 0], [0, 0, 1]], [[0, 1, 2]], name="ground")
    Mesh('ground', 3 vertices, 1 face, closed=False)
    >>> Mesh([[0, 0, 0], [1, 0, 0], [0, 0, 1]], [[0, 1, 2]], uvs=[[0, 0], [1, 0], [0, 1]], alpha=[[1, 0]])
    Mesh(3 vertices, 1 face, alpha 1x2, closed=False)
    """

    def __init__(self, vertices, faces, *, uvs=None, alpha=None, closed: bool = False, name: str | None = None):
        self.vertices = v.array("vertices", vertices, np.float32, (None, 3))
        self.faces = v.array("faces", faces, np.uint32, (None, 3))
        if self.faces.size and int(self.faces.max()) >= len(self.vertices):
            bad = int(np.argmax(self.faces.max(axis=1) >= len(self.vertices)))
            raise ValueError(
                f"faces: face {bad} = {self.faces[bad].tolist()} indexes past the {len(self.vertices)} vertices"
            )
        if alpha is not None and uvs is None:
            raise ValueError("uvs: a perforated mesh (alpha=...) needs per-vertex uvs of shape (N, 2)")
        self.uvs = None if uvs is None else v.array("uvs", uvs, np.float32, (len(self.vertices), 2))
        self.alpha = None if alpha is None else v.array("alpha", alpha, np.float32, (None, None))
        if self.alpha is not None and self.alpha.size == 0:
            raise ValueError(f"alpha: expected a non-empty (H, W) texture, got shape {self.alpha.shape}")
        if self.alpha is not None and (self.alpha.min() < 0 or self.alpha.max() > 1):
            raise ValueError(f"alpha: values must be in [0, 1], got [{self.alpha.min():g}, {self.alpha.max():g}]; "
                             "rescale an 8-bit texture by 1/255")
        self.closed = v.flag("closed", closed)
        self.name = name

    @property
    def perforated(self) -> bool:
        """Whether the mesh has an alpha texture."""
        return self.alpha is not None

    def transformed(self, matrix) -> "Mesh":
        """The same mesh moved rigidly (its faces, uvs, alpha texture, ``closed`` and name kept).

        Parameters
        ----------
        matrix : array_like, shape (4, 4)
            A rigid transform: a rotation, then a translation (last row 0 0 0 1).

        Examples
        --------
        >>> import numpy as np
        >>> from softshadows import Mesh
        >>> lift = np.eye(4)
        >>> lift[:3, 3] = (0, 2, 0)
        >>> Mesh([[0, 0, 0], [1, 0, 0], [0, 0, 1]], [[0, 1, 2]], name="tri").transformed(lift).vertices[:, 1].tolist()
        [2.0, 2.0, 2.0]
        """
        rotation, offset = v.rigid("matrix", matrix)
        return Mesh(self.vertices @ rotation.T + offset, self.faces, uvs=self.uvs, alpha=self.alpha, closed=self.closed,
                    name=self.name)

    def __repr__(self) -> str:
        parts = [] if self.name is None else [repr(self.name)]
        parts += [_count(len(self.vertices), "vertex", "vertices"), _count(len(self.faces), "face", "faces")]
        if self.perforated:
            parts.append("alpha {}x{}".format(*self.alpha.shape))
        return f"Mesh({', '.join(parts)}, closed={self.closed})"


class Scene:
    """A set of meshes; faces are numbered globally in mesh order (the G-buffer's face ids).

    Parameters
    ----------
    meshes : sequence of Mesh
        At least one triangle in all.

    Examples
    --------
    >>> from softshadows import Mesh, Scene
    >>> tri = Mesh([[0, 0, 0], [1, 0, 0], [0, 0, 1]], [[0, 1, 2]], name="ground")
    >>> Scene([tri, Mesh(tri.vertices + [0, 1, 0], tri.faces)])
    Scene(2 meshes ['ground', None], 2 faces)
    """

    def __init__(self, meshes):
        if isinstance(meshes, Mesh):
            meshes = [meshes]
        elif isinstance(meshes, (str, bytes)) or not hasattr(meshes, "__iter__"):  # list(None) would raise a bare TypeError
            raise ValueError(f"meshes: expected a non-empty list of softshadows.Mesh, got {meshes!r}")
        meshes = list(meshes)
        if not meshes or not all(isinstance(m, Mesh) for m in meshes):
            raise ValueError(f"meshes: expected a non-empty list of softshadows.Mesh, got {meshes!r}")
        if sum(len(m.faces) for m in meshes) == 0:
            raise ValueError("meshes: the scene has no triangles")
        self.meshes = meshes
        self._native = None
        self._bounds = None

    @classmethod
    def from_trimesh(cls, mesh, *, alpha=None, closed: bool | None = None, folder=None) -> "Scene":
        """Builds a scene from a ``trimesh.Trimesh`` or ``trimesh.Scene``, alpha-tested materials
        becoming perforated meshes.

        A glTF material with ``alphaMode: MASK`` keeps the texels whose base-colour alpha times
        the factor's reaches ``alphaCutoff`` (default 0.5); ``BLEND`` is cut out at 0.5, with a
        :class:`SetupWarning` (a blended surface has no binary coverage). An OBJ material's
        ``map_d`` (its alpha channel, or its grey level) times ``d`` is cut out at 0.5. The
        textures are turned to this library's convention (row 0 at v = 0; image files put the
        top row, v = 1, first).

        Parameters
        ----------
        mesh : trimesh.Trimesh or trimesh.Scene
            A scene is flattened with its node transforms applied (``Scene.dump``); its paths and
            point clouds are left out.
        alpha : array_like, shape (H, W), optional
            An alpha texture for every mesh, which then needs uvs (``mesh.visual.uv``), instead
            of the materials'.
        closed : bool, optional
            Overrides the default of ``mesh.is_watertight`` per mesh.
        folder : str or os.PathLike, optional
            Where the texture files named by OBJ materials (``map_d``) lie; :func:`load` passes
            the file's folder. Without it an OBJ ``map_d`` is an error.

        Examples
        --------
        >>> import trimesh
        >>> from softshadows import Scene
        >>> Scene.from_trimesh(trimesh.creation.box())
        Scene(1 mesh [None], 12 faces)
        """
        import trimesh

        if isinstance(mesh, trimesh.Scene):
            # Paths and point clouds in a scene have no faces and cast no shadows.
            parts = [g for g in mesh.dump(concatenate=False) if isinstance(g, trimesh.Trimesh)]
        elif isinstance(mesh, trimesh.Trimesh):
            parts = [mesh]
        else:
            raise ValueError(f"mesh: expected a trimesh.Trimesh or trimesh.Scene, got {type(mesh).__name__}")
        meshes = []
        for part in parts:
            uvs = getattr(part.visual, "uv", None)
            texture = alpha if alpha is not None else _material_alpha(part, folder)
            meshes.append(
                Mesh(
                    part.vertices,
                    part.faces,
                    uvs=None if texture is None else uvs,
                    alpha=texture,
                    closed=bool(part.is_watertight) if closed is None else closed,
                    name=getattr(part.metadata, "get", lambda k: None)("name"),
                )
            )
        return cls(meshes)

    def __getstate__(self):
        # The core copy and its BVH stay behind: an unpickled scene (in a sweep's worker process)
        # builds its own on first use.
        return {**self.__dict__, "_native": None}

    def subset(self, meshes) -> "Scene":
        """A scene of some of these meshes (the same Mesh objects), e.g. the shadow casters.

        Parameters
        ----------
        meshes : sequence of int or str
            Mesh indices or mesh names, in any order; the scene keeps this scene's order.
        """
        picked = set()
        names = [m.name for m in self.meshes]
        if isinstance(meshes, (str, int, np.integer)) or not hasattr(meshes, "__iter__"):
            raise ValueError(f"meshes: expected a sequence of mesh names or indices, got {meshes!r}")
        for key in meshes:
            if isinstance(key, str):
                if key not in names:
                    raise ValueError(f"meshes: no mesh named {key!r}; the scene has {names}")
                picked.add(names.index(key))
            elif isinstance(key, (int, np.integer)) and not isinstance(key, bool) and 0 <= key < len(self.meshes):
                picked.add(int(key))
            else:
                raise ValueError(f"meshes: expected mesh names or indices in [0, {len(self.meshes)}), got {key!r}")
        return Scene([m for i, m in enumerate(self.meshes) if i in picked])

    @property
    def bounds(self) -> np.ndarray:
        """Axis-aligned bounds of the referenced vertices, shape (2, 3): min and max.

        Computed once (the scene is treated as immutable, see :meth:`native`); a copy is returned.
        """
        if self._bounds is None:
            pts = np.concatenate([m.vertices[m.faces.reshape(-1)] for m in self.meshes if len(m.faces)])
            self._bounds = np.stack([pts.min(axis=0), pts.max(axis=0)])
        return self._bounds.copy()

    @property
    def epsilon(self) -> float:
        """The default shadow-ray offset along the receiver normal: 1e-4 x the bounds' diagonal.

        Computed by the core (``auto_epsilon`` in ``rust/core/src/methods/ray_traced.rs``) in
        float64, once per scene; ``ray_traced`` and the Mitsuba reference use the same value
        (docs/design.md section 3).
        """
        return self.native().epsilon

    @property
    def num_faces(self) -> int:
        """Total number of triangles."""
        return sum(len(m.faces) for m in self.meshes)

    def native(self):
        """The core scene with its BVH, built once and cached (the scene is treated as immutable)."""
        if self._native is None:
            from . import _core

            self._native = _core.NativeScene(
                [(m.vertices, m.faces, m.uvs, m.alpha, m.closed) for m in self.meshes]
            )
        return self._native

    def __repr__(self) -> str:
        shown = ", ".join(repr(m.name) for m in self.meshes[:_NAMES_SHOWN]) + (", ..." if len(self.meshes) > _NAMES_SHOWN else "")
        meshes = _count(len(self.meshes), "mesh", "meshes")
        return f"Scene({meshes} [{shown}], {_count(self.num_faces, 'face', 'faces')})"


#: Mesh names a Scene's repr lists before "...".
_NAMES_SHOWN = 4


def _count(n: int, one: str, many: str) -> str:
    """``n`` with the noun in the singular or plural: "1 face", "12 faces"."""
    return f"{n} {one if n == 1 else many}"


def load(path, *, closed: bool | None = None) -> Scene:
    """Reads a scene from a mesh file: OBJ (with its MTL), PLY, STL, OFF, glTF or GLB, through
    trimesh, node transforms applied, meshes named as in the file, alpha-tested materials as
    perforated meshes (see :meth:`Scene.from_trimesh`).

    Parameters
    ----------
    path : str or os.PathLike
        The file; its extension names the format (one of :data:`FORMATS`).
    closed : bool, optional
        Overrides, for every mesh, whether it is closed (default: watertight meshes are).

    Returns
    -------
    Scene

    Raises
    ------
    FileNotFoundError
        When ``path`` does not exist.
    ValueError
        When its extension is not one of :data:`FORMATS`, or trimesh cannot read it (the
        message names the path and trimesh's reason), or it holds no triangles.

    Examples
    --------
    >>> import os, tempfile
    >>> import trimesh
    >>> import softshadows as ss
    >>> folder = tempfile.TemporaryDirectory()
    >>> path = os.path.join(folder.name, "box.glb")
    >>> _ = trimesh.Scene({"box": trimesh.creation.box()}).export(path)
    >>> scene = ss.load(path)
    >>> scene, scene.meshes[0].closed
    (Scene(1 mesh ['box'], 12 faces), True)
    """
    return _read(path, closed=closed)[0]


def _read(path, *, closed: bool | None = None):
    """:func:`load`'s scene, and the file's camera (a glTF camera node) as a
    :class:`~softshadows.Camera` at its own field of view and 256 pixels wide, or None."""
    import trimesh

    from .camera import Camera

    path = Path(os.fspath(path))
    if not path.exists():
        raise FileNotFoundError(f"path: {path} does not exist")
    if path.suffix.lower() not in FORMATS:
        raise ValueError(f"path: {path} has the extension {path.suffix!r}; load reads {', '.join(FORMATS)}")
    try:
        loaded = trimesh.load(path, force="scene")
    except Exception as err:  # trimesh raises what its parsers raise
        raise ValueError(f"path: trimesh could not read {path}: {type(err).__name__}: {err}") from None
    if not any(isinstance(g, trimesh.Trimesh) and len(g.faces) for g in loaded.geometry.values()):
        raise ValueError(f"path: {path} holds no triangles (point clouds and lines cast no shadows)")
    scene = Scene.from_trimesh(loaded, closed=closed, folder=path.parent)
    if not loaded.has_camera:
        return scene, None
    fov_x, fov_y = (float(f) for f in loaded.camera.fov)
    width = 256
    height = max(1, round(width * np.tan(np.radians(fov_y) / 2) / np.tan(np.radians(fov_x) / 2)))
    return scene, Camera.from_matrix(loaded.camera_transform, fov_y=fov_y, width=width, height=height)


def _material_alpha(part, folder) -> np.ndarray | None:
    """The binary alpha texture (this library's orientation) of a trimesh part's alpha-tested
    material, or None for an opaque one."""
    from trimesh.visual.material import PBRMaterial, SimpleMaterial

    material = getattr(part.visual, "material", None)
    if getattr(part.visual, "uv", None) is None:
        return None
    if isinstance(material, PBRMaterial):
        return _gltf_alpha(material)
    if isinstance(material, SimpleMaterial) and "map_d" in material.kwargs:
        return _obj_alpha(material, folder)
    return None


def _gltf_alpha(material) -> np.ndarray | None:
    """glTF 2.0's alpha coverage: the base-colour texture's alpha times the factor's, against
    ``alphaCutoff`` under ``MASK`` and 0.5 under ``BLEND``."""
    mode = material.alphaMode
    if mode not in ("MASK", "BLEND"):
        return None
    from .methods import SetupWarning

    if mode == "BLEND":
        warnings.warn(f"material {material.name!r}: alphaMode BLEND has no binary coverage; cut out at alpha 0.5",
                      SetupWarning, stacklevel=5)
    cutoff = 0.5 if mode == "BLEND" or material.alphaCutoff is None else float(material.alphaCutoff)
    factor = 1.0 if material.baseColorFactor is None else float(material.baseColorFactor[3]) / 255.0
    texture = material.baseColorTexture
    coverage = np.ones((1, 1)) if texture is None else _image_alpha(texture)
    return _cut(coverage * factor, cutoff)


def _obj_alpha(material, folder) -> np.ndarray:
    """An OBJ material's ``map_d`` times its ``d``, cut out at 0.5."""
    from PIL import Image

    name = " ".join(material.kwargs["map_d"])
    if folder is None:
        raise ValueError(f"folder: material {material.name!r} names the map_d texture {name!r}; pass the folder it "
                         "lies in (softshadows.load passes the file's)")
    try:
        image = Image.open(Path(folder) / name)
    except OSError as err:
        raise ValueError(f"path: the map_d texture {name!r} of material {material.name!r} cannot be read: {err}") from None
    dissolve = float(material.kwargs.get("d", ["1"])[0])
    return _cut(_image_alpha(image, grey=True) * dissolve, 0.5)


def _image_alpha(image, *, grey: bool = False) -> np.ndarray:
    """A PIL image's alpha channel in [0, 1] (with ``grey``, its grey level when it has none)."""
    if "A" in image.getbands():
        return np.asarray(image.getchannel("A"), dtype=np.float64) / 255.0
    if grey:
        return np.asarray(image.convert("L"), dtype=np.float64) / 255.0
    return np.ones((image.height, image.width))


def _cut(coverage: np.ndarray, cutoff: float) -> np.ndarray:
    """Binary alpha from ``coverage`` (image rows, top first) in this library's orientation."""
    return np.ascontiguousarray(np.flipud(coverage >= cutoff), dtype=np.float32)

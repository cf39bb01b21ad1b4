"""softshadows: real-time soft-shadow algorithms from five research papers, run on numpy scenes
and measured against exact (ray-traced) and path-traced (Mitsuba 3) references.

Quick start::

    import softshadows as ss
    setup = ss.scenes.load_model("bunny")          # or ss.scenes.fence(), ss.scenes.columns(), ...
    gb = ss.gbuffer(setup.scene, setup.camera)
    vis = ss.ray_traced(setup.scene, setup.light, gb, samples=64)

See DESIGN.md for the data model and the definition of visibility.
"""

import os as _os

import numpy as _np

from . import _core, _validate, envmap, evaluation, io, metrics, plot, reference, scenes, shading
from .camera import Camera, GBuffer, Receivers, gbuffer
from .envmap import environment
from .evaluation import evaluate, sweep
from .gpu import gpu_info
from .lights import DiskLight, EllipsoidLight, PointLight, RectLight, SphereLight
from .methods import METHODS, alias_free, backprojection, cssm, dcs, mvr, pcss, penumbra_wedge, ray_traced, resolve_msaa, shadow_map, stsv, vwss
from .scene import Mesh, Scene

__version__ = "0.1.0"

from . import claims  # noqa: E402  (its measurements call the methods above)


def set_memory_limit(bytes: int | None) -> None:
    """Caps the working memory a call may plan to allocate (``None`` restores 75% of RAM).

    A call whose estimate exceeds it raises ``MemoryError`` before allocating. ``bytes`` must be
    in [1, 2**64 - 1] (the core reads 0 as "restore the default", so 0.5 must not round to it).
    """
    if bytes is None:
        _core.set_memory_limit(0)
        return
    if isinstance(bytes, (int, _np.integer)) and not isinstance(bytes, (bool, _np.bool_)):
        value = int(bytes)  # exact: float(2**64 - 1) rounds up to 2**64
    else:
        value = _validate.positive("bytes", bytes)  # refuses strings and bools (True is not 1 byte)
    if not 1 <= value < 2**64:
        raise ValueError(f"bytes: must be in [1, 2**64 - 1], got {bytes!r}")
    _core.set_memory_limit(int(value))


def memory_limit() -> int:
    """The current memory limit in bytes."""
    return int(_core.memory_limit())


#: The most worker threads ``set_num_threads`` takes: a pool of 10^5 threads takes minutes to
#: start and can exhaust the system's thread limit, which then fails other processes too.
MAX_THREADS = 1024


def set_num_threads(threads: int | None) -> None:
    """Sets the worker threads of every heavy call (``None`` or 0: one per core).

    Results do not depend on it: every method's output is the same bits for any thread count.
    ``threads`` is at most :data:`MAX_THREADS` (1024).
    """
    _core.set_num_threads(0 if threads is None else _validate.nonneg_int("threads", threads, maximum=MAX_THREADS))


def num_threads() -> int:
    """The worker threads of every heavy call."""
    return int(_core.num_threads())


# A forked child has none of the parent's worker threads: it builds its own pool on first use
# (as Hugging Face's tokenizers does after fork).
if hasattr(_os, "register_at_fork"):
    _os.register_at_fork(after_in_child=_core.after_fork_in_child)


__all__ = [
    "alias_free",
    "claims",
    "evaluate",
    "sweep",
    "backprojection",
    "dcs",
    "penumbra_wedge",
    "stsv",
    "resolve_msaa",
    "Camera",
    "DiskLight",
    "GBuffer",
    "METHODS",
    "Mesh",
    "PointLight",
    "Receivers",
    "RectLight",
    "Scene",
    "SphereLight",
    "EllipsoidLight",
    "gbuffer",
    "gpu_info",
    "io",
    "envmap",
    "evaluation",
    "environment",
    "metrics",
    "plot",
    "reference",
    "scenes",
    "shading",
    "cssm",
    "memory_limit",
    "mvr",
    "pcss",
    "ray_traced",
    "set_memory_limit",
    "set_num_threads",
    "num_threads",
    "shadow_map",
    "vwss",
]

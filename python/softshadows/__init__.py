"""softshadows: real-time soft-shadow algorithms from five research papers, run on numpy scenes
and measured against exact (ray-traced) and path-traced (Mitsuba 3) references.

Quick start::

    import softshadows as ss
    setup = ss.scenes.load_model("bunny")          # or ss.scenes.fence(), ss.scenes.columns(), ...
    gb = ss.gbuffer(setup.scene, setup.camera)
    vis = ss.ray_traced(setup.scene, setup.light, gb, samples=64)

See docs/design.md in the repository for the data model (section 2) and the definition of
visibility (section 3).
"""

import os as _os

import numpy as _np

from . import _core, _validate, envmap, evaluation, io, metrics, plot, reference, scenes, shading
from .camera import Camera, GBuffer, Receivers, gbuffer
from .envmap import environment
from .evaluation import evaluate, evaluate_sequence, sweep
from .gpu import gpu_info
from .lights import DiskLight, EllipsoidLight, PointLight, RectLight, SphereLight
from .methods import METHODS, SetupWarning, alias_free, backprojection, cssm, dcs, denoised, mvr, pcss, penumbra_wedge, ray_traced, resolve_msaa, shadow_map, stsv, vwss
from .scene import Mesh, Scene, load
from .scenes import sequence
from .temporal import History, accumulate

__version__ = "0.1.0"

from . import claims  # noqa: E402  (its measurements call the methods above)


def set_memory_limit(bytes: int | None) -> None:
    """Caps the working memory a call may plan to allocate (``None`` restores 75% of RAM).

    A call whose estimate exceeds it raises ``MemoryError`` before allocating. ``bytes`` must be
    in [1, 2**64 - 1] (the core reads 0 as "restore the default", so 0.5 must not round to it).

    Examples
    --------
    >>> import softshadows as ss
    >>> setup = ss.scenes.get("columns", width=16, height=16)
    >>> ss.set_memory_limit(1000)
    >>> try:
    ...     ss.ray_traced(setup.scene, setup.light, ss.gbuffer(setup.scene, setup.camera))
    ... except MemoryError:
    ...     print("refused before allocating")
    refused before allocating
    >>> ss.set_memory_limit(None)
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
    """The current memory limit in bytes.

    Examples
    --------
    >>> import softshadows as ss
    >>> ss.set_memory_limit(2**30)
    >>> ss.memory_limit()
    1073741824
    >>> ss.set_memory_limit(None)
    """
    return int(_core.memory_limit())


#: Raised by a call whose estimated work is above :func:`work_limit` (a ``RuntimeError``).
WorkLimitError = _core.WorkLimitError

#: Raised by a method that refuses a valid setup it cannot serve (a ``ValueError``): a light kind
#: (``backprojection`` needs a planar light), an emission texture (the single-map filters), a
#: light among the receivers (``vwss``), an option on the GPU. The message names the methods or
#: options that can. :func:`softshadows.evaluation.evaluate` records it as the method's refusal of
#: the setup; any other error stops the evaluation.
UnsupportedSetup = _core.UnsupportedSetup


def set_work_limit(operations: int | None) -> None:
    """Caps the work a call may plan to do (``None`` restores the default of 10**12 operations).

    Every method estimates its work before starting, as the sum of its main loops: a ray-scene
    query counts 100 operations, a triangle set up for rasterization 50, a depth-map texel, a
    receiver-sample pair or a receiver's look-up in one view 1. The default is on the order of a
    quarter of an hour of one core (a 1024 x 1024 image with 1024 ray-traced samples per pixel is
    about 10**11). A call above the limit raises :class:`WorkLimitError` naming its estimate
    before it computes anything. ``operations`` must be an int in [1, 2**64 - 1].

    Long calls can also be stopped: Ctrl-C (any signal handler that raises) stops a running
    method within a fraction of a second and raises the handler's exception.

    Examples
    --------
    >>> import softshadows as ss
    >>> ss.set_work_limit(10**13)
    >>> ss.work_limit()
    10000000000000
    >>> ss.set_work_limit(None)
    >>> ss.work_limit()
    1000000000000
    """
    if operations is None:
        _core.set_work_limit(0)
        return
    if isinstance(operations, (int, _np.integer)) and not isinstance(operations, (bool, _np.bool_)):
        value = int(operations)
    else:
        value = _validate.positive("operations", operations)
    if not 1 <= value < 2**64:
        raise ValueError(f"operations: must be in [1, 2**64 - 1], got {operations!r}")
    _core.set_work_limit(int(value))


def work_limit() -> int:
    """The current work limit in operations (see :func:`set_work_limit`).

    Examples
    --------
    >>> import softshadows as ss
    >>> ss.work_limit()  # the default
    1000000000000
    """
    return int(_core.work_limit())


#: The most worker threads ``set_num_threads`` takes: a pool of 10^5 threads takes minutes to
#: start and can exhaust the system's thread limit, which then fails other processes too.
MAX_THREADS = 1024


def set_num_threads(threads: int | None) -> None:
    """Sets the worker threads of every heavy call (``None`` or 0: one per core).

    Results do not depend on it: every method's output is the same bits for any thread count.
    ``threads`` is at most :data:`MAX_THREADS` (1024).

    Examples
    --------
    >>> import numpy as np
    >>> import softshadows as ss
    >>> setup = ss.scenes.get("columns", width=16, height=16)
    >>> gb = ss.gbuffer(setup.scene, setup.camera)
    >>> ss.set_num_threads(1)
    >>> one = ss.stsv(setup.scene, setup.light, gb)
    >>> ss.set_num_threads(None)
    >>> bool(np.array_equal(one, ss.stsv(setup.scene, setup.light, gb)))  # the same bits on every core count
    True
    """
    _core.set_num_threads(0 if threads is None else _validate.nonneg_int("threads", threads, maximum=MAX_THREADS))


def num_threads() -> int:
    """The worker threads of every heavy call.

    Examples
    --------
    >>> import softshadows as ss
    >>> ss.set_num_threads(2)
    >>> ss.num_threads()
    2
    >>> ss.set_num_threads(None)
    """
    return int(_core.num_threads())


# A forked child has none of the parent's worker threads, nor its GPU driver's: it builds its own
# pool (as Hugging Face's tokenizers does after fork) and GPU context on first use.
if hasattr(_os, "register_at_fork"):
    _os.register_at_fork(after_in_child=_core.after_fork_in_child)


__all__ = [
    "accumulate",
    "alias_free",
    "claims",
    "evaluate",
    "evaluate_sequence",
    "sweep",
    "backprojection",
    "dcs",
    "denoised",
    "History",
    "penumbra_wedge",
    "stsv",
    "resolve_msaa",
    "Camera",
    "DiskLight",
    "GBuffer",
    "METHODS",
    "SetupWarning",
    "Mesh",
    "PointLight",
    "Receivers",
    "RectLight",
    "Scene",
    "load",
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
    "sequence",
    "shading",
    "cssm",
    "memory_limit",
    "mvr",
    "pcss",
    "ray_traced",
    "set_memory_limit",
    "set_num_threads",
    "set_work_limit",
    "work_limit",
    "WorkLimitError",
    "UnsupportedSetup",
    "num_threads",
    "shadow_map",
    "vwss",
]

"""The GPU backend: the adapter softshadows uses, and the ``backend=`` choice of the methods that
have a GPU path (``rust/core/src/gpu``: wgpu compute pipelines).

The adapter is probed once per process, on the first call of :func:`gpu_info` or of a method
with ``backend="gpu"`` or ``"auto"``. On Linux, Mesa's Vulkan device-select layer (installed with
``mesa-vulkan-drivers``, lavapipe included) connects to the Wayland display during that probe to
choose a default GPU, and libwayland writes ``error: XDG_RUNTIME_DIR is invalid or not set in the
environment.`` to file descriptor 2 for every enumeration when the variable is unset, which it is
on headless machines and in most containers and CI jobs. The probe therefore runs with a private,
empty ``XDG_RUNTIME_DIR`` where none (or a relative one) is set: the connection then fails
silently, as it would on a machine without a display, and the adapter found is the same.
"""

import contextlib
import os
import tempfile
import threading
import warnings

from . import _core

BACKENDS = ("cpu", "gpu", "auto")

#: Held by the first probe of a process, so that no two threads swap the environment at once.
_PROBE_LOCK = threading.Lock()

#: Whether this process has probed the adapter (its context, or its error, is then cached by the
#: core, and the display is not asked again).
_probed = False


def _forget_probe() -> None:
    global _probed
    _probed = False


# A forked child makes its own context (and so probes again), as the core's fork handler says.
os.register_at_fork(after_in_child=_forget_probe)


@contextlib.contextmanager
def _runtime_dir():
    """A private, empty ``XDG_RUNTIME_DIR`` for the duration, where no absolute one is set (see
    the module notes); the variable is restored after."""
    old = os.environ.get("XDG_RUNTIME_DIR")
    if old is not None and old.startswith("/"):
        yield
        return
    # mkdtemp's 0700 directory is what the XDG base directory specification asks of it.
    with tempfile.TemporaryDirectory(prefix="softshadows-runtime-") as private:
        os.environ["XDG_RUNTIME_DIR"] = private
        try:
            yield
        finally:
            if old is None:
                del os.environ["XDG_RUNTIME_DIR"]
            else:
                os.environ["XDG_RUNTIME_DIR"] = old


def _adapter() -> list:
    """``_core.gpu_info()``: the first call of a process creates the context, quietly."""
    global _probed
    if _probed:
        return _core.gpu_info()
    with _PROBE_LOCK:
        if _probed:
            return _core.gpu_info()
        try:
            with _runtime_dir():
                return _core.gpu_info()
        finally:
            _probed = True


def gpu_info() -> dict:
    """The GPU adapter that ``backend="gpu"`` runs on (created on the first call).

    Returns
    -------
    dict
        ``name``, ``backend`` (``"vulkan"``, ``"metal"``, ``"dx12"``), ``device_type`` (``"cpu"``
        for a software rasterizer such as Mesa's lavapipe), ``driver``, and the limits that split
        large inputs into dispatches: ``max_workgroups_per_dimension`` and
        ``max_storage_binding_bytes`` (int); ``timestamp_queries`` (bool): whether the methods'
        stage seconds are the GPU's own execution times of their compute passes (timestamp
        queries) rather than the wall clock around their submissions.

    Raises
    ------
    RuntimeError
        When no adapter exists, saying how to get one (a Vulkan driver; on machines without a GPU,
        Mesa's lavapipe: ``apt-get install mesa-vulkan-drivers``).

    Examples
    --------
    >>> from softshadows.gpu import gpu_info
    >>> try:
    ...     ready = isinstance(gpu_info()["max_workgroups_per_dimension"], int)
    ... except RuntimeError as error:  # no adapter here: the message says how to get one
    ...     ready = "mesa-vulkan-drivers" in str(error)
    >>> ready
    True
    """
    info = dict(_adapter())
    for key in ("max_workgroups_per_dimension", "max_storage_binding_bytes"):
        info[key] = int(info[key])
    info["timestamp_queries"] = info["timestamp_queries"] == "true"
    return info


def resolve_backend(backend: str, method: str) -> str:
    """``"cpu"`` or ``"gpu"`` for ``backend``: ``"auto"`` is the GPU when an adapter exists, else
    the CPU with a warning.

    Parameters
    ----------
    backend : {"cpu", "gpu", "auto"}
        The method's ``backend=`` argument.
    method : str
        The method's name, for the warning.

    Returns
    -------
    str
        ``"cpu"`` or ``"gpu"``. For either GPU choice the adapter is probed here (once per
        process, see the module notes), so that no method creates it unquietly.

    Raises
    ------
    ValueError
        For a ``backend`` not in :data:`BACKENDS`.
    RuntimeError
        For ``"gpu"`` without an adapter, as :func:`gpu_info`.

    Examples
    --------
    >>> from softshadows.gpu import resolve_backend
    >>> resolve_backend("cpu", "vwss")
    'cpu'
    >>> resolve_backend("cuda", "vwss")
    Traceback (most recent call last):
    ...
    ValueError: backend: must be one of 'cpu', 'gpu', 'auto', got 'cuda'
    """
    if backend not in BACKENDS:
        raise ValueError(f"backend: must be one of {', '.join(map(repr, BACKENDS))}, got {backend!r}")
    if backend == "cpu":
        return backend
    try:
        gpu_info()
    except RuntimeError as error:
        if backend == "gpu":
            raise
        warnings.warn(f"{method}: backend='auto' runs on the CPU: {error}", RuntimeWarning, stacklevel=3)
        return "cpu"
    return "gpu"

"""The GPU backend: the adapter softshadows uses, and the ``backend=`` choice of the methods that
have a GPU path (``rust/core/src/gpu``: wgpu compute pipelines)."""

import warnings

from . import _core

BACKENDS = ("cpu", "gpu", "auto")


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
    """
    info = dict(_core.gpu_info())
    for key in ("max_workgroups_per_dimension", "max_storage_binding_bytes"):
        info[key] = int(info[key])
    info["timestamp_queries"] = info["timestamp_queries"] == "true"
    return info


def resolve_backend(backend: str, method: str) -> str:
    """``"cpu"`` or ``"gpu"`` for ``backend``: ``"auto"`` is the GPU when an adapter exists, else
    the CPU with a warning."""
    if backend not in BACKENDS:
        raise ValueError(f"backend: must be one of {', '.join(map(repr, BACKENDS))}, got {backend!r}")
    if backend != "auto":
        return backend
    try:
        gpu_info()
        return "gpu"
    except RuntimeError as error:
        warnings.warn(f"{method}: backend='auto' runs on the CPU: {error}", RuntimeWarning, stacklevel=3)
        return "cpu"

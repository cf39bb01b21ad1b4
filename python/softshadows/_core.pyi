"""Type stubs for the private extension module ``softshadows._core`` (rust/py)."""

from typing import Self, final

import numpy as np
import numpy.typing as npt

__all__ = [
    "NativeCamera",
    "NativeHistory",
    "NativeLight",
    "NativeReceivers",
    "NativeSamples",
    "NativeScene",
    "accumulate",
    "after_fork_in_child",
    "alias_free",
    "backprojection",
    "cssm",
    "cube_solid_angles",
    "dcs",
    "denoised",
    "fit_area_lights",
    "gpu_info",
    "memory_limit",
    "mvr",
    "num_threads",
    "pcss",
    "penumbra_wedge",
    "ray_traced",
    "set_memory_limit",
    "set_num_threads",
    "set_work_limit",
    "work_limit",
    "WorkLimitError",
    "UnsupportedSetup",
    "PATTERNS",
    "STATS",
    "TEMPORAL_STATS",
    "shadow_map",
    "stsv",
    "stsv_volumes",
    "vwss",
]

_F32 = npt.NDArray[np.float32]

@final
class NativeScene:
    def __new__(
        cls,
        meshes: list[tuple[_F32, npt.NDArray[np.uint32], _F32 | None, _F32 | None, bool]],
    ) -> Self: ...
    @property
    def num_faces(self) -> int: ...
    @property
    def epsilon(self) -> float: ...
    def gbuffer(
        self, camera: NativeCamera, msaa: int
    ) -> tuple[_F32, _F32, npt.NDArray[np.bool_], npt.NDArray[np.int64], _F32]: ...

@final
class NativeLight:
    @staticmethod
    def point(center: _F32) -> NativeLight: ...
    @staticmethod
    def rect(center: _F32, u: _F32, v: _F32, emission: _F32 | None = None) -> NativeLight: ...
    @staticmethod
    def disk(center: _F32, normal: _F32, radius: float, emission: _F32 | None = None) -> NativeLight: ...
    @staticmethod
    def sphere(center: _F32, radius: float) -> NativeLight: ...
    @staticmethod
    def ellipsoid(center: _F32, axes: _F32) -> NativeLight: ...
    @property
    def extent(self) -> float: ...
    @property
    def tangent_frame(self) -> tuple[tuple[float, float, float], tuple[float, float, float]] | None: ...
    def samples(self, n: int, pattern: str, seed: int, frame: int) -> _F32: ...
    def weights(self, points: _F32) -> _F32: ...
    def frusta(self, receivers: NativeReceivers) -> _F32: ...

@final
class NativeCamera:
    def __new__(cls, eye: _F32, target: _F32, up: _F32, fov_y: float, width: int, height: int) -> Self: ...

@final
class NativeReceivers:
    def __new__(cls, points: _F32, normals: _F32, mask: npt.NDArray[np.bool_], width: int, height: int) -> Self: ...

@final
class NativeHistory:
    def __new__(cls, camera: NativeCamera, receivers: NativeReceivers, visibility: _F32, length: _F32) -> Self: ...

@final
class NativeSamples:
    @staticmethod
    def generate(
        light: NativeLight,
        n: int,
        pattern: str,
        seed: int,
        interleave: int,
        rotate: bool,
        frame: int,
        receivers: NativeReceivers | None = None,
    ) -> NativeSamples: ...
    @staticmethod
    def explicit(samples: _F32, rotate_seed: int | None = None) -> NativeSamples: ...
    @property
    def count(self) -> int: ...
    @property
    def patterns(self) -> int: ...

def set_num_threads(threads: int) -> None: ...
def num_threads() -> int: ...
def after_fork_in_child() -> None: ...
def set_memory_limit(bytes: int) -> None: ...
def memory_limit() -> int: ...
def set_work_limit(operations: int) -> None: ...
def work_limit() -> int: ...

PATTERNS: tuple[str, ...]
STATS: dict[str, tuple[str, ...]]
TEMPORAL_STATS: tuple[str, ...]

class WorkLimitError(RuntimeError): ...
class UnsupportedSetup(ValueError): ...

def gpu_info() -> list[tuple[str, str]]: ...
def ray_traced(
    scene: NativeScene,
    light: NativeLight,
    receivers: NativeReceivers,
    samples: NativeSamples,
    epsilon: float,
    caster_faces: str,
) -> tuple[_F32, dict[str, float]]: ...
def accumulate(
    visibility: _F32,
    receivers: NativeReceivers,
    history: NativeHistory | None,
    alpha: float,
    depth_tolerance: float,
    normal_tolerance: float,
) -> tuple[_F32, _F32, dict[str, float]]: ...
def denoised(
    scene: NativeScene,
    light: NativeLight,
    receivers: NativeReceivers,
    camera: NativeCamera,
    spp: int,
    seed: int,
    frame: int,
    epsilon: float,
    search_radius: int,
    max_radius: int,
    sigma_z: float,
    sigma_n: float,
    temporal: bool,
    history: NativeHistory | None,
    alpha: float,
    depth_tolerance: float,
    normal_tolerance: float,
) -> tuple[_F32, _F32, _F32, dict[str, float]]: ...
def shadow_map(
    scene: NativeScene,
    light: NativeLight,
    receivers: NativeReceivers,
    resolution: int,
    bias: float | None,
    pcf: int,
    backend: str,
) -> tuple[_F32, dict[str, float]]: ...
def mvr(
    scene: NativeScene,
    light: NativeLight,
    receivers: NativeReceivers,
    samples: NativeSamples,
    resolution: int,
    pcf: int,
    bias: float | None,
    backend: str,
) -> tuple[_F32, dict[str, float]]: ...
def vwss(
    scene: NativeScene,
    light: NativeLight,
    receivers: NativeReceivers,
    samples: NativeSamples,
    resolution: int,
    pcf: int,
    bias: float | None,
    mode: str,
    parallel: str,
    views_per_pass: int,
    cull_backfaces: bool,
    layered: bool,
    precision: str,
    source_view: str,
    point_density: float,
    source_resolution: int | None,
    backend: str,
) -> tuple[_F32, dict[str, float]]: ...
def pcss(
    scene: NativeScene,
    light: NativeLight,
    receivers: NativeReceivers,
    resolution: int,
    blocker_samples: int,
    filter_samples: int,
    bias: float | None,
    near: float | None,
    seed: int,
    backend: str,
) -> tuple[_F32, dict[str, float]]: ...
def cssm(
    scene: NativeScene,
    light: NativeLight,
    receivers: NativeReceivers,
    resolution: int,
    order: int,
    prefilter: str,
    near: float | None,
    offset: float | None,
    scale: float,
    sharpen_a: float,
    sharpen_b: float,
    backend: str,
) -> tuple[_F32, dict[str, float]]: ...
def fit_area_lights(
    cube: _F32, n: int, threshold: float, max_lights: int | None, square: bool
) -> list[tuple[int, int, int, int, int, tuple[float, float, float]]]: ...
def cube_solid_angles(n: int) -> npt.NDArray[np.float64]: ...
def dcs(
    scene: NativeScene,
    light: NativeLight,
    receivers: NativeReceivers,
    samples: NativeSamples,
    epsilon: float,
    resolution: int,
    hull_degree: int,
) -> tuple[_F32, dict[str, float]]: ...
def penumbra_wedge(
    scene: NativeScene,
    light: NativeLight,
    receivers: NativeReceivers,
    samples: NativeSamples,
    epsilon: float,
    resolution: int,
    hull_degree: int,
) -> tuple[_F32, dict[str, float]]: ...
def stsv(
    scene: NativeScene,
    light: NativeLight,
    receivers: NativeReceivers,
    samples: NativeSamples,
    epsilon: float,
    resolution: int,
    hull_degree: int,
    opaque: str,
    two_sided: bool,
) -> tuple[_F32, dict[str, float]]: ...
def stsv_volumes(
    scene: NativeScene, light: NativeLight, receivers: NativeReceivers, hull_degree: int, two_sided: bool
) -> tuple[npt.NDArray[np.uint32], _F32]: ...
def backprojection(
    scene: NativeScene,
    light: NativeLight,
    receivers: NativeReceivers,
    resolution: int,
    occluder: str,
    extend: bool,
    accumulation: str,
    bitmask_side: int,
    accel: str,
    ysm_resolution: int,
    budget: list[float] | None,
    level: int | None,
    blend: bool,
    smoothing: int,
    bias: float | None,
) -> tuple[_F32, _F32, npt.NDArray[np.uint32], dict[str, float]]: ...
def alias_free(
    scene: NativeScene,
    light: NativeLight,
    receivers: NativeReceivers,
    samples: NativeSamples,
    resolution: int,
    caster_faces: str,
    bias: float,
    lut: int | None,
    hull_degree: int,
    restrict_to_penumbra: bool,
    cut_at_supporting_plane: bool,
    backend: str,
) -> tuple[_F32, dict[str, float]]: ...

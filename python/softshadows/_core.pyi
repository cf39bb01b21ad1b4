"""Type stubs for the private extension module ``softshadows._core`` (rust/py)."""

import numpy as np
import numpy.typing as npt

F32 = npt.NDArray[np.float32]

class NativeScene:
    def __init__(
        self,
        meshes: list[tuple[F32, npt.NDArray[np.uint32], F32 | None, F32 | None, bool]],
    ) -> None: ...
    @property
    def num_faces(self) -> int: ...
    def gbuffer(
        self, camera: NativeCamera, msaa: int
    ) -> tuple[F32, F32, npt.NDArray[np.bool_], npt.NDArray[np.int64], F32]: ...

class NativeLight:
    def __init__(
        self,
        kind: str,
        center: F32,
        a: F32 | None,
        b: F32 | None,
        radius: float,
        emission: F32 | None,
        c: F32 | None = None,
    ) -> None: ...
    @property
    def extent(self) -> float: ...
    def samples(self, n: int, pattern: str, seed: int, frame: int) -> F32: ...
    def weights(self, points: F32) -> F32: ...

class NativeCamera:
    def __init__(self, eye: F32, target: F32, up: F32, fov_y: float, width: int, height: int) -> None: ...

class NativeReceivers:
    def __init__(self, points: F32, normals: F32, mask: npt.NDArray[np.bool_], width: int, height: int) -> None: ...

class NativeSamples:
    @staticmethod
    def generate(
        light: NativeLight, n: int, pattern: str, seed: int, interleave: int, rotate: bool, frame: int
    ) -> NativeSamples: ...
    @staticmethod
    def explicit(samples: F32, rotate_seed: int | None = None) -> NativeSamples: ...
    @property
    def count(self) -> int: ...

def set_num_threads(threads: int) -> None: ...
def num_threads() -> int: ...
def after_fork_in_child() -> None: ...
def set_memory_limit(bytes: int) -> None: ...
def memory_limit() -> int: ...
def ray_traced(
    scene: NativeScene, light: NativeLight, receivers: NativeReceivers, samples: NativeSamples, epsilon: float
) -> tuple[F32, dict[str, float]]: ...
def shadow_map(
    scene: NativeScene, light: NativeLight, receivers: NativeReceivers, resolution: int, bias: float | None, pcf: int
) -> tuple[F32, dict[str, float]]: ...
def mvr(
    scene: NativeScene,
    light: NativeLight,
    receivers: NativeReceivers,
    samples: NativeSamples,
    resolution: int,
    pcf: int,
    bias: float | None,
) -> tuple[F32, dict[str, float]]: ...
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
    point_density: float,
    source_resolution: int | None,
) -> tuple[F32, dict[str, float]]: ...
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
) -> tuple[F32, dict[str, float]]: ...
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
) -> tuple[F32, dict[str, float]]: ...
def fit_area_lights(
    cube: F32, n: int, threshold: float, max_lights: int, square: bool
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
) -> tuple[F32, dict[str, float]]: ...
def penumbra_wedge(
    scene: NativeScene,
    light: NativeLight,
    receivers: NativeReceivers,
    samples: NativeSamples,
    epsilon: float,
    resolution: int,
    hull_degree: int,
) -> tuple[F32, dict[str, float]]: ...
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
) -> tuple[F32, dict[str, float]]: ...
def stsv_volumes(
    scene: NativeScene, light: NativeLight, receivers: NativeReceivers, hull_degree: int, two_sided: bool
) -> tuple[npt.NDArray[np.uint32], F32]: ...
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
) -> tuple[F32, F32, dict[str, float]]: ...
def alias_free(
    scene: NativeScene,
    light: NativeLight,
    receivers: NativeReceivers,
    samples: NativeSamples,
    resolution: int,
    casters: str,
    bias: float,
    lut: int | None,
    hull_degree: int,
    restrict_to_penumbra: bool,
) -> tuple[F32, dict[str, float]]: ...

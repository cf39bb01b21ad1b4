"""The option checks of the scene factories: lengths, counts and mesh budgets."""

from __future__ import annotations

from .. import _validate as _v


#: The range of lengths (and the largest light coordinate) the factories take, in world units.
#: The occluders are about 1 unit across; beyond 1e6 float32 coordinates lose the unit's
#: precision (and near 1e38 overflow), below 1e-6 a shape's own differences vanish next to its
#: position (tangents of zero length, NaN frames).
MIN_LENGTH, MAX_LENGTH = 1e-6, 1e6


#: The smallest field of view (degrees) the factories frame a scene with.
MIN_FOV = 0.01


#: Peak bytes per triangle while building a mesh: float64 vertices and int64 faces, their
#: float32/uint32 copies in the Mesh, and the temporaries of the vectorized builders.
BYTES_PER_TRIANGLE = 128.0


def length(name, value, *, allow_zero: bool = False) -> float:
    """A length in world units in [MIN_LENGTH, MAX_LENGTH] (or 0 with ``allow_zero``)."""
    length = _v.positive(name, value, allow_zero=allow_zero, maximum=MAX_LENGTH)
    if 0 < length < MIN_LENGTH:
        raise ValueError(f"{name}: must be at least {MIN_LENGTH:g} world units{' (or 0)' if allow_zero else ''}, got {length:g}")
    return length


def mesh_budget(name: str, what: str, triangles: float, vertices: float, *, extra: float = 0.0) -> None:
    """Refuses a mesh before building it: a ValueError naming the option that sizes it when its
    vertices would not fit uint32 indices, a MemoryError (as the core's) when its estimated peak
    memory exceeds ``softshadows.memory_limit()``. Counts are floats so that 4**(2**70) never
    has to be computed."""
    if vertices > 2**32 - 1:
        raise ValueError(f"{name}: the {what} mesh would have {vertices:.3g} vertices, more than uint32 indices address")
    _v.memory(f"{what} mesh", BYTES_PER_TRIANGLE * triangles + extra)


def at_least(name, value, low) -> int:
    value = _v.positive_int(name, value)
    if value < low:
        raise ValueError(f"{name}: expected an integer >= {low}, got {value}")
    return value

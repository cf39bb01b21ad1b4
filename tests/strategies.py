"""Hypothesis strategies and invariants shared by the property-based tests.

``tests/test_properties.py`` (the methods and the scene model) and
``tests/test_properties_api.py`` (every other public function) draw their adversarial inputs
from here, so that both try the same coordinates, meshes, arrays and bad scalars.

Invariants
----------
Every public call either returns a valid result or refuses: a ``ValueError`` or ``TypeError``
whose message starts with the offending argument's name (``"vertices: ..."``), a
``MemoryError`` that points to ``softshadows.set_memory_limit``, or, for file paths only, an
``OSError`` that names the path. Anything else (IndexError, AttributeError, OverflowError,
RuntimeError, a NaN in a result, a crash) is a bug.
"""

from __future__ import annotations

import collections
import re

import numpy as np
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

import softshadows as ss

# ----------------------------------------------------------------------------------------------
# Counting: how many inputs each public function was given in this run
# ----------------------------------------------------------------------------------------------

#: Public function -> inputs tried in this process (filled by :func:`tried`).
TRIED: collections.Counter = collections.Counter()
#: (public function, outcome) -> count, outcome "result" or the refusal's exception type
#: (filled by :func:`result_or_refusal` for calls given a ``label``).
OUTCOMES: collections.Counter = collections.Counter()


def tried(*functions: str) -> None:
    """Counts one input for each of ``functions`` (called first thing in a property)."""
    TRIED.update(functions)


# ----------------------------------------------------------------------------------------------
# Scalars
# ----------------------------------------------------------------------------------------------

# Coordinates from ordinary to extreme, with NaN and infinities.
COORD = st.one_of(st.floats(-3, 3), st.sampled_from([0.0, 1e-30, -1e-30, 1e30, -1e30, np.nan, np.inf, -np.inf]))
VEC3 = st.tuples(COORD, COORD, COORD)
# Sizes (radii, lengths, intensities): zero, negative, tiny, huge, beyond float32, NaN, inf.
SIZE = st.one_of(
    st.floats(0.05, 4),
    st.sampled_from([0.0, -1.0, 1e-30, 1e-45, 1e-300, 1e6, 1e30, 3.5e38, 1e300, np.nan, np.inf, -np.inf]),
)
# Integers for counts, resolutions and seeds: ordinary, zero, negative, and past every integer
# type of the core (u32, i64, u64), plus near-integers Python would happily truncate.
INT = st.one_of(
    st.integers(-2, 24),
    st.sampled_from([0, -1, 2**31, 2**32 + 1, 2**63, 2**64 - 1, 2**64, 2**70, 10**9]),
    st.sampled_from([np.int64(3), np.uint8(2), np.int32(-4)]),
)
# Mostly-ordinary variants: adversarial only part of the time, so that a property also checks
# the results of valid calls, not only refusals.
ORDINARY_COORD = st.floats(-3, 3)
ORDINARY_VEC3 = st.tuples(ORDINARY_COORD, ORDINARY_COORD, ORDINARY_COORD)
VEC3_MOSTLY = st.one_of(ORDINARY_VEC3, ORDINARY_VEC3, VEC3)
SIZE_MOSTLY = st.one_of(st.floats(0.05, 4), st.floats(0.05, 4), SIZE)
COUNT_MOSTLY = st.one_of(st.integers(1, 16), st.integers(1, 16), INT)
# Values of the wrong kind for any argument.
JUNK = st.sampled_from([None, "x", "", [1, [2, 3]], {"a": 1}, object(), True, 1.5, np.nan, b"\x00", (1, 2), []])


@st.composite
def arguments(draw, **pairs):
    """Keyword arguments from ``name=(ordinary, adversarial)`` pairs: all ordinary in about half
    the examples (so that results get checked, not only refusals), otherwise each drawn from
    its adversarial strategy (which may still give an ordinary value)."""
    ordinary = draw(st.booleans())
    return {name: draw(ok if ordinary else bad) for name, (ok, bad) in pairs.items()}


def junk_or(strategy):
    """``strategy``, sometimes replaced by a value of the wrong kind."""
    return st.one_of(strategy, strategy, strategy, JUNK)


# ----------------------------------------------------------------------------------------------
# Arrays
# ----------------------------------------------------------------------------------------------

ADVERSARIAL_FLOATS = st.one_of(
    st.floats(-2, 2, width=32),
    st.sampled_from([0.0, 1.0, -0.0, 1e-30, 1e30, -1e30, 3.5e38, np.nan, np.inf, -np.inf]),
)
DTYPES = st.sampled_from([np.float32, np.float64, np.float16, np.int32, np.int64, np.uint8, np.bool_])


ORDINARY_FLOATS = st.floats(-2, 2, width=32)


@st.composite
def arrays(draw, shape, *, elements=None, ordinary=ORDINARY_FLOATS, dtypes=DTYPES, layouts=True):
    """An array of ``shape`` (a tuple, or a strategy of tuples), of a random dtype, sometimes
    Fortran-ordered or a strided (non-contiguous) view. Its values are ``elements``; by default
    ``ordinary`` for half the arrays and adversarial (NaN, inf, 1e30, beyond float32) for the rest."""
    shape = draw(shape) if isinstance(shape, st.SearchStrategy) else shape
    if elements is None:
        elements = ADVERSARIAL_FLOATS if draw(st.booleans()) else ordinary
    dtype = np.dtype(draw(dtypes))
    values = draw(hnp.arrays(np.float64, shape, elements=elements))
    with np.errstate(invalid="ignore", over="ignore"):
        if dtype.kind == "b":
            a = np.nan_to_num(values) > 0.5
        elif dtype.kind in "iu":
            info = np.iinfo(dtype)
            a = np.clip(np.nan_to_num(values, posinf=info.max, neginf=info.min), info.min, info.max).astype(dtype)
        else:
            a = values.astype(dtype)
    if layouts:
        layout = draw(st.sampled_from(["c", "fortran", "strided"]))
        if layout == "fortran":
            a = np.asfortranarray(a)
        elif layout == "strided" and a.ndim:
            a = np.repeat(a, 2, axis=0)[::2]  # same values, a view with twice the stride
    return a


@st.composite
def meshes(draw, coords=COORD, past_end=2):
    """Vertices (0-7, coordinates from ``coords``) and faces (0-6, indices up to ``past_end``
    past the last vertex: degenerate, duplicate and out-of-range triangles) as float32 and
    int64 arrays."""
    n = draw(st.integers(0, 7))
    vertices = draw(st.lists(st.tuples(coords, coords, coords), min_size=n, max_size=n))
    faces = draw(st.lists(st.tuples(*[st.integers(0, max(n, 1) - 1 + past_end)] * 3), min_size=0, max_size=6))
    return np.array(vertices, np.float32).reshape(-1, 3), np.array(faces, np.int64).reshape(-1, 3)


@st.composite
def lights(draw, kinds=("point", "rect", "disk", "sphere", "ellipsoid"), adversarial=st.booleans()):
    """``(class name, light)`` of a random kind, with an ordinary or (``adversarial``) an
    adversarial center, sizes and emission texture; the light is the ValueError its
    constructor raised when it refused (callers check that it names an argument)."""
    kind = draw(st.sampled_from(kinds))
    bad = draw(adversarial)
    center = draw(VEC3 if bad else ORDINARY_VEC3)
    size, size2 = draw(SIZE if bad else st.floats(0.05, 4)), draw(SIZE if bad else st.floats(0.05, 4))
    shapes = [(1, 1), (0, 0), (2, 3), (3,)] if bad else [(1, 1), (2, 3)]
    emission = draw(st.one_of(st.none(), arrays(st.sampled_from(shapes), elements=None if bad else st.floats(0.1, 2), layouts=False)))
    name = {"point": "PointLight", "rect": "RectLight", "disk": "DiskLight", "sphere": "SphereLight", "ellipsoid": "EllipsoidLight"}[kind]
    normal, angle = draw(VEC3 if bad else VEC3_MOSTLY), draw(st.floats(0, 6.3))
    try:
        if kind == "point":
            return name, ss.PointLight(center)
        if kind == "rect":
            return name, ss.RectLight(center, (size, 0, 0), (0, 0, -size2), emission=emission)
        if kind == "disk":
            return name, ss.DiskLight(center, normal, size, emission=emission)
        if kind == "sphere":
            return name, ss.SphereLight(center, size)
        with np.errstate(all="ignore"):
            axes = np.diag([size, size2, 0.5]) @ _rotation(angle)
        return name, ss.EllipsoidLight(center, axes)
    except ValueError as error:
        return name, error


def _rotation(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


# ----------------------------------------------------------------------------------------------
# Invariants
# ----------------------------------------------------------------------------------------------

ARGUMENT = re.compile(r"^(\w+):")


def refusal_names_an_argument(error: Exception, names=None):
    """The message starts with an argument's name (one of ``names`` when given)."""
    match = ARGUMENT.match(str(error))
    assert match, f"a {type(error).__name__} must start with the argument's name: {error}"
    if names is not None:
        assert match.group(1) in names, f"{error!r} names {match.group(1)!r}, not one of {sorted(names)}"


REFUSED = object()


def result_or_refusal(call, names=None, *, paths=False, label=None):
    """``call()``'s result, or :data:`REFUSED` for an accepted refusal (see the module notes).

    Parameters
    ----------
    names : collection of str, optional
        The argument names a ValueError or TypeError may start with.
    paths : bool
        Also accept an OSError whose message names the path (file functions only).
    label : str, optional
        The public function called, to count its outcomes in :data:`OUTCOMES`.
    """
    try:
        result = call()
    except MemoryError as error:
        assert "set_memory_limit" in str(error), f"a MemoryError must point to set_memory_limit: {error}"
        outcome = "MemoryError"
    except (ValueError, TypeError) as error:
        refusal_names_an_argument(error, names)
        outcome = type(error).__name__
    except OSError as error:
        if not paths:
            raise
        assert error.filename is not None or "path" in str(error), f"an OSError must name the path: {error!r}"
        outcome = "OSError"
    else:
        if label:
            OUTCOMES[label, "result"] += 1
        return result
    if label:
        OUTCOMES[label, outcome] += 1
    return REFUSED


def ground_receivers(k=16):
    xs = np.linspace(-1.5, 1.5, k, dtype=np.float32)
    points = np.stack([xs, np.zeros_like(xs), np.zeros_like(xs)], axis=1)
    return ss.Receivers(points, np.tile(np.float32([0, 1, 0]), (k, 1)))


def check_visibility(vis):
    assert np.all(np.isfinite(vis)) and np.all((vis >= 0) & (vis <= 1))

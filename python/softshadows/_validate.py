"""Input conversion shared by every public constructor and method.

Each helper converts array-likes to the contiguous dtype the core needs and raises a
``ValueError`` that names the argument, the expected and the actual shape or dtype.
"""

from __future__ import annotations

import numpy as np


def array(name: str, value, dtype, shape: tuple, *, finite: bool = True) -> np.ndarray:
    """Converts ``value`` to a C-contiguous ``dtype`` array of ``shape`` (``None`` = any size).

    Parameters
    ----------
    name : str
        Argument name used in error messages.
    value : array_like
        Input; float64/int64 and non-contiguous arrays are accepted and converted.
    dtype : numpy dtype
        Target dtype.
    shape : tuple of int or None
        Expected shape; ``None`` entries match any length.
    finite : bool
        Reject NaN and Inf (floating dtypes only).
    """
    try:
        a = np.asarray(value)
    except Exception as exc:  # ragged lists and other non-arrays
        raise ValueError(f"{name}: expected an array of shape {_fmt(shape)}, got {type(value).__name__} ({exc})") from None
    if a.ndim != len(shape) or any(s is not None and s != n for s, n in zip(shape, a.shape)):
        raise ValueError(f"{name}: expected shape {_fmt(shape)}, got {a.shape} ({a.dtype})")
    if a.dtype.kind not in "biuf":
        raise ValueError(f"{name}: expected a numeric array, got dtype {a.dtype}")
    if np.dtype(dtype).kind in "ui" and a.dtype.kind == "f":
        if a.size and not np.all(np.isfinite(a) & (a == np.round(a))):
            raise ValueError(f"{name}: expected integer indices, got non-integer {a.dtype} values")
    if np.dtype(dtype).kind == "u" and a.size and a.min() < 0:
        raise ValueError(f"{name}: indices must be >= 0, got {a.min()}")
    if np.dtype(dtype).kind in "ui" and a.dtype.kind in "iuf" and a.size:
        info = np.iinfo(dtype)  # the cast below would wrap (int64 2**32 -> uint32 0) silently
        with np.errstate(over="ignore"):  # float16 against 2**32 - 1: inf, which compares right
            out_of_range = a.max() > info.max or a.min() < info.min
        if out_of_range:
            raise ValueError(f"{name}: values must be in [{info.min}, {info.max}] for {np.dtype(dtype)}, got [{a.min()}, {a.max()}]")
    with np.errstate(over="ignore", invalid="ignore"):  # 1e300 -> inf in float32: refused just below
        out = np.ascontiguousarray(a, dtype=dtype)
    if finite and out.dtype.kind == "f" and not np.all(np.isfinite(out)):
        raise ValueError(f"{name}: contains NaN or Inf")
    return out


def vec3(name: str, value) -> np.ndarray:
    """A finite 3-vector as float32."""
    return array(name, value, np.float32, (3,))


def _real(name: str, value, what: str) -> float:
    """``value`` as a float: a real number, not a string, bytes or a bool (``float("1e3")`` and
    ``float(True)`` would pass silently)."""
    if isinstance(value, (str, bytes, bool, np.bool_)):
        raise ValueError(f"{name}: expected {what}, got {value!r}")
    return float(value)


def flag(name: str, value) -> bool:
    """A bool (or numpy bool); ``"False"`` is refused, where ``bool("False")`` is True."""
    if not isinstance(value, (bool, np.bool_)):
        raise ValueError(f"{name}: expected True or False, got {value!r}")
    return bool(value)


def number(name: str, value) -> float:
    """A finite float (an int beyond the float range, a string, a bool or None is refused by name)."""
    try:
        v = _real(name, value, "a finite number")
    except (TypeError, ValueError, OverflowError):
        raise ValueError(f"{name}: expected a finite number, got {value!r}") from None
    if not np.isfinite(v):
        raise ValueError(f"{name}: expected a finite number, got {v}")
    return v


def positive(name: str, value, *, allow_zero: bool = False, maximum: float | None = None) -> float:
    """A finite positive float (not a string or a bool), at most ``maximum`` when given."""
    try:
        v = _real(name, value, "a number")
    except (TypeError, ValueError, OverflowError):  # OverflowError: float(10**400)
        raise ValueError(f"{name}: expected a number, got {value!r}") from None
    if not np.isfinite(v) or v < 0 or (v == 0 and not allow_zero):
        raise ValueError(f"{name}: must be finite and {'>=' if allow_zero else '>'} 0, got {v}")
    if maximum is not None and v > maximum:
        raise ValueError(f"{name}: must be at most {maximum:g}, got {v:g}")
    return v


#: The largest integer the core takes (u64 seeds, usize counts): a larger Python int would
#: escape as an OverflowError from the binding instead of a ValueError naming the argument.
MAX_INT = 2**64 - 1


def nonneg_int(name: str, value, *, maximum: int = MAX_INT) -> int:
    """A non-negative int such as a seed (bools refused), at most ``maximum``."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 0:
        raise ValueError(f"{name}: expected a non-negative integer, got {value!r}")
    if value > maximum:
        raise ValueError(f"{name}: must be at most {maximum}, got {value}")
    return int(value)


def fov_y(value) -> float:
    """A vertical field of view in degrees, in (0, 180)."""
    try:
        v = float(value)
    except (TypeError, ValueError, OverflowError):
        raise ValueError(f"fov_y: expected a number of degrees, got {value!r}") from None
    if not 0 < v < 180:
        raise ValueError(f"fov_y: must be in (0, 180) degrees, got {v}")
    return v


def light_points(name: str, value) -> np.ndarray:
    """Explicit world-space light samples: a non-empty finite (S, 3) float32 array."""
    pts = array(name, value, np.float32, (None, 3))
    if len(pts) == 0:
        raise ValueError(f"{name}: expected at least one light sample, got shape (0, 3)")
    return pts


def rigid(name: str, value) -> tuple[np.ndarray, np.ndarray]:
    """A 4 x 4 rigid transform (a rotation, then a translation) as float64 ``(rotation (3, 3),
    translation (3,))``: a scale or a mirror would change a light's size or turn a mesh inside
    out, which moving an object never does."""
    m = array(name, value, np.float64, (4, 4))
    rotation = m[:3, :3]
    if not np.allclose(m[3], [0, 0, 0, 1]) or not np.allclose(rotation @ rotation.T, np.eye(3), atol=1e-6) \
            or np.linalg.det(rotation) < 0:
        raise ValueError(f"{name}: expected a rigid 4 x 4 transform (a rotation and a translation, last row 0 0 0 1), "
                         f"got {m.tolist()}")
    return rotation, m[:3, 3]


def option(name: str, value) -> str:
    """``value`` if it is a string: an enum option, whose spelling the core's binding checks
    (naming the argument and every value it takes)."""
    if not isinstance(value, str):
        raise ValueError(f"{name}: expected a string, got {type(value).__name__} {value!r}")
    return value


def instance(name: str, value, cls, what: str):
    """``value`` if it is a ``cls``, else a ValueError naming the argument."""
    if not isinstance(value, cls):
        raise ValueError(f"{name}: expected {what}, got {type(value).__name__}")
    return value


def positive_int(name: str, value, *, maximum: int = MAX_INT) -> int:
    """A positive int (bools refused), at most ``maximum``."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
        raise ValueError(f"{name}: expected a positive integer, got {value!r}")
    if value > maximum:
        raise ValueError(f"{name}: must be at most {maximum}, got {value}")
    return int(value)


def memory(what: str, nbytes: float) -> None:
    """Raises the core's ``MemoryError`` when ``nbytes`` (an estimate, computed before any
    allocation, as a float so that astronomically large requests do not overflow) exceeds
    :func:`softshadows.memory_limit`."""
    from . import _core

    limit = _core.memory_limit()
    if not nbytes <= limit:
        raise MemoryError(
            f"{what} needs about {nbytes / 2**30:.2f} GiB, above the memory limit of {limit / 2**30:.2f} GiB "
            "(lower the size, or raise softshadows.set_memory_limit)"
        )


def _fmt(shape: tuple) -> str:
    return "(" + ", ".join("N" if s is None else str(s) for s in shape) + ("," if len(shape) == 1 else "") + ")"

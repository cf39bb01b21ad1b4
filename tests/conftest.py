"""Shared fixtures: tiny analytic scenes built from arrays."""

import numpy as np
import pytest

import softshadows as ss


def quad(center, half, y, *, uvs=False, alpha=None, name=None):
    """A horizontal square at height ``y``, facing up, as a Mesh."""
    cx, cz = center
    v = np.array(
        [[cx - half, y, cz - half], [cx + half, y, cz - half], [cx + half, y, cz + half], [cx - half, y, cz + half]],
        dtype=np.float32,
    )
    f = np.array([[0, 2, 1], [0, 3, 2]], dtype=np.uint32)
    uv = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=np.float32) if uvs else None
    return ss.Mesh(v, f, uvs=uv, alpha=alpha, name=name)


def disk_mesh(center, radius, y, segments=256):
    """A horizontal disk as a triangle fan (its area matches the true disk to < 1e-4)."""
    t = np.linspace(0, 2 * np.pi, segments, endpoint=False)
    # Circumscribe slightly so the polygon has the disk's area.
    r = radius * np.sqrt(2 * np.pi / (segments * np.sin(2 * np.pi / segments)))
    ring = np.stack([center[0] + r * np.cos(t), np.full_like(t, y), center[1] + r * np.sin(t)], axis=1)
    v = np.vstack([[center[0], y, center[1]], ring]).astype(np.float32)
    f = np.array([[0, 1 + (k + 1) % segments, 1 + k] for k in range(segments)], dtype=np.uint32)
    return ss.Mesh(v, f)


@pytest.fixture
def ground():
    return quad((0, 0), 50.0, 0.0, name="ground")


def up_receivers(xs, y=0.0, z=0.0):
    """Receivers on the ground (height ``y``) along a line parallel to the x axis, facing up."""
    xs = np.asarray(xs, dtype=np.float32)
    pts = np.stack([xs, np.full_like(xs, y), np.full_like(xs, z)], axis=1)
    return ss.Receivers(pts, np.tile([0, 1, 0], (len(xs), 1)))

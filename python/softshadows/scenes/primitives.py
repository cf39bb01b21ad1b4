"""Mesh primitives of the built-in scenes, as ``(vertices, faces)`` arrays in float64 (a
:class:`~softshadows.Mesh` converts them to float32 and uint32), and the random directions the
random scenes draw.

Examples
--------
>>> from softshadows import Mesh, Scene
>>> from softshadows.scenes import primitives
>>> vertices, faces = primitives.box((-1, 0, -1), (1, 1, 1))
>>> len(vertices), len(faces)
(8, 12)
>>> Scene([Mesh(vertices, faces, closed=True)]).num_faces
12
"""

from __future__ import annotations

import numpy as np

__all__ = ["box", "cylinder", "icosphere", "merge", "bounds"]


def bounds(meshes) -> np.ndarray:
    """Axis-aligned bounds of the referenced vertices of ``meshes``, shape (2, 3): min and max.

    Examples
    --------
    >>> from softshadows import Mesh
    >>> from softshadows.scenes import primitives
    >>> primitives.bounds([Mesh(*primitives.box((0, 0, 0), (1, 2, 3)))]).tolist()
    [[0.0, 0.0, 0.0], [1.0, 2.0, 3.0]]
    """
    pts = np.concatenate([m.vertices[m.faces.reshape(-1)] for m in meshes if len(m.faces)])
    return np.stack([pts.min(axis=0), pts.max(axis=0)])


def merge(parts):
    """One (vertices, faces) pair of the (vertices, faces) ``parts``, the faces renumbered.

    Examples
    --------
    >>> from softshadows.scenes import primitives
    >>> vertices, faces = primitives.merge([primitives.box((0, 0, 0), (1, 1, 1)), primitives.box((2, 0, 0), (3, 1, 1))])
    >>> len(vertices), len(faces), int(faces.max())
    (16, 24, 15)
    """
    verts, faces, offset = [], [], 0
    for v, f in parts:
        verts.append(v)
        faces.append(f + offset)
        offset += len(v)
    return np.concatenate(verts), np.concatenate(faces).astype(np.uint32)


def icosphere(subdivisions: int):
    """A unit icosphere with outward-facing triangles: 20 * 4**s faces, 10 * 4**s + 2 vertices.

    Examples
    --------
    >>> import numpy as np
    >>> from softshadows.scenes import primitives
    >>> vertices, faces = primitives.icosphere(2)
    >>> len(vertices), len(faces), bool(np.allclose(np.linalg.norm(vertices, axis=1), 1))
    (162, 320, True)
    """
    t = (1.0 + 5.0**0.5) / 2.0
    verts = np.array(
        [[-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0], [0, -1, t], [0, 1, t],
         [0, -1, -t], [0, 1, -t], [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1]],
        dtype=np.float64,
    )
    faces = np.array(
        [[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4], [11, 10, 2],
         [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8], [3, 8, 9], [4, 9, 5],
         [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]],
        dtype=np.int64,
    )
    verts /= np.linalg.norm(verts, axis=1, keepdims=True)
    for _ in range(subdivisions):
        edges = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
        keys, inverse = np.unique(np.sort(edges, axis=1), axis=0, return_inverse=True)
        mid = verts[keys[:, 0]] + verts[keys[:, 1]]
        mid /= np.linalg.norm(mid, axis=1, keepdims=True)
        m = inverse.reshape(3, -1) + len(verts)  # midpoints of edges 01, 12, 20 of each face
        a, b, c = faces.T
        faces = np.concatenate(
            [np.stack(x, axis=1) for x in ((a, m[0], m[2]), (b, m[1], m[0]), (c, m[2], m[1]), (m[0], m[1], m[2]))]
        )
        verts = np.concatenate([verts, mid])
    return verts, faces.astype(np.uint32)


def cylinder(center_xz, radius, y0, y1, segments):
    """A closed vertical cylinder with fan caps: 2 * segments + 2 vertices, 4 * segments faces.

    Examples
    --------
    >>> from softshadows.scenes import primitives
    >>> vertices, faces = primitives.cylinder((0, 0), 0.5, 0.0, 2.0, 16)
    >>> len(vertices), len(faces)
    (34, 64)
    """
    th = np.arange(segments) * (2 * np.pi / segments)
    ring = np.stack(
        [center_xz[0] + radius * np.cos(th), np.zeros(segments), center_xz[1] + radius * np.sin(th)], axis=1
    )
    bottom, top = ring + [0.0, y0, 0.0], ring + [0.0, y1, 0.0]
    caps = np.array([[center_xz[0], y0, center_xz[1]], [center_xz[0], y1, center_xz[1]]])
    verts = np.concatenate([bottom, top, caps])
    j = np.arange(segments)
    k = (j + 1) % segments
    b, t = j, segments + j
    b1, t1 = k, segments + k
    cb, ct = np.full(segments, 2 * segments), np.full(segments, 2 * segments + 1)
    faces = np.concatenate(
        [np.stack(x, axis=1) for x in ((b, t1, b1), (b, t, t1), (ct, t1, t), (cb, b, b1))]
    )
    return verts, faces.astype(np.uint32)


def box(lo, hi):
    """A closed axis-aligned box from corner ``lo`` to corner ``hi``: 8 vertices, 12
    outward-facing triangles.

    Examples
    --------
    >>> from softshadows import Mesh, Scene
    >>> from softshadows.scenes import primitives
    >>> Scene([Mesh(*primitives.box((-1, 0, -1), (1, 1, 1)), closed=True)]).num_faces
    12
    """
    x0, y0, z0 = lo
    x1, y1, z1 = hi
    verts = np.array(
        [[x0, y0, z0], [x1, y0, z0], [x1, y1, z0], [x0, y1, z0],
         [x0, y0, z1], [x1, y0, z1], [x1, y1, z1], [x0, y1, z1]],
        dtype=np.float64,
    )
    faces = np.array(
        [[0, 2, 1], [0, 3, 2], [4, 5, 6], [4, 6, 7], [0, 1, 5], [0, 5, 4],
         [3, 7, 6], [3, 6, 2], [0, 4, 7], [0, 7, 3], [1, 2, 6], [1, 6, 5]],
        dtype=np.uint32,
    )
    return verts, faces


def tube(pts, tan, nrm, radius, sides, *, loop):
    """Tubes swept along S polylines of K points with frames (tan, nrm); outward-facing faces.

    ``loop=True`` joins each polyline's last point to its first (a torus topology,
    2 * K * sides faces); otherwise each tube gets two fan caps (2 * (K - 1) * sides + 2 * (sides - 2)
    faces).
    """
    s_count, k_count, _ = pts.shape
    binorm = np.cross(tan, nrm)
    th = np.arange(sides) * (2 * np.pi / sides)
    ring = np.cos(th)[:, None] * nrm[:, :, None, :] + np.sin(th)[:, None] * binorm[:, :, None, :]
    verts = (pts[:, :, None, :] + radius * ring).reshape(-1, 3)
    idx = np.arange(s_count * k_count * sides).reshape(s_count, k_count, sides)
    seg = k_count if loop else k_count - 1
    i0 = idx[:, :seg]
    i1 = np.roll(idx, -1, axis=1)[:, :seg]
    i0n, i1n = np.roll(i0, -1, axis=2), np.roll(i1, -1, axis=2)
    faces = [
        np.stack([i0, i1n, i1], axis=-1).reshape(s_count, -1, 3),
        np.stack([i0, i0n, i1n], axis=-1).reshape(s_count, -1, 3),
    ]
    if not loop:
        j = np.arange(sides - 2)
        first, last = idx[:, 0], idx[:, -1]
        start = np.stack([first[:, [0] * (sides - 2)], first[:, j + 2], first[:, j + 1]], axis=-1)
        end = np.stack([last[:, [0] * (sides - 2)], last[:, j + 1], last[:, j + 2]], axis=-1)
        faces += [start, end]
    return verts, np.concatenate(faces, axis=1).reshape(-1, 3).astype(np.uint32)


def transport_frames(pts):
    """Tangents and parallel-transported normals along S open polylines (S, K, 3)."""
    tan = np.empty_like(pts)
    tan[:, 1:-1] = pts[:, 2:] - pts[:, :-2]
    tan[:, 0] = pts[:, 1] - pts[:, 0]
    tan[:, -1] = pts[:, -1] - pts[:, -2]
    tan /= np.linalg.norm(tan, axis=2, keepdims=True)
    nrm = np.empty_like(pts)
    t0 = tan[:, 0]
    helper = np.where(np.abs(t0[:, 1:2]) < 0.9, [[0.0, 1.0, 0.0]], [[1.0, 0.0, 0.0]])
    n = np.cross(t0, helper)
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    nrm[:, 0] = n
    for k in range(1, pts.shape[1]):
        t = tan[:, k]
        n = n - np.sum(n * t, axis=1, keepdims=True) * t
        bad = np.linalg.norm(n, axis=1) < 1e-6  # a U-turn: restart the frame
        if bad.any():
            h = np.where(np.abs(t[bad, 1:2]) < 0.9, [[0.0, 1.0, 0.0]], [[1.0, 0.0, 0.0]])
            n[bad] = np.cross(t[bad], h)
        n /= np.linalg.norm(n, axis=1, keepdims=True)
        nrm[:, k] = n
    return tan, nrm


def unit_vectors(rng, n):
    """``n`` uniform unit vectors, shape (n, 3), from the numpy Generator ``rng``."""
    d = rng.standard_normal((n, 3))
    return d / np.linalg.norm(d, axis=1, keepdims=True)


def unit_ball(rng, n):
    """Uniform points in the unit ball."""
    return unit_vectors(rng, n) * rng.uniform(0.0, 1.0, (n, 1)) ** (1.0 / 3.0)

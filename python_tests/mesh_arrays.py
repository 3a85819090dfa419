# SPDX-License-Identifier: GPL-3.0-or-later
"""Small meshes as numpy arrays, and what the native tests measure on them, shared by tests in several folders."""
import numpy as np

from uv_jacobians import triangle_jacobians

def polygon_grid(n, spacing, triangles=True, jitter=0.0, seed=1):
    rng = np.random.default_rng(seed)
    ys, xs = np.mgrid[0:n + 1, 0:n + 1]
    pos = np.stack([xs.ravel(), ys.ravel(), np.zeros(xs.size)], 1).astype(np.float64)
    pos[:, :2] += jitter * (rng.random((xs.size, 2)) - 0.5)
    pos = (pos * spacing).astype(np.float32)
    idx = lambda x, y: y * (n + 1) + x
    polys = []
    for y in range(n):
        for x in range(n):
            if triangles:
                polys += [[idx(x, y), idx(x + 1, y), idx(x + 1, y + 1)], [idx(x, y), idx(x + 1, y + 1), idx(x, y + 1)]]
            else:
                polys.append([idx(x, y), idx(x + 1, y), idx(x + 1, y + 1), idx(x, y + 1)])
    return pack(pos, polys)


def pack(pos, polys):
    sizes = np.array([len(p) for p in polys], np.int32)
    starts = np.concatenate([[0], np.cumsum(sizes)[:-1]]).astype(np.int32) if len(polys) else np.zeros(0, np.int32)
    corner_verts = np.array([v for p in polys for v in p], np.int32)
    return pos, corner_verts, starts, sizes


def texel(uv, pre):
    return np.stack([uv[..., 0] * pre.width, (1.0 - uv[..., 1]) * pre.height], -1).astype(np.float64)


def face_jacobians(pos, corner_verts, starts, uv, pre):
    """Per triangle: J mapping the triangle's own plane (basis from its first edge) to texels."""
    c = starts[:, None] + np.arange(3)[None, :]
    return triangle_jacobians(pos[corner_verts[c]], texel(uv[c], pre))


def jittered_plane(n=30, spacing=0.1, jitter=0.3, seed=1):
    """(n+1)^2 vertices on z = 0, two counter-clockwise triangles per cell, jittered in x and y."""
    rng = np.random.default_rng(seed)
    ys, xs = np.mgrid[0:n + 1, 0:n + 1]
    xy = np.stack([xs.ravel(), ys.ravel()], axis=1).astype(np.float64)
    xy += jitter * (rng.random(xy.shape) - 0.5)
    pos = np.zeros(((n + 1) ** 2, 3), np.float32)
    pos[:, :2] = xy * spacing
    tris = []
    for y in range(n):
        for x in range(n):
            a, b, c, d = y * (n + 1) + x, y * (n + 1) + x + 1, (y + 1) * (n + 1) + x + 1, (y + 1) * (n + 1) + x
            tris += [(a, b, c), (a, c, d)]
    return pos, np.array(tris, np.int32)


def triangle_grid(n, spacing):
    """(n + 1)^2 vertices on z = 0, two counter-clockwise triangles per cell."""
    xs = np.arange(n + 1) * spacing
    x, y = np.meshgrid(xs, xs)
    pos = np.stack([x.ravel(), y.ravel(), np.zeros(x.size)], 1).astype(np.float32)
    tris = []
    for j in range(n):
        for i in range(n):
            a, b, c, d = j * (n + 1) + i, j * (n + 1) + i + 1, (j + 1) * (n + 1) + i + 1, (j + 1) * (n + 1) + i
            tris += [(a, b, c), (a, c, d)]
    return pos, np.array(tris, np.int32)


def locate(pos, tris, xy):
    """Triangle and barycentrics (b1, b2) of the point xy of a planar mesh (z = 0)."""
    p = pos[tris].astype(np.float64)
    e1, e2, q = p[:, 1, :2] - p[:, 0, :2], p[:, 2, :2] - p[:, 0, :2], np.asarray(xy) - p[:, 0, :2]
    det = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    b1 = (q[:, 0] * e2[:, 1] - q[:, 1] * e2[:, 0]) / det
    b2 = (e1[:, 0] * q[:, 1] - e1[:, 1] * q[:, 0]) / det
    inside = np.flatnonzero((b1 >= 0) & (b2 >= 0) & (b1 + b2 <= 1))
    t = int(inside[0])
    return t, (b1[t], b2[t])

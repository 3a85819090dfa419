# SPDX-License-Identifier: GPL-3.0-or-later
"""Small UV-mapped meshes as numpy arrays for the surface-colour tests and benchmarks."""
import math

import numpy as np


def plane(n=8, side=1.0):
    """(n+1)^2 vertices on z = 0, two counter-clockwise triangles per cell, UV = position / side:
    positions (V, 3) float32, triangles (T, 3) int32, corner UVs (T, 3, 2) float32."""
    ys, xs = np.mgrid[0:n + 1, 0:n + 1]
    pos = np.zeros(((n + 1) ** 2, 3), np.float32)
    pos[:, 0] = xs.ravel() * side / n
    pos[:, 1] = ys.ravel() * side / n
    tris, uvs = [], []
    for y in range(n):
        for x in range(n):
            corners = [(x, y), (x + 1, y), (x + 1, y + 1), (x, y + 1)]
            for tri in ((0, 1, 2), (0, 2, 3)):
                tris.append([corners[k][1] * (n + 1) + corners[k][0] for k in tri])
                uvs.append([[corners[k][0] / n, corners[k][1] / n] for k in tri])
    return pos, np.array(tris, np.int32), np.array(uvs, np.float32)


def _clip(poly, axis, value, keep_below):
    """The convex polygon `poly` (list of (x, y)) cut by the line coordinate[axis] = value."""
    out = []
    for i, a in enumerate(poly):
        b = poly[(i + 1) % len(poly)]
        a_in = a[axis] <= value if keep_below else a[axis] >= value
        b_in = b[axis] <= value if keep_below else b[axis] >= value
        if a_in:
            out.append(a)
        if a_in != b_in:
            t = (value - a[axis]) / (b[axis] - a[axis])
            out.append((a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])))
    return out


def turned_plane(cells, degrees):
    """The unit square on z = 0 tessellated by a square lattice of `cells` cells per unit turned by `degrees`
    about the square's centre, each triangle clipped to the square (clipped pieces fanned into triangles),
    UV = position: positions (V, 3) float32, triangles (T, 3) int32, corner UVs (T, 3, 2) float32."""
    c, s = math.cos(math.radians(degrees)), math.sin(math.radians(degrees))
    h, reach = 1.0 / cells, int(math.ceil(0.75 * cells)) + 1
    verts, index, tris = [], {}, []

    def vertex(p):
        key = (round(p[0], 9), round(p[1], 9))
        if key not in index:
            index[key] = len(verts)
            verts.append(key)
        return index[key]

    for j in range(-reach, reach):
        for i in range(-reach, reach):
            quad = [((i + di) * h, (j + dj) * h) for di, dj in ((0, 0), (1, 0), (1, 1), (0, 1))]
            quad = [(0.5 + c * x - s * y, 0.5 + s * x + c * y) for x, y in quad]
            for tri in ((quad[0], quad[1], quad[2]), (quad[0], quad[2], quad[3])):
                poly = list(tri)
                for axis in (0, 1):
                    poly = _clip(poly, axis, 0.0, False)
                    poly = _clip(poly, axis, 1.0, True) if poly else poly
                if len(poly) < 3:
                    continue
                area = 0.5 * sum(poly[k][0] * poly[k - 1][1] - poly[k - 1][0] * poly[k][1] for k in range(len(poly)))
                if abs(area) < 1e-10:
                    continue
                ids = [vertex(p) for p in poly]
                tris += [(ids[0], ids[k], ids[k + 1]) for k in range(1, len(ids) - 1)]
    pos = np.zeros((len(verts), 3), np.float32)
    pos[:, :2] = verts
    tris = np.array(tris, np.int32)
    return pos, tris, np.ascontiguousarray(pos[tris][:, :, :2])


# SPDX-License-Identifier: GPL-3.0-or-later
"""Small UV-mapped meshes as numpy arrays for the surface-colour tests and benchmarks."""
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

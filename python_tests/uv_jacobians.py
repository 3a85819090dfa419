# SPDX-License-Identifier: GPL-3.0-or-later
"""Independent check of a UV mapping's local shape (numpy only, used inside and outside Blender)."""
import numpy as np


def triangle_jacobians(p, t):
    """Per triangle: J (2 x 2) mapping the triangle's own plane to the 2D coordinates t, with the
    plane basis e1 (along the first edge) and e2 = n x e1. p: (F, 3, 3) corner positions, t: (F, 3, 2)."""
    p = p.astype(np.float64)
    e1 = p[:, 1] - p[:, 0]
    e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
    n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    e2 = np.cross(n, e1)
    M = np.stack([np.stack([((p[:, k] - p[:, 0]) * e).sum(1) for k in (1, 2)], 1) for e in (e1, e2)], 1)
    T = np.stack([t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]], 2)
    return T @ np.linalg.inv(M), e1, e2

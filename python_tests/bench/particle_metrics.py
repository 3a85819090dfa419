# SPDX-License-Identifier: GPL-3.0-or-later
"""Arrangement statistics of texture particles (issue 15, "Quality, measured"), the same code for the sample,
its halves and the particles placed on a surface, so the three are compared like for like.

A particle is a box: centre, angle theta (sample frame), half extents, class. On a surface the chart of a
particle is its tangent plane, x along the field's sample-x axis, scaled to sample pixels at scale 1. Every
neighbour relation is measured in the reference particle's box frame, as the analysis defines it (analysis.hpp
"Co-occurrences"): quadrant from the signs of the centre offset (|offset| < 0.5 px counts as +),
dx, dy = the signed gaps between the two boxes' extents along the reference's axes on the quadrant's side.
Per quadrant the kept neighbour is the one nearest by box gap (max(dx, dy), what dilation reaches first).
"""
import math

import numpy as np

# Gaps and distances are compared to 0.01 px: positions placed on a surface are float32 (1e-4 px at a
# 3-unit plane of 448 px per unit), and a KS statistic on an exact lattice jumps from 0 to 1 on such noise.
RESOLUTION_DIGITS = 2


class Boxes:
    """Particles as boxes in local charts: positions (n, 3), normals (n, 3), chart x axes (n, 3) (the sample's x
    at each particle), angles (n,) theta in the chart, halves (n, 2) in chart pixels, classes (n,), and which ones
    may be centres (their neighbourhood lies inside the measured region). pixel = world units per chart pixel."""

    def __init__(self, positions, normals, x_axes, angles, halves, classes, centre_ok, pixel=1.0):
        self.positions = np.asarray(positions, np.float64).reshape(-1, 3)
        self.normals = _unit(np.asarray(normals, np.float64).reshape(-1, 3))
        self.x_axes = _unit(np.asarray(x_axes, np.float64).reshape(-1, 3))
        self.angles = np.asarray(angles, np.float64).ravel()
        self.halves = np.asarray(halves, np.float64).reshape(-1, 2)
        self.classes = np.asarray(classes).ravel()
        self.centre_ok = np.asarray(centre_ok, bool).ravel()
        self.pixel = float(pixel)

    @staticmethod
    def planar(centres, angles, halves, classes, centre_ok):
        """Boxes in one plane chart (the sample): centres (n, 2) in pixels."""
        c = np.asarray(centres, np.float64).reshape(-1, 2)
        n = len(c)
        pos = np.zeros((n, 3))
        pos[:, :2] = c
        return Boxes(pos, np.tile([0.0, 0.0, 1.0], (n, 1)), np.tile([1.0, 0.0, 0.0], (n, 1)), angles, halves,
                     classes, centre_ok)

    def __len__(self):
        return len(self.positions)

    def subset(self, keep):
        keep = np.asarray(keep)
        return Boxes(self.positions[keep], self.normals[keep], self.x_axes[keep], self.angles[keep],
                     self.halves[keep], self.classes[keep], self.centre_ok[keep], self.pixel)


def _unit(v):
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    return v / np.where(n > 0, n, 1.0)


def neighbour_gaps(boxes, cls, radius):
    """Rows (quadrant, dx, dy, nearest_centre_distance, centre index) for every centre particle of class cls: one
    row per non-empty quadrant (neighbours within `radius` chart pixels, centre to centre). The nearest distance
    is repeated per row; nearest_distances() gives one value per centre."""
    idx = np.flatnonzero(boxes.classes == cls)
    rows = []
    if len(idx) < 2:
        return np.zeros((0, 5))
    pos, nrm, xax = boxes.positions[idx], boxes.normals[idx], boxes.x_axes[idx]
    ang, half = boxes.angles[idx], boxes.halves[idx]
    r_world = radius * boxes.pixel
    cell = max(r_world, 1e-12)
    keys = np.floor(pos / cell).astype(np.int64)
    buckets = {}
    for i, k in enumerate(map(tuple, keys)):
        buckets.setdefault(k, []).append(i)
    offsets = [(a, b, c) for a in (-1, 0, 1) for b in (-1, 0, 1) for c in (-1, 0, 1)]
    for local in np.flatnonzero(boxes.centre_ok[idx]):
        k = keys[local]
        cand = [j for o in offsets for j in buckets.get((k[0] + o[0], k[1] + o[1], k[2] + o[2]), ()) if j != local]
        if not cand:
            continue
        cand = np.asarray(cand)
        d = pos[cand] - pos[local]
        ok = (np.einsum("ij,ij->i", d, d) <= r_world * r_world) & (nrm[cand] @ nrm[local] > 0.0)
        cand, d = cand[ok], d[ok]
        if len(cand) == 0:
            continue
        n = nrm[local]
        x = xax[local] - n * (xax[local] @ n)
        x /= np.linalg.norm(x)
        y = np.cross(n, x)
        # chart coordinates (pixels), then the reference box frame
        cx, cy = d @ x / boxes.pixel, d @ y / boxes.pixel
        t = ang[local]
        ox = cx * math.cos(t) + cy * math.sin(t)
        oy = -cx * math.sin(t) + cy * math.cos(t)
        rel = ang[cand] - t
        ex = np.abs(np.cos(rel)) * half[cand, 0] + np.abs(np.sin(rel)) * half[cand, 1]
        ey = np.abs(np.sin(rel)) * half[cand, 0] + np.abs(np.cos(rel)) * half[cand, 1]
        dx = np.abs(ox) - half[local, 0] - ex
        dy = np.abs(oy) - half[local, 1] - ey
        q = quadrant(ox, oy)
        gap = np.maximum(dx, dy)
        dist = np.sqrt(cx * cx + cy * cy)
        nearest = float(dist.min())
        for qq in range(4):
            m = np.flatnonzero(q == qq)
            if len(m):
                j = m[np.lexsort((dist[m], np.round(gap[m], RESOLUTION_DIGITS)))[0]]  # least gap, then the nearer centre
                rows.append((qq, round(dx[j], RESOLUTION_DIGITS), round(dy[j], RESOLUTION_DIGITS),
                             round(nearest, RESOLUTION_DIGITS), idx[local]))
    return np.asarray(rows, np.float64).reshape(-1, 5)


def quadrant(ox, oy):
    """0 (+,+), 1 (-,+), 2 (-,-), 3 (+,-); |offset| < 0.5 counts as +."""
    sx = np.asarray(ox) > -0.5
    sy = np.asarray(oy) > -0.5
    return np.where(sx & sy, 0, np.where(~sx & sy, 1, np.where(~sx & ~sy, 2, 3)))


def nearest_distances(gap_rows):
    """One nearest-centre distance per centre particle from neighbour_gaps rows (consecutive duplicates)."""
    if len(gap_rows) == 0:
        return np.zeros(0)
    _, first = np.unique(gap_rows[:, 4], return_index=True)
    return gap_rows[first, 3]


def ks(a, b):
    """Two-sample Kolmogorov-Smirnov statistic D and its asymptotic p-value."""
    a, b = np.sort(np.asarray(a, np.float64)), np.sort(np.asarray(b, np.float64))
    if len(a) == 0 or len(b) == 0:
        return float("nan"), float("nan")
    grid = np.concatenate([a, b])
    d = float(np.max(np.abs(np.searchsorted(a, grid, "right") / len(a) - np.searchsorted(b, grid, "right") / len(b))))
    en = math.sqrt(len(a) * len(b) / (len(a) + len(b)))
    lam = (en + 0.12 + 0.11 / en) * d
    p = 2.0 * sum((-1) ** (k - 1) * math.exp(-2.0 * k * k * lam * lam) for k in range(1, 101))
    return d, float(min(max(p, 0.0), 1.0))


def histogram_distance(a, b, bin_size=2.0):
    """Total-variation distance (0 = same, 1 = disjoint) between the 2-D histograms of (dx, dy) rows a and b,
    on common bins of bin_size pixels."""
    a, b = np.asarray(a, np.float64).reshape(-1, 2), np.asarray(b, np.float64).reshape(-1, 2)
    if len(a) == 0 or len(b) == 0:
        return float("nan")
    both = np.concatenate([a, b])
    lo = np.floor(both.min(0) / bin_size) * bin_size
    hi = np.ceil(both.max(0) / bin_size) * bin_size + bin_size
    edges = [np.arange(lo[k], hi[k] + bin_size / 2, bin_size) for k in range(2)]
    ha = np.histogram2d(a[:, 0], a[:, 1], bins=edges)[0] / len(a)
    hb = np.histogram2d(b[:, 0], b[:, 1], bins=edges)[0] / len(b)
    return float(0.5 * np.abs(ha - hb).sum())


def compare(gaps_a, gaps_b, bin_size=2.0):
    """Per-quadrant and overall figures between two neighbour_gaps tables: histogram distance of (dx, dy),
    KS D of the dx and dy marginals, KS D of the nearest-centre distances, and the median gaps."""
    out = {}
    for qq in range(4):
        a, b = gaps_a[gaps_a[:, 0] == qq, 1:3], gaps_b[gaps_b[:, 0] == qq, 1:3]
        out[qq] = {"hist": histogram_distance(a, b, bin_size), "ks_dx": ks(a[:, 0], b[:, 0])[0],
                   "ks_dy": ks(a[:, 1], b[:, 1])[0], "n": (len(a), len(b))}
    out["hist"] = histogram_distance(gaps_a[:, 1:3], gaps_b[:, 1:3], bin_size)
    out["ks_dx"] = ks(gaps_a[:, 1], gaps_b[:, 1])[0]
    out["ks_dy"] = ks(gaps_a[:, 2], gaps_b[:, 2])[0]
    out["ks_nearest"] = ks(nearest_distances(gaps_a), nearest_distances(gaps_b))[0]
    return out

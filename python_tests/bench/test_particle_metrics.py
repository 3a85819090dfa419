# SPDX-License-Identifier: GPL-3.0-or-later
"""The arrangement statistics of the particle benchmark (bench/particle_metrics.py): gaps worked out by hand on
a square grid, invariance to the chart's placement in space, and the distribution distances' extremes."""
import math
import sys

import numpy as np
import paths

sys.path.insert(0, paths.BENCH)
import particle_metrics as pm  # noqa: E402


def grid_boxes(n=6, side=20.0, gap_x=8.0, gap_y=12.0):
    ys, xs = np.mgrid[0:n, 0:n]
    centres = np.stack([xs.ravel() * (side + gap_x), ys.ravel() * (side + gap_y)], 1) + side / 2
    interior = ((xs > 0) & (xs < n - 1) & (ys > 0) & (ys < n - 1)).ravel()
    return centres, interior


def test_square_grid_gaps_by_hand():
    centres, interior = grid_boxes()
    boxes = pm.Boxes.planar(centres, np.zeros(len(centres)), np.full((len(centres), 2), 10.0),
                            np.zeros(len(centres), int), interior)
    rows = pm.neighbour_gaps(boxes, 0, radius=60.0)
    assert len(rows) == 4 * interior.sum()  # every interior square sees all four quadrants
    # squares 8 px apart in x, 12 in y: the right (q 0) and left (q 1) neighbours are 8 px away with
    # overlapping y extents (-20); (-,-) holds only the diagonal one; straight below counts as (+,-) (|x| < 0.5)
    expected = {0: (8.0, -20.0), 1: (8.0, -20.0), 2: (8.0, 12.0), 3: (-20.0, 12.0)}
    for q, dx, dy, nearest, _ in rows:
        assert (dx, dy) == expected[int(q)]
        assert nearest == 28.0
    np.testing.assert_array_equal(pm.nearest_distances(rows), np.full(interior.sum(), 28.0))


def test_gaps_do_not_depend_on_where_the_chart_lies():
    centres, interior = grid_boxes()
    n = len(centres)
    flat = pm.neighbour_gaps(pm.Boxes.planar(centres, np.zeros(n), np.full((n, 2), 10.0), np.zeros(n, int),
                                             interior), 0, 60.0)
    # the same grid on a tilted plane, in world units of 0.01 per pixel, turned 30 degrees in its plane
    t, tilt = math.radians(30), math.radians(40)
    u = np.array([math.cos(t), math.sin(t) * math.cos(tilt), math.sin(t) * math.sin(tilt)])
    normal = np.array([0.0, -math.sin(tilt), math.cos(tilt)])
    v = np.cross(normal, u)
    pos = 0.01 * (centres[:, :1] * u + centres[:, 1:] * v) + np.array([3.0, -2.0, 1.0])
    boxes = pm.Boxes(pos, np.tile(normal, (n, 1)), np.tile(u, (n, 1)), np.zeros(n), np.full((n, 2), 10.0),
                     np.zeros(n, int), interior, pixel=0.01)
    tilted = pm.neighbour_gaps(boxes, 0, 60.0)
    np.testing.assert_allclose(tilted, flat, atol=1e-9)


def test_rotated_reference_box_measures_in_its_own_frame():
    # two 20 x 10 boxes side by side along a 30-degree axis, 4 px apart along it
    t = math.radians(30)
    axis = np.array([math.cos(t), math.sin(t)])
    centres = np.array([[50.0, 50.0], [50.0, 50.0] + axis * 24.0])
    boxes = pm.Boxes.planar(centres, [t, t], [[10.0, 5.0], [10.0, 5.0]], [0, 0], [True, False])
    rows = pm.neighbour_gaps(boxes, 0, 100.0)
    assert rows.shape == (1, 5)
    np.testing.assert_allclose(rows[0, :3], [0, 4.0, -10.0], atol=1e-9)


def test_distribution_distances():
    rng = np.random.default_rng(0)
    a, b = rng.normal(0, 1, 2000), rng.normal(0, 1, 2000)
    d_same, p_same = pm.ks(a, b)
    d_shift, p_shift = pm.ks(a, b + 1.0)
    assert d_same < 0.05 and p_same > 0.05
    assert d_shift > 0.3 and p_shift < 1e-6
    assert pm.ks(a, a)[0] == 0.0
    pts = rng.normal(0, 3, (500, 2))
    assert pm.histogram_distance(pts, pts) == 0.0
    assert pm.histogram_distance(pts, pts + 100.0) == 1.0

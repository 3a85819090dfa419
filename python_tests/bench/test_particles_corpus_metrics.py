# SPDX-License-Identifier: GPL-3.0-or-later
"""The pure helpers of the particle corpus benchmark (bench/particles_corpus_metrics.py): the typical-element
range and share, class-share error, the periodic copies of a repeating sample, density ratio and goal shares, on figures worked out by hand."""
import math
import sys

import numpy as np
import paths

sys.path.insert(0, paths.BENCH)
import particle_metrics as pm  # noqa: E402
import particles_corpus_metrics as pcm  # noqa: E402


def test_aspect_is_long_over_short_whatever_the_order():
    assert np.allclose(pcm.aspect_of([[10.0, 5.0], [2.0, 8.0], [3.0, 3.0]]), [2.0, 4.0, 1.0])


def test_typical_range_is_the_percentiles_widened_by_the_slack():
    area = np.arange(1.0, 102.0)  # 1..101: 10th percentile 11, 90th 91
    aspect = np.linspace(1.0, 3.0, 101)  # 10th 1.2, 90th 2.8
    a0, a1, s0, s1 = pcm.typical_range(area, aspect)
    assert math.isclose(a0, 11.0 / 1.25) and math.isclose(a1, 91.0 * 1.25)
    assert math.isclose(s0, 1.2 / 1.1) and math.isclose(s1, 2.8 * 1.1)
    assert pcm.typical_range([], []) is None


def test_typical_range_aspect_never_below_one():
    assert pcm.typical_range([4.0, 4.0], [1.0, 1.0])[2] == 1.0


def test_in_range_share_counts_area_and_aspect_both():
    rng = (10.0, 20.0, 1.0, 2.0)
    area = [5.0, 15.0, 15.0, 25.0]
    aspect = [1.5, 1.5, 3.0, 1.5]  # only the second lies inside on both
    assert pcm.in_range_share(area, aspect, rng) == 0.25
    assert math.isnan(pcm.in_range_share([], [], rng))
    assert math.isnan(pcm.in_range_share([1.0], [1.0], None))


def test_worst_share_error():
    # sample: class 1 has 30, class 2 has 10 (0.75 / 0.25); placed: 1 1 2 2 (0.5 / 0.5)
    counts = [0, 30, 10]
    assert math.isclose(pcm.worst_share_error([1, 1, 2, 2], counts, [1, 2]), 0.25)
    assert pcm.worst_share_error([1, 1, 1, 2], counts, [1, 2]) == 0.0
    # placed classes the sample does not count are simply not shares of the listed ids
    assert math.isclose(pcm.worst_share_error([], counts, [1, 2]), 0.75)


def test_density_ratio():
    # 40 placed on 400 px^2 = 0.1; sample 10 on 200 px^2 = 0.05
    assert pcm.density_ratio(40, 400.0, 10, 200.0) == 2.0
    assert math.isnan(pcm.density_ratio(40, 400.0, 0, 200.0))


def test_goal_share_counts_nan_as_failure():
    values = [1.0, 1.1, 1.5, float("nan")]
    assert pcm.goal_share(values, lambda v: abs(v - 1.0) <= 0.15) == 0.5
    assert math.isnan(pcm.goal_share([], lambda v: True))


def test_periodic_copies_let_particles_by_the_border_see_each_other_across_it():
    # two particles 10 px apart across the border of a 100 x 80 sample (one centre given unwrapped, at -5)
    centres, angles, halves, original = pcm.periodic_copies([[-5.0, 40.0], [5.0, 40.0]], [0.0, 0.3],
                                                            [[2.0, 1.0], [2.0, 1.0]], 100, 80)
    assert centres.shape == (18, 2) and angles.shape == (18,) and halves.shape == (18, 2)
    assert original.tolist() == [True, True] + [False] * 16
    assert np.allclose(centres[:2], [[95.0, 40.0], [5.0, 40.0]])
    assert np.allclose(angles[16:], [0.0, 0.3])
    boxes = pm.Boxes.planar(centres, angles, halves, np.zeros(18, int), original)
    assert np.allclose(pm.nearest_distances(pm.neighbour_gaps(boxes, 0, 30.0)), [10.0, 10.0])
    # without the copies they are 90 px apart: outside the radius, no nearest distance at all
    alone = pm.Boxes.planar(centres[:2], angles[:2], halves[:2], np.zeros(2, int), original[:2])
    assert len(pm.nearest_distances(pm.neighbour_gaps(alone, 0, 30.0))) == 0

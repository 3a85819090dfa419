# SPDX-License-Identifier: GPL-3.0-or-later
"""The blending-quality measures of python_tests/bench/blend_metrics.py on images whose answers are
known by construction."""
import sys

import numpy as np
import paths

sys.path.insert(0, paths.BENCH)
import blend_metrics  # noqa: E402


def grid_mask(size, spacing):
    mask = np.zeros((size, size), bool)
    mask[::spacing, :] = True
    mask[:, ::spacing] = True
    return mask


def test_edge_distance_matches_brute_force():
    rng = np.random.default_rng(1)
    mask = rng.random((24, 31)) < 0.02
    mask[5, 7] = True
    distance = blend_metrics.edge_distance(mask, 6)
    ys, xs = np.nonzero(mask)
    for y in range(mask.shape[0]):
        for x in range(mask.shape[1]):
            expected = min(6 + 1, int(np.min(np.maximum(np.abs(ys - y), np.abs(xs - x)))))
            assert distance[y, x] == expected, (y, x)


def test_seams_raise_the_ratio_and_smooth_noise_does_not():
    rng = np.random.default_rng(2)
    size, spacing = 128, 16
    mask = grid_mask(size, spacing)
    distance = blend_metrics.edge_distance(mask, 8)
    valid = np.ones((size, size), bool)
    noise = rng.random((size, size))
    plain = blend_metrics.seam_ratio(blend_metrics.gradient_magnitude(noise), distance, valid)
    assert 0.9 < plain < 1.1, plain
    # Each cell gets its own brightness offset: a step at every cell border (a visible seam).
    cell_offset = rng.random((size // spacing + 1, size // spacing + 1)) * 2.0
    ys, xs = np.mgrid[0:size, 0:size]
    seamed = noise + cell_offset[ys // spacing, xs // spacing]  # steps on the mask lines
    assert blend_metrics.seam_ratio(blend_metrics.gradient_magnitude(seamed), distance, valid) > 1.3


def test_gradient_profile_is_flat_for_uniform_noise_and_dips_where_blurred():
    rng = np.random.default_rng(3)
    size = 160
    mask = grid_mask(size, 20)
    distance = blend_metrics.edge_distance(mask, 9)
    valid = np.ones((size, size), bool)
    noise = rng.random((size, size))
    flat = blend_metrics.gradient_profile(blend_metrics.gradient_magnitude(noise), distance, valid, 9)
    assert np.all(np.abs(flat - 1.0) < 0.08), flat
    # Averaging more images towards the face middles (as linear blending does) lowers the contrast there.
    washed = noise * (1.0 - 0.05 * np.minimum(distance, 9))
    profile = blend_metrics.gradient_profile(blend_metrics.gradient_magnitude(washed), distance, valid, 9)
    assert profile[0] > profile[-1] * 1.3, profile


def test_tiling_repeats_and_noise_does_not():
    rng = np.random.default_rng(4)
    tile = rng.random((32, 32))
    tiled = np.tile(tile, (4, 4))
    assert blend_metrics.autocorrelation_peak(tiled, 8) > 0.99
    assert blend_metrics.autocorrelation_peak(rng.random((128, 128)), 8) < 0.1


def test_detail_of_a_blurred_copy_is_lower():
    rng = np.random.default_rng(5)
    image = rng.random((64, 64))
    blurred = (image + np.roll(image, 1, 0) + np.roll(image, 1, 1) + np.roll(image, (1, 1), (0, 1))) / 4
    valid = np.ones(image.shape, bool)
    sharp = blend_metrics.mean_gradient(blend_metrics.gradient_magnitude(image), valid)
    soft = blend_metrics.mean_gradient(blend_metrics.gradient_magnitude(blurred), valid)
    assert soft / sharp < 0.8

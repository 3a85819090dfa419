# SPDX-License-Identifier: GPL-3.0-or-later
"""The vector-field-patch quality measures of python_tests/bench/bench_patches_quality.py on images whose
answers are known by construction (no Blender; numpy only, plus the plane lattice checked against the native
module's conventions)."""
import sys

import numpy as np
import pytest
import paths

sys.path.insert(0, paths.BENCH)
import bench_patches_quality as bpq  # noqa: E402


def stripes(size, grain_degrees, period=16.0):
    """Grey sinusoidal stripes whose crests run at grain_degrees (x = column, y = row), (size, size, 3)."""
    y, x = np.mgrid[0:size, 0:size].astype(np.float64)
    t = np.radians(grain_degrees)
    across = -np.sin(t) * x + np.cos(t) * y  # coordinate perpendicular to the grain
    grey = 0.5 + 0.4 * np.sin(2 * np.pi * across / period)
    return np.repeat(grey[..., None], 3, axis=2)


@pytest.mark.parametrize("degrees", [0.0, 30.0, 67.0, 120.0])
def test_stripes_at_a_known_angle_give_that_angle(degrees):
    image = stripes(96, degrees)
    valid = bpq.margin_mask(image.shape[:2], 8)
    # The field is +y; grain offset -90 deg + the stripes' angle: the error must be ~0 ...
    field = np.pi / 2
    error, coherence, dominant = bpq.field_angle_error(image, field, np.radians(degrees) - np.pi / 2, valid)
    assert np.median(error[valid]) < 1.0, np.median(error[valid])
    assert bpq.angle_error_degrees(dominant, np.radians(degrees)) < 1.0, np.degrees(dominant)
    assert coherence[valid].mean() > 0.9
    # ... and a wrong offset (20 deg off) must show up as 20 deg.
    error, _, _ = bpq.field_angle_error(image, field, np.radians(degrees + 20) - np.pi / 2, valid)
    assert abs(np.median(error[valid]) - 20) < 1.0


def test_dominant_grain_is_the_weighted_doubled_angle_mean():
    grain = np.radians(np.array([[10.0, 170.0], [5.0, 90.0]]))  # 10 and 170 average to 0, not 90
    coherence = np.array([[1.0, 1.0], [0.0, 0.0]])
    dominant = np.degrees(bpq.dominant_grain(grain, coherence))
    assert min(dominant, 180 - dominant) < 1e-6, dominant
    assert abs(np.degrees(bpq.dominant_grain(grain, 1 - coherence)) - 47.5) < 1e-6  # 5 and 90 average to 47.5


def test_field_error_follows_a_varying_field():
    # Concentric rings: grain tangential = perpendicular to the radial direction.
    size = 128
    y, x = np.mgrid[0:size, 0:size] - (size - 1) / 2.0
    grey = 0.5 + 0.4 * np.sin(2 * np.pi * np.hypot(x, y) / 7.0)
    image = np.repeat(grey[..., None], 3, axis=2)
    radial = np.arctan2(y, x)
    valid = bpq.margin_mask((size, size), 8) & (np.hypot(x, y) > 20)
    error, _, _ = bpq.field_angle_error(image, radial, np.pi / 2, valid)  # grain = field + 90 deg
    assert np.median(error[valid]) < 2.0
    error, _, _ = bpq.field_angle_error(image, radial, 0.0, valid)  # grain along the field: wrong by 90
    assert np.median(error[valid]) > 85.0


def two_patch_source(size=40, seam_column=17, offset=(50.3, 7.0)):
    """A source map of two pasted patches: identity steps everywhere, the right part shifted by offset."""
    y, x = np.mgrid[0:size, 0:size].astype(np.float64)
    src = np.stack([x + 5, y + 3], axis=2)
    src[:, seam_column:] += offset
    return src


def test_seam_detector_finds_exactly_the_seam():
    src = two_patch_source()
    mask = bpq.source_seams(src)
    expected = np.zeros(mask.shape, bool)
    expected[:, 16:18] = True
    assert np.array_equal(mask, expected)
    # A sub-threshold offset (0.3 px, e.g. rounding) is no seam; a horizontal seam is found along y.
    assert not bpq.source_seams(two_patch_source(offset=(0.3, 0.0))).any()
    src = np.swapaxes(two_patch_source(), 0, 1)[..., ::-1]
    mask = bpq.source_seams(src)
    assert np.array_equal(mask, expected.T)


def test_seam_detector_uses_the_expected_step_and_skips_uncovered():
    # Density 2: two source pixels per sample; with the unit step everything would be a seam.
    src = two_patch_source() * np.array([2.0, 2.0])
    assert bpq.source_seams(src).mean() > 0.9
    mask = bpq.source_seams(src, step_x=(2.0, 0.0), step_y=(0.0, 2.0))
    assert mask.sum() == 2 * src.shape[0]
    src[:, 30:] = -1  # uncovered: no seam at the coverage border
    mask = bpq.source_seams(src, step_x=(2.0, 0.0), step_y=(0.0, 2.0))
    assert mask.sum() == 2 * src.shape[0] and not mask[:, 28:].any()


def test_seam_figure_fails_a_visible_seam_and_passes_a_continuous_image():
    rng = np.random.default_rng(3)
    noise = rng.random((64, 64))
    src = np.zeros((64, 64, 2))
    for k, cut in enumerate((10, 21, 32, 43, 54)):
        src[:, cut:, 0] += 100.0 * (k + 1)
    src[..., 0] += np.arange(64)[None, :]
    src[..., 1] += np.arange(64)[:, None]
    grey = np.repeat(noise[..., None], 3, axis=2)
    ratio, share, _ = bpq.seam_figure(grey, src)
    assert 0.85 < ratio < 1.15, ratio
    assert abs(share - 10 / 60) < 0.01  # 2 px margin left out
    steps = np.searchsorted([10, 21, 32, 43, 54], np.arange(64), side="right")  # a brightness step per patch
    stepped = np.repeat((noise + 2.0 * (steps % 2))[..., None], 3, axis=2)
    assert bpq.seam_figure(stepped, src)[0] > 1.5


@pytest.mark.parametrize("period", [7.3, 12.0, 23.5])
def test_dominant_period_of_a_sine(period):
    rng = np.random.default_rng(5)
    y = np.arange(256, dtype=np.float64)[:, None]
    phase = rng.random(40)[None, :] * 2 * np.pi  # every column shifted: the period must not depend on it
    image = np.sin(2 * np.pi * y / period + phase) + 0.3 * rng.standard_normal((256, 40))
    assert abs(bpq.dominant_period(image, axis=0) / period - 1) < 0.02
    assert abs(bpq.dominant_period(image.T, axis=1) / period - 1) < 0.02


def test_dominant_period_of_a_brick_like_square_wave_and_of_noise():
    y = np.arange(200)[:, None]
    courses = ((y % 16) < 2).astype(float) * np.ones((1, 30))  # mortar line every 16 px
    assert abs(bpq.dominant_period(courses, 0) - 16.0) < 0.3
    rng = np.random.default_rng(6)
    noise = rng.random((200, 30))
    assert np.isnan(bpq.dominant_period(noise, 0))


def test_lattice_barycentrics_reproduce_the_positions():
    pos, tris = bpq.plane_mesh(5)
    P, tri, bary = bpq.lattice(16, 5)
    corners = pos[tris[tri]].astype(np.float64)
    w = np.stack([1 - bary[:, 0] - bary[:, 1], bary[:, 0], bary[:, 1]], 1)
    assert (bary >= -1e-6).all() and (w[:, 0] >= -1e-6).all()
    assert np.abs((w[:, :, None] * corners).sum(1) - P).max() < 1e-6


def test_turned_sample_turns_the_grain():
    image = stripes(160, 0.0)
    turned = bpq.turned_sample(image, 30, 96)
    grain, coherence = bpq.grain(turned)
    valid = bpq.margin_mask(grain.shape, 8)
    assert abs(np.degrees(bpq.dominant_grain(grain, coherence, valid)) - 30) < 1.0


def test_resample_reads_the_sample_at_pixel_centres():
    rng = np.random.default_rng(7)
    sample = rng.random((20, 30, 3))
    y, x = np.mgrid[0:5, 0:6].astype(np.float64)
    source = np.stack([x + 3.5, y + 10.5], axis=2)  # the centres of pixels (row 10.., column 3..)
    assert np.abs(bpq.resample(sample, source) - sample[10:15, 3:9]).max() < 1e-12
    source[0, 0] = [4.0, 10.5]  # halfway between columns 3 and 4
    assert np.allclose(bpq.resample(sample, source)[0, 0], 0.5 * (sample[10, 3] + sample[10, 4]))
    source[1, 1] = -1
    assert (bpq.resample(sample, source)[1, 1] == 0).all()


def test_detail_drops_for_a_blurred_image():
    rng = np.random.default_rng(8)
    image = rng.random((64, 64, 3))
    assert abs(bpq.detail(image, image) - 1) < 1e-12
    blurred = (image + np.roll(image, 1, 0) + np.roll(image, 1, 1) + np.roll(image, (1, 1), (0, 1))) / 4
    assert bpq.detail(blurred, image) < 0.8

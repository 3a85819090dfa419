# SPDX-License-Identifier: GPL-3.0-or-later
"""core/sample_image under plain pytest: integer samples (what Blender's decoding gives for 8- and 16-bit
files, issue 31) become exactly the floats texsynth_native and OpenImageIO make of them, bit for bit, so
caches and renders do not change when Blender decodes the sample instead of OpenImageIO."""
import os
import sys

import numpy as np
import pytest

import addon_package
import paths

SEED = os.path.join(paths.IMAGE_SEEDS, "rgb8.png")
sample_image = addon_package.load("core.sample_image")


def test_integer_pixels_become_the_floats_texsynth_native_makes(tmp_path):
    native = pytest.importorskip("texsynth_native")
    for dtype, top in ((np.uint8, 255), (np.uint16, 65535)):
        values = np.arange(top + 1, dtype=dtype).reshape(-1, 256, 1)  # every value the type holds
        floats = sample_image.sample_pixels(values)
        assert floats.dtype == np.float32 and floats.shape == values.shape and floats.flags.c_contiguous
        # The cache key hashes the float pixels image_from_pixels made: equal keys, equal bits.
        key = lambda image: native.cache_file_path(image, cache_dir=str(tmp_path), color_space="srgb")  # noqa: E731
        assert key(floats) == key(values), dtype
        assert sample_image.load_sample(values).dtype == dtype  # normalised by the native side, not here


def test_integer_pixels_become_the_floats_openimageio_decodes(tmp_path):
    native = pytest.importorskip("texsynth_native")
    try:
        native.image_info(SEED)
    except ValueError as error:
        pytest.skip("no texsynth_image_io in this build: %s" % error)
    sys.path.insert(0, paths.HOSTILE)
    import make_corpus
    for dtype, top in ((np.uint8, 255), (np.uint16, 65535)):
        values = np.arange(top + 1, dtype=dtype).reshape(-1, 256, 1)
        path = tmp_path / ("all_%d.png" % top)
        path.write_bytes(make_corpus.png_from_array(values))
        decoded = native.load_image(str(path))
        assert np.array_equal(sample_image.sample_pixels(values).view(np.uint32), decoded.view(np.uint32)), dtype


def test_a_sample_whose_edges_continue_each_other_looks_tileable():
    """border_seam_ratio (the particle analysis' Tileable when it is off): the step across the border against
    the sample's own steps between neighbours. A pattern with whole periods (and noise) repeats; the same
    pattern cut mid-period, a gradient, or a crop of a smooth photo-like field does not; a border that does not
    step at all (a flat colour, elements on a flat ground) says nothing, so it is not taken as repeating."""
    rng = np.random.default_rng(5)
    y, x = np.mgrid[0:96, 0:96] / 96.0
    whole = 0.5 + 0.4 * np.cos(2 * np.pi * 3 * x)[..., None] * np.cos(2 * np.pi * 2 * y)[..., None]
    pattern = np.repeat(whole, 3, axis=2)
    assert sample_image.repeats_across_border(pattern)
    assert sample_image.repeats_across_border(rng.random((64, 64, 3)))
    assert sample_image.border_seam_ratio(np.full((16, 16, 3), 0.3)) == 0.0
    ground = np.full((40, 40, 3), 0.3)
    ground[10:20, 12:25] = 0.8  # an element inside a flat border
    assert sample_image.border_seam_ratio(ground) == 0.0 and not sample_image.repeats_across_border(ground)
    assert not sample_image.repeats_across_border(pattern[:, :80])               # 2.5 periods across
    assert not sample_image.repeats_across_border(np.repeat(x[..., None], 3, axis=2))  # a gradient
    smooth = np.cumsum(np.cumsum(rng.random((256, 256)) - 0.5, axis=0), axis=1)
    assert not sample_image.repeats_across_border(smooth[..., None])
    assert sample_image.border_seam_ratio(np.zeros((2, 40, 3))) == float("inf")  # too small to tell: not tileable

# SPDX-License-Identifier: GPL-3.0-or-later
"""Python API of image loading and preprocessing (texsynth_native)."""
import os
import pathlib

import numpy as np
import pytest

import texsynth_native as ts


def bricks(height=48, width=56, seed=0):
    """Texture-like RGB uint8 sample: bricks with mortar and noise."""
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:height, 0:width]
    row = y // 12
    shifted = x + (row % 2) * 10
    mortar = ((y % 12) < 2) | ((shifted % 20) < 2)
    tint = rng.random((height // 12 + 2, width // 20 + 3))[row, shifted // 20]
    img = np.empty((height, width, 3), np.float32)
    img[..., 0] = np.where(mortar, 0.7, 0.4 + 0.3 * tint)
    img[..., 1] = np.where(mortar, 0.7, 0.2 + 0.1 * tint)
    img[..., 2] = np.where(mortar, 0.7, 0.1)
    img += rng.normal(0, 0.03, img.shape)
    return (np.clip(img, 0, 1) * 255).astype(np.uint8)


@pytest.fixture(scope="module")
def sample():
    return bricks()


@pytest.fixture(scope="module")
def result(sample):
    return ts.preprocess(sample, num_textons=30, seed=3)


def test_result_shapes_and_types(result, sample):
    h, w = sample.shape[:2]
    assert (result.width, result.height, result.num_textons, result.texton_dims) == (w, h, 30, 16)
    assert result.texton_map.shape == (h, w) and result.texton_map.dtype == np.int32
    assert result.textons.shape == (30, 16) and result.textons.dtype == np.float32
    assert result.texton_distances.shape == (30, 30)
    assert result.bucket_start.shape == (31,)
    assert result.bucket_pixels.shape == (h * w,)
    assert result.jump_targets.shape == (h, w, 4) and result.jump_targets.dtype == np.int32
    assert result.jump_weights.shape == (h, w, 4) and result.jump_weights.dtype == np.float32
    assert result.cache_hit is False and result.cache_status == "uncached"
    assert result.params["neighbourhood"] == 11 and result.params["seed"] == 3
    assert isinstance(result.sample_hash, int)


def test_tables_agree_with_numpy(result):
    t = result.textons.astype(np.float64)
    direct = ((t[:, None, :] - t[None, :, :]) ** 2).sum(-1)
    np.testing.assert_allclose(result.texton_distances, direct, rtol=1e-4, atol=1e-3)
    assert np.array_equal(result.texton_distances, result.texton_distances.T)
    assert np.all(np.diag(result.texton_distances) == 0)
    flat = result.texton_map.ravel()
    assert sorted(result.bucket_pixels.tolist()) == list(range(flat.size))
    for t in range(result.num_textons):
        members = result.bucket_pixels[result.bucket_start[t]:result.bucket_start[t + 1]]
        assert np.all(flat[members] == t)
    sums = result.jump_weights.sum(-1)
    assert np.all(sums <= 1 + 1e-6)
    assert np.all(result.jump_weights[result.jump_targets < 0] == 0)


def test_arrays_are_copies(result):
    m = result.texton_map
    m[:] = -5
    assert result.texton_map.min() >= 0


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16, np.float16, np.float32])
def test_numpy_input_types(sample, dtype):
    if np.issubdtype(dtype, np.integer):
        arr = (sample.astype(np.float64) / 255 * np.iinfo(dtype).max).astype(dtype)
    else:
        arr = (sample.astype(np.float32) / 255).astype(dtype)
    r = ts.preprocess(arr, num_textons=10)
    assert r.texton_map.shape == sample.shape[:2]
    gray = ts.preprocess(np.ascontiguousarray(arr[..., 0]), num_textons=10)
    assert gray.texton_map.shape == sample.shape[:2]


def test_non_contiguous_array_equals_contiguous(sample):
    wide = np.concatenate([sample, sample], axis=1)[:, ::2]
    a = ts.preprocess(wide, num_textons=12)
    b = ts.preprocess(np.ascontiguousarray(wide), num_textons=12)
    assert a.sample_hash == b.sample_hash
    assert np.array_equal(a.texton_map, b.texton_map)


@pytest.mark.parametrize("bad,fragment", [
    (np.zeros((20, 20, 3), np.float64), "dtype"),
    (np.zeros((20, 20, 5), np.uint8), "channels"),
    (np.zeros((2, 20, 20, 3), np.uint8), "dimensions"),
    (np.zeros((1, 1, 3), np.uint8), "smaller than"),
    (np.full((20, 20), np.nan, np.float32), "NaN"),
    (12, "file path or a numpy array"),
])
def test_bad_arrays_raise_value_error(bad, fragment):
    with pytest.raises(ValueError, match=fragment):
        ts.preprocess(bad)


@pytest.mark.parametrize("kwargs,fragment", [
    (dict(neighbourhood=10), "odd"),
    (dict(neighbourhood=0), "odd"),
    (dict(neighbourhood=-5), "odd"),
    (dict(num_textons=48 * 56 + 1), "pixel count"),
    (dict(jump_candidates=0), "jump_candidates"),
])
def test_bad_params_raise_and_write_nothing(sample, tmp_path, kwargs, fragment):
    cache = tmp_path / "cache"
    with pytest.raises(ValueError, match=fragment):
        ts.preprocess(sample, cache_dir=cache, **kwargs)
    assert not cache.exists()


def test_bad_files_raise_value_error(tmp_path):
    (tmp_path / "empty.png").write_bytes(b"")
    (tmp_path / "junk.png").write_bytes(os.urandom(500))
    for path, fragment in [(tmp_path / "empty.png", "empty"), (tmp_path / "junk.png", "junk.png"),
                           (tmp_path / "nope.png", "does not exist"), (tmp_path, "directory")]:
        with pytest.raises(ValueError, match=fragment):
            ts.preprocess(path)
        with pytest.raises(ValueError):
            ts.load_image(path)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["empty.png", "junk.png"]


def test_load_image_and_info_via_written_texton_map(result, tmp_path):
    out = tmp_path / "textons.png"
    result.write_texton_map_image(out)
    info = ts.image_info(out)
    assert (info["width"], info["height"], info["channels"]) == (result.width, result.height, 3)
    assert info["format"] == "png"
    pixels = ts.load_image(str(out))
    assert pixels.dtype == np.float32 and pixels.shape == (result.height, result.width, 3)
    expected = result.texton_map_image()
    assert expected.dtype == np.uint8 and expected.shape == pixels.shape
    np.testing.assert_array_equal(np.round(pixels * 255).astype(np.uint8), expected)
    # Same label <-> same colour.
    labels = result.texton_map.ravel()
    colours = expected.reshape(-1, 3)
    for t in range(result.num_textons):
        assert len({tuple(c) for c in colours[labels == t]}) <= 1


def test_path_and_array_inputs_agree(result, tmp_path):
    # A PNG written by OIIO, read back as a path and as the decoded array, hashes and clusters the same.
    path = tmp_path / "s.png"
    result.write_texton_map_image(path)
    from_path = ts.preprocess(path, num_textons=15)
    from_array = ts.preprocess((ts.load_image(path) * 255).round().astype(np.uint8), num_textons=15)
    assert from_path.sample_hash == from_array.sample_hash
    assert np.array_equal(from_path.texton_map, from_array.texton_map)


def test_cache_flow(sample, tmp_path):
    cache = tmp_path / "cache"
    params = dict(num_textons=20, seed=1)
    path = ts.cache_file_path(sample, cache_dir=cache, **params)
    first = ts.preprocess(sample, cache_dir=cache, **params)
    name = pathlib.Path(path).name
    assert name.startswith(f"{first.sample_hash:016x}-") and name.endswith(".tscache")
    assert ts.cache_status(sample, cache_dir=cache, **params) == "fresh"
    assert first.cache_hit is False and first.cache_status == "miss"
    second = ts.preprocess(sample, cache_dir=str(cache), **params)
    assert second.cache_hit is True and second.cache_status == "hit"
    for attr in ("texton_map", "textons", "texton_distances", "jump_targets", "jump_weights"):
        assert np.array_equal(getattr(first, attr), getattr(second, attr)), attr
    assert ts.cache_status(sample, cache_dir=cache, num_textons=21) == "missing"

    data = bytearray(pathlib.Path(path).read_bytes())
    data[len(data) // 3] ^= 0xFF
    pathlib.Path(path).write_bytes(bytes(data))
    assert ts.cache_status(sample, cache_dir=cache, **params) == "stale"
    with pytest.raises(ts.CacheError, match="checksum"):
        ts.load_preprocessed(path)
    third = ts.preprocess(sample, cache_dir=cache, **params)
    assert third.cache_status == "recomputed-corrupt" and not third.cache_hit
    assert np.array_equal(third.jump_targets, first.jump_targets)
    assert ts.cache_status(sample, cache_dir=cache, **params) == "fresh"


def test_save_and_load_preprocessed(result, tmp_path):
    path = tmp_path / "r.tscache"
    result.save(path)
    loaded = ts.load_preprocessed(path, expected_hash=result.sample_hash)
    assert loaded.cache_hit
    for attr in ("texton_map", "textons", "texton_distances", "bucket_start", "bucket_pixels",
                 "jump_targets", "jump_weights"):
        assert np.array_equal(getattr(result, attr), getattr(loaded, attr)), attr
    assert loaded.params == result.params
    with pytest.raises(ts.CacheError, match="different sample"):
        ts.load_preprocessed(path, expected_hash=result.sample_hash ^ 1)
    pathlib.Path(path).write_bytes(pathlib.Path(path).read_bytes()[:100])
    with pytest.raises(ts.CacheError, match="truncated"):
        ts.load_preprocessed(path)
    with pytest.raises(ts.CacheError):
        ts.load_preprocessed(tmp_path / "missing.tscache")


def test_color_space_override(sample):
    # Blender hands over float pixels that may still be sRGB-encoded: color_space="srgb" must make them
    # identical to the 8-bit sample; "auto" treats float as linear, which changes the result.
    as_float = sample.astype(np.float32) * np.float32(1 / 255)  # same rounding as the native uint8 path
    ref = ts.preprocess(sample, num_textons=12)
    same = ts.preprocess(as_float, num_textons=12, color_space="srgb")
    linear = ts.preprocess(as_float, num_textons=12)
    assert same.sample_hash == ref.sample_hash
    assert np.array_equal(same.texton_map, ref.texton_map)
    assert linear.sample_hash != ref.sample_hash
    with pytest.raises(ValueError, match="color_space"):
        ts.preprocess(sample, color_space="rec2020")


def test_working_size_analyses_a_smaller_copy_and_keys_the_cache(tmp_path):
    big = bricks(300, 200, seed=4)
    pre = ts.preprocess(big, working_size=100, num_textons=40)
    assert (pre.width, pre.height, pre.sample_width, pre.sample_height) == (67, 100, 200, 300)
    assert pre.texton_map.shape == (100, 67) and pre.jump_targets.shape == (100, 67, 4)
    assert pre.params["working_size"] == 100
    own = ts.preprocess(big, working_size=0, num_textons=40)
    assert (own.width, own.height) == (200, 300)
    assert ts.cache_file_path(big, cache_dir=tmp_path, working_size=100) != \
        ts.cache_file_path(big, cache_dir=tmp_path, working_size=0)
    first = ts.preprocess(big, working_size=100, num_textons=40, cache_dir=tmp_path)
    again = ts.preprocess(big, working_size=100, num_textons=40, cache_dir=tmp_path)
    assert again.cache_hit and (again.width, again.sample_width) == (67, 200)
    assert np.array_equal(again.jump_targets, first.jump_targets)


def test_texton_synthesis_takes_the_full_sample_after_a_working_size():
    from mesh_arrays import polygon_grid
    big = (bricks(160, 120, seed=5) / 255.0).astype(np.float32)
    pre = ts.preprocess(big, working_size=80, jump_candidates=2)
    mesh = polygon_grid(5, 0.2, triangles=False)
    out = ts.synthesize_texton(pre, big, *mesh, scale=8.0, seed=1)
    assert np.isfinite(out["edge_error"]).all() and out["base_uv"].shape[0] == mesh[1].size
    with pytest.raises(ValueError, match="sample"):
        ts.synthesize_texton(pre, big[:, :-3], *mesh, scale=8.0)  # neither the analysis nor the given size


@pytest.mark.parametrize("kwargs,fragment", [
    (dict(working_size=-1), "working_size must be"),
    (dict(working_size=63), "working_size must be"),
    (dict(working_size=5000), "working_size must be"),
    (dict(working_size=0), "set a working size"),
])
def test_oversized_or_bad_working_size_raises(kwargs, fragment):
    gray = np.zeros((4097, 4097), np.uint8)
    with pytest.raises(ValueError, match=fragment):
        ts.preprocess(gray, **kwargs)

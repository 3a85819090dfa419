# SPDX-License-Identifier: GPL-3.0-or-later
"""texsynth_native.histogram_transform: Gaussianized sample + inverse LUT (Heitz & Neyret 2018)."""
import os
import pathlib
import time

import numpy as np
import pytest

import texsynth_native as ts


def noise_sample(height=40, width=52, channels=3, seed=0):
    """Smooth-histogram uint8 sample (many ties, like a real 8-bit texture)."""
    rng = np.random.default_rng(seed)
    return rng.integers(0, 256, (height, width, channels), dtype=np.uint8)


def lookup(lut, channel, g):
    """The inverse LUT as a linearly filtered lut_size x 1 texture reads it (entry centres (i+0.5)/L)."""
    size = lut.shape[0]
    return np.interp(g * size - 0.5, np.arange(size), lut[:, channel].astype(np.float64))


def test_shapes_types_and_statistics():
    sample = np.random.default_rng(1).random((64, 48, 4), dtype=np.float32)
    out = ts.histogram_transform(sample, lut_size=256)
    assert set(out) == {"gaussian", "inverse_lut", "ok", "fallback_reason", "colour_channels",
                        "gaussian_path", "lut_path"}
    assert out["gaussian"].shape == (64, 48, 4) and out["gaussian"].dtype == np.float32
    assert out["inverse_lut"].shape == (256, 4) and out["inverse_lut"].dtype == np.float32
    assert out["ok"] is True and out["fallback_reason"] == "" and out["colour_channels"] == 3
    assert out["gaussian_path"] is None and out["lut_path"] is None
    g = out["gaussian"][..., :3].reshape(-1, 3)
    assert np.all((g >= 0) & (g <= 1))
    np.testing.assert_allclose(g.mean(0), 0.5, atol=1e-3)
    np.testing.assert_allclose(g.std(0), 1 / 6, rtol=0.01)
    assert np.array_equal(out["gaussian"][..., 3], sample[..., 3])  # alpha untouched
    identity = ((np.arange(256) + 0.5) / 256).astype(np.float32)
    assert np.array_equal(out["inverse_lut"][:, 3], identity)
    assert np.all(np.diff(out["inverse_lut"][:, :3], axis=0) >= 0)
    # The LUT maps Gaussian values back onto the sample's own values.
    for c in range(3):
        back = lookup(out["inverse_lut"], c, out["gaussian"][..., c])
        assert np.mean(np.abs(back - sample[..., c])) < 0.01


def test_uint8_values_are_encoded_values_and_ties_map_together():
    sample = noise_sample()
    out = ts.histogram_transform(sample)
    values = sample[..., 0].ravel()
    g = out["gaussian"][..., 0].ravel()
    for v in np.unique(values)[:20]:
        assert np.unique(g[values == v]).size == 1
    order = np.argsort(values, kind="stable")
    assert np.all(np.diff(g[order]) >= 0)
    lut = out["inverse_lut"]
    # Not linearised: the LUT spans the sample's 0..1 encoded values.
    assert lut[0, 0] < 0.02 and lut[-1, 0] > 0.98 and lut.shape == (1024, 3)
    assert np.array_equal(ts.histogram_transform(sample)["gaussian"], out["gaussian"])  # deterministic


def test_path_and_array_agree(tmp_path):
    # An 8-bit PNG written by OpenImageIO (the texton map picture), as a path and as its decoded array.
    path = tmp_path / "s.png"
    ts.preprocess(noise_sample(seed=4), num_textons=40).write_texton_map_image(path)
    decoded = (ts.load_image(path) * 255).round().astype(np.uint8)
    from_path, from_array = ts.histogram_transform(path), ts.histogram_transform(decoded)
    assert np.array_equal(from_path["gaussian"], from_array["gaussian"])
    assert np.array_equal(from_path["inverse_lut"], from_array["inverse_lut"])


def test_files_are_written_and_reused(tmp_path):
    sample = noise_sample(seed=2)
    cache = tmp_path / "cache"
    first = ts.histogram_transform(sample, cache_dir=cache, lut_size=64)
    gauss, lut = pathlib.Path(first["gaussian_path"]), pathlib.Path(first["lut_path"])
    assert gauss.parent == cache and lut.parent == cache
    assert gauss.name.endswith("-hist64.gauss.exr") and lut.name == gauss.name.replace(".gauss.exr", ".lut.exr")
    assert sorted(p.name for p in cache.iterdir()) == sorted([gauss.name, lut.name])  # no temporaries left
    # The files are what the dict holds.
    assert np.array_equal(ts.load_image(gauss), first["gaussian"])
    assert np.array_equal(ts.load_image(lut)[0], first["inverse_lut"])
    stamps = (gauss.stat().st_mtime_ns, lut.stat().st_mtime_ns)
    time.sleep(0.05)
    second = ts.histogram_transform(sample, cache_dir=str(cache), lut_size=64)
    assert (gauss.stat().st_mtime_ns, lut.stat().st_mtime_ns) == stamps
    for key in ("gaussian", "inverse_lut"):
        assert np.array_equal(first[key], second[key]), key
    assert second["gaussian_path"] == first["gaussian_path"]

    # A corrupt file is recomputed and rewritten.
    gauss.write_bytes(gauss.read_bytes()[:200])
    third = ts.histogram_transform(sample, cache_dir=cache, lut_size=64)
    assert np.array_equal(third["gaussian"], first["gaussian"])
    assert gauss.stat().st_size > 200


@pytest.mark.parametrize("kwargs,fragment", [
    (dict(lut_size=8), "lut_size"),
    (dict(lut_size=65537), "lut_size"),
    (dict(min_distinct_values=1), "min_distinct_values"),
    (dict(color_space="cmyk"), "color_space"),
])
def test_bad_arguments_raise_value_error_and_write_nothing(tmp_path, kwargs, fragment):
    cache = tmp_path / "cache"
    with pytest.raises(ValueError, match=fragment):
        ts.histogram_transform(noise_sample(), cache_dir=cache, **kwargs)
    assert not cache.exists()


def test_bad_samples_raise_value_error(tmp_path):
    with pytest.raises(ValueError, match="NaN"):
        ts.histogram_transform(np.full((8, 8), np.nan, np.float32))
    with pytest.raises(ValueError, match="does not exist"):
        ts.histogram_transform(tmp_path / "missing.png")
    with pytest.raises(ValueError):
        ts.histogram_transform(np.zeros((8, 8, 5), np.uint8))
    with pytest.raises(ValueError, match="cache_dir"):
        ts.histogram_transform(noise_sample(), cache_dir=12)


def test_constant_image_falls_back_to_identity(tmp_path):
    flat = np.full((16, 16, 3), 128, np.uint8)
    out = ts.histogram_transform(flat, cache_dir=tmp_path, lut_size=32)
    assert out["ok"] is False
    assert out["fallback_reason"].startswith("channel 0 is constant")
    assert np.array_equal(out["gaussian"], flat.astype(np.float32) / 255)
    identity = ((np.arange(32) + 0.5) / 32).astype(np.float32)
    assert np.array_equal(out["inverse_lut"], np.repeat(identity[:, None], 3, axis=1))
    assert not np.isnan(out["gaussian"]).any() and not np.isnan(out["inverse_lut"]).any()
    assert os.path.isfile(out["gaussian_path"]) and os.path.isfile(out["lut_path"])
    again = ts.histogram_transform(flat, cache_dir=tmp_path, lut_size=32)
    assert again["ok"] is False and again["fallback_reason"] == out["fallback_reason"]

    two_tone = np.zeros((16, 16), np.uint8)
    two_tone[::2] = 255
    out = ts.histogram_transform(two_tone)
    assert out["ok"] is False and out["colour_channels"] == 1
    assert out["fallback_reason"] == "channel 0 has only 2 distinct values (at least 16 are needed)"
    assert ts.histogram_transform(two_tone, min_distinct_values=2)["ok"] is True

# SPDX-License-Identifier: GPL-3.0-or-later
"""The sample image as the native module and the shaders see it: loading, size, pixels and the
statistics Auto blending is chosen on (mean, periodicity, correlation length); bpy-free."""
import math
import os

import numpy as np

from .. import native
from .finite import all_finite
from .settings import SettingsError


def blender_pixels_to_image(flat_pixels, width, height, channels):
    """Blender's bottom-up float RGBA(...) pixel buffer -> contiguous float32 H x W x C, row 0 = top."""
    pixels = np.asarray(flat_pixels, dtype=np.float32)
    if width <= 0 or height <= 0 or channels <= 0 or pixels.size != width * height * channels:
        raise SettingsError("image buffer has %d values, expected %d x %d x %d"
                            % (pixels.size, width, height, channels))
    if not np.all(np.isfinite(pixels)):
        raise SettingsError("image contains NaN or infinite pixel values")
    return np.ascontiguousarray(pixels.reshape(height, width, channels)[::-1])


def load_sample(sample):
    """A file path (str) or an H x W x C image array (row 0 = top); returns what preprocess accepts."""
    if isinstance(sample, str):
        if not sample:
            raise SettingsError("no sample image given")
        if not os.path.isfile(sample):
            raise SettingsError("sample image not found: %s" % sample)
        return sample
    array = np.asarray(sample)
    if array.ndim != 3 or array.shape[0] < 1 or array.shape[1] < 1 or array.shape[2] not in (1, 2, 3, 4):
        raise SettingsError("sample image array must be H x W x C with C in 1..4, got shape %s" % (array.shape,))
    if array.dtype in (np.uint8, np.uint16):  # normalised (and taken as sRGB) by the native side
        return np.ascontiguousarray(array)
    return np.ascontiguousarray(array, dtype=np.float32)


_INTEGER_SCALES = {np.uint8: np.float32(1.0) / np.float32(255.0), np.uint16: np.float32(1.0) / np.float32(65535.0)}


def sample_size(native_input):
    """(width, height) of a sample path (header only, nothing decoded) or H x W x C array."""
    if isinstance(native_input, str):
        info = native.require().image_info(native_input)
        return int(info["width"]), int(info["height"])
    shape = np.shape(native_input)
    return int(shape[1]), int(shape[0])


def sample_pixels(native_input):
    """The sample as float32 H x W x C (what synthesize_texton needs for E_t): decodes a path."""
    if isinstance(native_input, str):
        return native.require().load_image(native_input)
    array = np.asarray(native_input)
    if array.dtype.type in _INTEGER_SCALES:
        # As image_from_pixels: times the float32 reciprocal, not a division, so every value is bit-identical.
        return array.astype(np.float32, order="C") * _INTEGER_SCALES[array.dtype.type]
    return np.ascontiguousarray(array, dtype=np.float32)


def srgb_to_linear(values):
    """The sRGB transfer function inverted (what Blender does to an sRGB image before shading)."""
    values = np.asarray(values, dtype=np.float64)
    return np.where(values <= 0.04045, values / 12.92, ((np.maximum(values, 0.04045) + 0.055) / 1.055) ** 2.4)


def shader_mean(pixels, srgb, rows_per_chunk=128):
    """Mean colour (3 values) of an H x W x C sample as Blender's shaders read it: sRGB decoded when
    the image is sRGB; grey images repeat their one channel. Row chunks in float32, sums in float64:
    an 8K sample took 33 s and 5 GB as one float64 array, now about 2 s and a few MB."""
    pixels = np.asarray(pixels)
    channels = pixels.shape[2]
    used = 1 if channels <= 2 else 3
    total = np.zeros(used)
    for top in range(0, pixels.shape[0], rows_per_chunk):
        chunk = np.asarray(pixels[top:top + rows_per_chunk, :, :used], dtype=np.float32)
        if srgb:
            linear = chunk / np.float32(12.92)
            bright = chunk > np.float32(0.04045)
            linear[bright] = ((chunk[bright] + np.float32(0.055)) / np.float32(1.055)) ** np.float32(2.4)
            chunk = linear
        total += chunk.reshape(-1, used).astype(np.float64).sum(axis=0)
    mean = total / max(1, pixels.shape[0] * pixels.shape[1])
    return tuple(float(m) for m in (np.repeat(mean, 3) if used == 1 else mean))


def _autocorrelation(pixels, max_side):
    """Circular autocorrelation (by FFT) of a centred crop of max_side texels, colour channels
    standardised and averaged; None when every channel is constant."""
    pixels = np.asarray(pixels)
    top, left = max(0, (pixels.shape[0] - max_side) // 2), max(0, (pixels.shape[1] - max_side) // 2)
    pixels = pixels[top:top + max_side, left:left + max_side].astype(np.float64)
    colour = pixels[:, :, :1] if pixels.shape[2] <= 2 else pixels[:, :, :3]
    total = np.zeros(colour.shape[:2])
    used = 0
    for c in range(colour.shape[2]):
        channel = colour[:, :, c] - colour[:, :, c].mean()
        power = np.abs(np.fft.rfft2(channel)) ** 2
        auto = np.fft.irfft2(power, s=channel.shape)
        if auto[0, 0] > 1e-12:
            total += auto / auto[0, 0]
            used += 1
    return total / used if used else None


def periodicity(pixels, max_side=512):
    """The sample's largest autocorrelation at offsets beyond a quarter of its width or height (the
    render benchmark's repetition measure): ~0.95 for bricks, ~0.1 for moss or bark. 0 if constant."""
    total = _autocorrelation(pixels, max_side)
    if total is None:
        return 0.0
    height, width = total.shape
    dy = np.minimum(np.arange(height), height - np.arange(height))[:, None]
    dx = np.minimum(np.arange(width), width - np.arange(width))[None, :]
    far = (dx > width // 4) | (dy > height // 4)
    return float(total[far].max()) if far.any() else 0.0


def correlation_length(pixels, max_lag=64, max_side=512):
    """Correlation length (texels) of an H x W x C sample: the smallest offset along x or y at which
    its autocorrelation (colour channels standardised and averaged; circular, by FFT) falls below
    exp(-1/2), the value a Gaussian autocorrelation exp(-d^2 / (2 l^2)) has at d = l. Constant
    samples give 1. Lags go up to max_lag, so a centred crop of max_side texels is enough: a 4K
    sample would otherwise cost seconds and GBs of FFT buffers on every run."""
    total = _autocorrelation(pixels, max_side)
    if total is None:
        return 1.0
    height, width = total.shape
    threshold = math.exp(-0.5)
    for lag in range(1, max(2, min(max_lag, width // 2, height // 2))):
        if min(total[0, lag], total[lag, 0]) < threshold:
            # Linear interpolation between lag - 1 and lag on the axis that crossed first.
            row = total[0, lag - 1:lag + 1] if total[0, lag] < threshold else total[lag - 1:lag + 1, 0]
            return float(lag - 1 + (row[0] - threshold) / max(row[0] - row[1], 1e-12))
    return float(max_lag)


# A sample repeats when the step across its border (last column to first, last row to first) is no larger than
# its own steps between neighbouring columns and rows: the border's mean difference at most this many times the
# median of theirs (docs/algorithms/texture_particles.md "Tileable samples": tileable patterns of the corpus
# 0.94-7.1, crops of photos 10.0-343).
REPEAT_SEAM_RATIO = 8.5
BORDER_SEAM_LINES = 256


def border_seam_ratio(pixels):
    """The larger over x and y of (mean |first - last| column or row) / (median of the mean |difference|
    between neighbouring columns or rows) of an H x W (x C) sample; 0 where the border does not step at
    all, inf below 3 px. The median, not a high percentile: where elements lie on a flat ground, an element
    cut by the border steps like an element's edge, which a high percentile counts as ordinary."""
    pixels = np.asarray(pixels, np.float32)
    if pixels.ndim == 2:
        pixels = pixels[..., None]
    if pixels.ndim != 3 or min(pixels.shape[:2]) < 3:
        return math.inf
    ratios = []
    for image in (pixels, pixels.transpose(1, 0, 2)):
        # at most BORDER_SEAM_LINES rows, evenly spaced: the same ratio to ~1 % in 1/8 of the time at 2048 px
        image = image[np.unique(np.linspace(0, image.shape[0] - 1, BORDER_SEAM_LINES).round().astype(np.intp))]
        steps = np.abs(np.diff(image, axis=1)).mean(axis=(0, 2), dtype=np.float64)
        seam = float(np.abs(image[:, 0] - image[:, -1]).mean(dtype=np.float64))
        typical = float(np.median(steps))
        ratios.append(0.0 if seam == 0.0 else seam / typical if typical > 0.0 else math.inf)
    return max(ratios)


def repeats_across_border(pixels):
    """True when the sample's edges continue each other as its pixels continue their neighbours. A border
    that does not step at all (elements on a flat ground, none cut) says nothing either way: False."""
    return 0.0 < border_seam_ratio(pixels) <= REPEAT_SEAM_RATIO


def synthesis_sample(pixels_top_first):
    """H x W x C (row 0 = top) -> float32 H x W x 3|4 with row 0 = bottom (Blender's pixel order, which
    round_synthesize expects: rows grow along the texture's up). Grey samples become RGB."""
    pixels = np.asarray(pixels_top_first, dtype=np.float32)
    if pixels.ndim != 3 or pixels.shape[0] < 2 or pixels.shape[1] < 2:
        raise SettingsError("sample must be an image of at least 2 x 2 pixels, got shape %s" % (pixels.shape,))
    channels = pixels.shape[2]
    if channels == 1:
        pixels = np.repeat(pixels, 3, axis=2)
    elif channels == 2:  # grey + alpha
        pixels = np.concatenate([np.repeat(pixels[:, :, :1], 3, axis=2), pixels[:, :, 1:]], axis=2)
    if not all_finite(pixels):
        raise SettingsError("sample contains NaN or infinite pixel values")
    return np.ascontiguousarray(pixels[::-1])

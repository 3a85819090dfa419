# SPDX-License-Identifier: GPL-3.0-or-later
"""Render-quality measures for blending (bpy-free, numpy only), used by bench_blend_quality.py:

- seam ratio: mean |grad L| on mesh-edge pixels / on interior pixels (1.0 = seams invisible);
- detail: mean |grad L| of a render / that of plain tiling rendered the same way (< 1 = washed out);
- gradient profile: mean |grad L| by distance from the nearest mesh edge, relative to its mean;
- repetition: the largest normalised autocorrelation of L at lags beyond a quarter of the sample width.
"""
import numpy as np


def luminance(rgb):
    """Rec. 709 luminance of an (H, W, 3+) float image."""
    return rgb[..., 0] * 0.2126 + rgb[..., 1] * 0.7152 + rgb[..., 2] * 0.0722


def gradient_magnitude(image):
    """|grad| by central differences; the one-pixel border is NaN (no centred neighbours)."""
    grad = np.full(image.shape, np.nan)
    dx = (image[1:-1, 2:] - image[1:-1, :-2]) * 0.5
    dy = (image[2:, 1:-1] - image[:-2, 1:-1]) * 0.5
    grad[1:-1, 1:-1] = np.hypot(dx, dy)
    return grad


def edge_distance(mask, max_distance):
    """Chessboard distance (pixels) of every pixel to the nearest True pixel of mask, capped at
    max_distance + 1 (by repeated 8-neighbour dilation)."""
    distance = np.where(mask, 0, max_distance + 1).astype(np.int32)
    reached = mask.copy()
    for step in range(1, max_distance + 1):
        grown = reached.copy()
        grown[1:, :] |= reached[:-1, :]
        grown[:-1, :] |= reached[1:, :]
        grown[:, 1:] |= reached[:, :-1]
        grown[:, :-1] |= reached[:, 1:]
        grown[1:, 1:] |= reached[:-1, :-1]
        grown[1:, :-1] |= reached[:-1, 1:]
        grown[:-1, 1:] |= reached[1:, :-1]
        grown[:-1, :-1] |= reached[1:, 1:]
        distance[grown & ~reached] = step
        reached = grown
    return distance


def seam_ratio(grad, distance, valid, edge_within=1, interior_from=3):
    """Mean |grad| where the distance to an edge is <= edge_within, over the mean where it is >= interior_from."""
    ok = valid & np.isfinite(grad)
    edge = grad[ok & (distance <= edge_within)]
    interior = grad[ok & (distance >= interior_from)]
    return float(edge.mean() / interior.mean())


def gradient_profile(grad, distance, valid, max_distance):
    """Mean |grad| at each distance 0..max_distance, divided by the mean over those distances."""
    ok = valid & np.isfinite(grad)
    means = np.array([grad[ok & (distance == d)].mean() for d in range(max_distance + 1)])
    return means / means.mean()


def mean_gradient(grad, valid):
    ok = valid & np.isfinite(grad)
    return float(grad[ok].mean())


def autocorrelation_peak(image, min_lag):
    """Largest autocorrelation of (image - mean), normalised by lag 0, over lags with |lag| > min_lag in
    x or y (circular, by FFT). Plain tiling of a sample of width w peaks near 1 at lag w."""
    centred = image - image.mean()
    spectrum = np.fft.rfft2(centred)
    correlation = np.fft.irfft2(spectrum * np.conj(spectrum), s=centred.shape)
    correlation /= correlation[0, 0]
    height, width = correlation.shape
    lag_y = np.minimum(np.arange(height), height - np.arange(height))[:, None]
    lag_x = np.minimum(np.arange(width), width - np.arange(width))[None, :]
    far = (np.maximum(lag_y, lag_x) > min_lag) & (lag_y < height // 2) & (lag_x < width // 2)
    return float(correlation[far].max())


def jittered_plane_arrays(cells, width, seed):
    """(positions (V, 3) float32, triangles (T, 3) int32) over [-width/2, width/2]^2: interior vertices
    jittered by up to 0.3 cell, each cell split along a random diagonal (the blending benchmarks' plane)."""
    rng = np.random.default_rng(seed)
    step = width / cells
    ys, xs = np.mgrid[0:cells + 1, 0:cells + 1].astype(np.float64)
    jitter = rng.uniform(-0.3, 0.3, (cells + 1, cells + 1, 2))
    jitter[(xs == 0) | (xs == cells) | (ys == 0) | (ys == cells)] = 0.0
    px = (xs + jitter[..., 0]) * step - width / 2
    py = (ys + jitter[..., 1]) * step - width / 2
    positions = np.stack([px.ravel(), py.ravel(), np.zeros(px.size)], 1).astype(np.float32)
    triangles = []
    for y in range(cells):
        for x in range(cells):
            a, b, c, d = y * (cells + 1) + x, y * (cells + 1) + x + 1, (y + 1) * (cells + 1) + x + 1, \
                (y + 1) * (cells + 1) + x
            triangles += [(a, b, c), (a, c, d)] if rng.random() < 0.5 else [(a, b, d), (b, c, d)]
    return positions, np.array(triangles, np.int32)

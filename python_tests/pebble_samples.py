# SPDX-License-Identifier: GPL-3.0-or-later
"""A sample of separated pebbles that differ only in brightness, shared by the particle tests and
python_tests/bench/bench_particles_classes.py."""
import math

import numpy as np


def pebble_field(w=256, count=60, seed=3, gap=4.0):
    """(sample, element per pixel, brightness per pebble): separated ellipses of brightness 0.55-0.8 on a ground
    of 0.3, thrown at random on the torus and drawn wrapped (a crop of a stationary field)."""
    rng = np.random.default_rng(seed)
    element = -np.ones((w, w), np.int32)
    ys, xs = np.mgrid[0:w, 0:w] + 0.5
    brightness = []
    while len(brightness) < count:
        a, b, t = rng.uniform(8, 12), rng.uniform(5.5, 8), rng.uniform(0, math.pi)
        cx, cy = rng.uniform(0, w, 2)
        dx, dy = (xs - cx + w / 2) % w - w / 2, (ys - cy + w / 2) % w - w / 2
        u, v = dx * math.cos(t) + dy * math.sin(t), -dx * math.sin(t) + dy * math.cos(t)
        if (element[(u / (a + gap)) ** 2 + (v / (b + gap)) ** 2 <= 1] >= 0).any():
            continue
        element[(u / a) ** 2 + (v / b) ** 2 <= 1] = len(brightness)
        brightness.append(rng.uniform(0.55, 0.8))
    brightness = np.array(brightness)
    value = np.where(element >= 0, brightness[np.maximum(element, 0)], 0.3)
    return (value[..., None] * [1.0, 0.95, 0.85]).astype(np.float32), element, brightness


def brightness_labels(element, brightness, k):
    """The artist's label image: pebbles in k classes of equal counts by brightness, ground 0."""
    rank = np.argsort(np.argsort(brightness))
    labels = np.zeros(element.shape, np.int32)
    labels[element >= 0] = 1 + rank[element[element >= 0]] * k // len(brightness)
    return labels

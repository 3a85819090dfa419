# SPDX-License-Identifier: GPL-3.0-or-later
"""Pure helpers of bench_particles_corpus.py (issue 30, "Use the benchmark corpus"): densities, class shares,
a repeating sample's particles tiled 3 x 3, the typical-element range and the share of placed particles inside it; and whether a sample repeats (seam_ratio,
run as a script over the corpus, through the add-on's bpy-free core/sample_image). numpy, no native module
(except the script).
"""
import os
import sys

import numpy as np

from touching_metrics import AREA_SLACK, ASPECT_SLACK

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))  # python_tests: addon_package
import addon_package  # noqa: E402

_sample_image = addon_package.load("core.sample_image")

# The sample's typical element: its complete particles' area and box aspect between these percentiles
# (fragments and merged blobs of a segmentation sit in the tails), widened by touching_metrics' slack.
TYPICAL_PERCENTILES = (10.0, 90.0)


def periodic_copies(centres, angles, halves, width, height):
    """The particles of a sample that repeats, as the texture it tiles into: centres (n, 2) taken modulo the
    sample, then the 3 x 3 copies of every particle, the originals first. Returns (centres (9n, 2), angles (9n,),
    halves (9n, 2), original (9n,) bool): measure from the originals and look for their neighbours among all, so
    that a particle by the border sees the ones across it, as it does on the surface."""
    c = np.mod(np.asarray(centres, np.float64).reshape(-1, 2), [float(width), float(height)])
    shifts = [(i * float(width), j * float(height)) for i in (0, -1, 1) for j in (0, -1, 1)]  # (0, 0) first
    original = np.zeros(9 * len(c), bool)
    original[:len(c)] = True
    return (np.concatenate([c + s for s in shifts]), np.tile(np.asarray(angles, np.float64).ravel(), 9),
            np.tile(np.asarray(halves, np.float64).reshape(-1, 2), (9, 1)), original)


def aspect_of(halves):
    """Long / short half extent of (n, 2) box halves."""
    h = np.asarray(halves, np.float64).reshape(-1, 2)
    return h.max(1) / np.maximum(h.min(1), 1e-9)


def typical_range(area, aspect, percentiles=TYPICAL_PERCENTILES):
    """(area lo, hi, aspect lo, hi): the percentiles of the reference particles' area and aspect, widened by
    AREA_SLACK and ASPECT_SLACK (aspect never below 1). None without reference particles."""
    area, aspect = np.asarray(area, np.float64), np.asarray(aspect, np.float64)
    if len(area) == 0:
        return None
    a0, a1 = np.percentile(area, percentiles)
    s0, s1 = np.percentile(aspect, percentiles)
    return (float(a0 / AREA_SLACK), float(a1 * AREA_SLACK), float(max(1.0, s0 / ASPECT_SLACK)),
            float(s1 * ASPECT_SLACK))


def in_range_share(area, aspect, rng):
    """Share (0..1) of particles whose area and aspect lie within rng = typical_range(...); nan if none."""
    area, aspect = np.asarray(area, np.float64), np.asarray(aspect, np.float64)
    if len(area) == 0 or rng is None:
        return float("nan")
    a0, a1, s0, s1 = rng
    return float(np.mean((area >= a0) & (area <= a1) & (aspect >= s0) & (aspect <= s1)))


def class_shares(classes, class_ids):
    """Share of each id of class_ids among classes (zeros when classes is empty)."""
    classes = np.asarray(classes).ravel()
    if len(classes) == 0:
        return np.zeros(len(class_ids))
    return np.array([np.count_nonzero(classes == c) for c in class_ids], np.float64) / len(classes)


def worst_share_error(placed_classes, sample_counts, class_ids):
    """max over class_ids of |share among the placed - share among the sample's particles| (sample_counts:
    particles per class id, indexable by id)."""
    counts = np.array([sample_counts[c] for c in class_ids], np.float64)
    if counts.sum() == 0:
        return float("nan")
    return float(np.max(np.abs(class_shares(placed_classes, class_ids) - counts / counts.sum())))


def density_ratio(placed_count, placed_area_px, sample_count, sample_area_px):
    """(placed per px^2) / (sample's per px^2); nan when the sample has none."""
    if sample_count == 0 or placed_area_px <= 0:
        return float("nan")
    return (placed_count / placed_area_px) / (sample_count / sample_area_px)


def goal_share(values, test):
    """Share of the finite values passing test (a predicate); nan values count as failures."""
    values = list(values)
    if not values:
        return float("nan")
    return sum(1 for v in values if v is not None and v == v and test(v)) / len(values)


# Whether a sample repeats is the add-on's own rule (core/sample_image.border_seam_ratio), which the particle
# analysis applies when Tileable is off; printed over the corpus by main().
def seam_ratio(pixels):
    return _sample_image.border_seam_ratio(pixels)


def looks_tileable(pixels):
    return _sample_image.repeats_across_border(pixels)


def main():
    """Prints every corpus sample's seam ratio beside its manifest's tileable flag."""
    import json
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    sys.path.insert(0, os.path.join(root, "addon"))
    import texsynth_native as tn
    corpus = os.path.join(root, "out", "corpus")
    for sample in json.load(open(os.path.join(corpus, "manifest.json")))["samples"]:
        pixels = np.asarray(tn.load_image(os.path.join(corpus, sample["file"])), np.float32)[..., :3]
        print("%-26s tileable %-5s seam ratio %8.2f" % (sample["name"], sample["tileable"], seam_ratio(pixels)))


if __name__ == "__main__":
    main()

# SPDX-License-Identifier: GPL-3.0-or-later
"""Touching elements (issue 30, "Touching elements"): samples with known elements and how well the particle
analysis finds them whole. Used by bench_particles_touching.py and python_tests/native/test_particles_touching.py.

Samples, each with a ground-truth instance image (H, W) int, -1 = no element, row 0 = top as drawn; the
analysis is given the same array (it reads row 0 as the bottom: a mirror image, which changes no area, aspect
or overlap):
  - packed_pebbles(seed): generated, tileable 256^2: ellipses (half axes 7-15 px, aspect 1-1.9) packed so that
    most press on their neighbours (a candidate is rejected when closer to one than both 0.72 x the sum of
    their long half axes and 0.92 x that of their short ones), each pixel the
    element's with the least normalised radius below 1, else a dark sandy gap. Each pebble: a colour among
    four greys and browns, darkened towards its rim (0.55 at the rim, 1 at the centre) and mottled: touching
    pebbles meet along a darker seam of their own colours, not along the gap colour.
  - cobbles (the corpus's, extremetuxracer-data pebbles01.png, GPL-2+): hand-labelled ellipses in
    touching_cobbles_labels.json (how they were made is written there), drawn wrapped (the sample is tileable).

Measures, for an analysis against the ground truth:
  - in_range: the share of particles whose area and box aspect (long / short half extent of the analysis's
    box) lie within the ground truth's min..max, widened by RANGE_SLACK (area / 1.25 .. x 1.25, aspect / 1.1 ..
    x 1.1); the ground truth's boxes come from the same analysis run on its instances as a label image.
  - matched: the share of ground-truth elements with a particle of IoU >= 0.5 (pixel masks; each particle
    matches one element at most, as IoU >= 0.5 is unique).
  - count ratio: particles / ground-truth elements.
"""
import json
import math
import os

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
AREA_SLACK = 1.25
ASPECT_SLACK = 1.1
COBBLES_LABELS = os.path.join(HERE, "touching_cobbles_labels.json")
# Where corpus.py writes the samples; TEXSYNTH_CORPUS_SAMPLES names another folder (e.g. a shared checkout's).
CORPUS_SAMPLES = tuple(p for p in (os.environ.get("TEXSYNTH_CORPUS_SAMPLES", ""),
                                   os.path.join(ROOT, "out", "corpus", "samples")) if p)


def _wrapped_delta(d, n):
    return (d + n / 2.0) % n - n / 2.0


def draw_ellipses(shape, ellipses, tileable=True):
    """Instance image of ellipses (cx, cy, a, b, angle radians; x right, y down as drawn): each pixel the
    ellipse with the least normalised radius below 1, else -1. Returns (instances, radius)."""
    h, w = shape
    ys, xs = np.mgrid[0:h, 0:w].astype(np.float64) + 0.5
    best = np.full(shape, np.inf)
    inst = np.full(shape, -1, np.int32)
    for k, (cx, cy, a, b, ang) in enumerate(ellipses):
        dx, dy = xs - cx, ys - cy
        if tileable:
            dx, dy = _wrapped_delta(dx, w), _wrapped_delta(dy, h)
        c, s = math.cos(ang), math.sin(ang)
        u, v = (dx * c + dy * s) / a, (-dx * s + dy * c) / b
        r = np.sqrt(u * u + v * v)
        take = (r < 1.0) & (r < best)
        best[take] = r[take]
        inst[take] = k
    return inst, best


def packed_pebbles(seed=7, size=256):
    """(sample (H, W, 3) float32, instances (H, W) int32): see the module's docstring."""
    rng = np.random.default_rng(seed)
    ellipses = []
    for _ in range(6000):
        a = rng.uniform(9.0, 15.0)
        b = a / rng.uniform(1.0, 1.9)
        b = max(b, 7.0)
        cx, cy = rng.uniform(0, size, 2)
        ok = True
        for (ox, oy, oa, _ob, _oang) in ellipses:
            d = math.hypot(_wrapped_delta(cx - ox, size), _wrapped_delta(cy - oy, size))
            # short axes may press deeper: the smaller half axes set the limit, the long ones a softer one
            if d < 0.72 * (a + oa) and d < 0.92 * (b + _ob):
                ok = False
                break
        if ok:
            ellipses.append((cx, cy, a, b, rng.uniform(-math.pi / 2, math.pi / 2)))
    inst, radius = draw_ellipses((size, size), ellipses)
    palette = np.array([[0.62, 0.60, 0.56], [0.70, 0.62, 0.50], [0.55, 0.56, 0.58], [0.74, 0.70, 0.64]])
    colours = palette[rng.integers(0, len(palette), len(ellipses))] * rng.uniform(0.85, 1.1, (len(ellipses), 1))
    noise = rng.normal(0.0, 0.03, (size, size, 3))
    gap = np.array([0.25, 0.21, 0.17]) + rng.normal(0.0, 0.04, (size, size, 1))
    img = np.where(inst[..., None] >= 0,
                   colours[np.maximum(inst, 0)] * (1.0 - 0.45 * np.clip(radius, 0, 1)[..., None] ** 2),
                   gap) + noise
    return np.clip(img, 0, 1).astype(np.float32), inst


def load_sample(name):
    """(H, W, 3) float32 of a corpus sample (out/corpus/samples/<name>.png, made by corpus.py, or under
    $TEXSYNTH_CORPUS_SAMPLES), or None. The hand-labelled cobbles are committed beside this file
    (touching_cobbles.png, 70 KB), so their tests run on a fresh clone too."""
    committed = os.path.join(os.path.dirname(os.path.abspath(__file__)), "touching_%s.png" % name)
    for path in [committed] + [os.path.join(folder, name + ".png") for folder in CORPUS_SAMPLES]:
        if os.path.isfile(path):
            import texsynth_native
            return np.ascontiguousarray(np.asarray(texsynth_native.load_image(path), np.float32)[..., :3])
    return None


def cobbles():
    """(sample, instances) of the hand-labelled cobbles, or None when the corpus sample is missing."""
    sample = load_sample("cobbles")
    if sample is None:
        return None
    with open(COBBLES_LABELS) as handle:
        spec = json.load(handle)
    ellipses = [(e[0], e[1], e[2], e[3], math.radians(e[4])) for e in spec["ellipses"]]
    inst, _ = draw_ellipses(sample.shape[:2], ellipses, tileable=spec["tileable"])
    return sample, inst


def colour_instances(inst):
    """Label image (classes) of an instance image: 0 = none, else a greedy colour >= 1 that differs from every
    8-adjacent instance's, so that the analysis's components are the instances."""
    h, w = inst.shape
    n = int(inst.max()) + 1
    adjacent = [set() for _ in range(n)]
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            shifted = np.roll(np.roll(inst, dy, 0), dx, 1)
            pairs = np.unique(np.stack([inst.ravel(), shifted.ravel()], 1), axis=0)
            for p, q in pairs:
                if p >= 0 and q >= 0 and p != q:
                    adjacent[p].add(int(q))
    colour = np.zeros(n, np.int32)
    for k in range(n):
        used = {int(colour[j]) for j in adjacent[k] if j < k}
        c = 1
        while c in used:
            c += 1
        colour[k] = c
    return np.where(inst >= 0, colour[np.maximum(inst, 0)], 0).astype(np.int32)


def boxes_of(analysis):
    p = analysis.particles
    half = np.asarray(p["box_half"], np.float64).reshape(-1, 2)
    aspect = half.max(1) / np.maximum(half.min(1), 1e-9)
    return np.asarray(p["area"], np.float64), aspect


def truth_range(tn, sample, inst, tileable=True):
    """(area min, max, aspect min, max) of the ground-truth elements, boxed by the analysis itself."""
    a = tn.particle_analysis(sample, labels=colour_instances(inst), background=0, tileable=tileable, min_area=1)
    area, aspect = boxes_of(a)
    return float(area.min()), float(area.max()), float(aspect.min()), float(aspect.max())


def measure(analysis, inst, rng_truth):
    """dict: particles, elements, in_range, matched, count_ratio (see the module's docstring)."""
    area, aspect = boxes_of(analysis)
    a0, a1, s0, s1 = rng_truth
    ok = ((area >= a0 / AREA_SLACK) & (area <= a1 * AREA_SLACK) & (aspect >= s0 / ASPECT_SLACK)
          & (aspect <= s1 * ASPECT_SLACK))
    comp = np.asarray(analysis.components).ravel()
    truth = inst.ravel()
    elements = int(truth.max()) + 1
    n = len(area)
    both = (comp >= 0) & (truth >= 0)
    pairs, inter = np.unique(np.stack([truth[both], comp[both]], 1), axis=0, return_counts=True)
    t_size = np.bincount(truth[truth >= 0], minlength=elements)
    c_size = np.bincount(comp[comp >= 0], minlength=max(n, 1))
    matched = set()
    for (t, c), i in zip(pairs, inter):
        if i / (t_size[t] + c_size[c] - i) >= 0.5:
            matched.add(int(t))
    return {"particles": n, "elements": elements, "in_range": float(ok.mean()) if n else 0.0,
            "matched": len(matched) / elements if elements else 0.0, "count_ratio": n / elements if elements else 0.0}

# SPDX-License-Identifier: GPL-3.0-or-later
"""What the texton blend's fade zones mix, per sample (issue 29). Not a test: prints figures.

  PYTHONPATH=addon /usr/bin/python3.11 python_tests/bench/bench_texton_fade_mix.py SAMPLE.png ...

Synthesizes (texsynth_native, no Blender) on bench_blend_quality.py's jittered plane (200 triangles, 2 units,
seed 3) at its scale for a 512 px render (256 texels per unit, faces ~51 texels) and, at 400 random points
per blended triangle inside the fade zone (smallest barycentric coordinate < 0.15), compares each corner's
vertex mapping with the triangle's own patch:
  distinct  share of (point, corner) pairs where the two mappings differ by more than half a texel (where the
            fade mixes two patches; elsewhere it mixes a patch with itself)
  rho       correlation of the sample's luminance looked up through the two mappings at those pairs
plus the synthesis' coherent_faces (faces that continued a neighbour) and clipped_blend_sets.
"""
import os
import sys

import numpy as np

import texsynth_image_io
import texsynth_native as ts

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import blend_metrics  # noqa: E402


def jittered_plane(cells=10, width=2.0, seed=3):
    """bench_blend_quality.jittered_plane's mesh as Blender-layout arrays (same random draws)."""
    positions, t = blend_metrics.jittered_plane_arrays(cells, width, seed)
    return positions, t.ravel(), np.arange(0, t.size, 3, dtype=np.int32), np.full(len(t), 3, np.int32)


def lookup(lum, uv):
    """Bilinear, clamped, texel centres at +0.5; uv with v up."""
    h, w = lum.shape
    x = np.clip(uv[:, 0] * w - 0.5, 0, w - 1)
    y = np.clip((1 - uv[:, 1]) * h - 0.5, 0, h - 1)
    x0, y0 = np.minimum(np.floor(x).astype(int), w - 2), np.minimum(np.floor(y).astype(int), h - 2)
    fx, fy = x - x0, y - y0
    return (lum[y0, x0] * (1 - fx) * (1 - fy) + lum[y0, x0 + 1] * fx * (1 - fy)
            + lum[y0 + 1, x0] * (1 - fx) * fy + lum[y0 + 1, x0 + 1] * fx * fy)


def measure(path, rng):
    img = np.asarray(texsynth_image_io.load_image(path), np.float32)
    img = (img[..., None] if img.ndim == 2 else img)[..., :3]
    if img.max() > 1.5:
        img = img / 255
    lum = img.mean(axis=2) if img.shape[2] != 3 else img @ np.array([0.2126, 0.7152, 0.0722], np.float32)
    lum = (lum - lum.mean()) / (lum.std() + 1e-9)
    pos, corner_verts, starts, sizes = jittered_plane()
    r = ts.synthesize_texton(ts.preprocess(img), img, pos, corner_verts, starts, sizes, scale=256.0, seed=3,
                             axis=(0.0, 1.0, 0.0), allow_oversized=True)
    base, sets, weights = r["base_uv"], r["blend_uv"], r["blend_weights"]
    pairs, total = [], 0
    for f in range(len(sizes)):
        corners = np.arange(3) + starts[f]
        if weights[corners].sum() == 0:
            continue
        used = weights[corners].argmax(axis=1)
        lam = rng.dirichlet((1, 1, 1), 400)
        lam = lam[lam.min(axis=1) < 0.15]
        own = lam @ base[corners]
        own_values = lookup(lum, own)
        for k in range(3):
            vertex = lam @ sets[used[k], corners]
            differ = np.abs(vertex - own).max(axis=1) * img.shape[1] > 0.5
            pairs.append(np.stack([own_values[differ], lookup(lum, vertex[differ])], 1))
            total += len(lam)
    pairs = np.concatenate(pairs)
    stats = r["stats"]
    print("%-24s %4dx%-4d distinct %.2f  rho %.3f  coherent_faces %3d/%d  clipped_blend_sets %3d" % (
        os.path.basename(path), img.shape[1], img.shape[0], len(pairs) / total, np.corrcoef(pairs.T)[0, 1],
        stats["coherent_faces"], stats["faces"], stats["clipped_blend_sets"]))


def main():
    rng = np.random.default_rng(0)
    for path in sys.argv[1:]:
        measure(path, rng)


if __name__ == "__main__":
    main()

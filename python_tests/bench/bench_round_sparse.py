# SPDX-License-Identifier: GPL-3.0-or-later
"""Round neighbourhoods on sparse structure (round_neighbourhoods.md, "Sparse structure"): the coarsest
level matched against the sharp sample or a softened one. Not a test: prints figures and leaves pictures.

  PYTHONPATH=addon /usr/bin/python3.11 python_tests/bench/bench_round_sparse.py [--samples a,b] \\
      [--blur 0,1.5] [--share 0.1] [--seeds 1,2,3] [--out out/round_sparse]

The plane: the unit square tessellated by a 48-cell lattice turned 17 degrees, a 192^2 image target (UV =
position), the corpus sample reduced to the working size the bunny gave it in the corpus run (`--width`, by
area averages), and a field that turns: the texture's up at angle 90 + 135 * (2x - 1) * (2y - 1) degrees, so
templates and candidates are misaligned by a fraction of a pixel at their outer rings, as on a curved mesh.
With a constant field every sample is copied nearly whole and the question does not arise.

detail  mean |grad L| of the result over mean |grad L| of the working sample (1 = as sharp; bench_corpus'
        figure is the same ratio measured in renders)
patch   mean nearest 5 x 5 patch distance of 400 result patches to the sample, over the sample's own
        (each sample patch to its nearest patch at least half a patch away); 1 = as close as the sample is to
        itself
copied  share of the working sample's pixels that some texel copies
"""
import argparse
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))  # python_tests: uv_meshes
sys.path.insert(0, HERE)

import texsynth_native as ts  # noqa: E402
from uv_meshes import turned_plane  # noqa: E402

CORPUS = os.environ.get("TEXSYNTH_CORPUS_SAMPLES", "out/corpus/samples")
DEFAULT_SAMPLES = "dried_mud,brick_small,gravel,granite_grey,square_tiles_grey,stone_wall,cracked_rock,slate_paving"


def load(name, width):
    img = np.asarray(ts.load_image(os.path.join(CORPUS, name + ".png")), np.float32)[..., :3]
    if img.shape[2] == 1:
        img = np.repeat(img, 3, axis=2)
    h, w = img.shape[:2]
    if w > width:  # area average to width x round(h * width / w)
        nh = max(8, round(h * width / w))
        ys = (np.arange(nh + 1) * h / nh).astype(int)
        xs = (np.arange(width + 1) * w / width).astype(int)
        img = np.stack([[img[ys[j]:ys[j + 1], xs[i]:xs[i + 1]].mean(axis=(0, 1)) for i in range(width)]
                        for j in range(nh)])
    return np.ascontiguousarray(img, np.float32)


def luminance(rgb):
    return rgb[..., 0] * 0.2126 + rgb[..., 1] * 0.7152 + rgb[..., 2] * 0.0722


def gradient(rgb, mask=None):
    lum = luminance(rgb)
    gx, gy = lum[:, 1:] - lum[:, :-1], lum[1:, :] - lum[:-1, :]
    g = np.hypot(gx[:-1, :], gy[:, :-1])
    if mask is not None:
        m = mask[:-1, :-1] & mask[1:, :-1] & mask[:-1, 1:]
        return float(g[m].mean())
    return float(g.mean())


def patches(img, ys, xs, k=5):
    return np.stack([img[y:y + k, x:x + k].ravel() for y, x in zip(ys, xs)])


def patch_ratio(result, sample, rng, k=5, count=400):
    h, w = sample.shape[:2]
    cy, cx = np.mgrid[0:h - k + 1, 0:w - k + 1]
    cand = patches(sample, cy.ravel(), cx.ravel(), k)
    c2 = (cand ** 2).sum(1)

    def nearest(q, exclude=None):
        d = (q ** 2).sum(1)[:, None] + c2[None, :] - 2 * q @ cand.T
        if exclude is not None:
            d[exclude] = np.inf
        return float(np.maximum(d.min(1), 0).mean() / (k * k))

    ry = rng.integers(0, result.shape[0] - k, count)
    rx = rng.integers(0, result.shape[1] - k, count)
    own = rng.integers(0, len(cand), count)
    oy, ox = cy.ravel()[own], cx.ravel()[own]
    exclude = (np.abs(oy[:, None] - cy.ravel()[None, :]) < (k + 1) // 2) & \
              (np.abs(ox[:, None] - cx.ravel()[None, :]) < (k + 1) // 2)
    return nearest(patches(result, ry, rx, k)) / max(nearest(cand[own], exclude), 1e-12)


def turning_field(pos):
    x, y = pos[:, 0] * 2 - 1, pos[:, 1] * 2 - 1
    a = np.radians(90 + 135 * x * y)
    return np.stack([np.cos(a), np.sin(a), np.zeros_like(a)], 1).astype(np.float32)


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--samples", default=DEFAULT_SAMPLES)
    parser.add_argument("--blur", default="0,1.5")
    parser.add_argument("--share", type=float, default=0.1)
    parser.add_argument("--seeds", default="1,2,3")
    parser.add_argument("--width", type=int, default=131, help="working sample width (the bunny's in the corpus)")
    parser.add_argument("--size", type=int, default=192)
    parser.add_argument("--field", default="turning", choices=["turning", "constant"])
    parser.add_argument("--out", default="", help="folder for the first seed's images (.npy)")
    args = parser.parse_args()
    pos, tris, uvs = turned_plane(48, 17.0)
    ctx = ts.RoundSynthesisContext(pos, tris, uvs, width=args.size, height=args.size, texels_per_unit=args.size)
    field = turning_field(pos) if args.field == "turning" else np.tile(np.float32([0, 1, 0]), (len(pos), 1))
    blurs = [float(b) for b in args.blur.split(",")]
    seeds = [int(s) for s in args.seeds.split(",")]
    print("| sample | " + " | ".join("blur %g: detail / patch / copied" % b for b in blurs) + " |")
    print("|---|" + "---|" * len(blurs))
    for name in args.samples.split(","):
        sample = load(name, args.width)
        ref = gradient(sample)
        cells = []
        for b in blurs:
            d, p, c = [], [], []
            for seed in seeds:
                out = ts.round_synthesize(ctx, sample, field, seed=seed, coarse_blur=b, coarse_sharp_share=args.share)
                mask = out["mask"] == 1
                d.append(gradient(out["image"], mask) / ref)
                p.append(patch_ratio(out["image"], sample, np.random.default_rng(seed)))
                src = np.floor(out["source"]).astype(int)
                c.append(len(np.unique(src[:, 1] * sample.shape[1] + src[:, 0])) / (sample.shape[0] * sample.shape[1]))
                if args.out and seed == seeds[0]:
                    os.makedirs(args.out, exist_ok=True)
                    np.save(os.path.join(args.out, "%s_blur%g.npy" % (name, b)), out["image"])
            cells.append("%.2f±%.2f / %.2f / %.2f" % (np.mean(d), np.std(d), np.mean(p), np.mean(c)))
        print("| %s %dx%d | %s |" % (name, sample.shape[1], sample.shape[0], " | ".join(cells)), flush=True)


if __name__ == "__main__":
    main()

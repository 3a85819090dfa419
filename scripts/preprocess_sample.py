#!/usr/bin/env python3
# SPDX-License-Identifier: GPL-3.0-or-later
"""Preprocess a sample (textons + jump map, cached) and write its texton map in pseudo-colours.

Usage: /usr/bin/python3.11 scripts/preprocess_sample.py [IMAGE] [--out out] [--cache-dir out/cache]
Without IMAGE a synthetic 256x256 brick sample is generated.
"""
import argparse
import os
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.environ.get("TEXSYNTH_MODULE_DIR") or os.path.join(ROOT, "addon"))

import numpy as np  # noqa: E402
import texsynth_native as ts  # noqa: E402


def synthetic_bricks(size=256, seed=0):
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:size, 0:size]
    row = y // 20
    shifted = x + (row % 2) * 24
    mortar = ((y % 20) < 3) | ((shifted % 48) < 3)
    tint = rng.random((size // 20 + 2, size // 48 + 3))[row, shifted // 48]
    grain = rng.random((size // 4 + 2, size // 4 + 2))[y // 4, x // 4]
    img = np.empty((size, size, 3), np.float32)
    img[..., 0] = np.where(mortar, 0.6, 0.45 + 0.25 * tint) + 0.1 * grain
    img[..., 1] = np.where(mortar, 0.6, 0.18 + 0.12 * tint) + 0.08 * grain
    img[..., 2] = np.where(mortar, 0.6, 0.12 + 0.08 * tint) + 0.06 * grain
    return (np.clip(img, 0, 1) * 255).astype(np.uint8)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("image", nargs="?", help="sample image (any OpenImageIO format)")
    parser.add_argument("--out", default=os.path.join(ROOT, "out"))
    parser.add_argument("--cache-dir", default=None, help="default: OUT/cache")
    parser.add_argument("--textons", type=int, default=0, help="K (0 = sqrt of pixel count)")
    parser.add_argument("--tileable", action="store_true")
    args = parser.parse_args()
    os.makedirs(args.out, exist_ok=True)
    cache_dir = args.cache_dir or os.path.join(args.out, "cache")
    if args.image:
        sample, name = args.image, os.path.splitext(os.path.basename(args.image))[0]
    else:
        sample, name = synthetic_bricks(), "sample_bricks"
    start = time.perf_counter()
    result = ts.preprocess(sample, num_textons=args.textons, tileable=args.tileable, cache_dir=cache_dir)
    seconds = time.perf_counter() - start
    picture = os.path.join(args.out, f"{name}_textons.png")
    result.write_texton_map_image(picture)
    print(f"{name}: {result.width}x{result.height}, {result.num_textons} textons, "
          f"cache {result.cache_status} ({ts.cache_file_path(sample, cache_dir=cache_dir, num_textons=args.textons, tileable=args.tileable)}), "
          f"{seconds:.2f} s -> {picture}")


if __name__ == "__main__":
    main()

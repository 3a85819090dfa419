#!/usr/bin/env python3
# SPDX-License-Identifier: GPL-3.0-or-later
"""Synthesize on a flat triangle grid and rasterize it top-down (no Blender needed), to eyeball seams.

Writes OUT/synth_preview.png: left = base UVs only, right = blended sets (what the shader shows).
Usage: /usr/bin/python3.11 scripts/synth_preview.py [IMAGE] [--out out] [--scale 2.5] [--jump-rate 20]
Without IMAGE the synthetic brick sample of preprocess_sample.py is used.
"""
import argparse
import os
import struct
import sys
import time
import zlib

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.environ.get("TEXSYNTH_MODULE_DIR") or os.path.join(ROOT, "addon"))
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import numpy as np  # noqa: E402
import texsynth_native as ts  # noqa: E402
from preprocess_sample import synthetic_bricks  # noqa: E402


def write_png(path, rgb):
    h, w, _ = rgb.shape
    raw = b"".join(b"\x00" + rgb[y].tobytes() for y in range(h))
    chunk = lambda tag, data: struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data))
    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
                + chunk(b"IDAT", zlib.compress(raw, 6)) + chunk(b"IEND", b""))


def triangle_grid(n):
    ys, xs = np.mgrid[0:n + 1, 0:n + 1]
    pos = np.stack([xs.ravel(), ys.ravel(), np.zeros(xs.size)], 1).astype(np.float32)
    idx = lambda x, y: y * (n + 1) + x
    tris = []
    for y in range(n):
        for x in range(n):
            tris += [idx(x, y), idx(x + 1, y), idx(x + 1, y + 1), idx(x, y), idx(x + 1, y + 1), idx(x, y + 1)]
    cv = np.array(tris, np.int32)
    return pos, cv, np.arange(0, cv.size, 3, dtype=np.int32), np.full(cv.size // 3, 3, np.int32)


def render(sample, out, n, pixels_per_cell, blended):
    size = n * pixels_per_cell
    # pixel centres in grid units; image row 0 = top = largest y
    gy, gx = np.mgrid[0:size, 0:size].astype(np.float64)
    px, py = (gx + 0.5) / pixels_per_cell, n - (gy + 0.5) / pixels_per_cell
    cx, cy = np.minimum(px.astype(int), n - 1), np.minimum(py.astype(int), n - 1)
    fx, fy = px - cx, py - cy
    lower = fx >= fy
    poly = 2 * (cy * n + cx) + (~lower)
    bary = np.where(lower[..., None], np.stack([1 - fx, fx - fy, fy], -1), np.stack([1 - fy, fx, fy - fx], -1))
    corners = poly[..., None] * 3 + np.arange(3)
    h, w = sample.shape[:2]

    def lookup(uv):
        x = np.clip((uv[..., 0] * w).astype(int), 0, w - 1)
        y = np.clip(((1 - uv[..., 1]) * h).astype(int), 0, h - 1)
        return sample[y, x].astype(np.float64)

    if not blended:
        return lookup((bary[..., None] * out["base_uv"][corners]).sum(-2))
    colour = np.zeros((size, size, sample.shape[2]))
    for k in range(out["num_blend_sets"]):
        uv = (bary[..., None] * out["blend_uv"][k][corners]).sum(-2)
        weight = (bary * out["blend_weights"][corners, k]).sum(-1)
        colour += weight[..., None] * lookup(uv)
    return colour


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("image", nargs="?")
    parser.add_argument("--out", default=os.path.join(ROOT, "out"))
    parser.add_argument("--cells", type=int, default=48)
    parser.add_argument("--scale", type=float, default=12.0, help="texels per grid cell")
    parser.add_argument("--jump-rate", type=float, default=20.0)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    os.makedirs(args.out, exist_ok=True)
    sample = ts.load_image(args.image) if args.image else synthetic_bricks()
    if sample.dtype != np.uint8:
        sample = (np.clip(sample[..., :3], 0, 1) * 255).astype(np.uint8)
    pre = ts.preprocess(sample, cache_dir=os.path.join(args.out, "cache"))
    mesh = triangle_grid(args.cells)
    start = time.perf_counter()
    out = ts.synthesize_jumpmap(pre, *mesh, scale=args.scale, jump_rate=args.jump_rate, seed=args.seed,
                                axis=(0.0, 1.0, 0.0))
    seconds = time.perf_counter() - start
    ppc = max(2, int(round(args.scale)))
    picture = np.concatenate([render(sample, out, args.cells, ppc, False),
                              np.full((args.cells * ppc, 8, 3), 255.0),
                              render(sample, out, args.cells, ppc, True)], 1)
    path = os.path.join(args.out, "synth_preview.png")
    write_png(path, np.clip(picture, 0, 255).astype(np.uint8))
    print(f"{out['stats']} ({seconds * 1000:.1f} ms) -> {path}")


if __name__ == "__main__":
    main()

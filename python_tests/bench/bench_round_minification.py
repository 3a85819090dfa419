# SPDX-License-Identifier: GPL-3.0-or-later
"""Why the add-on's round method reduces the sample to the target's density (Synthesis Resolution:
Match Target, surface_colour/core.working_sample). A plane's image target 2-4x coarser than the sample:
synthesized from the full sample ("full") or from the sample area-averaged to the target's density
("auto"). Prints the mean nearest 5x5 patch distance (per value, 3 seeds) of each result to the sample
as a mipmap shows it at that density: lower = looks like the minified texture. Not a test.

  /usr/bin/python3.11 python_tests/bench/bench_round_minification.py
"""
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, os.environ.get("TEXSYNTH_MODULE_DIR", os.path.join(ROOT, "addon")))
sys.path.insert(0, os.path.dirname(HERE))
import texsynth_native as ts  # noqa: E402

import addon_package  # noqa: E402
from uv_meshes import plane  # noqa: E402

core = addon_package.load("surface_colour.core")
sample_image = addon_package.load("core.sample_image")


def patches(image, k, step=1):
    height, width = image.shape[:2]
    return np.stack([image[y:y + k, x:x + k].ravel() for y in range(0, height - k + 1, step)
                     for x in range(0, width - k + 1, step)])


def nearest_distance(a, b):
    d = (a * a).sum(1)[:, None] - 2 * a @ b.T + (b * b).sum(1)[None, :]
    return float(np.maximum(d.min(1), 0).mean() / a.shape[1])


def main():
    positions, triangles, uvs = plane()
    up = np.tile(np.array([0, 1, 0], np.float32), (len(positions), 1))
    size = 128
    print("sample  coarser  full     auto")
    for name in ("bricks", "moss"):
        sample = sample_image.synthesis_sample(ts.load_image(os.path.join(ROOT, "blend_samples", name + ".png")))
        for factor in (2, 3, 4):
            texels_per_unit = float(size * factor)
            mipmap = patches(core.working_sample(sample, texels_per_unit, float(size), "AUTO", 8)[0], 5)
            row = []
            for mode in ("FULL", "AUTO"):
                working, scale = core.working_sample(sample, texels_per_unit, float(size), mode, 40)
                context = ts.RoundSynthesisContext(positions, triangles, uvs, width=size, height=size,
                                                   texels_per_unit=scale)
                row.append(np.mean([nearest_distance(patches(ts.round_synthesize(context, working, up, seed=seed)
                                                             ["image"][:, :, :3], 5, 3), mipmap)
                                    for seed in (1, 2, 3)]))
            print("%-7s %dx       %.5f  %.5f" % (name, factor, row[0], row[1]), flush=True)


if __name__ == "__main__":
    main()

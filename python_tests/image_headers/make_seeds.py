# SPDX-License-Identifier: GPL-3.0-or-later
"""Writes the committed seed files of test_image_headers.py: one small valid file per layout the header
checks walk, all 13 x 7 pixels, made by oiiotool (openimageio-tools) from one random PNG.

    python3 python_tests/image_headers/make_seeds.py   (rewrites python_tests/image_headers/seeds/)

The files are committed so the test replays the same bytes everywhere, OpenImageIO or not."""
import os
import subprocess
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(os.path.dirname(HERE), "hostile"))
import make_corpus  # noqa: E402  (its byte-exact PNG writer)

# name: (channels of the source, oiiotool arguments before -o)
SEEDS = {
    "rgb8.png": (3, []),
    "grey_alpha16.png": (2, ["-d", "uint16"]),
    "baseline.jpg": (3, []),
    "progressive.jpg": (3, ["--attrib", "jpeg:progressive", "1"]),
    "half_zip.exr": (4, ["-d", "half"]),
    "float_none.exr": (3, ["-d", "float", "--compression", "none"]),
    "half_piz.exr": (3, ["-d", "half", "--compression", "piz"]),
    "tiled_mip.exr": (3, ["-d", "half", "--tile", "4", "4", "-otex"]),  # a MIP-mapped texture
    "tiled.exr": (3, ["-d", "half", "--tile", "4", "4"]),
    "rgb8.tif": (3, []),
    "rgba16_tiled.tif": (4, ["-d", "uint16", "--tile", "16", "16"]),
    "float_big.tif": (1, ["-d", "float", "--attrib", "tiff:bigtiff", "1"]),
    "rgb24.bmp": (3, []),
    "rgb_raw.tga": (3, ["--compression", "none"]),
    "rgba_rle.tga": (4, ["--compression", "rle"]),
    "radiance.hdr": (3, []),
    "lossless.webp": (4, ["--attrib", "compression", "lossless"]),
}


def main():
    out = os.path.join(HERE, "seeds")
    os.makedirs(out, exist_ok=True)
    rng = np.random.default_rng(31)
    for name, (channels, args) in SEEDS.items():
        source = os.path.join(out, "source.png")
        with open(source, "wb") as handle:
            handle.write(make_corpus.png_from_array(rng.integers(0, 256, (7, 13, channels), dtype=np.uint8)))
        output = ["-o"] if args[-1:] != ["-otex"] else []
        subprocess.run(["oiiotool", source, *args, *output, os.path.join(out, name)], check=True)
        os.remove(source)
    # A multi-part OpenEXR file: two parts of the same size.
    parts = [os.path.join(out, "part%d.exr" % i) for i in range(2)]
    for part in parts:
        subprocess.run(["oiiotool", os.path.join(out, "half_zip.exr"), "-o", part], check=True)
    subprocess.run(["oiiotool", *parts, "--siappend", "-o", os.path.join(out, "multipart.exr")], check=True)
    for part in parts:
        os.remove(part)


if __name__ == "__main__":
    main()

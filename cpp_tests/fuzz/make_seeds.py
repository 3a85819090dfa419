# SPDX-License-Identifier: GPL-3.0-or-later
"""Writes the small seed corpus of the libFuzzer targets into cpp_tests/fuzz/corpus/<target>/.
Run once (output is committed):  python3.11 cpp_tests/fuzz/make_seeds.py
Needs texsynth_native (addon/) for the cache seed and oiiotool for the image seeds."""
import os
import random
import struct
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, os.path.join(ROOT, "addon"))
sys.path.insert(0, os.path.join(ROOT, "python_tests", "hostile"))
import make_corpus  # noqa: E402
import numpy as np  # noqa: E402
import texsynth_native  # noqa: E402

EXTENSIONS = [".png", ".jpg", ".exr", ".tif", ".bmp", ".tga", ".hdr", ".ppm", ".gif", ".psd"]  # = fuzz_image.cpp


def put(target, name, data):
    folder = os.path.join(HERE, "corpus", target)
    os.makedirs(folder, exist_ok=True)
    with open(os.path.join(folder, name), "wb") as f:
        f.write(data)


def particle_cache_seeds(tmp):
    """A tileable 16 x 12 sample with two squares (one across the border), analysed and cached."""
    img = np.tile(np.array([0.2, 0.3, 0.25], np.float32), (12, 16, 1))
    img[2:6, 3:7] = (0.8, 0.7, 0.3)
    img[6:10, 13:16] = img[6:10, 0:2] = (0.8, 0.7, 0.3)
    analysis = texsynth_native.particle_analysis(img, classes=2, blur=0.0, min_area=4, tileable=True)
    path = os.path.join(tmp, "p.tspart")
    texsynth_native.save_particle_analysis(analysis, path, 1234)
    data = open(path, "rb").read()
    put("fuzz_particle_cache", "valid_checksum_appended", b"\x01" + data[:-8])
    put("fuzz_particle_cache", "valid_raw", b"\x00" + data)


def float_exr_seeds(tmp):
    """The cache's two side files, written by tinyexr: a Gaussianized 12 x 10 RGB sample and its 64-entry
    look-up table, and a grey + alpha pair. Header bytes: channels - 1, width - 1, height - 1."""
    rng = np.random.default_rng(5)
    for name, sample in (("rgb", rng.random((10, 12, 3), dtype=np.float32)),
                         ("grey_alpha", rng.random((10, 12, 2), dtype=np.float32))):
        out = texsynth_native.histogram_transform(sample, cache_dir=os.path.join(tmp, name), lut_size=64)
        channels = sample.shape[2]
        put("fuzz_float_exr", name + "_gaussian", bytes([channels - 1, 11, 9]) + open(out["gaussian_path"], "rb").read())
        put("fuzz_float_exr", name + "_lut", bytes([channels - 1, 63, 0]) + open(out["lut_path"], "rb").read())


def main():
    tmp = tempfile.mkdtemp()
    particle_cache_seeds(tmp)
    float_exr_seeds(tmp)
    pixels = make_corpus.sample_pixels(size=8)
    png = os.path.join(tmp, "s.png")
    open(png, "wb").write(make_corpus.png_from_array(pixels))
    pre = texsynth_native.preprocess(png, neighbourhood=3, num_textons=3, jump_candidates=2, feature_dims=3)
    cache = os.path.join(tmp, "s.tscache")
    pre.save(cache)
    data = open(cache, "rb").read()
    put("fuzz_cache", "valid_checksum_appended", b"\x01" + data[:-8])
    put("fuzz_cache", "valid_raw", b"\x00" + data)
    for index, ext in enumerate(EXTENSIONS):
        out = os.path.join(tmp, "s" + ext)
        if subprocess.run(["oiiotool", png, "-o", out], capture_output=True).returncode == 0:
            put("fuzz_image", "sample" + ext.replace(".", "_"), bytes([index]) + open(out, "rb").read())
    put("fuzz_image", "palette_png", bytes([0]) + make_corpus.png_bytes(
        4, 4, 3, 8, [bytes([0, 1, 2, 3])] * 4, palette=bytes(range(12))))
    put("fuzz_image", "gray16_png", bytes([0]) + make_corpus.png_from_array(
        (pixels[..., :1].astype(np.uint16) * 257)))
    rng = random.Random(7)
    for target in ("fuzz_mesh", "fuzz_params", "fuzz_texton", "fuzz_geometry"):
        for i in range(4):
            put(target, "random_%d" % i, bytes(rng.randrange(256) for _ in range(64 << i)))
    print("seeds written to", os.path.join(HERE, "corpus"))


if __name__ == "__main__":
    main()

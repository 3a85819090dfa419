# SPDX-License-Identifier: GPL-3.0-or-later
"""addon/core/image_headers.py under plain pytest (no Blender): a sample file's header is checked before
Blender opens it (issue 31). Valid files pass with their size; cut, damaged or oversized ones are refused
with one line; no byte sequence makes the check raise anything else. Inputs are committed files
(python_tests/image_headers/seeds, the C++ fuzzers' image corpus) and deterministic mutations of them."""
import os
import random
import struct
import sys
import zlib

import pytest

import addon_package
import paths

SEEDS = paths.IMAGE_SEEDS
FUZZ_IMAGE = [os.path.join(addon_package.ROOT, "cpp_tests", "fuzz", kind, "fuzz_image")
              for kind in ("corpus", "regressions")]
FUZZ_EXTENSIONS = (".png", ".jpg", ".exr", ".tif", ".bmp", ".tga", ".hdr", ".ppm", ".gif", ".psd")  # fuzz_image.cpp

headers = addon_package.load("core.image_headers")
limits = addon_package.load("core.image_limits")
settings = addon_package.load("core.settings")

# What `oiiotool --info` says of each seed (make_seeds.py writes them all 13 x 7).
SEED_FORMATS = {
    "baseline.jpg": ("jpeg", 3), "progressive.jpg": ("jpeg", 3), "float_big.tif": ("tiff", 1),
    "float_none.exr": ("openexr", 3), "half_piz.exr": ("openexr", 3), "half_zip.exr": ("openexr", 4),
    "tiled.exr": ("openexr", 3), "tiled_mip.exr": ("openexr", 3), "multipart.exr": ("openexr", 4),
    "grey_alpha16.png": ("png", 2), "rgb8.png": ("png", 3), "lossless.webp": ("webp", 4),
    "radiance.hdr": ("hdr", 3), "rgb24.bmp": ("bmp", 3), "rgb8.tif": ("tiff", 3),
    "rgba16_tiled.tif": ("tiff", 4), "rgb_raw.tga": ("targa", 3), "rgba_rle.tga": ("targa", 4),
}
# Formats whose every byte is needed: any cut must be refused (TGA and Radiance HDR carry optional
# trailers or compress too freely for a header to know their length).
WHOLE_FILE_FORMATS = ("png", "jpeg", "openexr", "tiff", "bmp", "webp")


def seed(name):
    with open(os.path.join(SEEDS, name), "rb") as handle:
        return handle.read()


def outcome(path):
    """The Header, or the HeaderError's message; anything else escapes and fails the test."""
    try:
        return headers.check_sample_file(path)
    except limits.HeaderError as error:
        message = str(error)
        assert message.startswith("image '%s': " % path) and "\n" not in message, message
        return message


def check_bytes(tmp_path, data, name="sample.bin"):
    """outcome() of `data` as a file; mutations are checked in memory (the same walk, without the disk)."""
    path = str(tmp_path / name)
    try:
        result = headers.check_sample_data(data, path)
    except limits.HeaderError as error:
        result = str(error)
        assert result.startswith("image '%s': " % path) and "\n" not in result, result
    return result


def test_checking_bytes_is_checking_the_file(tmp_path):
    for name in sorted(SEED_FORMATS):
        for data in (seed(name), seed(name)[:len(seed(name)) // 2], seed(name)[:7]):
            path = tmp_path / name
            path.write_bytes(data)
            assert check_bytes(tmp_path, data, name) == outcome(str(path)), name


def test_every_seed_passes_with_its_size_and_channels():
    assert sorted(os.listdir(SEEDS)) == sorted(SEED_FORMATS)
    for name, (kind, channels) in SEED_FORMATS.items():
        assert outcome(os.path.join(SEEDS, name)) == headers.Header(kind, 13, 7, channels), name


def test_the_header_error_is_a_settings_error():
    # The operators and the CLI report SettingsError as one line; the header error must be one.
    assert issubclass(limits.HeaderError, settings.SettingsError)


def test_every_cut_of_a_seed_is_refused(tmp_path):
    for name, (kind, _) in SEED_FORMATS.items():
        data = seed(name)
        if kind in WHOLE_FILE_FORMATS:
            must_refuse = len(data)
        elif kind == "targa":  # 18-byte header, then 13 x 7 raw pixels; RLE: the header at least
            must_refuse = 18 + 13 * 7 * 3 if name == "rgb_raw.tga" else 18
        else:  # Radiance: up to the end of the resolution line
            must_refuse = data.index(b"-Y 7 +X 13\n") + len(b"-Y 7 +X 13")
        for length in range(must_refuse):
            result = check_bytes(tmp_path, data[:length], name)
            assert isinstance(result, str), "%s cut to %d bytes passed: %s" % (name, length, result)
        for length in range(must_refuse, len(data)):
            check_bytes(tmp_path, data[:length], name)  # either outcome, nothing else


def mutations(data, rng, count):
    """Deterministic damage: single bit flips, and bytes set to boundary values (mostly in the header)."""
    for index in range(count):
        damaged = bytearray(data)
        if index % 2 == 0:
            position = rng.randrange(len(damaged))
            damaged[position] ^= 1 << rng.randrange(8)
        else:
            for _ in range(rng.randint(1, 4)):
                position = rng.randrange(min(len(damaged), 300))
                damaged[position] = rng.choice((0x00, 0x01, 0x7F, 0x80, 0xFE, 0xFF))
        yield bytes(damaged)


def test_damaged_seeds_only_ever_raise_the_header_error(tmp_path):
    refused = 0
    for name in sorted(SEED_FORMATS):
        rng = random.Random("issue31:" + name)  # the same damage on every run
        for damaged in mutations(seed(name), rng, 400):
            refused += isinstance(check_bytes(tmp_path, damaged, name), str)
    assert refused > 500  # the damage really reaches the checks (922 of 7,200 when written)


def test_the_fuzzers_committed_image_inputs_replay_cleanly(tmp_path):
    replayed = 0
    for folder in FUZZ_IMAGE:
        for name in sorted(os.listdir(folder)):
            with open(os.path.join(folder, name), "rb") as handle:
                data = handle.read()
            if data:  # byte 0 picks the extension, as in fuzz_image.cpp
                check_bytes(tmp_path, data[1:], "input" + FUZZ_EXTENSIONS[data[0] % len(FUZZ_EXTENSIONS)])
                replayed += 1
    assert replayed >= 15


def test_the_fuzzers_regressions_are_refused_with_their_reason(tmp_path):
    def replay(name):
        with open(os.path.join(FUZZ_IMAGE[1], name), "rb") as handle:
            data = handle.read()
        return check_bytes(tmp_path, data[1:], "input" + FUZZ_EXTENSIONS[data[0] % len(FUZZ_EXTENSIONS)])

    assert "declares 1" in replay("exr_attribute_declares_1_2gb_timeout")  # 1.2 GB declared in 130 bytes
    assert "truncated or corrupt file" in replay("exr_attribute_declares_1_2gb_timeout")
    assert "CMYK TIFF samples are not supported" in replay("cmyk_tiff_oiio31_stack_smash")
    assert "GIF samples are not supported" in replay("gif_reader_terminate")
    assert isinstance(replay("truncated_png_oiio_leak"), str)


def test_a_cut_openexr_header_is_refused_as_the_native_sniffing_words_it(tmp_path):
    # Blender 3.4's reader never returned on this file (the hostile corpus's truncated_header.exr).
    message = check_bytes(tmp_path, seed("half_zip.exr")[:20], "cut.exr")
    assert message.endswith("truncated or corrupt file"), message
    data = bytearray(seed("half_zip.exr"))
    size_at = data.index(b"channels\0chlist\0") + len(b"channels\0chlist\0")
    data[size_at:size_at + 4] = struct.pack("<i", 0x7FFFFFFF)
    message = check_bytes(tmp_path, bytes(data), "huge.exr")
    assert "OpenEXR header attribute 'channels' (chlist) declares 2147483647 bytes but only %d bytes follow " \
           "in the file: truncated or corrupt file" % (len(data) - size_at - 4) in message, message
    data[size_at:size_at + 4] = struct.pack("<i", -5)
    assert "declares a negative size (-5): corrupt file" in check_bytes(tmp_path, bytes(data), "negative.exr")


def png_sized(width, height):
    """rgb8.png with its IHDR rewritten to width x height (checksum updated)."""
    data = bytearray(seed("rgb8.png"))
    data[16:24] = struct.pack(">II", width, height)
    data[29:33] = struct.pack(">I", zlib.crc32(bytes(data[12:29])))
    return bytes(data)


def test_the_pixel_limit_is_the_native_one(tmp_path):
    # texsynth_native accepts up to 8192 x 8192 pixels, sides up to 65536 (image/image.hpp).
    for width, height in ((8192, 8192), (65536, 1024), (1, 65536)):
        assert isinstance(check_bytes(tmp_path, png_sized(width, height), "ok.png"), headers.Header), (width, height)
    for width, height in ((8193, 8192), (65537, 1), (16384, 16384)):
        message = check_bytes(tmp_path, png_sized(width, height), "big.png")
        assert "image %dx%d exceeds the limit of 67108864 pixels (8192x8192" % (width, height) in message, message
    assert "image has no pixels (0x7)" in check_bytes(tmp_path, png_sized(0, 7), "empty.png")
    damaged = bytearray(png_sized(13, 7))
    damaged[29] ^= 1
    assert "fails its checksum" in check_bytes(tmp_path, bytes(damaged), "crc.png")


def test_files_that_are_not_samples_are_refused_by_name(tmp_path):
    assert outcome(str(tmp_path / "missing.png")).endswith("file does not exist")
    assert outcome(str(tmp_path)).endswith("is a directory, not an image file")
    assert check_bytes(tmp_path, b"", "empty.png").endswith("file is empty (0 bytes)")
    assert "not a supported image format" in check_bytes(tmp_path, b"8BPS\0\1" + bytes(64), "layers.psd")
    assert "cannot be read inside Blender" in check_bytes(tmp_path, b"P6\n13 7\n255\n" + bytes(273), "a.ppm")
    with pytest.raises(limits.HeaderError, match="image path is empty"):
        headers.check_sample_file("")


def test_the_hostile_corpus_images_are_refused_before_blender_opens_them(tmp_path):
    """Every image the hostile corpus expects to fail is refused from its header, except the one whose
    header is sound and whose pixels are not (NaN/inf: refused by the native module after decoding)."""
    sys.path.insert(0, paths.HOSTILE)
    import make_corpus
    try:
        cases = make_corpus.image_cases(str(tmp_path))
    except (OSError, FileNotFoundError) as error:
        pytest.skip("oiiotool is needed to write the corpus: %s" % error)
    passed = {c["file"].split("/", 1)[1]: outcome(str(tmp_path / c["file"])) for c in cases}
    for case in cases:
        name = case["file"].split("/", 1)[1]
        if case["expect"] == "ok":
            assert isinstance(passed[name], headers.Header) and passed[name][1:3] == (32, 32), (name, passed[name])
    assert sorted(name for case in cases if case["expect"] == "error"
                  for name in [case["file"].split("/", 1)[1]] if isinstance(passed[name], headers.Header)) \
        == ["nan_inf.exr"]

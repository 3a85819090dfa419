# SPDX-License-Identifier: GPL-3.0-or-later
"""The sample size limits texsynth_native applies to decoded files (image/image.hpp), for checking a
header before anything is decoded; bpy-free."""
from .settings import SettingsError

MAX_SAMPLE_PIXELS = 8192 * 8192  # kMaxSamplePixels
MAX_IMAGE_SIDE = 65536           # kMaxImageSide
MAX_FILE_CHANNELS = 64           # kMaxFileChannels (image_files.cpp)
MAX_DECODED_VALUES = MAX_SAMPLE_PIXELS * 4


class HeaderError(SettingsError):
    """A sample file refused from its header (one line naming the file and the problem)."""


def check_size(width, height, channels, fail):
    """The native checks of a decoded file's size, worded as check_image_dims and load_image word them."""
    if width <= 0 or height <= 0:
        fail("image has no pixels (%dx%d)" % (width, height))
    if width > MAX_IMAGE_SIDE or height > MAX_IMAGE_SIDE or width * height > MAX_SAMPLE_PIXELS:
        fail("image %dx%d exceeds the limit of %d pixels (8192x8192; its pixels alone need %.1f GB); "
             "downscale the sample" % (width, height, MAX_SAMPLE_PIXELS, width * height * max(channels, 1) * 4 / 1e9))
    if channels < 1 or channels > MAX_FILE_CHANNELS:
        fail("image has %d channels; samples need 1 (gray), 2 (gray+alpha), 3 (RGB) or 4 (RGBA)" % channels)
    if width * height * channels > MAX_DECODED_VALUES:
        fail("%dx%d with %d channels needs %.2f GB as floats, more than the %.2f GB limit (8192x8192 RGBA); keep "
             "only the channels the sample needs, or downscale it"
             % (width, height, channels, width * height * channels * 4 / 1e9, MAX_DECODED_VALUES * 4 / 1e9))

# SPDX-License-Identifier: GPL-3.0-or-later
"""What a run reads from Blender besides meshes: the sample image (a file or an image in the .blend), the
mesh objects to work on, and where the caches go."""
import os

import bpy
import numpy as np

from ..core.image_headers import check_sample_file
from ..core.sample_image import sample_pixels
from ..core.settings import SettingsError
from . import mesh_io

CACHE_FOLDER = "texsynth"  # under Blender's user cache folder


class Sample:
    """The sample image: a file path or an image already in the .blend (packed ones too)."""

    def __init__(self, path="", image=None):
        self.path = path
        self.image = image

    def describe(self):
        return self.image.name if self.image is not None else (self.path or "<none>")

    def native_input(self):
        """What texsynth_native.preprocess accepts: the sample's pixels as numpy. A file is decoded by
        Blender (decode_sample_file), never by texsynth_image_io, which blender.org packages do not have."""
        if self.image is not None:
            return mesh_io.read_image_pixels(self.image)
        if not self.path:
            raise SettingsError("no sample image: choose an image file or an image in the .blend")
        path = bpy.path.abspath(self.path)
        if not os.path.isfile(path):
            raise SettingsError("sample image not found: %s" % path)
        return decode_sample_file(path)

    def shader_image(self):
        """The bpy image the node group samples (loaded once for file samples)."""
        if self.image is not None:
            return self.image
        return bpy.data.images.load(bpy.path.abspath(self.path), check_existing=True)


# Formats whose float buffers in Blender hold 16-bit integer samples (OpenImageIO reads them as uint16).
_SIXTEEN_BIT_FORMATS = ("PNG", "TIFF")


_PNG_GREY_ALPHA = 4


def _png_colour_type(path):
    """The colour type byte of a PNG's IHDR chunk (None if the header is not there)."""
    with open(path, "rb") as handle:
        header = handle.read(26)
    return header[25] if len(header) == 26 and header[12:16] == b"IHDR" else None


def decode_sample_file(path):
    """A sample file decoded by Blender, as texsynth_native.load_image decodes it with OpenImageIO: the
    file's own channel count (1, 2, 3 or 4), uint8 for 8-bit files, uint16 for 16-bit PNG/TIFF (sRGB
    encoded), float32 for float files (linear); row 0 = top. Passed to image_from_pixels or preprocess,
    it gives the same image (and cache key) as the path. A temporary datablock is used, because reading
    the stored values needs the Non-Color colour space and the artist's own image must not change."""
    if not os.path.isfile(path):
        raise SettingsError("sample image not found: %s" % path)
    # Before Blender opens it: Blender's readers trust the header (3.4 hangs on a cut OpenEXR header).
    header = check_sample_file(path)
    try:
        image = bpy.data.images.load(path, check_existing=False)
    except RuntimeError as error:
        raise SettingsError("cannot read the sample image %s: %s" % (path, str(error).strip()))
    try:
        image.colorspace_settings.name = "Non-Color"  # 16-bit and float buffers stay as stored
        width, height = int(image.size[0]), int(image.size[1])
        if width == 0 or height == 0 or not image.has_data:
            raise SettingsError("cannot read the sample image %s (unsupported or damaged file)" % path)
        if (width, height) != (header.width, header.height):  # another reader than the one checked
            raise SettingsError("cannot read the sample image %s: Blender decoded %dx%d where its %s header "
                                "says %dx%d (damaged file?)" % (path, width, height, header.format,
                                                               header.width, header.height))
        stored = int(image.channels)
        pixels = np.empty(width * height * stored, dtype=np.float32)
        image.pixels.foreach_get(pixels)
        pixels = pixels.reshape(height, width, stored)[::-1]
        # depth is bits per pixel of the file: 8 per byte channel; float buffers report 32 per channel.
        channels = max(1, min(4, int(image.depth) // (32 if image.is_float else 8)))
        if image.file_format == "PNG" and _png_colour_type(path) == _PNG_GREY_ALPHA:
            channels = 2  # Blender 4.3 reports grey + alpha as 32 bits
        if channels == 1:
            pixels = pixels[:, :, :1]
        elif channels == 2:
            pixels = pixels[:, :, (0, 3)]  # Blender stores grey + alpha as R=G=B, A
        else:
            pixels = pixels[:, :, :channels]
        if not image.is_float:
            return np.ascontiguousarray(np.rint(pixels * np.float32(255.0)).astype(np.uint8))
        if image.file_format in _SIXTEEN_BIT_FORMATS:
            scaled = pixels * np.float32(65535.0)
            integers = np.rint(scaled)
            # A float TIFF is not on the 1/65535 grid: keep it as float, as OpenImageIO does.
            if np.all(np.abs(scaled - integers) < 1e-2) and np.all((integers >= 0) & (integers <= 65535)):
                return np.ascontiguousarray(integers.astype(np.uint16))
        return np.ascontiguousarray(pixels, dtype=np.float32)
    finally:
        bpy.data.images.remove(image)


def read_sample_pixels(sample):
    """(H x W x C float32 pixels, row 0 = top, values as stored; True if they are sRGB-encoded)."""
    if sample.image is not None:
        image = sample.image
        return mesh_io.read_image_pixels(image), (not image.is_float and image.colorspace_settings.name == "sRGB")
    decoded = sample.native_input()
    # Integer files are display-referred, float files linear: the encoding texsynth_native gives them.
    return sample_pixels(decoded), decoded.dtype in (np.uint8, np.uint16)


def default_cache_dir():
    """TexSynth's cache folder under Blender's user cache (or scripts, or temporary) folder."""
    for resource in ("CACHE", "SCRIPTS"):
        try:
            base = bpy.utils.user_resource(resource)
        except (TypeError, ValueError):
            continue
        if base:
            return os.path.join(base, CACHE_FOLDER)
    return os.path.join(bpy.app.tempdir or "/tmp", CACHE_FOLDER)


def mesh_objects(objects):
    """(mesh objects with distinct mesh data, skipped (name, reason)) in a stable order."""
    seen, meshes, skipped = set(), [], []
    for obj in objects:
        if obj.type != "MESH":
            skipped.append((obj.name, "not a mesh object (%s)" % obj.type.lower()))
        elif obj.data.name in seen:
            skipped.append((obj.name, "shares mesh %r with an object already processed" % obj.data.name))
        elif obj.data.library is not None:
            skipped.append((obj.name, "mesh %r is linked from a library and cannot be edited" % obj.data.name))
        else:
            seen.add(obj.data.name)
            meshes.append(obj)
    return meshes, skipped

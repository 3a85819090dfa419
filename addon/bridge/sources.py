# SPDX-License-Identifier: GPL-3.0-or-later
"""What a run reads from Blender besides meshes: the sample image (a file or an image in the .blend), the
mesh objects to work on, and where the caches go."""
import os

import bpy

from .. import native
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
        """What texsynth_native.preprocess accepts: a path, or the image's pixels as numpy."""
        if self.image is not None:
            return mesh_io.read_image_pixels(self.image)
        if not self.path:
            raise SettingsError("no sample image: choose an image file or an image in the .blend")
        path = bpy.path.abspath(self.path)
        if not os.path.isfile(path):
            raise SettingsError("sample image not found: %s" % path)
        return path

    def shader_image(self):
        """The bpy image the node group samples (loaded once for file samples)."""
        if self.image is not None:
            return self.image
        return bpy.data.images.load(bpy.path.abspath(self.path), check_existing=True)


def read_sample_pixels(sample):
    """(H x W x C float32 pixels, row 0 = top, values as stored; True if they are sRGB-encoded)."""
    if sample.image is not None:
        image = sample.image
        return mesh_io.read_image_pixels(image), (not image.is_float and image.colorspace_settings.name == "sRGB")
    path = sample.native_input()
    module = native.require()
    info = module.image_info(path)
    return module.load_image(path), str(info.get("data_type", "uint8")) in ("uint8", "uint16")


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

# SPDX-License-Identifier: GPL-3.0-or-later
"""Images TexSynth writes (bakes, surface colour): new images, storing them packed or as files, naming
them in place of older outputs, and writing computed texels with a margin."""
import bpy
import numpy as np

from .. import native
from ..core import bake_options as options
from ..core.bake_options import BakeError


TEMP_PREFIX = "TexSynth Bake Temp "


def new_image(name, size, float_buffer):
    image = bpy.data.images.new(name, size, size, alpha=True, float_buffer=float_buffer)
    image.generated_color = (0.0, 0.0, 0.0, 0.0)
    if float_buffer:
        image.colorspace_settings.name = "Linear" if bpy.app.version < (4, 0, 0) else "Linear Rec.709"
    return image


def store_image(image, target):
    """Saves the image to target.path, or packs it into the .blend."""
    if target.path:
        image.filepath_raw = target.path
        image.file_format = target.file_format
        try:
            image.save()
        except RuntimeError as error:
            raise BakeError("could not save the baked image to %s: %s" % (target.path, str(error).strip()))
        image.filepath = target.path
        image.source = "FILE"
        image.reload()
    else:
        image.pack()


def take_name(image, name):
    """Gives image the name `name`, replacing (remapping users of) an existing image of that name."""
    old = bpy.data.images.get(name)
    if old is not None and old != image:
        old.user_remap(image)
        bpy.data.images.remove(old)
    image.name = name


def keep_unused(datablock):
    """Gives an output TexSynth does not assign (a baked image with no material, a baked material not
    assigned, a surface-colour image with material mode Layers Only) a fake user, so saving the .blend keeps
    it: a datablock with no user is dropped by the save, whatever the report said. Whatever users it has now
    do not count: take_name gave it those of the output it replaced (a material of the artist's showing the
    last result), and they may go. Returns it."""
    if datablock is not None:
        datablock.use_fake_user = True
    return datablock


def write_surface_colour(image, rgba, coverage, margin=options.DEFAULT_MARGIN):
    """Hook for methods that compute surface colour per texel (round neighbourhoods): writes `rgba`
    (float (H, W, 4), row 0 = top, linear values for float images) into the bpy image of the same size,
    after extending the covered texels (`coverage`, bool (H, W)) by `margin` pixels with
    texsynth_native.dilate_margin. Texels neither covered nor within the margin keep rgba's values."""
    rgba = np.ascontiguousarray(rgba, dtype=np.float32)
    coverage = np.ascontiguousarray(coverage, dtype=bool)
    width, height = int(image.size[0]), int(image.size[1])
    if rgba.shape != (height, width, 4) or coverage.shape != (height, width):
        raise BakeError("surface colour is %s with coverage %s; image %r is %dx%d RGBA"
                        % (rgba.shape, coverage.shape, image.name, width, height))
    if image.channels != 4:
        raise BakeError("image %r has %d channels, expected RGBA" % (image.name, image.channels))
    options.check_margin(int(margin), max(width, height))
    if margin > 0:
        module = native.require()
        if not hasattr(module, "dilate_margin"):
            raise BakeError("this texsynth_native has no dilate_margin (an older build): rebuild it")
        rgba = module.dilate_margin(rgba, coverage, int(margin))
    image.pixels.foreach_set(np.ascontiguousarray(rgba[::-1]).ravel())
    image.update()
    return image


def write_png(path, rgba_bottom_first):
    """Saves float RGBA pixels (row 0 = bottom, values 0..1 as stored) as an 8-bit PNG at path, through a
    temporary image that is removed again."""
    rgba = np.ascontiguousarray(rgba_bottom_first, dtype=np.float32)
    height, width = rgba.shape[:2]
    image = bpy.data.images.new("TexSynth PNG", width, height, alpha=True)
    try:
        image.pixels.foreach_set(rgba.ravel())
        image.filepath_raw = path
        image.file_format = "PNG"
        try:
            image.save()
        except RuntimeError as error:
            raise BakeError("could not write %s: %s" % (path, str(error).strip()))
    finally:
        bpy.data.images.remove(image)

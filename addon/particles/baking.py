# SPDX-License-Identifier: GPL-3.0-or-later
"""Baking a target's texture particles with its background (bake/baking.py calls this): prepare() reads and
checks the decal objects before the bake changes anything; apply() composites them onto the Cycles-baked
background through the bake UV map (particles/compositing.py) and redoes the margin."""
import time

import bpy
import numpy as np

from .. import native
from ..bridge import images, mesh_io
from ..core.bake_options import BakeError
from ..core.names import fit_name
from . import compositing, scene


class ParticleBake:
    def __init__(self, target, layers, atlas):
        self.target, self.layers, self.atlas = target, layers, atlas
        self.seconds = 0.0

    def note(self):
        return "particles: %d class layer(s) composited over the background in %.2f s" % (
            len(self.layers), self.seconds)


def prepare(target):
    """The target's decal layers in class order, read and checked, or None when it has none. BakeError (nothing
    changed) when the target was edited since synthesis, a decal mesh lacks its source data (made by an older
    TexSynth) or the atlas is missing."""
    objects = [obj for obj in scene.owned_objects(target.name, ("DECALS",)) if obj.type == "MESH"]
    if not objects:
        return None
    target.data.calc_loop_triangles()
    triangles = len(target.data.loop_triangles)
    layers = []
    for obj in sorted(objects, key=lambda o: (int(o.get(scene.RANK_TAG, o.get(scene.CLASS_TAG, 0))), o.name)):
        mesh = obj.data
        source = mesh.attributes.get(scene.SOURCE_TRIANGLE_NAME)
        bary = mesh_io.read_corner_attribute(mesh, scene.SOURCE_BARY_NAME, "FLOAT_VECTOR")
        atlas_uvs = mesh_io.read_corner_attribute(mesh, scene.ATLAS_UV, "FLOAT2")
        if scene.TRIANGLES_TAG not in obj or source is None or source.domain != "FACE" or bary is None \
                or atlas_uvs is None:
            raise BakeError("decal object %r has no source triangles for baking (made by an older TexSynth): "
                            "synthesize the particles of %r again" % (obj.name, target.name))
        if int(obj[scene.TRIANGLES_TAG]) != triangles:
            raise BakeError("object %r was edited since its particles were synthesized (%d triangles, the decals of "
                            "%r were made on %d): synthesize the particles again before baking"
                            % (target.name, triangles, obj.name, int(obj[scene.TRIANGLES_TAG])))
        starts, totals = mesh_io.read_polygon_layout(mesh)
        level = mesh.attributes.get(scene.STACK_LEVEL_NAME)  # absent on decals made before stacking: all 0
        layer = compositing.DecalLayer(starts, totals, atlas_uvs, mesh_io.read_face_ints(mesh, source.name),
                                       bary[:, :2], obj.name,
                                       None if level is None else mesh_io.read_face_ints(mesh, level.name))
        try:
            layer.check(triangles)
        except ValueError as error:
            raise BakeError(str(error)) from None
        layers.append(layer)
    atlas = bpy.data.images.get(fit_name(scene.ATLAS_PREFIX, target.name))
    if atlas is None:
        raise BakeError("the particle atlas %r of %r is missing: synthesize the particles again"
                        % (fit_name(scene.ATLAS_PREFIX, target.name), target.name))
    return ParticleBake(target, layers, atlas)


def _pixels(image):
    """(H, W, 4) float32, row 0 = bottom, as stored (sRGB-encoded for byte images)."""
    width, height = int(image.size[0]), int(image.size[1])
    if width == 0 or height == 0 or not image.has_data or image.channels != 4:
        raise BakeError("image %r could not be read as RGBA" % image.name)
    pixels = np.empty(width * height * 4, np.float32)
    image.pixels.foreach_get(pixels)
    return pixels.reshape(height, width, 4)


def _is_srgb(image):
    return not image.is_float and image.colorspace_settings.name not in ("Non-Color", "Linear", "Linear Rec.709")


def apply(bake, image, uv_map, margin):
    """Composites the layers onto `image` (the baked background) through `uv_map`, then the margin as
    write_surface_colour makes it. Raises BakeError; the caller removes the image on failure."""
    started = time.perf_counter()
    module = native.require()
    triangles, corner_uvs = mesh_io.read_loop_triangles(bake.target, uv_map)
    baked = _pixels(image)
    try:
        out, touched = compositing.composite(module, baked, _is_srgb(image), bake.layers, corner_uvs,
                                             _pixels(bake.atlas), _is_srgb(bake.atlas))
        height, width = out.shape[:2]
        covered = np.zeros(height * width, bool)
        if touched.any() and margin > 0:  # decals at an island's edge: the gutter takes their colours too
            positions = _positions(bake.target)
            covered[np.asarray(module.sample_texels(positions, triangles, corner_uvs, width, height, 0)["texel"])] = True
    except ValueError as error:
        raise BakeError("compositing the particles of %r: %s" % (bake.target.name, error)) from None
    if touched.any():
        mesh_io.fail_point("particle_bake")  # tests: a failure here must leave no image
        images.write_surface_colour(image, out[::-1], covered.reshape(height, width)[::-1],
                                    margin if covered.any() else 0)
    bake.seconds = time.perf_counter() - started
    return bake


def _positions(obj):
    positions = np.empty(len(obj.data.vertices) * 3, np.float32)
    obj.data.vertices.foreach_get("co", positions)
    return positions.reshape(-1, 3)

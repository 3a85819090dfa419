# SPDX-License-Identifier: GPL-3.0-or-later
"""Baking texture particles with their background (bpy-free): the decal layers composited "over" the baked
background in texture space.

Cycles' selected-to-active bake sees one decal per ray and loses the alpha of overlapping classes, so each
decal polygon is mapped into the bake UV map through the target triangle it lies in (decal_mesh's
source_triangle / source_barycentric), rasterised there with sample_texels (exact coverage) and the atlas
is sampled at the interpolated atlas UVs (bilinear, Image Texture's Linear + Clip). Layers go in class
order (a later class lies on top, as its decal offset puts it in a render). Within one class a texel takes
the decal with the highest stacking level covering it, as the render shows it lifted highest (decal_mesh's
stack_step); among equal levels the lowest-numbered particle (sample_texels keeps the lowest triangle, and
polygons are ordered by level first).
"""
import numpy as np


class DecalLayer:
    """One class's decal mesh as the bake needs it: polygons (loop_starts, loop_totals), per corner the atlas
    UV (C, 2) and the source barycentrics (C, 2), per polygon the target's loop triangle and stacking level
    (None: all 0). Polygons are kept highest level first (stable), the order the bake composites them in."""

    def __init__(self, loop_starts, loop_totals, corner_uvs, source_triangle, source_barycentric, name="",
                 face_level=None):
        self.loop_starts = np.ascontiguousarray(loop_starts, np.int64)
        self.loop_totals = np.ascontiguousarray(loop_totals, np.int64)
        self.face_level = (np.zeros(self.loop_starts.size, np.int64) if face_level is None
                           else np.ascontiguousarray(face_level, np.int64))
        self.corner_uvs = np.ascontiguousarray(corner_uvs, np.float32).reshape(-1, 2)
        self.source_triangle = np.ascontiguousarray(source_triangle, np.int64)
        self.source_barycentric = np.ascontiguousarray(source_barycentric, np.float64).reshape(-1, 2)
        self.name = name
        if self.face_level.shape == self.loop_starts.shape == self.source_triangle.shape:
            order = np.argsort(-self.face_level, kind="stable")  # loop_starts index the corners: nothing else moves
            self.loop_starts, self.loop_totals = self.loop_starts[order], self.loop_totals[order]
            self.source_triangle, self.face_level = self.source_triangle[order], self.face_level[order]

    def check(self, num_target_triangles):
        """ValueError naming the layer when its arrays disagree or point outside the target."""
        corners = self.corner_uvs.shape[0]
        what = self.name or "decal layer"
        if not (self.loop_starts.shape == self.loop_totals.shape == self.source_triangle.shape
                == self.face_level.shape):
            raise ValueError("%s: %d polygons but %d loop totals, %d source triangles and %d stacking levels" % (
                what, self.loop_starts.size, self.loop_totals.size, self.source_triangle.size, self.face_level.size))
        if self.source_barycentric.shape[0] != corners:
            raise ValueError("%s: %d corners but %d source barycentrics" % (what, corners,
                                                                           self.source_barycentric.shape[0]))
        if self.loop_totals.size and (self.loop_totals.min() < 3 or self.loop_starts.min() < 0
                                      or (self.loop_starts + self.loop_totals).max() > corners):
            raise ValueError("%s: polygons outside its %d corners" % (what, corners))
        if self.source_triangle.size and (self.source_triangle.min() < 0
                                          or self.source_triangle.max() >= num_target_triangles):
            raise ValueError("%s: source triangles outside the target's %d" % (what, num_target_triangles))
        if not (np.isfinite(self.corner_uvs).all() and np.isfinite(self.source_barycentric).all()):
            raise ValueError("%s: NaN or infinite UVs or barycentrics" % what)


def fan_triangles(loop_starts, loop_totals):
    """(T, 3) corner indices of each polygon's fan (the clipped faces are convex), and the polygon of each."""
    fans = np.maximum(loop_totals - 2, 0)
    polygon = np.repeat(np.arange(loop_starts.size), fans)
    first = np.repeat(loop_starts, fans)
    step = np.arange(polygon.size) - np.repeat(np.cumsum(fans) - fans, fans) + 1
    return np.stack([first, first + step, first + step + 1], 1), polygon


def bake_uvs(layer, target_corner_uvs):
    """(C, 2) bake-map UV of every decal corner: the target's corner UVs of its source triangle, interpolated."""
    face_of_corner = np.zeros(layer.corner_uvs.shape[0], np.int64)  # corners of no polygon: unused
    face_of_corner[_corner_index(layer)] = np.repeat(np.arange(layer.loop_starts.size), layer.loop_totals)
    uv = np.asarray(target_corner_uvs, np.float64)[layer.source_triangle[face_of_corner]]  # (C, 3, 2)
    b1, b2 = layer.source_barycentric[:, :1], layer.source_barycentric[:, 1:]
    return uv[:, 0] * (1 - b1 - b2) + uv[:, 1] * b1 + uv[:, 2] * b2


def _corner_index(layer):
    """Corner indices polygon by polygon (loop_starts need not be ascending)."""
    totals = layer.loop_totals
    offsets = np.arange(int(totals.sum())) - np.repeat(np.cumsum(totals) - totals, totals)
    return np.repeat(layer.loop_starts, totals) + offsets


def _srgb_formula(c):
    return np.where(c <= 0.04045, c / 12.92, ((np.maximum(c, 0.04045) + 0.055) / 1.055) ** 2.4).astype(np.float32)


_SRGB_TABLE = _srgb_formula(np.arange(256, dtype=np.float32) / 255)


def srgb_to_linear(c):
    c = np.asarray(c, np.float32)
    # Byte images give k / 255 (to float rounding: Blender multiplies by 1 / 255): a table then, the power
    # costs 10x more on a 2048² bake.
    steps = np.rint(c * 255)
    if c.size and steps.min() >= 0 and steps.max() <= 255 and np.abs(steps / 255 - c).max() <= 1e-6:
        return _SRGB_TABLE[steps.astype(np.intp)]
    return _srgb_formula(c)


def linear_to_srgb(c):
    c = np.clip(np.asarray(c, np.float32), 0.0, None)
    return np.where(c <= 0.0031308, c * 12.92, 1.055 * np.power(np.maximum(c, 0.0031308), 1 / 2.4) - 0.055
                    ).astype(np.float32)


def premultiplied(rgba, srgb):
    """Straight RGBA (N, 4), sRGB-encoded when srgb -> linear premultiplied float32."""
    out = np.array(rgba, np.float32, copy=True)
    if srgb:
        out[..., :3] = srgb_to_linear(out[..., :3])
    out[..., :3] *= out[..., 3:4]
    return out


def straight(rgba, srgb):
    """The inverse of premultiplied() (colour 0 where alpha is 0)."""
    out = np.array(rgba, np.float32, copy=True)
    alpha = out[..., 3:4]
    out[..., :3] = np.where(alpha > 0, out[..., :3] / np.maximum(alpha, 1e-12), 0.0)
    if srgb:
        out[..., :3] = linear_to_srgb(out[..., :3])
    return out


def sample_bilinear(image, uv, srgb):
    """Bilinear samples (N, 4), linear premultiplied, of a straight image (H, W, 4) (sRGB-encoded when srgb),
    row 0 at v = 0, texel centres at (i + 0.5) / size; outside the image transparent (Extension Clip).
    Taps are converted, not the image: a 4096² atlas costs more than the decals' texels."""
    height, width = image.shape[:2]
    padded = np.pad(image, ((1, 1), (1, 1), (0, 0)))  # a transparent border: taps outside read it
    x = np.clip(uv[:, 0].astype(np.float64) * width - 0.5, -1.0, width)
    y = np.clip(uv[:, 1].astype(np.float64) * height - 0.5, -1.0, height)
    x0, y0 = np.floor(x).astype(np.int64), np.floor(y).astype(np.int64)
    fx, fy = (x - x0)[:, None], (y - y0)[:, None]
    out = np.zeros((uv.shape[0], image.shape[2]), np.float64)
    for dx, dy, w in ((0, 0, (1 - fx) * (1 - fy)), (1, 0, fx * (1 - fy)), (0, 1, (1 - fx) * fy), (1, 1, fx * fy)):
        out += w * premultiplied(padded[np.minimum(y0 + dy + 1, height + 1), np.minimum(x0 + dx + 1, width + 1)], srgb)
    return out.astype(np.float32)


def composite(module, baked, baked_srgb, layers, target_corner_uvs, atlas, atlas_srgb, cancel=None):
    """Composites the decal layers (in order, later over earlier) onto `baked` ((H, W, 4) straight RGBA, row
    0 = bottom, sRGB-encoded when baked_srgb) through the target's bake UVs (T, 3, 2); the atlas is straight
    RGBA (row 0 = bottom). Returns (image like `baked`, texels covered by a decal (H*W,) bool). `module` is
    texsynth_native (its sample_texels rasterises)."""
    height, width = baked.shape[:2]
    target_corner_uvs = np.asarray(target_corner_uvs, np.float32)
    atlas = np.asarray(atlas, np.float32)
    result = np.array(baked, np.float32).reshape(-1, 4)  # converted only where a decal lands
    touched = np.zeros(height * width, bool)
    extra = {} if cancel is None else {"cancel": cancel}
    for layer in layers:
        layer.check(target_corner_uvs.shape[0])
        if layer.loop_starts.size == 0:
            continue
        corner_bake_uv = bake_uvs(layer, target_corner_uvs).astype(np.float32)
        fans, _ = fan_triangles(layer.loop_starts, layer.loop_totals)
        positions = np.zeros((corner_bake_uv.shape[0], 3), np.float32)
        positions[:, :2] = corner_bake_uv
        normals = np.zeros((fans.shape[0], 3, 3), np.float32)
        normals[..., 2] = 1.0  # unused; given so no normal is derived from the flat positions
        texels = module.sample_texels(positions, fans.astype(np.int32), corner_bake_uv[fans], width, height, 0,
                                      normals, **extra)
        where = np.asarray(texels["texel"], np.int64)
        if where.size == 0:
            continue
        tri = np.asarray(texels["triangle"], np.int64)
        b = np.asarray(texels["barycentric"], np.float64)
        corner = fans[tri]  # (N, 3)
        uv = layer.corner_uvs.astype(np.float64)
        atlas_uv = uv[corner[:, 0]] * (1 - b[:, :1] - b[:, 1:]) + uv[corner[:, 1]] * b[:, :1] + uv[corner[:, 2]] * b[:, 1:]
        source = sample_bilinear(atlas, atlas_uv, atlas_srgb)
        over = source[:, 3] > 0
        where, source = where[over], source[over]
        below = premultiplied(result[where], baked_srgb)
        result[where] = straight(source + below * (1.0 - source[:, 3:4]), baked_srgb)
        touched[where] = True
    return result.reshape(height, width, 4), touched

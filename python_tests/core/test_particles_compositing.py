# SPDX-License-Identifier: GPL-3.0-or-later
"""Baking texture particles (addon/particles/compositing.py, bpy-free): decals from the real decal_mesh on a
plane, composited through a known bake UV map onto a known background. Expected texels and colours are
worked out from the rectangles: a sprite lands exactly on the texel centres inside its rectangle's image,
later classes go over earlier ones, sRGB images are composited in linear and come back unchanged where a
decal is opaque, and bad layers are refused."""
import numpy as np
import pytest

import addon_package
from mesh_arrays import locate, triangle_grid

tn = pytest.importorskip("texsynth_native")
compositing = addon_package.load("particles.compositing")

SIZE = 16
BLUE = np.array([0.0, 0.0, 1.0, 1.0], np.float32)
RED = np.array([1.0, 0.0, 0.0, 1.0], np.float32)


def plane():
    pos, tris = triangle_grid(4, 0.25)  # the unit square, 32 triangles
    return pos, tris, tn.surface_walk_mesh(pos, tris)


def layer(walk, pos, tris, centre, half, uv_rect=(0.25, 0.25, 0.75, 0.75)):
    """One square particle (axis +x) through the real decal_mesh."""
    t, b = locate(pos, tris, centre)
    d = tn.decal_mesh(walk, np.array([t], np.int32), np.array([b], np.float64), np.array([[1.0, 0, 0]]),
                      np.array([[-half, -half, half, half]]), np.array([uv_rect]), offset=0.001)
    return compositing.DecalLayer(d["loop_starts"], d["loop_totals"], d["corner_uvs"], d["source_triangle"],
                                  d["source_barycentric"])


def solid(colour, size=8):
    return np.tile(np.asarray(colour, np.float32), (size, size, 1))


def inside(lo, hi):
    """Texel indices (per axis) whose centres (i + 0.5) / SIZE lie strictly inside (lo, hi)."""
    centres = (np.arange(SIZE) + 0.5) / SIZE
    return (centres > lo) & (centres < hi)


def test_a_sprite_lands_on_the_texels_of_its_rectangle_through_a_rotated_uv_map():
    pos, tris, walk = plane()
    decals = layer(walk, pos, tris, (0.4, 0.55), 0.2)  # x in [0.2, 0.6], y in [0.35, 0.75]
    xy = pos[tris][..., :2]
    uvs = np.stack([1.0 - xy[..., 1], xy[..., 0]], -1)  # u = 1 - y, v = x: a quarter turn
    out, touched = compositing.composite(tn, solid(BLUE, SIZE), False, [decals], uvs, solid(RED), False)
    # Texel (column i, row j) has u = (i + 0.5) / SIZE = 1 - y, v = (j + 0.5) / SIZE = x.
    expect = inside(0.2, 0.6)[:, None] & inside(1 - 0.75, 1 - 0.35)[None, :]  # [row j, column i]
    assert expect.sum() == 7 * 6  # rows 3..9 (x 0.2 .. 0.6), columns 4..9 (u 0.25 .. 0.65)
    np.testing.assert_array_equal(touched.reshape(SIZE, SIZE), expect)
    np.testing.assert_allclose(out[expect], np.tile(RED, (expect.sum(), 1)), atol=1e-6)
    np.testing.assert_array_equal(out[~expect], np.tile(BLUE, ((~expect).sum(), 1)))


def test_later_classes_go_over_earlier_ones_with_their_alpha():
    pos, tris, walk = plane()
    xy = pos[tris][..., :2]
    first = layer(walk, pos, tris, (0.5, 0.5), 0.3)
    second = layer(walk, pos, tris, (0.5, 0.5), 0.1)
    half_green = solid((0.0, 1.0, 0.0, 0.5))
    atlas = np.concatenate([solid(RED, 8), half_green], 1)  # left half red, right half half-green
    first.corner_uvs[:, 0] *= 0.5   # cells (0.125 .. 0.375) and (0.625 .. 0.875): bilinear stays inside
    second.corner_uvs[:, 0] = second.corner_uvs[:, 0] * 0.5 + 0.5
    out, _ = compositing.composite(tn, solid(BLUE, SIZE), False, [first, second], xy, atlas, False)
    centre = inside(0.4, 0.6)[:, None] & inside(0.4, 0.6)[None, :]
    ring = inside(0.2, 0.8)[:, None] & inside(0.2, 0.8)[None, :] & ~centre
    np.testing.assert_allclose(out[centre], np.tile([0.5, 0.5, 0.0, 1.0], (centre.sum(), 1)), atol=1e-6)
    np.testing.assert_allclose(out[ring], np.tile(RED, (ring.sum(), 1)), atol=1e-6)
    swapped, _ = compositing.composite(tn, solid(BLUE, SIZE), False, [second, first], xy, atlas, False)
    np.testing.assert_allclose(swapped[centre], np.tile(RED, (centre.sum(), 1)), atol=1e-6)


def test_within_a_class_the_higher_stacking_level_is_on_top_as_in_a_render():
    # Two overlapping squares of one class (one decal_mesh call) with stacking: they get levels 0 and 1, the
    # second lies higher, and the bake shows it over the first where they overlap; without stacking (all level
    # 0) the lowest-numbered particle wins, as before.
    pos, tris, walk = plane()
    xy = pos[tris][..., :2]
    anchors = [locate(pos, tris, c) for c in ((0.4, 0.5), (0.6, 0.5))]
    atlas = np.concatenate([solid(RED, 8), solid(BLUE, 8)], 1)  # cells (0.125 .. 0.375) and (0.625 .. 0.875)

    def decals(stack_step):
        d = tn.decal_mesh(walk, np.array([t for t, _ in anchors], np.int32), np.array([b for _, b in anchors]),
                          np.array([[1.0, 0, 0]] * 2), np.array([[-0.15, -0.15, 0.15, 0.15]] * 2),
                          np.array([[0.125, 0.25, 0.375, 0.75], [0.625, 0.25, 0.875, 0.75]]), offset=0.001,
                          stack_step=stack_step)
        return d, compositing.DecalLayer(d["loop_starts"], d["loop_totals"], d["corner_uvs"], d["source_triangle"],
                                         d["source_barycentric"], face_level=d["level"][d["face_particle"]])

    stacked, layer_stacked = decals(0.001)
    np.testing.assert_array_equal(stacked["level"], [0, 1])
    overlap = inside(0.35, 0.65)[:, None] & inside(0.45, 0.55)[None, :]  # [row (y), column (x)]
    assert overlap.sum() > 0
    out, _ = compositing.composite(tn, solid((0, 0, 0, 1), SIZE), False, [layer_stacked], xy, atlas, False)
    np.testing.assert_allclose(out[overlap], np.tile(BLUE, (overlap.sum(), 1)), atol=1e-6)
    flat, layer_flat = decals(0.0)
    np.testing.assert_array_equal(flat["level"], [0, 0])
    out, _ = compositing.composite(tn, solid((0, 0, 0, 1), SIZE), False, [layer_flat], xy, atlas, False)
    np.testing.assert_allclose(out[overlap], np.tile(RED, (overlap.sum(), 1)), atol=1e-6)


def test_srgb_images_are_composited_in_linear():
    pos, tris, walk = plane()
    xy = pos[tris][..., :2]
    decals = layer(walk, pos, tris, (0.5, 0.5), 0.3)
    background = solid((0.2, 0.4, 0.6, 1.0), SIZE)
    opaque = solid((0.8, 0.5, 0.1, 1.0))
    out, _ = compositing.composite(tn, background, True, [decals], xy, opaque, True)
    covered = inside(0.2, 0.8)[:, None] & inside(0.2, 0.8)[None, :]
    np.testing.assert_allclose(out[covered][:, :3], np.tile([0.8, 0.5, 0.1], (covered.sum(), 1)), atol=1e-5)
    np.testing.assert_allclose(out[~covered][:, :3], np.tile([0.2, 0.4, 0.6], ((~covered).sum(), 1)), atol=1e-5)
    half = solid((1.0, 1.0, 1.0, 0.5))
    mixed, _ = compositing.composite(tn, solid((0.0, 0.0, 0.0, 1.0), SIZE), True, [decals], xy, half, True)
    assert mixed[covered][0, 0] == pytest.approx(compositing.linear_to_srgb(np.float32(0.5)), abs=1e-5)


def test_bad_layers_are_refused():
    pos, tris, walk = plane()
    xy = pos[tris][..., :2]
    decals = layer(walk, pos, tris, (0.5, 0.5), 0.2)
    decals.source_triangle[0] = len(tris)
    with pytest.raises(ValueError, match="source triangles outside"):
        compositing.composite(tn, solid(BLUE, SIZE), False, [decals], xy, solid(RED), False)
    decals = layer(walk, pos, tris, (0.5, 0.5), 0.2)
    decals.source_barycentric = decals.source_barycentric[:-1]
    with pytest.raises(ValueError, match="source barycentrics"):
        compositing.composite(tn, solid(BLUE, SIZE), False, [decals], xy, solid(RED), False)


def test_fan_triangles_cover_each_polygon():
    fans, polygon = compositing.fan_triangles(np.array([0, 3]), np.array([3, 5]))
    np.testing.assert_array_equal(fans, [[0, 1, 2], [3, 4, 5], [3, 5, 6], [3, 6, 7]])
    np.testing.assert_array_equal(polygon, [0, 1, 1, 1])


def test_atlas_sampling_is_bilinear_with_a_transparent_outside():
    image = np.zeros((2, 2, 4), np.float32)
    image[0, 0] = (1.0, 0.0, 0.0, 1.0)
    image[0, 1] = (0.0, 1.0, 0.0, 0.5)
    uv = np.array([[0.25, 0.25], [0.5, 0.25], [0.0, 0.25], [-3.0, 0.25], [0.75, 2.0]])
    out = compositing.sample_bilinear(image, uv, False)
    np.testing.assert_allclose(out[0], [1.0, 0.0, 0.0, 1.0])                 # a texel centre
    np.testing.assert_allclose(out[1], [0.5, 0.25, 0.0, 0.75])               # premultiplied halfway
    np.testing.assert_allclose(out[2], [0.5, 0.0, 0.0, 0.5])                 # half outside: Clip
    np.testing.assert_allclose(out[3:], 0.0)
    steps = np.arange(256, dtype=np.float32) / 255
    formula = compositing._srgb_formula(steps)
    np.testing.assert_array_equal(compositing.srgb_to_linear(steps), formula)
    np.testing.assert_allclose(compositing.srgb_to_linear(steps + 1e-4), compositing._srgb_formula(steps + 1e-4))

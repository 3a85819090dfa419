# SPDX-License-Identifier: GPL-3.0-or-later
"""texsynth_native.sample_texels / dilate_margin: argument checking at the boundary, and small cases
end to end against analytic expectations (bilinear positions, overlap and gutter counts)."""
import numpy as np
import pytest

import texsynth_native as ts

# Parallelogram P(u, v) = O + u A + v B over UV [0, 1]^2, split along u = v.
O, A, B = np.array([1.0, 2.0, 3.0]), np.array([2.0, 0.0, 1.0]), np.array([0.0, 3.0, -1.0])
QUAD_UV = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], np.float32)
QUAD_TRIS = np.array([[0, 1, 2], [0, 2, 3]], np.int32)


def quad():
    pos = np.array([O + u * A + v * B for u, v in QUAD_UV], np.float32)
    return pos, QUAD_TRIS.copy(), QUAD_UV[QUAD_TRIS].copy()


def uv_rect(u0, v0, u1, v1, base=0):
    """A flat UV rectangle as two triangles with their own four vertices."""
    corners = np.array([[u0, v0], [u1, v0], [u1, v1], [u0, v1]], np.float32)
    pos = np.zeros((4, 3), np.float32)
    pos[:, :2] = corners
    return pos, QUAD_TRIS + base, corners[QUAD_TRIS]


def test_unit_quad_end_to_end():
    pos, tris, uvs = quad()
    r = ts.sample_texels(pos, tris, uvs, 4, 4, margin=0)
    assert r["texel"].dtype == np.int32 and r["texel"].shape == (16,)
    np.testing.assert_array_equal(r["texel"], np.arange(16))
    assert r["triangle"].dtype == np.int32 and r["island"].dtype == np.int32
    assert r["barycentric"].shape == (16, 2) and r["barycentric"].dtype == np.float32
    assert r["position"].shape == (16, 3) and r["normal"].shape == (16, 3)
    assert r["gutter_texel"].shape == (0,) and r["gutter_source"].shape == (0,)
    assert (r["num_overlapping_texels"], r["num_degenerate_triangles"], r["num_islands"]) == (0, 0, 1)
    x, y = np.arange(16) % 4, np.arange(16) // 4
    u, v = (x + 0.5) / 4, (y + 0.5) / 4
    expected = O + u[:, None] * A + v[:, None] * B
    np.testing.assert_allclose(r["position"], expected, atol=1e-5)
    n = np.cross(A, B) / np.linalg.norm(np.cross(A, B))
    np.testing.assert_allclose(r["normal"], np.broadcast_to(n, (16, 3)), atol=1e-6)
    # Barycentrics (weights of corners 1 and 2) give back the texel centre's UV.
    b1, b2 = r["barycentric"][:, 0:1], r["barycentric"][:, 1:2]
    corner = uvs[r["triangle"]]
    uv = (1 - b1 - b2) * corner[:, 0] + b1 * corner[:, 1] + b2 * corner[:, 2]
    np.testing.assert_allclose(uv, np.stack([u, v], axis=1), atol=1e-6)


def test_overlap_gutter_and_islands():
    # 8x8 image; in texel units island A = [0.1, 4.3] x [0.2, 5.4] (x 0..3, y 0..4), B = [2.2, 6.1] x
    # [3.6, 7.7] (x 2..5, y 4..7): 2 texels in both.
    pa, ta, ua = uv_rect(0.1 / 8, 0.2 / 8, 4.3 / 8, 5.4 / 8)
    pb, tb, ub = uv_rect(2.2 / 8, 3.6 / 8, 6.1 / 8, 7.7 / 8, base=4)
    r = ts.sample_texels(np.vstack([pa, pb]), np.vstack([ta, tb]), np.vstack([ua, ub]), 8, 8, 0)
    assert r["num_overlapping_texels"] == 2
    assert r["num_islands"] == 2
    assert len(r["texel"]) == 20 + 16 - 2
    np.testing.assert_array_equal(r["triangle_island"], [0, 0, 1, 1])

    # Gutter: a square over texel corners 4..8 of a 16x16 image, margin 2 -> the 36-texel ring.
    pos, tris, uvs = uv_rect(4 / 16, 4 / 16, 8 / 16, 8 / 16)
    g = ts.sample_texels(pos, tris, uvs, 16, 16, margin=2)
    assert len(g["texel"]) == 16 and len(g["gutter_texel"]) == 36
    gx, gy = g["gutter_texel"] % 16, g["gutter_texel"] // 16
    src = g["texel"][g["gutter_source"]]
    np.testing.assert_array_equal(src % 16, np.clip(gx, 4, 7))
    np.testing.assert_array_equal(src // 16, np.clip(gy, 4, 7))


def test_corner_normals_and_integer_inputs_are_accepted():
    pos, tris, uvs = quad()
    normals = np.zeros((2, 3, 3), np.float64)
    normals[..., 2] = 5.0  # any length: renormalised
    r = ts.sample_texels(pos.astype(np.float64), tris.astype(np.int64), uvs, 4, 4, 0, normals)
    np.testing.assert_allclose(r["normal"], np.tile([0, 0, 1], (16, 1)), atol=1e-7)


@pytest.mark.parametrize("bad, word", [
    (dict(positions=np.zeros((4, 2), np.float32)), "positions"),
    (dict(triangles=np.zeros((2, 4), np.int32)), "triangles"),
    (dict(triangles=np.zeros((2, 3), np.float32)), "triangles must hold integers"),
    (dict(corner_uvs=np.zeros((2, 3, 3), np.float32)), "corner_uvs"),
    (dict(corner_uvs=np.zeros((3, 3, 2), np.float32)), "corner_uvs"),
    (dict(corner_normals=np.zeros((2, 3), np.float32)), "corner_normals"),
    (dict(width=0), "at least 1 x 1"),
    (dict(width=10000, height=10000), "4800 MB"),
    (dict(margin=-1), "margin"),
])
def test_sample_texels_rejects_bad_arguments(bad, word):
    pos, tris, uvs = quad()
    args = dict(positions=pos, triangles=tris, corner_uvs=uvs, width=4, height=4)
    args.update(bad)
    with pytest.raises(ValueError, match=word):
        ts.sample_texels(**args)


def test_sample_texels_rejects_nan_and_bad_indices():
    pos, tris, uvs = quad()
    bad = uvs.copy()
    bad[1, 2, 0] = np.nan
    with pytest.raises(ValueError, match="triangle 1: UV of corner 2 is NaN"):
        ts.sample_texels(pos, tris, bad, 4, 4)
    bad_tris = tris.copy()
    bad_tris[0, 1] = 7
    with pytest.raises(ValueError, match="references vertex 7"):
        ts.sample_texels(pos, bad_tris, uvs, 4, 4)


def test_memory_estimate_and_cancel():
    assert ts.estimate_texel_sample_bytes(8192, 8192) <= ts.texel_sample_byte_limit
    assert ts.estimate_texel_sample_bytes(8193, 8192) > ts.texel_sample_byte_limit
    token = ts.CancelToken()
    token.cancel()
    pos, tris, uvs = quad()
    with pytest.raises(ts.Cancelled):
        ts.sample_texels(pos, tris, uvs, 64, 64, cancel=token)


def test_dilate_margin_end_to_end():
    h, w = 9, 11
    image = np.full((h, w, 4), 0.25, np.float32)
    image[4, 5] = [0.1, 0.2, 0.3, 1.0]
    mask = np.zeros((h, w), bool)
    mask[4, 5] = True
    out = ts.dilate_margin(image, mask, 2)
    assert out.shape == (h, w, 4) and out.dtype == np.float32
    assert out is not image
    yy, xx = np.mgrid[0:h, 0:w]
    disk = (xx - 5) ** 2 + (yy - 4) ** 2 <= 4
    np.testing.assert_array_equal(out[disk], np.tile(image[4, 5], (13, 1)))
    np.testing.assert_array_equal(out[~disk], image[~disk])
    np.testing.assert_array_equal(image[4, 4], [0.25] * 4)  # the input is not modified
    # uint8 and wide-integer masks: non-zero = covered (256 must not wrap to 0).
    np.testing.assert_array_equal(ts.dilate_margin(image, mask.astype(np.uint8), 2), out)
    np.testing.assert_array_equal(ts.dilate_margin(image, mask.astype(np.int64) * 256, 2), out)


def test_dilate_margin_keeps_garbage_out_of_the_margin():
    rng = np.random.default_rng(4)
    mask = rng.random((20, 30)) < 0.05
    image = np.where(mask[..., None], rng.random((20, 30, 4)), np.nan).astype(np.float32)
    out = ts.dilate_margin(image, mask, 3)
    np.testing.assert_array_equal(out[mask], image[mask])
    # Brute force: pixels within 3 (Euclidean) of a covered one get finite values, the others keep NaN.
    yy, xx = np.mgrid[0:20, 0:30]
    cy, cx = np.nonzero(mask)
    d2 = ((yy[..., None] - cy) ** 2 + (xx[..., None] - cx) ** 2).min(axis=-1)
    near = ~mask & (d2 <= 9)
    assert near.any() and (~mask & ~near).any()
    assert np.isfinite(out[near]).all()
    assert np.isnan(out[~mask & ~near]).all()


@pytest.mark.parametrize("image, mask, word", [
    (np.zeros((4, 5), np.float32), np.zeros((4, 5), bool), "image must have shape"),
    (np.zeros((4, 5, 4), np.float32), np.zeros((5, 4), bool), "mask must have shape"),
    (np.zeros((4, 5, 4), np.float32), np.zeros((4, 5), np.float32), "mask must be bool or integer"),
])
def test_dilate_margin_rejects_bad_arguments(image, mask, word):
    with pytest.raises(ValueError, match=word):
        ts.dilate_margin(image, mask, 2)
    with pytest.raises(ValueError, match="margin"):
        ts.dilate_margin(np.zeros((4, 5, 4), np.float32), np.zeros((4, 5), bool), -1)

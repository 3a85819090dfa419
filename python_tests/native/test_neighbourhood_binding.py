# SPDX-License-Identifier: GPL-3.0-or-later
"""texsynth_native.round_rings: argument checking at the boundary, and ring points rebuilt from the
returned arrays at the analytic distance m*r and template angle on a flat plane."""
import gc
import math

import numpy as np
import pytest

import texsynth_native as ts
from mesh_arrays import jittered_plane


def points_in(pos, tris, lo, hi, count, seed=2):
    """Random (triangle, b1, b2) whose point lies in the square [lo, hi]^2."""
    rng = np.random.default_rng(seed)
    t_out, b_out = [], []
    while len(t_out) < count:
        t = int(rng.integers(len(tris)))
        b1, b2 = rng.random(2)
        if b1 + b2 > 1:
            b1, b2 = 1 - b1, 1 - b2
        p = point(pos, tris, t, b1, b2)
        if lo <= p[0] <= hi and lo <= p[1] <= hi:
            t_out.append(t)
            b_out.append((b1, b2))
    return np.array(t_out, np.int32), np.array(b_out, np.float32)


def point(pos, tris, t, b1, b2):
    p = pos[tris[t]].astype(np.float64)
    return (1 - b1 - b2) * p[0] + b1 * p[1] + b2 * p[2]


def ring_positions(pos, tris, result):
    """(N, E, 3) positions of the ring points rebuilt from triangle + quantised barycentrics."""
    tri = result["triangle"]
    b = result["barycentrics"].astype(np.float64) / 65535.0
    corners = pos[tris[np.maximum(tri, 0)]].astype(np.float64)  # (N, E, 3 corners, 3)
    return (1 - b[..., 0:1] - b[..., 1:2]) * corners[..., 0, :] + b[..., 0:1] * corners[..., 1, :] + \
        b[..., 1:2] * corners[..., 2, :]


def test_plane_ring_points_at_radius_and_template_angle():
    pos, tris = jittered_plane()
    r = 0.12
    pt, bary = points_in(pos, tris, 1.0, 2.0, 200)  # K*r = 0.48 fits inside the 3 x 3 plane
    out = ts.round_rings(pos, tris, pt, bary, np.full(len(pt), r, np.float32))
    n, e = len(pt), 80
    assert out["rings"] == 4
    assert out["triangle"].shape == (n, e) and out["triangle"].dtype == np.int32
    assert out["barycentrics"].shape == (n, e, 2) and out["barycentrics"].dtype == np.uint16
    assert out["normal"].shape == (n, 3) and out["normal"].dtype == np.float32
    assert out["tangent"].shape == (n, 3) and out["tangent"].dtype == np.float32
    np.testing.assert_array_equal(out["ring_offsets"], [0, 8, 24, 48, 80])
    assert out["invalid_count"] == 0 and out["invalid_fraction"] == 0.0
    assert out["bytes"] == n * (e * 8 + 24)
    assert not out["triangle"].flags.writeable

    ring_points = ring_positions(pos, tris, out)
    centres = np.array([point(pos, tris, t, b[0], b[1]) for t, b in zip(pt, bary.astype(np.float64))])
    v = ring_points - centres[:, None, :]
    # t0 = first edge of the point's triangle; counter-clockwise about +z.
    edge = pos[tris[pt, 1]].astype(np.float64) - pos[tris[pt, 0]]
    t0 = edge / np.linalg.norm(edge, axis=1, keepdims=True)
    np.testing.assert_allclose(out["tangent"], t0, atol=1e-6)
    np.testing.assert_allclose(out["normal"], np.tile([0, 0, 1], (n, 1)), atol=1e-6)
    offsets = out["ring_offsets"]
    for m in range(1, 5):
        sl = slice(offsets[m - 1], offsets[m])
        assert sl.stop - sl.start == 8 * m
        np.testing.assert_allclose(np.linalg.norm(v[:, sl], axis=2), m * r, atol=2e-5)
        angle = np.arctan2(t0[:, None, 0] * v[:, sl, 1] - t0[:, None, 1] * v[:, sl, 0],
                           np.sum(t0[:, None, :2] * v[:, sl, :2], axis=2))
        want = 2 * math.pi * np.arange(8 * m) / (8 * m)
        diff = np.angle(np.exp(1j * (angle - want[None, :])))
        assert np.abs(diff).max() < 2e-4


def test_border_points_are_invalid_and_counted():
    pos, tris = jittered_plane(n=10, jitter=0.0)  # [0, 1]^2
    pt = np.array([0, 0], np.int32)
    bary = np.array([[0.2, 0.1], [0.3, 0.3]], np.float32)
    out = ts.round_rings(pos, tris, pt, bary, 0.2, rings=2)  # scalar radius: every point
    tri = out["triangle"]
    assert tri.shape == (2, 24)
    invalid = tri < 0
    assert 0 < invalid.sum() < tri.size  # the corner cell: discs half outside
    assert out["invalid_count"] == invalid.sum()
    assert out["invalid_fraction"] == pytest.approx(invalid.mean())
    np.testing.assert_array_equal(out["invalid_per_ring"], [invalid[:, 0:8].sum(), invalid[:, 8:24].sum()])
    assert np.all(out["barycentrics"][invalid] == 0)
    assert np.all(np.isfinite(ring_positions(pos, tris, out)))


def test_views_outlive_the_result_dict():
    pos, tris = jittered_plane(n=8)
    pt, bary = points_in(pos, tris, 0.3, 0.5, 5)
    out = ts.round_rings(pos, tris, pt, bary, 0.05, rings=1)
    tri, expected = out["triangle"], out["triangle"].copy()
    del out
    gc.collect()
    np.testing.assert_array_equal(tri, expected)


@pytest.mark.parametrize("arg, value, name", [
    ("positions", np.zeros((4, 2), np.float32), "positions"),
    ("positions", "abc", "positions"),
    ("triangles", np.zeros((2, 4), np.int32), "triangles"),
    ("triangles", np.zeros((2, 3), np.float32) + 0.5, "triangles"),
    ("point_triangles", np.zeros((3, 1), np.int32), "point_triangles"),
    ("point_barycentrics", np.zeros((3, 3), np.float32), "point_barycentrics"),
    ("point_barycentrics", np.zeros((2, 2), np.float32), "point_barycentrics"),
    ("point_radius", np.ones(4, np.float32), "point_radius"),
    ("point_radius", np.zeros(3, np.float32), "radius"),
    ("point_barycentrics", np.full((3, 2), 0.7, np.float32), "barycentrics"),
    ("point_triangles", np.array([0, 1, 99], np.int32), "triangle 99"),
])
def test_bad_arguments_raise_value_error_naming_them(arg, value, name):
    pos, tris = jittered_plane(n=2)
    args = dict(positions=pos, triangles=tris, point_triangles=np.zeros(3, np.int32),
                point_barycentrics=np.full((3, 2), 0.25, np.float32), point_radius=np.full(3, 0.1, np.float32))
    ts.round_rings(**args)  # the unmodified arguments are fine
    args[arg] = value
    with pytest.raises(ValueError, match=name):
        ts.round_rings(**args)


def test_bad_options_and_memory_limit():
    pos, tris = jittered_plane(n=2)
    pt, bary = np.zeros(3, np.int32), np.full((3, 2), 0.25, np.float32)
    for rings in (0, 7):
        with pytest.raises(ValueError, match="rings"):
            ts.round_rings(pos, tris, pt, bary, 0.1, rings=rings)
    bad = pos.copy()
    bad[1, 2] = np.nan
    with pytest.raises(ValueError, match="vertex 1"):
        ts.round_rings(bad, tris, pt, bary, 0.1)
    with pytest.raises(ValueError, match="MB"):
        ts.round_rings(pos, tris, pt, bary, 0.1, max_megabytes=1e-4)
    result_bytes, peak_bytes = ts.round_rings_memory(700000, 70000, 35000, 4)
    assert result_bytes == 700000 * (80 * 8 + 24)
    assert peak_bytes > result_bytes

# SPDX-License-Identifier: GPL-3.0-or-later
"""texsynth_native.decal_mesh and the particle analysis cache: output shapes and dtypes in Blender's
polygon layout, a big face shows only its rectangle (area, UV cell), a grid decal covers its rectangle,
shapes and values checked at the boundary, cancel; save / load round trip (same ParticleAnalysis type),
another key and a missing file give None, a damaged file raises ValueError."""
import math
import pathlib

import numpy as np
import pytest

from mesh_arrays import locate, triangle_grid

tn = pytest.importorskip("texsynth_native")


def polygon_areas(d):
    """Areas of the decal polygons (Newell), from the returned arrays only."""
    pos = d["positions"].astype(np.float64)
    areas = []
    for s, n in zip(d["loop_starts"], d["loop_totals"]):
        v = pos[d["corner_verts"][s:s + n]]
        areas.append(0.5 * np.linalg.norm(np.cross(v, np.roll(v, -1, axis=0)).sum(0)))
    return np.array(areas)


def one(pos, tris, xy, axis, rect, uv, **kw):
    t, b = locate(pos, tris, xy)
    return tn.decal_mesh(tn.surface_walk_mesh(pos, tris), np.array([t]), np.array([b]), np.array([axis]),
                         np.array([rect]), np.array([uv]), **kw)


def test_big_face_shows_only_its_rectangle():
    pos, tris = triangle_grid(1, 10.0)  # one 10 x 10 quad against a 1 x 0.6 particle
    a = math.radians(20)
    uv = (0.5, 0.25, 0.75, 0.5)
    d = one(pos, tris, (4.2, 5.1), (math.cos(a), math.sin(a), 0), (-0.5, -0.2, 0.5, 0.4), uv, offset=0.01)
    assert d["positions"].dtype == np.float32 and d["positions"].shape[1] == 3
    for key in ("loop_starts", "loop_totals", "corner_verts", "face_particle"):
        assert d[key].dtype == np.int32
    assert d["corner_uvs"].shape == (len(d["corner_verts"]), 2) and d["corner_uvs"].dtype == np.float32
    assert d["curved"].dtype == np.bool_ and d["curved"].shape == (1,) and not d["curved"][0]
    np.testing.assert_array_equal(d["loop_starts"], np.concatenate([[0], np.cumsum(d["loop_totals"])[:-1]]))
    assert math.isclose(polygon_areas(d).sum(), 0.6, rel_tol=1e-6)
    uvs = d["corner_uvs"]
    assert uvs[:, 0].min() == np.float32(0.5) and uvs[:, 0].max() == np.float32(0.75)
    assert uvs[:, 1].min() == np.float32(0.25) and uvs[:, 1].max() == np.float32(0.5)
    np.testing.assert_allclose(d["positions"][:, 2], 0.01, atol=1e-7)
    assert d["stats"]["particles"] == 1 and d["stats"]["empty"] == 0


def test_grid_decals_cover_their_rectangles_in_particle_order():
    pos, tris = triangle_grid(30, 0.1)
    mesh = tn.surface_walk_mesh(pos, tris)
    centres = [(0.73, 0.81), (1.52, 1.47), (2.2, 0.6)]
    located = [locate(pos, tris, c) for c in centres]
    rects = np.array([(-0.2, -0.1, 0.3, 0.15), (-0.25, -0.25, 0.25, 0.25), (-0.1, -0.3, 0.1, 0.3)])
    angles = np.array([0.0, 0.5, 2.0])
    axes = np.stack([np.cos(angles), np.sin(angles), np.zeros(3)], 1)
    d = tn.decal_mesh(mesh, [t for t, _ in located], [b for _, b in located], axes, rects,
                      np.tile([0.0, 0.0, 1.0, 1.0], (3, 1)), offset=0.0)
    fp = d["face_particle"]
    assert (np.diff(fp) >= 0).all() and set(fp) == {0, 1, 2}
    areas = polygon_areas(d)
    for i, r in enumerate(rects):
        assert math.isclose(areas[fp == i].sum(), (r[2] - r[0]) * (r[3] - r[1]), rel_tol=1e-5)
    # Each particle's vertices are its own: no corner of one particle's face points at another's vertex.
    owner = np.repeat(fp, d["loop_totals"])
    first = {i: d["corner_verts"][owner == i].min() for i in range(3)}
    assert first[0] == 0 and first[0] < first[1] < first[2]
    assert (d["corner_verts"][owner == 0] < first[1]).all()



def test_source_triangles_and_barycentrics_put_the_corners_back_on_the_surface():
    pos, tris = triangle_grid(12, 0.25)
    d = one(pos, tris, (1.43, 1.61), (1.0, 0.4, 0.0), (-0.6, -0.35, 0.5, 0.45), (0.1, 0.2, 0.3, 0.4), offset=0.0)
    lifted = one(pos, tris, (1.43, 1.61), (1.0, 0.4, 0.0), (-0.6, -0.35, 0.5, 0.45), (0.1, 0.2, 0.3, 0.4),
                 offset=0.05)
    source, bary = d["source_triangle"], d["source_barycentric"]
    assert source.dtype == np.int32 and source.shape == d["loop_starts"].shape
    assert bary.dtype == np.float32 and bary.shape == (len(d["corner_verts"]), 2)
    np.testing.assert_array_equal(lifted["source_triangle"], source)
    np.testing.assert_array_equal(lifted["source_barycentric"], bary)
    face_of_corner = np.repeat(np.arange(len(source)), d["loop_totals"])
    corners = pos[tris[source[face_of_corner]]].astype(np.float64)  # (C, 3, 3)
    b = bary.astype(np.float64)
    rebuilt = corners[:, 0] * (1 - b[:, :1] - b[:, 1:]) + corners[:, 1] * b[:, :1] + corners[:, 2] * b[:, 1:]
    np.testing.assert_allclose(rebuilt, d["positions"][d["corner_verts"]], atol=1e-6)
    assert len(np.unique(source)) > 5

def test_shapes_and_values_are_checked():
    pos, tris = triangle_grid(4, 1.0)
    mesh = tn.surface_walk_mesh(pos, tris)
    t, b = np.array([5]), np.array([[0.3, 0.3]])
    ax, rect, uv = np.array([[1.0, 0, 0]]), np.array([[-0.2, -0.2, 0.2, 0.2]]), np.array([[0, 0, 1, 1.0]])
    with pytest.raises(ValueError, match="axes"):
        tn.decal_mesh(mesh, t, b, np.ones((1, 2)), rect, uv, offset=0)
    with pytest.raises(ValueError, match="rects"):
        tn.decal_mesh(mesh, t, b, ax, np.ones((2, 4)), uv, offset=0)
    with pytest.raises(ValueError, match="uv_rects"):
        tn.decal_mesh(mesh, t, b, ax, rect, np.ones((1, 3)), offset=0)
    with pytest.raises(ValueError, match="barycentrics"):
        tn.decal_mesh(mesh, t, np.ones((1, 3)), ax, rect, uv, offset=0)
    with pytest.raises(ValueError, match="rect of particle 0"):
        tn.decal_mesh(mesh, t, b, ax, np.array([[0.2, -0.2, -0.2, 0.2]]), uv, offset=0)
    with pytest.raises(ValueError, match="triangle"):
        tn.decal_mesh(mesh, np.array([99]), b, ax, rect, uv, offset=0)
    with pytest.raises(ValueError, match="axis"):
        tn.decal_mesh(mesh, t, b, np.array([[0, 0, 1.0]]), rect, uv, offset=0)
    with pytest.raises(ValueError, match="offset"):
        tn.decal_mesh(mesh, t, b, ax, rect, uv, offset=float("nan"))
    with pytest.raises(ValueError, match="max_normal_angle"):
        tn.decal_mesh(mesh, t, b, ax, rect, uv, offset=0, max_normal_angle=90)
    with pytest.raises(TypeError):
        tn.decal_mesh(mesh, t, b, ax, rect, uv)  # offset is required
    token = tn.CancelToken()
    token.cancel()
    with pytest.raises(tn.Cancelled):
        tn.decal_mesh(mesh, t, b, ax, rect, uv, offset=0, cancel=token)
    empty = tn.decal_mesh(mesh, np.zeros(0, np.int32), np.zeros((0, 2)), np.zeros((0, 3)), np.zeros((0, 4)),
                          np.zeros((0, 4)), offset=0)
    assert empty["positions"].shape == (0, 3) and empty["curved"].shape == (0,)


def discs(width=96, height=64):
    ground, stone = np.array([0.2, 0.3, 0.25], np.float32), np.array([0.8, 0.7, 0.3], np.float32)
    img = np.tile(ground, (height, width, 1))
    y, x = np.mgrid[0:height, 0:width] + 0.5
    for cx, cy in [(20, 20), (50, 40), (80, 15)]:
        img[(x - cx) ** 2 + (y - cy) ** 2 <= 49] = stone
    return img


def test_analysis_cache_round_trip_key_and_damage(tmp_path):
    a = tn.particle_analysis(discs(), classes=2, blur=0.0)
    path = tmp_path / "a.tspart"
    tn.save_particle_analysis(a, path, 2**63 + 5)  # pathlib and the full unsigned range
    b = tn.load_particle_analysis(str(path), 2**63 + 5)
    assert isinstance(b, tn.ParticleAnalysis)
    for name in ("labels", "components", "background"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    assert a.particles.tobytes() == b.particles.tobytes() and a.classes.tobytes() == b.classes.tobytes()
    for key, value in a.cooccurrences.items():
        np.testing.assert_array_equal(value, b.cooccurrences[key])
    assert a.stats == b.stats and a.background_class == b.background_class
    s = tn.particle_sprite(b, discs(), 1)  # the loaded analysis is usable as is
    np.testing.assert_array_equal(s["rgba"], tn.particle_sprite(a, discs(), 1)["rgba"])
    assert tn.load_particle_analysis(path, 6) is None
    assert tn.load_particle_analysis(tmp_path / "missing.tspart", 5) is None
    data = bytearray(pathlib.Path(path).read_bytes())
    data[len(data) // 2] ^= 0x10
    pathlib.Path(path).write_bytes(bytes(data))
    with pytest.raises(ValueError, match="checksum"):
        tn.load_particle_analysis(path, 2**63 + 5)
    pathlib.Path(path).write_bytes(bytes(data[:40]))
    with pytest.raises(tn.CacheError):
        tn.load_particle_analysis(path, 2**63 + 5)

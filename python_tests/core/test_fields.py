# SPDX-License-Identifier: GPL-3.0-or-later
"""Field authoring core (addon/authoring.py) and native ray casting, against independent computations:
brute-force ray/triangle tests, geometric expectations, and UV Jacobians of the synthesized output."""
import math

import numpy as np
import pytest

import addon_package
import texsynth_native as ts
from mesh_arrays import face_jacobians, pack, polygon_grid

authoring = addon_package.load("fields.authoring")
core_layers = addon_package.load("core.layers")
native = addon_package.load("native")
# One copy of the extension per process: texsynth.texsynth_native would register its types twice.
native._module, native._reason, native._tried = ts, None, True


def mesh_arrays(pos, corner_verts, starts, sizes):
    return core_layers.MeshArrays(pos, corner_verts, starts, sizes)


def new_state(arrays, axis=(0.0, 1.0, 0.0)):
    n = arrays.num_vertices
    state = authoring.FieldState(arrays, np.zeros((n, 3), np.float32), np.zeros(n, np.int32),
                              np.zeros((n, 3), np.float32), axis)
    authoring.relax(state)
    return state


def angle_deg(a, b):
    a = a / np.linalg.norm(a, axis=-1, keepdims=True)
    b = b / np.linalg.norm(b, axis=-1, keepdims=True)
    return np.degrees(np.arccos(np.clip(np.sum(a * b, axis=-1), -1.0, 1.0)))


# ---------------------------------------------------------------------------------------------
# Ray casting

def brute_force_cast(pos, corner_verts, starts, sizes, origins, directions):
    """Nearest (face, t) per ray over all fan triangles, vectorised Möller–Trumbore in float64."""
    tris, owner = [], []
    for p, (s, k) in enumerate(zip(starts, sizes)):
        for j in range(1, k - 1):
            tris.append((corner_verts[s], corner_verts[s + j], corner_verts[s + j + 1]))
            owner.append(p)
    tris, owner = np.array(tris), np.array(owner)
    v0, v1, v2 = (pos[tris[:, i]].astype(np.float64) for i in range(3))
    e1, e2 = v1 - v0, v2 - v0
    faces, ts_ = np.full(len(origins), -1), np.full(len(origins), np.inf)
    for i, (o, d) in enumerate(zip(origins.astype(np.float64), directions.astype(np.float64))):
        h = np.cross(d, e2)
        det = np.sum(e1 * h, axis=1)
        ok = np.abs(det) > 1e-15
        inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
        s = o - v0
        u = np.sum(s * h, axis=1) * inv
        q = np.cross(s, e1)
        v = (q @ d) * inv
        t = np.sum(e2 * q, axis=1) * inv
        hit = ok & (u >= 0) & (v >= 0) & (u + v <= 1) & (t >= 0)
        if np.any(hit):
            j = np.flatnonzero(hit)[np.argmin(t[hit])]
            faces[i], ts_[i] = owner[j], t[j]
    return faces, ts_


def test_raycast_matches_brute_force_on_a_bumpy_quad_grid():
    pos, cv, st, sz = polygon_grid(20, 0.1, triangles=False, jitter=0.3)
    rng = np.random.default_rng(4)
    pos = pos.copy()
    pos[:, 2] = 0.05 * np.sin(pos[:, 0] * 9) * np.cos(pos[:, 1] * 7)  # non-planar quads
    caster = ts.RayCaster(pos, cv, st, sz)
    n = 400
    origins = np.column_stack([rng.uniform(-0.2, 2.2, n), rng.uniform(-0.2, 2.2, n), np.full(n, 1.0)]).astype(np.float32)
    directions = np.column_stack([rng.uniform(-0.3, 0.3, n), rng.uniform(-0.3, 0.3, n), -np.ones(n)]).astype(np.float32)
    got = caster.cast(origins, directions)
    want_face, want_t = brute_force_cast(pos, cv, st, sz, origins, directions)
    hit = want_face >= 0
    assert hit.sum() > n // 2
    assert np.mean(got["face"][hit] == want_face[hit]) > 0.99
    assert np.all((got["face"] >= 0) == hit) or np.sum((got["face"] >= 0) != hit) <= 2
    both = hit & (got["face"] >= 0)
    np.testing.assert_allclose(got["distance"][both], want_t[both], rtol=1e-4, atol=1e-5)
    # Barycentrics reconstruct the hit point.
    p = np.einsum("nk,nkd->nd", got["barycentrics"][both], pos[got["vertices"][both]])
    np.testing.assert_allclose(p, origins[both] + want_t[both, None] * directions[both], atol=1e-4)
    assert np.all(np.isinf(got["distance"][got["face"] < 0]))


def test_raycast_rejects_bad_input_with_value_errors():
    pos, cv, st, sz = polygon_grid(2, 1.0)
    with pytest.raises(ValueError, match="corner_verts"):
        ts.RayCaster(pos, cv + 100, st, sz)
    bad = pos.copy()
    bad[0, 0] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        ts.RayCaster(bad, cv, st, sz)
    caster = ts.RayCaster(pos, cv, st, sz)
    with pytest.raises(ValueError, match="directions"):
        caster.cast(np.zeros((2, 3)), np.zeros((3, 3)))
    with pytest.raises(ValueError, match="NaN"):
        caster.cast([[0, 0, np.inf]], [[0, 0, -1]])
    with pytest.raises(ValueError, match="radius"):
        caster.vertices_within((0, 0, 0), -1.0)


def newell_vertex_normals(pos, corner_verts, starts, sizes):
    """Reference: area-weighted vertex normals from Newell polygon normals (float64 numpy)."""
    normals = np.zeros((len(pos), 3))
    for s, k in zip(starts, sizes):
        ring = pos[corner_verts[s:s + k]].astype(np.float64)
        newell = np.cross(ring, np.roll(ring, -1, axis=0)).sum(0)
        normals[corner_verts[s:s + k]] += newell
    return normals / np.linalg.norm(normals, axis=1, keepdims=True)


def test_vertex_normals_match_newell_area_weighting():
    pos, cv, st, sz = polygon_grid(12, 0.1, triangles=False, jitter=0.3)
    pos = pos.copy()
    pos[:, 2] = 0.3 * np.sin(pos[:, 0] * 5) * np.cos(pos[:, 1] * 4)
    got = authoring.vertex_normals(mesh_arrays(pos, cv, st, sz))
    np.testing.assert_allclose(got, newell_vertex_normals(pos, cv, st, sz), atol=1e-5)


def test_field_mesh_gives_the_same_field_and_normals_as_the_one_shot_calls():
    pos, cv, st, sz = polygon_grid(20, 0.05, jitter=0.3)
    pos = pos.copy()
    pos[:, 2] = 0.1 * np.sin(pos[:, 0] * 6)
    guide = np.zeros_like(pos)
    guide[::37] = (1.0, 0.3, 0.0)
    kwargs = dict(orientation="field", axis=(0.0, 1.0, 0.0), direction=guide, sources=[5], sinks=[300])
    field_mesh = ts.FieldMesh(pos, cv, st, sz)
    np.testing.assert_array_equal(field_mesh.compute_field(**kwargs), ts.compute_field(pos, cv, st, sz, **kwargs))
    np.testing.assert_array_equal(field_mesh.normals, ts.vertex_normals(pos, cv, st, sz))
    with pytest.raises(ValueError, match="direction"):
        field_mesh.compute_field(orientation="field", direction=np.zeros((3, 3)))


# ---------------------------------------------------------------------------------------------
# Comb brush

def test_synthetic_stroke_on_a_plane_sets_directions_under_the_brush_and_a_smooth_field_elsewhere():
    pos, cv, st, sz = polygon_grid(60, 1.0 / 60)  # unit square, triangles
    arrays = mesh_arrays(pos, cv, st, sz)
    state = new_state(arrays, axis=(0.0, 1.0, 0.0))  # before: +Y everywhere
    caster = authoring.ray_caster(arrays)
    radius = 0.08
    brush = authoring.CombBrush(state, caster, radius)
    stroke_dir = np.array([1.0, 1.0, 0.0]) / math.sqrt(2)  # diagonal stroke through the middle
    for s in np.linspace(0.25, 0.75, 30):
        point = np.array([s, s, 0.0])
        assert brush.dab(point + (0, 0, 1), (0, 0, -1)) is not None
    assert brush.end_stroke()

    d = state.direction
    np.testing.assert_allclose(np.linalg.norm(d, axis=1), 1.0, atol=1e-4)
    assert np.all(np.abs(d[:, 2]) < 1e-4)  # tangent to the plane
    # Under the brush core (inside the stroked segment, distance to the line < radius / 2):
    rel = pos[:, :2] - 0.5
    along = rel @ stroke_dir[:2]
    across = np.abs(rel @ np.array([-stroke_dir[1], stroke_dir[0]]))
    core = (across < radius / 2) & (np.abs(along) < 0.3)
    assert core.sum() > 40
    assert np.max(angle_deg(d[core], stroke_dir)) < 3.0
    # The rest follows the stroke (only anchors) and is smooth: neighbours differ by little.
    e = authoring.edges(arrays)
    assert np.percentile(angle_deg(d[e[:, 0]], d[e[:, 1]]), 99) < 5.0
    assert np.median(angle_deg(d, stroke_dir)) < 10.0
    # Anchors are exactly the painted vertices (within the radius of some dab).
    anchored = np.any(state.guide != 0, axis=1)
    assert np.all(across[anchored] <= radius + 1e-6)


def test_erase_removes_anchors_under_the_brush_only():
    pos, cv, st, sz = polygon_grid(40, 1.0 / 40)
    arrays = mesh_arrays(pos, cv, st, sz)
    state = new_state(arrays)
    state.guide[:] = (1.0, 0.0, 0.0)
    brush = authoring.CombBrush(state, authoring.ray_caster(arrays), 0.1)
    brush.dab((0.5, 0.5, 1.0), (0, 0, -1), erase_mode=True)
    brush.end_stroke()
    distance = np.linalg.norm(pos[:, :2] - 0.5, axis=1)
    erased = ~np.any(state.guide != 0, axis=1)
    assert np.all(erased[distance < 0.099]) and not np.any(erased[distance > 0.101])


def test_brush_never_paints_the_far_side_of_a_thin_slab():
    top = polygon_grid(10, 0.1)
    bottom_pos = top[0].copy()
    bottom_pos[:, 2] = -0.01
    n = len(top[0])
    polys_top = [list(top[1][s:s + k]) for s, k in zip(top[2], top[3])]
    polys_bottom = [[v + n for v in reversed(p)] for p in polys_top]  # facing -Z
    arrays = mesh_arrays(*pack(np.concatenate([top[0], bottom_pos]), polys_top + polys_bottom))
    state = new_state(arrays)
    brush = authoring.CombBrush(state, authoring.ray_caster(arrays), 0.3)
    brush.dab((0.3, 0.5, 1), (0, 0, -1))
    brush.dab((0.6, 0.5, 1), (0, 0, -1))
    painted = np.any(state.guide != 0, axis=1)
    assert painted[:n].sum() > 10 and not painted[n:].any()


# ---------------------------------------------------------------------------------------------
# Sources and sinks

@pytest.mark.parametrize("kind", [authoring.SOURCE, authoring.SINK])
def test_sources_point_away_and_sinks_point_toward(kind):
    pos, cv, st, sz = polygon_grid(40, 1.0 / 40, jitter=0.2)
    arrays = mesh_arrays(pos, cv, st, sz)
    state = new_state(arrays)
    centre = int(np.argmin(np.linalg.norm(pos[:, :2] - 0.5, axis=1)))
    authoring.set_singularity(state, centre, kind)
    radial = pos - pos[centre]
    far = np.linalg.norm(radial, axis=1) > 3.0 / 40
    errors = angle_deg(state.direction[far], kind * radial[far])
    assert np.median(errors) < 3.0 and np.percentile(errors, 95) < 10.0
    authoring.set_singularity(state, centre, 0)  # removed: back to the axis
    assert np.max(angle_deg(state.direction, np.array([0.0, 1.0, 0.0]))) < 1e-3
    with pytest.raises(ValueError, match="not in the mesh"):
        authoring.set_singularity(state, 10 ** 6, authoring.SOURCE)


# ---------------------------------------------------------------------------------------------
# Presets

def test_curvature_preset_follows_a_cylinder_axis():
    segments, rows = 48, 24
    a = np.linspace(0, 2 * np.pi, segments, endpoint=False)
    z = np.linspace(0, 2, rows + 1)
    pos = np.array([(0.4 * math.cos(t), 0.4 * math.sin(t), h) for h in z for t in a], np.float32)
    idx = lambda i, j: i * segments + j % segments
    polys = [[idx(i, j), idx(i, j + 1), idx(i + 1, j + 1), idx(i + 1, j)] for i in range(rows) for j in range(segments)]
    state = new_state(mesh_arrays(*pack(pos, polys)), axis=(1.0, 0.0, 0.0))
    before = np.median(np.abs(state.direction[:, 2]))
    authoring.preset_curvature(state)
    assert before < 0.5  # the axis preset was not already vertical
    assert np.min(np.abs(state.direction[:, 2])) > 0.99


def test_smooth_preset_reduces_roughness_and_axis_preset_clears_the_guide():
    pos, cv, st, sz = polygon_grid(30, 1.0 / 30)
    arrays = mesh_arrays(pos, cv, st, sz)
    state = new_state(arrays)
    rng = np.random.default_rng(2)
    angles = rng.uniform(-0.8, 0.8, arrays.num_vertices)
    state.guide[:] = np.column_stack([np.sin(angles), np.cos(angles), np.zeros_like(angles)])
    authoring.relax(state)
    e = authoring.edges(arrays)
    rough = np.mean(angle_deg(state.direction[e[:, 0]], state.direction[e[:, 1]]))
    authoring.preset_smooth(state, iterations=20)
    smooth = np.mean(angle_deg(state.direction[e[:, 0]], state.direction[e[:, 1]]))
    assert smooth < rough / 4
    authoring.preset_axis(state, (1.0, 0.0, 0.0))
    assert not state.guide.any()
    assert np.max(angle_deg(state.direction, np.array([1.0, 0.0, 0.0]))) < 1e-3


def test_strokes_become_anchors_along_their_tangent():
    pos, cv, st, sz = polygon_grid(40, 1.0 / 40)
    arrays = mesh_arrays(pos, cv, st, sz)
    state = new_state(arrays)
    t = np.linspace(0, 1, 40)
    stroke = np.column_stack([0.2 + 0.6 * t, 0.5 + 0.1 * np.sin(3 * t), np.full_like(t, 0.002)])
    used = authoring.anchors_from_strokes(state, authoring.ray_caster(arrays), [stroke, np.zeros((1, 3))], 0.05)
    assert used == 40
    for point, tangent in zip(stroke[5:-5], authoring.stroke_tangents(stroke)[5:-5]):
        nearest = np.argmin(np.linalg.norm(pos - point, axis=1))
        assert angle_deg(state.direction[nearest], tangent) < 8.0


def test_scale_from_weights_maps_the_range():
    np.testing.assert_allclose(authoring.scale_from_weights([0, 0.5, 1, 2], 0.5, 2.0), [0.5, 1.25, 2.0, 2.0])
    with pytest.raises(ValueError, match="positive"):
        authoring.scale_from_weights([0], 0.0, 1.0)
    with pytest.raises(ValueError, match="vertex 1"):
        authoring.check_scale_multiplier([1.0, np.nan], "attribute")


# ---------------------------------------------------------------------------------------------
# Synthesis follows the field and the scale

@pytest.fixture(scope="module")
def pre():
    rng = np.random.default_rng(0)
    return ts.preprocess(rng.random((128, 128, 3), dtype=np.float32), jump_candidates=4)


def per_face_frames(pos, cv, st, uv, pre):
    """Per triangle: 3D direction of texture 'up' (UV +v) and texels per unit (sqrt |det J|)."""
    J, e1, e2 = face_jacobians(pos, cv, st, uv, pre)
    up_2d = np.linalg.solve(J, np.tile([0.0, -1.0], (len(J), 1))[..., None])[..., 0]  # texel y grows downward
    up = up_2d[:, :1] * e1 + up_2d[:, 1:] * e2
    return up, np.sqrt(np.abs(np.linalg.det(J)))


def test_synthesized_rotation_follows_a_swirling_field(pre):
    pos, cv, st, sz = polygon_grid(40, 0.05, jitter=0.2)
    centre = pos[:, :2].mean(0)
    angle = 2.0 * np.linalg.norm(pos[:, :2] - centre, axis=1)  # rotation grows with the radius
    field = np.column_stack([-np.sin(angle), np.cos(angle), np.zeros_like(angle)]).astype(np.float32)
    out = ts.synthesize_jumpmap(pre, pos, cv, st, sz, scale=40.0, orientation="field", direction=field, blend=False)
    up, _ = per_face_frames(pos, cv, st, out["base_uv"], pre)
    face_field = field[cv.reshape(-1, 3)].mean(1)
    errors = angle_deg(up, face_field)
    assert np.median(errors) < 3.0 and np.percentile(errors, 95) < 8.0, (np.median(errors), np.percentile(errors, 95))
    # Independent check that the statistic can fail: the axis orientation ignores the swirl.
    axis_out = ts.synthesize_jumpmap(pre, pos, cv, st, sz, scale=40.0, orientation="axis", axis=(0, 1, 0), blend=False)
    axis_up, _ = per_face_frames(pos, cv, st, axis_out["base_uv"], pre)
    assert np.median(angle_deg(axis_up, face_field)) > 20.0


def test_synthesized_scale_follows_the_multiplier(pre):
    pos, cv, st, sz = polygon_grid(40, 0.025, jitter=0.2)
    multiplier = (0.5 + 1.5 * pos[:, 0] / pos[:, 0].max()).astype(np.float32)  # 0.5 .. 2 along x
    scale = 30.0
    out = ts.synthesize_jumpmap(pre, pos, cv, st, sz, scale=scale, scale_multiplier=multiplier, blend=False)
    _, density = per_face_frames(pos, cv, st, out["base_uv"], pre)
    face_multiplier = multiplier[cv.reshape(-1, 3)].mean(1)
    relative = density / (scale * face_multiplier) - 1.0
    assert np.median(np.abs(relative)) < 0.03 and np.percentile(np.abs(relative), 95) < 0.1


def test_combing_over_anchors_blends_with_the_falloff():
    pos, cv, st, sz = polygon_grid(40, 1.0 / 40)
    arrays = mesh_arrays(pos, cv, st, sz)
    state = new_state(arrays)
    state.guide[:] = (0.0, 1.0, 0.0)
    brush = authoring.CombBrush(state, authoring.ray_caster(arrays), 0.2)
    brush.dab((0.45, 0.5, 1.0), (0, 0, -1))
    brush.dab((0.5, 0.5, 1.0), (0, 0, -1))  # one dab moving +X, centred at (0.5, 0.5)
    distance = np.linalg.norm(pos[:, :2] - (0.5, 0.5), axis=1)
    turned = angle_deg(state.guide, np.array([0.0, 1.0, 0.0]))  # 90 = fully +X
    expected = np.degrees(np.arctan2(authoring.falloff(distance, 0.2), 1.0 - authoring.falloff(distance, 0.2)))
    inside = distance < 0.2
    np.testing.assert_allclose(turned[inside], expected[inside], atol=0.5)
    assert np.all(turned[~inside] < 1e-3)

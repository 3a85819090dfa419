# SPDX-License-Identifier: GPL-3.0-or-later
"""texsynth_native.synthesize_jumpmap / compute_field / mesh_info through the Python boundary."""
import math

import numpy as np
import pytest

import texsynth_native as ts
from mesh_arrays import face_jacobians, pack, polygon_grid


@pytest.fixture(scope="module")
def pre():
    rng = np.random.default_rng(0)
    return ts.preprocess(rng.random((64, 64, 3), dtype=np.float32), jump_candidates=4)


def test_flat_jittered_grid_every_face_is_a_similarity_with_scale_and_rotation(pre):
    mesh = polygon_grid(16, 0.1, jitter=0.5)
    angle = 0.9
    axis = (math.sin(angle), math.cos(angle), 0.0)
    out = ts.synthesize_jumpmap(pre, *mesh, scale=25.0, orientation="axis", axis=axis, seed=4)
    assert out["num_blend_sets"] == 3
    for uv in [out["base_uv"], *out["blend_uv"]]:
        J, e1, e2 = face_jacobians(mesh[0], mesh[1], mesh[2], uv, pre)
        sv = np.linalg.svd(J, compute_uv=False)
        np.testing.assert_allclose(sv, 25.0, rtol=2e-3)
        assert (np.linalg.det(J) < 0).all()  # texel y points down: det < 0 means not mirrored
        up_local = np.linalg.solve(J, np.tile([[0.0], [-1.0]], (J.shape[0], 1, 1)))[..., 0]  # texture "up" in 3D
        up = up_local[:, :1] * e1 + up_local[:, 1:] * e2
        up /= np.linalg.norm(up, axis=1, keepdims=True)
        np.testing.assert_allclose(up @ np.array(axis), 1.0, atol=1e-5)
    assert ((out["base_uv"] >= 0) & (out["base_uv"] <= 1)).all()
    assert ((out["blend_uv"] >= 0) & (out["blend_uv"] <= 1)).all()


def test_blend_sets_agree_with_each_vertex_address_and_weights_are_one_hot(pre):
    mesh = polygon_grid(12, 0.15, triangles=False)
    pos, corner_verts, starts, sizes = mesh
    out = ts.synthesize_jumpmap(pre, *mesh, scale=20.0, seed=2)
    S = out["num_blend_sets"]
    assert S == 4 and out["blend_weights"].shape == (corner_verts.size, 4)
    w = out["blend_weights"]
    assert set(np.unique(w)) <= {0.0, 1.0} and (w.sum(1) == 1).all()
    # set k of each quad is grown from its corner k: that corner's UV is the vertex's own address,
    # so every quad sharing the vertex must report the same UV there.
    seen = {}
    for k in range(S):
        corners = starts + k
        for c in corners:
            v = corner_verts[c]
            uv = tuple(out["blend_uv"][k, c])
            assert seen.setdefault(v, uv) == pytest.approx(uv, abs=1e-6)
            assert w[c, k] == 1.0


def test_deterministic_and_seed_dependent(pre):
    mesh = polygon_grid(20, 0.05, jitter=0.4)
    a = ts.synthesize_jumpmap(pre, *mesh, scale=40.0, seed=7)
    b = ts.synthesize_jumpmap(pre, *mesh, scale=40.0, seed=7)
    c = ts.synthesize_jumpmap(pre, *mesh, scale=40.0, seed=8)
    for key in ("base_uv", "blend_uv", "blend_weights"):
        assert a[key].tobytes() == b[key].tobytes()
    assert a["base_uv"].tobytes() != c["base_uv"].tobytes()
    assert a["stats"]["vertices"] == 21 * 21 and a["stats"]["faces"] == 800 and a["stats"]["components"] == 1


def test_other_dtypes_and_layouts_are_converted(pre):
    pos, corner_verts, starts, sizes = polygon_grid(5, 0.1)
    ref = ts.synthesize_jumpmap(pre, pos, corner_verts, starts, sizes, scale=30.0)
    wide = np.asfortranarray(pos.astype(np.float64))
    out = ts.synthesize_jumpmap(pre, wide, corner_verts.astype(np.int64), list(starts), sizes.astype(np.uint16),
                                scale=30.0)
    assert out["base_uv"].tobytes() == ref["base_uv"].tobytes()


@pytest.mark.parametrize(
    "mutate, message",
    [
        (lambda m: (m[0], np.where(m[1] == 3, 999, m[1]), m[2], m[3]), "references vertex 999"),
        (lambda m: (m[0], m[1], m[2], np.where(np.arange(m[3].size) == 1, 2, m[3])), "has 2 corners"),
        (lambda m: (m[0], m[1], m[2] + 1, m[3]), "poly_starts[0]"),
        (lambda m: (np.where(np.arange(m[0].size).reshape(-1, 3) == 4, np.nan, m[0]), m[1], m[2], m[3]), "NaN"),
        (lambda m: (m[0][:, :2], m[1], m[2], m[3]), "positions must have shape (n, 3)"),
        (lambda m: (m[0], m[1].astype(np.float32), m[2], m[3]), "corner_verts must hold integers"),
        (lambda m: (m[0], m[1].astype(np.int64) + 2**40, m[2], m[3]), "does not fit in int32"),
        (lambda m: (m[0], m[1], m[2], m[3][:-1]), "poly_sizes must have shape"),
    ],
)
def test_malformed_meshes_raise_value_error(pre, mutate, message):
    mesh = mutate(polygon_grid(3, 0.1))
    with pytest.raises(ValueError, match=None) as err:
        ts.synthesize_jumpmap(pre, *mesh, scale=30.0)
    assert message in str(err.value)
    with pytest.raises(ValueError):
        ts.mesh_info(*mesh)


def test_bad_keywords_raise_value_error(pre):
    mesh = polygon_grid(3, 0.1)
    cases = [
        (dict(scale=0.0), "scale"),
        (dict(scale=30.0, jump_rate=0.0), "jump_rate"),
        (dict(scale=30.0, jump_rate=float("inf")), "jump_rate"),
        (dict(scale=float("nan")), "scale"),
        (dict(scale=30.0, axis=(0.0, 0.0)), "axis"),
        (dict(scale=30.0, orientation="spiral"), "orientation"),
        (dict(scale=30.0, orientation="field"), "direction"),
        (dict(scale=30.0, orientation="anchors"), "anchors"),
        (dict(scale=30.0, orientation="anchors", anchor_vertices=[1], anchor_directions=[[0, 0, 1]]), "parallel"),
        (dict(scale=30.0, orientation="anchors", anchor_vertices=[100], anchor_directions=[[1, 0, 0]]), "100"),
        (dict(scale=30.0, scale_multiplier=np.zeros(16, np.float32)), "scale_multiplier"),
        (dict(scale=30.0, scale_multiplier=np.ones(3, np.float32)), "scale_multiplier must have shape"),
        (dict(scale=30.0, normals=np.ones((2, 3), np.float32)), "normals must have shape"),
    ]
    for kwargs, message in cases:
        with pytest.raises(ValueError) as err:
            ts.synthesize_jumpmap(pre, *mesh, **kwargs)
        assert message in str(err.value), (kwargs, str(err.value))


def test_oversized_faces_are_reported_with_counts(pre):
    mesh = polygon_grid(2, 1.0, triangles=False)  # 4 unit quads
    with pytest.raises(ValueError) as err:
        ts.synthesize_jumpmap(pre, *mesh, scale=100.0)  # 100 texels per quad, sample is 64
    assert "4 of 4 faces are larger than the 64x64 sample" in str(err.value)
    out = ts.synthesize_jumpmap(pre, *mesh, scale=100.0, allow_oversized=True)
    assert out["stats"]["oversized_faces"] == 4
    assert out["stats"]["max_oversize_ratio"] == pytest.approx(100.0 / 64.0, rel=1e-5)
    assert ((out["blend_uv"] >= 0) & (out["blend_uv"] <= 1)).all()


def test_degenerate_meshes_give_valid_results(pre):
    pos = [[0, 0, 0], [1, 0, 0], [2, 0, 0], [0, 0, 0], [0, 1, 0], [7, 7, 7]]
    polys = [[0, 1, 2], [0, 0, 0], [3, 1, 4]]
    for i in range(20):
        pos.append([5 + math.cos(i * 0.314), math.sin(i * 0.314), 0.0])
    polys.append(list(range(6, 26)))
    mesh = pack(np.array(pos, np.float32), polys)
    out = ts.synthesize_jumpmap(pre, *mesh, scale=10.0)
    assert out["num_blend_sets"] == 4
    assert np.isfinite(out["blend_uv"]).all() and ((out["blend_uv"] >= 0) & (out["blend_uv"] <= 1)).all()
    assert (out["blend_weights"].sum(1) == 1).all()
    empty = ts.synthesize_jumpmap(pre, np.zeros((0, 3), np.float32), np.zeros(0, np.int32), np.zeros(0, np.int32),
                                  np.zeros(0, np.int32), scale=10.0)
    assert empty["base_uv"].shape == (0, 2) and empty["stats"]["faces"] == 0


def test_compute_field_modes(pre):
    pos, corner_verts, starts, sizes = polygon_grid(10, 0.1, jitter=0.3)
    up = ts.compute_field(pos, corner_verts, starts, sizes, orientation="axis", axis=(1.0, 1.0, 5.0))
    assert up.shape == (pos.shape[0], 3) and up.dtype == np.float32
    np.testing.assert_allclose(up, np.tile([math.sqrt(0.5), math.sqrt(0.5), 0.0], (pos.shape[0], 1)), atol=1e-6)
    centre = 5 * 11 + 5
    away = ts.compute_field(pos, corner_verts, starts, sizes, orientation="anchors", sources=[centre])
    radial = pos - pos[centre]
    far = np.linalg.norm(radial, axis=1) > 0.25
    radial = radial[far] / np.linalg.norm(radial[far], axis=1, keepdims=True)
    assert ((away[far] * radial).sum(1) > 0.9).all()
    painted = np.zeros_like(pos)
    painted[::2] = [0.0, -3.0, 0.0]
    filled = ts.compute_field(pos, corner_verts, starts, sizes, orientation="field", direction=painted)
    np.testing.assert_allclose(filled, np.tile([0.0, -1.0, 0.0], (pos.shape[0], 1)), atol=1e-6)


@pytest.mark.parametrize("triangles", [True, False])
def test_packed_set_pairs_hold_the_same_sets_as_blend_uv(pre, triangles):
    """pack_sets=True: the sets come as (u0, v0, u1, v1), (u2, v2, u3, v3) per corner (the add-on's
    RGBA attributes), bit-identical to blend_uv; an odd number of sets leaves zeros."""
    mesh = polygon_grid(6, 0.3, triangles=triangles, jitter=0.3)
    plain = ts.synthesize_jumpmap(pre, *mesh, scale=20.0, seed=4)
    packed = ts.synthesize_jumpmap(pre, *mesh, scale=20.0, seed=4, pack_sets=True)
    assert "blend_uv" not in packed and "blend_set_pairs" in plain.keys() | packed.keys()
    sets, corners = plain["num_blend_sets"], len(mesh[1])
    pairs = packed["blend_set_pairs"]
    assert pairs.shape == ((sets + 1) // 2, corners, 4) and pairs.dtype == np.float32
    for k in range(4):
        expected = plain["blend_uv"][k] if k < sets else np.zeros((corners, 2), np.float32)
        np.testing.assert_array_equal(pairs[k // 2][:, (k % 2) * 2:(k % 2) * 2 + 2], expected)
    np.testing.assert_array_equal(packed["base_uv"], plain["base_uv"])
    np.testing.assert_array_equal(packed["blend_weights"], plain["blend_weights"])


@pytest.mark.parametrize("triangles", [True, False])
@pytest.mark.parametrize("pack_sets", [True, False])
@pytest.mark.parametrize("blend", [True, False])
def test_baseline_passes_give_identical_outputs_on_a_shuffled_mesh(pre, triangles, pack_sets, blend):
    """baseline_passes=True (the previous pass structure, kept for benchmarks) and the default give
    the same bytes, with vertex numbering and polygon order unrelated to the surface; phase
    seconds are reported."""
    pos, corner_verts, starts, sizes = polygon_grid(30, 0.05, triangles=triangles, jitter=0.4)
    rng = np.random.default_rng(5)
    new_index = rng.permutation(len(pos)).astype(np.int32)
    shuffled_pos = np.empty_like(pos)
    shuffled_pos[new_index] = pos
    polys = [new_index[corner_verts[s:s + n]] for s, n in zip(starts, sizes)]
    mesh = pack(shuffled_pos, [polys[i].tolist() for i in rng.permutation(len(polys))])
    kwargs = dict(scale=40.0, seed=3, pack_sets=pack_sets, blend=blend)
    new = ts.synthesize_jumpmap(pre, *mesh, **kwargs)
    old = ts.synthesize_jumpmap(pre, *mesh, baseline_passes=True, **kwargs)
    sets_key = "blend_set_pairs" if pack_sets else "blend_uv"
    for key in ("base_uv", sets_key, "blend_weights"):
        assert new[key].tobytes() == old[key].tobytes(), key
    for key in ("jumps", "fallback_vertices", "fallback_faces", "oversized_faces"):
        assert new["stats"][key] == old["stats"][key], key
    for key in ("seconds_mesh", "seconds_faces", "seconds_walk", "seconds_corners"):
        assert 0.0 <= new["stats"][key] <= new["stats"]["seconds"] + new["stats"]["seconds_mesh"], key

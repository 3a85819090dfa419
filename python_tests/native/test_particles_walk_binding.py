# SPDX-License-Identifier: GPL-3.0-or-later
"""texsynth_native.surface_walk_mesh / walk_normal_sections / pseudo_geodesic_distances: shapes checked
at the boundary, a plane round trip (walk out, measure back), walls and thin-sheet sides."""
import math

import numpy as np
import pytest

from mesh_arrays import jittered_plane, locate

tn = pytest.importorskip("texsynth_native")


def test_plane_round_trip_walk_then_distance_back():
    pos, tris = jittered_plane()  # 30 x 30 cells of 0.1, jittered
    mesh = tn.surface_walk_mesh(pos, tris)
    assert mesh.num_triangles == len(tris) and mesh.num_vertices == len(pos)
    angles = np.linspace(0.1, 2 * math.pi, 7, endpoint=False)
    starts = [locate(pos, tris, (1.52, 1.47)) for _ in angles]
    t = np.array([s[0] for s in starts], np.int32)
    b = np.array([s[1] for s in starts])
    d = np.stack([np.cos(angles), np.sin(angles), np.zeros_like(angles)], axis=1)
    lengths = np.full(len(angles), 0.9)
    out = tn.walk_normal_sections(mesh, t, b, d, lengths)
    assert out["positions"].shape == (7, 3) and out["barycentrics"].shape == (7, 2)
    assert [tn.walk_statuses[s] for s in out["status"]] == ["reached"] * 7
    np.testing.assert_allclose(out["length"], 0.9)
    x0 = (pos[tris[t]].astype(np.float64) * np.stack([1 - b[:, 0] - b[:, 1], b[:, 0], b[:, 1]], 1)[..., None]).sum(1)
    np.testing.assert_allclose(out["positions"], x0 + 0.9 * d, atol=1e-6)
    np.testing.assert_allclose(out["directions"], d, atol=1e-6)
    back = tn.pseudo_geodesic_distances(mesh, t, b, out["triangle"], out["barycentrics"])
    np.testing.assert_allclose(back["distance"], 0.9, rtol=1e-6)
    assert set(tn.distance_kinds[k] for k in back["kind"]) <= {"section", "reverse_section"}


def test_walk_off_the_edge_stops_at_the_wall():
    pos, tris = jittered_plane(jitter=0.0)
    mesh = tn.surface_walk_mesh(pos, tris)
    t, b = locate(pos, tris, (1.52, 1.47))
    out = tn.walk_normal_sections(mesh, [t], [b], [[1.0, 0, 0]], [10.0])
    assert tn.walk_statuses[out["status"][0]] == "wall"
    assert np.all(np.isfinite(out["positions"]))
    assert out["positions"][0, 0] == pytest.approx(3.0, abs=1e-6)


def test_two_sided_sheet_never_conflicts():
    pos, tris = jittered_plane(n=8, jitter=0.0)
    both = np.concatenate([tris, tris[:, ::-1]])
    mesh = tn.surface_walk_mesh(pos, both)
    k = 10
    out = tn.pseudo_geodesic_distances(mesh, [k], [[0.3, 0.3]], [k + len(tris)], [[0.3, 0.4]])
    assert out["distance"][0] == math.inf and tn.distance_kinds[out["kind"][0]] == "opposite_normals"


def test_shapes_and_values_are_checked():
    pos, tris = jittered_plane(n=4)
    mesh = tn.surface_walk_mesh(pos, tris)
    with pytest.raises(ValueError, match="positions must have shape"):
        tn.surface_walk_mesh(pos[:, :2], tris)
    with pytest.raises(ValueError, match="triangles must have shape"):
        tn.surface_walk_mesh(pos, tris.ravel())
    bad = pos.copy()
    bad[3, 1] = np.nan
    with pytest.raises(ValueError, match="vertex 3 is NaN"):
        tn.surface_walk_mesh(bad, tris)
    ok = dict(triangles=[1], barycentrics=[[0.2, 0.2]], directions=[[1.0, 0, 0]], lengths=[0.1])
    tn.walk_normal_sections(mesh, **ok)
    with pytest.raises(ValueError, match="barycentrics must have shape"):
        tn.walk_normal_sections(mesh, **{**ok, "barycentrics": [0.2, 0.2]})
    with pytest.raises(ValueError, match="directions must have shape"):
        tn.walk_normal_sections(mesh, **{**ok, "directions": [[1.0, 0, 0], [0, 1.0, 0]]})
    with pytest.raises(ValueError, match="lengths must have shape"):
        tn.walk_normal_sections(mesh, **{**ok, "lengths": 0.1})
    with pytest.raises(ValueError, match="in triangle 99"):
        tn.walk_normal_sections(mesh, **{**ok, "triangles": [99]})
    with pytest.raises(ValueError, match="length of walk 0"):
        tn.walk_normal_sections(mesh, **{**ok, "lengths": [float("nan")]})
    with pytest.raises(ValueError, match="barycentrics2 must have shape"):
        tn.pseudo_geodesic_distances(mesh, [1], [[0.2, 0.2]], [2], [[0.2, 0.2], [0.1, 0.1]])
    with pytest.raises(ValueError, match="triangles2 must have shape"):
        tn.pseudo_geodesic_distances(mesh, [1], [[0.2, 0.2]], [2, 3], [[0.2, 0.2]])
    with pytest.raises(ValueError, match="cancel must be"):
        tn.walk_normal_sections(mesh, **ok, cancel=3)
    token = tn.CancelToken()
    token.cancel()
    with pytest.raises(tn.Cancelled):
        tn.walk_normal_sections(mesh, **ok, cancel=token)

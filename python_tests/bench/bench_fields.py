# SPDX-License-Identifier: GPL-3.0-or-later
"""Field authoring speed (not a test). Prints figures:
  1. a comb stroke on a ~1M-face mesh: BVH build (once per mesh), hit testing per dab (Embree ray
     cast + radius query) against a brute-force numpy ray/triangle test of the same ray (baseline,
     same run), and the relaxation after the stroke;
  2. re-synthesis after a field edit on a ~100k-face mesh with the sample in memory
     (native compute_field + synthesize_jumpmap), the "live update" goal being <= 100 ms.

  /usr/bin/python3.11 python_tests/bench/bench_fields.py [--faces-stroke 1000000] [--faces-synth 100000]
"""
import argparse
import os
import statistics
import sys
import tempfile
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "python_tests"))
sys.path.insert(0, os.path.join(ROOT, "addon"))
import addon_package  # noqa: E402
import texsynth_native as ts  # noqa: E402

authoring = addon_package.load("fields.authoring")
core_layers = addon_package.load("core.layers")
native = addon_package.load("native")
native._module, native._reason, native._tried = ts, None, True


def bumpy_torus(faces):
    """Closed all-quad torus with bumps, segments = 2 rings, segments * rings ~ faces."""
    rings = int(round((faces / 2) ** 0.5))
    segments = 2 * rings
    u = np.linspace(0, 2 * np.pi, segments, endpoint=False)[:, None]
    v = np.linspace(0, 2 * np.pi, rings, endpoint=False)[None, :]
    tube = 0.35 + 0.03 * np.sin(7 * u) * np.sin(5 * v)
    positions = np.stack([(1 + tube * np.cos(v)) * np.cos(u), (1 + tube * np.cos(v)) * np.sin(u),
                          tube * np.sin(v) + 0 * u], axis=-1).reshape(-1, 3).astype(np.float32)
    i, j = np.meshgrid(np.arange(segments), np.arange(rings), indexing="ij")
    i1, j1 = (i + 1) % segments, (j + 1) % rings
    quads = np.stack([i * rings + j, i1 * rings + j, i1 * rings + j1, i * rings + j1], axis=-1).reshape(-1)
    n = segments * rings
    return core_layers.MeshArrays(positions, quads.astype(np.int32), np.arange(0, 4 * n, 4, dtype=np.int32),
                               np.full(n, 4, np.int32))


def brute_force_hit(arrays, origin, direction):
    """Baseline: nearest hit over every fan triangle, vectorised numpy (float32)."""
    cv = arrays.corner_verts.reshape(-1, 4)
    p = arrays.positions
    t_best = np.inf
    for a, b, c in ((0, 1, 2), (0, 2, 3)):
        v0, e1, e2 = p[cv[:, a]], p[cv[:, b]] - p[cv[:, a]], p[cv[:, c]] - p[cv[:, a]]
        h = np.cross(direction, e2)
        det = np.einsum("ij,ij->i", e1, h)
        inv = 1.0 / np.where(np.abs(det) > 1e-12, det, np.inf)
        s = origin - v0
        u = np.einsum("ij,ij->i", s, h) * inv
        q = np.cross(s, e1)
        w = (q @ direction) * inv
        t = np.einsum("ij,ij->i", e2, q) * inv
        ok = (u >= 0) & (w >= 0) & (u + w <= 1) & (t > 0)
        if ok.any():
            t_best = min(t_best, float(t[ok].min()))
    return t_best


def bench_stroke(faces, dabs):
    arrays = bumpy_torus(faces)
    print("stroke mesh: %d faces, %d vertices" % (arrays.num_faces, arrays.num_vertices))
    start = time.perf_counter()
    caster = authoring.ray_caster(arrays)
    build = time.perf_counter() - start
    n = arrays.num_vertices
    state = authoring.FieldState(arrays, np.zeros((n, 3), np.float32), np.zeros(n, np.int32), np.zeros((n, 3), np.float32))
    start = time.perf_counter()
    state.field_mesh = authoring.field_mesh(arrays)
    state.vertex_normals()
    field_mesh_time = time.perf_counter() - start
    state.direction = authoring.tangent_unit(np.tile([0.0, 0.0, 1.0], (n, 1)), state.normals)
    brush = authoring.CombBrush(state, caster, radius=0.05)
    # A stroke across the top of the torus, rays straight down.
    angles = np.linspace(0.0, 1.0, dabs)
    per_dab = []
    for a in angles:
        origin = np.array([1.0 * np.cos(a), 1.0 * np.sin(a), 2.0])
        t0 = time.perf_counter()
        brush.dab(origin, (0.0, 0.0, -1.0))
        per_dab.append(time.perf_counter() - t0)
    hit_total = brush.seconds["hit_testing"]
    start = time.perf_counter()
    brush.end_stroke()
    relax = time.perf_counter() - start
    one_shot = authoring.FieldState(arrays, state.guide, state.singularity, state.direction)  # no FieldMesh
    start = time.perf_counter()
    authoring.relax(one_shot)
    relax_one_shot = time.perf_counter() - start
    origin = np.array([1.0, 0.0, 2.0], np.float32)
    t0 = time.perf_counter()
    brute = brute_force_hit(arrays, origin, np.array([0.0, 0.0, -1.0], np.float32))
    brute_time = time.perf_counter() - t0
    embree = caster.cast(origin[None], np.array([[0.0, 0.0, -1.0]], np.float32))
    assert abs(float(embree["distance"][0]) - brute) < 1e-4, (embree["distance"], brute)
    print("  BVH build (once per mesh):            %8.1f ms" % (1000 * build))
    print("  FieldMesh + normals (once per mesh):  %8.1f ms" % (1000 * field_mesh_time))
    print("  %d dabs: hit testing total            %8.1f ms (%.3f ms per dab: ray cast + radius query)"
          % (dabs, 1000 * hit_total, 1000 * hit_total / dabs))
    print("  %d dabs: whole dab incl. paint        %8.1f ms median per dab" % (dabs, 1000 * statistics.median(per_dab)))
    print("  baseline: one ray, brute force numpy  %8.1f ms (%.0fx the Embree per-dab hit test)"
          % (1000 * brute_time, brute_time / max(hit_total / dabs, 1e-9)))
    print("  relaxation after the stroke           %8.1f ms (FieldMesh.compute_field, %d anchors)"
          % (1000 * relax, int(np.any(state.guide != 0, axis=1).sum())))
    print("  baseline: one-shot compute_field      %8.1f ms (rebuilds the mesh adjacency)" % (1000 * relax_one_shot))


def bench_resynthesis(faces, repeat):
    arrays = bumpy_torus(faces)
    print("re-synthesis mesh: %d faces, %d vertices" % (arrays.num_faces, arrays.num_vertices))
    cache = os.path.join(tempfile.gettempdir(), "texsynth_bench_fields_cache")
    os.makedirs(cache, exist_ok=True)
    pre = ts.preprocess(os.path.join(ROOT, "blend_samples", "bricks.png"), cache_dir=cache)
    n = arrays.num_vertices
    state = authoring.FieldState(arrays, np.zeros((n, 3), np.float32), np.zeros(n, np.int32), np.zeros((n, 3), np.float32))
    state.singularity[0] = authoring.SOURCE
    state.field_mesh = authoring.field_mesh(arrays)
    relax_times, synth_times, native_seconds = [], [], []
    edge = 2 * np.pi * 1.35 / (2 * int(round((faces / 2) ** 0.5)))
    scale = 3.0 / edge  # ~3 texels per edge
    for _ in range(repeat):
        t0 = time.perf_counter()
        authoring.relax(state)
        t1 = time.perf_counter()
        out = ts.synthesize_jumpmap(pre, arrays.positions, arrays.corner_verts, arrays.poly_starts, arrays.poly_sizes,
                                    scale=scale, orientation="field", direction=state.direction, blend=True)
        t2 = time.perf_counter()
        relax_times.append(t1 - t0)
        synth_times.append(t2 - t1)
        native_seconds.append(out["stats"]["seconds"])
    print("  relax (FieldMesh, 1 source)           %8.1f ms median of %d" % (1000 * statistics.median(relax_times), repeat))
    print("  synthesize_jumpmap (field, blend)     %8.1f ms median (native stats.seconds %.1f ms)"
          % (1000 * statistics.median(synth_times), 1000 * statistics.median(native_seconds)))
    print("  live update native part total         %8.1f ms (goal <= 100 ms)"
          % (1000 * (statistics.median(relax_times) + statistics.median(synth_times))))


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--faces-stroke", type=int, default=1_000_000)
    parser.add_argument("--faces-synth", type=int, default=100_000)
    parser.add_argument("--dabs", type=int, default=50)
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    import multiprocessing
    print("cores: %d" % multiprocessing.cpu_count())
    bench_stroke(args.faces_stroke, args.dabs)
    bench_resynthesis(args.faces_synth, args.repeat)


if __name__ == "__main__":
    main()

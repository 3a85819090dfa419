# SPDX-License-Identifier: GPL-3.0-or-later
"""Writes bench_addon.py's benchmark mesh as numpy arrays (positions, corner_verts, poly_starts, poly_sizes)
so native benchmarks (bench_texton_speed.py) run on exactly the mesh the add-on benchmark builds. Not a test.

  bash scripts/fetch_bench_mesh.sh   # once
  blender -b --factory-startup --python-exit-code 1 --python python_tests/bench/export_bench_mesh.py \\
      [-- --mesh stanford|torus|suzanne] [--out out/bench/bunny_cc2.npz]
"""
import argparse
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(os.path.dirname(HERE), "blender"))
sys.path.insert(0, HERE)
import numpy as np  # noqa: E402

import bench_addon  # noqa: E402
import harness  # noqa: E402


def main():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    parser = argparse.ArgumentParser()
    parser.add_argument("--mesh", default="stanford", choices=("stanford", "torus", "suzanne"))
    parser.add_argument("--stanford-path", default=os.path.join(harness.ROOT, "out", "bench", "bunny00.off"))
    parser.add_argument("--out", default=os.path.join(harness.ROOT, "out", "bench", "bunny_cc2.npz"))
    args = parser.parse_args(argv)
    mesh = bench_addon.build_mesh(args.mesh, args.stanford_path).data
    positions = np.empty(len(mesh.vertices) * 3, dtype=np.float32)
    mesh.vertices.foreach_get("co", positions)
    corner_verts = np.empty(len(mesh.loops), dtype=np.int32)
    mesh.loops.foreach_get("vertex_index", corner_verts)
    poly_starts = np.empty(len(mesh.polygons), dtype=np.int32)
    mesh.polygons.foreach_get("loop_start", poly_starts)
    poly_sizes = np.empty(len(mesh.polygons), dtype=np.int32)
    mesh.polygons.foreach_get("loop_total", poly_sizes)
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    np.savez(args.out, positions=positions.reshape(-1, 3), corner_verts=corner_verts, poly_starts=poly_starts,
             poly_sizes=poly_sizes)
    print("export_bench_mesh: %s: %d vertices, %d polygons" % (args.out, len(mesh.vertices), len(mesh.polygons)))


main()

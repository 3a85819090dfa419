# SPDX-License-Identifier: GPL-3.0-or-later
"""The UV map TexSynth makes for image targets and bakes (bridge/uv_maps.smart_project), on a scanned mesh:
how much of the image it uses, the texel density, and the most any bounding-box packing could use with
the same islands. Not a test; figures in docs/dev/uv_packing.md.

  bash scripts/fetch_bench_mesh.sh   # once (or the corpus' out/corpus/meshes/bunny.obj)
  blender -b --factory-startup --python-exit-code 1 --python python_tests/bench/bench_uv_packing.py \\
      [-- --mesh out/corpus/meshes/bunny.obj] [--size 1024]

used = the sum of UV triangle areas (UV space is 1 x 1); texels per unit = sqrt(used x size^2 / surface
area). Box ceiling = used / the sum, over islands, of each island's smallest rectangle (any rotation, 2°
steps) grown by the packing gap: what a perfect packer of bounding boxes would reach with these islands.
"""
import argparse
import math
import os
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, os.path.join(os.path.dirname(HERE), "blender"))
import bpy  # noqa: E402
import numpy as np  # noqa: E402

import harness  # noqa: E402

texsynth = harness.load_addon()
texsynth.register()
from texsynth.core import bake_options as options  # noqa: E402
from texsynth.bridge import uv_maps  # noqa: E402


def parse_args():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    parser = argparse.ArgumentParser(prog="bench_uv_packing")
    parser.add_argument("--mesh", default=os.path.join(ROOT, "out", "corpus", "meshes", "bunny.obj"))
    parser.add_argument("--size", type=int, default=1024)
    return parser.parse_args(argv)


def import_mesh(path):
    harness.reset_scene()
    if path.endswith(".obj"):
        if hasattr(bpy.ops.wm, "obj_import"):
            bpy.ops.wm.obj_import(filepath=path)
        else:
            bpy.ops.import_scene.obj(filepath=path)
    else:
        raise SystemExit("bench_uv_packing: only .obj meshes (%s)" % path)
    obj = bpy.context.selected_objects[0]
    while obj.data.uv_layers:
        obj.data.uv_layers.remove(obj.data.uv_layers[0])
    harness.select_only([obj])
    return obj


def loop_arrays(mesh, name):
    count = len(mesh.loops)
    uv = np.empty(count * 2, np.float64)
    mesh.uv_layers[name].data.foreach_get("uv", uv)
    vertex = np.empty(count, np.int64)
    mesh.loops.foreach_get("vertex_index", vertex)
    starts = np.empty(len(mesh.polygons), np.int64)
    totals = np.empty(len(mesh.polygons), np.int64)
    mesh.polygons.foreach_get("loop_start", starts)
    mesh.polygons.foreach_get("loop_total", totals)
    face = np.repeat(np.arange(len(mesh.polygons)), totals)
    following = np.arange(count) + 1
    ends = starts + totals
    following[ends - 1] = starts  # the next loop wraps round each face
    return uv.reshape(-1, 2), vertex, face, following


def islands(mesh, name):
    """Island index per face: faces joined where a shared edge has the same UVs on both sides."""
    uv, vertex, face, following = loop_arrays(mesh, name)
    a, b = vertex, vertex[following]
    key = np.minimum(a, b) * (len(mesh.vertices) + 1) + np.maximum(a, b)
    order = np.argsort(key, kind="stable")
    same = key[order[:-1]] == key[order[1:]]
    first, second = order[:-1][same], order[1:][same]
    # Opposite directions on a manifold edge: first's start is second's end.
    joined = (np.abs(uv[first] - uv[following[second]]).max(1) < 1e-6) & \
             (np.abs(uv[following[first]] - uv[second]).max(1) < 1e-6)
    left, right = face[first[joined]], face[second[joined]]
    label = np.arange(len(mesh.polygons))
    while True:  # smallest face index per island: propagate minima, then jump pointers
        before = label.copy()
        low = np.minimum(label[left], label[right])
        np.minimum.at(label, left, low)
        np.minimum.at(label, right, low)
        label = label[label]
        if np.array_equal(label, before):
            break
    return np.unique(label, return_inverse=True)[1], uv, face


def figures(obj, name, size, gap_texels):
    mesh = obj.data
    mesh.calc_loop_triangles()
    count = len(mesh.loop_triangles)
    loops = np.empty(count * 3, np.int64)
    vertices = np.empty(count * 3, np.int64)
    mesh.loop_triangles.foreach_get("loops", loops)
    mesh.loop_triangles.foreach_get("vertices", vertices)
    co = np.empty(len(mesh.vertices) * 3)
    mesh.vertices.foreach_get("co", co)
    island, uv, face = islands(mesh, name)
    t = uv[loops].reshape(-1, 3, 2)
    p = co.reshape(-1, 3)[vertices].reshape(-1, 3, 3)
    used = 0.5 * np.abs(np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])).sum()
    area = 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1).sum()
    loop_island = island[face]
    angles = np.radians(np.arange(0.0, 90.0, 2.0))
    axis_u = np.stack([np.cos(angles), np.sin(angles)], 1)
    axis_v = np.stack([-np.sin(angles), np.cos(angles)], 1)
    gap = gap_texels / float(size)
    order = np.argsort(loop_island, kind="stable")
    cuts = np.flatnonzero(np.diff(loop_island[order])) + 1
    boxes = 0.0
    sizes = np.bincount(island)
    for group in np.split(order, cuts):
        x, y = uv[group] @ axis_u.T, uv[group] @ axis_v.T
        width, height = x.max(0) - x.min(0), y.max(0) - y.min(0)
        boxes += ((width + gap) * (height + gap)).min()
    return {"faces": len(mesh.polygons), "islands": len(sizes), "one_face": int((sizes == 1).sum()),
            "used": used, "texels_per_unit": math.sqrt(used * size * size / area), "ceiling": used / boxes}


def main():
    args = parse_args()
    if not os.path.isfile(args.mesh):
        raise SystemExit("bench_uv_packing: no mesh at %s (run python_tests/bench/corpus.py or "
                         "scripts/fetch_bench_mesh.sh)" % args.mesh)
    obj = import_mesh(args.mesh)
    start = time.perf_counter()
    name = uv_maps.smart_project(obj, options.BakeRequest(size=args.size, margin=16, create_uv=True), bpy.context)
    seconds = time.perf_counter() - start
    result = figures(obj, name, args.size, options.PACK_GAP_TEXELS)
    print("bench_uv_packing: Blender %s, %s, %d faces, %d² image, islands %d apart"
          % (bpy.app.version_string, os.path.basename(args.mesh), result["faces"], args.size,
             options.PACK_GAP_TEXELS))
    print("  islands %d (%d of one face)  used %.3f  texels/unit %.0f  box-packing ceiling %.3f  %.1f s"
          % (result["islands"], result["one_face"], result["used"], result["texels_per_unit"],
             result["ceiling"], seconds))


main()

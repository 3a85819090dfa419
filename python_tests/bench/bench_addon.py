# SPDX-License-Identifier: GPL-3.0-or-later
"""Speed of the Synthesize operator (read mesh + native synthesis + write all layers) against
Blender's own Smart UV Project on the same ~840k-face mesh, in the same Blender run. Not a test.

  blender -b --factory-startup --python-exit-code 1 --python python_tests/bench/bench_addon.py \\
      [-- --mesh torus|suzanne] [--repeat N]

torus (default): a bumpy closed torus, 1296 x 648 = 839,808 quads.
suzanne: Suzanne with 5 subdivision levels applied, 503,808 quads.
Goal: operator <= 0.1 x Smart UV Project. The sample is preprocessed (cached) before timing.
"""
import argparse
import os
import statistics
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(os.path.dirname(HERE), "blender"))
sys.path.insert(0, HERE)  # bench_native_torus: the shared benchmark mesh
import bpy  # noqa: E402
import numpy as np  # noqa: E402

import bench_native_torus  # noqa: E402
import harness  # noqa: E402


def bumpy_torus():
    """The bumpy quad torus of bench_native_torus (same arrays), built with foreach_set (primitive
    operators are far too slow at this size)."""
    positions, corner_verts, poly_starts, poly_sizes = bench_native_torus.bumpy_torus()
    mesh = bpy.data.meshes.new("Bench")
    mesh.vertices.add(len(positions))
    mesh.vertices.foreach_set("co", positions.ravel())
    mesh.loops.add(len(corner_verts))
    mesh.loops.foreach_set("vertex_index", corner_verts)
    mesh.polygons.add(len(poly_starts))
    mesh.polygons.foreach_set("loop_start", poly_starts)
    mesh.polygons.foreach_set("loop_total", poly_sizes)
    mesh.update(calc_edges=True)
    obj = bpy.data.objects.new("Bench", mesh)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def build_mesh(kind):
    harness.reset_scene()
    if kind == "torus":
        return bumpy_torus()
    obj = harness.add_primitive("monkey", "Bench")
    modifier = obj.modifiers.new("Subdivision", "SUBSURF")
    modifier.levels = 5
    bpy.ops.object.modifier_apply(modifier=modifier.name)
    while len(obj.data.uv_layers):
        obj.data.uv_layers.remove(obj.data.uv_layers[0])
    return obj


def copy_of(obj, name):
    duplicate = obj.copy()
    duplicate.data = obj.data.copy()
    duplicate.name = duplicate.data.name = name
    bpy.context.scene.collection.objects.link(duplicate)
    return duplicate


def smart_uv_project(obj):
    harness.select_only([obj])
    bpy.ops.object.mode_set(mode="EDIT")
    bpy.ops.mesh.select_all(action="SELECT")
    start = time.perf_counter()
    bpy.ops.uv.smart_project(angle_limit=1.15192, island_margin=0.0)
    seconds = time.perf_counter() - start
    bpy.ops.object.mode_set(mode="OBJECT")
    return seconds


def main():
    parser = argparse.ArgumentParser(prog="bench_addon")
    parser.add_argument("--mesh", choices=["torus", "suzanne"], default="torus")
    parser.add_argument("--repeat", type=int, default=1)
    args = parser.parse_args(harness.script_args())
    texsynth = harness.load_addon()
    texsynth.register()
    from texsynth import pipeline, synthesis

    source = build_mesh(args.mesh)
    print("mesh: %s, %d faces, %d vertices, %d corners" % (args.mesh, len(source.data.polygons),
                                                         len(source.data.vertices), len(source.data.loops)))
    cache_dir = tempfile.mkdtemp(prefix="texsynth_bench_")
    props = bpy.context.scene.texsynth
    props.sample_source, props.sample_path = "FILE", os.path.join(harness.SAMPLES_DIR, "bricks.png")
    props.scale, props.seed, props.material_mode = 0.5, 1, "NEW"
    settings = props.to_settings()
    synthesis.preprocess(synthesis.Sample(path=props.sample_path), settings, cache_dir)
    texsynth.properties.cache_dir = lambda context: cache_dir  # the operator uses the warm bench cache

    operator_runs, undo_runs, breakdowns, smart_runs = [], [], [], []
    for run in range(args.repeat):
        target = copy_of(source, "Operator%d" % run)
        harness.select_only([target])
        start = time.perf_counter()
        assert bpy.ops.texsynth.synthesize() == {"FINISHED"}
        operator_runs.append(time.perf_counter() - start)
        # What the operator's UNDO flag costs on top of the job: one more global undo step of the scene.
        start = time.perf_counter()
        bpy.ops.ed.undo_push(message="bench")
        undo_runs.append(time.perf_counter() - start)

        target = copy_of(source, "Breakdown%d" % run)
        report = synthesis.synthesize([target], synthesis.Sample(path=props.sample_path), settings, cache_dir)
        assert not report.failures, report.summary()
        breakdowns.append(report.seconds)

        smart_runs.append(smart_uv_project(copy_of(source, "Smart%d" % run)))

    operator, smart = statistics.median(operator_runs), statistics.median(smart_runs)
    print("Smart UV Project:            %7.3f s" % smart)
    print("TexSynth Synthesize operator: %7.3f s  = %.3f x Smart UV Project (goal <= 0.1)" % (operator, operator / smart))
    last = breakdowns[-1]
    print("  breakdown (direct call): read %.3f s, native %.3f s, write %.3f s, material %.3f s, "
          "preprocess (cache hit) %.3f s, total %.3f s" % (last["read"], last["synthesis"], last["write"],
                                                           last["material"], last["preprocess"], last["total"]))
    print("  undo push after the operator (part of the operator time, Blender's): %.3f s (median)"
          % statistics.median(undo_runs))
    print("  all runs: operator %s, smart %s" % (["%.3f" % t for t in operator_runs], ["%.3f" % t for t in smart_runs]))
    del pipeline


if __name__ == "__main__":
    main()

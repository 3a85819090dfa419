# SPDX-License-Identifier: GPL-3.0-or-later
"""Speed of the Synthesize operator (read mesh + native synthesis + write all layers) against
Blender's own Smart UV Project on the same ~840k-face mesh, in the same Blender run. Not a test.

  bash scripts/fetch_bench_mesh.sh   # once: the Stanford bunny from Debian's libcgal-demo package
  blender -b --factory-startup --python-exit-code 1 --python python_tests/bench/bench_addon.py \\
      [-- --mesh stanford|torus|suzanne] [--repeat N] [--material NEW|NONE]

stanford (default): the scanned Stanford bunny (out/bench/bunny00.off, 75,408 triangles) with 2
  Catmull-Clark levels applied: 904,896 quads (the issue's "subdivided bunny", 836k quads there).
torus: a bumpy closed torus, 1296 x 648 = 839,808 quads (python_tests/bench/bench_native_torus.py).
suzanne: Suzanne with 5 subdivision levels applied, 503,808 quads.

Each repeat times, on fresh copies of the mesh: the operator (bpy.ops call, as a script or the redo
panel runs it; bpy.ops ends with a view-layer update, i.e. Blender's depsgraph evaluation of the new
layers), the Blender-only floor (the same reads, layer creation, foreach_set and view-layer update
with no synthesis: what any implementation writing these layers pays), and Smart UV Project.
Goal: operator <= 0.1 x Smart UV Project. The sample is preprocessed (cached) before timing.
Each repeat also runs the operator with TEXSYNTH_WRITE_CHECK=before (the results' NaN/inf scan
before the layer writes, as before; now it runs in a worker thread during them), alternating the
order, and prints the operator's own read + write phases against the floor's.
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


def bumpy_torus(segments=1296, rings=648):
    """The bumpy quad torus of bench_native_torus (same arrays) as a Blender object."""
    return harness.mesh_from_arrays("Bench", *bench_native_torus.bumpy_torus(segments, rings))


def read_off(path):
    """(positions float32 (V, 3), triangles int32 (F, 3)) of a triangle-only OFF file."""
    with open(path) as handle:
        if handle.readline().strip() != "OFF":
            raise SystemExit("bench_addon: %s is not an OFF file" % path)
        num_vertices, num_faces, _ = (int(value) for value in handle.readline().split())
        values = np.array(handle.read().split(), dtype=np.float64)
    positions = values[:num_vertices * 3].reshape(num_vertices, 3).astype(np.float32)
    faces = values[num_vertices * 3:].reshape(num_faces, 4).astype(np.int32)
    if not (faces[:, 0] == 3).all():
        raise SystemExit("bench_addon: %s has non-triangle faces" % path)
    return positions, faces[:, 1:]


def subdivide(obj, levels):
    harness.select_only([obj])
    modifier = obj.modifiers.new("Subdivision", "SUBSURF")
    modifier.levels = levels
    bpy.ops.object.modifier_apply(modifier=modifier.name)
    while len(obj.data.uv_layers):
        obj.data.uv_layers.remove(obj.data.uv_layers[0])
    return obj


def build_mesh(kind, stanford_path):
    harness.reset_scene()
    if kind == "torus":
        return bumpy_torus()
    if kind == "stanford":
        if not os.path.isfile(stanford_path):
            raise SystemExit("bench_addon: %s is missing; run scripts/fetch_bench_mesh.sh first" % stanford_path)
        positions, triangles = read_off(stanford_path)
        count = len(triangles)
        obj = harness.mesh_from_arrays("Bench", positions, triangles.ravel(), np.arange(count, dtype=np.int32) * 3,
                                       np.full(count, 3, dtype=np.int32))
        return subdivide(obj, 2)
    return subdivide(harness.add_primitive("monkey", "Bench"), 5)


def copy_of(obj, name):
    """A fresh copy, already evaluated: bpy.ops runs a view-layer update before every operator, and
    evaluating a just-linked copy must not be charged to the operator timed next."""
    duplicate = obj.copy()
    duplicate.data = obj.data.copy()
    duplicate.name = duplicate.data.name = name
    bpy.context.scene.collection.objects.link(duplicate)
    bpy.context.view_layer.update()
    return duplicate


def discard(obj):
    mesh = obj.data
    bpy.data.objects.remove(obj)
    bpy.data.meshes.remove(mesh)


def smart_uv_project(obj):
    harness.select_only([obj])
    bpy.ops.object.mode_set(mode="EDIT")
    bpy.ops.mesh.select_all(action="SELECT")
    start = time.perf_counter()
    bpy.ops.uv.smart_project(angle_limit=1.15192, island_margin=0.0)
    seconds = time.perf_counter() - start
    bpy.ops.object.mode_set(mode="OBJECT")
    return seconds


def blender_floor(obj, num_uv_layers, num_colours=3):
    """Seconds of the Blender-only part of a Synthesize: the same bulk reads, num_uv_layers UV maps
    and num_colours float corner colours (0.2: 1 UV map + blend sets 01, 23 + weights; 0.1 wrote
    5 UV maps + weights) filled with foreach_set from ready float32 arrays (allocated before timing),
    and the view-layer update bpy.ops runs after the operator. No synthesis, no checks. With 1 UV
    map and no colours it is what Smart UV Project itself writes."""
    mesh = obj.data
    num_vertices, num_corners, num_polys = len(mesh.vertices), len(mesh.loops), len(mesh.polygons)
    uv = np.random.default_rng(0).random(num_corners * 2, dtype=np.float32)
    colours = np.random.default_rng(1).random(num_corners * 4, dtype=np.float32)
    times = {}
    start = time.perf_counter()
    mesh.vertices.foreach_get("co", np.empty(num_vertices * 3, dtype=np.float32))
    for collection, name, count in ((mesh.loops, "vertex_index", num_corners),
                                    (mesh.polygons, "loop_start", num_polys),
                                    (mesh.polygons, "loop_total", num_polys)):
        collection.foreach_get(name, np.empty(count, dtype=np.uint32))
    times["read"] = time.perf_counter() - start
    start = time.perf_counter()
    for index in range(num_uv_layers):
        mesh.uv_layers.new(name="Floor%d" % index, do_init=False).data.foreach_set("uv", uv)
    for index in range(num_colours):
        mesh.attributes.new("FloorColour%d" % index, "FLOAT_COLOR", "CORNER").data.foreach_set("color", colours)
    mesh.update()
    times["write"] = time.perf_counter() - start
    start = time.perf_counter()
    bpy.context.view_layer.update()
    times["view_layer_update"] = time.perf_counter() - start
    times["total"] = sum(times.values())
    return times


def main():
    parser = argparse.ArgumentParser(prog="bench_addon")
    parser.add_argument("--mesh", choices=["stanford", "torus", "suzanne"], default="stanford")
    parser.add_argument("--stanford-path", default=os.path.join(harness.ROOT, "out", "bench", "bunny00.off"))
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--material", choices=["NEW", "NONE"], default="NEW",
                        help="the operator's material mode (NONE: layers only, no material assignment)")
    args = parser.parse_args(harness.script_args())
    texsynth = harness.load_addon()
    texsynth.register()
    from texsynth.uv_methods import synthesis
    from texsynth.bridge import sources

    source = build_mesh(args.mesh, args.stanford_path)
    print("mesh: %s, %d faces, %d vertices, %d corners" % (args.mesh, len(source.data.polygons),
                                                         len(source.data.vertices), len(source.data.loops)))
    size = max(source.dimensions)
    # Out of the scene: a material's first assignment rebuilds the depsgraph relations and Blender
    # then re-evaluates every object in the view layer; the timed copy should be the only big one.
    bpy.context.scene.collection.objects.unlink(source)
    cache_dir = tempfile.mkdtemp(prefix="texsynth_bench_")
    props = bpy.context.scene.texsynth
    props.sample_source, props.sample_path = "FILE", os.path.join(harness.SAMPLES_DIR, "bricks.png")
    props.scale, props.seed, props.material_mode = size / 4.0, 1, args.material  # the sample spans a quarter of the mesh
    settings = props.to_settings()
    synthesis.preprocess(sources.Sample(path=props.sample_path), settings, cache_dir)
    texsynth.ui.properties.cache_dir = lambda context: cache_dir  # the operator uses the warm bench cache

    # The operator's own breakdown (core.reporting.Timings of its Job), captured as the job finishes.
    breakdowns, layer_counts = [], []
    apply = synthesis.Job.apply

    def recording_apply(job, *args, **kwargs):
        report = apply(job, *args, **kwargs)
        breakdowns.append(dict(report.seconds))
        return report

    synthesis.Job.apply = recording_apply
    operator_runs, undo_runs, floor_runs, minimal_floor_runs, smart_runs, old_floor_runs = [], [], [], [], [], []
    scan_first = {"operator": [], "breakdown": []}  # the previous write order (NaN/inf scan, then writes)
    from texsynth.bridge import mesh_io
    for run in range(args.repeat):
        for mode in (("before", "") if run % 2 else ("", "before")):
            if mode:
                os.environ[mesh_io.WRITE_CHECK_ENV] = mode
            target = copy_of(source, "Operator%d%s" % (run, mode))
            harness.select_only([target])
            start = time.perf_counter()
            assert bpy.ops.texsynth.synthesize() == {"FINISHED"}
            seconds = time.perf_counter() - start
            os.environ.pop(mesh_io.WRITE_CHECK_ENV, None)
            if mode:
                scan_first["operator"].append(seconds)
                scan_first["breakdown"].append(breakdowns.pop())
                discard(target)
            else:
                kept, kept_seconds = target, seconds
        target = kept
        operator_runs.append(kept_seconds)
        layer_counts.append(len(target.data.uv_layers))
        # A global undo step of the scene: in the UI it follows every undoable operator (Smart UV's too);
        # not part of the operator time measured here.
        start = time.perf_counter()
        bpy.ops.ed.undo_push(message="bench")
        undo_runs.append(time.perf_counter() - start)
        discard(target)

        target = copy_of(source, "Floor%d" % run)
        floor_runs.append(blender_floor(target, layer_counts[-1]))
        discard(target)
        target = copy_of(source, "OldFloor%d" % run)
        old_floor_runs.append(blender_floor(target, 5, 1))  # TexSynth 0.1's layers
        discard(target)
        target = copy_of(source, "MinimalFloor%d" % run)
        minimal_floor_runs.append(blender_floor(target, 1, 0)["total"])
        discard(target)

        target = copy_of(source, "Smart%d" % run)
        smart_runs.append(smart_uv_project(target))
        discard(target)

    operator, smart = statistics.median(operator_runs), statistics.median(smart_runs)
    floor = statistics.median(times["total"] for times in floor_runs)
    print("Smart UV Project:             %7.3f s" % smart)
    print("TexSynth Synthesize operator: %7.3f s  = %.3f x Smart UV Project (goal <= 0.1)" % (operator, operator / smart))
    print("Blender-only floor:           %7.3f s  = %.3f x Smart UV Project (%d UV map + 3 corner colours, no synthesis)"
          % (floor, floor / smart, layer_counts[-1]))
    old_floor = statistics.median(times["total"] for times in old_floor_runs)
    write, old_write = (statistics.median(times["write"] for times in runs) for runs in (floor_runs, old_floor_runs))
    print("0.1's layers (5 UV maps + weights) floor: %7.3f s; layer writes %.3f s now vs %.3f s then (%.2fx)"
          % (old_floor, write, old_write, write / old_write))
    minimal_floor = statistics.median(minimal_floor_runs)
    print("Minimal floor:                %7.3f s  = %.3f x Smart UV Project (1 UV map, no weights, no synthesis)"
          % (minimal_floor, minimal_floor / smart))
    for run, (seconds, times, floor_times) in enumerate(zip(operator_runs, breakdowns, floor_runs)):
        print("  run %d: operator %.3f s = job %.3f s (read %.3f, native %.3f, write %.3f, material %.3f, "
              "preprocess cache hit %.3f) + view-layer update and bpy.ops %.3f s" % (
                  run, seconds, times["total"], times["read"], times["synthesis"], times["write"],
                  times["material"], times["preprocess"], seconds - times["total"]))
        print("         floor %.3f s (read %.3f, write %.3f, view-layer update %.3f); Smart UV %.3f s" % (
            floor_times["total"], floor_times["read"], floor_times["write"], floor_times["view_layer_update"],
            smart_runs[run]))
    print("  global undo push after the operator (Blender's, not in the operator time): %.3f s (median)"
          % statistics.median(undo_runs))

    def median(runs, key):
        return statistics.median(times[key] for times in runs)
    floor_io = median(floor_runs, "read") + median(floor_runs, "write")
    print("Operator's own bpy work (read + write phases) vs the floor's read + write (%.3f s), medians:" % floor_io)
    for label, runs in (("scan during the write (now)", breakdowns),
                        ("scan before the write (TEXSYNTH_WRITE_CHECK=before)", scan_first["breakdown"])):
        own = median(runs, "read") + median(runs, "write")
        print("  %-52s read %.3f + write %.3f = %.3f s = %.2f x floor; with native %.3f s = %.2f x floor total"
              % (label, median(runs, "read"), median(runs, "write"), own, own / floor_io,
                 own + median(runs, "synthesis"), (own + median(runs, "synthesis")) / floor))


if __name__ == "__main__":
    main()

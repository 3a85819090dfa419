# SPDX-License-Identifier: GPL-3.0-or-later
"""Round neighbourhoods end to end in Blender on the scanned Stanford bunny (75,408 triangles, issue 13's
"~70k-face scanned mesh"): Smart UV Project, then Synthesize into a 1024² image (about 700k surface samples)
through the add-on's surface_colour Job, then a re-synthesis with a new field (neighbourhoods reused).
Prints seconds per stage, surface samples, peak RSS and the paper's anchors; renders the result. Not a test.

  bash scripts/fetch_bench_mesh.sh   # once
  blender -b --factory-startup --python-exit-code 1 --python python_tests/bench/bench_round_bunny.py \\
      [-- --size 1024] [--sample blend_samples/bricks.png] [--render out/round_bunny.png]
"""
import argparse
import os
import resource
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(os.path.dirname(HERE), "blender"))
sys.path.insert(0, HERE)
import bpy  # noqa: E402
import numpy as np  # noqa: E402

import bench_addon  # noqa: E402
import harness  # noqa: E402

texsynth = harness.load_addon()
texsynth.register()
from texsynth.core import bake_options as options  # noqa: E402
from texsynth.core import settings as core_settings  # noqa: E402
from texsynth.surface_colour import synthesis as surface  # noqa: E402
from texsynth.bridge import sources  # noqa: E402


def peak_mb():
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def render(obj, path, size=512):
    scene = bpy.context.scene
    from mathutils import Vector
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    scene.collection.objects.link(camera)
    corners = [obj.matrix_world @ Vector(c) for c in obj.bound_box]
    centre = sum(corners, Vector()) / 8
    radius = max((c - centre).length for c in corners)
    direction = Vector((0.2, -1.0, 0.35)).normalized()
    camera.location = centre + direction * radius * 3.2
    camera.rotation_euler = (-direction).to_track_quat("-Z", "Y").to_euler()
    scene.camera = camera
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.rotation_euler = (0.6, 0.1, 0.5)
    scene.collection.objects.link(sun)
    scene.world = bpy.data.worlds.new("World")
    scene.world.color = (0.35, 0.35, 0.38)
    texsynth.compat.use_eevee(scene)
    scene.eevee.taa_render_samples = 16
    scene.render.resolution_x = scene.render.resolution_y = size
    scene.render.filepath = os.path.abspath(path)
    if path.lower().endswith((".jpg", ".jpeg")):
        scene.render.image_settings.file_format = "JPEG"
        scene.render.image_settings.quality = 85
    bpy.ops.render.render(write_still=True)


def main():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    parser = argparse.ArgumentParser()
    parser.add_argument("--size", type=int, default=1024)
    parser.add_argument("--sample", default=os.path.join(harness.SAMPLES_DIR, "bricks.png"))
    parser.add_argument("--mesh", default=os.path.join(harness.ROOT, "out", "bench", "bunny00.off"))
    parser.add_argument("--render", default="")
    args = parser.parse_args(argv)
    if not os.path.isfile(args.mesh):
        raise SystemExit("bench_round_bunny: %s is missing; run scripts/fetch_bench_mesh.sh" % args.mesh)
    harness.reset_scene()
    positions, triangles = bench_addon.read_off(args.mesh)
    positions = positions[:, [0, 2, 1]] * np.array([1, -1, 1], np.float32)  # the scan's y-up -> Blender's z-up
    positions = positions / np.ptp(positions, axis=0).max()  # about 1 unit long
    count = len(triangles)
    obj = harness.mesh_from_arrays("Bunny", positions, triangles.ravel(), np.arange(count, dtype=np.int32) * 3,
                                   np.full(count, 3, dtype=np.int32))
    harness.select_only([obj])
    obj.data.polygons.foreach_set("use_smooth", np.ones(count, bool))
    started = time.perf_counter()
    bpy.ops.object.mode_set(mode="EDIT")
    bpy.ops.mesh.select_all(action="SELECT")
    bpy.ops.uv.smart_project(island_margin=0.004)
    bpy.ops.object.mode_set(mode="OBJECT")
    smart_uv = time.perf_counter() - started
    print("mesh: Stanford bunny %d vertices, %d triangles; Smart UV Project %.2f s" % (
        len(positions), count, smart_uv), flush=True)
    sample = sources.Sample(path=os.path.abspath(args.sample))
    request = options.BakeRequest(size=args.size, margin=2, create_uv=False)
    base = dict(method="ROUND", sample_world_size=0.25, seed=1, axis=(0.0, 0.0, 1.0))
    runs = (("first run (context + synthesis)", dict(base)),
            ("new field (neighbourhoods reused)", dict(base, axis=(1.0, 0.0, 0.0))),
            ("new seed (neighbourhoods reused)", dict(base, seed=2)))
    print("%-36s %8s %8s %8s %8s %10s %9s" % ("run", "context", "synth", "native", "total", "samples", "peak MB"))
    for label, values in runs:
        started = time.perf_counter()
        report = surface.synthesize([obj], sample, core_settings.Settings(**values), request, "NEW")
        total = time.perf_counter() - started
        if report.failures:
            raise SystemExit("bench_round_bunny: %s" % report.summary())
        stats = report.native_stats["Bunny"]
        print("%-36s %8.2f %8.2f %8.2f %8.2f %10d %9.0f" % (
            label, stats["seconds_context"], stats["seconds_synthesis"], report.seconds["synthesis"], total,
            stats["surface_samples"], peak_mb()), flush=True)
    print("working sample %s px for a target of %.0f texels/unit (sample %.0f px/unit)" % (
        stats["working_sample"], stats["target_density"], 192 / 0.25))
    print("goals: <= 20 s first run at 1024² (~700k samples), <= 5 s re-synthesis, <= 1500 MB peak")
    print("paper (3.8 GHz P4): 48k-vertex horse ~5 min marching + 10-15 s synthesis; 512² 2D ~30 s")
    if args.render:
        render(obj, args.render)
        print("render: %s" % args.render)


main()

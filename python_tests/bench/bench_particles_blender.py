# SPDX-License-Identifier: GPL-3.0-or-later
"""Texture particles inside Blender (not a test): writing the decal geometry of ~20k particles on a ~100k-face
mesh (goal <= 1 s) and re-synthesizing one class (goal <= 0.5 s), with the parts printed: native (placement,
sprites + atlas, decal_mesh) and bpy writes (meshes, UVs, particle_id, atlas image, material, objects).

  blender -b --factory-startup --python-exit-code 1 --python python_tests/bench/bench_particles_blender.py \\
      [-- --segments 448 --rings 224 --particles 20000 --repeat 3 --bake 2048]     (default: 100,352 quads)

--bake N also times compositing the decals of the full run into an N x N bake image (particles/baking.py:
reading the decal layers, rasterising, sampling the atlas, the margin; Cycles' background bake excluded)
through a Smart UV Project map.

Without the native place_particles / decal_mesh (a build from before they landed) only the bpy half is
measured, on decal geometry made here of the same size (a 6-triangle fan per particle, 4 classes), and the
figures say so.
"""
import argparse
import os
import statistics
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(os.path.dirname(HERE), "blender"))
import bpy  # noqa: E402
import numpy as np  # noqa: E402

import bench_addon  # noqa: E402
import harness  # noqa: E402


def pebble_sample(path, size=256, seed=0):
    """Discs of two colours on a ground, on a jittered grid: ~100 complete particles."""
    rng = np.random.default_rng(seed)
    pixels = np.ones((size, size, 4), np.float32)
    pixels[..., :3] = (0.25, 0.3, 0.2)
    yy, xx = np.mgrid[0:size, 0:size]
    for gy in range(12, size - 12, 24):
        for gx in range(12, size - 12, 24):
            cx, cy, r = gx + rng.uniform(-3, 3), gy + rng.uniform(-3, 3), rng.uniform(5, 8)
            pixels[(xx - cx) ** 2 + (yy - cy) ** 2 < r * r, :3] = (0.8, 0.7, 0.3) if rng.random() < 0.6 else (0.6, 0.1, 0.1)
    return harness.save_png(path, pixels)


def fan_decals(count, rng, radius=0.01):
    """decal_mesh-sized output for `count` particles: per particle a fan of 6 triangles (7 vertices)."""
    centres = rng.uniform(-1, 1, size=(count, 3)).astype(np.float32)
    angles = np.linspace(0, 2 * np.pi, 7)[:-1]
    ring = np.stack([np.cos(angles), np.sin(angles), np.zeros(6)], axis=1).astype(np.float32) * radius
    positions = np.concatenate([centres[:, None, :], centres[:, None, :] + ring[None]], axis=1).reshape(-1, 3)
    base = (np.arange(count) * 7)[:, None]
    tris = np.stack([np.zeros(6, np.int32), 1 + np.arange(6), 1 + (np.arange(6) + 1) % 6], axis=1)
    corner_verts = (base[:, None, :] + tris[None]).reshape(-1).astype(np.int32)
    faces = count * 6
    uv = rng.random((faces * 3, 2)).astype(np.float32)
    return {"positions": positions, "loop_starts": np.arange(faces, dtype=np.int32) * 3,
            "loop_totals": np.full(faces, 3, np.int32), "corner_verts": corner_verts, "corner_uvs": uv,
            "face_particle": np.repeat(np.arange(count, dtype=np.int32), 6),
            "source_triangle": np.zeros(faces, np.int32), "source_barycentric": np.zeros((faces * 3, 2), np.float32)}


def synthetic(args, obj):
    from texsynth.particles import scene
    rng = np.random.default_rng(1)
    atlas = np.zeros((2048, 2048, 4), np.float32)
    write, one = [], []
    per_class = args.particles // 4
    for _ in range(args.repeat):
        outputs = []
        for c in range(4):
            out = scene.ClassOutput(c, c, per_class)
            out.decals = fan_decals(per_class, rng)
            outputs.append(out)
        start = time.perf_counter()
        scene.write_outputs(obj, outputs, atlas, (2048, 2048))
        write.append(time.perf_counter() - start)
        start = time.perf_counter()
        scene.write_outputs(obj, outputs[:1], atlas, (2048, 2048), keep_atlas=True)
        one.append(time.perf_counter() - start)
    faces = sum(len(o.data.polygons) for o in scene.owned_objects(obj.name))
    print("bench_particles_blender: native place_particles / decal_mesh not built: bpy writes only, on decal "
          "geometry made here (%d particles, %d decal faces, 4 classes, 2048² atlas)" % (per_class * 4, faces))
    print("  write all classes (bpy): median %.3f s (min %.3f)  goal <= 1 s with the native part" % (
        statistics.median(write), min(write)))
    print("  rewrite one class (bpy): median %.3f s (min %.3f)" % (statistics.median(one), min(one)))


def real(args, obj, texsynth):
    from texsynth.core import settings as core_settings
    from texsynth.particles import core, outputs, scene, synthesis
    from texsynth.bridge.sources import Sample
    path = pebble_sample(os.path.join(tempfile.mkdtemp(), "pebbles.png"))
    settings = core_settings.Settings(method="PARTICLES", particle_classes=3, particle_blur=0.0,
                                 particle_background="NONE", seed=3)
    probe = synthesis.Job([obj], Sample(path=path), settings).prepare()
    a = probe.analysis
    rows = core.class_rows(a)
    n_sample = sum(r["particles"] for r in rows if not r["background"])
    area = float(outputs.triangle_areas(probe.items[0].arrays.positions, probe.items[0].triangles).sum())
    pixel = np.sqrt(n_sample * area / (a.width * a.height * args.particles))
    settings.sample_world_size = float(pixel * a.width)
    # Calibrated on one untimed placement (the placement packs particles more tightly than the sample's density).
    placed = len(probe.place(texsynth.native.require(), probe.items[0])[1]["class"])
    settings.sample_world_size *= float(np.sqrt(placed / args.particles))
    print("bench_particles_blender: %d faces, sample %dx%d with %d particles, scale %.4f for ~%d particles"
          % (len(obj.data.polygons), a.width, a.height, n_sample, settings.sample_world_size, args.particles))
    for label, only in (("all classes", None), ("one class", probe.order[0])):
        totals, natives, writes, counts, parts = [], [], [], [], []
        for _ in range(args.repeat):
            job = synthesis.Job([obj], Sample(path=path), settings, only_class=only).prepare()
            start = time.perf_counter()
            job.compute()
            job.apply()
            totals.append(time.perf_counter() - start)
            natives.append(job.timings.seconds["synthesis"])
            writes.append(job.timings.seconds["write"])
            stats = job.report.native_stats[obj.name]
            counts.append(stats["placed"])
            parts.append((stats["seconds_placement"], stats["seconds_atlas"], stats["seconds_decal_mesh"]))
        faces = sum(len(o.data.polygons) for o in scene.owned_objects(obj.name, ("DECALS",))
                    if only is None or o[scene.CLASS_TAG] == only)
        print("  %s: %d particles, %d decal faces, total median %.3f s = native %.3f s (placement, sprites, atlas, "
              "decal_mesh) + bpy writes %.3f s" % (label, counts[-1], faces, statistics.median(totals),
                                                  statistics.median(natives), statistics.median(writes)))
        placement, atlas, decal = (statistics.median(p[k] for p in parts) for k in range(3))
        print("    native parts: placement %.3f s, sprites + atlas %.3f s, decal_mesh %.3f s; decal geometry written "
              "(decal_mesh + bpy writes) %.3f s" % (placement, atlas, decal, decal + statistics.median(writes)))
        if args.bake and only is None:
            bake_compositing(args, obj)
    print("  goals: write decal geometry of 20k particles <= 1 s; re-synthesize one class <= 0.5 s")


def bake_compositing(args, obj):
    """Times particles/baking.py's prepare + apply (the compositing) on an N x N image of a flat background."""
    from texsynth.bridge import images
    from texsynth.particles import baking as particle_baking
    harness.select_only([obj])
    bpy.context.view_layer.objects.active = obj
    obj.data.uv_layers.new(name="Bake")
    bpy.ops.object.mode_set(mode="EDIT")
    bpy.ops.mesh.select_all(action="SELECT")
    bpy.ops.uv.smart_project(island_margin=0.002)
    bpy.ops.object.mode_set(mode="OBJECT")
    seconds = []
    for _ in range(args.repeat):
        image = images.new_image("bench bake", args.bake, False)
        image.pixels.foreach_set(np.tile(np.float32([0.3, 0.3, 0.25, 1.0]), args.bake * args.bake))
        start = time.perf_counter()
        layers = particle_baking.prepare(obj)
        particle_baking.apply(layers, image, "Bake", 16)
        seconds.append(time.perf_counter() - start)
        bpy.data.images.remove(image)
    faces = sum(len(layer.loop_starts) for layer in layers.layers)
    print("    bake compositing into %d² (%d class layers, %d decal faces, margin 16): median %.3f s (min %.3f)"
          % (args.bake, len(layers.layers), faces, statistics.median(seconds), min(seconds)))


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--segments", type=int, default=448)
    parser.add_argument("--rings", type=int, default=224)
    parser.add_argument("--particles", type=int, default=20000)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--bake", type=int, default=0, help="also time the bake compositing at this image size")
    args = parser.parse_args(harness.script_args())
    texsynth = harness.load_addon()
    harness.reset_scene()
    texsynth.register()
    obj = bench_addon.bumpy_torus(args.segments, args.rings)
    module = texsynth.native.require()
    if hasattr(module, "place_particles") and hasattr(module, "decal_mesh"):
        real(args, obj, texsynth)
    else:
        synthetic(args, obj)


if __name__ == "__main__":
    main()

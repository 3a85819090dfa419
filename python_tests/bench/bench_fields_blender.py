# SPDX-License-Identifier: GPL-3.0-or-later
"""A field edit with Live Update inside Blender, end to end (not a test). Prints per phase: read the
field, relax (native), write the attributes, re-synthesize (bpy read + native + bpy write).

  blender -b --factory-startup --python-exit-code 1 --python python_tests/bench/bench_fields_blender.py \\
      [-- --segments 448 --rings 224 --repeat 5 --method JUMP|PATCHES]      (default: 448 x 224 = 100,352 quads)

--method PATCHES: the vector-field patch preview (patch sampling into a 256² image through the UV map;
goal <= 0.3 s, issue 14).
"""
import argparse
import os
import statistics
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(os.path.dirname(HERE), "blender"))
import bpy  # noqa: E402

import bench_addon  # noqa: E402
import harness  # noqa: E402


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--segments", type=int, default=448)
    parser.add_argument("--rings", type=int, default=224)
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--method", default="JUMP", choices=("JUMP", "PATCHES"))
    args = parser.parse_args(harness.script_args())
    texsynth = harness.load_addon()
    texsynth.register()
    from texsynth.bridge import mesh_io
    from texsynth.fields import authoring, tools
    harness.reset_scene()
    texsynth.register()
    obj = bench_addon.bumpy_torus(args.segments, args.rings)
    harness.select_only([obj])
    props = bpy.context.scene.texsynth
    props.sample_source, props.sample_path = "FILE", os.path.join(harness.SAMPLES_DIR, "bricks.png")
    props.scale, props.blend, props.material_mode, props.allow_oversized = 0.5, True, "NONE", True
    props.orientation, props.direction_attribute = "FIELD", authoring.DIRECTION_NAME
    if args.method == "PATCHES":
        props.method, props.scale = "PATCHES", 4.0
    print("mesh: %d faces, %d vertices" % (len(obj.data.polygons), len(obj.data.vertices)))
    state = tools.field_state(bpy.context, obj)
    tools.commit_edit(bpy.context, obj, state)
    tools.live_update(bpy.context, obj)  # warm: preprocess (disk cache) into memory
    phases = {name: [] for name in ("read", "relax", "write", "live_total", "live_native")}
    for k in range(args.repeat):
        t0 = time.perf_counter()
        state = tools.field_state(bpy.context, obj)
        t1 = time.perf_counter()
        authoring.set_singularity(state, 1000 * (k + 1), authoring.SOURCE)  # includes the native relax
        t2 = time.perf_counter()
        mesh_io.write_field_state(obj, state)
        t3 = time.perf_counter()
        tools.live_update(bpy.context, obj)
        phases["read"].append(t1 - t0)
        phases["relax"].append(t2 - t1)
        phases["write"].append(t3 - t2)
        phases["live_total"].append(tools.last_timings["live_update"])
        phases["live_native"].append(tools.last_timings["live_native"])
    for name, values in phases.items():
        print("  %-12s %8.1f ms median of %d" % (name, 1000 * statistics.median(values), len(values)))


if __name__ == "__main__":
    main()

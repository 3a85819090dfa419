# SPDX-License-Identifier: GPL-3.0-or-later
"""A field edit with Live Update inside Blender, end to end (not a test).

  blender -b --factory-startup --python-exit-code 1 --python python_tests/bench/bench_fields_blender.py \\
      [-- --segments 448 --rings 224 --repeat 7 --method JUMP|PATCHES]      (default: 448 x 224 = 100,352 quads)

JUMP (default): a comb stroke as the Comb operator runs it: the FieldState stays in memory for the
edit session, a stroke paints anchors (authoring.paint, a brush of --radius mean edge lengths), then
the timed part: relax (native compute_field) + field_edits.commit_edit (field attributes written + live
re-synthesis). The live-update paths run in the same process, in rotating order:
  old  TEXSYNTH_LIVE_PATH=full: write the field, then a Synthesize that re-reads mesh and field,
       synthesizes, snapshots the layers it replaces and writes them (before this branch);
  sequential  TEXSYNTH_LIVE_PATH=sequential: from the in-memory state (no mesh/field re-read), one
       step after the other: field write, layer snapshot, native synthesis, layer writes;
  new  the same with the native synthesis in a worker thread (GIL released) while the main thread
       writes the field and snapshots the layers.
Prints medians and ranges per step, then Blender's own costs at this size: whole-layer foreach_set
and foreach_get of one corner layer, per-item writes of 1 % / 5 % of the corners (the alternative
for "write only the changed corners"), and the view-layer (depsgraph) update a redraw then pays.

--method PATCHES: the vector-field patch preview (patch sampling into a 256² image through the UV map;
goal <= 0.3 s, issue 14; every path writes the field first there).
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
import numpy as np  # noqa: E402

import bench_addon  # noqa: E402
import harness  # noqa: E402


def ms(values):
    return "%7.1f ms (%.1f-%.1f)" % (1000 * statistics.median(values), 1000 * min(values), 1000 * max(values))


def timed(function, repeat=5):
    seconds = []
    for _ in range(repeat):
        start = time.perf_counter()
        function()
        seconds.append(time.perf_counter() - start)
    return seconds


def blender_costs(obj):
    """Blender's own per-layer costs at this mesh size (what any live update pays)."""
    mesh = obj.data
    corners = len(mesh.loops)
    colour = np.random.default_rng(0).random(corners * 4, dtype=np.float32)
    attribute = mesh.attributes.new("BenchColour", "FLOAT_COLOR", "CORNER")
    buffer = np.empty(corners * 4, np.float32)
    print("Blender's costs at %d corners (one FLOAT_COLOR corner layer; the live update writes 1 UV map + 3 of these):"
          % corners)
    print("  foreach_set whole layer        %s" % ms(timed(lambda: mesh.attributes["BenchColour"].data.foreach_set(
        "color", colour))))
    print("  foreach_get whole layer        %s" % ms(timed(lambda: mesh.attributes["BenchColour"].data.foreach_get(
        "color", buffer))))
    data = attribute.data
    for share in (0.01, 0.05):
        ids = np.arange(0, corners, int(round(1 / share)))
        values = colour.reshape(-1, 4)[ids].tolist()
        indices = ids.tolist()

        def per_item():
            for index, value in zip(indices, values):
                data[index].color = value
        print("  per-item writes, %2d %% corners  %s" % (round(100 * share), ms(timed(per_item, 3))))
    mesh.attributes.remove(mesh.attributes["BenchColour"])

    def view_layer_update():
        mesh.update()
        bpy.context.view_layer.update()
    print("  view-layer (depsgraph) update after a mesh change %s" % ms(timed(view_layer_update)))


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--segments", type=int, default=448)
    parser.add_argument("--rings", type=int, default=224)
    parser.add_argument("--repeat", type=int, default=7)
    parser.add_argument("--radius", type=float, default=8.0, help="brush radius in mean edge lengths")
    parser.add_argument("--method", default="JUMP", choices=("JUMP", "PATCHES"))
    args = parser.parse_args(harness.script_args())
    texsynth = harness.load_addon()
    texsynth.register()
    from texsynth.fields import authoring
    from texsynth.ui import field_edits
    from texsynth.fields import mesh_state
    harness.reset_scene()
    texsynth.register()
    obj = bench_addon.bumpy_torus(args.segments, args.rings)
    harness.select_only([obj])
    props = bpy.context.scene.texsynth
    props.sample_source, props.sample_path = "FILE", os.path.join(harness.SAMPLES_DIR, "bricks.png")
    props.scale, props.blend, props.material_mode, props.allow_oversized = 0.5, True, "NONE", True
    props.orientation, props.direction_attribute = "FIELD", authoring.DIRECTION_NAME
    props.field_live_update = True
    if args.method == "PATCHES":
        props.method, props.scale = "PATCHES", 4.0
    print("mesh: %d faces, %d vertices, %d corners" % (len(obj.data.polygons), len(obj.data.vertices),
                                                       len(obj.data.loops)))
    from texsynth.fields import overlay
    overlay.active_editors.add(obj.name)  # inside a Comb session (its snapshot buffers are kept)
    os.environ[field_edits.LIVE_PATH_ENV] = "full"
    state = mesh_state.field_state(bpy.context, obj)
    field_edits.commit_edit(bpy.context, obj, state)  # warm: preprocess (disk cache) into memory, layers exist
    os.environ.pop(field_edits.LIVE_PATH_ENV)
    field_edits.commit_edit(bpy.context, obj, state)
    read = timed(lambda: mesh_state.field_state(bpy.context, obj))
    print("field_state (mesh + field read, once per Comb session, not per stroke): %s" % ms(read))

    positions = state.arrays.positions
    edge = np.linalg.norm(positions[state.arrays.corner_verts[1::4]] - positions[state.arrays.corner_verts[0::4]],
                          axis=1).mean()
    caster = mesh_state.caster_for(obj, state.arrays)
    rng = np.random.default_rng(7)
    paths = ("old", "sequential", "new")
    environment = {"old": "full", "sequential": "sequential", "new": None}
    steps = ("end_to_end", "relax", "commit")
    figures = {path: {step: [] for step in steps} for path in paths}
    breakdown = {path: {} for path in paths}
    changed = []
    for k in range(args.repeat):
        for path in paths[k % 3:] + paths[:k % 3]:  # rotating order
            if environment[path]:
                os.environ[field_edits.LIVE_PATH_ENV] = environment[path]
            else:
                os.environ.pop(field_edits.LIVE_PATH_ENV, None)
            # One stroke: a dab of anchors around a random vertex, along a random tangent direction.
            centre = positions[rng.integers(len(positions))]
            ids, distances = caster.vertices_within(centre, args.radius * edge)
            authoring.paint(state, ids, authoring.falloff(distances, args.radius * edge), rng.normal(size=3))
            before = state.direction.copy()
            start = time.perf_counter()
            authoring.relax(state)
            relaxed = time.perf_counter()
            warning = field_edits.commit_edit(bpy.context, obj, state)
            end = time.perf_counter()
            if warning:
                raise SystemExit(warning)
            changed.append(int(np.count_nonzero(np.any(state.direction != before, axis=1))))
            figures[path]["end_to_end"].append(end - start)
            figures[path]["relax"].append(relaxed - start)
            figures[path]["commit"].append(end - relaxed)
            for name, value in field_edits.last_timings.items():
                if name.startswith("live_") and isinstance(value, float):
                    breakdown[path].setdefault(name, []).append(value)
    print("comb stroke of %d anchors (radius %.0f edges); vertices whose direction changed per stroke: median %d of %d"
          % (len(ids), args.radius, int(statistics.median(changed)), len(positions)))
    print("old = write field, then Synthesize re-reading mesh + field; sequential = from memory; new = from memory, "
          "native overlapped with the field write + layer snapshot. Medians (ranges) of %d strokes each:" % args.repeat)
    for path in paths:
        print("  %s:" % path)
        for step in steps:
            print("    %-22s %s" % (step, ms(figures[path][step])))
        for name in sorted(breakdown[path]):
            print("    %-22s %s" % (name, ms(breakdown[path][name])))
    for path in paths[1:]:
        ratio = statistics.median(figures[path]["end_to_end"]) / statistics.median(figures["old"]["end_to_end"])
        print("  %s / old end to end: %.2f" % (path, ratio))
    blender_costs(obj)


if __name__ == "__main__":
    main()

# SPDX-License-Identifier: GPL-3.0-or-later
"""Jump-map synthesis speed on the subdivided Stanford bunny imported from OBJ (issue 16 row 3:
"jump-map synthesis end to end (native seconds, mesh build included) on an ~836k-quad scanned mesh
imported from OBJ, 2 threads"). Not a test. Two steps:

  bash scripts/fetch_bench_mesh.sh   # once
  # 1. in Blender: the bunny with 2 Catmull-Clark levels (as bench_addon.py builds it) written as OBJ,
  #    imported back the way the CLI imports --mesh (compat.import_mesh_file) and read by mesh_io.read_mesh;
  #    the arrays go to out/bench/bunny_subdiv2.npz (and the OBJ to out/bench/bunny_subdiv2.obj; the
  #    mesh as Blender built it, before the export, to bunny_subdiv2_blender.npz: pass it with --npz)
  blender -b --factory-startup --python-exit-code 1 --python python_tests/bench/bench_jumpmap_obj.py
  # 2. timing, without Blender: synthesize_jumpmap (mesh build + field + synthesis, as the CLI's
  #    seconds.synthesis) on those arrays, alternating the new path and the old one in the same run
  PYTHONPATH=addon python3.11 python_tests/bench/bench_jumpmap_obj.py [--repeat 7]   # 2 threads on this 2-CPU VM

The old path is the same call with baseline_passes=True (the previous pass structure). Prints
medians and ranges (seconds, vertices/s, CPU time of all threads, the native phase seconds) and a
hash of each path's outputs (they must be equal).

  PYTHONPATH=addon python3.11 python_tests/bench/bench_jumpmap_obj.py --baseline OLD_MODULE_DIR [--repeat 7]
times another build of the module (e.g. an earlier commit's, built in a worktree) against this one
instead, each call in its own process, alternating builds, and compares their outputs.
"""
import argparse
import hashlib
import json
import os
import statistics
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
OBJ_PATH = os.path.join(ROOT, "out", "bench", "bunny_subdiv2.obj")
NPZ_PATH = os.path.join(ROOT, "out", "bench", "bunny_subdiv2.npz")


def save_arrays(path, arrays, size):
    import numpy as np
    np.savez(path, positions=arrays.positions, corner_verts=arrays.corner_verts, poly_starts=arrays.poly_starts,
             poly_sizes=arrays.poly_sizes, size=np.float32(size))


def blender_main():
    sys.path.insert(0, os.path.join(os.path.dirname(HERE), "blender"))
    sys.path.insert(0, HERE)
    import bpy

    import bench_addon
    import harness

    texsynth = harness.load_addon()
    texsynth.register()
    from texsynth import compat
    from texsynth.bridge import mesh_io

    source = bench_addon.build_mesh("stanford", os.path.join(ROOT, "out", "bench", "bunny00.off"))
    harness.select_only([source])
    save_arrays(NPZ_PATH.replace(".npz", "_blender.npz"), mesh_io.read_mesh(source), max(source.dimensions))
    bpy.ops.wm.obj_export(filepath=OBJ_PATH, export_selected_objects=True, export_uv=False,
                          export_normals=False, export_materials=False, apply_modifiers=False)
    harness.reset_scene()
    objects = compat.import_mesh_file(OBJ_PATH)
    arrays = mesh_io.read_mesh(objects[0])
    save_arrays(NPZ_PATH, arrays, max(objects[0].dimensions))
    print("bench_jumpmap_obj: %s -> %s: %d vertices, %d polygons, %d corners"
          % (OBJ_PATH, NPZ_PATH, len(arrays.positions), len(arrays.poly_sizes), len(arrays.corner_verts)))


def digest(result):
    h = hashlib.sha256()
    for key in ("base_uv", "blend_set_pairs", "blend_weights"):
        h.update(result[key].tobytes())
    return h.hexdigest()[:16]


def timing_main():
    parser = argparse.ArgumentParser(prog="bench_jumpmap_obj")
    parser.add_argument("--repeat", type=int, default=7)
    parser.add_argument("--npz", default=NPZ_PATH)
    parser.add_argument("--sample", default=os.path.join(ROOT, "blend_samples", "bricks.png"))
    parser.add_argument("--baseline", default="", help="another module build to time against this one")
    parser.add_argument("--module", default="", help="(child process) directory of the module to time")
    args = parser.parse_args()
    if args.baseline:
        return compare_builds(args)
    if args.module:
        sys.path.insert(0, args.module)
    import tempfile

    import numpy as np
    import texsynth_native as native

    if not os.path.isfile(args.npz):
        raise SystemExit("bench_jumpmap_obj: %s is missing; run step 1 in Blender first" % args.npz)
    data = np.load(args.npz)
    mesh = (data["positions"], data["corner_verts"], data["poly_starts"], data["poly_sizes"])
    # The operator's preprocessing of the sample (bench_native_torus's cache).
    pre = native.preprocess(args.sample, cache_dir=os.path.join(tempfile.gettempdir(), "texsynth_bench_native_cache"),
                            neighbourhood=11, tileable=False, seed=0)
    num_vertices = len(mesh[0])
    print("mesh: %d vertices, %d polygons, %d corners; %d CPUs (TBB's default: one thread each)"
          % (num_vertices, len(mesh[3]), len(mesh[1]), os.cpu_count()))
    # The operator's arguments (uv_methods.core.synthesize): sample a quarter of the mesh, blended, packed sets.
    kwargs = dict(scale=float(pre.width) / (float(data["size"]) / 4.0), seed=1, pack_sets=True, blend=True,
                  jump_rate=20.0, orientation="axis", axis=(0.0, 0.0, 1.0))
    if args.module:  # child: one call of the default path, raw figures as JSON
        import resource

        before = resource.getrusage(resource.RUSAGE_SELF)
        start = time.perf_counter()
        out = native.synthesize_jumpmap(pre, *mesh, **kwargs)
        seconds = time.perf_counter() - start
        after = resource.getrusage(resource.RUSAGE_SELF)
        user, system = after.ru_utime - before.ru_utime, after.ru_stime - before.ru_stime
        print(json.dumps({"seconds": seconds, "vertices": num_vertices, "hash": digest(out),
                          "cpu_user": user, "cpu_system": system, "threads": os.cpu_count(),
                          "phases": {key[8:]: out["stats"][key] for key in out["stats"] if key.startswith("seconds_")}}))
        return
    times = {True: [], False: []}
    native_seconds = {True: [], False: []}
    cpu = {True: [], False: []}
    phases = {True: {}, False: {}}
    hashes = {True: set(), False: set()}
    for run in range(args.repeat):
        for new in ((True, False) if run % 2 == 0 else (False, True)):
            start, start_cpu = time.perf_counter(), time.process_time()
            out = native.synthesize_jumpmap(pre, *mesh, baseline_passes=not new, **kwargs)
            times[new].append(time.perf_counter() - start)
            cpu[new].append(time.process_time() - start_cpu)
            native_seconds[new].append(out["stats"]["seconds"])
            for key in ("seconds_mesh", "seconds_faces", "seconds_walk", "seconds_corners"):
                phases[new].setdefault(key, []).append(out["stats"][key])
            hashes[new].add(digest(out))
            del out
    for new, name in ((False, "old (baseline_passes)"), (True, "new")):
        t = times[new]
        print("%-22s call %.3f s median (%.3f-%.3f), core %.3f s, CPU (both threads) %.3f s; %.2f M vertices/s "
              "median (%.2f-%.2f); outputs %s" % (name, statistics.median(t), min(t), max(t),
                                                 statistics.median(native_seconds[new]), statistics.median(cpu[new]),
                                                 num_vertices / statistics.median(t) / 1e6,
                                          num_vertices / max(t) / 1e6, num_vertices / min(t) / 1e6,
                                          ", ".join(sorted(hashes[new]))))
        print("%-22s phases (medians): %s" % ("", ", ".join("%s %.3f s" % (key[8:], statistics.median(values))
                                                              for key, values in phases[new].items())))
    print("identical outputs: %s" % (hashes[True] == hashes[False] and len(hashes[True]) == 1))


def compare_builds(args):
    """Each repeat: one call per build, each in its own process, alternating the order."""
    import module_builds

    builds = [("new", os.path.abspath(os.path.join(ROOT, "addon"))), ("baseline", os.path.abspath(args.baseline))]
    runs = module_builds.run_alternating(builds, args.repeat, lambda directory: [
        sys.executable, os.path.abspath(__file__), "--module", directory, "--npz", args.npz, "--sample", args.sample])
    print("builds: new %s, baseline %s; %d calls each, alternating" % (builds[0][1], builds[1][1], args.repeat))
    for name, _ in builds:
        seconds = [run["seconds"] for run in runs[name]]
        vertices = runs[name][0]["vertices"]
        print("%-9s call %.3f s median (%.3f-%.3f); %.2f M vertices/s median; outputs %s" % (
            name, statistics.median(seconds), min(seconds), max(seconds), vertices / statistics.median(seconds) / 1e6,
            ",".join(sorted({run["hash"] for run in runs[name]}))))
        print("%-9s phases (medians): %s" % ("", ", ".join("%s %.3f s" % (key, statistics.median(
            run["phases"][key] for run in runs[name])) for key in runs[name][0]["phases"])))
        if "cpu_user" in runs[name][0]:
            # All threads' CPU time bounds the wall time from below, however well the work is spread.
            cpu = statistics.median(run["cpu_user"] + run["cpu_system"] for run in runs[name])
            cores = runs[name][0]["threads"]
            print("%-9s CPU of all threads %.3f s median (user %.3f, system %.3f): spread perfectly over %d CPUs, "
                  "at best %.3f s = %.2f M vertices/s" % (
                      "", cpu, statistics.median(run["cpu_user"] for run in runs[name]),
                      statistics.median(run["cpu_system"] for run in runs[name]), cores, cpu / cores,
                      vertices / (cpu / cores) / 1e6))
    print("new / baseline: %.2fx; identical outputs: %s" % (
        statistics.median(run["seconds"] for run in runs["new"]) /
        statistics.median(run["seconds"] for run in runs["baseline"]),
        {run["hash"] for run in runs["new"]} == {run["hash"] for run in runs["baseline"]}))


if __name__ == "__main__":
    if "bpy" in sys.modules or os.path.basename(sys.executable).startswith("blender"):
        blender_main()
    else:
        timing_main()

# SPDX-License-Identifier: GPL-3.0-or-later
"""Texton synthesis speed and seam error on a large mesh, the original path (coherence_threshold=0,
seeds_per_component=1) against the new ones IN THE SAME RUN (configurations alternate, medians). Not a test.

  bash scripts/fetch_bench_mesh.sh   # once, then (once) the bunny with 2 Catmull-Clark levels as arrays:
  blender -b --factory-startup --python-exit-code 1 --python python_tests/bench/export_bench_mesh.py
  PYTHONPATH=addon /usr/bin/python3.11 python_tests/bench/bench_texton_speed.py [--repeat 3] \\
      [--mesh out/bench/bunny_cc2.npz] [--configs 0:1,0.5:1,0:16,0.5:16]

Mesh: out/bench/bunny_cc2.npz (904,896 quads) or, when missing, a synthetic jittered quad grid of that size.
Samples: blend_samples/bricks.png (structured) and a value-noise image (stochastic), scale as bench_addon.py
(the sample spans a quarter of the mesh). Threads: TBB's default (every core). A configuration is
coherence_threshold:seeds_per_component. Prints per configuration: median wall seconds of the native call
(range), faces/s, median process CPU seconds (all threads), E_t mean / p95 over interior edges, E_t mean on region-border edges, coherent / border faces,
and the native phases (medians). The call is the add-on's (pack_sets=True).

Another build of the module as a baseline in the same run (e.g. the previous commit's, built in a worktree):
  PYTHONPATH=addon /usr/bin/python3.11 python_tests/bench/bench_texton_speed.py --baseline OLD_MODULE_DIR [--repeat 5]
runs every repeat once per build, each in its own process, alternating the order, and prints both builds'
medians and whether their outputs are identical (hash of every output array).
"""
import argparse
import hashlib
import json
import os
import statistics
import sys
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
MODULE_DIR = (sys.argv[sys.argv.index("--module") + 1] if "--module" in sys.argv
              else os.path.join(ROOT, "addon"))
sys.path.insert(0, MODULE_DIR)
import texsynth_native as ts  # noqa: E402

OUTPUT_KEYS = ("base_uv", "blend_set_pairs", "blend_weights", "edge_error", "edge_phi", "edge_blended",
               "corner_edge_blended", "corner_edge_error", "face_region", "edge_vertices")


def output_hash(out):
    digest = hashlib.sha256()
    for key in OUTPUT_KEYS:
        digest.update(np.ascontiguousarray(out[key]).tobytes())
    return digest.hexdigest()[:16]


def synthetic_grid(n=951, jitter=0.3, seed=1):
    """An n x n jittered quad grid spanning one unit (904,401 quads for n = 951)."""
    rng = np.random.default_rng(seed)
    xs, ys = np.meshgrid(np.arange(n + 1, dtype=np.float64), np.arange(n + 1, dtype=np.float64))
    pos = np.stack([xs, ys, np.zeros_like(xs)], -1).reshape(-1, 3)
    pos[:, :2] += rng.uniform(-jitter, jitter, (len(pos), 2))
    i, j = np.meshgrid(np.arange(n), np.arange(n))
    v = (j * (n + 1) + i).ravel()
    corner_verts = np.stack([v, v + 1, v + n + 2, v + n + 1], -1).ravel().astype(np.int32)
    count = n * n
    return ((pos / n).astype(np.float32), corner_verts, (np.arange(count) * 4).astype(np.int32),
            np.full(count, 4, np.int32))


def value_noise(size=256, seed=4):
    rng = np.random.default_rng(seed)
    out = np.zeros((size, size), np.float64)
    for cell, weight in ((32, 0.5), (12, 0.3), (5, 0.2)):
        lattice = rng.random((size // cell + 2, size // cell + 2))
        t = np.arange(size) / cell
        i = t.astype(int)
        f = t - i
        f = f * f * (3 - 2 * f)
        a = lattice[i][:, i] * (1 - f)[None, :] + lattice[i][:, i + 1] * f[None, :]
        b = lattice[i + 1][:, i] * (1 - f)[None, :] + lattice[i + 1][:, i + 1] * f[None, :]
        out += weight * (a * (1 - f)[:, None] + b * f[:, None])
    return np.stack([0.2 + 0.6 * out, 0.3 + 0.4 * out, 0.1 + 0.3 * out], -1).astype(np.float32)


def edge_faces(mesh, edge_vertices):
    """(E, 2) faces on each sorted edge (-1 when fewer; the first two on non-manifold ones)."""
    positions, corner_verts, starts, sizes = mesh
    poly = np.repeat(np.arange(len(starts)), sizes)
    nxt = np.arange(len(corner_verts)) + 1
    ends = (starts + sizes)[poly]
    nxt[nxt == ends] = starts[poly][nxt == ends]
    a, b = corner_verts, corner_verts[nxt]
    lo, hi = np.minimum(a, b).astype(np.int64), np.maximum(a, b).astype(np.int64)
    V = len(positions)
    keys = edge_vertices[:, 0].astype(np.int64) * V + edge_vertices[:, 1]
    idx = np.searchsorted(keys, lo * V + hi)
    out = np.full((len(keys), 2), -1, np.int64)
    order = np.argsort(idx, kind="stable")
    sorted_idx = idx[order]
    first = np.r_[True, sorted_idx[1:] != sorted_idx[:-1]]
    out[sorted_idx[first], 0] = poly[order][first]
    second = ~first & np.r_[False, first[:-1]]
    out[sorted_idx[second], 1] = poly[order][second]
    return out


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--mesh", default=os.path.join(ROOT, "out", "bench", "bunny_cc2.npz"))
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--configs", default="0:1,0.5:1,0:16,0.5:16")
    parser.add_argument("--samples", default="bricks,noise")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--module", default=MODULE_DIR, help="directory of the texsynth_native module to time")
    parser.add_argument("--baseline", default="", help="another module build to time in the same run")
    parser.add_argument("--json", action="store_true", help="(child process) one JSON line of raw figures")
    args = parser.parse_args()
    if args.baseline:
        return compare_builds(args)
    if os.path.isfile(args.mesh):
        data = np.load(args.mesh)
        mesh = (data["positions"], data["corner_verts"], data["poly_starts"], data["poly_sizes"])
        name = os.path.basename(args.mesh)
    else:
        print("bench_texton_speed: %s missing: synthetic jittered quad grid instead" % args.mesh)
        mesh, name = synthetic_grid(), "jittered quad grid"
    size = float(np.max(mesh[0].max(0) - mesh[0].min(0)))
    faces = len(mesh[2])
    configs = [(float(c.split(":")[0]), int(c.split(":")[1])) for c in args.configs.split(",")]
    print("mesh: %s, %d faces, %d vertices; %d cores" % (name, faces, len(mesh[0]), os.cpu_count()))
    for sample_name in args.samples.split(","):
        pixels = (ts.load_image(os.path.join(ROOT, "blend_samples", "bricks.png")) if sample_name == "bricks"
                  else value_noise())
        pre = ts.preprocess(pixels)
        scale = pixels.shape[1] / (size / 4.0)  # bench_addon.py: the sample spans a quarter of the mesh
        print("\nsample %s %dx%d (K=%d), scale %.1f texels/unit" % (sample_name, pixels.shape[1], pixels.shape[0],
                                                                  pre.num_textons, scale))
        times = {c: [] for c in configs}
        cpu = {c: [] for c in configs}
        phases = {c: {} for c in configs}
        results = {}
        for _ in range(args.repeat):
            for c in configs:  # alternate: machine load drifts the same way for every configuration
                t0, c0 = time.perf_counter(), time.process_time()
                out = ts.synthesize_texton(pre, pixels, *mesh, scale=scale, seed=args.seed, coherence_threshold=c[0],
                                           seeds_per_component=c[1], pack_sets=True)
                times[c].append(time.perf_counter() - t0)
                cpu[c].append(time.process_time() - c0)
                for key, value in out["stats"].items():
                    if key.startswith("seconds_"):
                        phases[c].setdefault(key[8:], []).append(value)
                results[c] = out
        if args.json:
            print(json.dumps({"sample": sample_name, "faces": faces, "configs": [
                {"config": "%g:%d" % c, "wall": times[c], "cpu": cpu[c], "hash": output_hash(results[c]),
                 "phases": {key: statistics.median(v) for key, v in phases[c].items()}} for c in configs]}))
            continue
        ef = edge_faces(mesh, results[configs[0]]["edge_vertices"])
        interior = ef[:, 1] >= 0
        print("  %-10s %22s %9s %7s %17s %10s %8s %7s" % ("coh:seeds", "wall s median [range]", "faces/s", "CPU s",
                                                          "E_t mean / p95", "border E_t", "coherent", "border"))
        for c in configs:
            out = results[c]
            et = out["edge_error"][interior]
            region = out["face_region"]
            ra, rb = region[ef[interior, 0]], region[ef[interior, 1]]
            border = (ra != rb) | (ra < 0) | (rb < 0)
            med = statistics.median(times[c])
            st = out["stats"]
            print("  %-10s %7.3f [%.3f-%.3f] %9.0f %7.3f %8.4f / %6.4f %10s %8d %7d" % (
                "%g:%d" % c, med, min(times[c]), max(times[c]), faces / med, statistics.median(cpu[c]), et.mean(),
                np.quantile(et, 0.95),
                "%.4f" % et[border].mean() if border.any() else "-", st["coherent_faces"], st["border_faces"]))
            if phases[c]:
                print("  %-10s phases (medians): %s" % ("", ", ".join("%s %.3f s" % (key, statistics.median(v))
                                                                   for key, v in phases[c].items())))


def compare_builds(args):
    """Each repeat runs this script once per build (its own process, --json), alternating the order."""
    import module_builds

    builds = [("new", os.path.abspath(args.module)), ("baseline", os.path.abspath(args.baseline))]
    runs = module_builds.run_alternating(builds, args.repeat, lambda directory: [
        sys.executable, os.path.abspath(__file__), "--module", directory, "--json", "--repeat", "1", "--mesh", args.mesh,
        "--configs", args.configs, "--samples", args.samples, "--seed", str(args.seed)])
    print("builds: new %s, baseline %s; %d repeats each, alternating" % (builds[0][1], builds[1][1], args.repeat))
    for sample in args.samples.split(","):
        print("\nsample %s" % sample)
        for config in args.configs.split(","):
            figures = {}
            for name, _ in builds:
                rows = [c for run in runs[name] if run["sample"] == sample for c in run["configs"]
                        if c["config"] == "%g:%d" % (float(config.split(":")[0]), int(config.split(":")[1]))]
                wall = [w for row in rows for w in row["wall"]]
                figures[name] = (statistics.median(wall), min(wall), max(wall),
                                 statistics.median(c for row in rows for c in row["cpu"]),
                                 {row["hash"] for row in rows}, rows[-1]["phases"], runs[name][0]["faces"])
            for name, (wall, low, high, cpu, hashes, phase, faces) in figures.items():
                print("  %-6s %-9s wall %.3f s median [%.3f-%.3f], %7.0f faces/s, CPU %.3f s, outputs %s" % (
                    config, name, wall, low, high, faces / wall, cpu, ",".join(sorted(hashes))))
                if phase:
                    print("  %-16s phases: %s" % ("", ", ".join("%s %.3f" % kv for kv in phase.items())))
            print("  %-6s new / baseline wall: %.2fx; identical outputs: %s" % (
                config, figures["new"][0] / figures["baseline"][0], figures["new"][4] == figures["baseline"][4]))


main()

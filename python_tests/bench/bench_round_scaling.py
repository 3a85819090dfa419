# SPDX-License-Identifier: GPL-3.0-or-later
"""Round-neighbourhood synthesis (texsynth_native.RoundSynthesisContext / round_synthesize) from 128^2 to
2048^2 image targets on one fixed mesh. Not a test: prints figures. No Blender.

  /usr/bin/python3.11 python_tests/bench/bench_round_scaling.py [--sizes 128,256,512,1024,2048]
      [--scale world|texel] [--world-texels 512] [--sample moss] [--raised-mb 0] [--seed 1] [--module-dir DIR]

Mesh: the benches' UV-unwrapped sheet (cpp_tests/bench/unwrapped_sheet.hpp, rebuilt here in numpy): a bumpy
unit sheet of 187 x 187 quads (69,938 triangles) cut into 4 x 4 UV islands, every other one mirrored, packed
into the unit square with gaps; island UVs span 0.23 of the image per 0.25 world units (0.92 texels per
world unit per texel of image width).

--scale world (default): texels_per_unit (sample pixels per world unit) is the same at every size,
0.92 x world-texels (one sample pixel per texel at 512^2), so the texture keeps its world size: smaller
images undersample it, larger ones magnify it (points per sample pixel = size / world-texels).
--scale texel: one sample pixel per texel at every size (texels_per_unit = 0.92 x size), as
cpp_tests/bench/bench_round.cpp.

Each size runs in a fresh process (so that its peak RSS is its own): surface samples (covered texels of the
finest level), context seconds, synthesis seconds, re-synthesis with the field turned 90 degrees, peak RSS
(ru_maxrss of that process, in MB = 2^20 B; the parent holds only numpy). When a size is refused at the default
limit (1500 MB) the refusal is printed, and the size is run again with max_megabytes raised to 1.25 x the
estimate when the machine has that much memory available (--raised-mb N: that limit instead; 0 = automatic).
Field: +y on the sheet (the texture's up), the re-synthesis uses +x.
"""
import argparse
import json
import os
import re
import subprocess
import sys
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
DEFAULT_LIMIT_MB = 1500.0


def unwrapped_sheet(n=187, blocks=4):
    """positions (V, 3), triangles (T, 3), corner_uvs (T, 3, 2): cpp_tests/bench/unwrapped_sheet.hpp."""
    j, i = np.mgrid[0:n + 1, 0:n + 1]
    x, y = i.ravel() / n, j.ravel() / n
    positions = np.stack([x, y, 0.05 * np.sin(9 * x) * np.cos(7 * y)], 1).astype(np.float32)
    qj, qi = np.mgrid[0:n, 0:n]
    qi, qj = qi.ravel(), qj.ravel()
    bi, bj = qi * blocks // n, qj * blocks // n
    cell = 1.0 / blocks
    gap = 0.04 * cell
    scale = (cell - 2 * gap) * blocks / n
    corners = [(qi, qj), (qi + 1, qj), (qi + 1, qj + 1), (qi, qj + 1)]
    triangles, uvs = [], []
    for split in ((0, 1, 2), (0, 2, 3)):
        tri, uv = [], []
        for k in split:
            ci, cj = corners[k]
            tri.append(cj * (n + 1) + ci)
            lu = (ci - bi * n / blocks) * scale
            lv = (cj - bj * n / blocks) * scale
            lu = np.where((bi + bj) % 2 == 1, (cell - 2 * gap) - lu, lu)
            uv.append(np.stack([bi * cell + gap + lu, bj * cell + gap + lv], 1))
        triangles.append(np.stack(tri, 1))
        uvs.append(np.stack(uv, 1))
    # Interleave the two triangles of each quad as the C++ header does (order only).
    triangles = np.stack(triangles, 1).reshape(-1, 3).astype(np.int32)
    uvs = np.stack(uvs, 1).reshape(-1, 3, 2).astype(np.float32)
    return positions, triangles, uvs


def load_sample(ts, spec):
    path = spec if os.path.exists(spec) else os.path.join(ROOT, "blend_samples", spec + ".png")
    pixels = ts.load_image(path)  # row 0 = top: flip to Blender order (row 0 = bottom)
    return np.ascontiguousarray(pixels[::-1, :, :3], np.float32)


def memory_available_mb():
    with open("/proc/meminfo") as f:
        for line in f:
            if line.startswith("MemAvailable:"):
                return float(line.split()[1]) / 1024.0
    return 0.0


def worker(args):
    sys.path.insert(0, args.module_dir)
    import resource

    import texsynth_native as ts
    size = args.worker
    tpu = 0.92 * (args.world_texels if args.scale == "world" else size)
    positions, triangles, uvs = unwrapped_sheet()
    sample = load_sample(ts, args.sample)
    up = np.tile(np.float32([0, 1, 0]), (len(positions), 1))
    right = np.tile(np.float32([1, 0, 0]), (len(positions), 1))
    result = dict(size=size, texels_per_unit=tpu, limit_mb=args.max_mb)
    try:
        start = time.perf_counter()
        ctx = ts.RoundSynthesisContext(positions, triangles, uvs, width=size, height=size, texels_per_unit=tpu,
                                       max_megabytes=args.max_mb)
        result["context_s"] = time.perf_counter() - start
        result["points"] = ctx.num_points
        result["level_points"] = list(ctx.stats["level_points"])
        result["estimated_mb"] = ctx.stats["estimated_bytes"] / 1e6
        result["context_mb"] = ctx.stats["context_bytes"] / 1e6
        start, cpu = time.perf_counter(), time.process_time()
        out = ts.round_synthesize(ctx, sample, up, seed=args.seed, max_megabytes=args.max_mb)
        result["synth_s"] = time.perf_counter() - start
        result["synth_cpu_s"] = time.process_time() - cpu
        result["synth_estimated_mb"] = out["stats"]["estimated_bytes"] / 1e6
        result["covered"] = int((out["mask"] == 1).sum())
        del out
        start = time.perf_counter()
        out = ts.round_synthesize(ctx, sample, right, seed=args.seed + 1, max_megabytes=args.max_mb)
        result["resynth_s"] = time.perf_counter() - start
        del out
    except ValueError as e:
        result["refused"] = str(e)
    result["peak_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    print("RESULT " + json.dumps(result), flush=True)


def run_size(args, size, limit):
    command = [sys.executable, os.path.abspath(__file__), "--worker", str(size), "--max-mb", str(limit),
               "--scale", args.scale, "--world-texels", str(args.world_texels), "--sample", args.sample,
               "--seed", str(args.seed), "--module-dir", args.module_dir]
    start = time.perf_counter()
    run = subprocess.run(command, capture_output=True, text=True)
    wall = time.perf_counter() - start
    lines = [line for line in run.stdout.splitlines() if line.startswith("RESULT ")]
    if run.returncode or not lines:
        return dict(size=size, limit_mb=limit, failed="exit %d: %s" % (run.returncode, run.stderr[-1500:]),
                    process_s=wall)
    result = json.loads(lines[0][7:])
    result["process_s"] = wall
    return result


def row(r):
    size = "%d^2" % r["size"]
    if "failed" in r:
        return "%-7s %7.0f  worker failed: %s" % (size, r["limit_mb"], r["failed"])
    if "refused" in r:
        return "%-7s %7.0f  refused (%.1f s, peak %.0f MB): %s" % (size, r["limit_mb"], r["process_s"], r["peak_mb"],
                                                                  r["refused"])
    return "%-7s %7.0f %9d %6.2f %7.2f %7.2f %7.2f %7.2f %7.2f %7.0f %7.0f %7.0f" % (
        size, r["limit_mb"], r["points"], 0.92 * r["size"] / r["texels_per_unit"], r["context_s"], r["synth_s"],
        r["synth_cpu_s"], r["context_s"] + r["synth_s"], r["resynth_s"], r["peak_mb"], r["estimated_mb"],
        r["context_mb"])


def main():
    parser = argparse.ArgumentParser(prog="bench_round_scaling")
    parser.add_argument("--sizes", default="128,256,512,1024,2048")
    parser.add_argument("--scale", choices=("world", "texel"), default="world")
    parser.add_argument("--world-texels", type=int, default=512,
                        help="--scale world: the size at which one sample pixel covers one texel")
    parser.add_argument("--sample", default="moss")
    parser.add_argument("--raised-mb", type=float, default=0.0)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--module-dir", default=os.environ.get("TEXSYNTH_MODULE_DIR", os.path.join(ROOT, "addon")))
    parser.add_argument("--worker", type=int, help=argparse.SUPPRESS)
    parser.add_argument("--max-mb", type=float, default=DEFAULT_LIMIT_MB, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        worker(args)
        return
    sizes = [int(s) for s in args.sizes.split(",") if s]
    start = time.perf_counter()
    print("bench_round_scaling: unwrapped sheet (69,938 triangles, 16 islands), sample %s, scale %s%s, seed %d, "
          "%d cores, %.0f MB available, load average %.2f"
          % (args.sample, args.scale, " (1 sample pixel per texel at %d^2)" % args.world_texels
             if args.scale == "world" else " (1 sample pixel per texel)", args.seed, os.cpu_count(),
             memory_available_mb(), os.getloadavg()[0]))
    print("pts/px = points per sample pixel along a line; peak = ru_maxrss of the size's own process; est = the "
          "context's estimated_bytes; ctx = context_bytes (MB = 1e6 B for the last two)")
    header = "%-7s %7s %9s %6s %7s %7s %7s %7s %7s %7s %7s %7s" % (
        "size", "limit", "samples", "pts/px", "ctx s", "synth s", "cpu s", "total", "resyn s", "peak MB", "est MB",
        "ctx MB")
    print(header)
    for size in sizes:
        r = run_size(args, size, DEFAULT_LIMIT_MB)
        print(row(r), flush=True)
        if "refused" in r:
            match = re.search(r"(\d+(?:\.\d+)?) ?MB", r["refused"])
            estimate = float(match.group(1)) if match else 0.0
            limit = args.raised_mb or (round(1.25 * estimate / 100.0 + 0.5) * 100 if estimate else 0)
            available = memory_available_mb()
            if limit and limit < 0.8 * available:
                print(row(run_size(args, size, limit)), flush=True)
            else:
                print("%-7s not run with a raised limit: estimate %.0f MB, %.0f MB available"
                      % ("%d^2" % size, estimate, available))
    print("goals (2 cores, 1024^2 ~700k samples): context + synthesis <= 20 s, re-synthesis <= 5 s, peak <= 1.5 GB")
    print("bench_round_scaling: %.0f s" % (time.perf_counter() - start))


if __name__ == "__main__":
    main()

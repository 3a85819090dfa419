# SPDX-License-Identifier: GPL-3.0-or-later
"""Native side of the Synthesize operator without Blender: synthesize_jumpmap on the benchmark's
839,808-quad bumpy torus (same mesh, sample and scale as bench_addon.py). Prints the median wall
and CPU time (all threads) of the whole call and the core's own `stats["seconds"]`, plus an output checksum so a speed
change can be checked for bit-identical results. Not a test.

  /usr/bin/python3.11 python_tests/bench/bench_native_torus.py [--repeat N] [--module-dir DIR]
"""
import argparse
import hashlib
import os
import statistics
import sys
import tempfile
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def bumpy_torus(segments=1296, rings=648):
    """The arrays bench_addon.bumpy_torus gives Blender (Blender's own corner order)."""
    u = np.linspace(0, 2 * np.pi, segments, endpoint=False)[:, None]
    v = np.linspace(0, 2 * np.pi, rings, endpoint=False)[None, :]
    tube = 0.35 + 0.03 * np.sin(7 * u) * np.sin(5 * v) + 0.02 * np.sin(23 * u + 3 * v)
    positions = np.stack([(1 + tube * np.cos(v)) * np.cos(u), (1 + tube * np.cos(v)) * np.sin(u),
                          tube * np.sin(v) + 0 * u], axis=-1).reshape(-1, 3).astype(np.float32)
    i, j = np.meshgrid(np.arange(segments), np.arange(rings), indexing="ij")
    i1, j1 = (i + 1) % segments, (j + 1) % rings
    quads = np.stack([i * rings + j, i1 * rings + j, i1 * rings + j1, i * rings + j1], axis=-1).reshape(-1)
    faces = segments * rings
    return (positions, quads.astype(np.int32), np.arange(0, 4 * faces, 4, dtype=np.int32),
            np.full(faces, 4, dtype=np.int32))


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--module-dir", default=os.environ.get("TEXSYNTH_MODULE_DIR", os.path.join(ROOT, "addon")))
    args = parser.parse_args()
    sys.path.insert(0, args.module_dir)
    import texsynth_native as ts

    cache_dir = os.path.join(tempfile.gettempdir(), "texsynth_bench_native_cache")
    pre = ts.preprocess(os.path.join(ROOT, "blend_samples", "bricks.png"), cache_dir=cache_dir,
                        neighbourhood=11, tileable=False, seed=0)
    mesh = bumpy_torus()
    scale = pre.width / 0.5  # bench_addon: the sample spans 0.5 world units
    walls, cpus, cores, digest = [], [], [], None
    for _ in range(args.repeat):
        start, start_cpu = time.perf_counter(), time.process_time()
        result = ts.synthesize_jumpmap(pre, *mesh, scale=scale, seed=1)
        walls.append(time.perf_counter() - start)
        cpus.append(time.process_time() - start_cpu)
        cores.append(result["stats"]["seconds"])
        if digest is None:  # outputs of every run are compared by the tests; hash the first only
            h = hashlib.sha256()
            for key in ("base_uv", "blend_uv", "blend_weights"):
                h.update(np.ascontiguousarray(result[key]))
            digest = h.hexdigest()[:16]
        del result
    print("faces %d: synthesize_jumpmap call %.3f s wall, %.3f s CPU (all threads), core %.3f s wall "
          "(medians of %d; wall runs %s), output sha256 %s"
          % (len(mesh[2]), statistics.median(walls), statistics.median(cpus), statistics.median(cores), args.repeat,
             ["%.3f" % t for t in walls], digest))


if __name__ == "__main__":
    main()

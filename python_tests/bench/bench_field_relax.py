# SPDX-License-Identifier: GPL-3.0-or-later
"""Relaxation speed (FieldMesh.compute_field, the step after every comb stroke) of this build
against a baseline build of texsynth_native, alternating in the same run (not a test).

  /usr/bin/python3.11 python_tests/bench/bench_field_relax.py --baseline DIR [--rounds 7] [--faces 100000]

DIR holds the baseline texsynth_native*.so (e.g. copied from a build of the previous commit). Each
round runs one worker process per build, in alternating order; a worker times --calls relaxations
per configuration (sparse anchors, dense anchors, anchors + a source and a sink) and hashes the
outputs, which must be identical between the builds (the change must not alter results).
"""
import argparse
import hashlib
import json
import os
import statistics
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))


def worker(module_dir, faces, calls):
    sys.path.insert(0, module_dir)
    import numpy as np
    import texsynth_native as ts
    sys.path.insert(0, HERE)
    import bench_fields
    arrays = bench_fields.bumpy_torus(faces)
    mesh = ts.FieldMesh(arrays.positions, arrays.corner_verts, arrays.poly_starts, arrays.poly_sizes)
    n = arrays.num_vertices
    rng = np.random.default_rng(0)
    out = {}
    for name, anchors, singular in (("sparse", 300, False), ("dense", n // 4, False), ("singular", 300, True)):
        guide = np.zeros((n, 3), np.float32)
        ids = rng.choice(n, anchors, replace=False)
        guide[ids] = rng.normal(size=(anchors, 3))
        kwargs = dict(orientation="field", direction=guide, axis=(0.0, 0.0, 1.0))
        if singular:
            kwargs.update(sources=np.array([1], np.int32), sinks=np.array([n // 2], np.int32))
        seconds = []
        for _ in range(calls):
            start = time.perf_counter()
            field = mesh.compute_field(**kwargs)
            seconds.append(time.perf_counter() - start)
        out[name] = {"seconds": seconds, "hash": hashlib.sha256(np.ascontiguousarray(field).tobytes()).hexdigest()[:16]}
    print(json.dumps(out))


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--baseline", help="directory with the baseline texsynth_native*.so")
    parser.add_argument("--rounds", type=int, default=7)
    parser.add_argument("--calls", type=int, default=5)
    parser.add_argument("--faces", type=int, default=100000)
    parser.add_argument("--worker", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        return worker(args.worker, args.faces, args.calls)
    if not args.baseline:
        raise SystemExit("--baseline DIR (the old texsynth_native*.so) is required")
    builds = {"baseline": os.path.abspath(args.baseline), "this build": os.path.join(ROOT, "addon")}
    results = {name: [] for name in builds}
    for k in range(args.rounds):
        for name in (list(builds) if k % 2 == 0 else list(builds)[::-1]):
            output = subprocess.run([sys.executable, __file__, "--worker", builds[name], "--faces", str(args.faces),
                                     "--calls", str(args.calls)], check=True, capture_output=True, text=True).stdout
            results[name].append(json.loads(output.strip().splitlines()[-1]))
    print("compute_field on a %d-face torus, %d rounds x %d calls, alternating builds; median (min-max) of the"
          " per-round medians:" % (args.faces, args.rounds, args.calls))
    same = True
    for config in results["baseline"][0]:
        line = "  %-9s" % config
        medians = {}
        for name in builds:
            per_round = [statistics.median(r[config]["seconds"]) for r in results[name]]
            medians[name] = statistics.median(per_round)
            line += "  %s %6.1f ms (%.1f-%.1f)" % (name, 1000 * medians[name], 1000 * min(per_round),
                                                   1000 * max(per_round))
        hashes = {r[config]["hash"] for name in builds for r in results[name]}
        same &= len(hashes) == 1
        print(line + "  ratio %.2f  outputs %s" % (medians["this build"] / medians["baseline"],
                                                   "identical" if len(hashes) == 1 else "DIFFER %s" % hashes))
    if not same:
        raise SystemExit("outputs differ between the builds")


if __name__ == "__main__":
    main()

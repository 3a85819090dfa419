# SPDX-License-Identifier: GPL-3.0-or-later
"""Throughput of the batch runner (addon/texsynth_batch.py) with 1 and 2 local workers on the same jobs, and
its per-job overhead over a bare CLI call, in one run (prints figures; not a test).

  /usr/bin/python3 python_tests/bench/bench_batch.py [--jobs 16] [--out DIR]

The jobs: jump maps on a grid with different seeds, each baking a 64² image (a few seconds of Blender each).
Overhead: the batch's wall time per job with one worker against the mean wall time of the same jobs run one
after the other as bare `blender -b ... texsynth_cli.py` calls."""
import argparse
import json
import os
import pathlib
import shutil
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, os.path.dirname(HERE))
from scene_files import write_grid_obj  # noqa: E402

BATCH = os.path.join(ROOT, "addon", "texsynth_batch.py")
CLI = os.path.join(ROOT, "addon", "texsynth_cli.py")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--jobs", type=int, default=16)
    parser.add_argument("--out", default=None)
    args = parser.parse_args()
    folder = args.out or tempfile.mkdtemp(prefix="texsynth-bench-batch-")
    os.makedirs(folder, exist_ok=True)
    grid = str(write_grid_obj(pathlib.Path(folder) / "grid.obj", cells=8))
    sample = os.path.join(ROOT, "blend_samples", "bricks.png")
    jobs = [{"name": "seed %d" % seed, "input": grid,
             "args": ["--sample", sample, "--seed", str(seed), "--bake-size", "64", "--bake-margin", "2"],
             "outputs": {"bake": "out/seed%d.png" % seed}} for seed in range(args.jobs)]
    manifest = os.path.join(folder, "manifest.json")
    with open(manifest, "w") as handle:
        json.dump({"jobs": jobs}, handle)
    rows = []
    for workers in (1, 2):
        shutil.rmtree(os.path.join(folder, "out"), ignore_errors=True)
        started = time.perf_counter()
        process = subprocess.run([sys.executable, BATCH, "run", manifest, "--workers", str(workers), "--force",
                                  "--out", os.path.join(folder, "report-%d" % workers)],
                                 capture_output=True, text=True)
        seconds = time.perf_counter() - started
        if process.returncode != 0:
            sys.exit(process.stdout[-2000:] + process.stderr[-2000:])
        with open(os.path.join(folder, "report-%d" % workers, "summary.json")) as handle:
            in_worker = [job["seconds"] for job in json.load(handle)["jobs"]]
        rows.append((workers, seconds, 60.0 * args.jobs / seconds, sum(in_worker)))
    bare = []
    for job in jobs[:max(4, args.jobs // 4)]:
        started = time.perf_counter()
        subprocess.run(["blender", "-b", "--factory-startup", "--python-exit-code", "1", "--python", CLI, "--"]
                       + job["args"] + ["--mesh", grid, "--bake", os.path.join(folder, "bare.png")],
                       capture_output=True, check=True)
        bare.append(time.perf_counter() - started)
    mean_bare = sum(bare) / len(bare)
    print("%d jobs (jump map, 64² bake on an 8 x 8 grid), %d cores" % (args.jobs, os.cpu_count() or 0))
    print("%-8s %10s %12s" % ("workers", "seconds", "jobs/min"))
    for workers, seconds, rate, _ in rows:
        print("%-8d %10.1f %12.1f" % (workers, seconds, rate))
    print("scaling 2 workers / 1 worker: %.2f" % (rows[1][2] / rows[0][2]))
    workers, seconds, _, in_worker = rows[0]
    per_job = in_worker / args.jobs
    print("bare CLI call: %.2f s per job (mean of %d); the same call inside a worker: %.2f s (%+.1f %%)"
          % (mean_bare, len(bare), per_job, 100.0 * (per_job / mean_bare - 1.0)))
    print("cluster start, scheduling and stop with 1 worker: %.1f s in all (%.2f s per job over %d jobs)"
          % (seconds - in_worker, (seconds - in_worker) / args.jobs, args.jobs))


if __name__ == "__main__":
    main()

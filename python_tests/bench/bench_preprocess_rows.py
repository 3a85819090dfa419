# SPDX-License-Identifier: GPL-3.0-or-later
"""Issue 16's preprocessing rows: cold preprocess (file decode included, no cache) of photo-like samples,
each size in its own process, printing wall seconds, CPU seconds and peak RSS; with --baseline DIR the
texsynth_native found in DIR (an older build) is timed on the same files in the same run.

Samples: TEXSYNTH_WRITE_SAMPLES=DIR build/cpp_tests/bench/bench_preprocess --benchmark_filter=BM_WriteSamples
(gravel_<size>.png, the synthetic_texture.hpp gravel: no outside data).

    PYTHONPATH=addon /usr/bin/python3.11 python_tests/bench/bench_preprocess_rows.py --samples DIR [--baseline DIR]
"""
import argparse
import json
import os
import subprocess
import sys

CHILD = r"""
import json, resource, sys, time
sys.path.insert(0, sys.argv[1])
import texsynth_native as ts
kwargs = json.loads(sys.argv[3])
start, cpu = time.perf_counter(), time.process_time()
try:
    pre = ts.preprocess(sys.argv[2], **kwargs)
    result = dict(analysed=pre.width, K=pre.num_textons)
except ValueError as error:
    result = dict(refused=str(error)[:160])
result.update(wall=time.perf_counter() - start, cpu=time.process_time() - cpu,
              rss_mb=resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0)
print(json.dumps(result))
"""


def run(module_dir, path, kwargs):
    out = subprocess.run([sys.executable, "-c", CHILD, module_dir, path, json.dumps(kwargs)], capture_output=True,
                         text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    here = os.path.dirname(os.path.abspath(__file__))
    parser.add_argument("--samples", required=True)
    parser.add_argument("--module", default=os.path.join(here, "..", "..", "addon"))
    parser.add_argument("--baseline", default="")
    parser.add_argument("--sizes", default="512,1024,2048,4096,8192")
    args = parser.parse_args()
    print("%-6s %-9s %9s %8s %8s %9s  %s" % ("size", "build", "wall_s", "cpu_s", "rss_MB", "analysed", "note"))
    for size in [int(s) for s in args.sizes.split(",")]:
        path = os.path.join(args.samples, "gravel_%d.png" % size)
        builds = [("new", args.module, {})] + ([("baseline", args.baseline, {})] if args.baseline else [])
        for name, module_dir, kwargs in builds:
            r = run(module_dir, path, kwargs)
            print("%-6d %-9s %9.2f %8.2f %8.0f %9s  %s" % (size, name, r["wall"], r["cpu"], r["rss_mb"],
                                                          r.get("analysed", "-"), r.get("refused", "")), flush=True)


if __name__ == "__main__":
    main()

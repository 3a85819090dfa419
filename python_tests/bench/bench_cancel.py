# SPDX-License-Identifier: GPL-3.0-or-later
"""Cancellation latency of the native calls: time from CancelToken.cancel() (main thread) to the
Cancelled exception in the worker thread, cancelling at several points of a large jump-map synthesis,
a texton synthesis and a preprocessing run. Not a test.

  /usr/bin/python3.11 python_tests/bench/bench_cancel.py [--faces 2000000] [--texton-faces 400000]
"""
import argparse
import os
import statistics
import sys
import threading
import time

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "python_tests", "hostile"))
sys.path.insert(0, os.environ.get("TEXSYNTH_MODULE_DIR") or os.path.join(ROOT, "addon"))
import numpy as np  # noqa: E402
import texsynth_native as tn  # noqa: E402

import make_corpus  # noqa: E402
import worker  # noqa: E402


def latency(call, delay):
    """Seconds from cancel() to the exception, or None when the call finished first."""
    token, done = tn.CancelToken(), {}

    def run():
        try:
            call(token)
        except tn.Cancelled:
            done["at"] = time.perf_counter()

    thread = threading.Thread(target=run)
    thread.start()
    time.sleep(delay)
    cancelled_at = time.perf_counter()
    token.cancel()
    thread.join()
    return done["at"] - cancelled_at if "at" in done else None


def report(name, call, full_seconds):
    delays = np.linspace(0.02, 0.9 * full_seconds, 8)
    values = [latency(call, d) for d in delays]
    measured = [v for v in values if v is not None]
    print("%-12s full run %.2f s; cancel latency over %d points: median %.1f ms, max %.1f ms" % (
        name, full_seconds, len(measured), 1e3 * statistics.median(measured), 1e3 * max(measured)), flush=True)


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--faces", type=int, default=2_000_000)
    parser.add_argument("--texton-faces", type=int, default=400_000)
    args = parser.parse_args()
    pre = tn.preprocess(make_corpus.sample_pixels(), **make_corpus.SMALL_PARAMS)
    mesh = worker.huge_triangle_grid(int(np.sqrt(args.faces / 2)))
    synth = lambda token: tn.synthesize_jumpmap(pre, *mesh, scale=0.05, cancel=token)  # noqa: E731
    start = time.perf_counter()
    synth(None)
    report("synthesis", synth, time.perf_counter() - start)
    texton_mesh = worker.huge_triangle_grid(int(np.sqrt(args.texton_faces / 2)))
    pixels = make_corpus.sample_pixels()
    texton = lambda token: tn.synthesize_texton(pre, pixels, *texton_mesh, scale=0.05, cancel=token)  # noqa: E731
    start = time.perf_counter()
    texton(None)
    report("texton", texton, time.perf_counter() - start)
    regions = lambda token: tn.synthesize_texton(pre, pixels, *texton_mesh, scale=0.05, cancel=token,  # noqa: E731
                                                 seeds_per_component=16)
    start = time.perf_counter()
    regions(None)
    report("texton, 16 regions", regions, time.perf_counter() - start)
    image = np.ascontiguousarray(np.tile(make_corpus.sample_pixels(size=64), (8, 8, 1)))  # 512 x 512
    prep = lambda token: tn.preprocess(image, neighbourhood=7, cancel=token)  # noqa: E731
    start = time.perf_counter()
    prep(None)
    report("preprocess", prep, time.perf_counter() - start)


if __name__ == "__main__":
    main()

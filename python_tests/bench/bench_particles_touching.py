# SPDX-License-Identifier: GPL-3.0-or-later
"""Touching elements (issue 30): does the particle analysis give whole elements when they touch? Not a test:
prints a table. No Blender needed.

  PYTHONPATH=addon /usr/bin/python3.11 python_tests/bench/bench_particles_touching.py [--classes 2,3,4]
  (the cobbles rows need out/corpus/samples/cobbles.png, which python_tests/bench/corpus.py builds, or
  TEXSYNTH_CORPUS_SAMPLES=<folder holding cobbles.png>)

Samples and measures: touching_metrics.py. For each sample and class count it analyses with the defaults
(touching=False: background = the class with the most pixels, 8-connected components) and with touching=True
(background = the lace class, a distance-transform watershed split; --necks lists the touching_neck values,
--depths touching_depth values at the default neck, --shadings touching_shading values),
blur 1, seed 0, tileable as the sample is, and prints the particles, the ground truth's elements, the share in
the ground truth's size range, the share of elements matched at IoU >= 0.5, the count ratio and seconds. The
"mask" rows give the ground truth's element mask as the artist's label image (background 0 given): the split
alone, without k-means (and with touching_shading 1).
"""
import argparse
import os
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, os.environ.get("TEXSYNTH_MODULE_DIR", os.path.join(ROOT, "addon")))
sys.path.insert(0, HERE)
import texsynth_native as tn  # noqa: E402
import particles_corpus_metrics as pcm  # noqa: E402
import touching_metrics as tm  # noqa: E402


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--classes", default="2,3,4")
    parser.add_argument("--necks", default="0.85", help="touching_neck values (0.85 = the default)")
    parser.add_argument("--depths", default="", help="touching_depth values to try at the default neck")
    parser.add_argument("--shadings", default="", help="touching_shading values to try")
    parser.add_argument("--no-darker", action="store_true", help="also touching without the darker classes rule")
    args = parser.parse_args()
    samples = [("packed_pebbles", tm.packed_pebbles())]
    cob = tm.cobbles()
    if cob is None:
        print("cobbles: out/corpus/samples/cobbles.png is missing (python_tests/bench/corpus.py); skipped")
    else:
        samples.append(("cobbles", cob))
    print("%-15s %2s %-14s %9s %8s %8s %8s %6s %6s" % ("sample", "k", "mode", "particles", "elements", "in_range",
                                                        "matched", "ratio", "s"))
    for name, (sample, inst) in samples:
        truth = tm.truth_range(tn, sample, inst)
        print("%-15s ground truth: area %.0f..%.0f px, box aspect %.2f..%.2f" % ((name,) + truth))
        for k in (int(v) for v in args.classes.split(",")):
            modes = [("default", {})] + [("touching %.2f" % float(n), {"touching": True, "touching_neck": float(n)})
                                         for n in args.necks.split(",")]
            modes += [("depth %.2f" % float(d), {"touching": True, "touching_depth": float(d)})
                      for d in args.depths.split(",") if d]
            modes += [("shading %.2f" % float(v), {"touching": True, "touching_shading": float(v)})
                      for v in args.shadings.split(",") if v]
            if args.no_darker:
                modes.append(("no darker", {"touching": True, "touching_darker": False}))
            # The add-on's defaults: Touching Elements Auto, Tileable off with the repeat found at the border
            # (the blur then clamps; particles/core.analysis_tileable).
            modes.append(("add-on auto", {"touching": "auto", "tileable": pcm.looks_tileable(sample),
                                          "wrap_blur": False}))
            for mode, extra in modes:
                t0 = time.perf_counter()
                a = tn.particle_analysis(sample, classes=k, seed=0, **{"tileable": True, **extra})
                seconds = time.perf_counter() - t0
                m = tm.measure(a, inst, truth)
                print("%-15s %2d %-14s %9d %8d %8.2f %8.2f %6.2f %6.2f" % (
                    name, k, mode, m["particles"], m["elements"], m["in_range"], m["matched"], m["count_ratio"],
                    seconds))
        # The split alone: the ground truth's element mask as the artist's label image (1 = element, 0 = not).
        mask = (inst >= 0).astype("int32")
        for mode, extra in (("mask default", {}), ("mask touching", {"touching": True}),
                            ("mask shading 1", {"touching": True, "touching_shading": 1.0})):
            t0 = time.perf_counter()
            a = tn.particle_analysis(sample, labels=mask, background=0, tileable=True, seed=0, **extra)
            seconds = time.perf_counter() - t0
            m = tm.measure(a, inst, truth)
            print("%-15s %2s %-14s %9d %8d %8.2f %8.2f %6.2f %6.2f" % (
                name, "-", mode, m["particles"], m["elements"], m["in_range"], m["matched"], m["count_ratio"],
                seconds))


if __name__ == "__main__":
    main()

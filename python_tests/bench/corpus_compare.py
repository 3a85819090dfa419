# SPDX-License-Identifier: GPL-3.0-or-later
"""Two corpus benchmark results side by side (issue 29's "before and after"), and the round method's goal
against patches. Not a test; figures in docs/benchmarks/corpus.md.

  python3 python_tests/bench/corpus_compare.py BEFORE.json AFTER.json

BEFORE / AFTER: corpus_results.json files written by bench_corpus.py (e.g. `git show
012bf39:docs/benchmarks/corpus_results.json > before.json`). Prints markdown: per method, results / runs and
the medians of seam, detail, patch and complete, before -> after (runs at the defaults only, not the
"+oversized" reruns); then the share of (mesh, sample) pairs where round neighbourhoods are within
ROUND_GOAL of vector-field patches on detail and on the nearest-patch distance.
"""
import json
import statistics
import sys

FIGURES = ("seam", "detail", "patch", "complete")
# Issue 29: round's detail and nearest-patch distance within 20 % of patches' on the same sample and mesh.
ROUND_GOAL = 0.2


def default_runs(results):
    return [r for r in results["runs"] if not r.get("variant")]


def method_summary(runs, method):
    mine = [r for r in runs if r["method"] == method]
    ok = [r for r in mine if r["ok"]]
    medians = {}
    for name in FIGURES:
        values = [r[name] for r in ok if r.get(name) is not None]
        medians[name] = statistics.median(values) if values else None
    return len(ok), len(mine), medians


def round_against_patches(runs, goal=ROUND_GOAL):
    """[(mesh, sample, detail ratio, patch ratio, within)] for every pair where both methods gave a result.
    detail ratio = round / patches (within: >= 1 - goal); patch ratio = round / patches, lower is closer to
    the sample (within: <= 1 + goal)."""
    by_key = {(r["mesh"], r["sample"], r["method"]): r for r in runs if r["ok"]}
    pairs = []
    for (mesh, sample, method), row in sorted(by_key.items()):
        other = by_key.get((mesh, sample, "patches"))
        if method != "round" or other is None or not other.get("detail") or not other.get("patch"):
            continue
        detail = row["detail"] / other["detail"]
        patch = row["patch"] / other["patch"]
        pairs.append((mesh, sample, detail, patch, detail >= 1.0 - goal and patch <= 1.0 + goal))
    return pairs


def fmt(value):
    return "–" if value is None else "%.2f" % value


def main(argv):
    if len(argv) != 2:
        raise SystemExit(__doc__)
    before, after = (default_runs(json.load(open(path))) for path in argv)
    methods = sorted({r["method"] for r in after}, key=("jumpmap", "texton", "round", "patches", "particles").index)
    print("| method | results before → after | " + " | ".join(FIGURES) + " |")
    print("|---|---|" + "---|" * len(FIGURES))
    for method in methods:
        ok0, n0, m0 = method_summary(before, method)
        ok1, n1, m1 = method_summary(after, method)
        cells = ["%s → %s" % (fmt(m0[name]), fmt(m1[name])) for name in FIGURES]
        print("| %s | %d/%d → %d/%d | %s |" % (method, ok0, n0, ok1, n1, " | ".join(cells)))
    for label, runs in (("before", before), ("after", after)):
        pairs = round_against_patches(runs)
        within = sum(p[4] for p in pairs)
        print("\nround within %d %% of patches (%s): %d of %d pairs (%.0f %%)"
              % (ROUND_GOAL * 100, label, within, len(pairs), 100.0 * within / max(1, len(pairs))))
        if label == "after":
            for mesh, sample, detail, patch, ok in pairs:
                if not ok:
                    print("  %s %s: detail %.2f, patch %.2f of patches'" % (mesh, sample, detail, patch))


if __name__ == "__main__":
    main(sys.argv[1:])

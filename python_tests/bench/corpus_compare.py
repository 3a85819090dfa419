# SPDX-License-Identifier: GPL-3.0-or-later
"""Two corpus benchmark results side by side (issue 29's "before and after"), and the round method's goal
against patches. Not a test; figures in docs/benchmarks/corpus.md.

  python3 python_tests/bench/corpus_compare.py BEFORE.json AFTER.json

A defaults sweep (bench_corpus.py --cli-args) runs one method only: AFTER's missing methods are then taken
from BEFORE (so round's goal against patches is counted against the default patches runs), the medians are over
the pairs AFTER ran, and each figure's count of pairs that rose and fell is printed.

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
    """[(mesh, sample, detail ratio, patch ratio, within)] for every pair where patches gave a result.
    detail ratio = round / patches (within: >= 1 - goal); patch ratio = round / patches, lower is closer to
    the sample (within: <= 1 + goal). A round run that failed (e.g. refused by a sweep's memory estimate) is
    a pair outside the goal, with None ratios."""
    patches = {(r["mesh"], r["sample"]): r for r in runs if r["ok"] and r["method"] == "patches"}
    rounds = {(r["mesh"], r["sample"]): r for r in runs if r["method"] == "round"}
    pairs = []
    for key, row in sorted(rounds.items()):
        other = patches.get(key)
        if other is None or not other.get("detail") or not other.get("patch"):
            continue
        if not row["ok"]:
            pairs.append(key + (None, None, False))
            continue
        detail = row["detail"] / other["detail"]
        patch = row["patch"] / other["patch"]
        pairs.append(key + (detail, patch, detail >= 1.0 - goal and patch <= 1.0 + goal))
    return pairs


def fill_from(before, after):
    """after's runs plus before's runs of every method after has none of (a one-method sweep)."""
    present = {r["method"] for r in after}
    return after + [r for r in before if r["method"] not in present]


def moves(before, after, method, figure):
    """(rose, fell) over the pairs where both have the figure: how a sweep moved it, run by run."""
    old = {(r["mesh"], r["sample"]): r.get(figure) for r in before if r["method"] == method and r["ok"]}
    rose = fell = 0
    for r in after:
        value, base = r.get(figure), old.get((r["mesh"], r["sample"]))
        if r["method"] != method or not r["ok"] or value is None or base is None:
            continue
        rose += value > base
        fell += value < base
    return rose, fell


def fmt(value):
    return "–" if value is None else "%.2f" % value


def main(argv):
    if len(argv) != 2:
        raise SystemExit(__doc__)
    before, after = (default_runs(json.load(open(path))) for path in argv)
    methods = sorted({r["method"] for r in after}, key=("jumpmap", "texton", "round", "patches", "particles").index)
    ran = {(r["mesh"], r["sample"]) for r in after}
    before = [r for r in before if (r["mesh"], r["sample"]) in ran]
    after = fill_from(before, after)
    print("| method | results before → after | " + " | ".join(FIGURES) + " |")
    print("|---|---|" + "---|" * len(FIGURES))
    for method in methods:
        ok0, n0, m0 = method_summary(before, method)
        ok1, n1, m1 = method_summary(after, method)
        cells = ["%s → %s" % (fmt(m0[name]), fmt(m1[name])) for name in FIGURES]
        print("| %s | %d/%d → %d/%d | %s |" % (method, ok0, n0, ok1, n1, " | ".join(cells)))
    for method in methods:
        print("\n%s, pairs that rose / fell: %s" % (method, ", ".join(
            "%s %d / %d" % ((name,) + moves(before, after, method, name)) for name in FIGURES)))
    for label, runs in (("before", before), ("after", after)):
        pairs = round_against_patches(runs)
        within = sum(p[4] for p in pairs)
        print("\nround within %d %% of patches (%s): %d of %d pairs (%.0f %%)"
              % (ROUND_GOAL * 100, label, within, len(pairs), 100.0 * within / max(1, len(pairs))))
        if label == "after":
            for mesh, sample, detail, patch, ok in pairs:
                if detail is None:
                    print("  %s %s: round failed" % (mesh, sample))
                elif not ok:
                    print("  %s %s: detail %.2f, patch %.2f of patches'" % (mesh, sample, detail, patch))


if __name__ == "__main__":
    main(sys.argv[1:])

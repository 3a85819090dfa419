# SPDX-License-Identifier: GPL-3.0-or-later
"""corpus_compare.py: the round-against-patches goal on hand-made rows."""
import corpus_compare


def row(mesh, sample, method, detail, patch, ok=True, variant=""):
    return {"mesh": mesh, "sample": sample, "method": method, "detail": detail, "patch": patch, "ok": ok,
            "variant": variant, "seam": 1.0, "complete": 1.0}


def test_round_is_within_the_goal_only_when_both_figures_are():
    runs = [row("bunny", "a", "patches", 0.60, 0.50), row("bunny", "a", "round", 0.50, 0.55),  # 0.83, 1.10
            row("bunny", "b", "patches", 0.60, 0.50), row("bunny", "b", "round", 0.45, 0.55),  # detail 0.75
            row("bunny", "c", "patches", 0.60, 0.50), row("bunny", "c", "round", 0.60, 0.65),  # patch 1.30
            row("bunny", "d", "patches", 0.60, 0.50, ok=False), row("bunny", "d", "round", 0.1, 9.0),
            row("bunny", "e", "patches", 0.60, 0.50), row("bunny", "e", "round", None, None, ok=False),
            row("elk", "a", "round", 0.60, 0.50)]  # no patches result on the elk: not a pair
    pairs = corpus_compare.round_against_patches(runs)
    assert [(p[1], p[4]) for p in pairs] == [("a", True), ("b", False), ("c", False), ("e", False)]
    assert pairs[3][2:4] == (None, None)
    assert abs(pairs[0][2] - 0.5 / 0.6) < 1e-12 and abs(pairs[0][3] - 1.1) < 1e-12


def test_the_summary_skips_reruns_and_counts_failures():
    results = {"runs": [row("bunny", "a", "round", 0.5, 0.5), row("bunny", "b", "round", 0.7, 0.9),
                        row("bunny", "c", "round", None, None, ok=False),
                        row("part", "a", "round", 0.1, 0.1, variant="+oversized")]}
    ok, runs, medians = corpus_compare.method_summary(corpus_compare.default_runs(results), "round")
    assert (ok, runs) == (2, 3) and abs(medians["detail"] - 0.6) < 1e-12 and abs(medians["patch"] - 0.7) < 1e-12


def test_a_one_method_sweep_is_counted_against_the_other_methods_default_runs():
    before = [row("bunny", "a", "patches", 0.60, 0.50), row("bunny", "a", "round", 0.40, 0.55),
              row("bunny", "b", "patches", 0.60, 0.50), row("bunny", "b", "round", 0.50, 0.55)]
    sweep = [row("bunny", "a", "round", 0.50, 0.58), row("bunny", "b", "round", 0.45, 0.55)]
    merged = corpus_compare.fill_from(before, sweep)
    assert [(r["sample"], r["method"]) for r in merged] == [("a", "round"), ("b", "round"), ("a", "patches"),
                                                            ("b", "patches")]
    assert [(p[1], p[4]) for p in corpus_compare.round_against_patches(merged)] == [("a", True), ("b", False)]
    assert corpus_compare.moves(before, sweep, "round", "detail") == (1, 1)
    assert corpus_compare.moves(before, sweep, "round", "patch") == (1, 0)

# SPDX-License-Identifier: GPL-3.0-or-later
"""Hostile corpus against the native API (outside Blender): every case ends in a clear error or a
valid result; none crashes, hangs or half-writes. Cases run in a worker subprocess with a time
bound (python_tests/hostile/run_hostile.py), so a crash is a failed case, not a dead test run."""
import json
import os
import sys

import pytest
import paths

sys.path.insert(0, paths.HOSTILE)

import make_corpus  # noqa: E402
import run_hostile  # noqa: E402

texsynth_native = pytest.importorskip("texsynth_native")


@pytest.fixture(scope="module")
def corpus(tmp_path_factory):
    folder = str(tmp_path_factory.mktemp("hostile"))
    cases = make_corpus.generate(folder, texsynth_native)
    return folder, cases


def test_corpus_covers_every_class(corpus):
    _, cases = corpus
    ids = {c["id"] for c in cases}
    for required in ("image/zero_bytes.png", "image/truncated_half.jpg", "image/truncated_half.exr",
                     "image/1x1.png", "image/huge_16k.png", "image/nan_inf.exr", "image/palette.png",
                     "image/two_channel.png", "image/16bit.png", "image/cmyk.tif", "image/directory.png",
                     "mesh/empty@scale=4", "mesh/one_vertex@scale=4", "mesh/loose_edges_only@scale=4",
                     "mesh/zero_area_faces@scale=4", "mesh/sliver_faces@scale=4", "mesh/duplicate_vertices@scale=4",
                     "mesh/nonmanifold_fan@scale=4", "mesh/inconsistent_winding@scale=4",
                     "mesh/tris_quads_20gon@scale=4", "mesh/coords_1e30@scale=4", "mesh/coords_nan@scale=4",
                     "mesh/coords_inf@scale=4", "synth/components_anchor_on_one", "synth/components_no_anchor",
                     "synth/scale_zero", "synth/scale_negative", "synth/scale_huge", "preprocess/textons_more_than_pixels",
                     "preprocess/neighbourhood_even_4", "preprocess/seed_max", "synth/jump_rate_tiny",
                     "cache/version_mismatch", "cache/hash_mismatch"):
        assert required in ids, required
    mutations = [c for c in cases if c["id"].startswith("cache/") and "@" in c["id"] and "truncated" not in c["id"]]
    assert {c["id"].rsplit("/", 1)[1] for c in mutations} == set(make_corpus.MUTATIONS)
    assert sum(c["id"].startswith("cache/truncated@") for c in cases) >= 30


def test_no_crash_hang_or_partial_write(corpus, capsys):
    folder, cases = corpus
    results = run_hostile.run_cases(folder, os.path.join(folder, "cases.json"), cases)
    line, counts = run_hostile.summary(results)
    with capsys.disabled():  # the counts belong in the CI log
        print("\n" + line)
    failures = ["%s %s: %s" % (r["outcome"], r["id"], r["detail"]) for r in results
                if r["outcome"] in run_hostile.FAILURES]
    assert not failures, "\n".join(failures[:40])
    assert counts["ok"] > 50 and counts["error"] > 500  # both paths really exercised


def test_harness_reports_a_crash_and_a_hang_and_goes_on(tmp_path, monkeypatch):
    """The harness itself: a case that kills the worker and one that never answers are reported
    against the right case, and the cases after them still run."""
    cases = [dict(id="first", kind="preprocess", file="none.png", params={}, expect="error"),
             dict(id="segfault", kind="crash_test", expect="error"),
             dict(id="hang", kind="hang_test", expect="error", timeout=2),
             dict(id="last", kind="preprocess", file="none.png", params={}, expect="error")]
    cases_file = tmp_path / "cases.json"
    cases_file.write_text(json.dumps(cases))
    monkeypatch.setenv("TEXSYNTH_HOSTILE_SELF_TEST", "1")
    results = run_hostile.run_cases(str(tmp_path), str(cases_file), cases)
    assert [r["outcome"] for r in results] == ["error", "crash", "hang", "error"]

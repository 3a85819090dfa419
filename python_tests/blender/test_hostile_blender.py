# SPDX-License-Identifier: GPL-3.0-or-later
"""Hostile corpus through the add-on inside `blender -b` (operator, undo, injected write failures)
and through the headless CLI. Every case ends in a clear error with the mesh byte-identical, or in a
valid result that one undo removes exactly; a Blender crash or hang is reported against its case."""
import collections
import json
import os
import subprocess
import sys

import pytest
import paths

sys.path.insert(0, paths.HOSTILE)

import addon_package  # noqa: E402
import blender_run  # noqa: E402
import blender_cases  # noqa: E402
import make_corpus  # noqa: E402
import run_hostile  # noqa: E402

texsynth_native = pytest.importorskip("texsynth_native")
if not hasattr(texsynth_native, "synthesize_jumpmap"):
    pytest.skip("texsynth_native has no synthesizer", allow_module_level=True)
SCRIPT = os.path.join(paths.BLENDER_SCRIPTS, "tests_hostile.py")
CLI = os.path.join(addon_package.ROOT, "addon", "texsynth_cli.py")


@pytest.fixture(scope="module")
def corpus(tmp_path_factory):
    folder = str(tmp_path_factory.mktemp("hostile_blender"))
    native_cases = make_corpus.generate(folder, texsynth_native)
    return folder, native_cases


def test_operator_on_hostile_cases_never_crashes_or_half_writes(corpus, capsys):
    folder, native_cases = corpus
    cases = blender_cases.generate(folder, native_cases)
    cases_file = os.path.join(folder, "blender_cases.json")
    command = lambda first: [addon_package.BLENDER, "-b", "--factory-startup", "--python-exit-code", "1",  # noqa: E731
                             "--python", SCRIPT, "--", folder, cases_file, str(first)]
    results = run_hostile.run_cases(folder, cases_file, cases, command)
    line, counts = run_hostile.summary(results)
    with capsys.disabled():  # the counts belong in the CI log
        print("\n" + line.replace("hostile native", "hostile blender operator"))
    failures = ["%s %s: %s" % (r["outcome"], r["id"], r["detail"]) for r in results
                if r["outcome"] in run_hostile.FAILURES]
    assert not failures, "\n".join(failures[:40])
    assert counts["ok"] >= 40 and counts["error"] >= 40


def cli_cases(folder):
    """(id, argv after --, expect) for the headless CLI."""
    sample = os.path.join(folder, "images", "sample.png")
    obj = os.path.join(folder, "grid.obj")
    with open(obj, "w") as f:  # 4 x 4 quads, 1 unit each
        f.write("".join("v %d %d 0\n" % (x, y) for y in range(5) for x in range(5)))
        f.write("".join("f %d %d %d %d\n" % (y * 5 + x + 1, y * 5 + x + 2, y * 5 + x + 7, y * 5 + x + 6)
                        for y in range(4) for x in range(4)))
    nan_obj = os.path.join(folder, "nan.obj")
    with open(nan_obj, "w") as f:
        f.write("v 0 0 0\nv 1 0 0\nv nan 1 0\nv 0 1 0\nf 1 2 3 4\n")
    garbage_obj = os.path.join(folder, "garbage.obj")
    with open(garbage_obj, "wb") as f:
        f.write(bytes(range(256)) * 8)
    cases = [("ok", ["--sample", sample, "--mesh", obj, "--scale", "8"], "ok")]
    for image in blender_cases.CLI_IMAGES:
        expect = "ok" if image in ("palette.png", "two_channel.png", "16bit.png") else "either"
        cases.append(("image/" + image, ["--sample", os.path.join(folder, "images", image), "--mesh", obj,
                                         "--scale", "8"], expect))
    for label, extra in (("scale_zero", ["--scale", "0"]), ("scale_negative", ["--scale", "-1"]),
                         ("scale_nan", ["--scale", "nan"]), ("scale_inf", ["--scale", "inf"]),
                         ("scale_tiny", ["--scale", "1e-30"]), ("scale_huge", ["--scale", "1e30"]),
                         ("seed_negative", ["--seed", "-1"]), ("seed_huge", ["--seed", str(2**70)]),
                         ("seed_text", ["--seed", "many"]), ("jump_rate_zero", ["--jump-rate", "0"]),
                         ("jump_rate_nan", ["--jump-rate", "nan"]), ("jump_rate_huge", ["--jump-rate", "1e300"])):
        # A huge world size for the sample only makes texels tiny: a valid (if pointless) result.
        cases.append(("param/" + label, ["--sample", sample, "--mesh", obj] + extra,
                      "ok" if label == "scale_huge" else "error"))
    cases.append(("mesh/nan_coordinates", ["--sample", sample, "--mesh", nan_obj, "--scale", "8"], "either"))
    cases.append(("mesh/garbage_obj", ["--sample", sample, "--mesh", garbage_obj, "--scale", "8"], "either"))
    cases.append(("mesh/missing", ["--sample", sample, "--mesh", obj + ".missing"], "error"))
    return cases


def test_cli_on_hostile_cases_exits_cleanly_and_never_half_writes(corpus, tmp_path, capsys):
    folder, _ = corpus
    counts, failures = collections.Counter(), []
    for case_id, argv, expect in cli_cases(folder):
        out = tmp_path / (case_id.replace("/", "_") + ".blend")
        stats = tmp_path / (case_id.replace("/", "_") + ".json")
        command = [addon_package.BLENDER, "-b", "--factory-startup", "--python-exit-code", "1", "--python", CLI,
                   "--", *argv, "--cache-dir", str(tmp_path / "cache"), "--save", str(out), "--stats", str(stats)]
        try:
            process = subprocess.run(command, capture_output=True, text=True, timeout=blender_run.HANG_SECONDS, errors="replace")
        except subprocess.TimeoutExpired:
            counts["hang"] += 1
            failures.append("hang %s" % case_id)
            continue
        output = process.stdout + process.stderr
        errors = [l for l in output.splitlines() if l.startswith("texsynth_cli: error")]
        if (process.returncode not in (0, 1, 2) or "Traceback" in blender_run.without_blender_noise(output)
                or "Segmentation" in output):
            outcome = "crash"
        elif process.returncode == 0:
            outcome = "ok" if out.exists() and json.loads(stats.read_text()) else "invalid"
        elif not errors:
            outcome = "unclear"
        elif out.exists() or stats.exists():
            outcome = "partial"  # a failed run must not leave an output file behind
        else:
            outcome = "error"
        if outcome in ("ok", "error") and expect != "either" and outcome != expect:
            outcome = "unexpected"
        counts[outcome] += 1
        if outcome not in ("ok", "error"):
            failures.append("%s %s (exit %s): %s" % (outcome, case_id, process.returncode, output[-600:]))
    summary = ("\nhostile blender CLI: %d cases run: %d ok, %d clear errors; crashes %d, hangs %d, partial writes %d, "
          "other failures %d" % (sum(counts.values()), counts["ok"], counts["error"], counts["crash"], counts["hang"],
                                 counts["partial"], sum(counts.values()) - counts["ok"] - counts["error"]
                                 - counts["crash"] - counts["hang"] - counts["partial"]))
    with capsys.disabled():  # the counts belong in the CI log
        print(summary)
    assert not failures, "\n".join(failures)


def test_cancellation_and_modal_operator_inside_blender(capsys):
    """Esc during a 490k-face synthesis: Cancelled within a fraction of a second, mesh untouched."""
    process = subprocess.run([addon_package.BLENDER, "-b", "--factory-startup", "--python-exit-code", "1", "--python",
                              os.path.join(paths.BLENDER_SCRIPTS, "tests_cancel.py")],
                             capture_output=True, text=True, timeout=blender_run.HANG_SECONDS, errors="replace")
    output = process.stdout + process.stderr
    assert process.returncode == 0 and "SUMMARY failed=0" in output, output[-4000:]
    with capsys.disabled():
        print("\n" + next(line for line in output.splitlines() if line.startswith("CANCEL ")))

# SPDX-License-Identifier: GPL-3.0-or-later
"""An artist's day (issue 34): python_tests/blender/workflow_soak.py runs a few hundred random but seeded
steps through TexSynth's real operators, undo, redo and save + reload in one Blender process, checking its
invariants after every step (see that script's docstring). Fails on any violation, naming the step and the
operator. The report (counts, violations, RSS curve) is kept in out/workflow_<blender version>.json.

Always STEPS steps, on a busy machine as on an idle one, so the answer does not depend on the load (400
steps: 25 s on Blender 3.4 and 50 s on 5.2 on an idle machine, 85 s on 3.4 under a load of 8). Longer soaks
run the script directly (its docstring has the command)."""
import json
import os

import pytest

import addon_package
import blender_run

SOAK = os.path.join(blender_run.BLENDER_TESTS, "workflow_soak.py")
SEED = 34
STEPS = 400
WARMUP = 120           # steps before the memory baseline (caches and the 32-step undo stack fill up; 5.2
                       # levels off after about 100 steps, 3.4 sooner)
RSS_BOUND_MB = 150     # allowed RSS growth after the warm-up (see workflow_soak.py; measured in the report)



def format_violation(violation):
    lines = ["step %d, operator %s: %s" % (violation["step"], violation["op"], violation["invariant"])]
    lines += ["    " + line for line in violation["detail"]]
    if violation.get("settings"):
        lines.append("    settings changed in this step: " + violation["settings"])
    lines += ["    before: step " + step for step in violation.get("recent", [])]
    return "\n".join(lines)


@pytest.mark.needs_native
def test_an_artists_day_keeps_every_invariant():
    version = "%d.%d" % addon_package.blender_version()[:2]
    report_path = os.path.join(blender_run.ROOT, "out", "workflow_%s.json" % version)
    if os.path.exists(report_path):
        os.remove(report_path)
    process = blender_run.blender("--python", SOAK, "--", "--steps", str(STEPS), "--seed", str(SEED),
                                  "--warmup", str(WARMUP), "--rss-bound-mb", str(RSS_BOUND_MB),
                                  "--report", report_path)
    output = blender_run.without_blender_noise(process.stdout + process.stderr)
    assert os.path.isfile(report_path), "no report written (exit code %d):\n%s\n%s" % (
        process.returncode, output[-6000:], blender_run.crash_logs(process.stdout + process.stderr))
    with open(report_path) as handle:
        report = json.load(handle)
    start = output.rfind("== TexSynth workflow soak")
    summary = output[start:output.find("\nVIOLATIONS", start)] if start >= 0 else ""
    violations = report["violations"]
    if violations:
        pytest.fail("%d invariant violation(s) in %d steps (seed %d, report %s):\n%s\n\n%s" % (
            len(violations), report["steps"], SEED, report_path,
            "\n".join(format_violation(v) for v in violations[:25]), summary), pytrace=False)
    assert process.returncode == 0, output[-6000:]
    assert report["steps"] == STEPS, "only %d of %d steps ran:\n%s" % (report["steps"], STEPS, summary)
    counts = report["counts"]
    # Every kind of step ran, and the operators did their work (not only failed).
    for name in ("jumpmap", "texton", "round", "patches", "particles", "bake", "clear", "save_reload",
                 "bad_settings", "comb", "field_preset", "singularity"):
        assert counts.get(name, {}).get("steps", 0) > 0, (name, counts)
    for name in ("jumpmap", "texton", "round", "patches", "particles", "bake"):
        assert counts[name].get("finished", 0) > 0, (name, counts[name], report["error_reports"].get(name))
    assert sum(c.get("undo", 0) for c in counts.values()) > 20 and sum(c.get("redo", 0) for c in counts.values()) > 10
    assert report["memory"]["within_bound"], report["memory"]

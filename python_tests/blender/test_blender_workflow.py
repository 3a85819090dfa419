# SPDX-License-Identifier: GPL-3.0-or-later
"""An artist's day (issue 34): python_tests/blender/workflow_soak.py runs a few hundred random but seeded
steps through TexSynth's real operators, undo, redo and save + reload in one Blender process, checking its
invariants after every step (see that script's docstring). Fails on any violation, naming the step and the
operator. The report (counts, violations, RSS curve) is kept in out/workflow_<blender version>.json. On
Blender 5, a crash inside Blender's own code (its log names no TexSynth module) earns one more run; see
test_an_artists_day_keeps_every_invariant.

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


# TexSynth's own native modules: a crash log that names one of them is TexSynth's crash.
OWN_MODULES = ("texsynth_native", "texsynth_image_io")


def run_soak(report_path):
    if os.path.exists(report_path):
        os.remove(report_path)
    return blender_run.blender("--python", SOAK, "--", "--steps", str(STEPS), "--seed", str(SEED),
                               "--warmup", str(WARMUP), "--rss-bound-mb", str(RSS_BOUND_MB),
                               "--report", report_path)


def blender_own_crash(process):
    """Blender's crash log when Blender died of a signal and the log's backtrace names none of TexSynth's
    modules; else None (no crash, no log found, or TexSynth's code on the stack)."""
    if process.returncode >= 0:
        return None
    logs = [text for text in blender_run.read_crash_logs(process.stdout + process.stderr).values()
            if isinstance(text, str)]
    if not logs or any(name in text for text in logs for name in OWN_MODULES):
        return None
    return "\n".join(logs)


@pytest.mark.needs_native
def test_an_artists_day_keeps_every_invariant():
    major, minor = addon_package.blender_version()[:2]
    report_path = os.path.join(blender_run.ROOT, "out", "workflow_%d.%d.json" % (major, minor))
    process = run_soak(report_path)
    # Blender 5 crashes now and then inside its own memfile undo when scripts undo and redo (reported upstream
    # by another add-on's test suite, blender/blender#149890). Here: once on the CI's 5.2 (seed 34, between
    # steps 125 and 136), never in 38 runs on this machine. A crash whose log names none of TexSynth's modules
    # is printed and the same soak runs once more; a second crash, or one in TexSynth's code, fails.
    crash = blender_own_crash(process) if major >= 5 else None
    if crash:
        print("Blender %d.%d crashed inside its own code (exit code %d); the soak runs once more. Its log:\n%s"
              % (major, minor, process.returncode, crash[-4000:]))
        process = run_soak(report_path)
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


def test_only_a_crash_in_blenders_own_code_earns_a_second_run(tmp_path):
    import subprocess
    log = tmp_path / "workflow.crash.txt"

    def crashed(backtrace, code=-11):
        log.write_text("# Blender 5.2.2\n# backtrace\n" + backtrace)
        return subprocess.CompletedProcess([], code, "STEP 100\n", "Writing: %s\n" % log)

    blender_frames = "/usr/bin/blender(BKE_memfile_undo_decode+0x4c) [0x55d1]\n"
    ours = "/src/addon/texsynth_native.cpython-314-x86_64-linux-gnu.so(+0x1f2a0) [0x7f10]\n"
    assert "BKE_memfile_undo_decode" in blender_own_crash(crashed(blender_frames))
    assert blender_own_crash(crashed(blender_frames + ours)) is None  # TexSynth's code on the stack
    assert blender_own_crash(crashed(blender_frames, code=1)) is None  # a failure, not a crash
    log.unlink()
    assert blender_own_crash(subprocess.CompletedProcess([], -11, "", "Writing: %s\n" % log)) is None  # no log

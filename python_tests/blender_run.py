# SPDX-License-Identifier: GPL-3.0-or-later
"""Launches Blender subprocesses for the pytest tests."""
import os
import re
import subprocess

import addon_package

ROOT = addon_package.ROOT
SAMPLES = os.path.join(ROOT, "blend_samples")
BLENDER_TESTS = os.path.join(ROOT, "python_tests", "blender")


# Subprocess timeouts only catch hangs: generous enough that no load on the machine can reach them (a suite
# takes up to ~2 minutes on an idle 2-core machine and a few times that under load).
HANG_SECONDS = 1800


def blender(*args, blend_file=None, env=None, timeout=HANG_SECONDS):
    """Runs `blender -b [blend_file] --factory-startup --python-exit-code 1 <args>`; returns CompletedProcess."""
    command = [addon_package.BLENDER, "-b"] + ([blend_file] if blend_file else []) + \
        ["--factory-startup", "--python-exit-code", "1"] + list(args)
    full_env = dict(os.environ)
    full_env.update(env or {})
    return subprocess.run(command, cwd=ROOT, capture_output=True, text=True, timeout=timeout, env=full_env)


def read_crash_logs(output):
    """{path: text} of the crash logs Blender wrote ("Writing: <file>.crash.txt" in its output) that can be
    read: their backtrace names the native function that crashed, which the test output alone does not."""
    logs = {}
    for path in sorted(set(re.findall(r"Writing: (\S+\.crash\.txt)", output))):
        try:
            with open(path, errors="replace") as handle:
                logs[path] = handle.read()[-8000:]
        except OSError as error:
            logs[path] = error
    return logs


def crash_logs(output):
    """The crash logs of read_crash_logs as one text for a failure message (or why one could not be read)."""
    return "\n".join("== %s%s" % (path, ": %s" % text if isinstance(text, OSError) else "\n" + text)
                     for path, text in read_crash_logs(output).items())


def cli(*cli_args, blend_file=None, env=None):
    """Runs the headless CLI (with the contract double when the real synthesizer is not built)."""
    if addon_package.real_synthesizer_available():
        script = os.path.join(ROOT, "addon", "texsynth_cli.py")
    else:
        script = os.path.join(BLENDER_TESTS, "cli_with_fake_native.py")
    return blender("--python", script, "--", *cli_args, blend_file=blend_file, env=env)


def error_lines(process):
    return [line for line in (process.stdout + process.stderr).splitlines() if line.startswith("texsynth_cli: error")]


# Debian sid's Blender 5.2 prints this at every start: its extension manager (bl_pkg) imports cattrs,
# which Debian does not package. It is Blender's own add-on, not TexSynth, and changes nothing else.
_BLENDER_OWN_NOISE = re.compile(r"Traceback \(most recent call last\):\n(?:[ \t].*\n)*?"
                                r"ModuleNotFoundError: No module named 'cattrs'\n")


def without_blender_noise(output):
    """Blender's output without the tracebacks Blender itself prints on some distributions."""
    return _BLENDER_OWN_NOISE.sub("", output)


def run_failing(*args, code, fragment):
    """Runs the CLI with args; asserts the exit code and one error line containing fragment, and returns it."""
    process = cli(*args)
    lines = error_lines(process)
    assert process.returncode == code, process.stdout[-2000:] + process.stderr[-2000:]
    assert len(lines) == 1 and fragment.lower() in lines[0].lower(), lines
    return lines[0]

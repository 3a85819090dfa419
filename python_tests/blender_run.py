# SPDX-License-Identifier: GPL-3.0-or-later
"""Launches Blender subprocesses for the pytest tests."""
import os
import subprocess

import addon_package

ROOT = addon_package.ROOT
SAMPLES = os.path.join(ROOT, "blend_samples")
BLENDER_TESTS = os.path.join(ROOT, "python_tests", "blender")


def blender(*args, blend_file=None, env=None, timeout=300):
    """Runs `blender -b [blend_file] --factory-startup --python-exit-code 1 <args>`; returns CompletedProcess."""
    command = [addon_package.BLENDER, "-b"] + ([blend_file] if blend_file else []) + \
        ["--factory-startup", "--python-exit-code", "1"] + list(args)
    full_env = dict(os.environ)
    full_env.update(env or {})
    return subprocess.run(command, cwd=ROOT, capture_output=True, text=True, timeout=timeout, env=full_env)


def cli(*cli_args, blend_file=None, env=None):
    """Runs the headless CLI (with the contract double when the real synthesizer is not built)."""
    if addon_package.real_synthesizer_available():
        script = os.path.join(ROOT, "addon", "texsynth_cli.py")
    else:
        script = os.path.join(BLENDER_TESTS, "cli_with_fake_native.py")
    return blender("--python", script, "--", *cli_args, blend_file=blend_file, env=env)


def error_lines(process):
    return [line for line in (process.stdout + process.stderr).splitlines() if line.startswith("texsynth_cli: error")]

# SPDX-License-Identifier: GPL-3.0-or-later
"""Runs the blend-group render checks inside Blender (python_tests/blender/tests_shading.py)."""
import os

import addon_package
import blender_run
import pytest


@pytest.mark.skipif(not addon_package.real_synthesizer_available(), reason="texsynth_native not built")
def test_blend_group_renders_inside_blender():
    process = blender_run.blender("--python", os.path.join(blender_run.BLENDER_TESTS, "tests_shading.py"))
    output = process.stdout + process.stderr
    assert process.returncode == 0 and "SUMMARY failed=0" in output, output[-6000:]
    assert output.count("PASS test_") == 4, output[-3000:]

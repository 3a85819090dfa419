# SPDX-License-Identifier: GPL-3.0-or-later
"""Runs the blend-group render checks inside Blender (python_tests/blender/tests_shading.py)."""
import os

import pytest

import addon_package
import blender_run
import blender_suite


SHADING_SUITE = os.path.join(blender_run.BLENDER_TESTS, "tests_shading.py")


@pytest.mark.skipif(not addon_package.real_synthesizer_available(), reason="texsynth_native not built")
@pytest.mark.parametrize("check", blender_suite.check_names(SHADING_SUITE))
def test_shading_check_inside_blender(check):
    blender_suite.assert_check(SHADING_SUITE, check)

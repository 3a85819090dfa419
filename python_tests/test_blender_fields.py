# SPDX-License-Identifier: GPL-3.0-or-later
"""Direction/scale fields inside Blender (python_tests/blender/tests_fields.py) and the CLI's field flags."""
import os

import pytest

import addon_package
import blender_run

SCENE = os.path.join(blender_run.SAMPLES, "scene.blend")
BRICKS = os.path.join(blender_run.SAMPLES, "bricks.png")


def _native_has_fields():
    try:
        import texsynth_native
    except ImportError:
        return False
    return addon_package.real_synthesizer_available() and hasattr(texsynth_native, "RayCaster")


needs_native = pytest.mark.skipif(not _native_has_fields(), reason="texsynth_native with RayCaster not built")


@needs_native
def test_field_suite_inside_blender():
    process = blender_run.blender("--python", os.path.join(blender_run.BLENDER_TESTS, "tests_fields.py"))
    output = process.stdout + process.stderr
    assert process.returncode == 0 and "SUMMARY failed=0" in output, output[-6000:]
    assert output.count("PASS test_") >= 10, output[-3000:]


@needs_native
@pytest.mark.parametrize("args, code, fragment", [
    (("--direction-attribute", "NoSuchField"), 1, "NoSuchField"),
    (("--scale-attribute", "NoSuchScale"), 1, "NoSuchScale"),
    (("--scale-group", "NoSuchGroup"), 1, "NoSuchGroup"),
    (("--scale-group", "G", "--scale-range", "0", "1"), 2, "--scale-range"),
    (("--scale-group", "G", "--scale-attribute", "S"), 2, "not allowed"),
])
def test_cli_field_flags_report_bad_input(args, code, fragment):
    process = blender_run.cli("--sample", BRICKS, "--object", "Suzanne", *args, blend_file=SCENE)
    lines = blender_run.error_lines(process)
    assert process.returncode == code, process.stdout[-2000:] + process.stderr[-2000:]
    assert len(lines) == 1 and fragment.lower() in lines[0].lower(), lines

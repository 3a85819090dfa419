# SPDX-License-Identifier: GPL-3.0-or-later
"""Direction/scale fields inside Blender (python_tests/blender/tests_fields.py) and the CLI's field flags."""
import os
import shutil
import subprocess

import pytest

import addon_package
import blender_run
import blender_suite

SCENE = os.path.join(blender_run.SAMPLES, "scene.blend")
BRICKS = os.path.join(blender_run.SAMPLES, "bricks.png")


def _native_has_fields():
    try:
        import texsynth_native
    except ImportError:
        return False
    return addon_package.real_synthesizer_available() and hasattr(texsynth_native, "RayCaster")


needs_native = pytest.mark.skipif(not _native_has_fields(), reason="texsynth_native with RayCaster not built")


FIELDS_SUITE = os.path.join(blender_run.BLENDER_TESTS, "tests_fields.py")


@needs_native
@pytest.mark.parametrize("check", blender_suite.check_names(FIELDS_SUITE))
def test_fields_check_inside_blender(check):
    blender_suite.assert_check(FIELDS_SUITE, check)


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


@needs_native
@pytest.mark.skipif(shutil.which("xvfb-run") is None, reason="xvfb-run not installed (scripts/install_deps.sh)")
def test_interactive_tools_with_simulated_mouse_events():
    """Comb modal, Ctrl-drag erase, sidebar-started Source pick and the overlay in a real (virtual) window."""
    command = ["xvfb-run", "-a", "-s", "-screen 0 1280x800x24", addon_package.BLENDER, "--factory-startup",
               "--enable-event-simulate", "--python", os.path.join(blender_run.BLENDER_TESTS, "gui_fields.py")]
    process = subprocess.run(command, cwd=blender_run.ROOT, capture_output=True, text=True, timeout=blender_run.HANG_SECONDS)
    output = process.stdout + process.stderr
    assert "GUI SUMMARY failed=0" in output, output[-4000:]
    assert output.count("PASS ") >= 8, output[-3000:]

# SPDX-License-Identifier: GPL-3.0-or-later
"""Runs the add-on test suite inside Blender (python_tests/blender/tests_addon.py)."""
import os
import warnings

import addon_package
import blender_run


def test_addon_suite_inside_blender():
    process = blender_run.blender("--python", os.path.join(blender_run.BLENDER_TESTS, "tests_addon.py"))
    output = process.stdout + process.stderr
    assert process.returncode == 0 and "SUMMARY failed=0" in output, output[-6000:]
    assert output.count("PASS test_") >= 25, output[-3000:]
    if addon_package.real_synthesizer_available():
        assert "NATIVE real" in output, "the suite must use the real module once it is built"
    else:
        warnings.warn("texsynth_native has no synthesize_jumpmap yet: the add-on suite ran on the contract double")


def test_enabling_without_native_module_does_not_fail(tmp_path):
    """Install a copy of the add-on without the .so in a user scripts dir and enable it like a user."""
    import shutil
    addons = tmp_path / "scripts" / "addons"
    shutil.copytree(os.path.join(addon_package.ROOT, "addon"), addons / "texsynth",
                    ignore=shutil.ignore_patterns("*.so", "__pycache__"))
    script = ("import addon_utils, bpy, sys\n"
              "mod = addon_utils.enable('texsynth', default_set=True, handle_error=None)\n"
              "assert mod is not None, 'enable failed'\n"
              "assert hasattr(bpy.types.Scene, 'texsynth')\n"
              "print('REASON', mod.native.reason())\n"
              "addon_utils.disable('texsynth')\n"
              "assert not hasattr(bpy.types.Scene, 'texsynth')\n")
    process = blender_run.blender("--python-expr", script, env={"BLENDER_USER_SCRIPTS": str(tmp_path / "scripts")})
    output = process.stdout + process.stderr
    assert process.returncode == 0, output[-3000:]
    assert "REASON native module missing" in output, output[-3000:]


def test_addon_suite_on_the_contract_double():
    """The same suite against fake_native.py: the add-on's I/O checked independently of the synthesizer."""
    process = blender_run.blender("--python", os.path.join(blender_run.BLENDER_TESTS, "tests_addon.py"),
                                  env={"TEXSYNTH_FAKE_NATIVE": "1"})
    output = process.stdout + process.stderr
    assert "NATIVE fake" in output
    assert process.returncode == 0 and "SUMMARY failed=0" in output, output[-6000:]

# SPDX-License-Identifier: GPL-3.0-or-later
"""Runs the add-on test suite inside Blender (python_tests/blender/tests_addon.py)."""
import os
import warnings

import pytest

import addon_package
import blender_run
import blender_suite


ADDON_SUITE = os.path.join(blender_run.BLENDER_TESTS, "tests_addon.py")


@pytest.mark.parametrize("check", blender_suite.check_names(ADDON_SUITE))
def test_addon_check_inside_blender(check):
    blender_suite.assert_check(ADDON_SUITE, check)


def test_addon_suite_uses_the_real_module_once_built():
    output = blender_suite.run(ADDON_SUITE).output
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


# Makes NumPy unimportable in Blender's Python, as on Debian's blender without python3-numpy.
HIDE_NUMPY = ("import sys\n"
              "class HideNumpy:\n"
              "    def find_spec(self, name, path=None, target=None):\n"
              "        if name == 'numpy' or name.startswith('numpy.'):\n"
              "            raise ModuleNotFoundError(\"No module named 'numpy'\")\n"
              "sys.meta_path.insert(0, HideNumpy())\n"
              "for name in [n for n in sys.modules if n == 'numpy' or n.startswith('numpy.')]:\n"
              "    del sys.modules[name]\n")


def test_a_package_for_another_python_says_which_in_console_sidebar_and_cli(tmp_path):
    """Issue 31: a package built for another Python names both versions when enabled (console and sidebar
    reason) and the CLI exits 1 with that line, never an import traceback."""
    import re
    import shutil
    addons = tmp_path / "scripts" / "addons"
    shutil.copytree(os.path.join(addon_package.ROOT, "addon"), addons / "texsynth",
                    ignore=shutil.ignore_patterns("*.so", "__pycache__"))
    (addons / "texsynth" / "texsynth_native.cpython-399-x86_64-linux-gnu.so").write_bytes(b"\x7fELF")
    expected = re.compile(r"native module built for another Python: this TexSynth package is built for Python 3\.99 "
                          r"on Linux \(texsynth_native\.cpython-399-x86_64-linux-gnu\.so\), but this Blender runs "
                          r"Python 3\.\d+ on Linux")
    script = ("import addon_utils\n"
              "mod = addon_utils.enable('texsynth', default_set=True, handle_error=None)\n"
              "assert mod is not None, 'enable failed'\n"
              "print('REASON', mod.native.reason())\n")
    env = {"BLENDER_USER_SCRIPTS": str(tmp_path / "scripts")}
    process = blender_run.blender("--python-expr", script, env=env)
    output = process.stdout + process.stderr
    assert process.returncode == 0, output[-3000:]
    console = [line for line in output.splitlines() if line.startswith("TexSynth: ")]
    assert any(expected.search(line) for line in console), output[-3000:]
    assert any(line.startswith("REASON ") and expected.search(line) for line in output.splitlines()), output[-3000:]
    bricks = os.path.join(addon_package.ROOT, "blend_samples", "bricks.png")
    cli = blender_run.blender("--python", str(addons / "texsynth" / "texsynth_cli.py"), "--", "--sample", bricks,
                              "--object", "Cube",
                              env=env)
    cli_output = cli.stdout + cli.stderr
    assert cli.returncode == 1, cli_output[-3000:]
    # No TexSynth frame in any traceback (sid's Blender 5.2 prints one of its own: bl_pkg lacks cattrs there).
    assert expected.search(cli_output), cli_output[-3000:]
    assert not re.search(r'File "[^"]*texsynth[^"]*", line', cli_output), cli_output[-3000:]


def test_enabling_without_numpy_says_so_in_one_sentence(tmp_path):
    import shutil
    addons = tmp_path / "scripts" / "addons"
    shutil.copytree(os.path.join(addon_package.ROOT, "addon"), addons / "texsynth",
                    ignore=shutil.ignore_patterns("__pycache__"))
    script = HIDE_NUMPY + (
        "import addon_utils, bpy\n"
        "mod = addon_utils.enable('texsynth', default_set=True, handle_error=None)\n"
        "assert mod is not None, 'enable failed'\n"
        "print('UNSUPPORTED', mod.UNSUPPORTED)\n"
        "assert bpy.types.TEXSYNTH_PT_unavailable.is_registered\n"
        "assert not hasattr(bpy.types.Scene, 'texsynth')\n"
        "addon_utils.disable('texsynth')\n"
        "assert 'TEXSYNTH_PT_unavailable' not in dir(bpy.types)\n"
        "print('DISABLED')\n")
    process = blender_run.blender("--python-expr", script, env={"BLENDER_USER_SCRIPTS": str(tmp_path / "scripts")})
    output = blender_run.without_blender_noise(process.stdout + process.stderr)
    assert process.returncode == 0 and "DISABLED" in output, output[-3000:]
    assert "UNSUPPORTED TexSynth needs NumPy" in output and "python3-numpy" in output, output[-3000:]
    assert "Traceback" not in output, output[-3000:]
    cli = blender_run.blender("--python-expr", HIDE_NUMPY, "--python",
                              os.path.join(addon_package.ROOT, "addon", "texsynth_cli.py"), "--",
                              "--sample", os.path.join(blender_run.SAMPLES, "bricks.png"), "--object", "Suzanne",
                              blend_file=os.path.join(blender_run.SAMPLES, "scene.blend"))
    lines = blender_run.error_lines(cli)
    assert cli.returncode == 1 and len(lines) == 1 and "needs NumPy" in lines[0], cli.stdout[-2000:] + cli.stderr[-2000:]


def test_addon_suite_on_the_contract_double():
    """The same suite against fake_native.py: the add-on's I/O checked independently of the synthesizer."""
    process = blender_run.blender("--python", os.path.join(blender_run.BLENDER_TESTS, "tests_addon.py"),
                                  env={"TEXSYNTH_FAKE_NATIVE": "1"})
    output = process.stdout + process.stderr
    assert "NATIVE fake" in output
    assert process.returncode == 0 and "SUMMARY failed=0" in output, output[-6000:]

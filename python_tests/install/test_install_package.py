# SPDX-License-Identifier: GPL-3.0-or-later
"""The add-on's install routes: scripts/install_addon.sh (link or copy + enable + save prefs) and
scripts/package_addon.sh (zip for Preferences > Add-ons > Install), in throwaway Blender user dirs."""
import os
import subprocess
import zipfile

import pytest

import addon_package

ROOT = addon_package.ROOT


def user_dirs(tmp_path):
    return {"BLENDER_USER_SCRIPTS": str(tmp_path / "scripts"), "BLENDER_USER_CONFIG": str(tmp_path / "config")}


CHECK_ENABLED = ("import addon_utils, sys\n"
                 "loaded_default, loaded_state = addon_utils.check('texsynth')\n"
                 "print('ENABLED', loaded_default, loaded_state)\n"
                 "mod = sys.modules['texsynth']\n"
                 "print('NATIVE', mod.native.get() is not None, mod.native.reason())\n")


def blender_with_prefs(env, script):
    """Blender WITHOUT --factory-startup, so the saved preferences (enabled add-ons) load."""
    full_env = dict(os.environ, **env)
    return subprocess.run([addon_package.BLENDER, "-b", "--python-exit-code", "1", "--python-expr", script],
                          capture_output=True, text=True, env=full_env, cwd=ROOT, timeout=1800)


@pytest.mark.parametrize("mode", ["link", "copy"])
def test_install_script_enables_addon_persistently(tmp_path, mode):
    env = user_dirs(tmp_path)
    args = ["bash", os.path.join(ROOT, "scripts", "install_addon.sh")] + (["--copy"] if mode == "copy" else [])
    install = subprocess.run(args, capture_output=True, text=True, env=dict(os.environ, **env), timeout=1800)
    assert install.returncode == 0, install.stdout + install.stderr
    target = tmp_path / "scripts" / "addons" / "texsynth"
    assert target.is_symlink() == (mode == "link") and (target / "__init__.py").is_file()
    check = blender_with_prefs(env, CHECK_ENABLED)
    assert "ENABLED True True" in check.stdout, check.stdout[-2000:] + check.stderr[-2000:]
    assert "NATIVE True" in check.stdout, check.stdout[-2000:]


@pytest.mark.skipif(addon_package.blender_version()[:2] >= (4, 2),
                    reason="4.2+ installs extensions: scripts/test.sh builds them (package_addon.sh trixie sid) and "
                           "installs each in a runtime-only environment (blender_envs.sh install-check)")
def test_package_zip_installs_with_native_module(tmp_path):
    package = subprocess.run(["bash", os.path.join(ROOT, "scripts", "package_addon.sh")], capture_output=True,
                             text=True, timeout=1800)
    assert package.returncode == 0, package.stdout + package.stderr
    zips = [line.split()[1] for line in package.stdout.splitlines() if line.startswith("package_addon: ")]
    assert len(zips) == 1 and os.path.isfile(zips[0]), package.stdout
    major, minor, _ = addon_package.blender_version()
    assert os.path.basename(zips[0]).startswith("texsynth-0.1.0-blender%d.%d-py3" % (major, minor)), zips[0]
    names = zipfile.ZipFile(zips[0]).namelist()
    assert all(name.startswith("texsynth/") for name in names)
    for required in ("__init__.py", "native.py", "bridge/mesh_io.py", "core/settings.py", "uv_methods/core.py",
                     "texsynth_cli.py", "blender_manifest.toml"):
        assert "texsynth/" + required in names
    assert any(n.startswith("texsynth/texsynth_native") and n.endswith(".so") for n in names)
    env = user_dirs(tmp_path)
    install = ("import bpy, addon_utils\n"
               "bpy.ops.preferences.addon_install(filepath=%r)\n"
               "assert addon_utils.enable('texsynth', default_set=True, handle_error=None) is not None\n"
               "bpy.ops.wm.save_userpref()\n" % zips[0])
    first = blender_with_prefs(env, install)
    assert first.returncode == 0, first.stdout[-2000:] + first.stderr[-2000:]
    assert (tmp_path / "scripts" / "addons" / "texsynth" / "__init__.py").is_file()
    check = blender_with_prefs(env, CHECK_ENABLED)
    assert "ENABLED True True" in check.stdout and "NATIVE True" in check.stdout, check.stdout[-2000:]

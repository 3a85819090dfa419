# SPDX-License-Identifier: GPL-3.0-or-later
"""Bake (addon/bake/): the checks inside Blender (python_tests/blender/tests_bake.py) and the CLI's
--bake flags end to end in a subprocess."""
import json
import os

import pytest

import blender_run
import blender_suite
from blender_run import run_failing
from scene_files import png_size, write_grid_obj

BRICKS = os.path.join(blender_run.SAMPLES, "bricks.png")


BAKE_SUITE = os.path.join(blender_run.BLENDER_TESTS, "tests_bake.py")


@pytest.mark.needs_native
@pytest.mark.parametrize("check", blender_suite.check_names(BAKE_SUITE))
def test_bake_check_inside_blender(check):
    blender_suite.assert_check(BAKE_SUITE, check)


@pytest.mark.needs_native
def test_cli_bake_writes_the_png_and_stats(tmp_path):
    mesh = write_grid_obj(tmp_path / "grid.obj")
    out, stats_path, saved = tmp_path / "out.png", tmp_path / "stats.json", tmp_path / "out.blend"
    process = blender_run.cli("--sample", BRICKS, "--mesh", str(mesh), "--scale", "2",
                              "--cache-dir", str(tmp_path / "cache"), "--stats", str(stats_path), "--save", str(saved),
                              "--bake", str(out), "--bake-uv", "UVMap", "--bake-size", "256", "--bake-material")
    assert process.returncode == 0, process.stdout[-3000:] + process.stderr[-3000:]
    assert png_size(out) == (256, 256)
    stats = json.loads(stats_path.read_text())
    assert stats["seconds"]["bake"] > 0 and stats["bake"]["uv_map"] == "UVMap", stats
    assert stats["bake"]["size"] == [256, 256] and not stats["bake"]["created_uv"]
    # The saved .blend has the baked material assigned, reading out.png through UVMap.
    check = ("import bpy\nobj = bpy.data.objects[%r]\n"
             "m = obj.material_slots[0].material\nprint('MATERIAL', m.name)\n"
             "assert m.name.startswith('TexSynth Baked: ')\n"
             "t = next(n for n in m.node_tree.nodes if n.type == 'TEX_IMAGE')\n"
             "assert bpy.path.abspath(t.image.filepath) == %r, t.image.filepath\n"
             "uv = next(n for n in m.node_tree.nodes if n.type == 'UVMAP')\nassert uv.uv_map == 'UVMap'\n"
             % (stats["objects"][0], str(out)))
    reopened = blender_run.blender("--python-expr", check, blend_file=str(saved))
    assert reopened.returncode == 0, reopened.stdout[-2000:] + reopened.stderr[-2000:]


@pytest.mark.parametrize("extra, fragment", [
    (("--bake", "OUT", "--bake-size", "0"), "bake size"),
    (("--bake", "OUT", "--bake-size", "99999"), "bake size"),
    (("--bake", "OUT", "--bake-margin", "-3"), "bake margin"),
    (("--bake", "OUT", "--bake-uv", "TexSynth"), "islands overlap"),
    (("--bake-size", "256",), "--bake-size needs --bake"),
    (("--bake", "OUT.xyz"), "image file name"),
    (("--bake", "/no/such/dir/out.png"), "does not exist"),
])
def test_cli_bad_bake_arguments_exit_2_with_one_line(tmp_path, extra, fragment):
    mesh = write_grid_obj(tmp_path / "grid.obj")
    extra = tuple(str(tmp_path / "out.png") if a == "OUT" else str(tmp_path / "out.xyz") if a == "OUT.xyz" else a
                  for a in extra)
    run_failing("--sample", BRICKS, "--mesh", str(mesh), "--scale", "2", *extra, code=2, fragment=fragment)
    assert not (tmp_path / "out.png").exists()


@pytest.mark.needs_native
@pytest.mark.parametrize("extra, fragment", [
    (("--material", "none", "--bake-uv", "UVMap"), "no TexSynth result"),
    (("--bake-uv", "Missing"), "no UV map 'Missing'"),
])
def test_cli_bake_failures_exit_1(tmp_path, extra, fragment):
    mesh = write_grid_obj(tmp_path / "grid.obj")
    run_failing("--sample", BRICKS, "--mesh", str(mesh), "--scale", "2", "--cache-dir", str(tmp_path / "cache"),
                "--bake", str(tmp_path / "out.png"), *extra, code=1, fragment=fragment)
    assert not (tmp_path / "out.png").exists()

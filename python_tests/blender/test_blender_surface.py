# SPDX-License-Identifier: GPL-3.0-or-later
"""Surface-colour methods (addon/surface_colour/): the checks inside Blender
(python_tests/blender/tests_surface.py) and the CLI's --method round end to end in a subprocess."""
import json
import os

import pytest

import blender_run
import blender_suite
from blender_run import run_failing
from scene_files import png_size, write_grid_obj

BRICKS = os.path.join(blender_run.SAMPLES, "bricks.png")


SURFACE_SUITE = os.path.join(blender_run.BLENDER_TESTS, "tests_surface.py")


@pytest.mark.needs_native
@pytest.mark.parametrize("check", blender_suite.check_names(SURFACE_SUITE))
def test_surface_check_inside_blender(check):
    blender_suite.assert_check(SURFACE_SUITE, check)


@pytest.mark.needs_native
def test_cli_round_writes_the_image_the_material_and_native_seconds(tmp_path):
    mesh = write_grid_obj(tmp_path / "grid.obj")
    out, stats_path, saved = tmp_path / "round.png", tmp_path / "stats.json", tmp_path / "round.blend"
    process = blender_run.cli("--sample", BRICKS, "--mesh", str(mesh), "--method", "round", "--scale", "3",
                              "--stats", str(stats_path), "--save", str(saved),
                              "--bake", str(out), "--bake-uv", "UVMap", "--bake-size", "128")
    assert process.returncode == 0, process.stdout[-3000:] + process.stderr[-3000:]
    assert png_size(out) == (128, 128)
    stats = json.loads(stats_path.read_text())
    assert stats["seconds"]["synthesis"] > 0 and "bake" not in stats["seconds"], stats["seconds"]
    name = stats["objects"][0]
    assert stats["native"][name]["surface_samples"] == 128 * 128, stats["native"][name]
    check = ("import bpy\nm = bpy.data.objects[%r].material_slots[0].material\n"
             "t = next(n for n in m.node_tree.nodes if n.type == 'TEX_IMAGE')\n"
             "assert bpy.path.abspath(t.image.filepath) == %r, t.image.filepath\n"
             "assert next(n for n in m.node_tree.nodes if n.type == 'UVMAP').uv_map == 'UVMap'\n" % (name, str(out)))
    reopened = blender_run.blender("--python-expr", check, blend_file=str(saved))
    assert reopened.returncode == 0, reopened.stdout[-2000:] + reopened.stderr[-2000:]


@pytest.mark.needs_native
def test_cli_round_vertex_target(tmp_path):
    mesh = write_grid_obj(tmp_path / "grid.obj", cells=40)
    stats_path = tmp_path / "stats.json"
    process = blender_run.cli("--sample", BRICKS, "--mesh", str(mesh), "--method", "round", "--scale", "10",
                              "--target", "vertices", "--stats", str(stats_path))
    assert process.returncode == 0, process.stdout[-3000:] + process.stderr[-3000:]
    stats = json.loads(stats_path.read_text())
    assert any("colour attribute 'TexSynth_Colour'" in line for line in stats["outputs"]), stats["outputs"]


@pytest.mark.parametrize("extra, fragment", [
    (("--method", "round", "--target", "vertices", "--bake", "OUT"), "drop --bake"),
    (("--target", "vertices"), "--target is for --method round"),
    (("--method", "round", "--bake", "OUT", "--bake-material"), "--bake-material is for"),
])
def test_cli_bad_round_arguments_exit_2_with_one_line(tmp_path, extra, fragment):
    mesh = write_grid_obj(tmp_path / "grid.obj")
    extra = tuple(str(tmp_path / "out.png") if a == "OUT" else a for a in extra)
    run_failing("--sample", BRICKS, "--mesh", str(mesh), *extra, code=2, fragment=fragment)
    assert not (tmp_path / "out.png").exists()


@pytest.mark.needs_native
@pytest.mark.parametrize("extra, fragment", [
    (("--levels", "9"), "round levels must be an integer in [1, 6]"),
    (("--bake-size", "8192"), "MB"),
])
def test_cli_round_failures_exit_1_and_write_nothing(tmp_path, extra, fragment):
    mesh = write_grid_obj(tmp_path / "grid.obj")
    run_failing("--sample", BRICKS, "--mesh", str(mesh), "--method", "round", "--bake", str(tmp_path / "out.png"),
                "--bake-uv", "UVMap", *extra, code=1, fragment=fragment)
    assert not (tmp_path / "out.png").exists()

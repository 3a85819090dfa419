# SPDX-License-Identifier: GPL-3.0-or-later
"""Vector-field patches in Blender: the checks inside Blender (python_tests/blender/tests_patches.py) and
the CLI's --method patches end to end in a subprocess."""
import json
import os

import pytest

import blender_run
import blender_suite
from blender_run import run_failing
from scene_files import png_size, write_grid_obj

BRICKS = os.path.join(blender_run.SAMPLES, "bricks.png")


PATCHES_SUITE = os.path.join(blender_run.BLENDER_TESTS, "tests_patches.py")


@pytest.mark.needs_native
@pytest.mark.parametrize("check", blender_suite.check_names(PATCHES_SUITE))
def test_patches_check_inside_blender(check):
    blender_suite.assert_check(PATCHES_SUITE, check)


@pytest.mark.needs_native
@pytest.mark.parametrize("mode", ["sampling", "optimisation"])
def test_cli_patches_writes_the_image_and_native_seconds(tmp_path, mode):
    mesh = write_grid_obj(tmp_path / "grid.obj")
    out, stats_path = tmp_path / "patches.png", tmp_path / "stats.json"
    extra = ("--iterations", "2") if mode == "optimisation" else ()
    process = blender_run.cli("--sample", BRICKS, "--mesh", str(mesh), "--method", "patches", "--mode", mode,
                              "--patch-size", "16", "--scale", "3", "--stats", str(stats_path),
                              "--cache-dir", str(tmp_path / "cache"), "--bake", str(out), "--bake-uv", "UVMap",
                              "--bake-size", "128", *extra)
    assert process.returncode == 0, process.stdout[-3000:] + process.stderr[-3000:]
    assert png_size(out) == (128, 128)
    stats = json.loads(stats_path.read_text())
    name = stats["objects"][0]
    native = stats["native"][name]
    assert native["surface_samples"] == 128 * 128 and native["mode"] == mode.upper(), native
    assert native["seconds_synthesis"] > 0 and stats["seconds"]["synthesis"] >= native["seconds_synthesis"]
    assert any(f.startswith("patches-") for f in os.listdir(tmp_path / "cache")), "analysed sample cached"


@pytest.mark.needs_native
def test_cli_patches_vertex_target(tmp_path):
    mesh = write_grid_obj(tmp_path / "grid.obj", cells=40)
    stats_path = tmp_path / "stats.json"
    process = blender_run.cli("--sample", BRICKS, "--mesh", str(mesh), "--method", "patches", "--patch-size", "16",
                              "--scale", "10", "--target", "vertices", "--stats", str(stats_path))
    assert process.returncode == 0, process.stdout[-3000:] + process.stderr[-3000:]
    stats = json.loads(stats_path.read_text())
    assert any("colour attribute 'TexSynth_Colour'" in line for line in stats["outputs"]), stats["outputs"]


@pytest.mark.parametrize("extra, code, fragment", [
    (("--method", "round", "--mode", "sampling"), 2, "--mode is for --method patches"),
    (("--method", "texton", "--patch-size", "16"), 2, "--patch-size is for --method patches"),
    (("--method", "patches", "--iterations", "3"), 2, "--iterations is for --mode optimisation"),
    (("--method", "patches", "--patch-size", "30"), 1, "multiple of 4"),
    (("--method", "patches", "--tolerance", "0.5"), 1, "tolerance"),
])
def test_cli_patches_bad_arguments_exit_with_one_line(tmp_path, extra, code, fragment):
    mesh = write_grid_obj(tmp_path / "grid.obj")
    run_failing("--sample", BRICKS, "--mesh", str(mesh), *extra, code=code, fragment=fragment)

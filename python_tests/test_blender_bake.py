# SPDX-License-Identifier: GPL-3.0-or-later
"""Bake (addon/bake/): the checks inside Blender (python_tests/blender/tests_bake.py) and the CLI's
--bake flags end to end in a subprocess."""
import json
import os
import struct

import pytest

import addon_package
import blender_run
import blender_suite

BRICKS = os.path.join(blender_run.SAMPLES, "bricks.png")
needs_native = pytest.mark.skipif(not addon_package.real_synthesizer_available(), reason="texsynth_native not built")


BAKE_SUITE = os.path.join(blender_run.BLENDER_TESTS, "tests_bake.py")


@needs_native
@pytest.mark.parametrize("check", blender_suite.check_names(BAKE_SUITE))
def test_bake_check_inside_blender(check):
    blender_suite.assert_check(BAKE_SUITE, check)


def write_grid_obj(path, cells=4, size=2.0):
    """A size x size grid of cells x cells quads in the xy plane with planar UVs (u, v) = (x, y) / size + .5."""
    lines, n = [], cells + 1
    for j in range(n):
        for i in range(n):
            x, y = (i / cells - 0.5) * size, (j / cells - 0.5) * size
            lines.append("v %g %g 0" % (x, y))
            lines.append("vt %g %g" % (i / cells, j / cells))
    for j in range(cells):
        for i in range(cells):
            a = j * n + i + 1
            corners = (a, a + 1, a + n + 1, a + n)
            lines.append("f " + " ".join("%d/%d" % (c, c) for c in corners))
    path.write_text("\n".join(lines) + "\n")
    return path


def png_size(path):
    with open(path, "rb") as handle:
        header = handle.read(24)
    assert header[:8] == b"\x89PNG\r\n\x1a\n", header[:8]
    return struct.unpack(">II", header[16:24])


def run_failing(*args, code, fragment):
    process = blender_run.cli(*args)
    lines = blender_run.error_lines(process)
    assert process.returncode == code, process.stdout[-2000:] + process.stderr[-2000:]
    assert len(lines) == 1 and fragment.lower() in lines[0].lower(), lines
    return lines[0]


@needs_native
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


@needs_native
@pytest.mark.parametrize("extra, fragment", [
    (("--material", "none", "--bake-uv", "UVMap"), "no TexSynth result"),
    (("--bake-uv", "Missing"), "no UV map 'Missing'"),
])
def test_cli_bake_failures_exit_1(tmp_path, extra, fragment):
    mesh = write_grid_obj(tmp_path / "grid.obj")
    run_failing("--sample", BRICKS, "--mesh", str(mesh), "--scale", "2", "--cache-dir", str(tmp_path / "cache"),
                "--bake", str(tmp_path / "out.png"), *extra, code=1, fragment=fragment)
    assert not (tmp_path / "out.png").exists()

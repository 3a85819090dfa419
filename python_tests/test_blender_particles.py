# SPDX-License-Identifier: GPL-3.0-or-later
"""Texture Particles in Blender: the checks inside Blender (python_tests/blender/tests_particles.py) and the
CLI's --method particles end to end in a subprocess. The end-to-end checks need the native place_particles
and decal_mesh: skipped while the module lacks them (they are not faked)."""
import ast
import json
import os

import numpy as np
import pytest

import addon_package
import blender_run
from test_blender_bake import run_failing, write_grid_obj

needs_native = pytest.mark.skipif(not addon_package.real_synthesizer_available(), reason="texsynth_native not built")


def _has(*names):
    try:
        import texsynth_native
    except ImportError:
        return False
    return all(hasattr(texsynth_native, name) for name in names)


needs_placement = pytest.mark.skipif(not _has("place_particles", "decal_mesh"),
                                     reason="texsynth_native has no place_particles / decal_mesh yet")
SUITE = os.path.join(blender_run.BLENDER_TESTS, "tests_particles.py")


def suite_names():
    """(every test of the suite, the end-to-end ones): read from its source, which needs bpy to import."""
    tree = ast.parse(open(SUITE).read())
    names = [node.name for node in tree.body if isinstance(node, ast.FunctionDef) and node.name.startswith("test_")]
    full = next(ast.literal_eval(node.value) for node in tree.body if isinstance(node, ast.Assign)
                and getattr(node.targets[0], "id", "") == "FULL_RUN_TESTS")
    return names, tuple(full)


ALL_TESTS, FULL_RUN = suite_names()


def run_suite(*names):
    process = blender_run.blender("--python", SUITE, "--", *names)
    output = process.stdout + process.stderr
    assert process.returncode == 0 and "SUMMARY failed=0" in output, output[-6000:]
    return output


@needs_native
def test_particles_view_and_outputs_inside_blender():
    names = [name for name in ALL_TESTS if name not in FULL_RUN]
    output = run_suite(*names)
    assert output.count("PASS test_") == len(names) >= 17, output[-3000:]


@needs_native
@needs_placement
def test_particles_end_to_end_inside_blender():
    output = run_suite(*FULL_RUN)
    assert output.count("PASS test_") == len(FULL_RUN), output[-3000:]


def write_png(path, pixels):
    """An 8-bit RGB PNG of (H, W, 3) uint8 pixels (row 0 = top), written with zlib (no bpy here)."""
    import struct
    import zlib
    raw = b"".join(b"\x00" + row.tobytes() for row in pixels)

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xffffffff)
    height, width = pixels.shape[:2]
    with open(path, "wb") as handle:
        handle.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0))
                     + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))
    return str(path)


def pebbles_png(path, flat=False):
    """Ground with 4 stones and 2 leaves (or the ground alone)."""
    pixels = np.zeros((64, 96, 3), np.uint8)
    pixels[:] = (51, 77, 64)
    if not flat:
        for x0, y0 in [(8, 8), (40, 8), (70, 30), (20, 40)]:
            pixels[y0:y0 + 10, x0:x0 + 10] = (230, 51, 25)
        for x0, y0 in [(55, 6), (82, 40)]:
            pixels[y0:y0 + 14, x0:x0 + 6] = (25, 153, 25)
    return write_png(path, pixels)


@needs_native
@needs_placement
def test_cli_particles_writes_decals_and_stats(tmp_path):
    mesh = write_grid_obj(tmp_path / "grid.obj", cells=30)
    stats_path, blend = tmp_path / "stats.json", tmp_path / "out.blend"
    process = blender_run.cli("--sample", pebbles_png(tmp_path / "pebbles.png"), "--mesh", str(mesh),
                              "--method", "particles", "--classes", "3", "--blur", "0", "--scale", "1.5",
                              "--particle-output", "both", "--instances", "example",
                              "--stats", str(stats_path), "--save", str(blend),
                              "--cache-dir", str(tmp_path / "cache"))
    assert process.returncode == 0, process.stdout[-3000:] + process.stderr[-3000:]
    stats = json.loads(stats_path.read_text())
    name = stats["objects"][0]
    per_class = stats["native"][name]["per_class"]
    assert sum(per_class.values()) == stats["native"][name]["placed"] > 0
    classes = sum(1 for count in per_class.values() if count)
    # a decal object and a points object per class that got particles
    assert any(line.endswith("in %d object(s)" % (2 * classes)) for line in stats["outputs"]), stats["outputs"]
    assert blend.is_file() and any(f.startswith("particles-") for f in os.listdir(tmp_path / "cache"))


@pytest.mark.parametrize("extra, code, fragment", [
    (("--method", "jumpmap", "--classes", "3"), 2, "--classes is for --method particles"),
    (("--method", "particles", "--particle-output", "instances"), 2, "--instances"),
    (("--method", "particles", "--classes", "20"), 1, "particle classes"),
    (("--method", "particles", "--size-jitter", "2"), 1, "size jitter"),
])
def test_cli_particles_bad_arguments_exit_with_one_line(tmp_path, extra, code, fragment):
    mesh = write_grid_obj(tmp_path / "grid.obj")
    run_failing("--sample", os.path.join(blender_run.SAMPLES, "bricks.png"), "--mesh", str(mesh), *extra,
                code=code, fragment=fragment)


@needs_native
def test_cli_particles_one_colour_sample_fails_clearly(tmp_path):
    mesh = write_grid_obj(tmp_path / "grid.obj")
    run_failing("--sample", pebbles_png(tmp_path / "flat.png", flat=True), "--mesh", str(mesh),
                "--method", "particles", code=1, fragment="no particles")

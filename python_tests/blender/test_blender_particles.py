# SPDX-License-Identifier: GPL-3.0-or-later
"""Texture Particles in Blender: the checks inside Blender (python_tests/blender/tests_particles.py) and the
CLI's --method particles end to end in a subprocess. The end-to-end checks need the native place_particles
and decal_mesh: skipped while the module lacks them (they are not faked)."""
import json
import os

import numpy as np
import pytest

import blender_run
import blender_suite
from blender_run import run_failing
from scene_files import pebbles_png, write_grid_obj



def _has(*names):
    try:
        import texsynth_native
    except ImportError:
        return False
    return all(hasattr(texsynth_native, name) for name in names)


needs_placement = pytest.mark.skipif(not _has("place_particles", "decal_mesh"),
                                     reason="texsynth_native has no place_particles / decal_mesh yet")
SUITE = os.path.join(blender_run.BLENDER_TESTS, "tests_particles.py")


ALL_TESTS = blender_suite.check_names(SUITE)
FULL_RUN = tuple(blender_suite.module_constant(SUITE, "FULL_RUN_TESTS"))
VIEW_AND_OUTPUTS = tuple(name for name in ALL_TESTS if name not in FULL_RUN)


@pytest.mark.needs_native
@pytest.mark.parametrize("check", VIEW_AND_OUTPUTS)
def test_particles_view_and_outputs_inside_blender(check):
    blender_suite.assert_check(SUITE, check, *VIEW_AND_OUTPUTS)


@pytest.mark.needs_native
@needs_placement
@pytest.mark.parametrize("check", FULL_RUN)
def test_particles_end_to_end_inside_blender(check):
    blender_suite.assert_check(SUITE, check, *FULL_RUN)


def cli_particles(tmp_path, *extra):
    """The CLI's particles run on a 30 x 30 grid of the pebbles; returns its stats."""
    mesh = write_grid_obj(tmp_path / "grid.obj", cells=30)
    stats_path = tmp_path / "stats.json"
    process = blender_run.cli("--sample", pebbles_png(tmp_path / "pebbles.png"), "--mesh", str(mesh),
                              "--method", "particles", "--classes", "3", "--blur", "0", "--scale", "1.5",
                              "--stats", str(stats_path), "--cache-dir", str(tmp_path / "cache"), *extra)
    assert process.returncode == 0, process.stdout[-3000:] + process.stderr[-3000:]
    return json.loads(stats_path.read_text())


@pytest.mark.needs_native
@needs_placement
def test_cli_touching_keys_its_own_analysis_and_places_the_stones(tmp_path):
    # The pebbles' stones and leaves are separated, so --touching finds the same six elements, through an
    # analysis of its own (a second cache entry: the plain one is not reused).
    plain = cli_particles(tmp_path)
    touching = cli_particles(tmp_path, "--touching")
    assert touching["cache_status"] == "analysis built", touching["cache_status"]
    assert len(list((tmp_path / "cache").glob("particles-*.bin"))) == 2
    assert touching["native"]["grid"]["placed"] > 0
    assert abs(touching["native"]["grid"]["placed"] - plain["native"]["grid"]["placed"]) <= \
        0.15 * plain["native"]["grid"]["placed"]


@pytest.mark.needs_native
@needs_placement
def test_cli_particles_writes_decals_and_stats(tmp_path):
    blend = tmp_path / "out.blend"
    stats = cli_particles(tmp_path, "--particle-output", "both", "--instances", "example", "--save", str(blend))
    name = stats["objects"][0]
    per_class = stats["native"][name]["per_class"]
    assert sum(per_class.values()) == stats["native"][name]["placed"] > 0
    classes = sum(1 for count in per_class.values() if count)
    # a decal object and a points object per class that got particles
    assert any(line.endswith("in %d object(s)" % (2 * classes)) for line in stats["outputs"]), stats["outputs"]
    assert blend.is_file() and any(f.startswith("particles-") for f in os.listdir(tmp_path / "cache"))


@pytest.mark.needs_native
@needs_placement
def test_cli_particles_bake_composites_the_decals_into_the_image(tmp_path):
    from scene_files import png_size
    baked = tmp_path / "baked.png"
    stats = cli_particles(tmp_path, "--bake", str(baked), "--bake-size", "128")
    layers = sum(1 for count in stats["native"][stats["objects"][0]]["per_class"].values() if count)
    assert any(note.startswith("particles: %d class layer(s) composited" % layers) for note in stats["bake"]["notes"]), \
        stats["bake"]
    assert png_size(baked) == (128, 128)

@pytest.mark.needs_native
@needs_placement
def test_cli_write_labels_writes_the_segmentation_and_labels_reads_it_back(tmp_path):
    import texsynth_native
    written = tmp_path / "labels.png"
    first = cli_particles(tmp_path, "--write-labels", str(written))
    labels = texsynth_native.load_image(str(written))
    sample = texsynth_native.load_image(str(tmp_path / "pebbles.png"))
    assert labels.shape[:2] == sample.shape[:2]
    colours = np.unique(np.round(labels[:, :, :3] * 255).astype(np.int32).reshape(-1, 3), axis=0)
    assert len(colours) == 3, colours  # --classes 3: one flat colour per class
    again = tmp_path / "again"
    again.mkdir()
    second = cli_particles(again, "--labels", str(written))
    placed = [stats["native"][stats["objects"][0]]["placed"] for stats in (first, second)]
    assert placed[1] > 0 and abs(placed[1] - placed[0]) <= 0.15 * placed[0], placed


@pytest.mark.parametrize("extra, code, fragment", [
    (("--method", "jumpmap", "--classes", "3"), 2, "--classes is for --method particles"),
    (("--method", "particles", "--particle-output", "instances"), 2, "--instances"),
    (("--method", "particles", "--classes", "20"), 1, "particle classes"),
    (("--method", "particles", "--size-jitter", "2"), 1, "size jitter"),
    (("--method", "particles", "--background", "none", "--bake", "out.png"), 2, "drop --background none"),
    (("--method", "jumpmap", "--write-labels", "labels.png"), 2, "--write-labels is for --method particles"),
    (("--method", "jumpmap", "--touching"), 2, "--touching is for --method particles"),
])
def test_cli_particles_bad_arguments_exit_with_one_line(tmp_path, extra, code, fragment):
    mesh = write_grid_obj(tmp_path / "grid.obj")
    run_failing("--sample", os.path.join(blender_run.SAMPLES, "bricks.png"), "--mesh", str(mesh), *extra,
                code=code, fragment=fragment)


@pytest.mark.needs_native
def test_cli_particles_over_the_cap_are_refused_before_placement(tmp_path):
    # A 2 x 2 grid under a sample 1 mm wide: hundreds of millions of particles. Refused with the scale that fits.
    mesh = write_grid_obj(tmp_path / "grid.obj")
    run_failing("--sample", pebbles_png(tmp_path / "pebbles.png"), "--mesh", str(mesh), "--method", "particles",
                "--scale", "0.001", code=1, fragment="raise Scale (CLI --scale) to at least")


@pytest.mark.needs_native
def test_cli_particles_one_colour_sample_fails_clearly(tmp_path):
    mesh = write_grid_obj(tmp_path / "grid.obj")
    run_failing("--sample", pebbles_png(tmp_path / "flat.png", flat=True), "--mesh", str(mesh),
                "--method", "particles", code=1, fragment="no particles")

# SPDX-License-Identifier: GPL-3.0-or-later
"""bpy-free part of Texture Particles (addon/particles/core.py) under plain pytest: settings ranges, label
images, merges, the analysis cache and the refusals of unusable samples, the segmentation preview, atlas
packing, decal rectangles and instance frames. Expected values are worked out from the inputs."""
import math
import os

import re

import numpy as np
import pytest

import addon_package

core_settings = addon_package.load("core.settings")
core = addon_package.load("particles.core")
outputs = addon_package.load("particles.outputs")

GROUND = np.array([0.2, 0.3, 0.25], np.float32)
STONE = np.array([0.9, 0.8, 0.3], np.float32)
LEAF = np.array([0.1, 0.6, 0.1], np.float32)


def settings(**changes):
    values = dict(method="PARTICLES", particle_classes=3, particle_blur=0.0)
    values.update(changes)
    return core_settings.Settings(**values)


def pebbles(width=96, height=64):
    """Ground with four 10 px stones and two 6 x 14 px leaves, rows bottom-first."""
    img = np.tile(GROUND, (height, width, 1))
    for x0, y0 in [(8, 8), (40, 8), (70, 30), (20, 40)]:
        img[y0:y0 + 10, x0:x0 + 10] = STONE
    for x0, y0 in [(55, 6), (82, 40)]:
        img[y0:y0 + 14, x0:x0 + 6] = LEAF
    return img


# -- settings -----------------------------------------------------------------------------------

@pytest.mark.parametrize("changes, fragment", [
    (dict(particle_classes=1), "particle classes"), (dict(particle_classes=13), "particle classes"),
    (dict(particle_blur=-1.0), "blur"), (dict(particle_blur=float("nan")), "blur"),
    (dict(particle_min_area=-2), "minimum particle area"), (dict(particle_background_class=-2), "background class"),
    (dict(particle_merges=((1, 1),)), "merge"), (dict(particle_class_order=(1, 1)), "class order"),
    (dict(particle_output="SPRITES"), "particle output"),
    (dict(particle_output="INSTANCES"), "instance collection"),
    (dict(particle_size_jitter=0.95), "size jitter"), (dict(particle_background="ROUND"), "particle background"),
])
def test_particle_settings_are_checked(changes, fragment):
    with pytest.raises(core_settings.SettingsError, match=fragment):
        settings(**changes).validate()


def test_particle_defaults_validate_and_other_methods_ignore_them():
    assert settings().validate().method == "PARTICLES"
    assert "PARTICLES" in core_settings.METHODS
    core_settings.Settings(method="JUMPMAP", particle_classes=99).validate()  # not checked for other methods
    settings(particle_output="BOTH", particle_collection="Thorns", particle_size_jitter=0.9).validate()


def test_class_lists_and_merges_parse():
    assert core.parse_class_list("2, 0 1") == (2, 0, 1) and core.parse_class_list("") == ()
    assert core.parse_merges("3>1, 2>0") == ((3, 1), (2, 0)) and core.format_merges(((3, 1),)) == "3>1"
    with pytest.raises(core_settings.SettingsError, match="class numbers"):
        core.parse_class_list("a, 1")
    with pytest.raises(core_settings.SettingsError, match="a>b"):
        core.parse_merges("3-1")


# -- labels and merges --------------------------------------------------------------------------

def test_label_image_gives_one_class_per_colour_by_first_appearance():
    rgba = np.zeros((4, 5, 4), np.float32)
    rgba[..., :3] = (1.0, 0.0, 0.0)      # class 0: the first pixel (bottom-left)
    rgba[2:, 3:, :3] = (0.0, 0.0, 1.0)   # appears in row 2
    rgba[1, 1, :3] = (0.0, 1.0, 0.0)     # appears in row 1: class 1
    labels = core.labels_from_image(rgba, 5, 4)
    assert labels.dtype == np.int32 and labels.shape == (4, 5)
    assert labels[0, 0] == 0 and labels[1, 1] == 1 and labels[3, 4] == 2 and np.count_nonzero(labels == 2) == 4


def test_label_image_of_the_wrong_size_or_colours_is_refused():
    with pytest.raises(core_settings.SettingsError, match="is 5 x 4 pixels but the sample is 6 x 4"):
        core.labels_from_image(np.zeros((4, 5, 4), np.float32), 6, 4)
    noisy = np.random.default_rng(0).random((8, 8, 4)).astype(np.float32)
    with pytest.raises(core_settings.SettingsError, match="at most 12 classes"):
        core.labels_from_image(noisy, 8, 8)
    with pytest.raises(core_settings.SettingsError, match="one colour"):
        core.labels_from_image(np.ones((8, 8, 4), np.float32), 8, 8)


def test_merges_join_classes_in_order_and_renumber():
    labels = np.array([[0, 1, 2, 3]], np.int32)
    merged, mapping = core.merge_labels(labels, ((3, 1), (1, 0)))
    assert merged.tolist() == [[0, 0, 1, 0]] and mapping.tolist() == [0, 0, 1, 0]
    assert core.original_id(1, 4, ((3, 1), (1, 0))) == 2
    with pytest.raises(core_settings.SettingsError, match="does not have"):
        core.merge_labels(labels, ((5, 0),))


# -- analysis (native) ----------------------------------------------------------------------------

native = pytest.importorskip("texsynth_native")
addon_native = addon_package.load("native")
addon_native._module, addon_native._reason, addon_native._tried = native, None, True  # one copy of the module


def test_analysis_is_cached_in_memory_by_sample_and_parameters():
    cache = core.AnalysisCache()
    sample = pebbles()
    first, source = core.analyse(sample, settings(), cache=cache)
    assert source == "built"
    again, source = core.analyse(sample, settings(), cache=cache)
    assert source == "memory" and again is first
    _, source = core.analyse(sample, settings(particle_blur=0.5), cache=cache)
    assert source == "built"
    changed = sample.copy()
    changed[0, 0] = STONE
    assert core.analyse(changed, settings(), cache=cache)[1] == "built"


def repeating_pebbles(width=96, height=64):
    """Noisy ground whose 10 px stones wrap round the border: a sample that repeats. 4 stones, two of them cut
    in two by the border (one across the left/right edges, one across the top/bottom)."""
    img = np.tile(GROUND, (height, width, 1)) + np.random.default_rng(3).normal(0, 0.005, (height, width, 1))
    for x0, y0 in [(20, 20), (50, 35), (-5, 30), (70, -4)]:
        img[np.ix_(np.arange(y0, y0 + 10) % height, np.arange(x0, x0 + 10) % width)] = STONE
    return np.ascontiguousarray(img, np.float32)


def test_a_sample_that_repeats_is_analysed_as_tileable_with_the_classes_of_an_untiled_analysis():
    """Tileable off: a sample whose edges continue each other has its cut stones joined (4 particles, all
    complete, and the report says why), with the classes k-means finds without Tileable (the blur clamps: the
    same labels); a crop of it that no longer repeats stays untiled."""
    sample = repeating_pebbles()
    cache = core.AnalysisCache()
    two = dict(particle_blur=1.0, particle_classes=2)
    analysis, _ = core.analyse(sample, settings(**two), cache=cache)
    assert analysis.tileable
    assert (len(analysis.particles["class"]), int(analysis.particles["complete"].sum())) == (4, 4)
    untiled = native.particle_analysis(sample, classes=2, blur=1.0, tileable=False)
    assert np.array_equal(analysis.labels, untiled.labels)
    assert len(untiled.particles["class"]) == 6
    assert any("repeats across its border" in note for note in core.check_usable(analysis, settings()))
    crop = np.ascontiguousarray(sample[:, 3:-6])
    cropped, _ = core.analyse(crop, settings(**two), cache=cache)
    assert not cropped.tileable
    assert not any("repeats" in note for note in core.check_usable(cropped, settings()))
    chosen, _ = core.analyse(sample, settings(tileable=True, **two), cache=cache)
    assert chosen.tileable and not any("repeats" in n for n in core.check_usable(chosen, settings(tileable=True)))
    assert core.analysis_key(sample, settings()) != core.analysis_key(crop, settings())


@pytest.mark.skipif(not hasattr(native, "save_particle_analysis"), reason="no save/load_particle_analysis yet")
def test_analysis_is_cached_on_disk_and_a_corrupt_file_is_rebuilt(tmp_path):
    sample = pebbles()
    first, source = core.analyse(sample, settings(), cache_dir=str(tmp_path), cache=core.AnalysisCache())
    assert source == "built"
    files = list(tmp_path.iterdir())
    assert len(files) == 1 and files[0].name.startswith(core.ANALYSIS_CACHE_PREFIX)
    loaded, source = core.analyse(sample, settings(), cache_dir=str(tmp_path), cache=core.AnalysisCache())
    assert source == "disk" and np.array_equal(loaded.labels, first.labels)
    data = bytearray(files[0].read_bytes())
    data[len(data) // 2] ^= 0xFF
    files[0].write_bytes(bytes(data))
    _, source = core.analyse(sample, settings(), cache_dir=str(tmp_path), cache=core.AnalysisCache())
    assert source == "built"


def test_the_background_file_follows_the_filled_background():
    # The background PNG is written from analysis.background alone, so its folder is that array's digest:
    # a label image or any analysis setting that changes the fill gets another file, and only an identical
    # fill shares one (the old path came from the sample's pixels alone). The file name (the Blender
    # image's name) names the sample and label image.
    sample = pebbles()
    base = core.analyse(sample, settings(), cache=core.AnalysisCache())[0].background
    path = core.background_file_path("cache", base, sample)
    assert path == core.background_file_path("cache", base.copy(), sample.copy())
    folder, name = os.path.split(path)
    assert os.path.dirname(folder) == "cache" and os.path.basename(folder).startswith(core.BACKGROUND_PREFIX)
    assert folder.endswith("-%d" % core.BACKGROUND_FORMAT)
    # Sample part, then the folder's key: two backgrounds of one sample never share the Blender image's name.
    assert name == "%s%s-%s.png" % (core.BACKGROUND_PREFIX, core.analysis_key(sample, settings())[:16],
                                    os.path.basename(folder)[len(core.BACKGROUND_PREFIX):][:8])
    labels = np.zeros(sample.shape[:2], np.int32)
    labels[8:18, 8:18] = 1  # one stone as the only particle: the other stones stay in the background
    differing = 0
    for changes, label_image in ((dict(particle_classes=2), None), (dict(particle_min_area=200), None),
                                 (dict(particle_blur=1.5), None), (dict(seed=9), None), ({}, labels)):
        other = core.analyse(sample, settings(**changes), label_image, cache=core.AnalysisCache())[0].background
        same = other.shape == base.shape and np.array_equal(other, base)
        other_folder = os.path.dirname(core.background_file_path("cache", other, sample, label_image))
        assert (other_folder == folder) == same, changes
        other_name = os.path.basename(core.background_file_path("cache", other, sample, label_image))
        assert (other_name == name) == (same and label_image is None), changes
        differing += not same
    assert differing >= 2
    tweaked = base.copy()
    tweaked[0, 0, 0] += 0.25
    assert os.path.dirname(core.background_file_path("cache", tweaked, sample)) != folder


def test_class_rows_count_the_drawn_particles():
    analysis, _ = core.analyse(pebbles(), settings(), cache=core.AnalysisCache())
    rows = core.class_rows(analysis)
    def by_colour(colour):
        return min(rows, key=lambda row: np.abs(np.array(row["colour"]) - colour).sum())
    stones, leaves, ground = by_colour(STONE), by_colour(LEAF), by_colour(GROUND)
    assert (stones["particles"], stones["complete"], stones["pixels"]) == (4, 4, 400)
    assert (leaves["particles"], leaves["pixels"]) == (2, 2 * 84)
    assert ground["background"] and not stones["background"]
    assert core.class_order(analysis, settings()) == [stones["id"], leaves["id"]]  # more particles first
    assert core.class_order(analysis, settings(particle_class_order=(leaves["id"],))) == [leaves["id"]]
    with pytest.raises(core_settings.SettingsError, match="is the background"):
        core.class_order(analysis, settings(particle_class_order=(ground["id"],)))
    assert core.class_at(analysis, 12, 12) == stones["id"] and core.class_at(analysis, 0, 0) == ground["id"]
    with pytest.raises(core_settings.SettingsError, match="outside"):
        core.class_at(analysis, 96, 0)


def test_merging_two_classes_leaves_one_class_with_both_particle_sets():
    analysis, _ = core.analyse(pebbles(), settings(), cache=core.AnalysisCache())
    rows = core.class_rows(analysis)
    stone = next(r["id"] for r in rows if r["pixels"] == 400)
    leaf = next(r["id"] for r in rows if r["pixels"] == 168)
    merged, _ = core.analyse(pebbles(), settings(particle_merges=((leaf, stone),)), cache=core.AnalysisCache())
    rows = core.class_rows(merged)
    assert len(rows) == 2
    assert sorted((r["pixels"], r["particles"]) for r in rows if not r["background"]) == [(568, 6)]


def test_segmentation_preview_shows_class_colours_and_outlines():
    analysis, _ = core.analyse(pebbles(), settings(), cache=core.AnalysisCache())
    preview = core.segmentation_preview(analysis)
    assert preview.shape == (64, 96, 4) and np.all(preview[..., 3] == 1.0)
    np.testing.assert_allclose(preview[13, 13, :3], STONE, atol=0.02)   # inside a stone
    np.testing.assert_allclose(preview[30, 5, :3], GROUND, atol=0.02)   # ground
    # The stone at x 8..17, y 8..17: its boundary pixels are outlined (stone is bright: black).
    np.testing.assert_allclose(preview[8, 12, :3], 0.0)
    np.testing.assert_allclose(preview[12, 17, :3], 0.0)


def test_unusable_samples_get_clear_errors():
    flat = np.tile(GROUND, (64, 64, 1))
    with pytest.raises((core_settings.SettingsError, ValueError), match="no particles|one colour|class"):
        analysis, _ = core.analyse(flat, settings(particle_classes=2), cache=core.AnalysisCache())
        core.check_usable(analysis)
    # A band across the sample, lit from one side (so that its left and right edges do not continue each other
    # and it is not taken for a tileable sample): its one region is cut by the border, no complete particle.
    band = np.tile(GROUND, (64, 64, 1))
    band[24:41] = STONE
    band = (band * np.linspace(0.7, 1.0, 64, dtype=np.float32)[None, :, None]).astype(np.float32)
    analysis, _ = core.analyse(band, settings(particle_classes=2), cache=core.AnalysisCache())
    assert not analysis.tileable
    with pytest.raises(core_settings.SettingsError, match="complete particle") as refused:
        core.check_usable(analysis)
    assert "--method jumpmap" in str(refused.value) and "Round Neighbourhoods" in str(refused.value)
    # A gradient has no elements at all: k-means cuts it into bands that touch the border.
    gradient = np.repeat(np.linspace(0.0, 1.0, 96, dtype=np.float32)[None, :, None], 64, 0).repeat(3, 2)
    analysis, _ = core.analyse(gradient, settings(), cache=core.AnalysisCache())
    with pytest.raises(core_settings.SettingsError, match="served by Jump Maps"):
        core.check_usable(analysis)


def test_thousands_of_tiny_components_are_bounded_and_reported():
    rng = np.random.default_rng(3)
    noise = np.where((rng.random((256, 256)) < 0.3)[..., None], STONE, GROUND).astype(np.float32)
    noise[100:120, 100:120] = LEAF  # one real particle
    analysis, _ = core.analyse(noise, settings(particle_classes=3), cache=core.AnalysisCache())
    notes = core.check_usable(analysis)
    assert analysis.merged_components > 1000
    assert any("tiny components" in note for note in notes), notes


# -- atlas, decals, instances ---------------------------------------------------------------------

def test_atlas_packs_every_sprite_with_padding_in_a_power_of_two():
    rng = np.random.default_rng(1)
    sizes = rng.integers(4, 40, size=(60, 2))
    atlas = outputs.pack_atlas(np.arange(60), sizes, np.zeros(60, np.int32))
    assert atlas.width == atlas.height and atlas.width & (atlas.width - 1) == 0 and not atlas.dropped
    cells = atlas.cells
    padded = np.column_stack([cells[:, 0] - 2, cells[:, 1] - 2, cells[:, 0] + cells[:, 2] + 2,
                              cells[:, 1] + cells[:, 3] + 2])
    assert padded.min() >= 0 and padded[:, 2].max() <= atlas.width and padded[:, 3].max() <= atlas.height
    for i in range(60):
        for j in range(i + 1, 60):  # padded cells never overlap
            a, b = padded[i], padded[j]
            assert a[2] <= b[0] or b[2] <= a[0] or a[3] <= b[1] or b[3] <= a[1]
    uv = atlas.uv_rects([5])
    np.testing.assert_allclose(uv[0] * atlas.width, [cells[5, 0], cells[5, 1], cells[5, 0] + cells[5, 2],
                                                     cells[5, 1] + cells[5, 3]])


def test_atlas_beyond_the_limit_keeps_a_subset_of_every_class():
    sizes = np.full((300, 2), 30)
    classes = np.repeat([0, 1, 2], 100)
    atlas = outputs.pack_atlas(np.arange(300), sizes, classes, max_side=256)
    assert atlas.width <= 256 and len(atlas.ids) <= (256 // 34) ** 2
    assert set(atlas.dropped) == {0, 1, 2} and sum(atlas.dropped.values()) == 300 - len(atlas.ids)
    assert set(atlas.classes.tolist()) == {0, 1, 2}
    sprites, turn = outputs.substitute_sprites([atlas.ids[0], 299], [0, 2], atlas, np.linspace(0, 1, 300))
    assert sprites[0] == atlas.ids[0] and turn[0] == 0.0
    assert sprites[1] in atlas.ids[atlas.classes == 2] or 299 in atlas.ids


def test_atlas_pixels_put_each_sprite_in_its_cell():
    atlas = outputs.pack_atlas([7, 9], [(3, 2), (2, 4)], [0, 0])
    a = np.full((2, 3, 4), 0.5, np.float32)
    b = np.full((4, 2, 4), 1.0, np.float32)
    pixels = outputs.atlas_pixels(atlas, [a if s == 7 else b for s in atlas.ids])
    assert pixels.shape == (atlas.height, atlas.width, 4)
    assert pixels[..., 3].sum() == pytest.approx(0.5 * 6 + 8)


class _Analysis:
    """The parts of a ParticleAnalysis decal_inputs and instance_frames read."""

    def __init__(self):
        self.particles = {"box_centre": np.array([[10.0, 20.0], [5.0, 5.0]]), "box_angle": np.array([0.0, 0.5]),
                          "box_half": np.array([[4.0, 2.0], [1.0, 1.0]])}


def test_decal_rectangles_are_the_sprite_around_its_box_centre_in_world_units():
    atlas = outputs.pack_atlas([0, 1], [(12, 8), (4, 4)], [0, 0])
    placed = {"class": np.array([0]), "sprite": np.array([0]), "sprite_axis": np.array([[1.0, 0.0, 0.0]]),
              "normal": np.array([[0.0, 0.0, 1.0]]), "pixel_size": np.array([0.5])}
    boxes = {0: (4, 16, 12, 8), 1: (3, 3, 4, 4)}
    axes, rects, uv_rects, sprites = outputs.decal_inputs(placed, _Analysis(), atlas, boxes)
    # Sprite x 4..16, y 16..24 around the centre (10, 20), at 0.5 world units per pixel.
    np.testing.assert_allclose(rects[0], [-3.0, -2.0, 3.0, 2.0])
    np.testing.assert_allclose(axes[0], [1, 0, 0])
    np.testing.assert_allclose(uv_rects[0], atlas.uv_rects([0])[0])
    # Class bands 3 units apart from 1 unit up (unit 1e-4 x the diagonal), stacking half a unit per level, at
    # most 5 levels: a band's top (2.5 units above its base) stays below the next band.
    first, third = outputs.decal_lift(0, 10.0), outputs.decal_lift(2, 10.0)
    assert first["offset"] == pytest.approx(1e-3) and third["offset"] == pytest.approx(7e-3)
    assert first["stack_step"] == pytest.approx(5e-4) and first["max_level"] == 5
    assert first["offset"] + 5 * first["stack_step"] < outputs.decal_lift(1, 10.0)["offset"]
    assert outputs.decal_lift_top(3, 10.0) == pytest.approx(9.5e-3)


def test_instance_frames_point_x_along_the_box_and_z_along_the_normal():
    # Sprite axis +x, box angle 0.5 rad: the box axis is +x turned by 0.5 rad about the normal +z.
    placed = {"sprite": np.array([1]), "sprite_axis": np.array([[1.0, 0.0, 0.0]]),
              "normal": np.array([[0.0, 0.0, 1.0]]), "pixel_size": np.array([2.0])}
    rotation, scale = outputs.instance_frames(placed, _Analysis())
    np.testing.assert_allclose(rotation[0], [0.0, 0.0, 0.5], atol=1e-6)
    np.testing.assert_allclose(scale[0], [4.0, 4.0, 4.0])


def test_euler_angles_rebuild_the_frame():
    rng = np.random.default_rng(5)
    z = rng.normal(size=(50, 3))
    x = np.cross(z, rng.normal(size=(50, 3)))
    angles = outputs.euler_xyz(x, z).astype(np.float64)

    def matrix(a, b, c):  # Blender's XYZ Euler: Rz(c) Ry(b) Rx(a)
        rx = np.array([[1, 0, 0], [0, math.cos(a), -math.sin(a)], [0, math.sin(a), math.cos(a)]])
        ry = np.array([[math.cos(b), 0, math.sin(b)], [0, 1, 0], [-math.sin(b), 0, math.cos(b)]])
        rz = np.array([[math.cos(c), -math.sin(c), 0], [math.sin(c), math.cos(c), 0], [0, 0, 1]])
        return rz @ ry @ rx
    for i in range(50):
        m = matrix(*angles[i])
        np.testing.assert_allclose(m[:, 0], x[i] / np.linalg.norm(x[i]), atol=1e-5)
        np.testing.assert_allclose(m[:, 2], z[i] / np.linalg.norm(z[i]), atol=1e-5)


def test_label_image_gives_back_the_segmentation_it_was_written_from():
    # --write-labels then --labels: the same partition of the sample (class ids may be renumbered).
    sample = pebbles()
    analysis, _ = core.analyse(sample, settings(), cache=core.AnalysisCache())
    image = core.label_image(analysis)
    assert image.shape == sample.shape[:2] + (4,) and image.dtype == np.float32
    assert np.array_equal(np.round(image * 255) / 255, image)  # exact in an 8-bit PNG
    ids = core.labels_from_image(image, sample.shape[1], sample.shape[0])
    labels = np.asarray(analysis.labels)
    pairs = set(zip(labels.ravel().tolist(), ids.ravel().tolist()))
    assert len(pairs) == len(np.unique(labels)) == len(np.unique(ids)) >= 2, pairs


def test_a_run_over_the_particle_cap_is_refused_with_the_scale_that_fits():
    analysis, _ = core.analyse(pebbles(), settings(), cache=core.AnalysisCache())
    placed = sum(row["particles"] for row in core.class_rows(analysis) if not row["background"])
    # The sample (1 unit wide, height / width of a unit high) over 10 units² of surface.
    expected = core.expected_particles(analysis, 1.0, 10.0)
    assert expected == pytest.approx(placed * 10.0 / (analysis.height / analysis.width))
    assert core.expected_particles(analysis, 2.0, 10.0) == pytest.approx(expected / 4)  # twice the scale
    core.check_particle_count(expected, 1.0, "Rock", cap=int(expected) + 1)  # under the cap: nothing said
    with pytest.raises(core_settings.SettingsError) as refused:
        core.check_particle_count(expected, 1.0, "Rock", cap=int(expected / 9))
    found = re.search(r"Rock: about (\d+) particles .* raise Scale \(CLI --scale\) to at least ([\d.]+)",
                      str(refused.value))
    assert found and int(found.group(1)) == int(expected), refused.value
    suggested = float(found.group(2))
    assert core.expected_particles(analysis, suggested, 10.0) <= int(expected / 9) < \
        core.expected_particles(analysis, suggested * 0.95, 10.0)


def _footprint(position, axis, normal, scale, bounds):
    """World corners of an instance's own XY bounding box (z at its lower bound) under the frame
    (X = axis, Z = normal, Y = Z x X) and per-axis scale: what the Instance on Points node draws."""
    y_axis = np.cross(normal, axis)
    low, high = np.asarray(bounds[0], float), np.asarray(bounds[1], float)
    return np.array([position + x * scale[0] * axis + y * scale[1] * y_axis + low[2] * scale[2] * normal
                     for x in (low[0], high[0]) for y in (low[1], high[1])])


def test_instances_are_fitted_inside_their_particles_boxes():
    """Each instanced object's own bounding box lands inside its particle's box, centred, touching the
    box's sides along one axis, with the object's proportions and its longer side along the box's; an
    object without bounds is placed as given."""
    thorn = ((-0.185, 0.0, 0.0), (0.185, 1.0, 0.355))       # the example thorn: origin at its base end
    pebble = ((-2.0, -3.0, -1.0), (6.0, 1.0, 1.0))           # 8 x 4, off-centre
    axis = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [np.sqrt(0.5), np.sqrt(0.5), 0.0]])
    normal = np.tile([0.0, 0.0, 1.0], (3, 1))
    centre = np.array([[0.0, 0.0, 0.0], [5.0, 1.0, 0.0], [-3.0, 2.0, 0.5]])
    box = np.array([[0.2, 0.4, np.sqrt(0.08)], [0.1, 0.5, np.sqrt(0.05)], [0.6, 0.3, np.sqrt(0.18)]])
    classes = [0, 1, 2]  # children wrap: class 2 is child 0 again
    bounds = [thorn, pebble, thorn]
    position, fitted_axis, scale = outputs.fit_instances(centre, axis, normal, box, classes, [thorn, pebble])
    for i in range(3):
        corners = _footprint(position[i], fitted_axis[i], normal[i], scale[i], bounds[i])
        y_axis = np.cross(normal[i], axis[i])
        local = (corners - centre[i]) @ np.column_stack([axis[i], y_axis])  # in the particle's box frame
        low, high = local.min(axis=0), local.max(axis=0)
        assert np.allclose(low + high, 0.0, atol=1e-6), (i, local)                      # centred
        assert np.all(high <= 0.5 * box[i, :2] + 1e-6), (i, high)                        # inside
        assert np.isclose((high / (0.5 * box[i, :2])).max(), 1.0, atol=1e-6), (i, high)  # touching
        size = np.asarray(bounds[i][1]) - np.asarray(bounds[i][0])
        assert np.isclose(max(high) / min(high), max(size[:2]) / min(size[:2]), rtol=1e-5)  # proportions
        assert (high[0] >= high[1]) == (box[i, 0] >= box[i, 1]), (i, high)               # long side along
        assert np.allclose(scale[i], scale[i, 0])                                         # one factor
    # unfitted (the old output), the thorn's footprint sat half a box off the particle
    corners = _footprint(centre[0], axis[0], normal[0], box[0], thorn)
    assert corners[:, 1].min() >= 0.0 and corners[:, 1].max() > 0.35
    same = outputs.fit_instances(centre, axis, normal, box, classes, [None])
    assert np.allclose(same[0], centre) and np.allclose(same[1], axis) and np.allclose(same[2], box)

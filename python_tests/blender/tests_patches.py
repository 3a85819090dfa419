# SPDX-License-Identifier: GPL-3.0-or-later
"""Vector-field patches inside Blender (addon/surface_colour/, method PATCHES):

  blender -b --factory-startup --python-exit-code 1 --python python_tests/blender/tests_patches.py [-- test_name ...]

Expected values come from the sample's own pixels, Blender's data and the settings, never from the
add-on's code. Targets stay small (64-128 px): the machine is shared.
"""
import os
import re
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import bpy  # noqa: E402
import numpy as np  # noqa: E402

import harness  # noqa: E402

texsynth = harness.load_addon()
texsynth.register()
from texsynth.core import bake_options as options  # noqa: E402
from texsynth.bridge import mesh_io  # noqa: E402
from texsynth.fields import mesh_state  # noqa: E402
from texsynth.core import settings as core_settings  # noqa: E402
from texsynth.fields import authoring  # noqa: E402
from texsynth.ui import field_edits  # noqa: E402
from texsynth.surface_colour import core, synthesis as surface  # noqa: E402
from texsynth.surface_colour import patches as patches_core  # noqa: E402
from texsynth.bridge import sources  # noqa: E402
from texsynth.core import jobs  # noqa: E402

from tests_surface import BRICKS, SAMPLE, pixels_of, plane, sample_bytes, state  # noqa: E402

IMAGE = "TexSynth Patches: Plane"


def settings(**changes):
    values = dict(method="PATCHES", sample_world_size=3.0, seed=5, axis=(0.0, 1.0, 0.0), patch_size=16)
    values.update(changes)
    return core_settings.Settings(**values)


def run(objects, request=None, cache_dir="", **changes):
    return surface.synthesize(objects, SAMPLE, settings(**changes),
                              request or options.BakeRequest(size=128, margin=4, create_uv=True), "NEW",
                              cache_dir=cache_dir)


def test_image_target_shows_whole_sample_patches_along_the_field():
    # 2 x 2 units, UV [0, 1]² at 128 px: 64 texels per unit, the sample's own density at scale 3. With the
    # field along +y every texel centre is a grid point, so outside the cross-faded boundary zones the
    # texels are the sample's own pixels, and rows of the sample stay rows of the image.
    obj = plane()
    patches_core.exemplars.clear()
    report = run([obj])
    assert report.objects == ["Plane"] and not report.failures, report.summary()
    image = bpy.data.images[IMAGE]
    assert tuple(image.size) == (128, 128) and image.packed_file is not None
    pixels = pixels_of(image)
    assert np.all(pixels[..., 3] == 1.0), "every texel of the one island is covered"
    texels = np.round(pixels[..., :3].reshape(-1, 3) * 255).astype(np.int32)
    palette = {tuple(p) for p in sample_bytes()}
    copied = np.mean([tuple(t) in palette for t in texels])
    assert copied > 0.6, "too few texels are sample pixels: %.3f" % copied
    stats = report.native_stats["Plane"]
    assert stats["surface_samples"] == 128 * 128 and stats["mode"] == "SAMPLING" and stats["patches"] > 4
    assert stats["exemplar"] == "built" and report.seconds["synthesis"] > 0.0
    material = obj.material_slots[0].material
    assert next(n for n in material.node_tree.nodes if n.type == "TEX_IMAGE").image == image


def test_bricks_follow_a_field_turned_by_ninety_degrees():
    # The sample's mortar courses run along its x axis: with up = +y the image's rows are smoother than
    # its columns; with up = +x (a quarter turn) the other way round.
    obj = plane()
    run([obj])
    along_y = pixels_of(bpy.data.images[IMAGE])[..., :3].mean(axis=2)
    run([obj], axis=(1.0, 0.0, 0.0))
    along_x = pixels_of(bpy.data.images[IMAGE])[..., :3].mean(axis=2)

    def row_vs_column(grey):
        return np.abs(np.diff(grey, axis=1)).mean() / np.abs(np.diff(grey, axis=0)).mean()
    sample = sample_bytes().reshape(192, 192, 3).mean(axis=2)
    assert (row_vs_column(sample) < 1) == (row_vs_column(along_y) < 1), (row_vs_column(sample), row_vs_column(along_y))
    assert (row_vs_column(along_x) < 1) != (row_vs_column(along_y) < 1), (row_vs_column(along_x), row_vs_column(along_y))


def test_vertex_target_writes_the_colour_attribute():
    obj = plane(cells=48)
    report = run([obj], surface_target="VERTICES", sample_world_size=192 / 24.5)
    assert report.objects == ["Plane"], report.summary()
    attribute = obj.data.attributes[core.COLOUR_ATTRIBUTE_NAME]
    values = np.empty(len(attribute.data) * 4, np.float32)
    attribute.data.foreach_get("color", values)
    rgb = values.reshape(-1, 4)[:, :3]
    srgb = np.where(rgb <= 0.0031308, rgb * 12.92, 1.055 * np.power(np.maximum(rgb, 0), 1 / 2.4) - 0.055)
    assert abs(srgb.mean() - (sample_bytes() / 255.0).mean()) < 0.05
    assert rgb.std() > 0.02, "a texture, not a flat colour"


def test_optimisation_refines_the_sampled_texture():
    # Starts from patch sampling (same seed), then re-matches every patch: the image changes, each pass
    # re-matches fewer patches, and the native stats report the passes made.
    obj = plane()
    run([obj])
    sampled = pixels_of(bpy.data.images[IMAGE]).copy()
    report = run([obj], patch_mode="OPTIMISATION", patch_iterations=4)
    assert report.objects == ["Plane"], report.summary()
    native = report.native_stats["Plane"]["native"]
    assert 2 <= len(native["energy"]) <= 4 and len(native["changed"]) == len(native["energy"]), native
    assert native["changed"][-1] < native["changed"][0] == 1.0, native["changed"]
    assert native["seconds_optimisation"] > 0.0
    assert not np.array_equal(pixels_of(bpy.data.images[IMAGE]), sampled)


def test_same_seed_same_image_and_another_seed_another():
    obj = plane()
    run([obj])
    first = pixels_of(bpy.data.images[IMAGE]).copy()
    run([obj])
    assert np.array_equal(pixels_of(bpy.data.images[IMAGE]), first)
    run([obj], seed=6)
    assert not np.array_equal(pixels_of(bpy.data.images[IMAGE]), first)


def test_analysed_sample_is_cached_on_disk_and_a_corrupt_file_is_rebuilt():
    obj = plane()
    folder = tempfile.mkdtemp(prefix="texsynth_patches_cache_")
    patches_core.exemplars.clear()
    assert run([obj], cache_dir=folder).native_stats["Plane"]["exemplar"] == "built"
    files = [name for name in os.listdir(folder) if name.startswith("patches-")]
    assert len(files) == 1, os.listdir(folder)
    assert run([obj], cache_dir=folder).native_stats["Plane"]["exemplar"] == "memory"
    patches_core.exemplars.clear()
    assert run([obj], cache_dir=folder).native_stats["Plane"]["exemplar"] == "disk"
    path = os.path.join(folder, files[0])
    with open(path, "r+b") as handle:
        handle.seek(os.path.getsize(path) // 2)
        handle.write(b"\xff" * 64)
    patches_core.exemplars.clear()
    report = run([obj], cache_dir=folder)
    assert report.objects == ["Plane"] and report.native_stats["Plane"]["exemplar"] == "built", report.summary()


def test_bad_patch_settings_are_refused_and_change_nothing():
    obj = plane()
    before = state(obj)
    for changes, fragment in ((dict(patch_size=30), "multiple of 4"), (dict(patch_boundary=12), "boundary width"),
                              (dict(patch_tolerance=0.5), "tolerance"), (dict(patch_iterations=0), "iterations"),
                              (dict(patch_mode="FAST"), "patch mode")):
        try:
            run([obj], **changes)
            raise AssertionError("accepted %r" % (changes,))
        except core_settings.SettingsError as error:
            assert fragment in str(error), (changes, str(error))
        assert state(obj) == before


def test_a_sample_smaller_than_the_patch_uses_smaller_patches():
    obj = plane()
    small = os.path.join(tempfile.mkdtemp(), "small.png")
    image = bpy.data.images.new("small", 24, 24)
    image.pixels.foreach_set(np.random.default_rng(1).random(24 * 24 * 4).astype(np.float32))
    image.filepath_raw, image.file_format = small, "PNG"
    image.save()
    bpy.data.images.remove(image)
    report = surface.synthesize([obj], sources.Sample(path=small), settings(patch_size=32, sample_world_size=0.375,
                                                                               round_resolution="FULL"),
                                options.BakeRequest(size=64, margin=2), "NEW")
    assert report.objects == ["Plane"], report.summary()
    assert report.native_stats["Plane"]["patch_size"] == 12  # largest multiple of 4 <= 24 / 2


def test_cancel_leaves_nothing_behind():
    obj = plane()
    before = state(obj)
    job = surface.Job([obj], SAMPLE, settings(), options.BakeRequest(size=64, margin=2)).prepare()
    job.cancel()
    try:
        job.compute()
        raise AssertionError("compute() did not raise after cancel()")
    except jobs.Cancelled:
        pass
    job.discard()
    assert state(obj) == before


def test_live_preview_after_a_field_edit_writes_a_small_image():
    obj = plane()
    props = bpy.context.scene.texsynth
    props.sample_path, props.method, props.scale, props.axis = BRICKS, "PATCHES", 3.0, (0.0, 1.0, 0.0)
    props.patch_size, props.bake_size, props.bake_margin = 16, 512, 4
    state = mesh_state.field_state(bpy.context, obj)  # what a comb stroke leaves: a painted field on the mesh
    authoring.preset_axis(state, (0.0, 1.0, 0.0))
    mesh_state.write_field_state(obj, state)
    patches_core.patch_targets.clear()
    field_edits.live_update(bpy.context, obj)
    image = bpy.data.images[IMAGE]
    assert tuple(image.size) == (field_edits.PATCH_PREVIEW_SIZE,) * 2, tuple(image.size)
    assert field_edits.last_timings["live_update"] > 0.0
    assert not patches_core.patch_targets.field.reused_mesh
    first = np.array(image.pixels[:])
    # The next stroke redoes the field only: same surface samples, the walk mesh copied.
    authoring.preset_axis(state, (1.0, 0.0, 0.0))
    mesh_state.write_field_state(obj, state)
    field_edits.live_update(bpy.context, obj)
    assert patches_core.patch_targets.field.reused_mesh
    assert not np.array_equal(first, np.array(bpy.data.images[IMAGE].pixels[:])), "the new field shows"


def test_settings_persist_in_the_blend_file():
    plane()
    props = bpy.context.scene.texsynth
    props.method, props.patch_mode, props.patch_size = "PATCHES", "OPTIMISATION", 24
    props.patch_boundary, props.patch_tolerance, props.patch_iterations = 3, 1.5, 9
    path = os.path.join(tempfile.mkdtemp(), "patches.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path)
    bpy.ops.wm.read_homefile(use_empty=True)
    bpy.ops.wm.open_mainfile(filepath=path)
    s = bpy.context.scene.texsynth.to_settings()
    assert (s.method, s.patch_mode, s.patch_size, s.patch_boundary, s.patch_iterations) == \
        ("PATCHES", "OPTIMISATION", 24, 3, 9)
    assert abs(s.patch_tolerance - 1.5) < 1e-6


def test_layers_only_image_survives_save_and_reload():
    # Material mode Layers Only: the packed image is the only output and nothing uses it yet.
    obj = plane()
    report = surface.synthesize([obj], SAMPLE, settings(), options.BakeRequest(size=64, margin=2), "NONE")
    assert report.objects == ["Plane"] and not obj.material_slots, report.summary()
    image = bpy.data.images[IMAGE]
    assert image.packed_file is not None and "(packed)" in report.summary()
    digest = harness.pixel_digest(image)
    harness.save_and_reload("patches.blend")
    image = bpy.data.images.get(IMAGE)
    assert image is not None, sorted(i.name for i in bpy.data.images)
    assert image.packed_file is not None and harness.pixel_digest(image) == digest


def large_sample(side=512):
    """bricks.png scaled to side x side (Blender's own scaling), saved as a PNG; returns its path."""
    path = os.path.join(tempfile.mkdtemp(prefix="texsynth_patches_"), "bricks%d.png" % side)
    image = bpy.data.images.load(BRICKS, check_existing=False)
    image.scale(side, side)
    image.filepath_raw, image.file_format = path, "PNG"
    image.save()
    bpy.data.images.remove(image)
    return path


def test_full_resolution_sample_over_the_memory_limit_is_refused_before_any_work():
    # The soak's configuration: Synthesis Resolution Full Sample, a 512² sample at scale 0.3 (1707 sample
    # pixels per unit), a 512² image on Blender's default cube (its UV map: 98304 texels, 64 per unit). The
    # sample has 27 pixels per texel, so nearly every texel gets a patch of 34² traced points, and the
    # sample is analysed at 512²: measured 5.0 GB peak and 189 s here, where the old estimate said 22 MB.
    path = large_sample()
    harness.reset_scene()
    obj = harness.add_primitive("cube", "Cube")
    harness.select_only([obj])
    before = state(obj)
    patches_core.exemplars.clear()
    patches_core.patch_targets.clear()
    sample = sources.Sample(path=path)
    report = surface.synthesize([obj], sample, settings(sample_world_size=0.3, round_resolution="FULL", patch_size=32),
                                options.BakeRequest(size=512, margin=4), "NEW")
    message = report.summary()
    assert not report.objects, message
    found = re.search(r"about (\d+) MB \(limit (\d+) MB\)", message)
    assert found and int(found.group(1)) > int(found.group(2)) == patches_core.PATCH_MAX_MEGABYTES, message
    assert "Synthesis Resolution" in message and "Match Target" in message, message
    # Refused before the sample analysis and the field: nothing of either was built.
    assert patches_core.exemplars.entry is None and patches_core.patch_targets.field is None
    assert state(obj) == before
    # The default Synthesis Resolution (Match Target) analyses the sample reduced to the cube's density.
    report = surface.synthesize([obj], sample, settings(sample_world_size=0.3, patch_size=32),
                                options.BakeRequest(size=512, margin=4), "NEW")
    assert report.objects == ["Cube"], report.summary()
    assert report.native_stats["Cube"]["working_sample"][0] < 512


def test_a_sample_over_the_analysis_limit_is_reduced_and_the_report_says_to_what():
    # The corpus' large photos passed the analysis limit on the bunny and were refused; at Match Target the
    # working sample is now reduced until it fits. Here the limit is lowered to 60 % of what this run's
    # working sample needs, so the fit must reduce it (its area, and so the analysis, about halves).
    obj = plane()
    request = options.BakeRequest(size=128, margin=4)
    patches_core.exemplars.clear()
    patches_core.patch_targets.clear()
    report = run([obj], request)
    assert report.objects, report.summary()
    width, height = report.native_stats[obj.name]["working_sample"]
    assert report.native_stats[obj.name]["memory_reduced_from"] is None
    module = texsynth.native.require()
    needed = module.estimate_patch_exemplar_bytes(width, height, 3, 16) / 1e6
    limit = patches_core.PATCH_EXEMPLAR_MAX_MEGABYTES
    patches_core.PATCH_EXEMPLAR_MAX_MEGABYTES = 0.6 * needed
    try:
        obj = plane()
        report = run([obj], request)
    finally:
        patches_core.PATCH_EXEMPLAR_MAX_MEGABYTES = limit
    message = report.summary()
    assert report.objects, message
    stats = report.native_stats[obj.name]
    assert stats["memory_reduced_from"] == [width, height], stats
    smaller = stats["working_sample"]
    assert smaller[0] < width and module.estimate_patch_exemplar_bytes(smaller[0], smaller[1], 3, 16) / 1e6 <= 0.6 * needed
    assert "reduced to %d x %d (from %d x %d)" % (smaller[0], smaller[1], width, height) in message, message


def test_a_boundary_wider_than_half_the_patches_used_is_refused_by_the_addon():
    # Patch Size 16 allows Boundary 6 (at most half the patch size) for a large enough sample, but here the
    # sample is reduced to 32² (a 64 px image over 2 units at scale 1: 32 texels per unit) and Optimisation's
    # coarsest level halves it to 16², which holds 8 px patches only: the native synthesis takes a
    # boundary of at most 4 there. The add-on must refuse it itself, before any work, naming the setting.
    obj = plane()
    before = state(obj)
    patches_core.exemplars.clear()
    request = options.BakeRequest(size=64, margin=2)
    wide = dict(patch_mode="OPTIMISATION", patch_size=16, patch_boundary=6, sample_world_size=1.0)
    settings(**wide).validate()  # fine as long as the sample is not known
    report = run([obj], request, **wide)
    message = report.summary()
    assert not report.objects and "Boundary" in message and "at most 4" in message, message
    assert "patch synthesis:" not in message, "refused by the native code, not the add-on: " + message
    assert patches_core.exemplars.entry is None, "the sample was analysed before the refusal"
    assert state(obj) == before
    # The operator turns it into an error report and changes nothing.
    props = bpy.context.scene.texsynth
    props.sample_path, props.method, props.scale, props.axis = BRICKS, "PATCHES", 1.0, (0.0, 1.0, 0.0)
    props.patch_mode, props.patch_size, props.patch_boundary = "OPTIMISATION", 16, 6
    props.bake_size, props.bake_margin = 64, 2
    try:
        bpy.ops.texsynth.synthesize()
        raise AssertionError("the operator accepted Boundary 6")
    except RuntimeError as error:
        assert "at most 4" in str(error), error
    assert state(obj) == before
    # The limit the message gives is the one that runs; the UI property's range is the add-on's one range.
    assert run([obj], request, **dict(wide, patch_boundary=4)).objects == ["Plane"]
    rna = props.bl_rna.properties["patch_boundary"]
    assert (rna.hard_min, rna.hard_max) == core_settings.PATCH_BOUNDARY_RANGE, (rna.hard_min, rna.hard_max)


def test_a_sample_that_repeats_is_read_as_tileable_and_the_report_says_so():
    """moss.png continues across its border: with Tileable off the patches give the very image Tileable on
    gives, and the report says why; bricks.png does not repeat: no note."""
    moss = sources.Sample(path=os.path.join(harness.SAMPLES_DIR, "moss.png"))
    request = options.BakeRequest(size=64, margin=2, create_uv=True)

    def image_of(sample, tileable):
        obj = plane()
        report = surface.synthesize([obj], sample, settings(tileable=tileable, patch_size=12), request, "NEW")
        assert report.objects == ["Plane"] and not report.failures, report.summary()
        return pixels_of(bpy.data.images[IMAGE]).copy(), report

    found, report = image_of(moss, False)
    assert "repeats across its border" in report.summary() and report.native_stats["Plane"]["repeat_found"]
    ticked, report_on = image_of(moss, True)
    assert np.array_equal(found, ticked) and "repeats across its border" not in report_on.summary()
    plain, report = image_of(SAMPLE, False)
    assert "repeats across its border" not in report.summary() and not report.native_stats["Plane"]["repeat_found"]


if __name__ == "__main__":
    harness.Checks().run([value for name, value in list(globals().items()) if name.startswith("test_")],
                         only=harness.script_args())

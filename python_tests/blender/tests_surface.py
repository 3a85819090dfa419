# SPDX-License-Identifier: GPL-3.0-or-later
"""Surface-colour methods inside Blender (addon/surface_colour/, round neighbourhoods):

  blender -b --factory-startup --python-exit-code 1 --python python_tests/blender/tests_surface.py [-- test_name ...]

Expected values come from the sample's own pixels, the meshes' own UV coordinates and Blender's data,
never from the add-on's code. Targets stay small (64-128 px): the machine is shared.
"""
import os
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import bpy  # noqa: E402
import numpy as np  # noqa: E402

import harness  # noqa: E402

texsynth = harness.load_addon()
texsynth.register()
from texsynth.bake import baking  # noqa: E402
from texsynth.core import bake_options as options  # noqa: E402
from texsynth.bridge import mesh_io  # noqa: E402
from texsynth.core import settings as core_settings  # noqa: E402
from texsynth.surface_colour import core, synthesis as surface  # noqa: E402
from texsynth.surface_colour import round_neighbourhoods as round_core  # noqa: E402
from texsynth.uv_methods import synthesis  # noqa: E402
from texsynth.bridge import sources  # noqa: E402
from texsynth.core import jobs  # noqa: E402

BRICKS = os.path.join(harness.SAMPLES_DIR, "bricks.png")  # 192 x 192, 8-bit sRGB
SAMPLE = sources.Sample(path=BRICKS)


def sample_bytes():
    """The sample's pixels as 8-bit values (N, 3), read by Blender itself."""
    image = bpy.data.images.load(BRICKS, check_existing=False)
    values = np.empty(len(image.pixels), np.float32)
    image.pixels.foreach_get(values)
    pixels = np.round(values.reshape(-1, image.channels)[:, :3] * 255).astype(np.int32)
    bpy.data.images.remove(image)
    return pixels


def pixels_of(image):
    values = np.empty(len(image.pixels), np.float32)
    image.pixels.foreach_get(values)
    return values.reshape(image.size[1], image.size[0], image.channels)


def plane(cells=4, size=2.0):
    """A grid in the xy plane with Blender's default UV map (one island covering [0, 1]²)."""
    harness.reset_scene()
    obj = harness.add_primitive("grid", "Plane", x_subdivisions=cells, y_subdivisions=cells, size=size)
    harness.select_only([obj])
    return obj


def settings(**changes):
    values = dict(method="ROUND", sample_world_size=3.0, seed=5, axis=(0.0, 1.0, 0.0))
    values.update(changes)
    return core_settings.Settings(**values)


def run(objects, request=None, material_mode="NEW", **changes):
    return surface.synthesize(objects, SAMPLE, settings(**changes),
                              request or options.BakeRequest(size=128, margin=4, create_uv=True), material_mode)


def state(obj):
    """Everything a failed or cancelled run must leave as it was."""
    return dict(images=sorted(i.name for i in bpy.data.images), materials=sorted(m.name for m in bpy.data.materials),
                mesh=harness.mesh_hash(obj.data), slots=[s.material.name if s.material else None
                                                         for s in obj.material_slots])


def test_image_texels_are_sample_pixels_and_the_material_shows_them():
    # 2 x 2 units, UV [0, 1]² at 128 px: 64 texels per unit, the sample's own density at scale 3 (192 / 3).
    obj = plane()
    report = run([obj])
    assert report.objects == ["Plane"] and not report.failures, report.summary()
    image = bpy.data.images["TexSynth Round: Plane"]
    assert tuple(image.size) == (128, 128) and image.packed_file is not None
    pixels = pixels_of(image)
    assert np.all(pixels[..., 3] == 1.0), "every texel of the one island is covered"
    texels = np.round(pixels[..., :3].reshape(-1, 3) * 255).astype(np.int32)
    palette = {tuple(p) for p in sample_bytes()}
    copied = np.mean([tuple(t) in palette for t in texels])
    assert copied == 1.0, "texels not taken from the sample: %.3f" % copied
    material = obj.material_slots[0].material
    nodes = {node.type: node for node in material.node_tree.nodes}
    assert nodes["TEX_IMAGE"].image == image and nodes["UVMAP"].uv_map == "UVMap"
    link = next(l for l in material.node_tree.links if l.to_node.type == "BSDF_PRINCIPLED")
    assert link.from_node.type == "TEX_IMAGE" and link.to_socket.name == "Base Color"
    assert report.seconds["synthesis"] > 0.0 and report.native_stats["Plane"]["surface_samples"] == 128 * 128


def test_vertex_target_writes_a_linear_colour_attribute_of_sample_colours():
    obj = plane(cells=48)  # 49² vertices, 24.5 per unit: the sample is reduced to that density
    report = run([obj], surface_target="VERTICES", sample_world_size=192 / 24.5)
    assert report.objects == ["Plane"], report.summary()
    attribute = obj.data.attributes[core.COLOUR_ATTRIBUTE_NAME]
    assert (attribute.domain, attribute.data_type) == ("POINT", "FLOAT_COLOR")
    assert obj.data.attributes.active_color.name == core.COLOUR_ATTRIBUTE_NAME
    values = np.empty(len(attribute.data) * 4, np.float32)
    attribute.data.foreach_get("color", values)
    rgb = values.reshape(-1, 4)[:, :3]
    # Linear: back to sRGB by the standard formula gives the sample's colour range, not its square.
    srgb = np.where(rgb <= 0.0031308, rgb * 12.92, 1.055 * np.power(np.maximum(rgb, 0), 1 / 2.4) - 0.055)
    sample = sample_bytes() / 255.0
    assert abs(srgb.mean() - sample.mean()) < 0.05, (srgb.mean(), sample.mean())
    assert np.all(values.reshape(-1, 4)[:, 3] == 1.0)
    attribute_node = next(n for n in obj.material_slots[0].material.node_tree.nodes if n.type == "ATTRIBUTE")
    assert attribute_node.attribute_name == core.COLOUR_ATTRIBUTE_NAME


def test_no_uv_map_gets_smart_uv_project_or_a_clear_refusal():
    harness.reset_scene()
    obj = harness.add_primitive("cube", "Cube")
    obj.data.uv_layers.remove(obj.data.uv_layers[0])
    harness.select_only([obj])
    before = state(obj)
    report = run([obj], options.BakeRequest(size=64, margin=2, create_uv=False))
    assert not report.objects and "Smart UV Project" in report.summary(), report.summary()
    assert state(obj) == before
    report = run([obj], options.BakeRequest(size=64, margin=2, create_uv=True))
    assert report.objects == ["Cube"] and "created UV map 'UVMap' with Smart UV Project" in report.summary()
    assert [layer.name for layer in obj.data.uv_layers] == ["UVMap"]
    # Six islands: covered texels plus their margin, and empty texels between them.
    alpha = pixels_of(bpy.data.images["TexSynth Round: Cube"])[..., 3]
    assert 0.3 < alpha.mean() < 1.0, alpha.mean()


def test_overlapping_uv_islands_are_refused_and_change_nothing():
    obj = plane(cells=2)
    uv = obj.data.uv_layers[0]
    values = np.empty(len(uv.data) * 2, np.float32)
    uv.data.foreach_get("uv", values)
    uv.data.foreach_set("uv", 1.0 - np.abs(2.0 * values - 1.0))  # folded: every quad covers all of [0, 1]²
    before = state(obj)
    report = run([obj])
    assert not report.objects and "overlap" in report.summary(), report.summary()
    assert state(obj) == before


def suzanne_without_uvs(levels=2):
    harness.reset_scene()
    obj = harness.add_primitive("monkey", "Suzanne")
    harness.select_only([obj])
    modifier = obj.modifiers.new("Subdivision", "SUBSURF")
    modifier.levels = levels
    bpy.ops.object.modifier_apply(modifier=modifier.name)
    while len(obj.data.uv_layers):
        obj.data.uv_layers.remove(obj.data.uv_layers[0])
    return obj


def test_a_few_folded_texels_are_accepted_with_a_note_and_texsynths_own_map_has_none():
    # Smart UV Project at Blender's default angle (66°) folds a few faces of a subdivided Suzanne.
    obj = suzanne_without_uvs()
    obj.data.uv_layers.new(name="Folded")
    bpy.ops.object.mode_set(mode="EDIT")
    bpy.ops.mesh.select_all(action="SELECT")
    bpy.ops.uv.smart_project()
    bpy.ops.object.mode_set(mode="OBJECT")
    report = run([obj], options.BakeRequest(size=512, margin=2, uv_map="Folded"), sample_world_size=1.0)
    assert report.objects == ["Suzanne"], report.summary()
    folded = report.native_stats["Suzanne"]["overlapping_texels"]
    assert 0 < folded < 0.01 * report.native_stats["Suzanne"]["surface_samples"], folded
    assert "%d texels of UV map 'Folded' are covered twice" % folded in report.summary(), report.summary()
    obj = suzanne_without_uvs()  # the map TexSynth makes itself (Smart UV Project at 45°)
    report = run([obj], options.BakeRequest(size=512, margin=2, create_uv=True), sample_world_size=1.0)
    assert report.objects == ["Suzanne"] and report.native_stats["Suzanne"]["overlapping_texels"] == 0, \
        report.summary()


def test_nan_coordinates_are_refused_and_change_nothing():
    obj = plane(cells=2)
    obj.data.vertices[4].co = (float("nan"), 0.0, 0.0)
    before = state(obj)
    report = run([obj])
    assert not report.objects and "nan" in report.summary().lower(), report.summary()
    assert state(obj) == before


def test_zero_area_faces_still_give_a_complete_image():
    # One quad collapsed to a point in 3D keeps its UV area: its texels have no surface to stand on.
    obj = plane(cells=4)
    mesh = obj.data
    corner_verts = [mesh.loops[i].vertex_index for i in range(mesh.polygons[5].loop_start,
                                                                 mesh.polygons[5].loop_start + 4)]
    for index in corner_verts:
        mesh.vertices[index].co = mesh.vertices[corner_verts[0]].co.copy()
    report = run([obj])
    assert report.objects == ["Plane"], report.summary()
    pixels = pixels_of(bpy.data.images["TexSynth Round: Plane"])
    # Documented: those texels are filled like the bake margin, from the covered texels around them.
    assert np.all(np.isfinite(pixels)) and np.all(pixels[..., 3] == 1.0), pixels[..., 3].mean()


def test_huge_target_is_refused_with_the_estimated_memory():
    obj = plane(cells=2)
    before = state(obj)
    report = run([obj], options.BakeRequest(size=8192, margin=2))
    assert not report.objects and "MB" in report.summary(), report.summary()
    assert state(obj) == before


def test_failure_while_writing_leaves_the_existing_image_and_mesh_unchanged():
    obj = plane()
    old = bpy.data.images.new("TexSynth Round: Plane", 8, 8)
    old.generated_color = (0.1, 0.2, 0.3, 1.0)
    before = state(obj)
    os.environ[mesh_io.FAIL_AT_ENV] = "surface_image"
    try:
        report = run([obj])
    finally:
        del os.environ[mesh_io.FAIL_AT_ENV]
    assert not report.objects and "injected failure" in report.summary(), report.summary()
    assert state(obj) == before and tuple(old.size) == (8, 8)
    report = run([obj])  # then it replaces the old image, and keeps its users pointing at the new one
    assert report.objects == ["Plane"] and tuple(bpy.data.images["TexSynth Round: Plane"].size) == (128, 128)


def test_cancel_leaves_nothing_behind_even_a_new_uv_map():
    harness.reset_scene()
    obj = harness.add_primitive("cube", "Cube")
    obj.data.uv_layers.remove(obj.data.uv_layers[0])
    harness.select_only([obj])
    before = state(obj)
    job = surface.Job([obj], SAMPLE, settings(), options.BakeRequest(size=64, margin=2, create_uv=True)).prepare()
    assert len(obj.data.uv_layers) == 1  # made by prepare()
    job.cancel()
    try:
        job.compute()
        raise AssertionError("compute() did not raise after cancel()")
    except jobs.Cancelled:
        pass
    job.discard()
    assert state(obj) == before


def test_resynthesis_with_a_new_field_reuses_the_neighbourhoods():
    obj = plane()
    round_core.contexts.clear()
    first = run([obj])
    assert "neighbourhoods reused" not in first.summary()
    image = bpy.data.images["TexSynth Round: Plane"]
    before = pixels_of(image).copy()
    second = run([obj], axis=(1.0, 0.0, 0.0))
    assert "neighbourhoods reused" in second.summary(), second.summary()
    stats = second.native_stats["Plane"]
    assert stats["context_reused"] and stats["seconds_context"] == 0.0
    assert not np.array_equal(pixels_of(bpy.data.images["TexSynth Round: Plane"]), before)


def test_same_seed_same_image():
    obj = plane()
    round_core.contexts.clear()
    run([obj])
    first = pixels_of(bpy.data.images["TexSynth Round: Plane"]).copy()
    round_core.contexts.clear()
    run([obj])
    assert np.array_equal(pixels_of(bpy.data.images["TexSynth Round: Plane"]), first)
    report = run([obj])  # the kept context gives the same bytes as a fresh one
    assert "neighbourhoods reused" in report.summary()
    assert np.array_equal(pixels_of(bpy.data.images["TexSynth Round: Plane"]), first)


def test_a_sample_that_repeats_is_read_as_tileable_and_the_report_says_so():
    """moss.png continues across its border (core/sample_image.repeats_across_border): with Tileable off the
    round method gives the very image Tileable on gives, and notes why. bricks.png does not: no note, and its
    image differs from Tileable on (so the comparison can tell the two apart)."""
    moss = sources.Sample(path=os.path.join(harness.SAMPLES_DIR, "moss.png"))
    request = options.BakeRequest(size=96, margin=2, create_uv=True)

    def image_of(sample, tileable):
        obj = plane()
        round_core.contexts.clear()
        report = surface.synthesize([obj], sample, settings(tileable=tileable), request, "NEW")
        assert report.objects == ["Plane"] and not report.failures, report.summary()
        return pixels_of(bpy.data.images["TexSynth Round: Plane"]).copy(), report

    found, report = image_of(moss, False)
    assert "repeats across its border" in report.summary(), report.summary()
    assert report.native_stats["Plane"]["repeat_found"]
    ticked, report_on = image_of(moss, True)
    assert np.array_equal(found, ticked)
    assert "repeats across its border" not in report_on.summary()
    plain, report = image_of(SAMPLE, False)
    assert "repeats across its border" not in report.summary() and not report.native_stats["Plane"]["repeat_found"]
    assert not np.array_equal(plain, image_of(SAMPLE, True)[0])
    # decided once per run: two objects, one note, both read as tileable
    first = plane()
    second = harness.add_primitive("grid", "Plane2", x_subdivisions=4, y_subdivisions=4, size=2.0)
    harness.select_only([first, second])
    report = surface.synthesize([first, second], moss, settings(), request, "NEW")
    assert sorted(report.objects) == ["Plane", "Plane2"] and not report.failures, report.summary()
    assert report.summary().count("repeats across its border") == 1, report.summary()
    assert report.native_stats["Plane"]["repeat_found"] and report.native_stats["Plane2"]["repeat_found"]
    assert np.array_equal(pixels_of(bpy.data.images["TexSynth Round: Plane"]), found)


def test_operator_runs_round_from_the_scene_settings_and_saves_next_to_the_blend():
    obj = plane()
    folder = tempfile.mkdtemp(prefix="texsynth_surface_")
    bpy.ops.wm.save_as_mainfile(filepath=os.path.join(folder, "scene.blend"))
    props = bpy.context.scene.texsynth
    props.sample_path, props.method, props.scale, props.axis = BRICKS, "ROUND", 3.0, (0.0, 1.0, 0.0)
    props.bake_size, props.bake_margin, props.bake_save_mode = 64, 2, "NEXT_TO_BLEND"
    assert bpy.ops.texsynth.synthesize() == {"FINISHED"}
    path = os.path.join(folder, "TexSynth Round_ Plane.png")
    assert os.path.isfile(path), os.listdir(folder)
    assert bpy.path.abspath(bpy.data.images["TexSynth Round: Plane"].filepath) == path
    assert bpy.ops.texsynth.preprocess() == {"FINISHED"}  # nothing to preprocess, says so


def test_settings_persist_in_the_blend_file():
    plane()
    props = bpy.context.scene.texsynth
    props.method, props.surface_target, props.round_levels, props.round_coarse_rings = "ROUND", "VERTICES", 4, 3
    props.round_fine_rings, props.round_candidates, props.round_resolution = 1, 5, "FULL"
    path = os.path.join(tempfile.mkdtemp(), "round.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path)
    bpy.ops.wm.read_homefile(use_empty=True)
    bpy.ops.wm.open_mainfile(filepath=path)
    settings = bpy.context.scene.texsynth.to_settings()
    assert (settings.method, settings.surface_target, settings.round_levels, settings.round_coarse_rings,
            settings.round_fine_rings, settings.round_candidates, settings.round_resolution) == \
        ("ROUND", "VERTICES", 4, 3, 1, 5, "FULL")


def test_layers_only_image_survives_save_and_reload():
    # Material mode Layers Only: the packed image is the only output and nothing uses it yet.
    obj = plane()
    report = run([obj], material_mode="NONE")
    assert report.objects == ["Plane"] and not obj.material_slots, report.summary()
    image = bpy.data.images["TexSynth Round: Plane"]
    assert image.packed_file is not None and "(packed)" in report.summary()
    digest = harness.pixel_digest(image)
    harness.save_and_reload("round.blend")
    image = bpy.data.images.get("TexSynth Round: Plane")
    assert image is not None, sorted(i.name for i in bpy.data.images)
    assert image.packed_file is not None and harness.pixel_digest(image) == digest


def test_layers_only_image_survives_when_the_image_it_replaced_was_shown_elsewhere():
    # Found by the workflow soak (seed 109): a material of the artist's showed the previous result; the new
    # image takes its users, so it still had one when the run ended and got no fake user; once that material
    # no longer shows it, the save drops the result the report named.
    obj = plane()
    run([obj])  # shown by TexSynth's material: no fake user
    viewer = bpy.data.materials.new("Viewer")
    viewer.use_nodes = True
    node = viewer.node_tree.nodes.new("ShaderNodeTexImage")
    node.image = bpy.data.images["TexSynth Round: Plane"]
    obj.data.materials.clear()
    for material in [m for m in bpy.data.materials if m.name.startswith("TexSynth")]:
        bpy.data.materials.remove(material)
    run([obj], material_mode="NONE")
    image = bpy.data.images["TexSynth Round: Plane"]
    assert node.image == image  # the new result took the old one's users
    digest = harness.pixel_digest(image)
    node.image = None
    harness.save_and_reload("round_shown.blend")
    image = bpy.data.images.get("TexSynth Round: Plane")
    assert image is not None, sorted(i.name for i in bpy.data.images)
    assert harness.pixel_digest(image) == digest


def test_a_uv_map_made_for_a_mesh_without_one_is_active_and_bake_works_after():
    # Smart UV Project on a mesh with no UV map: the mesh had no active UV map (index -1) and must not be left
    # with that index now that it has one, or Cycles' bake refuses it ("No active UV layer found").
    harness.reset_scene()
    obj = harness.add_primitive("cube", "Cube")
    obj.data.uv_layers.remove(obj.data.uv_layers[0])
    harness.select_only([obj])
    assert obj.data.uv_layers.active_index == -1
    report = run([obj], options.BakeRequest(size=64, margin=2, create_uv=True))
    assert report.objects == ["Cube"], report.summary()
    layers = obj.data.uv_layers
    assert [layer.name for layer in layers] == ["UVMap"]
    assert 0 <= layers.active_index < len(layers) and layers.active is not None, layers.active_index
    assert layers[layers.active_index].name == "UVMap"
    # Then a UV method on the same mesh, and Bake through the map made above.
    settings_jumpmap = core_settings.Settings(method="JUMPMAP", sample_world_size=3.0, seed=3, axis=(0.0, 1.0, 0.0))
    uv_report = synthesis.synthesize([obj], sources.Sample(path=os.path.join(harness.SAMPLES_DIR, "moss.png")),
                                     settings_jumpmap, cache_dir=tempfile.mkdtemp(prefix="texsynth_surface_"))
    assert uv_report.objects == ["Cube"], uv_report.summary()
    layers = obj.data.uv_layers
    assert 0 <= layers.active_index < len(layers) and layers.active is not None, layers.active_index
    result = baking.bake(obj, options.BakeRequest(uv_map="UVMap", size=64, margin=2))
    assert result.uv_map == "UVMap" and tuple(result.image.size) == (64, 64)
    assert pixels_of(result.image)[..., 3].max() > 0.99  # something was baked
    # A mesh saved with no active UV map (Blender 3.4 keeps an index of -1, 4.x clamps it to 0): Bake makes
    # its map active while Cycles bakes, and leaves the index as it was.
    obj.data.uv_layers.active_index = -1
    index = obj.data.uv_layers.active_index
    result = baking.bake(obj, options.BakeRequest(uv_map="UVMap", size=64, margin=2, target="Baked Again"))
    assert tuple(result.image.size) == (64, 64) and obj.data.uv_layers.active_index == index


if __name__ == "__main__":
    harness.Checks().run([value for name, value in list(globals().items()) if name.startswith("test_")],
                         only=harness.script_args())

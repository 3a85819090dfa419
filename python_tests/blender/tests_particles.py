# SPDX-License-Identifier: GPL-3.0-or-later
"""Texture Particles inside Blender (addon/particles/, method PARTICLES):

  blender -b --factory-startup --python-exit-code 1 --python python_tests/blender/tests_particles.py [-- test_name ...]

The analysis view and the outputs' Blender side (decal objects, atlas, material, points, Geometry Nodes,
Clear, atomic failure) run on any build; the end-to-end runs (FULL_RUN_TESTS) need the native
place_particles and decal_mesh and are selected by python_tests/blender/test_blender_particles.py only when the
module has them. Expected values come from the drawn sample and the hand-made geometry, not from the add-on.
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
from texsynth import native  # noqa: E402
from texsynth.core import layers as core_layers  # noqa: E402
from texsynth.core import settings as core_settings  # noqa: E402
from texsynth.particles import core, outputs, scene, synthesis  # noqa: E402
from texsynth.bridge.sources import Sample  # noqa: E402

sys.path.insert(0, harness.SAMPLES_DIR)
import particle_instances  # noqa: E402

# python_tests/: the mesh helpers shared with the native tests.
sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
import mesh_arrays  # noqa: E402

GROUND = (0.2, 0.3, 0.25)
STONE = (0.9, 0.2, 0.1)
LEAF = (0.1, 0.6, 0.1)
FOLDER = tempfile.mkdtemp(prefix="texsynth_particles_")


def pebbles_path(name="pebbles.png", kind="pebbles", size=(96, 64), noise=0.0):
    """A PNG drawn here: ground, four 10 px stones and two 6 x 14 leaves (rows from the bottom); or 'flat'.
    noise: the deviation of a seeded Gaussian noise on the colours (then the analysis' settings change the
    filled background)."""
    path = os.path.join(FOLDER, name)
    width, height = size
    pixels = np.ones((height, width, 4), np.float32)
    pixels[..., :3] = GROUND
    if kind == "pebbles":
        for x0, y0 in [(8, 8), (40, 8), (70, 30), (20, 40)]:
            pixels[y0:y0 + 10, x0:x0 + 10, :3] = STONE
        for x0, y0 in [(55, 6), (82, 40)]:
            pixels[y0:y0 + 14, x0:x0 + 6, :3] = LEAF
    if noise:
        pixels[..., :3] = np.clip(pixels[..., :3] + np.random.default_rng(3).normal(0.0, noise, (height, width, 3)),
                                  0.0, 1.0)
    return harness.save_png(path, pixels)


def clean():
    harness.reset_scene()
    core.analyses.clear()


def configure(**values):
    props = bpy.context.scene.texsynth
    props.sample_source, props.sample_path, props.method = "FILE", pebbles_path(), "PARTICLES"
    props.particle_classes, props.particle_blur, props.scale = 3, 0.0, 1.0
    for key, value in values.items():
        setattr(props, key, value)
    return props


def plane(name="Plane", size=2.0, cuts=8):
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=cuts, y_subdivisions=cuts, size=size)
    obj = bpy.context.active_object
    obj.name = obj.data.name = name
    return obj


def names():
    """Every datablock name a run could create or remove."""
    return {kind: sorted(item.name for item in getattr(bpy.data, kind))
            for kind in ("objects", "meshes", "images", "materials", "node_groups", "collections")}


def class_ids():
    rows = bpy.context.scene.texsynth.particle_rows
    stone = next(r.class_id for r in rows if abs(r.colour[0] - STONE[0]) < 0.05 and abs(r.colour[1] - STONE[1]) < 0.05)
    leaf = next(r.class_id for r in rows if abs(r.colour[1] - LEAF[1]) < 0.05 and abs(r.colour[0] - LEAF[0]) < 0.05)
    return stone, leaf


# -- analysis view --------------------------------------------------------------------------------

def test_analyse_lists_the_classes_and_writes_the_segmentation_image():
    clean()
    configure()
    assert bpy.ops.texsynth.particle_analyse() == {"FINISHED"}
    props = bpy.context.scene.texsynth
    rows = props.particle_rows
    assert len(rows) == 3
    stone, leaf = class_ids()
    assert (rows[stone].pixels, rows[stone].particles, rows[stone].complete) == (400, 4, 4)
    assert (rows[leaf].pixels, rows[leaf].particles) == (168, 2)
    assert sum(r.background for r in rows) == 1 and not rows[stone].background
    image = bpy.data.images["TexSynth Segmentation: pebbles.png"]
    assert props.particle_preview == image and tuple(image.size) == (96, 64)
    pixels = np.array(image.pixels[:], np.float32).reshape(64, 96, 4)
    assert np.allclose(pixels[13, 13, :3], STONE, atol=0.02)       # inside a stone, in its class colour
    # Its outline: white, as the red's luminance (0.34) is below one half.
    assert np.allclose(pixels[8, 12, :3], 1.0, atol=0.02) and np.allclose(pixels[12, 17, :3], 1.0, atol=0.02)


def test_undo_of_an_analysis_restores_the_previous_segmentation_image():
    # Blender's undo does not restore the pixels of a packed image rewritten in place: each analysis must
    # give the preview as a new image (users remapped), so undo brings back the one before.
    clean()
    configure(particle_classes=2)
    name = "TexSynth Segmentation: pebbles.png"
    bpy.ops.ed.undo_push(message="before the analyses")
    assert bpy.ops.texsynth.particle_analyse("EXEC_DEFAULT", True) == {"FINISHED"}
    first = harness.pixel_digest(bpy.data.images[name])
    bpy.context.scene.texsynth.particle_classes = 4
    bpy.ops.ed.undo_push(message="Classes")  # what the sidebar edit pushes
    assert bpy.ops.texsynth.particle_analyse("EXEC_DEFAULT", True) == {"FINISHED"}
    assert len(bpy.context.scene.texsynth.particle_rows) == 4
    assert harness.pixel_digest(bpy.data.images[name]) != first
    bpy.ops.ed.undo()
    props = bpy.context.scene.texsynth
    assert props.particle_classes == 4 and len(props.particle_rows) == 2  # the step before the second analysis
    images = [image.name for image in bpy.data.images if image.name.startswith("TexSynth Segmentation: ")]
    assert images == [name], images
    assert props.particle_preview == bpy.data.images[name]
    assert harness.pixel_digest(bpy.data.images[name]) == first


def test_the_view_and_the_sidebar_draw_the_particle_section():
    clean()
    configure()
    bpy.ops.texsynth.particle_analyse()
    panel = texsynth.ui.panels.TEXSYNTH_PT_particles
    assert panel.poll(bpy.context)
    bpy.context.scene.texsynth.method = "JUMPMAP"
    assert not panel.poll(bpy.context)
    assert "PARTICLES" in bpy.context.scene.texsynth.bl_rna.properties["method"].enum_items.keys()


def test_show_in_image_editor_puts_the_segmentation_there():
    clean()
    configure()
    bpy.ops.texsynth.particle_analyse()
    image = bpy.context.scene.texsynth.particle_preview
    window = bpy.context.window_manager.windows[0] if bpy.context.window_manager.windows else None
    if window is None:  # background mode without a window: nothing to show in, a clear refusal
        try:
            bpy.ops.texsynth.particle_show_segmentation()
            raise AssertionError("showed an image without an Image Editor")
        except RuntimeError as error:
            assert "Image Editor" in str(error)
        return
    area = window.screen.areas[0]
    area.type = "IMAGE_EDITOR"
    with_area = {"window": window, "screen": window.screen, "area": area}
    if hasattr(bpy.context, "temp_override"):
        with bpy.context.temp_override(**with_area):
            assert bpy.ops.texsynth.particle_show_segmentation() == {"FINISHED"}
    else:
        assert bpy.ops.texsynth.particle_show_segmentation(with_area) == {"FINISHED"}
    assert area.spaces.active.image == image


def test_live_field_update_is_refused_for_particles():
    clean()
    configure()
    obj = plane()
    try:
        texsynth.ui.field_edits.live_update(bpy.context, obj)
        raise AssertionError("live update ran the UV path for Texture Particles")
    except core_settings.SettingsError as error:
        assert "not available for Texture Particles" in str(error), error
    assert "TexSynth" not in obj.data.uv_layers


def test_settings_persist_in_the_blend_file():
    clean()
    props = configure(particle_classes=5, particle_blur=2.0, particle_merges="3>1", particle_class_order="1, 2",
                      particle_output="BOTH", particle_size_jitter=0.3, particle_density_source="Dens",
                      particle_background="TEXTON")
    props.particle_collection = particle_instances.make_collection()
    props.particle_collection.use_fake_user = True
    path = os.path.join(FOLDER, "particles.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path)
    bpy.ops.wm.read_homefile(use_empty=True)
    bpy.ops.wm.open_mainfile(filepath=path)
    s = bpy.context.scene.texsynth.to_settings().validate()
    assert (s.method, s.particle_classes, s.particle_merges, s.particle_class_order, s.particle_output) == \
        ("PARTICLES", 5, ((3, 1),), (1, 2), "BOTH")
    assert (s.particle_collection, s.particle_density_source, s.particle_background) == \
        (particle_instances.NAME, "Dens", "TEXTON")
    assert abs(s.particle_blur - 2.0) < 1e-6 and abs(s.particle_size_jitter - 0.3) < 1e-6


def test_pick_class_selects_the_class_of_a_pixel():
    clean()
    configure()
    bpy.ops.texsynth.particle_analyse()
    stone, leaf = class_ids()
    assert bpy.ops.texsynth.particle_pick_class(x=12, y=12) == {"FINISHED"}
    assert bpy.context.scene.texsynth.particle_active_class == stone
    bpy.ops.texsynth.particle_pick_class(x=57, y=10)
    assert bpy.context.scene.texsynth.particle_active_class == leaf


def test_pick_class_reads_the_image_editor_cursor():
    from types import SimpleNamespace
    clean()
    configure()
    bpy.ops.texsynth.particle_analyse()
    image = bpy.context.scene.texsynth.particle_preview
    # The 2D cursor in image coordinates (0..1): (12.5 / 96, 12.5 / 64) is inside the first stone.
    space = SimpleNamespace(type="IMAGE_EDITOR", image=image, cursor_location=(12.5 / 96, 12.5 / 64))
    picker = texsynth.ui.particle_operators.TEXSYNTH_OT_particle_pick_class
    assert picker._cursor(SimpleNamespace(space_data=space)) == (12, 12)
    try:
        picker._cursor(SimpleNamespace(space_data=None))
        raise AssertionError("picked a class without an Image Editor")
    except core_settings.SettingsError as error:
        assert "Image Editor" in str(error)


def test_merge_and_background_edit_the_analysis():
    clean()
    props = configure()
    bpy.ops.texsynth.particle_analyse()
    stone, leaf = class_ids()
    props.particle_active_class, props.particle_merge_into = leaf, stone
    assert bpy.ops.texsynth.particle_merge() == {"FINISHED"}
    rows = props.particle_rows
    assert len(rows) == 2
    merged = next(r for r in rows if not r.background)
    assert (merged.pixels, merged.particles) == (568, 6)
    props.particle_active_class = merged.class_id
    try:  # the merged stones and leaves as background leave the ground as one border-cut region
        bpy.ops.texsynth.particle_set_background()
        raise AssertionError("a background leaving no complete particle was accepted")
    except RuntimeError as error:
        assert "complete particle" in str(error), error
    assert props.particle_background_class == -1 and len(props.particle_rows) == 2


def test_label_image_of_the_wrong_size_is_refused_and_changes_nothing():
    clean()
    props = configure()
    props.particle_label_image = bpy.data.images.new("Labels", 32, 32)
    before = names()
    try:
        bpy.ops.texsynth.particle_analyse()
        raise AssertionError("accepted a 32 x 32 label image for a 96 x 64 sample")
    except RuntimeError as error:
        assert "32 x 32 pixels but the sample is 96 x 64" in str(error), error
    assert names() == before


def test_label_image_replaces_the_segmentation():
    clean()
    props = configure()
    labels = bpy.data.images.new("Labels", 96, 64)
    pixels = np.zeros((64, 96, 4), np.float32)
    pixels[..., 3] = 1.0
    pixels[8:18, 8:18, 0] = 1.0   # one red square label: a single particle
    labels.pixels.foreach_set(pixels.ravel())
    props.particle_label_image = labels
    assert bpy.ops.texsynth.particle_analyse() == {"FINISHED"}
    rows = props.particle_rows
    assert len(rows) == 2 and sorted(r.particles for r in rows) == [0, 1]
    assert next(r for r in rows if not r.background).pixels == 100


# -- outputs (Blender side, hand-made geometry) ----------------------------------------------------

def square_decals(centres, half, cell):
    """decal_mesh-like dict: one quad per centre on z = 0.01, UVs the atlas cell (s0, t0, s1, t1)."""
    positions, corner_uvs = [], []
    for x, y in centres:
        positions += [(x - half, y - half, 0.01), (x + half, y - half, 0.01), (x + half, y + half, 0.01),
                      (x - half, y + half, 0.01)]
        corner_uvs += [(cell[0], cell[1]), (cell[2], cell[1]), (cell[2], cell[3]), (cell[0], cell[3])]
    n = len(centres)
    return {"positions": np.array(positions, np.float32), "loop_starts": np.arange(n, dtype=np.int32) * 4,
            "loop_totals": np.full(n, 4, np.int32), "corner_verts": np.arange(4 * n, dtype=np.int32),
            "corner_uvs": np.array(corner_uvs, np.float32), "face_particle": np.arange(n, dtype=np.int32),
            "source_triangle": np.zeros(n, np.int32), "source_barycentric": np.zeros((4 * n, 2), np.float32)}


def red_atlas(size=64):
    """A red disc of radius 24 px (alpha 1) on transparent pixels."""
    pixels = np.zeros((size, size, 4), np.float32)
    yy, xx = np.mgrid[0:size, 0:size]
    disc = (xx - size / 2 + 0.5) ** 2 + (yy - size / 2 + 0.5) ** 2 < 24 ** 2
    pixels[disc] = (1.0, 0.0, 0.0, 1.0)
    return pixels


def hand_outputs(target, collection=None, classes=(1, 2)):
    outputs = []
    for rank, c in enumerate(classes):
        out = scene.ClassOutput(c, rank, 3)
        out.decals = square_decals([(-0.5 + 0.5 * i, 0.2 * rank) for i in range(3)], 0.2, (0.0, 0.0, 1.0, 1.0))
        if collection is not None:
            out.points = dict(position=np.array([[0.3 * i, 0.0, 0.0] for i in range(3)], np.float32),
                              axis=np.tile([1.0, 0.0, 0.0], (3, 1)), normal=np.tile([0.0, 0.0, 1.0], (3, 1)),
                              scale=np.full((3, 3), 0.1, np.float32))
        outputs.append(out)
    return scene.write_outputs(target, outputs, red_atlas(), (64, 64), collection)


def test_decal_objects_per_class_with_particle_ids_uvs_and_an_alpha_material():
    clean()
    target = plane()
    made = hand_outputs(target)
    assert made == [scene.decal_name("Plane", 1), scene.decal_name("Plane", 2)]
    for name in made:
        obj = bpy.data.objects[name]
        assert obj.parent == target and obj[scene.TAG] == "Plane"
        ids = texsynth.bridge.mesh_io.read_face_ints(obj.data, core.PARTICLE_ID_NAME)
        assert ids.tolist() == [0, 1, 2]
        uv = np.empty(len(obj.data.loops) * 2, np.float32)
        obj.data.uv_layers[scene.ATLAS_UV].data.foreach_get("uv", uv)
        assert uv.min() >= 0.0 and uv.max() <= 1.0
    material = bpy.data.materials["TexSynth Particles: Plane"]
    texture = next(n for n in material.node_tree.nodes if n.type == "TEX_IMAGE")
    assert texture.extension == "CLIP" and texture.image.name == "TexSynth Atlas: Plane"
    principled = next(n for n in material.node_tree.nodes if n.type == "BSDF_PRINCIPLED")
    assert principled.inputs["Alpha"].is_linked
    blended = getattr(material, "surface_render_method", None) == "BLENDED" or \
        getattr(material, "blend_method", None) == "BLEND"
    assert blended
    atlas = np.array(texture.image.pixels[:], np.float32).reshape(64, 64, 4)
    assert atlas[32, 32, 3] == 1.0 and atlas[0, 0, 3] == 0.0


def test_moving_the_target_moves_its_decals():
    clean()
    target = plane()
    target.location = (5.0, 0.0, 0.0)
    bpy.context.view_layer.update()
    outputs = [scene.ClassOutput(1, 0, 1)]
    outputs[0].decals = square_decals([(5.0, 0.0)], 0.2, (0, 0, 1, 1))  # world space, as decal_mesh gives
    scene.write_outputs(target, outputs, red_atlas(), (64, 64))
    decal = bpy.data.objects[scene.decal_name("Plane", 1)]
    bpy.context.view_layer.update()
    world = decal.matrix_world @ decal.data.vertices[0].co
    assert abs(world.x - 4.8) < 1e-5, world


def test_instances_follow_the_points_through_geometry_nodes():
    clean()
    target = plane()
    collection = particle_instances.make_collection()
    hand_outputs(target, collection)
    points = bpy.data.objects[scene.points_name("Plane", 1)]
    mesh = points.data
    assert len(mesh.vertices) == 3 and len(mesh.polygons) == 0
    for name, kind in ((core.ROTATION_NAME, "FLOAT_VECTOR"), (core.SCALE_NAME, "FLOAT_VECTOR"), (core.CLASS_NAME, "INT")):
        assert mesh.attributes[name].data_type == kind and mesh.attributes[name].domain == "POINT"
    modifier = points.modifiers[scene.MODIFIER_NAME]
    assert modifier.node_group.name == "TexSynth Instances: " + collection.name
    depsgraph = bpy.context.evaluated_depsgraph_get()
    # Read while iterating: the instance structs do not outlive the iteration.
    instanced = [i.object.original.name for i in depsgraph.object_instances
                 if i.is_instance and i.parent is not None and i.parent.original == points]
    # class 1 picks the collection's child 1 in name order (Bead, Thorn)
    assert instanced == ["Thorn"] * 3, instanced


def test_clear_removes_every_particle_output_and_keeps_the_rest():
    clean()
    target = plane()
    collection = particle_instances.make_collection()
    before = names()
    hand_outputs(target, collection)
    assert names() != before
    harness.select_only([target])
    assert bpy.ops.texsynth.clear() == {"FINISHED"}
    assert names() == before, (names(), before)


def test_a_failure_while_creating_leaves_the_scene_unchanged():
    clean()
    target = plane()
    collection = particle_instances.make_collection()
    hand_outputs(target, collection, classes=(1,))
    before = names()
    first = bpy.data.objects[scene.decal_name("Plane", 1)].data.vertices[0].co.copy()
    os.environ["TEXSYNTH_TEST_FAIL_AT"] = "particle_outputs"
    try:
        hand_outputs(target, collection, classes=(1, 2))
        raise AssertionError("the injected failure did not stop the write")
    except RuntimeError as error:
        assert "injected" in str(error)
    finally:
        del os.environ["TEXSYNTH_TEST_FAIL_AT"]
    assert names() == before, (names(), before)
    assert bpy.data.objects[scene.decal_name("Plane", 1)].data.vertices[0].co == first


def test_rewriting_one_class_replaces_only_its_objects():
    clean()
    target = plane()
    hand_outputs(target, classes=(1, 2))
    other = bpy.data.objects[scene.decal_name("Plane", 2)]
    other_mesh = other.data.name
    atlas = bpy.data.images["TexSynth Atlas: Plane"]
    out = scene.ClassOutput(1, 0, 2)
    out.decals = square_decals([(0.0, 0.0), (0.5, 0.5)], 0.1, (0, 0, 1, 1))
    scene.write_outputs(target, [out], red_atlas(), (64, 64), keep_atlas=True)
    assert len(bpy.data.objects[scene.decal_name("Plane", 1)].data.polygons) == 2
    assert bpy.data.objects[scene.decal_name("Plane", 2)] == other and other.data.name == other_mesh
    assert len([o for o in bpy.data.objects if o.get(scene.TAG) == "Plane"]) == 2
    assert bpy.data.materials["TexSynth Particles: Plane"].users >= 2
    assert bpy.data.images["TexSynth Atlas: Plane"] == atlas, "the same atlas is kept, not packed again"
    # A full run (no keep_atlas) replaces every earlier output of the target: class 2 placed nothing now.
    scene.write_outputs(target, [out], red_atlas(), (64, 64))
    assert [o.name for o in bpy.data.objects if o.get(scene.TAG) == "Plane"] == [scene.decal_name("Plane", 1)]
    assert len([image for image in bpy.data.images if image.name.startswith("TexSynth Atlas")]) == 1


def test_eevee_render_shows_the_decal_sprites():
    # A grey plane seen from above with one decal quad over its middle showing the red disc: the rendered
    # centre turns red, the corners keep the plane's grey.
    decal_render_check("EEVEE")


def test_cycles_render_shows_the_decal_sprites():
    decal_render_check("CYCLES")


def decal_render_check(engine):
    clean()
    target = plane(size=2.0, cuts=2)
    grey = harness.emission_material("Grey", lambda nodes, links: _rgb(nodes, (0.5, 0.5, 0.5)))
    target.data.materials.append(grey)
    out = scene.ClassOutput(1, 0, 1)
    out.decals = square_decals([(0.0, 0.0)], 0.6, (0.0, 0.0, 1.0, 1.0))
    scene.write_outputs(target, [out], red_atlas(), (64, 64))
    top_camera(2.0)
    pixels = render_pixels("decal_%s.png" % engine.lower(), engine=engine)
    centre, corner = pixels[28:36, 28:36].mean(axis=(0, 1)), pixels[:6, :6].mean(axis=(0, 1))
    # Chromaticity, not brightness: the decal is lit (Principled), the plane emits its grey.
    assert centre[0] / max(centre.sum(), 1e-6) > 0.6, (centre, corner)
    assert abs(corner[0] - corner[1]) < 0.05 and corner[0] > 0.2, corner


def top_camera(ortho_scale):
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    camera.data.type = "ORTHO"
    camera.data.ortho_scale = ortho_scale
    camera.location = (0.0, 0.0, 3.0)
    bpy.context.scene.collection.objects.link(camera)
    bpy.context.scene.camera = camera
    bpy.context.scene.world = bpy.data.worlds.new("W")
    bpy.context.scene.world.color = (1.0, 1.0, 1.0)


def render_pixels(name, pixels=64, engine="EEVEE"):
    scene_ = harness.flat_render_settings(bpy.context.scene, pixels, samples=4)
    if engine == "CYCLES":
        scene_.render.engine = "CYCLES"
        scene_.cycles.samples = 4
        scene_.cycles.device = "CPU"
        scene_.cycles.use_denoising = False  # Debian's Blender has no OpenImageDenoise
    scene_.render.filepath = os.path.join(FOLDER, name)
    bpy.ops.render.render(write_still=True)
    image = bpy.data.images.load(scene_.render.filepath)
    values = np.array(image.pixels[:], np.float32).reshape(pixels, pixels, 4)[..., :3]
    bpy.data.images.remove(image)
    return values


def _rgb(nodes, colour):
    node = nodes.new("ShaderNodeRGB")
    node.outputs[0].default_value = tuple(colour) + (1.0,)
    return node.outputs[0]


# -- refusals that change nothing ------------------------------------------------------------------

def expect_error(fragment, **props):
    before = names()
    try:
        result = bpy.ops.texsynth.synthesize()
        raise AssertionError("Synthesize accepted it: %s" % result)
    except RuntimeError as error:
        assert fragment in str(error), str(error)
    assert names() == before


def test_one_colour_sample_is_refused_and_changes_nothing():
    clean()
    configure(sample_path=pebbles_path("flat.png", "flat"))
    harness.select_only([plane()])
    expect_error("no particles")


def test_a_mesh_with_no_area_is_refused():
    clean()
    configure()
    mesh = bpy.data.meshes.new("Flat")
    mesh.from_pydata([(0, 0, 0), (1, 0, 0), (2, 0, 0)], [], [(0, 1, 2)])
    obj = bpy.data.objects.new("Flat", mesh)
    bpy.context.scene.collection.objects.link(obj)
    harness.select_only([obj])
    expect_error("has no area")


def test_a_missing_or_empty_instance_collection_is_refused():
    clean()
    configure(particle_output="INSTANCES")
    harness.select_only([plane()])
    expect_error("needs an instance collection")
    empty = bpy.data.collections.new("Empty")
    configure(particle_output="INSTANCES", particle_collection=empty)
    expect_error("is empty")


def test_label_image_of_the_wrong_size_stops_synthesize():
    clean()
    props = configure()
    props.particle_label_image = bpy.data.images.new("Labels", 10, 10)
    harness.select_only([plane()])
    expect_error("but the sample is 96 x 64")


# -- end to end (native place_particles and decal_mesh) -------------------------------------------

def full_run(target, **values):
    configure(**values)
    harness.select_only([target])
    return bpy.ops.texsynth.synthesize("EXEC_DEFAULT", True)


def test_synthesize_makes_decals_per_class_with_ids_matching_the_placed_count():
    clean()
    target = plane(size=4.0, cuts=40)
    collection = particle_instances.make_collection()
    props = configure(scale=1.5, particle_output="BOTH", particle_collection=collection)
    report = synthesis.synthesize([target], Sample(path=props.sample_path), props.to_settings(), FOLDER)
    per_class = report.native_stats["Plane"]["per_class"]
    assert sum(per_class.values()) == report.native_stats["Plane"]["placed"] > 0, report.summary()
    decals = scene.owned_objects("Plane", ("DECALS",))
    assert sorted(o[scene.CLASS_TAG] for o in decals) == sorted(c for c, n in per_class.items() if n)
    for obj in decals:
        ids = texsynth.bridge.mesh_io.read_face_ints(obj.data, core.PARTICLE_ID_NAME)
        # every placed particle of the class has faces, numbered 0..n-1
        assert np.array_equal(np.unique(ids), np.arange(per_class[obj[scene.CLASS_TAG]])), obj.name
        uv = np.empty(len(obj.data.loops) * 2, np.float32)
        obj.data.uv_layers[scene.ATLAS_UV].data.foreach_get("uv", uv)
        assert uv.min() >= 0.0 and uv.max() <= 1.0
    assert "TexSynth" in target.data.uv_layers, "the background went through the jump map"
    depsgraph = bpy.context.evaluated_depsgraph_get()
    for points in scene.owned_objects("Plane", ("POINTS",)):
        count = sum(1 for i in depsgraph.object_instances if i.is_instance and i.parent is not None
                    and i.parent.original == points)
        assert count == per_class[points[scene.CLASS_TAG]] == len(points.data.vertices), points.name


def test_resynthesizing_one_class_gives_the_same_rows_and_leaves_the_others():
    clean()
    target = plane(size=4.0, cuts=40)
    full_run(target, scale=1.5)
    stone, leaf = class_ids() if bpy.context.scene.texsynth.particle_rows else (None, None)
    decals = {o.get(scene.CLASS_TAG): o for o in scene.owned_objects("Plane", ("DECALS",))}
    c = sorted(decals)[0]
    before = {k: harness.mesh_hash(o.data) for k, o in decals.items()}
    bpy.context.scene.texsynth.particle_active_class = c
    assert bpy.ops.texsynth.particle_resynthesize() == {"FINISHED"}
    after = {o.get(scene.CLASS_TAG): harness.mesh_hash(o.data) for o in scene.owned_objects("Plane", ("DECALS",))}
    assert after == before, "one class placed alone gives exactly its rows of the full run"


def test_undo_removes_what_synthesize_made():
    clean()
    target = plane(size=4.0, cuts=20)
    bpy.ops.ed.undo_push(message="before particles")
    before = names()
    assert full_run(target, scale=1.5) == {"FINISHED"}
    assert names() != before
    bpy.ops.ed.undo()
    assert names() == before


def test_density_override_of_zero_keeps_particles_off_those_faces():
    # FLOAT face attribute 'Dens': 0 on the faces left of x = 0, 1 elsewhere: every placed particle's anchor
    # (a point's position) lies on the right half.
    clean()
    target = plane(size=4.0, cuts=40)
    centres = np.empty(len(target.data.polygons) * 3, np.float32)
    target.data.polygons.foreach_get("center", centres)
    dens = target.data.attributes.new("Dens", "FLOAT", "FACE")
    dens.data.foreach_set("value", (centres.reshape(-1, 3)[:, 0] > 0).astype(np.float32))
    collection = particle_instances.make_collection()
    assert full_run(target, scale=1.5, particle_output="INSTANCES", particle_collection=collection,
                    particle_density_source="Dens") == {"FINISHED"}
    xs = np.concatenate([np.array([v.co.x for v in o.data.vertices]) for o in scene.owned_objects("Plane", ("POINTS",))])
    assert xs.size > 10 and xs.min() >= -1e-5, (xs.size, xs.min())
    configure(particle_density_source="NoSuchGroup")
    try:
        bpy.ops.texsynth.synthesize()
        raise AssertionError("a missing override was accepted")
    except RuntimeError as error:
        assert "no face attribute or vertex group 'NoSuchGroup'" in str(error), error


def test_probability_from_a_vertex_group_thins_the_particles():
    # Weight 1 on the vertices right of x = 0.5, 0 elsewhere: probability (mean of the triangle's weights) 0 on
    # most faces, so far fewer particles are output than with no override, and none far left.
    clean()
    target = plane(size=4.0, cuts=40)
    assert full_run(target, scale=1.5, particle_background="NONE") == {"FINISHED"}
    full = sum(np.unique(texsynth.bridge.mesh_io.read_face_ints(o.data, core.PARTICLE_ID_NAME)).size
               for o in scene.owned_objects("Plane", ("DECALS",)))
    group = target.vertex_groups.new(name="Keep")
    group.add([v.index for v in target.data.vertices if v.co.x > 0.5], 1.0, "REPLACE")
    collection = particle_instances.make_collection()
    assert full_run(target, scale=1.5, particle_background="NONE", particle_output="INSTANCES",
                    particle_collection=collection, particle_probability_source="Keep") == {"FINISHED"}
    xs = np.concatenate([np.array([v.co.x for v in o.data.vertices]) for o in scene.owned_objects("Plane", ("POINTS",))])
    assert 0 < xs.size < full / 2 and xs.min() > 0.4, (xs.size, full, xs.min())


def test_texton_background_writes_the_texton_layers():
    clean()
    target = plane(size=4.0, cuts=20)
    assert full_run(target, scale=1.5, particle_background="TEXTON") == {"FINISHED"}
    assert "TexSynth" in target.data.uv_layers and core_layers.EDGE_BLENDED_NAME in target.data.attributes
    assert scene.owned_objects("Plane", ("DECALS",))


def test_eevee_render_of_synthesized_decals_moves_towards_the_particle_colour():
    # The same view with the decals hidden and shown: the stones' red raises the red share of the image.
    clean()
    target = plane(size=4.0, cuts=40)
    assert full_run(target, scale=1.5) == {"FINISHED"}
    top_camera(4.0)
    decals = scene.owned_objects("Plane", ("DECALS",))
    for obj in decals:
        obj.hide_render = True
    without = render_pixels("without.png").mean(axis=(0, 1))
    for obj in decals:
        obj.hide_render = False
    with_decals = render_pixels("with.png").mean(axis=(0, 1))
    share = lambda rgb: rgb[0] / max(rgb.sum(), 1e-6)  # noqa: E731
    assert share(with_decals) > share(without) + 0.02, (with_decals, without)


def test_a_turned_and_scaled_target_gets_decals_on_its_surface_and_instances_along_its_normal():
    # The plane turned 90 degrees about x (its normal becomes -y... in world: (0, -1, 0) or (0, 1, 0)) and
    # scaled by 1.5: decal vertices lie within the class offsets of the plane y = 0, and every instance's
    # local Z axis is the plane's world normal.
    import math
    clean()
    target = plane(size=3.0, cuts=30)
    target.rotation_euler = (math.pi / 2, 0.0, 0.0)
    target.scale = (1.5, 1.5, 1.5)
    bpy.context.view_layer.update()
    normal = (target.matrix_world.to_3x3() @ target.data.polygons[0].normal).normalized()
    collection = particle_instances.make_collection()
    assert full_run(target, scale=1.5, particle_output="BOTH", particle_collection=collection,
                    particle_background="NONE") == {"FINISHED"}
    diagonal = 4.5 * math.sqrt(2.0)
    for obj in scene.owned_objects("Plane", ("DECALS",)):
        world = np.array([obj.matrix_world @ v.co for v in obj.data.vertices])
        top = outputs.decal_lift_top(core_settings.Settings().particle_classes, diagonal)  # every class band, at most
        assert np.abs(world[:, 1]).max() <= top + 1e-5, np.abs(world[:, 1]).max()
    depsgraph = bpy.context.evaluated_depsgraph_get()
    axes = [np.array(i.matrix_world.to_3x3().normalized().col[2]) for i in depsgraph.object_instances
            if i.is_instance and i.parent is not None and i.parent.original.get(scene.TAG) == "Plane"]
    assert axes and all(abs(float(np.dot(a, normal))) > 0.999 for a in axes), len(axes)


def test_a_failed_particle_write_leaves_the_scene_and_the_mesh_unchanged():
    clean()
    target = plane(size=4.0, cuts=20)
    configure(scale=1.5)
    harness.select_only([target])
    before, hashed = names(), harness.mesh_hash(target.data)
    os.environ["TEXSYNTH_TEST_FAIL_AT"] = "particle_outputs"
    try:
        bpy.ops.texsynth.synthesize()
        raise AssertionError("the injected failure was not reported")
    except RuntimeError as error:
        assert "injected" in str(error), error
    finally:
        del os.environ["TEXSYNTH_TEST_FAIL_AT"]
    # the background image file may be loaded by nothing: no datablock, no layer, no material changed
    assert names() == before and harness.mesh_hash(target.data) == hashed and not target.material_slots


def test_the_background_file_follows_the_analysis_and_a_damaged_one_is_rewritten():
    """The background PNG's folder is named after the filled background itself, so a label image (or any
    setting that changes the fill) gets its own file; a truncated file or one of another size there is
    written again, through a temporary file renamed into place."""
    from texsynth.bridge import sources
    clean()
    target = plane(size=4.0, cuts=20)
    props = configure(scale=1.5)
    cache = tempfile.mkdtemp(dir=FOLDER)

    def prepared(label_pixels=None):
        job = synthesis.Job([target], Sample(path=props.sample_path), props.to_settings(), cache,
                            label_pixels=label_pixels).prepare()
        path = job.background_job.sample.path
        stored = sources.decode_sample_file(path)  # row 0 = top, uint8 RGBA
        expected = np.clip(job.analysis.background[::-1, :, :3], 0.0, 1.0) * 255.0
        assert stored.shape[:2] == expected.shape[:2], (path, stored.shape)
        assert np.abs(stored[..., :3].astype(np.float32) - expected).max() <= 1.0, path
        return path

    drawn = prepared()
    labels = np.zeros((64, 96, 4), np.float32)
    labels[..., 3] = 1.0
    labels[8:18, 8:18, 0] = 1.0  # one square particle: another filled background
    labelled = prepared(labels)
    assert labelled != drawn and os.path.isfile(drawn)
    whole = open(labelled, "rb").read()
    for damaged in (whole[:len(whole) // 2], whole[:60]):
        with open(labelled, "wb") as handle:
            handle.write(damaged)
        assert prepared(labels) == labelled and open(labelled, "rb").read() == whole
    harness.save_png(labelled, np.ones((8, 8, 4), np.float32))  # a valid PNG of another size
    assert prepared(labels) == labelled and open(labelled, "rb").read() == whole
    written = [name for _, _, names in os.walk(cache) for name in names]
    assert not [name for name in written if name.startswith(".")], written  # no temporary file left


def twins():
    """Names Blender made unique with a '.001'-style suffix."""
    return [name for listed in names().values() for name in listed if re.search(r"\.\d{3}$", name)]


def shading_trees():
    """{(kind, name): use_nodes, nodes (name, type, image, group) and links} of every material and node group."""
    def tree(node_tree):
        if node_tree is None:
            return None
        nodes = sorted((node.name, node.bl_idname, getattr(getattr(node, "image", None), "name", None),
                        getattr(getattr(node, "node_tree", None), "name", None)) for node in node_tree.nodes)
        links = sorted((link.from_node.name, link.from_socket.identifier, link.to_node.name,
                        link.to_socket.identifier) for link in node_tree.links)
        return nodes, links
    found = {("materials", m.name): (m.use_nodes, tree(m.node_tree)) for m in bpy.data.materials}
    found.update({("node_groups", g.name): (True, tree(g)) for g in bpy.data.node_groups})
    return found


def test_two_analyses_of_one_sample_make_no_twins_and_undo_restores_their_materials():
    """Two runs on one sample with different analyses fill two different backgrounds. Each gets its own image
    and material name, never Blender's '.001' twin of the other: Blender 5.2's redo restored such a twin with
    another node tree (docs/benchmarks/workflow_soak.md). Undo and redo of the next operator give every
    material and node group back exactly."""
    clean()
    target = plane(size=4.0, cuts=20)
    bpy.ops.ed.undo_push(message="before particles")
    common = dict(scale=1.5, particle_output="DECALS", particle_background="JUMPMAP", material_mode="NEW",
                  sample_path=pebbles_path("noisy_pebbles.png", noise=0.05))

    def backgrounds():
        return {image.name: image.filepath for image in bpy.data.images
                if image.name.startswith(core.BACKGROUND_PREFIX)}

    assert full_run(target, particle_classes=3, particle_blur=0.0, **common) == {"FINISHED"}
    after_first, first = shading_trees(), backgrounds()
    assert full_run(target, particle_classes=4, particle_blur=1.0, **common) == {"FINISHED"}
    second = set(backgrounds().values()) - set(first.values())
    assert len(first) == len(second) == 1, "the two analyses fill different backgrounds"
    assert not twins(), twins()
    # the target shows the second background (its material is named after that image)
    assert [name for name, path in backgrounds().items() if path in second] == \
        [image.name for image in bpy.data.images if target.material_slots[0].material.name.endswith(image.name)]
    after_runs = shading_trees()
    harness.select_only([target])
    assert bpy.ops.texsynth.field_preset("EXEC_DEFAULT", True, preset="AXIS", iterations=1) == {"FINISHED"}
    after_preset = shading_trees()
    bpy.ops.ed.undo()
    assert shading_trees() == after_runs
    bpy.ops.ed.redo()
    assert shading_trees() == after_preset
    bpy.ops.ed.undo()
    bpy.ops.ed.undo()
    assert shading_trees() == after_first
    assert not twins(), twins()


def test_the_worker_thread_runs_the_job_as_the_modal_operator_does():
    import time
    clean()
    target = plane(size=4.0, cuts=20)
    props = configure(scale=1.5)
    job = synthesis.Job([target], Sample(path=props.sample_path), props.to_settings()).prepare()
    state = texsynth.ui.modal_jobs.ModalSynthesis(job).start()
    while state.running():
        time.sleep(0.02)
        assert 0.0 <= state.live_fraction() <= 1.0
    state.finish().apply()
    assert scene.owned_objects("Plane", ("DECALS",)) and job.report.objects == ["Plane"]


def test_cancel_leaves_nothing_behind():
    clean()
    target = plane(size=4.0, cuts=20)
    configure(scale=1.5)
    before = names()
    hashed = harness.mesh_hash(target.data)
    props = bpy.context.scene.texsynth
    job = synthesis.Job([target], Sample(path=props.sample_path), props.to_settings()).prepare()
    job.cancel()
    try:
        job.compute()
        raise AssertionError("compute() did not raise after cancel()")
    except texsynth.core.jobs.Cancelled:
        pass
    job.discard()
    assert names() == before and harness.mesh_hash(target.data) == hashed



# -- baking the particles with the background (particles/baking.py) --------------------------------

def _bake(target, size, margin=2):
    from texsynth.bake import baking
    from texsynth.core import bake_options as options
    result = baking.bake(target, options.BakeRequest(uv_map="UVMap", size=size, margin=margin))
    pixels = np.empty(size * size * 4, np.float32)
    result.image.pixels.foreach_get(pixels)
    return result, pixels.reshape(size, size, 4)


def _uv_affine(target):
    """(3, 2) A with bake UV = [x, y, 1] @ A on the grid (fitted from its UV map, exact for a grid)."""
    mesh = target.data
    loops = np.empty(len(mesh.loops), np.int64)
    mesh.loops.foreach_get("vertex_index", loops)
    co = np.empty(len(mesh.vertices) * 3, np.float32)
    mesh.vertices.foreach_get("co", co)
    uv = np.empty(len(mesh.loops) * 2, np.float32)
    mesh.uv_layers["UVMap"].data.foreach_get("uv", uv)
    xy1 = np.c_[co.reshape(-1, 3)[loops, :2], np.ones(len(loops))]
    affine = np.linalg.lstsq(xy1, uv.reshape(-1, 2), rcond=None)[0]
    assert np.abs(xy1 @ affine - uv.reshape(-1, 2)).max() < 1e-5
    return affine


def _expected_decal_texels(target, size):
    """From the decal objects' own vertices (not their source triangles), texel centres in bake space:
    (sure, atlas_uv, near): `sure` texels lie 0.75 texel inside one particle of the topmost class covering
    them and near no other particle of it or of a class above; atlas_uv (size, size, 2) there; `near` any
    texel within 1.5 texels of a decal."""
    affine = _uv_affine(target)
    sure = np.zeros((size, size), bool)
    near = np.zeros((size, size), bool)
    atlas_uv = np.zeros((size, size, 2))
    layers = sorted(scene.owned_objects(target.name, ("DECALS",)), key=lambda o: o[scene.RANK_TAG])
    for obj in layers:
        mesh = obj.data
        co = np.array([v.co[:2] for v in mesh.vertices])
        pixel = (np.c_[co, np.ones(len(co))] @ affine) * size - 0.5  # texel (i, j) centre at (i, j)
        uv = np.empty(len(mesh.loops) * 2, np.float32)
        mesh.uv_layers[scene.ATLAS_UV].data.foreach_get("uv", uv)
        uv = uv.reshape(-1, 2)
        ids = texsynth.bridge.mesh_io.read_face_ints(mesh, core.PARTICLE_ID_NAME)
        count = np.zeros((size, size), np.int32)  # particles of this class near each texel
        layer_sure = np.zeros((size, size), bool)
        for particle in np.unique(ids):
            mine = np.zeros((size, size), bool)
            for polygon in np.flatnonzero(ids == particle):
                p = mesh.polygons[int(polygon)]
                loops = list(range(p.loop_start, p.loop_start + p.loop_total))
                for k in range(1, len(loops) - 1):
                    corner = [loops[0], loops[k], loops[k + 1]]
                    tri = pixel[[mesh.loops[c].vertex_index for c in corner]]
                    lo, hi = np.floor(tri.min(0) - 2).astype(int), np.ceil(tri.max(0) + 2).astype(int)
                    lo, hi = np.clip(lo, 0, size - 1), np.clip(hi, 0, size - 1)
                    jj, ii = np.mgrid[lo[1]:hi[1] + 1, lo[0]:hi[0] + 1]
                    q = np.stack([ii.ravel(), jj.ravel()], 1).astype(float)
                    area = np.cross(tri[1] - tri[0], tri[2] - tri[0])
                    if abs(area) < 1e-9:
                        continue
                    dist = np.stack([np.cross(tri[(e + 1) % 3] - tri[e], q - tri[e]) / np.linalg.norm(
                        tri[(e + 1) % 3] - tri[e]) for e in range(3)], 1) * np.sign(area)
                    b = np.stack([np.cross(tri[2] - tri[1], q - tri[1]), np.cross(tri[0] - tri[2], q - tri[2]),
                                  np.cross(tri[1] - tri[0], q - tri[0])], 1) / area
                    inner = (dist >= 0.75).all(1)
                    mine[jj.ravel()[(dist >= -1.5).all(1)], ii.ravel()[(dist >= -1.5).all(1)]] = True
                    layer_sure[jj.ravel()[inner], ii.ravel()[inner]] = True
                    atlas_uv[jj.ravel()[inner], ii.ravel()[inner]] = b[inner] @ uv[corner]
            count += mine
        sure &= ~(count > 0)          # a class above covers (or nearly covers) it
        sure |= layer_sure & (count == 1)
        near |= count > 0
    return sure, atlas_uv, near


def test_baking_composites_the_decals_over_the_background():
    clean()
    size = 256
    target = plane(size=4.0, cuts=40)
    assert full_run(target, scale=1.5) == {"FINISHED"}
    sure, atlas_uv, near = _expected_decal_texels(target, size)
    result, baked = _bake(target, size)
    assert any(note.startswith("particles: ") for note in result.notes), result.notes
    atlas = bpy.data.images[scene.ATLAS_PREFIX + "Plane"]
    width, height = atlas.size
    atlas_px = np.empty(width * height * 4, np.float32)
    atlas.pixels.foreach_get(atlas_px)
    atlas_px = atlas_px.reshape(height, width, 4)
    for obj in scene.owned_objects("Plane", ("DECALS",)):  # the background alone, for comparison
        scene.remove_object(obj)
    _, background = _bake(target, size)
    # Away from the decals: exactly the background bake.
    assert (~near).sum() > size * size // 4
    np.testing.assert_array_equal(baked[~near], background[~near])
    # Inside a decal where the sprite is opaque around the sampled point: the atlas colour there.
    ax = np.floor(atlas_uv[..., 0] * width - 0.5).astype(int)
    ay = np.floor(atlas_uv[..., 1] * height - 0.5).astype(int)
    checked = 0
    for j, i in zip(*np.nonzero(sure)):
        x, y = ax[j, i], ay[j, i]
        if x < 1 or y < 1 or x >= width - 2 or y >= height - 2:
            continue
        block = atlas_px[y - 1:y + 3, x - 1:x + 3]
        if block[..., 3].min() < 1.0:
            continue
        lo, hi = block[..., :3].min((0, 1)), block[..., :3].max((0, 1))
        assert (baked[j, i, :3] >= lo - 2 / 255).all() and (baked[j, i, :3] <= hi + 2 / 255).all(), (
            (i, j), baked[j, i], lo, hi)
        checked += 1
    assert checked > 200, checked
    print("checked %d decal texels, %d away from the decals" % (checked, (~near).sum()))
    changed = np.abs(baked[sure] - background[sure])[:, :3].max(1)
    assert (changed > 0.1).mean() > 0.3, "the decals' texels should mostly differ from the background"


def test_baking_refuses_a_target_edited_since_its_particles_and_changes_nothing():
    import bmesh
    clean()
    target = plane(size=4.0, cuts=20)
    assert full_run(target, scale=1.5) == {"FINISHED"}
    bm = bmesh.new()
    bm.from_mesh(target.data)
    bm.faces.ensure_lookup_table()
    bmesh.ops.delete(bm, geom=[bm.faces[0]], context="FACES")
    bm.to_mesh(target.data)
    bm.free()
    before = sorted(i.name for i in bpy.data.images)
    from texsynth.core import bake_options as options
    try:
        _bake(target, 128)
        raise AssertionError("a stale decal layer was baked")
    except options.BakeError as error:
        assert "'Plane' was edited" in str(error) and "synthesize the particles again" in str(error), error
    assert sorted(i.name for i in bpy.data.images) == before


def test_a_failed_particle_composite_leaves_no_image():
    clean()
    target = plane(size=4.0, cuts=20)
    assert full_run(target, scale=1.5) == {"FINISHED"}
    before = sorted(i.name for i in bpy.data.images)
    hashed = harness.mesh_hash(target.data)
    os.environ["TEXSYNTH_TEST_FAIL_AT"] = "particle_bake"
    try:
        _bake(target, 128)
        raise AssertionError("the injected failure was not reported")
    except RuntimeError as error:
        assert "injected" in str(error), error
    finally:
        del os.environ["TEXSYNTH_TEST_FAIL_AT"]
    assert sorted(i.name for i in bpy.data.images) == before and harness.mesh_hash(target.data) == hashed

def overlapping_decals_render(engine, stack):
    """Two overlapping squares of one class through the real decal_mesh at the add-on's lifts, particle 0 red
    and particle 1 blue, rendered from above: (overlap, red-only part, blue-only part) mean colours."""
    clean()
    target = plane(size=2.0, cuts=8)
    grey = harness.emission_material("Grey", lambda nodes, links: _rgb(nodes, (0.5, 0.5, 0.5)))
    target.data.materials.append(grey)
    mesh = target.data
    positions = np.empty(len(mesh.vertices) * 3, np.float32)
    mesh.vertices.foreach_get("co", positions)
    mesh.calc_loop_triangles()
    triangles = np.empty(len(mesh.loop_triangles) * 3, np.int32)
    mesh.loop_triangles.foreach_get("vertices", triangles)
    positions, triangles = positions.reshape(-1, 3), triangles.reshape(-1, 3)
    module = native.require()
    walk = module.surface_walk_mesh(positions, triangles)
    # Squares 0.8 wide: they overlap on x in [-0.2, 0.2].
    anchors = [mesh_arrays.locate(positions, triangles, (x, 0.05)) for x in (-0.2, 0.2)]
    lift = outputs.decal_lift(0, outputs.bbox_diagonal(positions))
    if not stack:
        lift["stack_step"] = 0.0
    decals = module.decal_mesh(walk, np.array([a[0] for a in anchors], np.int32), np.array([a[1] for a in anchors]),
                               np.array([[1.0, 0, 0]] * 2), np.array([[-0.4, -0.4, 0.4, 0.4]] * 2),
                               np.array([[0.05, 0.05, 0.45, 0.95], [0.55, 0.05, 0.95, 0.95]]), **lift)
    atlas = np.zeros((64, 64, 4), np.float32)
    atlas[:, :32], atlas[:, 32:] = (1.0, 0.0, 0.0, 1.0), (0.0, 0.0, 1.0, 1.0)  # cell 0 red, cell 1 blue
    out = scene.ClassOutput(1, 0, 2)
    out.decals = dict(decals)
    scene.write_outputs(target, [out], atlas, (64, 64))
    top_camera(2.0)
    pixels = render_pixels("overlap_%s_%s.png" % (engine.lower(), "stacked" if stack else "flat"), engine=engine)
    # 64 px over 2 units: x = -1 + (i + 0.5) / 32. Overlap x in (-0.2, 0.2) -> columns 26..37; y (-0.35, 0.45).
    rows = slice(22, 44)
    return (pixels[rows, 27:37].reshape(-1, 3), pixels[rows, 17:24].reshape(-1, 3),
            pixels[rows, 40:47].reshape(-1, 3)), decals


def chromaticity(rgb):
    return rgb / np.maximum(rgb.sum(axis=1, keepdims=True), 1e-6)


def overlap_check(engine):
    (overlap, red_part, blue_part), decals = overlapping_decals_render(engine, stack=True)
    assert list(decals["level"]) == [0, 1], decals["level"]
    # The decals are lit (Principled under a white world), so colours are compared by chromaticity with each
    # decal's own part: every overlap pixel shows the higher decal (blue), as the bake composites it.
    red, blue = np.median(chromaticity(red_part), axis=0), np.median(chromaticity(blue_part), axis=0)
    assert red[0] > 0.5 and blue[2] > 0.5, (red, blue)
    off_blue = np.abs(chromaticity(overlap) - blue).max(axis=1)
    assert off_blue.max() < 0.1, (engine, float(off_blue.max()), float((off_blue >= 0.1).mean()))
    (flat_overlap, _, _), _ = overlapping_decals_render(engine, stack=False)
    flat = chromaticity(flat_overlap)
    print("DECAL_OVERLAP %s: stacked %.3f of the overlap shows the upper decal; at one height %.3f the first, "
          "%.3f the second" % (engine, float((off_blue < 0.1).mean()),
                               float((np.abs(flat - red).max(axis=1) < 0.1).mean()),
                               float((np.abs(flat - blue).max(axis=1) < 0.1).mean())))


def test_overlapping_decals_of_one_class_render_whole_in_eevee():
    overlap_check("EEVEE")


def test_overlapping_decals_of_one_class_render_whole_in_cycles():
    overlap_check("CYCLES")


def instance_footprints(target_name):
    """Every instance of a target's points as a rectangle on the z = 0 plane: (centre, x axis, y axis, half
    extents) of the instanced object's own bounding box under the instance's world matrix."""
    rects = []
    depsgraph = bpy.context.evaluated_depsgraph_get()
    for inst in depsgraph.object_instances:
        if not (inst.is_instance and inst.parent is not None and inst.parent.original.get(scene.TAG) == target_name):
            continue
        matrix = np.array(inst.matrix_world, np.float64)
        corners = np.array([tuple(c) for c in inst.object.original.bound_box], np.float64) @ matrix[:3, :3].T
        corners = corners[:, :2] + matrix[:2, 3]
        x_axis = matrix[:2, 0] / np.linalg.norm(matrix[:2, 0])
        y_axis = np.array([-x_axis[1], x_axis[0]])
        local = corners @ np.column_stack([x_axis, y_axis])
        low, high = local.min(axis=0), local.max(axis=0)
        rects.append(((low + high) / 2 @ np.vstack([x_axis, y_axis]), x_axis, y_axis, (high - low) / 2))
    return rects


def unit_box_collection(name="TexSynth Test Boxes"):
    """A collection holding one unit cube centred on its origin: its instances cover their particles'
    boxes exactly, with or without fitting."""
    import bmesh
    collection = bpy.data.collections.new(name)
    mesh = bpy.data.meshes.new("Box")
    bm = bmesh.new()
    bmesh.ops.create_cube(bm, size=1.0)
    bm.to_mesh(mesh)
    bm.free()
    collection.objects.link(bpy.data.objects.new("Box", mesh))
    return collection


def test_instances_sit_inside_their_particles_boxes_whatever_the_object_was_modelled_as():
    """Issue 30: the example thorn is modelled from its base at the origin to +Y, 0.37 wide, and was scaled
    as if a unit object centred on its origin, so it reached half a box beyond its particle. Each object is
    now fitted inside its particle's box (proportions kept): the thorns' footprints are centred in, and lie
    within, those of unit cubes placed by the same run (same seed, same placement), touching one pair of
    sides."""
    footprints = {}
    for key in ("thorns", "boxes"):
        clean()
        target = plane(size=4.0, cuts=40)
        collection = particle_instances.make_collection() if key == "thorns" else unit_box_collection()
        assert full_run(target, scale=1.5, particle_output="INSTANCES", particle_collection=collection,
                        particle_background="NONE", particle_classes=2) == {"FINISHED"}
        footprints[key] = instance_footprints("Plane")
    thorns, boxes = footprints["thorns"], footprints["boxes"]
    assert len(thorns) == len(boxes) > 10, (len(thorns), len(boxes))
    box_centres = np.array([rect[0] for rect in boxes])
    side = float(np.median([2 * rect[3].min() for rect in boxes]))
    for centre, x_axis, y_axis, half in thorns:
        k = int(np.argmin(np.linalg.norm(box_centres - centre, axis=1)))
        box_centre, box_x, box_y, box_half = boxes[k]
        assert np.linalg.norm(box_centre - centre) < 1e-3 * side, (centre, box_centre, side)
        # the thorn's half extents along the box's own axes
        reach = np.array([half[0] * abs(np.dot(x_axis, box_x)) + half[1] * abs(np.dot(y_axis, box_x)),
                          half[0] * abs(np.dot(x_axis, box_y)) + half[1] * abs(np.dot(y_axis, box_y))])
        assert np.all(reach <= box_half + 1e-3 * side), (reach, box_half)
        assert np.max(reach / box_half) > 1 - 1e-3, (reach, box_half)


FULL_RUN_TESTS = ("test_instances_sit_inside_their_particles_boxes_whatever_the_object_was_modelled_as",
                  "test_synthesize_makes_decals_per_class_with_ids_matching_the_placed_count",
                  "test_resynthesizing_one_class_gives_the_same_rows_and_leaves_the_others",
                  "test_undo_removes_what_synthesize_made", "test_cancel_leaves_nothing_behind",
                  "test_eevee_render_of_synthesized_decals_moves_towards_the_particle_colour",
                  "test_density_override_of_zero_keeps_particles_off_those_faces",
                  "test_texton_background_writes_the_texton_layers",
                  "test_the_worker_thread_runs_the_job_as_the_modal_operator_does",
                  "test_a_turned_and_scaled_target_gets_decals_on_its_surface_and_instances_along_its_normal",
                  "test_a_failed_particle_write_leaves_the_scene_and_the_mesh_unchanged",
                  "test_the_background_file_follows_the_analysis_and_a_damaged_one_is_rewritten",
                  "test_two_analyses_of_one_sample_make_no_twins_and_undo_restores_their_materials",
                  "test_probability_from_a_vertex_group_thins_the_particles",
                  "test_baking_composites_the_decals_over_the_background",
                  "test_baking_refuses_a_target_edited_since_its_particles_and_changes_nothing",
                  "test_a_failed_particle_composite_leaves_no_image",
                  "test_overlapping_decals_of_one_class_render_whole_in_eevee",
                  "test_overlapping_decals_of_one_class_render_whole_in_cycles")


if __name__ == "__main__":
    only = harness.script_args()
    if not only:  # without a selection: everything this build can run
        full = hasattr(native.require(), "place_particles") and hasattr(native.require(), "decal_mesh")
        only = [name for name in globals() if name.startswith("test_") and (full or name not in FULL_RUN_TESTS)]
    harness.Checks().run([value for name, value in list(globals().items()) if name.startswith("test_")], only=only)

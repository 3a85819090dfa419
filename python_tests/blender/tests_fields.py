# SPDX-License-Identifier: GPL-3.0-or-later
"""Direction/scale field tests inside Blender (needs the real texsynth_native).
Run: blender -b --factory-startup --python-exit-code 1 --python <this> [-- names]"""
import math
import os
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))  # uv_jacobians
import bpy  # noqa: E402
import numpy as np  # noqa: E402

import harness  # noqa: E402
from uv_jacobians import triangle_jacobians  # noqa: E402

texsynth = harness.load_addon()
from texsynth import native  # noqa: E402
from texsynth.bridge import mesh_io  # noqa: E402
from texsynth.core import layers as core_layers  # noqa: E402
from texsynth.fields import mesh_state  # noqa: E402
from texsynth.uv_methods import core as uv_core  # noqa: E402
from texsynth.fields import authoring, overlay  # noqa: E402
from texsynth.ui import field_edits  # noqa: E402
from texsynth.ui import field_operators  # noqa: E402

assert native.get() is not None and hasattr(native.get(), "RayCaster"), native.reason()
BRICKS = os.path.join(harness.SAMPLES_DIR, "bricks.png")
texsynth.register()


def fresh_scene():
    for collection in (bpy.data.objects, bpy.data.meshes, bpy.data.materials, bpy.data.node_groups,
                       bpy.data.images, bpy.data.grease_pencils):
        for item in list(collection):
            collection.remove(item)
    props = bpy.context.scene.texsynth
    for key, value in dict(sample_source="FILE", sample_path=BRICKS, scale=2.0, seed=3, orientation="AXIS",
                           axis=(0.0, 0.0, 1.0), direction_attribute=authoring.DIRECTION_NAME, blend=False,
                           allow_oversized=False, material_mode="NONE", scale_source="NONE",
                           field_brush_radius=0.3, field_brush_strength=1.0, field_live_update=False).items():
        setattr(props, key, value)
    return props


def grid_object(name="Plane", size=2.0, cuts=40, rotation=(0.0, 0.0, 0.0), location=(0.0, 0.0, 0.0)):
    """A subdivided plane (quads) of `size` world units, rotated/translated (object space != world)."""
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=cuts, y_subdivisions=cuts, size=size, location=location,
                                    rotation=rotation)
    obj = bpy.context.active_object
    obj.name = obj.data.name = name
    harness.select_only([obj])
    return obj


def angle_deg(a, b):
    a = a / np.linalg.norm(a, axis=-1, keepdims=True)
    b = b / np.linalg.norm(b, axis=-1, keepdims=True)
    return np.degrees(np.arccos(np.clip(np.sum(a * b, axis=-1), -1.0, 1.0)))


def world_direction(obj):
    local = mesh_io.read_point_attribute(obj.data, authoring.DIRECTION_NAME, "FLOAT_VECTOR")
    return local @ np.array(obj.matrix_world, np.float64)[:3, :3].T


def face_frames(obj, uv_name="TexSynth"):
    """Per polygon (first triangle): world 3D direction of texture 'up' (+V) and |dUV| per unit."""
    arrays = mesh_io.read_mesh(obj)
    uv = np.empty(len(obj.data.loops) * 2, np.float32)
    obj.data.uv_layers[uv_name].data.foreach_get("uv", uv)
    uv = uv.reshape(-1, 2).astype(np.float64)
    c = arrays.poly_starts[:, None] + np.arange(3)[None, :]
    J, e1, e2 = triangle_jacobians(arrays.positions[arrays.corner_verts[c]], uv[c])  # plane coords -> UV
    up2 = np.linalg.solve(J, np.tile([0.0, 1.0], (len(J), 1))[..., None])[..., 0]
    return up2[:, :1] * e1 + up2[:, 1:] * e2, np.sqrt(np.abs(np.linalg.det(J))), arrays


# ---------------------------------------------------------------------------------------------

def test_comb_stroke_on_a_rotated_plane_writes_object_space_attributes():
    fresh_scene()
    obj = grid_object(rotation=(0.0, 0.0, math.radians(30)), location=(1.0, 2.0, 0.5))
    state = mesh_state.field_state(bpy.context, obj)
    brush = authoring.CombBrush(state, mesh_state.caster_for(obj, state.arrays), 0.25)
    start, end = np.array([0.2, 2.0, 0.5]), np.array([1.8, 2.0, 0.5])  # world +X stroke through the plane
    for s in np.linspace(0, 1, 25):
        brush.dab(start + s * (end - start) + (0, 0, 3), (0, 0, -1))
    assert brush.end_stroke()
    field_edits.commit_edit(bpy.context, obj, state)
    world = world_direction(obj)
    positions = state.arrays.positions
    core = (np.abs(positions[:, 1] - 2.0) < 0.1) & (positions[:, 0] > 0.4) & (positions[:, 0] < 1.6)
    assert core.sum() > 20
    assert np.max(angle_deg(world[core], np.array([1.0, 0.0, 0.0]))) < 3.0
    # Object-space storage: the local vector is the world one rotated back by -30 degrees.
    local = mesh_io.read_point_attribute(obj.data, authoring.DIRECTION_NAME, "FLOAT_VECTOR")[core]
    expected_local = np.array([math.cos(math.radians(-30)), math.sin(math.radians(-30)), 0.0])
    assert np.max(angle_deg(local, expected_local)) < 3.0
    guide = mesh_io.read_point_attribute(obj.data, authoring.GUIDE_NAME, "FLOAT_VECTOR")
    assert np.any(guide != 0, axis=1).sum() > 20


def test_source_and_sink_operators_store_singularities_and_orient_the_field():
    fresh_scene()
    obj = grid_object()
    arrays = mesh_io.read_mesh(obj)
    centre = int(np.argmin(np.linalg.norm(arrays.positions[:, :2] - (0.5, 0.0), axis=1)))
    other = int(np.argmin(np.linalg.norm(arrays.positions[:, :2] - (-0.5, 0.0), axis=1)))
    assert bpy.ops.texsynth.singularity(mode="SOURCE", vertex=centre) == {"FINISHED"}
    assert bpy.ops.texsynth.singularity(mode="SINK", vertex=other) == {"FINISHED"}
    singular = mesh_io.read_point_attribute(obj.data, authoring.SINGULARITY_NAME, "INT")
    assert singular[centre] == 1 and singular[other] == -1 and np.count_nonzero(singular) == 2
    d = world_direction(obj)
    p = arrays.positions
    near_source = (np.linalg.norm(p - p[centre], axis=1) < 0.3) & (np.linalg.norm(p - p[centre], axis=1) > 0.1)
    near_sink = (np.linalg.norm(p - p[other], axis=1) < 0.3) & (np.linalg.norm(p - p[other], axis=1) > 0.1)
    assert np.median(angle_deg(d[near_source], p[near_source] - p[centre])) < 10.0
    assert np.median(angle_deg(d[near_sink], p[other] - p[near_sink])) < 10.0
    assert bpy.ops.texsynth.singularity(mode="REMOVE", vertex=centre) == {"FINISHED"}
    assert mesh_io.read_point_attribute(obj.data, authoring.SINGULARITY_NAME, "INT")[centre] == 0
    # A bad vertex index is an error that changes nothing.
    before = harness.mesh_hash(obj.data)
    try:
        bpy.ops.texsynth.singularity(mode="SOURCE", vertex=10 ** 7)
        raise AssertionError("expected an error")
    except RuntimeError as error:
        assert "not in the mesh" in str(error)
    assert harness.mesh_hash(obj.data) == before


def test_presets_axis_curvature_smooth():
    props = fresh_scene()
    props.axis = (1.0, 0.0, 0.0)
    segments, rows = 64, 24  # an open tube along Z, radius 0.5, length 3
    a = np.linspace(0, 2 * np.pi, segments, endpoint=False)
    verts = [(0.5 * math.cos(t), 0.5 * math.sin(t), z) for z in np.linspace(-1.5, 1.5, rows + 1) for t in a]
    faces = [(i * segments + j, i * segments + (j + 1) % segments, (i + 1) * segments + (j + 1) % segments,
              (i + 1) * segments + j) for i in range(rows) for j in range(segments)]
    mesh = bpy.data.meshes.new("Tube")
    mesh.from_pydata(verts, [], faces)
    cylinder = bpy.data.objects.new("Tube", mesh)
    bpy.context.scene.collection.objects.link(cylinder)
    cylinder.rotation_euler = (0.3, 0.0, 0.0)  # world axis tilted: checks the object -> world transform
    bpy.context.view_layer.update()
    harness.select_only([cylinder])
    tube_axis = np.array(cylinder.matrix_world, np.float64)[:3, 2]
    assert bpy.ops.texsynth.field_preset(preset="AXIS") == {"FINISHED"}
    inner = np.abs(np.array(verts)[:, 2]) < 1.2  # away from the open rims (one-sided estimates)
    along = lambda: np.abs(world_direction(cylinder)[inner] @ tube_axis)
    assert np.median(along()) < 0.5  # the X axis projected on the tube: mostly across it
    assert bpy.ops.texsynth.field_preset(preset="CURVATURE") == {"FINISHED"}
    assert np.min(along()) > 0.99, np.min(along())
    assert bpy.ops.texsynth.field_preset(preset="SMOOTH", iterations=5) == {"FINISHED"}
    assert np.min(along()) > 0.99


def draw_guide_stroke(points):
    """One stroke through `points` (world space) the way this Blender lets a script draw it: an
    annotation (3.x, 5.x: legacy strokes with strokes.new) or, where annotation strokes cannot be made
    from Python (4.3), a Grease Pencil v3 object, offset by its transform to check that it is applied."""
    if hasattr(bpy.data, "annotations"):
        data = bpy.data.annotations.new("Annotations")
        bpy.context.scene.annotation = data
    else:
        data = bpy.data.grease_pencils.new("Annotations")
        bpy.context.scene.grease_pencil = data
    frame = data.layers.new("Note").frames.new(bpy.context.scene.frame_current)
    if hasattr(frame.strokes, "new"):
        stroke = frame.strokes.new()
        stroke.points.add(len(points))
        stroke.points.foreach_set("co", points.astype(np.float32).ravel())
        return "annotation"
    data.layers.remove(data.layers[0])
    gp = bpy.data.grease_pencils_v3.new("Guide")
    obj = bpy.data.objects.new("Guide", gp)
    bpy.context.scene.collection.objects.link(obj)
    obj.location = (0.0, 0.0, 2.0)
    drawing = gp.layers.new("Guide").frames.new(bpy.context.scene.frame_current).drawing
    drawing.add_strokes([len(points)])
    local = (points - np.array(obj.location)).astype(np.float32)
    drawing.attributes["position"].data.foreach_set("vector", local.ravel())
    bpy.context.view_layer.update()
    obj.select_set(True)
    return "grease pencil v3 object"


def test_field_from_annotation_strokes():
    props = fresh_scene()
    props.field_brush_radius = 0.15
    obj = grid_object()
    t = np.linspace(0, 1, 30)
    points = np.column_stack([-0.6 + 1.2 * t, 0.3 * np.sin(2 * t), np.full_like(t, 0.001)])
    kind = draw_guide_stroke(points)
    print("guide stroke drawn as", kind)
    assert len(field_operators.guide_strokes(bpy.context)) == 1
    assert bpy.ops.texsynth.field_from_strokes() == {"FINISHED"}
    d = world_direction(obj)
    positions = mesh_io.read_mesh(obj).positions
    tangents = authoring.stroke_tangents(points)
    errors = [angle_deg(d[np.argmin(np.linalg.norm(positions - point, axis=1))], tangent)
              for point, tangent in zip(points[3:-3], tangents[3:-3])]
    assert max(errors) < 8.0, errors


def test_fields_survive_save_and_reload():
    fresh_scene()
    obj = grid_object()
    state = mesh_state.field_state(bpy.context, obj)
    authoring.set_singularity(state, 5, authoring.SINK)
    state.guide[100] = (0.0, 1.0, 0.0)
    authoring.relax(state)
    field_edits.commit_edit(bpy.context, obj, state)
    scale = np.linspace(0.5, 2.0, len(obj.data.vertices)).astype(np.float32)
    mesh_io.write_point_attribute(obj.data, authoring.SCALE_NAME, "FLOAT", scale)
    saved = {name: mesh_io.read_point_attribute(obj.data, name, kind) for name, kind in (
        (authoring.DIRECTION_NAME, "FLOAT_VECTOR"), (authoring.GUIDE_NAME, "FLOAT_VECTOR"),
        (authoring.SINGULARITY_NAME, "INT"), (authoring.SCALE_NAME, "FLOAT"))}
    path = os.path.join(tempfile.mkdtemp(), "fields.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path)
    bpy.ops.wm.read_homefile(use_empty=True)
    bpy.ops.wm.open_mainfile(filepath=path)
    mesh = bpy.data.objects["Plane"].data
    for (name, kind), values in zip(((authoring.DIRECTION_NAME, "FLOAT_VECTOR"), (authoring.GUIDE_NAME, "FLOAT_VECTOR"),
                                     (authoring.SINGULARITY_NAME, "INT"), (authoring.SCALE_NAME, "FLOAT")), saved.values()):
        np.testing.assert_array_equal(mesh_io.read_point_attribute(mesh, name, kind), values)
    assert saved[authoring.SINGULARITY_NAME][5] == -1


def swirl_field(obj):
    """A world-space field rotating with the distance from the centre, written as the direction."""
    arrays = mesh_io.read_mesh(obj)
    angle = 1.5 * np.linalg.norm(arrays.positions[:, :2], axis=1)
    world = np.column_stack([-np.sin(angle), np.cos(angle), np.zeros_like(angle)])
    inverse = np.linalg.inv(np.array(obj.matrix_world, np.float64)[:3, :3])
    mesh_io.write_point_attribute(obj.data, authoring.DIRECTION_NAME, "FLOAT_VECTOR", world @ inverse.T)
    return world


def test_synthesize_follows_the_direction_attribute_angle_statistics():
    props = fresh_scene()
    props.orientation = "FIELD"
    obj = grid_object(cuts=50, rotation=(0.0, 0.0, 0.4))
    world = swirl_field(obj)
    assert bpy.ops.texsynth.synthesize() == {"FINISHED"}
    up, _, arrays = face_frames(obj)
    face_field = np.array([world[arrays.corner_verts[s:s + k]].mean(0) for s, k in zip(arrays.poly_starts,
                                                                                      arrays.poly_sizes)])
    errors = angle_deg(up, face_field)
    print("rotation error deg: median %.2f p95 %.2f max %.2f" % (np.median(errors), np.percentile(errors, 95),
                                                                 errors.max()))
    assert np.median(errors) < 3.0 and np.percentile(errors, 95) < 8.0


def test_synthesize_follows_the_scale_vertex_group_and_attribute():
    props = fresh_scene()
    obj = grid_object(cuts=50)
    arrays = mesh_io.read_mesh(obj)
    weights = (arrays.positions[:, 0] + 1.0) / 2.0  # 0 .. 1 along x
    group = obj.vertex_groups.new(name="Density")
    for index, weight in enumerate(weights):
        group.add([index], float(weight), "REPLACE")
    props.scale_source, props.scale_group, props.scale_min, props.scale_max = "VERTEX_GROUP", "Density", 0.5, 2.0
    assert bpy.ops.texsynth.synthesize() == {"FINISHED"}
    _, density, _ = face_frames(obj)
    multiplier = 0.5 + 1.5 * weights
    face_multiplier = np.array([multiplier[arrays.corner_verts[s:s + k]].mean() for s, k in
                                zip(arrays.poly_starts, arrays.poly_sizes)])
    base = 1.0 / props.scale  # UV units per world unit at multiplier 1 (the sample spans `scale` units)
    relative = density / (base * face_multiplier) - 1.0
    print("scale error: median %.3f p95 %.3f" % (np.median(np.abs(relative)), np.percentile(np.abs(relative), 95)))
    assert np.median(np.abs(relative)) < 0.03 and np.percentile(np.abs(relative), 95) < 0.1
    # Same through the attribute (and a bad attribute is refused, naming it).
    mesh_io.write_point_attribute(obj.data, authoring.SCALE_NAME, "FLOAT", multiplier)
    props.scale_source = "ATTRIBUTE"
    assert bpy.ops.texsynth.synthesize() == {"FINISHED"}
    _, density2, _ = face_frames(obj)
    np.testing.assert_allclose(density2, density, rtol=0.02)
    mesh_io.write_point_attribute(obj.data, authoring.SCALE_NAME, "FLOAT", np.zeros_like(multiplier))
    try:
        bpy.ops.texsynth.synthesize()
        raise AssertionError("expected an error")
    except RuntimeError as error:
        assert "TexSynth_Scale" in str(error) and "> 0" in str(error), str(error)


def test_cli_direction_and_scale_flags():
    fresh_scene()
    obj = grid_object(cuts=40)
    world = swirl_field(obj)
    multiplier = np.full(len(obj.data.vertices), 2.0, np.float32)
    mesh_io.write_point_attribute(obj.data, authoring.SCALE_NAME, "FLOAT", multiplier)
    sys.path.insert(0, harness.ADDON_DIR)
    import texsynth_cli
    texsynth_cli.main(["--sample", BRICKS, "--object", "Plane", "--scale", "2", "--no-blend", "--material", "none",
                       "--direction-attribute", authoring.DIRECTION_NAME, "--scale-attribute", authoring.SCALE_NAME])
    up, density, arrays = face_frames(obj)
    face_field = np.array([world[arrays.corner_verts[s:s + k]].mean(0) for s, k in zip(arrays.poly_starts,
                                                                                      arrays.poly_sizes)])
    assert np.median(angle_deg(up, face_field)) < 3.0
    assert abs(np.median(density) / (2.0 / 2.0) - 1.0) < 0.03  # multiplier 2 at scale 2: 1 UV unit per world unit
    try:
        texsynth_cli.main(["--sample", BRICKS, "--object", "Plane", "--direction-attribute", "Missing"])
        raise AssertionError("expected an error")
    except texsynth_cli.CliError as error:
        assert "Missing" in str(error)


def test_live_update_resynthesizes_after_an_edit():
    props = fresh_scene()
    obj = grid_object(cuts=30)
    props.field_live_update = True
    assert bpy.ops.texsynth.field_preset(preset="AXIS") == {"FINISHED"}  # axis Z projected: degenerate -> fallback
    first = np.empty(len(obj.data.loops) * 2, np.float32)
    obj.data.uv_layers["TexSynth"].data.foreach_get("uv", first)
    assert bpy.ops.texsynth.singularity(mode="SOURCE", vertex=0) == {"FINISHED"}
    second = np.empty_like(first)
    obj.data.uv_layers["TexSynth"].data.foreach_get("uv", second)
    assert not np.array_equal(first, second)
    assert field_edits.last_timings["live_native"] > 0
    # A failing live update (no sample) keeps the field edit and only warns.
    props.sample_path = "/no/such/sample.png"
    field_edits._live_samples.clear()
    assert bpy.ops.texsynth.singularity(mode="SINK", vertex=1) == {"FINISHED"}
    assert mesh_io.read_point_attribute(obj.data, authoring.SINGULARITY_NAME, "INT")[1] == -1
    third = np.empty_like(first)
    obj.data.uv_layers["TexSynth"].data.foreach_get("uv", third)
    np.testing.assert_array_equal(third, second)


def texsynth_layers(obj):
    """Every TexSynth corner layer's values, for bit-exact comparisons."""
    mesh = obj.data
    layers = {}
    for layer in mesh.uv_layers:
        if core_layers.is_texsynth_uv_name(layer.name):
            values = np.empty(len(mesh.loops) * 2, np.float32)
            layer.data.foreach_get("uv", values)
            layers["uv:" + layer.name] = values
    for name in core_layers.ATTRIBUTE_NAMES:
        attribute = mesh.attributes.get(name)
        if attribute is not None:
            values = np.empty(len(mesh.loops) * 4, np.float32)
            attribute.data.foreach_get("color", values)
            layers[name] = values
    return layers


def assert_same_layers(a, b):
    assert sorted(a) == sorted(b), (sorted(a), sorted(b))
    for name in a:
        np.testing.assert_array_equal(a[name], b[name], err_msg=name)


def live_scene():
    """A rotated, translated grid (object space != world) with blending (1 UV map + 3 colours)."""
    props = fresh_scene()
    props.blend, props.field_live_update, props.orientation = True, True, "FIELD"
    return props, grid_object(cuts=24, rotation=(0.3, 0.0, math.radians(30)), location=(1.0, 2.0, 0.5))


def comb(state, obj, direction, centre_vertex=100):
    """A stroke of anchors around one vertex along `direction`, then the relaxation (as Comb does)."""
    caster = mesh_state.caster_for(obj, state.arrays)
    ids, distances = caster.vertices_within(state.arrays.positions[centre_vertex], 0.4)
    authoring.paint(state, ids, authoring.falloff(distances, 0.4), direction)
    authoring.relax(state)


def test_live_update_from_memory_equals_the_old_path_and_a_fresh_synthesize():
    props, obj = live_scene()
    state = mesh_state.field_state(bpy.context, obj)
    results = {}
    try:
        for k, path in enumerate(("full", "sequential", "")):
            os.environ[field_edits.LIVE_PATH_ENV] = path
            comb(state, obj, (1.0, 0.5 * k, 0.0), centre_vertex=100 + 40 * k)
            assert field_edits.commit_edit(bpy.context, obj, state) is None
            assert field_edits.last_timings["live_from_memory"] == (path != "full")
            results[path] = texsynth_layers(obj)
            assert "TexSynth_Sets01" in results[path] and "uv:TexSynth" in results[path]
            # The field attributes hold the edit, and a fresh Synthesize (re-reading mesh and field)
            # gives exactly the live update's layers.
            stored = mesh_io.read_point_attribute(obj.data, authoring.DIRECTION_NAME, "FLOAT_VECTOR")
            np.testing.assert_array_equal(stored, mesh_state.field_attributes(obj, state)[authoring.DIRECTION_NAME][1])
            harness.select_only([obj])
            assert bpy.ops.texsynth.synthesize() == {"FINISHED"}
            assert_same_layers(texsynth_layers(obj), results[path])
    finally:
        os.environ.pop(field_edits.LIVE_PATH_ENV, None)
    # Each stroke changed the result (the live update did re-synthesize).
    assert not np.array_equal(results["full"]["uv:TexSynth"], results[""]["uv:TexSynth"])
    # Same state -> same layers on every path, and repeatable (deterministic for the seed).
    for path in ("full", "sequential", "", ""):
        os.environ[field_edits.LIVE_PATH_ENV] = path
        try:
            assert field_edits.commit_edit(bpy.context, obj, state) is None
        finally:
            os.environ.pop(field_edits.LIVE_PATH_ENV, None)
        assert_same_layers(texsynth_layers(obj), results[""])


def test_live_update_from_memory_falls_back_when_the_mesh_changed():
    props, obj = live_scene()
    state = mesh_state.field_state(bpy.context, obj)
    comb(state, obj, (1.0, 0.0, 0.0))
    obj.data.vertices[5].co.z += 0.01  # e.g. an edit behind the session's back: the state is stale
    assert field_edits.commit_edit(bpy.context, obj, state) is None
    assert field_edits.last_timings["live_from_memory"] is False
    live = texsynth_layers(obj)
    harness.select_only([obj])
    assert bpy.ops.texsynth.synthesize() == {"FINISHED"}
    assert_same_layers(texsynth_layers(obj), live)
    # Another direction attribute than the field's: read from the mesh as Synthesize does.
    props.direction_attribute = "Other"
    mesh_io.write_point_attribute(obj.data, "Other", "FLOAT_VECTOR",
                                  np.tile([1.0, 0.0, 0.0], (len(obj.data.vertices), 1)))
    state = mesh_state.field_state(bpy.context, obj)
    assert field_edits.commit_edit(bpy.context, obj, state) is None
    assert field_edits.last_timings["live_from_memory"] is False


def test_live_update_from_memory_failing_write_keeps_the_field_and_restores_the_layers():
    props, obj = live_scene()
    state = mesh_state.field_state(bpy.context, obj)
    comb(state, obj, (1.0, 0.0, 0.0))
    assert field_edits.commit_edit(bpy.context, obj, state) is None
    before = texsynth_layers(obj)
    comb(state, obj, (0.0, 1.0, 0.0), centre_vertex=300)
    for point in ("uv_layer", "sets", "weights"):
        os.environ[mesh_io.FAIL_AT_ENV] = point
        try:
            warning = field_edits.commit_edit(bpy.context, obj, state)
        finally:
            os.environ.pop(mesh_io.FAIL_AT_ENV)
        assert warning is not None and "injected failure" in warning, warning
        assert field_edits.last_timings["live_from_memory"] is True
        assert_same_layers(texsynth_layers(obj), before)  # the layers as before the failed update
        stored = mesh_io.read_point_attribute(obj.data, authoring.GUIDE_NAME, "FLOAT_VECTOR")
        np.testing.assert_array_equal(stored, mesh_state.field_attributes(obj, state)[authoring.GUIDE_NAME][1])
    # An error in the worker thread reaches the caller as a warning after the field was written.
    original = uv_core.synthesize

    def failing(*args, **kwargs):
        raise RuntimeError("native failure in the worker")
    uv_core.synthesize = failing
    try:
        comb(state, obj, (1.0, 1.0, 0.0), centre_vertex=200)
        warning = field_edits.commit_edit(bpy.context, obj, state)
    finally:
        uv_core.synthesize = original
    assert warning is not None and "native failure in the worker" in warning, warning
    assert_same_layers(texsynth_layers(obj), before)
    stored = mesh_io.read_point_attribute(obj.data, authoring.DIRECTION_NAME, "FLOAT_VECTOR")
    np.testing.assert_array_equal(stored, mesh_state.field_attributes(obj, state)[authoring.DIRECTION_NAME][1])
    # A bad scale attribute is refused before the worker starts; the field edit is kept as well.
    props.scale_source, props.scale_attribute = "ATTRIBUTE", "Bad"
    mesh_io.write_point_attribute(obj.data, "Bad", "FLOAT", np.zeros(len(obj.data.vertices)))
    comb(state, obj, (1.0, -1.0, 0.0), centre_vertex=250)
    warning = field_edits.commit_edit(bpy.context, obj, state)
    assert warning is not None and "Bad" in warning, warning
    assert_same_layers(texsynth_layers(obj), before)
    stored = mesh_io.read_point_attribute(obj.data, authoring.DIRECTION_NAME, "FLOAT_VECTOR")
    np.testing.assert_array_equal(stored, mesh_state.field_attributes(obj, state)[authoring.DIRECTION_NAME][1])


def test_live_update_from_memory_is_undone_with_the_edit():
    props, obj = live_scene()
    state = mesh_state.field_state(bpy.context, obj)
    comb(state, obj, (1.0, 0.0, 0.0))
    assert field_edits.commit_edit(bpy.context, obj, state) is None
    bpy.ops.ed.undo_push(message="first stroke")
    before = harness.mesh_hash(obj.data)
    comb(state, obj, (0.0, 1.0, 0.0), centre_vertex=300)
    assert field_edits.commit_edit(bpy.context, obj, state) is None
    assert field_edits.last_timings["live_from_memory"] is True
    assert harness.mesh_hash(obj.data) != before
    bpy.ops.ed.undo_push(message="second stroke")  # what Blender does after the undoable operator
    bpy.ops.ed.undo()
    assert harness.mesh_hash(bpy.data.objects["Plane"].data) == before


def test_panel_and_overlay_geometry():
    fresh_scene()
    from texsynth.fields import overlay
    from texsynth.ui import panels
    log = []

    class Layout:
        def __getattr__(self, name):
            def record(*args, **kwargs):
                log.append((name, args, kwargs))
                return Layout()
            return record
    panels.TEXSYNTH_PT_field.draw(type("P", (), {"layout": Layout()})(), bpy.context)
    operators = {args[0] for kind, args, _ in log if kind == "operator"}
    assert operators == {"texsynth.comb", "texsynth.singularity", "texsynth.field_preset",
                         "texsynth.field_from_strokes"}, operators
    # Arrows: one shaft + two barbs per chosen vertex, shaft along the direction with the given length.
    positions = np.random.default_rng(1).random((1000, 3)).astype(np.float32)
    normals = np.tile([0.0, 0.0, 1.0], (1000, 1))
    directions = np.tile([1.0, 0.0, 0.0], (1000, 1))
    lines = overlay.arrow_lines(positions, normals, directions, 0.2, 0.1).reshape(-1, 6, 3)
    assert 150 < len(lines) < 250
    np.testing.assert_allclose(lines[:, 1] - lines[:, 0], np.tile([0.1, 0.0, 0.0], (len(lines), 1)), atol=1e-6)
    assert len(overlay.arrow_lines(positions, normals, directions, 1.0, 0.1)) == 6 * 1000
    circle = overlay.circle_lines((1.0, 2.0, 3.0), (0.0, 0.6, 0.8), 0.5, segments=32).reshape(-1, 3)
    offsets = circle - (1.0, 2.0, 3.0)
    np.testing.assert_allclose(np.linalg.norm(offsets, axis=1), 0.5, atol=1e-5)
    np.testing.assert_allclose(offsets @ np.array([0.0, 0.6, 0.8]), 0.0, atol=1e-5)
    assert len(circle) == 64
    obj = grid_object(size=2.0, cuts=10)  # 10 x 10 quads of side 0.2
    assert abs(overlay.mean_edge_length(mesh_io.read_mesh(obj)) - 0.2) < 1e-6


def test_register_adds_and_removes_the_comb_workspace_tool():
    from bl_ui.space_toolsystem_common import ToolSelectPanelHelper
    registered = ToolSelectPanelHelper._tool_class_from_space_type("VIEW_3D")._tools
    assert overlay.COMB_TOOL_ID in repr(registered["OBJECT"])
    texsynth.unregister()
    try:
        assert overlay.COMB_TOOL_ID not in repr(registered["OBJECT"])
        assert not hasattr(bpy.types, "TEXSYNTH_OT_comb")
    finally:
        texsynth.register()
    assert overlay.COMB_TOOL_ID in repr(registered["OBJECT"])
    assert not overlay.comb_tool_active(bpy.context)


if __name__ == "__main__":
    harness.Checks().run([value for name, value in list(globals().items()) if name.startswith("test_")],
                         only=harness.script_args())

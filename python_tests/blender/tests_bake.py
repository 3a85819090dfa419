# SPDX-License-Identifier: GPL-3.0-or-later
"""Bake checks inside Blender (addon/bake/baking.py):

  blender -b --factory-startup --python-exit-code 1 --python python_tests/blender/tests_bake.py [-- test_name ...]

Expected values come from the meshes' own UV coordinates, an independent render and the sample's
pixels, never from the add-on's code. Images stay small (64-256 px): the machine is shared.
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
from texsynth.bridge import images, uv_maps  # noqa: E402
from texsynth.core import bake_options as options  # noqa: E402
from texsynth.core import settings as core_settings  # noqa: E402
from texsynth.uv_methods import synthesis  # noqa: E402
from texsynth.bridge import sources  # noqa: E402

CACHE = tempfile.mkdtemp(prefix="texsynth_bake_tests_")
MOSS = os.path.join(harness.SAMPLES_DIR, "moss.png")      # 160 x 160
BRICKS = os.path.join(harness.SAMPLES_DIR, "bricks.png")  # 192 x 192


def synthesize(obj, method="JUMPMAP", sample=MOSS, scale=1.25, material_mode="NEW"):
    settings = core_settings.Settings(method=method, sample_world_size=scale, seed=3, axis=(0.0, 1.0, 0.0))
    report = synthesis.synthesize([obj], sources.Sample(path=sample), settings, cache_dir=CACHE,
                                  material_mode=material_mode)
    assert not report.failures and report.objects, report.summary()


def pixels_of(image):
    """float (H, W, 4), row 0 = bottom (Blender's order)."""
    values = np.empty(len(image.pixels), np.float32)
    image.pixels.foreach_get(values)
    return values.reshape(image.size[1], image.size[0], image.channels)


def plane(size=2.0):
    """A 2 x 2 grid of 8 x 8 quads (faces smaller than the sample) with Blender's default UV map."""
    harness.reset_scene()
    obj = harness.add_primitive("grid", "Plane", x_subdivisions=8, y_subdivisions=8, size=size)
    harness.select_only([obj])
    return obj


def state_of(obj):
    """Everything a failed bake must leave as it was."""
    materials = {m.name: sorted((n.name, n.type, n.select) for n in m.node_tree.nodes) for m in bpy.data.materials
                 if m.node_tree is not None}
    actives = {m.name: getattr(m.node_tree.nodes.active, "name", None) for m in bpy.data.materials if m.node_tree}
    scene = bpy.context.scene
    return dict(images=sorted(i.name for i in bpy.data.images), materials=materials, actives=actives,
                groups=sorted(g.name for g in bpy.data.node_groups), mesh=harness.mesh_hash(obj.data),
                slots=[s.material.name if s.material else None for s in obj.material_slots],
                engine=scene.render.engine, samples=scene.cycles.samples,
                selected=sorted(o.name for o in bpy.context.view_layer.objects if o.select_get()),
                active=bpy.context.view_layer.objects.active.name if bpy.context.view_layer.objects.active else None)


def expect_bake_error(obj, request, *fragments):
    before = state_of(obj)
    try:
        baking.bake(obj, request)
    except (ValueError, RuntimeError) as error:  # BakeError is a ValueError; the injected failure a RuntimeError
        message = str(error)
        for fragment in fragments:
            assert fragment.lower() in message.lower(), (fragment, message)
    else:
        raise AssertionError("expected a bake error mentioning %s" % (fragments,))
    after = state_of(obj)
    for key in before:
        assert before[key] == after[key], (key, before[key], after[key])
    return message


def render_top_view(obj, pixels, path):
    """Eevee render of obj's TexSynth material as flat emission (group Color -> Emission) from an
    orthographic top camera framing the 2 x 2 plane: pixel (i, j) looks at x = -1 + (i + .5) / pixels * 2."""
    scene = bpy.context.scene
    material = obj.active_material
    tree = material.node_tree
    group = next(n for n in tree.nodes if n.type == "GROUP")
    emission = tree.nodes.new("ShaderNodeEmission")
    output = tree.nodes.new("ShaderNodeOutputMaterial")
    tree.links.new(group.outputs["Color"], emission.inputs["Color"])
    tree.links.new(emission.outputs["Emission"], output.inputs["Surface"])
    for node in tree.nodes:
        if node.type == "OUTPUT_MATERIAL":
            node.is_active_output = node == output
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    camera.data.type, camera.data.ortho_scale = "ORTHO", 2.0
    camera.location = (0.0, 0.0, 3.0)
    scene.collection.objects.link(camera)
    scene.camera = camera
    texsynth.compat.use_eevee(scene)
    scene.eevee.taa_render_samples = 1
    scene.render.resolution_x = scene.render.resolution_y = pixels
    scene.render.resolution_percentage = 100
    scene.view_settings.view_transform = "Standard"
    scene.render.image_settings.file_format = "PNG"
    scene.render.filepath = path
    bpy.ops.render.render(write_still=True)
    rendered = bpy.data.images.load(path, check_existing=False)
    result = pixels_of(rendered)[..., :3].copy()
    bpy.data.images.remove(rendered)
    return result


def test_jumpmap_bake_matches_a_top_view_render():
    """A 2 x 2 plane with its default UV map (u = (x + 1) / 2, v = (y + 1) / 2): texel (i, j) of an N x N
    bake has its centre where pixel (i, j) of an N x N orthographic top render looks, so the two images
    must agree pixel by pixel (both 8-bit sRGB, Blender's bottom-up order)."""
    obj = plane()
    # moss: 160 texels per 1.25 units = 128 px per unit = 1 texel per pixel at 256 px over 2 units.
    synthesize(obj)
    size = 256
    result = baking.bake(obj, options.BakeRequest(uv_map="UVMap", size=size, margin=4))
    assert result.uv_map == "UVMap" and not result.created_uv and result.image.packed_file is not None
    baked = pixels_of(result.image)
    assert baked.shape == (size, size, 4)
    assert np.all(baked[..., 3] > 0.99)  # the plane covers the whole UV square
    rendered = render_top_view(obj, size, os.path.join(CACHE, "top.png"))
    difference = np.abs(baked[..., :3] - rendered)
    # Control: the same images one sample width apart in x (different texture there) must differ far more.
    shifted = np.abs(np.roll(baked[..., :3], 37, axis=1) - rendered)
    print("BAKE vs render: mean %.4f, p99 %.4f; shifted control %.4f"
          % (difference.mean(), np.percentile(difference, 99), shifted.mean()))
    assert rendered.std() > 0.03  # not two flat images
    assert difference.mean() < 0.02, difference.mean()
    assert difference.mean() < 0.25 * shifted.mean(), (difference.mean(), shifted.mean())


def uv_triangles(mesh, name):
    """(T, 3, 2) UV triangles of UV map `name` (fan triangulation of each polygon)."""
    uv = np.empty(len(mesh.loops) * 2, np.float32)
    mesh.uv_layers[name].data.foreach_get("uv", uv)
    uv = uv.reshape(-1, 2)
    starts = np.empty(len(mesh.polygons), np.int32)
    sizes = np.empty(len(mesh.polygons), np.int32)
    mesh.polygons.foreach_get("loop_start", starts)
    mesh.polygons.foreach_get("loop_total", sizes)
    triangles = [(uv[s], uv[s + k], uv[s + k + 1]) for s, n in zip(starts, sizes) for k in range(1, n - 1)]
    return np.array(triangles, np.float64)


def covered_texels(triangles, size, inset=1e-3):
    """Texels whose centre lies strictly inside a UV triangle (by at least `inset` of barycentric weight);
    only the triangles' bounding box (plus a texel) is evaluated."""
    lo = np.clip(np.floor(triangles.reshape(-1, 2).min(axis=0) * size).astype(int) - 1, 0, size)
    hi = np.clip(np.ceil(triangles.reshape(-1, 2).max(axis=0) * size).astype(int) + 1, 0, size)
    u, v = np.meshgrid((np.arange(lo[0], hi[0]) + 0.5) / size, (np.arange(lo[1], hi[1]) + 0.5) / size)
    inside = np.zeros(u.shape, bool)  # row = v (bottom-up, as Blender's pixels)
    for a, b, c in triangles:
        det = (b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1])
        if abs(det) < 1e-12:
            continue
        l1 = ((u - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (v - a[1])) / det
        l2 = ((b[0] - a[0]) * (v - a[1]) - (u - a[0]) * (b[1] - a[1])) / det
        inside |= (l1 > inset) & (l2 > inset) & (1.0 - l1 - l2 > inset)
    covered = np.zeros((size, size), bool)
    covered[lo[1]:hi[1], lo[0]:hi[0]] = inside
    return covered


def grow(mask, steps):
    """mask grown by `steps` texels in the 8-neighbourhood (Chebyshev distance)."""
    out = mask.copy()
    for _ in range(steps):
        padded = np.pad(out, 1)
        out = np.zeros_like(out)
        for dy in (0, 1, 2):
            for dx in (0, 1, 2):
                out |= padded[dy:dy + mask.shape[0], dx:dx + mask.shape[1]]
    return out


def test_texton_cube_smart_uv_bake_covers_islands_and_margin():
    """A cube without UV maps: the bake makes one with Smart UV Project (and says so). Every texel whose
    centre is inside a UV triangle is baked (a sample colour), texels up to 2 px outside the islands are
    filled by the 3 px margin, texels far from every island keep the cleared (black) background."""
    harness.reset_scene()
    obj = harness.add_primitive("cube", "Cube")
    harness.select_only([obj])
    while obj.data.uv_layers:
        obj.data.uv_layers.remove(obj.data.uv_layers[0])
    synthesize(obj, method="TEXTON", sample=BRICKS, scale=3.5)
    expect_bake_error(obj, options.BakeRequest(size=256, margin=3), "no UV map besides", "Smart UV Project")
    size = 256
    result = baking.bake(obj, options.BakeRequest(size=size, margin=3, create_uv=True))
    assert result.created_uv and any("Smart UV Project" in note for note in result.notes), result.notes
    assert [l.name for l in obj.data.uv_layers] == ["TexSynth", result.uv_map], list(obj.data.uv_layers.keys())
    assert obj.data.uv_layers.active.name == "TexSynth"  # the active UV map was left alone
    baked = pixels_of(result.image)
    covered = covered_texels(uv_triangles(obj.data, result.uv_map), size)
    assert 0.2 < covered.mean() < 0.95, covered.mean()
    # Cycles clears the image to black before baking; no bricks texel is black (darkest sum of RGB
    # in the sample: printed below), so "black" = not baked.
    sample = bpy.data.images.load(BRICKS, check_existing=True)
    sample_rgb = pixels_of(sample)[..., :3].reshape(-1, 3)
    baked_sum = baked[..., :3].sum(axis=2)
    print("CUBE darkest sample texel %.4f, darkest covered baked texel %.4f"
          % (sample_rgb.sum(axis=1).min(), baked_sum[covered].min()))
    assert np.all(baked_sum[covered] > 0.0), int((baked_sum[covered] == 0).sum())
    ring = grow(covered, 2) & ~covered
    assert ring.any() and np.all(baked_sum[ring] > 0.0), int((baked_sum[ring] == 0).sum())
    far = ~grow(covered, 6)
    assert far.any() and np.all(baked_sum[far] == 0.0), int((baked_sum[far] > 0).sum())
    # Colours are the sample's: mean within 0.08 of the sample's mean (both 8-bit sRGB values).
    sample_mean = sample_rgb.mean(axis=0)
    baked_mean = baked[..., :3][covered].mean(axis=0)
    print("CUBE covered %.3f, colour mean baked %s sample %s" % (covered.mean(), baked_mean, sample_mean))
    assert np.all(np.abs(baked_mean - sample_mean) < 0.08), (baked_mean, sample_mean)


def bumpy_sphere(name, subdivisions=5, amplitude=0.12):
    """An icosphere with deterministic bumps: Smart UV Project cuts it into hundreds of islands, as it
    cuts scanned meshes."""
    obj = harness.add_primitive("ico_sphere", name, subdivisions=subdivisions)
    co = np.empty(len(obj.data.vertices) * 3, np.float32)
    obj.data.vertices.foreach_get("co", co)
    co = co.reshape(-1, 3)
    bumps = np.sin(7.0 * co[:, 0]) * np.sin(9.0 * co[:, 1] + 1.0) * np.sin(11.0 * co[:, 2] + 2.0)
    obj.data.vertices.foreach_set("co", (co * (1.0 + amplitude * bumps)[:, None]).ravel())
    obj.data.update()
    return obj


def test_a_new_uv_map_uses_the_image_and_keeps_islands_two_texels_apart():
    """Smart UV Project used to pad each island by a fraction of UV space (2 x margin / size): on a
    mesh cut into hundreds of islands most of the image stayed empty. Islands are now packed 2 texels
    apart: a large share of the image is used, and no texel of one island neighbours a texel of another
    (packed with no gap, 1,246 such pairs here)."""
    harness.reset_scene()
    obj = bumpy_sphere("Bumpy")
    harness.select_only([obj])
    while obj.data.uv_layers:
        obj.data.uv_layers.remove(obj.data.uv_layers[0])
    size = 1024
    name = uv_maps.smart_project(obj, options.BakeRequest(size=size, margin=16, create_uv=True), bpy.context)
    triangles = uv_triangles(obj.data, name)
    used = 0.5 * np.abs((triangles[:, 1, 0] - triangles[:, 0, 0]) * (triangles[:, 2, 1] - triangles[:, 0, 1])
                        - (triangles[:, 2, 0] - triangles[:, 0, 0]) * (triangles[:, 1, 1] - triangles[:, 0, 1])).sum()
    # Islands: faces joined through shared UV edges.
    mesh = obj.data
    uv = np.empty(len(mesh.loops) * 2, np.float32)
    mesh.uv_layers[name].data.foreach_get("uv", uv)
    print("BUMPY %d faces, UV share used %.3f" % (len(mesh.polygons), used))
    # No texel centre is covered by two islands once each island is grown by one texel: gaps >= 2 texels
    # apart from rounding (checked on 64 islands, for speed).
    starts = np.empty(len(mesh.polygons), np.int32)
    mesh.polygons.foreach_get("loop_start", starts)
    import bmesh
    bm = bmesh.new()
    bm.from_mesh(mesh)
    layer = bm.loops.layers.uv[name]
    bm.faces.ensure_lookup_table()
    island_of = np.full(len(bm.faces), -1)
    islands = 0
    for seed in range(len(bm.faces)):
        if island_of[seed] >= 0:
            continue
        stack = [seed]
        island_of[seed] = islands
        while stack:
            face = bm.faces[stack.pop()]
            for loop in face.loops:
                other = loop.link_loop_radial_next
                if other == loop or island_of[other.face.index] >= 0:
                    continue
                # Same UV edge on both sides: the faces share the island.
                if (loop[layer].uv - other.link_loop_next[layer].uv).length < 1e-6 and \
                        (loop.link_loop_next[layer].uv - other[layer].uv).length < 1e-6:
                    island_of[other.face.index] = islands
                    stack.append(other.face.index)
        islands += 1
    bm.free()
    print("BUMPY %d islands" % islands)
    assert islands > 100, islands
    assert used > 0.40, used  # 0.46 here; 0.07 with Smart UV Project's per-island fraction margin
    # Texels whose centre lies inside an island: no texel is inside two islands, and no texel inside one
    # island touches (8-neighbourhood) a texel inside another.
    corners = uv.reshape(-1, 2)
    owner = np.full((size, size), -1)
    for island in range(islands):
        tris = [(corners[starts[f]], corners[starts[f] + k], corners[starts[f] + k + 1])
                for f in np.flatnonzero(island_of == island) for k in range(1, mesh.polygons[f].loop_total - 1)]
        covered = covered_texels(np.array(tris, np.float64), size)
        assert not (covered & (owner >= 0)).any(), "islands overlap"
        owner[covered] = island
    padded = np.pad(owner, 1, constant_values=-1)
    clash = 0
    for dy in (0, 1, 2):
        for dx in (0, 1, 2):
            other = padded[dy:dy + size, dx:dx + size]
            clash += int(((owner >= 0) & (other >= 0) & (other != owner)).sum())
    assert clash == 0, clash


def test_gltf_round_trip_keeps_baked_image_and_uv_map():
    """Bake with the baked material assigned, export the object alone as GLB, import it into an empty
    scene: its Base Color image has the bake's size and pixels, and its mesh the bake's UV coordinates."""
    assert hasattr(bpy.ops.export_scene, "gltf") and hasattr(bpy.ops.import_scene, "gltf")
    obj = plane()
    other = harness.add_primitive("cube", "Other", location=(5.0, 0.0, 0.0))  # must not be exported
    harness.select_only([obj])
    synthesize(obj)
    size = 64
    result = baking.bake(obj, options.BakeRequest(uv_map="UVMap", size=size, margin=2, material="ASSIGN"))
    assert [s.material.name for s in obj.material_slots] == ["TexSynth Baked: Plane"]
    baked = pixels_of(result.image).copy()
    uv = np.empty(len(obj.data.loops) * 2, np.float32)
    obj.data.uv_layers["UVMap"].data.foreach_get("uv", uv)
    expected_uvs = set(map(tuple, np.round(uv.reshape(-1, 2), 4)))
    path = os.path.join(CACHE, "plane.glb")
    harness.select_only([obj])
    # TexSynth's FLOAT_COLOR corner attributes are not colours, but glTF exporters write colour attributes as
    # COLOR_n (3.x: the active one unless export_colors=False; 4.2+: all of them unless export_vertex_color
    # is NONE), which importers multiply into the base colour.
    exporter = bpy.ops.export_scene.gltf.get_rna_type().properties.keys()
    extra = {"export_vertex_color": "NONE"} if "export_vertex_color" in exporter else {"export_colors": False}
    bpy.ops.export_scene.gltf(filepath=path, export_format="GLB", use_selection=True, **extra)
    assert other.name == "Other"
    harness.reset_scene()
    # Blender 3.4's bundled glTF importer still uses np.bool, which NumPy 1.24 (Debian 12's) removed.
    had_alias = "bool" in np.__dict__
    if not had_alias:
        np.bool = bool
    try:
        bpy.ops.import_scene.gltf(filepath=path)
    finally:
        if not had_alias:
            del np.bool
    meshes = [o for o in bpy.data.objects if o.type == "MESH"]
    assert len(meshes) == 1, [o.name for o in meshes]
    imported = meshes[0]
    tree = imported.active_material.node_tree
    principled = next(n for n in tree.nodes if n.type == "BSDF_PRINCIPLED")
    links = principled.inputs["Base Color"].links
    assert links and links[0].from_node.type == "TEX_IMAGE", "no image on the Base Color"
    texture = links[0].from_node
    image = texture.image
    assert tuple(image.size) == (size, size), tuple(image.size)
    difference = np.abs(pixels_of(image)[..., :3] - baked[..., :3])
    print("GLTF pixel difference mean %.5f max %.5f" % (difference.mean(), difference.max()))
    assert difference.mean() < 0.01, difference.mean()
    uv_links = texture.inputs["Vector"].links
    uv_name = uv_links[0].from_node.uv_map if uv_links and uv_links[0].from_node.type == "UVMAP" else \
        imported.data.uv_layers[0].name
    values = np.empty(len(imported.data.loops) * 2, np.float32)
    imported.data.uv_layers[uv_name].data.foreach_get("uv", values)
    assert set(map(tuple, np.round(values.reshape(-1, 2), 4))) == expected_uvs


def test_failures_change_nothing():
    """Every refused or failed bake leaves images, materials, node groups, the mesh (hashed), the render
    engine and the selection as they were; a failure after Cycles baked also removes the UV map it made."""
    obj = plane()
    expect_bake_error(obj, options.BakeRequest(uv_map="UVMap", size=64), "no TexSynth result")
    synthesize(obj)
    expect_bake_error(obj, options.BakeRequest(uv_map="TexSynth", size=64), "overlap")
    expect_bake_error(obj, options.BakeRequest(uv_map="Missing", size=64), "no UV map 'Missing'", "UVMap")
    expect_bake_error(obj, options.BakeRequest(uv_map="UVMap", size=0), "size")
    expect_bake_error(obj, options.BakeRequest(uv_map="UVMap", size=99999), "size")
    expect_bake_error(obj, options.BakeRequest(uv_map="UVMap", size=64, margin=-1), "margin")
    expect_bake_error(obj, options.BakeRequest(uv_map="UVMap", size=64, target="/nonexistent_dir/x/out.png"),
                      "does not exist")
    expect_bake_error(obj, options.BakeRequest(uv_map="UVMap", size=64, target=os.path.join(CACHE, "out.xyz")),
                      "unsupported")
    # A failure after Cycles has baked (injected), with a UV map made by Smart UV Project on the way.
    obj.data.uv_layers.remove(obj.data.uv_layers["UVMap"])
    os.environ[texsynth.bridge.mesh_io.FAIL_AT_ENV] = "bake"
    try:
        expect_bake_error(obj, options.BakeRequest(size=64, create_uv=True, material="ASSIGN",
                                                   target=os.path.join(CACHE, "failed.png")), "injected")
    finally:
        del os.environ[texsynth.bridge.mesh_io.FAIL_AT_ENV]
    assert not os.path.exists(os.path.join(CACHE, "failed.png"))
    # No faces.
    empty = bpy.data.objects.new("Empty Mesh", bpy.data.meshes.new("Empty Mesh"))
    bpy.context.scene.collection.objects.link(empty)
    expect_bake_error(empty, options.BakeRequest(size=64), "no faces")


def test_saved_file_and_rebake_replace_the_image():
    """Baking to a path saves a PNG there; baking again under the same name replaces the image (one
    image of that name, the baked material points to the new one)."""
    obj = plane()
    synthesize(obj)
    path = os.path.join(CACHE, "saved.png")
    first = baking.bake(obj, options.BakeRequest(uv_map="UVMap", size=32, margin=1, target=path, material="CREATE"))
    assert os.path.isfile(path) and first.image.packed_file is None and first.path == path
    assert first.image.name == "saved.png"
    second = baking.bake(obj, options.BakeRequest(uv_map="UVMap", size=64, margin=1, target=path, material="CREATE"))
    assert [i.name for i in bpy.data.images].count("saved.png") == 1
    material = bpy.data.materials["TexSynth Baked: Plane"]
    texture = next(n for n in material.node_tree.nodes if n.type == "TEX_IMAGE")
    assert texture.image == second.image and tuple(second.image.size) == (64, 64)
    assert obj.material_slots[0].material.name.startswith("TexSynth: ")  # CREATE does not assign


def test_surface_colour_hook_dilates_the_margin():
    """write_surface_colour: covered texels copied, texels within the margin take the nearest covered
    colour, farther ones keep the caller's background; row 0 of the array is the image's top row."""
    harness.reset_scene()
    image = bpy.data.images.new("Surface", 16, 8, alpha=True, float_buffer=True)
    rgba = np.zeros((8, 16, 4), np.float32)
    coverage = np.zeros((8, 16), bool)
    coverage[0:2, 0:3] = True  # top-left block
    rgba[coverage] = (0.25, 0.5, 0.75, 1.0)
    images.write_surface_colour(image, rgba, coverage, margin=2)
    written = pixels_of(image)[::-1]  # top row first
    assert np.allclose(written[0, 0], (0.25, 0.5, 0.75, 1.0))
    assert np.allclose(written[3, 2], (0.25, 0.5, 0.75, 1.0))  # 2 px below the block: margin
    assert np.allclose(written[0, 4], (0.25, 0.5, 0.75, 1.0))  # 2 px right of it
    assert np.allclose(written[7, 15], 0.0)                    # far away: background
    try:
        images.write_surface_colour(image, rgba[:4], coverage[:4], margin=2)
    except options.BakeError:
        pass
    else:
        raise AssertionError("a wrongly sized array must be refused")


def test_operator_bakes_the_active_object_with_the_panel_settings():
    """texsynth.bake on the active object with the scene's bake settings: packed image, material created
    (not assigned); the TexSynth UV map is refused with the reason."""
    obj = plane()
    synthesize(obj)
    props = bpy.context.scene.texsynth
    props.bake_target, props.bake_uv_map, props.bake_size, props.bake_margin = "Baked Op", "UVMap", 32, 2
    props.bake_material = "CREATE"
    assert bpy.ops.texsynth.bake() == {"FINISHED"}
    image = bpy.data.images["Baked Op"]
    assert tuple(image.size) == (32, 32) and image.packed_file is not None
    assert "TexSynth Baked: Plane" in bpy.data.materials
    assert obj.material_slots[0].material.name.startswith("TexSynth: ")
    props.bake_uv_map = "TexSynth"
    before = state_of(obj)
    try:
        bpy.ops.texsynth.bake()
    except RuntimeError as error:
        assert "overlap" in str(error), error
    else:
        raise AssertionError("baking through TexSynth must be refused")
    assert state_of(obj) == before


def test_baked_outputs_nothing_uses_yet_survive_save_and_reload():
    """Baked Material = Create (the material made, not assigned) and None (the image alone) leave outputs
    no object uses yet; the report says "packed into the .blend", so a save + reload must keep them: the
    material with its image, and the lone image, with the same pixels."""
    obj = plane()
    synthesize(obj)
    created = baking.bake(obj, options.BakeRequest(uv_map="UVMap", size=32, margin=1, target="Baked Create",
                                                   material="CREATE"))
    alone = baking.bake(obj, options.BakeRequest(uv_map="UVMap", size=32, margin=1, target="Baked Alone"))
    assert "packed into the .blend" in created.summary("Plane") and "packed into the .blend" in alone.summary("Plane")
    assert obj.material_slots[0].material.name.startswith("TexSynth: ")  # neither output is on the object
    digests = {"Baked Create": harness.pixel_digest(created.image), "Baked Alone": harness.pixel_digest(alone.image)}
    harness.save_and_reload("baked.blend")
    material = bpy.data.materials.get("TexSynth Baked: Plane")
    assert material is not None, sorted(m.name for m in bpy.data.materials)
    texture = next(n for n in material.node_tree.nodes if n.type == "TEX_IMAGE")
    assert texture.image is not None and texture.image.name == "Baked Create", texture.image
    assert harness.pixel_digest(texture.image) == digests["Baked Create"]
    image = bpy.data.images.get("Baked Alone")
    assert image is not None, sorted(i.name for i in bpy.data.images)
    assert image.packed_file is not None and harness.pixel_digest(image) == digests["Baked Alone"]


TESTS = [test_jumpmap_bake_matches_a_top_view_render, test_texton_cube_smart_uv_bake_covers_islands_and_margin,
         test_a_new_uv_map_uses_the_image_and_keeps_islands_two_texels_apart,
         test_gltf_round_trip_keeps_baked_image_and_uv_map, test_failures_change_nothing,
         test_saved_file_and_rebake_replace_the_image, test_surface_colour_hook_dilates_the_margin,
         test_operator_bakes_the_active_object_with_the_panel_settings,
         test_baked_outputs_nothing_uses_yet_survive_save_and_reload]

if __name__ == "__main__":
    harness.Checks().run(TESTS, harness.script_args())

# SPDX-License-Identifier: GPL-3.0-or-later
"""Blend group behaviour measured in renders (addon/blend_groups.py), inside Blender:

  blender -b --factory-startup --python-exit-code 1 --python python_tests/blender/tests_shading.py [-- test_name ...]

A jittered triangulated plane fills an orthographic view with flat emission shading (no lights), about
one texel per pixel; Eevee, one sample. Expectations come from the sample's own pixels, never from
the add-on's code.
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
from texsynth.core import layers as core_layers  # noqa: E402
from texsynth.core import settings as core_settings  # noqa: E402
from texsynth.shading import blend_groups  # noqa: E402
from texsynth.uv_methods import synthesis  # noqa: E402
from texsynth.bridge import sources  # noqa: E402

PIXELS = 128
CACHE = tempfile.mkdtemp(prefix="texsynth_shading_tests_")
MOSS = os.path.join(harness.SAMPLES_DIR, "moss.png")


def plane_scene():
    """A 2 x 2 plane of 8 x 8 jittered cells (2 triangles each) seen from above, filling the frame."""
    harness.reset_scene()
    cells, rng = 8, np.random.default_rng(5)
    grid = np.linspace(-1.0, 1.0, cells + 1)
    xs, ys = np.meshgrid(grid, grid)
    positions = np.stack([xs.ravel(), ys.ravel(), np.zeros(xs.size)], 1)
    inner = (np.abs(positions[:, 0]) < 0.999) & (np.abs(positions[:, 1]) < 0.999)
    positions[inner, :2] += rng.uniform(-0.3, 0.3, (inner.sum(), 2)) * (2.0 / cells)
    index = np.arange((cells + 1) ** 2).reshape(cells + 1, cells + 1)
    triangles = []
    for y in range(cells):
        for x in range(cells):
            a, b, c, d = index[y, x], index[y, x + 1], index[y + 1, x + 1], index[y + 1, x]
            triangles += [[a, b, c], [a, c, d]]
    corner_verts = np.array(triangles, np.int32).ravel()
    obj = harness.mesh_from_arrays("Plane", positions.astype(np.float32), corner_verts,
                                   np.arange(0, corner_verts.size, 3, dtype=np.int32),
                                   np.full(len(triangles), 3, np.int32))
    scene = bpy.context.scene
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    camera.data.type, camera.data.ortho_scale = "ORTHO", 1.6  # the middle of the plane: no border
    camera.location = (0.0, 0.0, 3.0)
    scene.collection.objects.link(camera)
    scene.camera = camera
    texsynth.compat.use_eevee(scene)
    scene.eevee.taa_render_samples = 1
    scene.render.resolution_x = scene.render.resolution_y = PIXELS
    scene.render.resolution_percentage = 100
    scene.view_settings.view_transform = "Standard"
    scene.render.filepath = os.path.join(CACHE, "frame.png")
    return obj, scene


def emission_with_group(group):
    material = bpy.data.materials.new("Emission " + group.name)
    material.use_nodes = True
    nodes, links = material.node_tree.nodes, material.node_tree.links
    nodes.clear()
    node = nodes.new("ShaderNodeGroup")
    node.node_tree = group
    emission = nodes.new("ShaderNodeEmission")
    output = nodes.new("ShaderNodeOutputMaterial")
    links.new(node.outputs["Color"], emission.inputs["Color"])
    links.new(emission.outputs["Emission"], output.inputs["Surface"])
    return material


def render_luminance(obj, scene, image, mode, blend=True, method="JUMPMAP"):
    # 1.2 world units per sample width: ~1 texel per pixel for the 128 px moss sample at this view.
    settings = core_settings.Settings(method=method, sample_world_size=1.2, seed=3, blend=blend, axis=(0.0, 1.0, 0.0))
    report = synthesis.synthesize([obj], sources.Sample(path=MOSS), settings, cache_dir=CACHE, material_mode="NONE")
    assert not report.failures, report.summary()
    group = blend_groups.ensure_blend_group(image, synthesis.blend_inputs(image, mode, CACHE, method))
    obj.data.materials.clear()
    obj.data.materials.append(emission_with_group(group))
    bpy.ops.render.render(write_still=True)
    rendered = bpy.data.images.load(scene.render.filepath, check_existing=False)
    pixels = np.empty(len(rendered.pixels), np.float32)
    rendered.pixels.foreach_get(pixels)
    bpy.data.images.remove(rendered)
    rgb = pixels.reshape(PIXELS, PIXELS, 4)[..., :3].astype(np.float64)
    return rgb @ np.array([0.2126, 0.7152, 0.0722])


def sample_luminance_std(image):
    pixels = np.empty(len(image.pixels), np.float32)
    image.pixels.foreach_get(pixels)
    rgb = pixels.reshape(image.size[1], image.size[0], image.channels)[..., :3].astype(np.float64)
    return float((rgb @ np.array([0.2126, 0.7152, 0.0722])).std())


def test_histogram_mode_with_one_mapping_gives_the_sample_back():
    """No blending: the base mapping alone goes through the Gaussianized image and the inverse look-up
    table, so the render must match the plain image's (colour space and alpha handling included)."""
    obj, scene = plane_scene()
    image = bpy.data.images.load(MOSS, check_existing=True)
    plain = render_luminance(obj, scene, image, "LINEAR", blend=False)
    through_lut = render_luminance(obj, scene, image, "HISTOGRAM", blend=False)
    difference = np.abs(plain - through_lut)
    print("LUT round trip: mean %.4f, 99th percentile %.4f" % (difference.mean(), np.percentile(difference, 99)))
    assert difference.mean() < 0.01 and np.percentile(difference, 99) < 0.05, (difference.mean(), difference.max())
    assert plain.std() > 0.03  # the comparison is not between two flat images


def test_histogram_blending_keeps_the_contrast_linear_blending_loses():
    """Blended jump maps: linear cross-fades average up to three images in face middles and lose
    contrast; the histogram-preserving blend keeps the luminance spread of the unblended render."""
    obj, scene = plane_scene()
    image = bpy.data.images.load(MOSS, check_existing=True)
    unblended = render_luminance(obj, scene, image, "LINEAR", blend=False).std()
    linear = render_luminance(obj, scene, image, "LINEAR").std()
    histogram = render_luminance(obj, scene, image, "HISTOGRAM").std()
    variance = render_luminance(obj, scene, image, "VARIANCE").std()
    print("CONTRAST (luminance std) unblended %.4f linear %.4f histogram %.4f variance %.4f"
          % (unblended, linear, histogram, variance))
    assert linear < 0.93 * unblended, (linear, unblended)
    assert abs(histogram / unblended - 1.0) < 0.07, (histogram, unblended)
    assert abs(variance / unblended - 1.0) < 0.1, (variance, unblended)
    # The sample's own spread, in the render's (linear) space, is in the same range.
    assert 0.5 < unblended / max(sample_luminance_std(image), 1e-6) < 1.5


def test_texton_patches_blend_only_near_their_edges():
    """Texton: face middles show the face's own patch exactly; the render with blending differs from
    the unblended one only in a band along the edges."""
    obj, scene = plane_scene()
    image = bpy.data.images.load(MOSS, check_existing=True)
    unblended = render_luminance(obj, scene, image, "LINEAR", blend=False, method="TEXTON")
    blended = render_luminance(obj, scene, image, "LINEAR", method="TEXTON")
    changed = np.abs(blended - unblended) > 0.02
    print("TEXTON changed fraction %.3f" % changed.mean())
    assert 0.05 < changed.mean() < 0.7, changed.mean()  # some pixels change (edges), many do not (middles)


def _gradient(luminance):
    return float(np.hypot(np.diff(luminance, axis=1)[:-1], np.diff(luminance, axis=0)[:, :-1]).mean())


def test_texton_variance_blending_keeps_the_detail_linear_blending_loses():
    """Moss is stochastic: neighbouring texton patches are nearly independent, so cross-fading them
    linearly averages detail away along the edges; the variance blend rescales the mixture by its
    deviation (identical mappings grouped, TexSynth_Groups) and keeps the unblended gradient."""
    obj, scene = plane_scene()
    image = bpy.data.images.load(MOSS, check_existing=True)
    unblended = _gradient(render_luminance(obj, scene, image, "LINEAR", blend=False, method="TEXTON"))
    linear = _gradient(render_luminance(obj, scene, image, "LINEAR", method="TEXTON"))
    variance = _gradient(render_luminance(obj, scene, image, "VARIANCE", method="TEXTON"))
    assert obj.data.attributes.get(core_layers.GROUPS_NAME) is not None
    print("TEXTON gradient unblended %.4f linear %.4f variance %.4f" % (unblended, linear, variance))
    assert linear < 0.96 * unblended, (linear, unblended)
    # Not below the unblended render, and not sharpened far past it (measured 1.05 here, where the view
    # is slightly minified: 1.3 texels per pixel).
    assert 0.99 < variance / unblended < 1.08, (variance, unblended)


if __name__ == "__main__":
    harness.Checks().run([value for name, value in list(globals().items()) if name.startswith("test_")],
                         only=harness.script_args())

# SPDX-License-Identifier: GPL-3.0-or-later
"""Run by Blender in a runtime environment (only Debian's blender and python3-numpy, no source tree) after the
package was installed and enabled: a headless Synthesize through the operator, then a render.

blender -b --python-exit-code 1 --python check_installed.py -- SAMPLE.png OUT.png
Prints CHECK_INSTALLED ok ... on success; raises (exit code 1) otherwise.
"""
import sys

import addon_utils
import bpy
import numpy as np

sample, out_path = sys.argv[sys.argv.index("--") + 1:][:2]

# The installed add-on: a legacy add-on is `texsynth`, an extension `bl_ext.<repository>.texsynth`.
module_name = next((m.__name__ for m in addon_utils.modules() if m.__name__.split(".")[-1] == "texsynth"), None)
assert module_name, "TexSynth is not installed"
loaded_default, loaded_state = addon_utils.check(module_name)
assert loaded_state, "TexSynth (%s) is installed but not enabled" % module_name
addon = sys.modules[module_name]
assert addon.native.get() is not None, "native module unavailable: " + addon.native.reason()

for obj in list(bpy.data.objects):  # the startup scene's cube, camera and light
    bpy.data.objects.remove(obj)
bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=4, radius=1.0, calc_uvs=False)
sphere = bpy.context.active_object
assert len(sphere.data.uv_layers) == 0
bpy.ops.object.camera_add(location=(0.0, -4.0, 0.0), rotation=(1.5708, 0.0, 0.0))
bpy.context.scene.camera = bpy.context.active_object
bpy.ops.object.light_add(type="SUN", location=(0.0, -3.0, 3.0))
bpy.context.view_layer.objects.active = sphere
sphere.select_set(True)

settings = bpy.context.scene.texsynth
settings.sample_source = "FILE"
settings.sample_path = sample
settings.scale = 0.8
settings.seed = 3
result = bpy.ops.texsynth.synthesize()
assert result == {"FINISHED"}, "Synthesize returned %s" % result
uv_names = [layer.name for layer in sphere.data.uv_layers]
assert "TexSynth" in uv_names, uv_names
assert sphere.active_material is not None, "no material assigned"

scene = bpy.context.scene
scene.render.engine = "CYCLES"  # CPU Cycles renders headless on every version
scene.cycles.device = "CPU"
scene.cycles.samples = 4
scene.cycles.use_denoising = False
scene.render.resolution_x, scene.render.resolution_y = 96, 96
scene.render.resolution_percentage = 100
scene.render.filepath = out_path
scene.render.image_settings.file_format = "PNG"
bpy.ops.render.render(write_still=True)

image = bpy.data.images.load(out_path)
pixels = np.empty(len(image.pixels), np.float32)
image.pixels.foreach_get(pixels)
rgb = pixels.reshape(-1, 4)[:, :3]
# The sphere's pixels: those unlike the background (the corner). Untextured grey would have R = B
# there; the brick sample is red.
sphere_pixels = rgb[np.abs(rgb - rgb[0]).max(axis=1) > 0.02]
assert len(sphere_pixels) > len(rgb) // 10, "the sphere is not in the render"
redness = float(np.mean(sphere_pixels[:, 0] - sphere_pixels[:, 2]))
assert redness > 0.05, "the render shows no brick red (R - B = %.3f): the texture did not show" % redness
print("CHECK_INSTALLED ok: Blender %s, %s, %d UV maps, render %s (R - B %.3f)" % (
    bpy.app.version_string, module_name, len(uv_names), out_path, redness), flush=True)

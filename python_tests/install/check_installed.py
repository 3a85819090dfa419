# SPDX-License-Identifier: GPL-3.0-or-later
"""Run by Blender in a runtime environment (only Debian's blender and python3-numpy, no source tree) after the
package was installed and enabled: a headless Synthesize through the operator, a comb stroke of the field
brushes (rays through Embree), then a render. For a self-contained package (texsynth_native.libs/ beside the
module) it also shows that the bundled libraries answer: build_info() and /proc/self/maps.

blender -b --python-exit-code 1 --python check_installed.py -- SAMPLE.png OUT.png
Prints CHECK_INSTALLED ok ... on success; raises (exit code 1) otherwise.
"""
import importlib
import os
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

# The field brushes: a comb stroke across the sphere's front casts rays through the module's Embree.
authoring = importlib.import_module(module_name + ".fields.authoring")
mesh_state = importlib.import_module(module_name + ".fields.mesh_state")
field_edits = importlib.import_module(module_name + ".ui.field_edits")
state = mesh_state.field_state(bpy.context, sphere)
brush = authoring.CombBrush(state, mesh_state.caster_for(sphere, state.arrays), 0.4)
for s in np.linspace(0.0, 1.0, 25):
    brush.dab(np.array([-0.6 + 1.2 * s, -3.0, 0.0]), np.array([0.0, 1.0, 0.0]))
assert brush.end_stroke(), "the comb stroke hit nothing"
field_edits.commit_edit(bpy.context, sphere, state)
combed = sphere.data.attributes.get(authoring.GUIDE_NAME)
assert combed is not None, "the stroke wrote no guide attribute"
guide = np.empty(len(sphere.data.vertices) * 3, np.float32)
combed.data.foreach_get("vector", guide)
guided = int(np.any(guide.reshape(-1, 3) != 0, axis=1).sum())
assert guided > 10, "the comb stroke guided %d vertices" % guided

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
module = addon.native.get()
folder = os.path.dirname(os.path.abspath(module.__file__))
if os.path.isdir(os.path.join(folder, "texsynth_native.libs")):
    # Blender may have loaded its own TBB and Embree; the module must use the copies it carries.
    with open("/proc/self/maps") as maps_file:
        mapped = sorted({line.split()[-1] for line in maps_file if ".so" in line.split()[-1]})
    tbb = [path for path in mapped if "tbb" in os.path.basename(path)]
    embree = [path for path in mapped if "embree" in os.path.basename(path)]
    print("CHECK_INSTALLED maps: TBB %s; Embree %s" % (" ".join(tbb) or "-", " ".join(embree) or "- (static)"))
    info = module.build_info()
    print("CHECK_INSTALLED build_info:", info)
    assert any(path.startswith(folder + "/texsynth_native.libs/") for path in tbb), tbb
    # The copies that answer the module's calls, whatever else Blender has loaded.
    assert info["self_contained"] and info["embree_library"] == os.path.realpath(module.__file__), info
    assert info["tbb_library"].startswith(folder + "/texsynth_native.libs/"), info
print("CHECK_INSTALLED ok: Blender %s, %s, %d UV maps, %d vertices combed, render %s (R - B %.3f)" % (
    bpy.app.version_string, module_name, len(uv_names), guided, out_path, redness), flush=True)

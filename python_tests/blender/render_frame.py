# SPDX-License-Identifier: GPL-3.0-or-later
"""Renders one reference frame of blend_samples/scene.blend textured by TexSynth.

blender -b blend_samples/scene.blend --factory-startup --python-exit-code 1 --python <this> -- NAME OUT.png
Frames (fixed seeds, fixed samples, 320x240 unless noted) are defined in FRAMES.
"""
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import bpy  # noqa: E402

import harness  # noqa: E402

FRAMES = {
    # Suzanne (subdivision modifier) with bricks, ground with moss; blending on; Eevee.
    "scene_eevee": dict(engine="BLENDER_EEVEE", resolution=(320, 240), samples=16, blend=True,
                        jobs=(("Ground", "moss.png", 2.0, 11), ("Suzanne", "bricks.png", 1.2, 5))),
    # Same without blending: the raw jump-map patches and their seams.
    "suzanne_noblend_eevee": dict(engine="BLENDER_EEVEE", resolution=(320, 240), samples=16, blend=False,
                                  jobs=(("Suzanne", "bricks.png", 1.2, 5),)),
    # Round neighbourhoods: Suzanne's colours synthesized into a 256² image through its UV map.
    "suzanne_round_eevee": dict(engine="BLENDER_EEVEE", resolution=(320, 240), samples=16, blend=True,
                                jobs=(("Suzanne", "bricks.png", 1.2, 5, "ROUND"),)),
    # The blend group in Cycles (CPU, fixed seed and samples, no denoising).
    "scene_cycles": dict(engine="CYCLES", resolution=(160, 120), samples=8, blend=True,
                         jobs=(("Ground", "bark.png", 2.0, 2), ("Suzanne", "bricks.png", 1.2, 5))),
}


def render(name, out_path):
    frame = FRAMES[name]
    texsynth = harness.load_addon()
    from texsynth.core import settings as core_settings
    from texsynth.uv_methods import synthesis
    from texsynth.bridge import sources
    for obj_name, sample, world_size, seed, *method in frame["jobs"]:
        method = method[0] if method else "JUMPMAP"
        settings = core_settings.Settings(method=method, sample_world_size=world_size, seed=seed, blend=frame["blend"])
        path = os.path.join(harness.SAMPLES_DIR, sample)
        if method in core_settings.SURFACE_METHODS:
            from texsynth.core import bake_options as options
            from texsynth.surface_colour import synthesis as surface
            report = surface.synthesize([bpy.data.objects[obj_name]], sources.Sample(path=path), settings,
                                        options.BakeRequest(size=256, margin=4, create_uv=True))
        else:
            report = synthesis.synthesize([bpy.data.objects[obj_name]], sources.Sample(path=path), settings,
                                          cache_dir=os.environ.get("TEXSYNTH_CACHE_DIR") or None)
        if report.failures:
            raise RuntimeError(report.summary())
        print("FRAME", name, report.summary(), flush=True)
    scene = bpy.context.scene
    if frame["engine"] == "CYCLES":
        scene.render.engine = "CYCLES"
    else:
        texsynth.compat.use_eevee(scene)
    scene.render.resolution_x, scene.render.resolution_y = frame["resolution"]
    scene.render.resolution_percentage = 100
    if frame["engine"] == "CYCLES":
        scene.cycles.device = "CPU"
        scene.cycles.samples = frame["samples"]
        scene.cycles.seed = 0
        scene.cycles.use_denoising = False
        scene.cycles.use_adaptive_sampling = False
    else:
        scene.eevee.taa_render_samples = frame["samples"]
    scene.render.image_settings.file_format = "PNG"
    scene.render.image_settings.color_depth = "8"
    scene.render.filepath = os.path.abspath(out_path)
    bpy.ops.render.render(write_still=True)
    del texsynth


if __name__ == "__main__":
    frame_name, out = harness.script_args()
    render(frame_name, out)

# SPDX-License-Identifier: GPL-3.0-or-later
"""Render cost of TexSynth's blend group against one Image Texture on the same base UVs, same scene.
Not a test: prints figures.

  blender -b blend_samples/scene.blend --factory-startup --python-exit-code 1 \\
      --python python_tests/bench/bench_render_cost.py -- [--repeat 3] [--engines CYCLES,EEVEE]

Suzanne (subdivided) gets bricks and the ground moss, by the jump map and the texton method in turn.
Each variant swaps only the nodes feeding the Principled BSDF's Base Color: a plain Image Texture of
the sample on the TexSynth UV map (the baseline), then the blend group in each blend mode. Frames
alternate between variants within each repeat (the machine's noise hits all alike); the median of
the per-repeat ratios to the baseline is reported, with their range. Goal: <= 1.5x.
"""
import argparse
import os
import statistics
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(os.path.dirname(HERE), "blender"))
import bpy  # noqa: E402

import harness  # noqa: E402

JOBS = (("Ground", "moss.png", 2.0, 11), ("Suzanne", "bricks.png", 1.2, 5))
MODES = ("HISTOGRAM", "VARIANCE", "LINEAR")


def parse_args():
    parser = argparse.ArgumentParser(prog="bench_render_cost")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--engines", default="CYCLES,EEVEE")
    parser.add_argument("--methods", default="JUMPMAP,TEXTON")
    return parser.parse_args(harness.script_args())


def base_color_input(material):
    principled = next(n for n in material.node_tree.nodes if n.type == "BSDF_PRINCIPLED")
    return principled.inputs["Base Color"]


def plain_texture(material, image):
    """An Image Texture of image on the TexSynth UV map, feeding Base Color (the baseline)."""
    nodes, links = material.node_tree.nodes, material.node_tree.links
    uv = nodes.new("ShaderNodeUVMap")
    uv.uv_map = "TexSynth"
    texture = nodes.new("ShaderNodeTexImage")
    texture.image, texture.interpolation, texture.extension = image, "Linear", "EXTEND"
    links.new(uv.outputs["UV"], texture.inputs["Vector"])
    return texture.outputs["Color"]


def setup_render(scene, engine, texsynth):
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = 320, 240, 100
    if engine == "CYCLES":
        scene.render.engine = "CYCLES"
        scene.cycles.device, scene.cycles.samples, scene.cycles.seed = "CPU", 16, 0
        scene.cycles.use_denoising = False
        scene.cycles.use_adaptive_sampling = False
    else:
        texsynth.compat.use_eevee(scene)
        scene.eevee.taa_render_samples = 16


def main():
    args = parse_args()
    texsynth = harness.load_addon()
    from texsynth.core import settings as core_settings
    from texsynth.shading import blend_groups
    from texsynth.uv_methods import synthesis
    from texsynth.bridge import sources
    scene = bpy.context.scene
    cache_dir = tempfile.mkdtemp(prefix="texsynth_render_cost_")
    scene.render.filepath = os.path.join(cache_dir, "frame.png")
    for method in args.methods.split(","):
        materials = {}
        for obj_name, sample, world_size, seed in JOBS:
            settings = core_settings.Settings(method=method, sample_world_size=world_size, seed=seed)
            path = os.path.join(harness.SAMPLES_DIR, sample)
            report = synthesis.synthesize([bpy.data.objects[obj_name]], sources.Sample(path=path), settings,
                                          cache_dir=cache_dir)
            if report.failures:
                raise SystemExit(report.summary())
            source = bpy.data.objects[obj_name].material_slots[0].material
            image = bpy.data.images.load(path, check_existing=True)
            # One material per variant, so switching variants recompiles no shader (Eevee).
            variants = {}
            for variant in ("baseline",) + MODES:
                material = source.copy()
                if variant == "baseline":
                    color = plain_texture(material, image)
                else:
                    group = material.node_tree.nodes.new("ShaderNodeGroup")
                    group.node_tree = blend_groups.ensure_blend_group(
                        image, synthesis.blend_inputs(image, variant, cache_dir, method))
                    color = group.outputs["Color"]
                material.node_tree.links.new(color, base_color_input(material))
                variants[variant] = material
            materials[obj_name] = variants
        for engine in args.engines.split(","):
            setup_render(scene, engine, texsynth)
            times = {variant: [] for variant in ("baseline",) + MODES}
            def use(variant):
                for obj_name, variants in materials.items():
                    bpy.data.objects[obj_name].material_slots[0].material = variants[variant]
            for variant in times:  # warm-up: shader compilation and image upload are not frame cost
                use(variant)
                bpy.ops.render.render()
            for _ in range(args.repeat):
                for variant in times:
                    use(variant)
                    start = time.perf_counter()
                    bpy.ops.render.render()
                    times[variant].append(time.perf_counter() - start)
            baseline = statistics.median(times["baseline"])
            print("%s, %s: one Image Texture %.3f s per frame (median of %d)" % (method, engine, baseline, args.repeat))
            for mode in MODES:
                # Ratios within each repeat (frames rendered back to back): the VM's speed drifts
                # between repeats by more than the differences measured here.
                ratios = sorted(t / b for t, b in zip(times[mode], times["baseline"]))
                print("  blend group, %-9s %.3f s = %.2fx (per-repeat ratios %.2f-%.2f; goal <= 1.5x)"
                      % (mode, statistics.median(times[mode]), statistics.median(ratios), ratios[0], ratios[-1]))
    del texsynth


if __name__ == "__main__":
    main()

# SPDX-License-Identifier: GPL-3.0-or-later
"""Blending quality measured in renders. Not a test: prints figures and leaves the pictures.

  blender -b --factory-startup --python-exit-code 1 --python python_tests/bench/bench_blend_quality.py -- \\
      [--sample blend_samples/bricks.png] [--modes tiling,box,jumpmap,jumpmap_variance,jumpmap_linear,...]
      [--pixels 512] [--cells 10] [--seed 3] [--out out/bench_blend] [--scenes plane,curved] [--tileable]

Scene 1: a jittered triangulated plane seen from straight above by an orthographic camera, flat emission
shading (no lights), scaled so that one sample texel covers one pixel. Each mode renders the same view
(Eevee, one sample): plain tiling of the sample through planar UVs (the reference), Blender's box
projection (blend 0.2; on this flat view it is planar tiling too), then TexSynth's methods with and
without blending. Mesh edges are rasterised from the known projection (exact for
this view) into a mask; blend_metrics.py turns render + mask into:
  tiling_shifted: tiling moved half a texel; tiling_rotated: turned by 3 degrees, so that every
  sub-texel phase occurs (what a synthesized mapping, landing anywhere between texel centres, pays in
  bilinear resampling; plain tiling here samples one phase only)
  seam     mean |grad L| within 1 px of an edge / from 3 px on (1.00 = no visible seam)
  detail   mean |grad L| / that of tiling (< 1: blending washed detail out)
  profile  mean |grad L| by distance 0..10 px from the nearest edge, relative to its mean
  repeat   largest autocorrelation of L beyond a quarter of the sample width (tiling: ~0.99)
Scene 2: triangulated Suzanne (curved) from three orthographic views, same shading and scale; its edge
masks are Cycles renders of the Wireframe node (1 px, hidden edges hidden), and only pixels at least
4 px inside the silhouette count. Tiling has no meaning there, so detail is relative to box projection.
Renders and edge masks go to --out.
"""
import argparse
import math
import os
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, os.path.join(os.path.dirname(HERE), "blender"))
sys.path.insert(0, HERE)
import bpy  # noqa: E402
import numpy as np  # noqa: E402

import blend_metrics  # noqa: E402
import harness  # noqa: E402

# <method>[_<blend mode>]: no suffix = histogram-preserving blending; _auto = what Auto picks for the sample.
MODES = ("tiling", "tiling_shifted", "tiling_rotated", "box", "jumpmap", "jumpmap_variance", "jumpmap_linear", "jumpmap_noblend",
         "texton", "texton_auto", "texton_variance", "texton_linear", "texton_noblend")


def blend_mode_of(mode):
    return {"noblend": "LINEAR", "variance": "VARIANCE", "linear": "LINEAR", "auto": "AUTO"}.get(mode.rpartition("_")[2], "HISTOGRAM")
PROFILE_DISTANCE = 10


def parse_args():
    parser = argparse.ArgumentParser(prog="bench_blend_quality")
    parser.add_argument("--sample", default=os.path.join(ROOT, "blend_samples", "bricks.png"))
    parser.add_argument("--modes", default=",".join(MODES))
    parser.add_argument("--pixels", type=int, default=512, help="render width and height")
    parser.add_argument("--cells", type=int, default=10, help="grid cells per side (2 triangles each)")
    parser.add_argument("--seed", type=int, default=3)
    parser.add_argument("--out", default=os.path.join(ROOT, "out", "bench_blend"))
    parser.add_argument("--scenes", default="plane,curved", help="plane and/or curved")
    parser.add_argument("--tileable", action="store_true",
                        help="synthesize with Tileable on (the group's look-ups then repeat the image)")
    parser.add_argument("--allow-oversized", action="store_true",
                        help="let faces be larger than the sample (64^2 samples at 1 texel/px)")
    args = parser.parse_args(harness.script_args())
    args.modes = [m for m in args.modes.split(",") if m]
    unknown = set(args.modes) - set(MODES)
    if unknown:
        parser.error("unknown modes %s (choose from %s)" % (", ".join(sorted(unknown)), ", ".join(MODES)))
    return args


def jittered_plane(cells, width, seed):
    """Triangles over [-width/2, width/2]^2: interior vertices jittered by up to 0.3 cell, each cell split
    along a random diagonal. Returns the object and its edges as (E, 2, 2) world xy segments."""
    positions, triangles = blend_metrics.jittered_plane_arrays(cells, width, seed)
    obj = harness.mesh_from_arrays("Plane", positions, triangles.ravel(),
                                   np.arange(0, 3 * len(triangles), 3, dtype=np.int32),
                                   np.full(len(triangles), 3, np.int32))
    edges = {tuple(sorted((int(t[k]), int(t[(k + 1) % 3])))) for t in triangles for k in range(3)}
    segments = np.array([[positions[i, :2], positions[j, :2]] for i, j in sorted(edges)], np.float64)
    return obj, segments


def edge_mask(segments, width, pixels):
    """Pixels (row 0 = top) that the projected edges pass through, sampled every 0.25 px."""
    mask = np.zeros((pixels, pixels), bool)
    to_pixel = pixels / width
    for (x0, y0), (x1, y1) in segments:
        count = int(math.ceil(math.hypot(x1 - x0, y1 - y0) * to_pixel * 4)) + 1
        t = np.linspace(0.0, 1.0, count)
        cols = np.floor((x0 + (x1 - x0) * t + width / 2) * to_pixel).astype(int)
        rows = np.floor((width / 2 - (y0 + (y1 - y0) * t)) * to_pixel).astype(int)
        keep = (cols >= 0) & (cols < pixels) & (rows >= 0) & (rows < pixels)
        mask[rows[keep], cols[keep]] = True
    return mask


def setup_view(width, pixels):
    scene = bpy.context.scene
    camera_data = bpy.data.cameras.new("Top")
    camera_data.type = "ORTHO"
    camera_data.ortho_scale = width
    camera = bpy.data.objects.new("Top", camera_data)
    camera.location = (0.0, 0.0, 5.0)  # looks down -Z: image x = world x, image up = world y
    scene.collection.objects.link(camera)
    scene.camera = camera
    scene.world = None
    harness.flat_render_settings(scene, pixels)
    scene.render.image_settings.file_format = "PNG"
    scene.render.image_settings.color_depth = "16"
    return scene


def projected_material(name, image, world_size, projection="FLAT", shift=(0.0, 0.0), turn=0.0):
    """Emission of the sample repeated every world_size units through object coordinates: FLAT is plain
    tiling (the reference), BOX Blender's box projection. `shift` (texels) moves the texture off the
    pixel grid: what bilinear resampling costs any mapping that does not land on texel centres."""
    def color(nodes, links):
        coordinates = nodes.new("ShaderNodeTexCoord")
        scale = nodes.new("ShaderNodeVectorMath")
        scale.operation = "MULTIPLY_ADD"
        # world_size is the sample's width; its height spans world_size * H / W (square texels).
        aspect = image.size[0] / image.size[1]
        scale.inputs[1].default_value = (1.0 / world_size, aspect / world_size, 1.0 / world_size)
        scale.inputs[2].default_value = (shift[0] / image.size[0], shift[1] / image.size[1], 0.0)
        texture = nodes.new("ShaderNodeTexImage")
        texture.image, texture.interpolation, texture.extension = image, "Linear", "REPEAT"
        texture.projection, texture.projection_blend = projection, 0.2
        rotate = nodes.new("ShaderNodeVectorRotate")
        rotate.rotation_type, rotate.inputs["Angle"].default_value = "Z_AXIS", turn
        links.new(coordinates.outputs["Object"], rotate.inputs["Vector"])
        links.new(rotate.outputs["Vector"], scale.inputs[0])
        links.new(scale.outputs["Vector"], texture.inputs["Vector"])
        return texture.outputs["Color"]
    return harness.emission_material(name, color)


def texsynth_material(image, blend_mode, cache_dir, method, tileable=False):
    from texsynth.shading import blend_groups
    from texsynth.uv_methods import synthesis
    inputs = synthesis.blend_inputs(image, blend_mode, cache_dir, method, tileable=tileable)

    def color(nodes, links):
        group = nodes.new("ShaderNodeGroup")
        group.node_tree = blend_groups.ensure_blend_group(image, inputs)
        return group.outputs["Color"]
    return harness.emission_material("TexSynth emission", color)


def render(scene, path):
    scene.render.filepath = path
    bpy.ops.render.render(write_still=True)
    image = bpy.data.images.load(path, check_existing=False)
    pixels = np.empty(len(image.pixels), np.float32)
    image.pixels.foreach_get(pixels)
    bpy.data.images.remove(image)
    return pixels.reshape(scene.render.resolution_y, scene.render.resolution_x, 4)[::-1].astype(np.float64)


def synthesize(obj, sample_path, mode, world_size, seed, cache_dir, axis, allow_oversized=False, tileable=False):
    from texsynth.bridge import sources
    from texsynth.core import settings as core_settings
    from texsynth.uv_methods import synthesis
    method = "TEXTON" if mode.startswith("texton") else "JUMPMAP"
    settings = core_settings.Settings(method=method, sample_world_size=world_size, seed=seed, axis=axis,
                                 blend=not mode.endswith("_noblend"), allow_oversized=allow_oversized,
                                 tileable=tileable)
    report = synthesis.synthesize([obj], sources.Sample(path=sample_path), settings, cache_dir=cache_dir,
                                  material_mode="NONE")
    if report.failures:
        raise SystemExit("bench_blend_quality: %s: %s" % (mode, report.summary()))


def sample_luminance(image):
    width, height = image.size
    pixels = np.empty(width * height * image.channels, np.float32)
    image.pixels.foreach_get(pixels)
    return blend_metrics.luminance(pixels.reshape(height, width, image.channels).astype(np.float64))


def save_mask(mask, path):
    pixels = np.repeat(mask[::-1, :, None].astype(np.float32), 4, axis=2)
    pixels[..., 3] = 1.0
    written = bpy.data.images.new("mask", mask.shape[1], mask.shape[0])
    written.pixels.foreach_set(pixels.ravel())
    written.filepath_raw = path
    written.file_format = "PNG"
    written.save()
    bpy.data.images.remove(written)


def measure(rgba, distance, valid, repeat_lag):
    lum = blend_metrics.luminance(rgba)
    grad = blend_metrics.gradient_magnitude(lum)
    return dict(seam=blend_metrics.seam_ratio(grad, distance, valid),
                gradient=blend_metrics.mean_gradient(grad, valid),
                profile=blend_metrics.gradient_profile(grad, distance, valid, PROFILE_DISTANCE),
                repeat=blend_metrics.autocorrelation_peak(lum[4:-4, 4:-4], repeat_lag) if repeat_lag else None)


def print_table(title, results, reference_mode):
    reference = results.get(reference_mode, {}).get("gradient")
    print("\n" + title)
    print("%-16s %6s %7s %7s  %s" % ("mode", "seam", "detail", "repeat",
                                     "profile: |grad L| at 0..%d px from an edge" % PROFILE_DISTANCE))
    for mode, r in results.items():
        detail = "%7.3f" % (r["gradient"] / reference) if reference else "      -"
        repeat = "%7.3f" % r["repeat"] if r["repeat"] is not None else "      -"
        print("%-16s %6.3f %s %s  %s" % (mode, r["seam"], detail, repeat, " ".join("%.2f" % v for v in r["profile"])))


def apply_mode(obj, mode, image, world_size, args, cache_dir, axis=(0.0, 0.0, 1.0)):
    if mode in ("tiling", "tiling_shifted", "tiling_rotated", "box"):
        material = projected_material(mode, image, world_size, "BOX" if mode == "box" else "FLAT",
                                      (0.5, 0.5) if mode == "tiling_shifted" else (0.0, 0.0),
                                      math.radians(3.0) if mode == "tiling_rotated" else 0.0)
    else:
        synthesize(obj, os.path.abspath(args.sample), mode, world_size, args.seed, cache_dir, axis,
                   args.allow_oversized, args.tileable)
        material = texsynth_material(image, blend_mode_of(mode), cache_dir,
                                     "TEXTON" if mode.startswith("texton") else "JUMPMAP", args.tileable)
    obj.data.materials.clear()
    obj.data.materials.append(material)


def plane_benchmark(args, cache_dir):
    harness.reset_scene()
    image = bpy.data.images.load(os.path.abspath(args.sample))
    sample_width = image.size[0]
    plane_width = 2.0
    world_size = sample_width * plane_width / args.pixels  # one texel per pixel
    scene = setup_view(plane_width, args.pixels)
    obj, segments = jittered_plane(args.cells, plane_width, args.seed)
    mask = edge_mask(segments, plane_width, args.pixels)
    distance = blend_metrics.edge_distance(mask, PROFILE_DISTANCE + 2)
    valid = np.zeros(mask.shape, bool)
    valid[4:-4, 4:-4] = True
    save_mask(mask, os.path.join(args.out, "edges.png"))
    own_repeat = blend_metrics.autocorrelation_peak(sample_luminance(image), sample_width // 4)
    results = {}
    for mode in args.modes:
        # Texture up = +y on the plane (the axis is projected on it): the same orientation as tiling.
        apply_mode(obj, mode, image, world_size, args, cache_dir, axis=(0.0, 1.0, 0.0))
        rgba = render(scene, os.path.join(args.out, mode + ".png"))
        results[mode] = measure(rgba, distance, valid, sample_width // 4)
    print_table("plane: %d jittered triangles, %d edges, %dx%d px, 1 texel/px, sample %s (%dx%d); "
                "the sample's own repeat (circular) %.3f" % (2 * args.cells ** 2, len(segments), args.pixels,
                                                             args.pixels, os.path.basename(args.sample),
                                                             image.size[0], image.size[1], own_repeat),
                results, "tiling")


# Three orthographic views of the curved mesh: (location, rotation) of a camera aimed at the origin.
VIEWS = {"front": ((0.0, -5.0, 0.0), (math.pi / 2, 0.0, 0.0)),
         "side": ((5.0, 0.0, 0.0), (math.pi / 2, 0.0, math.pi / 2)),
         "top": ((0.0, 0.0, 5.0), (0.0, 0.0, 0.0))}


def wireframe_mask(scene, obj, path):
    """Mesh-edge pixels of the current view: a Cycles render of the Wireframe node (1 px wide), which
    hides edges behind the surface. The mesh is all triangles, so every drawn edge is a mesh edge."""
    def color(nodes, links):
        wire = nodes.new("ShaderNodeWireframe")
        wire.use_pixel_size = True
        wire.inputs["Size"].default_value = 1.0
        return wire.outputs["Fac"]
    saved = list(obj.data.materials)
    obj.data.materials.clear()
    obj.data.materials.append(harness.emission_material("Wire", color))
    engine = scene.render.engine
    scene.render.engine = "CYCLES"
    scene.cycles.samples = 16
    scene.cycles.use_denoising = False
    rgba = render(scene, path)
    scene.render.engine = engine
    obj.data.materials.clear()
    for material in saved:
        obj.data.materials.append(material)
    return (rgba[..., 0] > 0.5) & (rgba[..., 3] > 0.5), rgba[..., 3] > 0.999


def curved_benchmark(args, cache_dir):
    harness.reset_scene()
    image = bpy.data.images.load(os.path.abspath(args.sample))
    view_width = 3.0
    world_size = image.size[0] * view_width / args.pixels  # one texel per pixel where the surface faces the camera
    scene = setup_view(view_width, args.pixels)
    scene.render.film_transparent = True
    obj = harness.add_primitive("monkey", "Suzanne")
    harness.select_only([obj])
    # Triangulated, not subdivided: faces of 10-40 px at this size leave room for an edge-distance profile.
    modifier = obj.modifiers.new("Triangulate", "TRIANGULATE")
    bpy.ops.object.modifier_apply(modifier=modifier.name)
    masks = {}
    for view, (location, rotation) in VIEWS.items():
        scene.camera.location, scene.camera.rotation_euler = location, rotation
        edges, opaque = wireframe_mask(scene, obj, os.path.join(args.out, "suzanne_%s_edges.png" % view))
        inside = blend_metrics.edge_distance(~opaque, 4) >= 4  # away from the silhouette
        masks[view] = (blend_metrics.edge_distance(edges, PROFILE_DISTANCE + 2), inside)
    results = {view: {} for view in VIEWS}
    for mode in [m for m in args.modes if m != "tiling"]:  # tiling needs UVs Suzanne has no use for
        apply_mode(obj, mode, image, world_size, args, cache_dir)
        for view, (location, rotation) in VIEWS.items():
            scene.camera.location, scene.camera.rotation_euler = location, rotation
            rgba = render(scene, os.path.join(args.out, "suzanne_%s_%s.png" % (view, mode)))
            results[view][mode] = measure(rgba, *masks[view], None)
    for view in VIEWS:
        print_table("Suzanne (%d triangles), %s view, %dx%d px; detail relative to box projection"
                    % (len(obj.data.polygons), view, args.pixels, args.pixels), results[view], "box")


def main():
    args = parse_args()
    os.makedirs(args.out, exist_ok=True)
    cache_dir = tempfile.mkdtemp(prefix="texsynth_bench_cache_")
    if "plane" in args.scenes:
        plane_benchmark(args, cache_dir)
    if "curved" in args.scenes:
        curved_benchmark(args, cache_dir)
    print("\nbench_blend_quality: renders and edge masks in %s" % args.out)


if __name__ == "__main__":
    main()

# SPDX-License-Identifier: GPL-3.0-or-later
"""Measures one corpus run inside the Blender that has just run addon/texsynth_cli.py (bench_corpus.py starts
`blender -b empty.blend --python corpus_cli_shim.py --python addon/texsynth_cli.py --python corpus_measure.py
-- <cli args>`): the CLI synthesized, rendered (--render) and wrote --stats; this script then reads the scene as
the CLI left it. Its settings come in the JSON file named by $TEXSYNTH_CORPUS_MEASURE:
{sample, method, mesh, px_per_unit, out, stats, seed}. It writes <out>/measure.json and pictures.

Peak memory: ru_maxrss of this process when this script starts (the CLI's synthesis and Eevee render).

Views: two orthographic cameras (front = looking along +Y, side = along -X) over the mesh (centred, longest
side 1 unit), px_per_unit render pixels per world unit = the sample's pixels per world unit (--scale = sample
width / px_per_unit), so a surface facing the camera shows the texture 1:1. Cycles, 1 sample, box filter
0.01 px (point sampling at pixel centres: no anti-aliasing blur), Standard view transform, every Principled
BSDF replaced by an Emission of its Base Color (alpha kept through a Transparent mix): the rendered colour is
the texture's colour. Three renders per view: colour (8-bit PNG, sRGB like the sample), world position and
the result's UV map (float EXR; particle decals hidden in these two).

Masks per view: covered (alpha 1); occlusion = 4-neighbours both covered whose positions are more than 3 px
of world apart, plus the silhouette, dilated by 2 px; facing = both pixel steps of the position under
1.5 / px_per_unit (surface within ~48 degrees of facing the camera); valid = covered & facing & ~occlusion.
Seams = 4-neighbours (both covered, not occlusion) whose UVs differ by more than 2.5 texels after removing
whole sample periods (texels of the sample for jumpmap / texton / particles' background through TexSynth's UV
map, of the 1024^2 image for round / patches through the bake UV map): where the mapping is discontinuous.

Figures (both views pooled):
  seam     blend_metrics.seam_ratio: mean |grad L| within 1 px of a seam / from 3 px on (1.00 = invisible)
  detail   mean |grad L| over valid pixels / the sample's own mean |grad L| (1.00 = as sharp as the sample)
  patch    nearest-patch distance ratio: 400 random 7 x 7 RGB render patches (all pixels valid), each's mean
           squared distance per pixel value to its nearest sample patch, averaged; divided by the same for 400
           held-out sample patches, each against sample patches whose corner is at least 7 px away (Chebyshev).
           Sample patches: every position (a regular subset of at most 30,000 for large samples). 1.0 = the
           render's neighbourhoods are as close to the sample as the sample's own; larger = new structure
           (mush, blotches, broken elements); far below 1 = verbatim copies.
  density  particles only: placed particles per surface pixel (mesh area x px_per_unit^2) / the analysis'
           particles of the placed classes per sample pixel.
"""
import json
import math
import os
import resource
import sys

PEAK_KB = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss  # before this script allocates anything

import bpy  # noqa: E402
import numpy as np  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import blend_metrics  # noqa: E402

PATCH = 7
QUERIES = 400
MAX_CANDIDATES = 30000
SEAM_TEXELS = 2.5
VIEWS = {"front": ((0.0, -5.0, 0.0), (math.pi / 2, 0.0, 0.0)),
         "side": ((5.0, 0.0, 0.0), (math.pi / 2, 0.0, math.pi / 2))}


def load_pixels(path):
    image = bpy.data.images.load(path, check_existing=False)
    width, height = image.size
    pixels = np.empty(width * height * image.channels, np.float32)
    image.pixels.foreach_get(pixels)
    channels = image.channels
    bpy.data.images.remove(image)
    return pixels.reshape(height, width, channels)[::-1].astype(np.float64)  # row 0 = top


def emission_everywhere():
    """Every Principled BSDF of every material -> Emission(Base Color), mixed with Transparent by Alpha."""
    for material in bpy.data.materials:
        if not material.use_nodes:
            continue
        nodes, links = material.node_tree.nodes, material.node_tree.links
        for node in [n for n in nodes if n.type == "BSDF_PRINCIPLED"]:
            emission = nodes.new("ShaderNodeEmission")
            base = node.inputs["Base Color"]
            if base.is_linked:
                links.new(base.links[0].from_socket, emission.inputs["Color"])
            else:
                emission.inputs["Color"].default_value = base.default_value
            out = emission.outputs["Emission"]
            alpha = node.inputs["Alpha"]
            if alpha.is_linked or alpha.default_value < 1.0:
                mix = nodes.new("ShaderNodeMixShader")
                transparent = nodes.new("ShaderNodeBsdfTransparent")
                if alpha.is_linked:
                    links.new(alpha.links[0].from_socket, mix.inputs["Fac"])
                else:
                    mix.inputs["Fac"].default_value = alpha.default_value
                links.new(transparent.outputs["BSDF"], mix.inputs[1])
                links.new(out, mix.inputs[2])
                out = mix.outputs["Shader"]
            for link in list(node.outputs["BSDF"].links):
                target = link.to_socket
                links.remove(link)
                links.new(out, target)
        if material.blend_method == "BLEND":
            material.blend_method = "HASHED"


def vector_material(name, kind, uv_name=""):
    material = bpy.data.materials.new(name)
    material.use_nodes = True
    nodes, links = material.node_tree.nodes, material.node_tree.links
    nodes.clear()
    emission = nodes.new("ShaderNodeEmission")
    output = nodes.new("ShaderNodeOutputMaterial")
    links.new(emission.outputs["Emission"], output.inputs["Surface"])
    if kind == "uv":
        uv = nodes.new("ShaderNodeUVMap")
        uv.uv_map = uv_name
        links.new(uv.outputs["UV"], emission.inputs["Color"])
    else:
        geometry = nodes.new("ShaderNodeNewGeometry")
        links.new(geometry.outputs["Position"], emission.inputs["Color"])
    return material


def setup_scene(pixels):
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = 1
    scene.cycles.use_denoising = False
    scene.cycles.pixel_filter_type = "BOX"
    scene.cycles.filter_width = 0.01
    scene.cycles.max_bounces = 0
    scene.cycles.transparent_max_bounces = 16
    scene.cycles.use_adaptive_sampling = False
    scene.render.film_transparent = True
    scene.render.dither_intensity = 0.0
    scene.render.resolution_x = scene.render.resolution_y = pixels
    scene.render.resolution_percentage = 100
    scene.view_settings.view_transform = "Standard"
    scene.view_settings.look = "None"
    scene.view_settings.exposure = 0.0
    scene.view_settings.gamma = 1.0
    scene.world = None
    for obj in scene.objects:
        if obj.type == "LIGHT":
            obj.hide_render = True
    data = bpy.data.cameras.new("Measure")
    data.type = "ORTHO"
    data.ortho_scale = 1.1
    camera = bpy.data.objects.new("Measure", data)
    scene.collection.objects.link(camera)
    scene.camera = camera
    return scene, camera


def render(scene, path, exr):
    settings = scene.render.image_settings
    if exr:
        settings.file_format, settings.color_depth, settings.color_mode = "OPEN_EXR", "32", "RGBA"
    else:
        settings.file_format, settings.color_depth, settings.color_mode = "PNG", "8", "RGBA"
    scene.render.filepath = path
    bpy.ops.render.render(write_still=True)
    return load_pixels(path)


def neighbours_differ(values, threshold, wrap=False, scale=None):
    """Boolean masks of pixels whose right or lower neighbour's value differs by more than threshold
    (both pixels of a pair are marked); wrap: whole periods (1.0) removed first; then scaled per channel."""
    def step(a, b):
        d = a - b
        if wrap:
            d = d - np.round(d)
        if scale is not None:
            d = d * scale
        return np.sqrt((d ** 2).sum(-1)) > threshold
    mask = np.zeros(values.shape[:2], bool)
    right = step(values[:, 1:], values[:, :-1])
    down = step(values[1:, :], values[:-1, :])
    mask[:, 1:] |= right
    mask[:, :-1] |= right
    mask[1:, :] |= down
    mask[:-1, :] |= down
    return mask


def dilate(mask, steps):
    out = mask.copy()
    for _ in range(steps):
        grown = out.copy()
        grown[1:, :] |= out[:-1, :]
        grown[:-1, :] |= out[1:, :]
        grown[:, 1:] |= out[:, :-1]
        grown[:, :-1] |= out[:, 1:]
        out = grown
    return out


def erode(mask, steps):
    return ~dilate(~mask, steps)


def view_masks(position, uv, alpha, px_per_unit, texels):
    covered = alpha > 0.999
    pixel = 1.0 / px_per_unit
    occlusion = neighbours_differ(np.where(covered[..., None], position, 1e6), 3.0 * pixel)
    occlusion |= covered & ~erode(covered, 1)
    bad = dilate(occlusion, 2)
    step_x = np.full(covered.shape, np.inf)
    step_y = np.full(covered.shape, np.inf)
    step_x[:, :-1] = np.linalg.norm(position[:, 1:] - position[:, :-1], axis=-1)
    step_y[:-1, :] = np.linalg.norm(position[1:, :] - position[:-1, :], axis=-1)
    facing = (step_x < 1.5 * pixel) & (step_y < 1.5 * pixel)
    valid = covered & facing & ~bad
    seams = neighbours_differ(uv[..., :2], SEAM_TEXELS, wrap=True, scale=np.asarray(texels, np.float64))
    seams = seams & covered & ~dilate(occlusion, 1)
    return valid, seams


def save_mask_picture(path, seams, valid, covered):
    """red = seam pixels, green = valid (measured) pixels, grey = covered but left out."""
    rgba = np.zeros(seams.shape + (4,), np.float32)
    rgba[..., 3] = 1.0
    rgba[covered] = (0.3, 0.3, 0.3, 1.0)
    rgba[valid, 1] = 0.7
    rgba[seams, 0] = 1.0
    image = bpy.data.images.new("mask", seams.shape[1], seams.shape[0])
    image.pixels.foreach_set(rgba[::-1].ravel())
    image.filepath_raw = path
    image.file_format = "PNG"
    image.save()
    bpy.data.images.remove(image)


def luminance(rgb):
    return blend_metrics.luminance(rgb)


def patch_matrix(image, ys, xs, k):
    offsets_y, offsets_x = np.mgrid[0:k, 0:k]
    rows = ys[:, None, None] + offsets_y[None]
    cols = xs[:, None, None] + offsets_x[None]
    return image[rows, cols].reshape(len(ys), -1)


def nearest_mean(queries, candidates, exclude=None):
    """Mean over queries of min over candidates of the mean squared difference per value."""
    cand_sq = (candidates ** 2).sum(1)
    best = np.empty(len(queries))
    for start in range(0, len(queries), 100):
        q = queries[start:start + 100]
        d = (q ** 2).sum(1)[:, None] + cand_sq[None, :] - 2.0 * q @ candidates.T
        if exclude is not None:
            d[exclude[start:start + 100]] = np.inf
        best[start:start + 100] = np.maximum(d.min(1), 0.0)
    return float(best.mean() / candidates.shape[1])


def sample_patches(sample, rng):
    height, width = sample.shape[:2]
    ny, nx = height - PATCH + 1, width - PATCH + 1
    stride = max(1, int(math.ceil(math.sqrt(ny * nx / MAX_CANDIDATES))))
    cy, cx = np.mgrid[0:ny:stride, 0:nx:stride]
    cy, cx = cy.ravel(), cx.ravel()
    candidates = patch_matrix(sample, cy, cx, PATCH)
    qy = rng.integers(0, ny, QUERIES)
    qx = rng.integers(0, nx, QUERIES)
    queries = patch_matrix(sample, qy, qx, PATCH)
    near = (np.abs(qy[:, None] - cy[None, :]) < PATCH) & (np.abs(qx[:, None] - cx[None, :]) < PATCH)
    own = nearest_mean(queries, candidates, exclude=near)
    return candidates, own


def render_patch_distance(rgb_list, valid_list, candidates, rng):
    pools = []
    for rgb, valid in zip(rgb_list, valid_list):
        ok = valid
        # a patch is usable when all of its k x k pixels are valid
        h, w = valid.shape
        usable = np.zeros((h - PATCH + 1, w - PATCH + 1), bool)
        usable[:] = True
        for dy in range(PATCH):
            for dx in range(PATCH):
                usable &= ok[dy:dy + h - PATCH + 1, dx:dx + w - PATCH + 1]
        ys, xs = np.nonzero(usable)
        pools.append((rgb, ys, xs))
    total = sum(len(p[1]) for p in pools)
    if total < 20:
        return None, total
    queries = []
    for rgb, ys, xs in pools:
        count = int(round(QUERIES * len(ys) / total))
        if count == 0:
            continue
        pick = rng.choice(len(ys), size=min(count, len(ys)), replace=False)
        queries.append(patch_matrix(rgb, ys[pick], xs[pick], PATCH))
    return nearest_mean(np.concatenate(queries), candidates), total


def mesh_area(obj):
    mesh = obj.data
    mesh.calc_loop_triangles()
    count = len(mesh.loop_triangles)
    area = np.empty(count, np.float32)
    mesh.loop_triangles.foreach_get("area", area)
    scale = np.asarray(obj.matrix_world.to_scale())
    return float(area.sum()) * float(abs(scale[0] * scale[1]))


def particle_density(config, target, stats):
    try:
        from texsynth.particles import core
    except ImportError:
        return None
    entries = getattr(core.analyses, "entries", [])
    if not entries:
        return None
    analysis = entries[-1][1]
    rows = core.class_rows(analysis)
    native = (stats.get("native") or {}).get(target.name) or {}
    per_class = native.get("per_class") or {}
    placed = sum(int(v) for v in per_class.values()) if per_class else int(native.get("placed", 0))
    classes = [int(c) for c in per_class] if per_class else [r["id"] for r in rows if not r["background"]]
    sample_count = sum(rows[c]["particles"] for c in classes if c < len(rows))
    width, height = config["sample_size"]
    if sample_count == 0:
        return None
    surface_pixels = mesh_area(target) * config["px_per_unit"] ** 2
    return dict(ratio=(placed / surface_pixels) / (sample_count / float(width * height)), placed=placed,
                sample_particles=sample_count, classes=classes)


def main():
    with open(os.environ["TEXSYNTH_CORPUS_MEASURE"]) as handle:
        config = json.load(handle)
    out = config["out"]
    method = config["method"]
    with open(config["stats"]) as handle:
        stats = json.load(handle)
    scene = bpy.context.scene
    target = bpy.data.objects.get(config["mesh"])
    if target is None:
        raise SystemExit("corpus_measure: no object %r" % config["mesh"])
    others = [o for o in scene.objects if o.type == "MESH" and o is not target]
    uv_layers = [uv.name for uv in target.data.uv_layers]
    if method in ("round", "patches"):
        uv_name = next((n for n in uv_layers if n != "TexSynth"), "")
        texels = (1024, 1024)
        image = bpy.data.images.get("TexSynth %s: %s" % ("Round" if method == "round" else "Patches", target.name))
        if image is not None:
            texels = tuple(image.size)
    else:
        uv_name = "TexSynth"
        texels = tuple(config["sample_size"])
    sample_rgba = load_pixels(os.path.abspath(config["sample"]))
    sample = sample_rgba[..., :3] if sample_rgba.shape[2] >= 3 else np.repeat(sample_rgba[..., :1], 3, 2)
    sample_grad = blend_metrics.gradient_magnitude(luminance(sample))
    sample_detail = float(np.nanmean(sample_grad))

    pixels = int(math.ceil(1.1 * config["px_per_unit"]))
    scene, camera = setup_scene(pixels)
    emission_everywhere()
    uv_material = vector_material("Measure UV", "uv", uv_name)
    position_material = vector_material("Measure Position", "position")
    rgb_views, valid_views, grads, seams_views = [], [], [], []
    for view, (location, rotation) in VIEWS.items():
        camera.location, camera.rotation_euler = location, rotation
        colour = render(scene, os.path.join(out, "flat_%s.png" % view), exr=False)
        layer = scene.view_layers[0]
        hidden = [(o, o.hide_render) for o in others]
        for o in others:
            o.hide_render = True
        layer.material_override = position_material
        position = render(scene, os.path.join(out, "position_%s.exr" % view), exr=True)
        layer.material_override = uv_material
        uv = render(scene, os.path.join(out, "uv_%s.exr" % view), exr=True)
        layer.material_override = None
        for o, was in hidden:
            o.hide_render = was
        valid, seams = view_masks(position[..., :3], uv[..., :2], position[..., 3], config["px_per_unit"], texels)
        rgb = colour[..., :3]
        rgb_views.append(rgb)
        valid_views.append(valid)
        grads.append(blend_metrics.gradient_magnitude(luminance(rgb)))
        seams_views.append(seams)
        save_mask_picture(os.path.join(out, "masks_%s.png" % view), seams, valid, covered=position[..., 3] > 0.999)
        for name in ("position_%s.exr", "uv_%s.exr"):
            os.remove(os.path.join(out, name % view))
    # seam ratio over both views: distances per view, pixels pooled
    edge, interior = [], []
    valid_count = 0
    seam_pixels = 0
    for grad, valid, seams in zip(grads, valid_views, seams_views):
        distance = blend_metrics.edge_distance(seams, 4)
        ok = valid & np.isfinite(grad)
        edge.append(grad[ok & (distance <= 1)])
        interior.append(grad[ok & (distance >= 3)])
        valid_count += int(ok.sum())
        seam_pixels += int((seams & valid).sum())
    edge, interior = np.concatenate(edge), np.concatenate(interior)
    seam = float(edge.mean() / interior.mean()) if len(edge) >= 50 and len(interior) else None
    render_detail = float(np.concatenate([g[v & np.isfinite(g)] for g, v in zip(grads, valid_views)]).mean())
    rng = np.random.default_rng(int(config.get("seed", 0)) + 29)
    candidates, own = sample_patches(sample, rng)
    distance, usable = render_patch_distance(rgb_views, valid_views, candidates, rng)
    result = dict(peak_mb=PEAK_KB / 1024.0, valid_pixels=valid_count, seam_pixels=seam_pixels, seam=seam,
                  detail=render_detail / sample_detail if sample_detail > 0 else None,
                  render_gradient=render_detail, sample_gradient=sample_detail,
                  patch_render=distance, patch_sample=own,
                  patch=(distance / own) if (distance is not None and own > 0) else None,
                  patch_windows=usable, uv_map=uv_name, texels=list(texels), render_pixels=pixels)
    if method == "particles":
        result["density"] = particle_density(config, target, stats)
    with open(os.path.join(out, "measure.json"), "w") as handle:
        json.dump(result, handle, indent=1)
    print("corpus_measure: seam %s detail %s patch %s peak %.0f MB" % (
        "%.3f" % seam if seam is not None else "-", "%.3f" % result["detail"] if result["detail"] else "-",
        "%.3f" % result["patch"] if result["patch"] is not None else "-", result["peak_mb"]))


main()

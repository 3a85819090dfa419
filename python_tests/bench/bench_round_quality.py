# SPDX-License-Identifier: GPL-3.0-or-later
"""Round-neighbourhood synthesis (Chen & Dong 2008; texsynth_native.round_synthesize) measured as issue 13
asks. Not a test: prints figures and leaves pictures.

  blender -b --factory-startup --python-exit-code 1 --python python_tests/bench/bench_round_quality.py -- \\
      [--sample blend_samples/bricks.png ...] [--size 512] [--out /tmp/round_bench] [--seed 1]
      [--parts plane,seam,field,perf] [--perf-size 1024,1200] [--perf-sample bricks] [--render 512]

--sample may be repeated; the word `stripes` names a synthetic wavy-grain sample made here (128 x 128,
grain along the sample's +y). Default: bricks, moss, bark, stripes. bpy builds the meshes, unwraps them
(Smart UV Project) and renders; mesh data goes to the native module through foreach_get.

1. plane: a flat 1 x 1 plane, UV = position, constant field +y, `size`^2 texels, one sample pixel per texel.
   Three surfaces: the plane as 16 x 16 square cells along the UV axes (the rings' reference tangent, each
   triangle's first edge, then lies at 0 or 45 degrees from the field's normal, so every template angle falls
   exactly on a ring bin: the best case); the same plane tessellated by a lattice turned 17 degrees (template
   angles fall between bins, as on any real mesh); an open cylinder (radius 1/(2 pi), height 1, isometric UV
   map, 128 x 128 square cells, field along the axis). Synthesis rows: mean +- sd over 3 seeds.
   hist   colour-histogram distance to the sample: per channel 32 bins on [0, 1], L1 distance between the
          normalised histograms (0 = same, 2 = disjoint), mean of R, G, B. The sample's own value: its left
          half against its right half and its bottom half against its top half (mean of the two).
   p5/p11 mean nearest-patch distance: for 600 random patches of the image (5 x 5 or 11 x 11, RGB), the
          squared distance per pixel (sum over the patch and RGB / k^2) to the nearest patch of the sample
          (brute force over every sample patch). The sample's own value: 600 random sample patches, each to
          its nearest sample patch whose top-left corner is at least half a patch away (Chebyshev >= (k+1)//2).
   Baselines: the sample tiled (a verbatim copy: only tile borders are new), its 8 x 8 and 4 x 4 blocks
   shuffled (must score badly on p5/p11; their histogram is the sample's), the sample blurred by a 4 x 4 box.
2. seam: Suzanne (Subdivision level 2, ~15.7k triangles), Smart UV Project at 45 degrees (the default 66
   degrees folds islands onto themselves and the context refuses it: printed), field = world +Z projected on
   the tangent plane, `size`^2 image target, one sample pixel per texel of the UV map (its mean texel density).
   Emission of that image through the UV map, Eevee, 1 sample, 3 orthographic views of `render` px. Two more
   renders per view write UV and object position (EXR); a pixel is on a UV seam when a 4-neighbour lands on
   another UV island (island map from sample_texels) of the same connected mesh part while their positions are
   less than 6 px of world apart; larger jumps and other parts are occlusion edges and, with the silhouette,
   are excluded within 2 px; so are pixels whose surface turns more than 60 degrees from the camera.
   ratio = mean |grad L| within 1 px of a seam / from 3 px on (blend_metrics.seam_ratio); 1.0 = no seam.
   Baseline: the sample tiled over the image (one sample pixel per texel) through the same UV map. Control
   (seamless by construction): wavy stripes of world x written per texel from its 3D position.
3. field: structure-tensor orientation of the synthesized image (luminance, central differences, tensor
   smoothed by three 5-wide box passes, sigma ~2.4 texels) against the field mapped into the image per texel
   (barycentric field, through its triangle's UV Jacobian, python_tests/uv_jacobians.py); texels whose 15 x 15
   window is all covered texels of one island. Error = angle between the grain (perpendicular to the dominant
   gradient) and the mapped field, 0..90 degrees; median, 75th percentile, share <= 10 degrees, mean
   coherence. Meshes: torus (Smart UV 66 degrees, field along its rings), Suzanne as in 2 (projected +Z).
   Floors: the 2D sample itself, the plane result of 1. Baselines: the field turned 90 degrees (n x d)
   measured against the original field (should be ~90) and against itself, a random field per vertex
   (should be ~45 against the field). Samples: stripes and bark (anisotropic) when given.
4. perf: Suzanne Subdivision level 3 (~63k triangles), Smart UV Project 45 degrees, each of `perf-size`^2
   (1200^2 gives ~700k surface samples), one sample pixel per texel; each size in a fresh /usr/bin/python3.11
   (TEXSYNTH_PYTHON overrides): context seconds, synthesis seconds, re-synthesis with the field turned 90
   degrees, peak RSS (VmHWM), with the load average of the machine (other jobs slow the figures down).

Pictures go to --out (PNG: synthesized images, renders, seam masks, orientation-error maps; row 0 = top).
"""
import argparse
import json
import math
import os
import resource
import shutil
import subprocess
import sys
import time
import zlib

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.dirname(HERE))
sys.path.insert(0, os.environ.get("TEXSYNTH_MODULE_DIR", os.path.join(ROOT, "addon")))
try:
    import bpy
except ImportError:  # the --perf-worker process
    bpy = None
else:
    sys.path.insert(0, os.path.join(os.path.dirname(HERE), "blender"))
    import harness  # noqa: E402
import texsynth_native as ts  # noqa: E402

import blend_metrics  # noqa: E402
import uv_jacobians  # noqa: E402

SAMPLES = ("bricks", "moss", "bark", "stripes")
FIELD_SAMPLES = ("stripes", "bark")
PLANE_SEEDS = 3  # part 1: synthesis rows over this many seeds
PLANE_TURN = 17.0  # part 1: the turned tessellation of the plane (degrees)  # anisotropic: grain along the sample's +y
PAPER = ("paper (Chen & Dong 2008, §7; 3.8 GHz Pentium, vertex colours): Horse 48,485 vertices: ~5 min "
         "marching + 10-15 s synthesis; 2D 512^2: ~30 s, 360^2: ~15 s")


# ---------------------------------------------------------------------------------------------- images

def write_png(path, rgb):
    """(H, W, 3 or 1) floats in [0, 1], row 0 = BOTTOM (Blender order), as an 8-bit PNG (row 0 = top)."""
    a = np.asarray(rgb, np.float64)
    if a.ndim == 2:
        a = a[..., None]
    if a.shape[2] == 1:
        a = np.repeat(a, 3, axis=2)
    a = (np.clip(a[::-1, :, :3], 0, 1) * 255 + 0.5).astype(np.uint8)
    h, w = a.shape[:2]
    raw = b"".join(b"\x00" + a[y].tobytes() for y in range(h))

    def chunk(kind, data):
        body = kind + data
        return len(data).to_bytes(4, "big") + body + (zlib.crc32(body) & 0xffffffff).to_bytes(4, "big")
    with open(path, "wb") as f:
        header = w.to_bytes(4, "big") + h.to_bytes(4, "big") + b"\x08\x02\x00\x00\x00"
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header)
                + chunk(b"IDAT", zlib.compress(raw, 6)) + chunk(b"IEND", b""))


def smooth_noise(shape, cell, rng):
    """Value noise in [0, 1]: a random lattice every `cell` pixels, bilinear."""
    h, w = shape
    grid = rng.random((h // cell + 2, w // cell + 2))
    y = np.arange(h) / cell
    x = np.arange(w) / cell
    y0, x0 = np.floor(y).astype(int), np.floor(x).astype(int)
    fy, fx = (y - y0)[:, None], (x - x0)[None, :]
    fy, fx = fy * fy * (3 - 2 * fy), fx * fx * (3 - 2 * fx)
    g = grid
    return ((1 - fy) * ((1 - fx) * g[y0][:, x0] + fx * g[y0][:, x0 + 1])
            + fy * ((1 - fx) * g[y0 + 1][:, x0] + fx * g[y0 + 1][:, x0 + 1]))


def stripes_sample(size=128, seed=7):
    """Wavy wood-like grain running along +y (row index = texture up), Blender row order."""
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:size, 0:size].astype(np.float64)
    phase = 2 * np.pi * x / 9.0 + 2.2 * smooth_noise((size, size), 32, rng) + 0.8 * smooth_noise((size, size), 12, rng)
    grain = 0.5 + 0.5 * np.sin(phase)
    tone = 0.2 + 0.6 * grain + 0.12 * (smooth_noise((size, size), 4, rng) - 0.5)
    rgb = np.stack([0.25 + 0.55 * tone, 0.15 + 0.4 * tone, 0.08 + 0.2 * tone], axis=2)
    return np.ascontiguousarray(np.clip(rgb, 0, 1), np.float32)


def load_sample(spec):
    """(name, float32 (H, W, 3) in Blender row order: row 0 = bottom)."""
    if spec == "stripes":
        return "stripes", stripes_sample()
    path = spec if os.path.exists(spec) else os.path.join(ROOT, "blend_samples", spec + ".png")
    pixels = ts.load_image(path)  # row 0 = top
    return os.path.splitext(os.path.basename(path))[0], np.ascontiguousarray(pixels[::-1, :, :3], np.float32)


def luminance(rgb):
    return blend_metrics.luminance(np.asarray(rgb, np.float64))


def box(image, width, axis):
    """Moving mean of `width` (odd) along axis, edges clamped."""
    r = width // 2
    pad = [(0, 0)] * image.ndim
    pad[axis] = (r + 1, r)
    c = np.cumsum(np.pad(image, pad, mode="edge"), axis=axis)
    n = image.shape[axis]
    hi = np.take(c, np.arange(width, width + n), axis=axis)
    lo = np.take(c, np.arange(0, n), axis=axis)
    return (hi - lo) / width


def blur(image, width=5, passes=3):
    for _ in range(passes):
        image = box(box(image, width, 0), width, 1)
    return image


def grain_orientation(rgb):
    """Per pixel: grain angle (radians, mod pi, in (x = column, y = row) coordinates) = the dominant gradient
    orientation of the smoothed structure tensor turned by 90 degrees, and the coherence (l1-l2)/(l1+l2)."""
    lum = luminance(rgb)
    ix = np.zeros_like(lum)
    iy = np.zeros_like(lum)
    ix[:, 1:-1] = (lum[:, 2:] - lum[:, :-2]) * 0.5
    iy[1:-1, :] = (lum[2:, :] - lum[:-2, :]) * 0.5
    jxx, jyy, jxy = blur(ix * ix), blur(iy * iy), blur(ix * iy)
    gradient = 0.5 * np.arctan2(2 * jxy, jxx - jyy)
    coherence = np.hypot(jxx - jyy, 2 * jxy) / np.maximum(jxx + jyy, 1e-12)
    return gradient + np.pi / 2, coherence


def angle_error_degrees(a, b):
    """Angle between two line orientations (radians, mod pi), in degrees 0..90."""
    d = np.mod(a - b, np.pi)
    return np.degrees(np.minimum(d, np.pi - d))


def error_picture(error, valid):
    """0 degrees green, 45 yellow, 90 red; invalid texels dark grey."""
    t = np.clip(error / 90.0, 0, 1)
    rgb = np.stack([np.clip(2 * t, 0, 1), np.clip(2 - 2 * t, 0, 1), np.zeros_like(t)], axis=2)
    rgb[~valid] = 0.15
    return rgb


# ------------------------------------------------------------------------------------------ statistics

def histogram_distance(a, b, bins=32):
    total = 0.0
    for c in range(3):
        ha = np.histogram(a[..., c], bins=bins, range=(0.0, 1.0))[0].astype(np.float64)
        hb = np.histogram(b[..., c], bins=bins, range=(0.0, 1.0))[0].astype(np.float64)
        total += np.abs(ha / ha.sum() - hb / hb.sum()).sum()
    return total / 3


def own_histogram_distance(sample):
    h, w = sample.shape[:2]
    return 0.5 * (histogram_distance(sample[:, :w // 2], sample[:, w // 2:]) +
                  histogram_distance(sample[:h // 2], sample[h // 2:]))


def patches(image, k, ys, xs):
    """(N, k*k*3) float64 patches with top-left corners (ys, xs)."""
    dy, dx = np.mgrid[0:k, 0:k]
    return image[ys[:, None] + dy.ravel()[None, :], xs[:, None] + dx.ravel()[None, :], :3].reshape(len(ys), -1) \
        .astype(np.float64)


def nearest_patch(image, sample, k, count, rng, covered=None, leave_one_out=False):
    """Mean over `count` random k x k patches of `image` of the squared distance per pixel to the nearest
    k x k patch of `sample` (leave_one_out: image is the sample; patches within Chebyshev < (k+1)//2 excluded)."""
    sh, sw = sample.shape[:2]
    gy, gx = np.mgrid[0:sh - k + 1, 0:sw - k + 1]
    gy, gx = gy.ravel(), gx.ravel()
    centre = sample[..., :3].reshape(-1, 3).mean(0)
    sample, image = sample[..., :3] - centre, image[..., :3] - centre  # centred: float32 sums stay accurate
    bank = patches(sample, k, gy, gx).astype(np.float32)
    bank_sq = (bank.astype(np.float64) ** 2).sum(1)
    h, w = image.shape[:2]
    oy, ox = np.mgrid[0:h - k + 1, 0:w - k + 1]
    oy, ox = oy.ravel(), ox.ravel()
    if covered is not None:  # only patches whose texels are all covered
        full = blur_min(covered, k)[oy, ox]
        oy, ox = oy[full], ox[full]
    pick = rng.choice(len(oy), size=min(count, len(oy)), replace=False)
    qy, qx = oy[pick], ox[pick]
    best = []
    for start in range(0, len(qy), 100):
        q = patches(image, k, qy[start:start + 100], qx[start:start + 100])
        d = (q * q).sum(1)[:, None] + bank_sq[None, :] - 2 * (q.astype(np.float32) @ bank.T).astype(np.float64)
        if leave_one_out:
            near = (np.abs(qy[start:start + 100, None] - gy[None, :]) < (k + 1) // 2) & \
                   (np.abs(qx[start:start + 100, None] - gx[None, :]) < (k + 1) // 2)
            d[near] = np.inf
        best.append(np.maximum(d.min(1), 0.0))
    return float(np.concatenate(best).mean() / (k * k))


def blur_min(mask, k):
    """True at (y, x) when mask[y:y+k, x:x+k] is all True."""
    m = mask.astype(np.int32)
    c = np.pad(np.cumsum(np.cumsum(m, 0), 1), ((1, 0), (1, 0)))
    s = c[k:, k:] - c[:-k, k:] - c[k:, :-k] + c[:-k, :-k]
    out = np.zeros(mask.shape, bool)
    out[:s.shape[0], :s.shape[1]] = s == k * k
    return out


def shuffled_blocks(sample, block, rng):
    h, w = (sample.shape[0] // block) * block, (sample.shape[1] // block) * block
    blocks = sample[:h, :w].reshape(h // block, block, w // block, block, -1).transpose(0, 2, 1, 3, 4)
    flat = blocks.reshape(-1, block, block, sample.shape[2])
    flat = flat[rng.permutation(len(flat))]
    return np.ascontiguousarray(flat.reshape(h // block, w // block, block, block, -1).transpose(0, 2, 1, 3, 4)
                                .reshape(h, w, -1))


def tiled(sample, h, w):
    reps = (h // sample.shape[0] + 1, w // sample.shape[1] + 1, 1)
    return np.ascontiguousarray(np.tile(sample, reps)[:h, :w])


def box_blurred(sample, width=4):
    out = sample.astype(np.float64)
    c = np.cumsum(np.cumsum(np.pad(out, ((1, 0), (1, 0), (0, 0))), 0), 1)
    s = (c[width:, width:] - c[:-width, width:] - c[width:, :-width] + c[:-width, :-width]) / width ** 2
    return s.astype(np.float32)


# ---------------------------------------------------------------------------------------- mesh / bpy

def reset():
    bpy.ops.wm.read_factory_settings(use_empty=True)


def select_only(obj):
    bpy.context.view_layer.update()
    for o in bpy.context.view_layer.objects:
        o.select_set(False)
    obj.select_set(True)
    bpy.context.view_layer.objects.active = obj


def build_mesh(kind, subdivisions=0, **kwargs):
    getattr(bpy.ops.mesh, "primitive_%s_add" % kind)(**kwargs)
    obj = bpy.context.active_object
    if subdivisions:
        modifier = obj.modifiers.new("Subdivision", "SUBSURF")
        modifier.levels = modifier.render_levels = subdivisions
        bpy.ops.object.modifier_apply(modifier=modifier.name)
    return obj


def smart_uv(obj, angle_degrees, size, name):
    """A new UV map by Smart UV Project (island margin 4 texels of `size`), made active; seconds."""
    mesh = obj.data
    layer = mesh.uv_layers.new(name=name)
    mesh.uv_layers.active = layer
    layer.active_render = True
    select_only(obj)
    bpy.ops.object.mode_set(mode="EDIT")
    bpy.ops.mesh.select_all(action="SELECT")
    start = time.perf_counter()
    bpy.ops.uv.smart_project(angle_limit=math.radians(angle_degrees), island_margin=4.0 / size)
    seconds = time.perf_counter() - start
    bpy.ops.object.mode_set(mode="OBJECT")
    return seconds


def mesh_arrays(obj):
    """positions (V, 3), triangles (T, 3) (loop triangles), corner_uvs (T, 3, 2) of the active UV map,
    vertex normals (V, 3): all by foreach_get."""
    mesh = obj.data
    mesh.calc_loop_triangles()
    t = len(mesh.loop_triangles)
    positions = np.empty(len(mesh.vertices) * 3, np.float32)
    mesh.vertices.foreach_get("co", positions)
    normals = np.empty(len(mesh.vertices) * 3, np.float32)
    mesh.vertices.foreach_get("normal", normals)
    triangles = np.empty(t * 3, np.int32)
    mesh.loop_triangles.foreach_get("vertices", triangles)
    loops = np.empty(t * 3, np.int32)
    mesh.loop_triangles.foreach_get("loops", loops)
    uv = np.empty(len(mesh.loops) * 2, np.float32)
    mesh.uv_layers.active.data.foreach_get("uv", uv)
    corner_uvs = np.ascontiguousarray(uv.reshape(-1, 2)[loops].reshape(t, 3, 2))
    return dict(positions=positions.reshape(-1, 3), triangles=triangles.reshape(-1, 3), corner_uvs=corner_uvs,
                normals=normals.reshape(-1, 3))


def texel_density(m, size):
    """Texels per world unit of the UV map at size^2 (square root of UV area over surface area)."""
    p = m["positions"][m["triangles"]].astype(np.float64)
    t = m["corner_uvs"].astype(np.float64)
    world = 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1).sum()
    e1, e2 = t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]
    uv = 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]).sum()
    return size * math.sqrt(uv / world)


def tangent(vectors, normals):
    """vectors projected on the planes of normals, normalised (zero where undefined)."""
    v = vectors - (vectors * normals).sum(1, keepdims=True) * normals
    n = np.linalg.norm(v, axis=1, keepdims=True)
    return np.where(n > 1e-6, v / np.maximum(n, 1e-12), 0.0).astype(np.float32)


def projected_z(m):
    return tangent(np.tile(np.array([0.0, 0.0, 1.0]), (len(m["positions"]), 1)), m["normals"].astype(np.float64))


def torus_rings(m):
    p = m["positions"].astype(np.float64)
    return tangent(np.stack([-p[:, 1], p[:, 0], np.zeros(len(p))], 1), m["normals"].astype(np.float64))


def turned(directions, m):
    """The field turned by 90 degrees about the normal: n x d."""
    return np.ascontiguousarray(np.cross(m["normals"].astype(np.float64), directions), np.float32)


def random_field(m, rng):
    return tangent(rng.normal(size=(len(m["positions"]), 3)), m["normals"].astype(np.float64))


def context(m, size, density, **kw):
    return ts.RoundSynthesisContext(m["positions"], m["triangles"], m["corner_uvs"], width=size, height=size,
                                    texels_per_unit=density, **kw)


def vertex_components(triangles, num_vertices):
    """Connected component (lowest vertex index) of every vertex, by min-label propagation."""
    label = np.arange(num_vertices)
    while True:
        new = label.copy()
        np.minimum.at(new, triangles.ravel(), np.repeat(label[triangles].min(1), 3))
        new = new[new]
        if np.array_equal(new, label):
            return label
        label = new


def island_map(m, size):
    """(size, size) int: UV island per texel (gutter texels: their source's island), -1 elsewhere; and the
    sample_texels dict."""
    s = ts.sample_texels(m["positions"], m["triangles"], m["corner_uvs"], size, size, 2)
    islands = np.full(size * size, -1, np.int32)
    islands[s["texel"]] = s["island"]
    islands[s["gutter_texel"]] = s["island"][s["gutter_source"]]
    component = vertex_components(m["triangles"], len(m["positions"]))[m["triangles"][:, 0]]
    s["island_component"] = np.zeros(s["num_islands"], np.int64)
    keep = s["triangle_island"] >= 0
    s["island_component"][s["triangle_island"][keep]] = component[keep]
    return islands.reshape(size, size), s


# ------------------------------------------------------------------------------------------- render

VIEWS = {"front": ((0.0, -5.0, 0.0), (math.pi / 2, 0.0, 0.0)),
         "side": ((5.0, 0.0, 0.0), (math.pi / 2, 0.0, math.pi / 2)),
         "top": ((0.0, 0.0, 5.0), (0.0, 0.0, 0.0))}
VIEW_WIDTH = 3.0
FACING = 0.5  # seam measure: only pixels whose surface faces the camera within 60 degrees


def setup_render(pixels):
    scene = bpy.context.scene
    camera_data = bpy.data.cameras.new("Camera")
    camera_data.type = "ORTHO"
    camera_data.ortho_scale = VIEW_WIDTH
    camera = bpy.data.objects.new("Camera", camera_data)
    scene.collection.objects.link(camera)
    scene.camera = camera
    scene.world = None
    harness.flat_render_settings(scene, pixels)
    scene.render.film_transparent = True
    return scene


def image_material(name, rgb, uv_name):
    """Emission of rgb (H, W, 3, row 0 = bottom) through UV map uv_name, bilinear."""
    h, w = rgb.shape[:2]
    image = bpy.data.images.new(name, w, h, alpha=True)
    rgba = np.ones((h, w, 4), np.float32)
    rgba[..., :3] = rgb[..., :3]
    image.pixels.foreach_set(rgba.ravel())
    image.pack()

    def color(nodes, links):
        uv = nodes.new("ShaderNodeUVMap")
        uv.uv_map = uv_name
        texture = nodes.new("ShaderNodeTexImage")
        texture.image, texture.interpolation, texture.extension = image, "Linear", "EXTEND"
        links.new(uv.outputs["UV"], texture.inputs["Vector"])
        return texture.outputs["Color"]
    return harness.emission_material(name, color)


def coordinate_material(name, uv_name):
    """Emission = (u, v, 0) through uv_name (for the UV pass)."""
    def color(nodes, links):
        uv = nodes.new("ShaderNodeUVMap")
        uv.uv_map = uv_name
        return uv.outputs["UV"]
    return harness.emission_material(name, color)


def position_material(name):
    def color(nodes, links):
        return nodes.new("ShaderNodeTexCoord").outputs["Object"]
    return harness.emission_material(name, color)


def assign(obj, material):
    obj.data.materials.clear()
    obj.data.materials.append(material)


def render(scene, path, exr=False):
    settings = scene.render.image_settings
    settings.file_format = "OPEN_EXR" if exr else "PNG"
    settings.color_depth = "32" if exr else "16"
    settings.color_mode = "RGBA"
    scene.render.filepath = path
    scene.view_settings.view_transform = "Raw" if exr else "Standard"
    bpy.ops.render.render(write_still=True)
    image = bpy.data.images.load(path, check_existing=False)
    pixels = np.empty(len(image.pixels), np.float32)
    image.pixels.foreach_get(pixels)
    bpy.data.images.remove(image)
    return pixels.reshape(scene.render.resolution_y, scene.render.resolution_x, 4).astype(np.float64)


def set_view(scene, view):
    location, rotation = VIEWS[view]
    scene.camera.location, scene.camera.rotation_euler = location, rotation


def seam_masks(scene, obj, uv_name, islands, island_component, out, tag):
    """Per view: (distance to a UV-seam pixel, valid pixels) from a UV pass and a position pass (row 0 = bottom)."""
    size = islands.shape[0]
    pixels = scene.render.resolution_x
    step = VIEW_WIDTH / pixels
    masks = {}
    for view in VIEWS:
        set_view(scene, view)
        assign(obj, coordinate_material("UV pass", uv_name))
        uv = render(scene, os.path.join(out, "%s_%s_uv.exr" % (tag, view)), exr=True)
        assign(obj, position_material("Position pass"))
        pos = render(scene, os.path.join(out, "%s_%s_pos.exr" % (tag, view)), exr=True)
        opaque = uv[..., 3] > 0.999
        tx = np.clip((uv[..., 0] * size).astype(int), 0, size - 1)
        ty = np.clip((uv[..., 1] * size).astype(int), 0, size - 1)
        island = np.where(opaque, islands[ty, tx], -1)
        seam = np.zeros(opaque.shape, bool)
        jump = np.zeros(opaque.shape, bool)
        for axis in (0, 1):
            a = [slice(None), slice(None)]
            b = [slice(None), slice(None)]
            a[axis], b[axis] = slice(0, -1), slice(1, None)
            a, b = tuple(a), tuple(b)
            both = opaque[a] & opaque[b]
            far = np.linalg.norm(pos[a][..., :3] - pos[b][..., :3], axis=-1) > 6 * step
            defined = (island[a] >= 0) & (island[b] >= 0)
            different = (island[a] != island[b]) & defined
            # Islands of different mesh parts (Suzanne's eyes and head) meet at occlusion edges, not seams.
            apart = defined & (island_component[np.maximum(island[a], 0)] != island_component[np.maximum(island[b], 0)])
            s = both & ~far & different & ~apart
            j = both & (far | apart)
            seam[a] |= s
            seam[b] |= s
            jump[a] |= j
            jump[b] |= j
        excluded = ~opaque | jump | (island < 0)
        valid = blend_metrics.edge_distance(excluded, 2) > 2
        # Facing: cos(angle between the normal and the view) = pixel area / the surface area it covers.
        dx = np.zeros(pos.shape[:2] + (3,))
        dy = np.zeros(pos.shape[:2] + (3,))
        dx[:, :-1] = pos[:, 1:, :3] - pos[:, :-1, :3]
        dy[:-1] = pos[1:, :, :3] - pos[:-1, :, :3]
        area = np.linalg.norm(np.cross(dx, dy), axis=-1)
        facing = step * step / np.maximum(area, 1e-12)
        valid &= facing >= FACING
        masks[view] = (blend_metrics.edge_distance(seam, 4), valid)
        picture = np.zeros(opaque.shape + (3,))
        picture[valid] = 0.35
        picture[seam] = (1.0, 0.2, 0.2)
        picture[jump] = (0.2, 0.4, 1.0)
        write_png(os.path.join(out, "%s_%s_seams.png" % (tag, view)), picture)
    return masks


# -------------------------------------------------------------------------------------------- parts

def open_cylinder(segments=128, rows=32):
    """Radius 1 / (2 pi), height 1, axis +z, UV = (angle / 2 pi, z): an isometric unwrap (one seam along z)."""
    theta = 2 * np.pi * np.arange(segments) / segments
    z = np.arange(rows + 1) / rows
    radius = 1 / (2 * np.pi)
    positions = np.stack([np.tile(radius * np.cos(theta), rows + 1), np.tile(radius * np.sin(theta), rows + 1),
                          np.repeat(z, segments)], 1).astype(np.float32)
    i, j = np.meshgrid(np.arange(segments), np.arange(rows), indexing="xy")
    i, j = i.ravel(), j.ravel()
    vid = lambda a, b: b * segments + a % segments  # noqa: E731
    quad = [(i, j), (i + 1, j), (i + 1, j + 1), (i, j + 1)]
    triangles, uvs = [], []
    for tri in ((0, 1, 2), (0, 2, 3)):
        triangles.append(np.stack([vid(*quad[k]) for k in tri], 1))
        uvs.append(np.stack([np.stack([quad[k][0] / segments, quad[k][1] / rows], 1) for k in tri], 1))
    return dict(positions=positions, triangles=np.concatenate(triangles).astype(np.int32),
                corner_uvs=np.ascontiguousarray(np.concatenate(uvs), np.float32))


def grid_plane(cells, turn_degrees=0.0):
    """A flat square lattice of 1/cells, two triangles per cell (first edges along the lattice and its diagonal),
    turned by turn_degrees about the centre of the unit square and cut to the triangles that reach it;
    UV = position (the unit square is the image). positions, triangles, corner_uvs."""
    m = int(cells * 0.75) + 2 if turn_degrees else 0  # lattice cells beyond the square on each side
    count = cells + 2 * m
    ys, xs = np.mgrid[0:count + 1, 0:count + 1]
    p = np.stack([xs.ravel() - m, ys.ravel() - m], 1) / cells - 0.5
    a = math.radians(turn_degrees)
    c, s = math.cos(a), math.sin(a)
    q = np.stack([c * p[:, 0] - s * p[:, 1], s * p[:, 0] + c * p[:, 1]], 1) + 0.5
    i, j = np.meshgrid(np.arange(count), np.arange(count))
    i, j = i.ravel(), j.ravel()
    quad = [(i, j), (i + 1, j), (i + 1, j + 1), (i, j + 1)]
    triangles = np.concatenate([np.stack([quad[k][1] * (count + 1) + quad[k][0] for k in tri], 1)
                                for tri in ((0, 1, 2), (0, 2, 3))]).astype(np.int32)
    uvs = q[triangles]
    keep = ((uvs.max(1) >= 0.0) & (uvs.min(1) <= 1.0)).all(1)
    positions = np.concatenate([q, np.zeros((len(q), 1))], 1).astype(np.float32)
    return positions, triangles[keep], np.ascontiguousarray(uvs[keep], np.float32)


def part_plane(samples, args):
    size = args.size
    start = time.perf_counter()
    positions, tris, uvs = grid_plane(16)
    ctx = ts.RoundSynthesisContext(positions, tris, uvs, width=size, height=size, texels_per_unit=size)
    ctx_seconds = time.perf_counter() - start
    up = np.tile(np.float32([0, 1, 0]), (len(positions), 1))
    turned_plane = grid_plane(64, PLANE_TURN)
    turned_ctx = ts.RoundSynthesisContext(*turned_plane, width=size, height=size, texels_per_unit=size)
    turned_up = np.tile(np.float32([0, 1, 0]), (len(turned_plane[0]), 1))
    cylinder = open_cylinder(128, 128)
    cyl_ctx = ts.RoundSynthesisContext(cylinder["positions"], cylinder["triangles"], cylinder["corner_uvs"],
                                       width=size, height=size, texels_per_unit=size)
    along_axis = np.tile(np.float32([0, 0, 1]), (len(cylinder["positions"]), 1))
    print("\n== 1. plane vs 2D statistics: flat 1 x 1 plane, UV = position, field +y (= v), %d^2 texels, "
          "1 sample pixel per texel (context %.2f s) ==" % (size, ctx_seconds))
    print("surfaces: 'plane' = 16 x 16 square cells along the UV axes: triangle first edges (the rings' reference "
          "t0) at 0 and 45 deg from the field's normal, so every template angle falls on a ring bin (best case); "
          "'plane, mesh turned %g deg' = the same flat square, tessellated by a 64 x 64 lattice turned %g deg "
          "(template angles between bins, as on any real mesh); 'cylinder' = open cylinder of radius 1/(2 pi), "
          "isometric UV map, 128 x 128 square cells, field along the axis" % (PLANE_TURN, PLANE_TURN))
    seeds = [args.seed + k for k in range(PLANE_SEEDS)]
    print("hist: per-channel 32-bin L1 of normalised histograms vs the sample (0..2); p5 / p11: mean nearest "
          "5x5 / 11x11 patch distance to the sample (squared, per pixel, RGB summed; 600 patches; synthesis rows: "
          "mean and sd over seeds %s, 300 patches each)" % ", ".join(map(str, seeds)))
    print("%-8s %-28s %13s %17s %17s %7s" % ("sample", "image", "hist", "p5", "p11", "synth s"))
    results = {}

    def cell(values, digits):
        if len(values) == 1:
            return "%.*f" % (digits, values[0])
        return "%.*f+-%.*f" % (digits, np.mean(values), digits, np.std(values))
    for name, sample in samples:
        plane_images, cylinder_images, plane_seconds, cylinder_seconds = [], [], [], []
        turned_images, turned_seconds = [], []
        for seed in seeds:
            start = time.perf_counter()
            plane_images.append(ts.round_synthesize(ctx, sample, up, seed=seed)["image"])
            plane_seconds.append(time.perf_counter() - start)
            start = time.perf_counter()
            turned_images.append(ts.round_synthesize(turned_ctx, sample, turned_up, seed=seed)["image"])
            turned_seconds.append(time.perf_counter() - start)
            start = time.perf_counter()
            cylinder_images.append(ts.round_synthesize(cyl_ctx, sample, along_axis, seed=seed)["image"])
            cylinder_seconds.append(time.perf_counter() - start)
        results[name] = plane_images[0]
        write_png(os.path.join(args.out, "plane_%s.png" % name), plane_images[0])
        write_png(os.path.join(args.out, "cylinder_%s.png" % name), cylinder_images[0])
        write_png(os.path.join(args.out, "plane_turned_mesh_%s.png" % name), turned_images[0])
        shuffled = shuffled_blocks(sample, 8, np.random.default_rng(args.seed))
        shuffled4 = shuffled_blocks(sample, 4, np.random.default_rng(args.seed))
        write_png(os.path.join(args.out, "plane_%s_shuffled8.png" % name), shuffled)
        rows = [("own (halves / leave-1-out)", None, None),
                ("round synthesis, plane", plane_images, plane_seconds),
                ("round, plane, mesh turned %g" % PLANE_TURN, turned_images, turned_seconds),
                ("round, cylinder R 0.16", cylinder_images, cylinder_seconds),
                ("tiled sample (copy)", [tiled(sample, size, size)], None),
                ("shuffled 8x8 blocks", [shuffled], None),
                ("shuffled 4x4 blocks", [shuffled4], None),
                ("4x4 box-blurred sample", [box_blurred(sample)], None)]
        for label, images, seconds in rows:
            if images is None:
                hist = [own_histogram_distance(sample)]
                p5 = [nearest_patch(sample, sample, 5, 600, np.random.default_rng(args.seed), leave_one_out=True)]
                p11 = [nearest_patch(sample, sample, 11, 600, np.random.default_rng(args.seed), leave_one_out=True)]
            else:
                count = 600 if len(images) == 1 else 300
                hist = [histogram_distance(img, sample) for img in images]
                p5 = [nearest_patch(img, sample, 5, count, np.random.default_rng(args.seed)) for img in images]
                p11 = [nearest_patch(img, sample, 11, count, np.random.default_rng(args.seed)) for img in images]
            print("%-8s %-28s %13s %17s %17s %7s" % (name, label, cell(hist, 3), cell(p5, 5), cell(p11, 5),
                                                     "%.2f" % np.mean(seconds) if seconds else ""), flush=True)
    return results


def part_seam(samples, args):
    reset()
    size = args.size
    obj = build_mesh("monkey", 2, calc_uvs=False)
    obj.name = "Suzanne"
    uv_name = "Smart45"
    # Smart UV Project's default angle (66 degrees) folds some islands of Suzanne onto themselves: the
    # round context refuses overlapping UVs. Report it, then use 45 degrees.
    smart_uv(obj, 66, size, "Smart66")
    m66 = mesh_arrays(obj)
    try:
        context(m66, size, texel_density(m66, size))
        refused66 = "accepted"
    except ValueError as e:
        refused66 = "refused: %s" % e
    uv_seconds = smart_uv(obj, 45, size, uv_name)
    m = mesh_arrays(obj)
    density = texel_density(m, size)
    islands, texels = island_map(m, size)
    start = time.perf_counter()
    ctx = context(m, size, density)
    ctx_seconds = time.perf_counter() - start
    field = projected_z(m)
    print("\n== 2. UV seams in renders: Suzanne (subdivision 2, %d triangles), Smart UV Project 45 deg (%.2f s): %d "
          "islands, %d texels covered of %d^2; %.1f texels (= sample pixels) per unit; context %.2f s =="
          % (len(m["triangles"]), uv_seconds, texels["num_islands"], len(texels["texel"]), size, density,
             ctx_seconds))
    print("Smart UV Project at its default 66 deg: %d texels covered twice; round context %s"
          % (ts.sample_texels(m66["positions"], m66["triangles"], m66["corner_uvs"], size, size)
             ["num_overlapping_texels"], refused66))
    scene = setup_render(args.render)
    masks = seam_masks(scene, obj, uv_name, islands, texels["island_component"], args.out, "seam")
    for view, (distance, valid) in masks.items():
        print("  %s view: %d seam pixels (<= 1 px), %d interior pixels (>= 3 px)"
              % (view, int(((distance <= 1) & valid).sum()), int(((distance >= 3) & valid).sum())))
    print("ratio = mean |grad L| within 1 px of a UV seam / from 3 px on (1.00 = no seam)")
    print("hist = colour-histogram distance of the covered texels to the sample (as in 1; the sample's own value "
          "is in 1)")
    print("%-8s %-16s %7s %7s %7s %7s %8s %7s" % ("sample", "texture", *VIEWS, "mean", "synth s", "hist"))
    # Control, seamless by construction: wavy stripes of world x (period 9 sample pixels) written per texel
    # from the texel's 3D position (gutter texels: their source's), rendered the same way.
    control = np.zeros((size * size, 3), np.float32)
    p = texels["position"].astype(np.float64)
    wave = 0.5 + 0.5 * np.sin(2 * np.pi * (p[:, 0] + 0.03 * np.sin(9 * p[:, 2])) * density / 9.0)
    colour = np.stack([0.3 + 0.45 * wave, 0.2 + 0.3 * wave, 0.1 + 0.15 * wave], 1)
    control[texels["texel"]] = colour
    control[texels["gutter_texel"]] = colour[texels["gutter_source"]]
    control = control.reshape(size, size, 3)
    write_png(os.path.join(args.out, "seam_control_texture.png"), control)
    assign(obj, image_material("control", control, uv_name))
    ratios = []
    for view in VIEWS:
        set_view(scene, view)
        rgba = render(scene, os.path.join(args.out, "seam_control_%s.png" % view))
        distance, valid = masks[view]
        ratios.append(blend_metrics.seam_ratio(blend_metrics.gradient_magnitude(luminance(rgba)), distance, valid))
    print("%-8s %-16s %s %7.3f" % ("control", "3D stripes baked", " ".join("%7.3f" % r for r in ratios),
                                   np.mean(ratios)))
    synthesized = {}
    for name, sample in samples:
        start = time.perf_counter()
        out = ts.round_synthesize(ctx, sample, field, seed=args.seed)
        seconds = time.perf_counter() - start
        synthesized[name] = out
        write_png(os.path.join(args.out, "seam_%s_texture.png" % name), out["image"])
        for key, label, image in (("round", "round synthesis", out["image"]),
                                  ("tiled", "tiled via UVs", tiled(sample, size, size))):
            assign(obj, image_material("%s %s" % (name, key), image, uv_name))
            ratios = []
            for view in VIEWS:
                set_view(scene, view)
                rgba = render(scene, os.path.join(args.out, "seam_%s_%s_%s.png" % (name, key, view)))
                grad = blend_metrics.gradient_magnitude(luminance(rgba))
                distance, valid = masks[view]
                ratios.append(blend_metrics.seam_ratio(grad, distance, valid))
            hist = histogram_distance(image[out["mask"] == 1], sample)
            print("%-8s %-16s %s %7.3f %8s %7.3f" % (name, label, " ".join("%7.3f" % r for r in ratios),
                                                     np.mean(ratios), "%.2f" % seconds if key == "round" else "",
                                                     hist), flush=True)
    return obj, m, ctx, synthesized, scene, uv_name


def field_error(image, mask, islands, texels, m, directions, radius=7):
    """Per texel of image: grain-vs-field error (degrees) and validity (window of one island, all covered)."""
    size = image.shape[0]
    grain, coherence = grain_orientation(image)
    # Field in texel coordinates per covered texel.
    tri = texels["triangle"]
    bary = texels["barycentric"].astype(np.float64)
    d = directions[m["triangles"][tri]].astype(np.float64)  # (N, 3, 3)
    w = np.stack([1 - bary[:, 0] - bary[:, 1], bary[:, 0], bary[:, 1]], 1)
    field = (w[:, :, None] * d).sum(1)
    jac, e1, e2 = uv_jacobians.triangle_jacobians(m["positions"][m["triangles"]],
                                                  m["corner_uvs"].astype(np.float64) * size)
    local = np.stack([(field * e1[tri]).sum(1), (field * e2[tri]).sum(1)], 1)
    mapped = np.einsum("nij,nj->ni", jac[tri], local)
    angle = np.full(size * size, np.nan)
    angle[texels["texel"]] = np.arctan2(mapped[:, 1], mapped[:, 0])
    angle = angle.reshape(size, size)
    covered = np.zeros(size * size, bool)
    covered[texels["texel"]] = True
    covered = covered.reshape(size, size) & (mask == 1)
    # One island and all covered in the (2 radius + 1)^2 window: separable min / max (exact for a square).
    mn, mx = np.where(covered, islands, -1).astype(np.int64), np.where(covered, islands, -1).astype(np.int64)
    for axis in (0, 1):
        a, b = mn.copy(), mx.copy()
        for shift in range(1, radius + 1):
            for s in (shift, -shift):
                a = np.minimum(a, np.roll(mn, s, axis))
                b = np.maximum(b, np.roll(mx, s, axis))
        mn, mx = a, b
    valid = (mn == mx) & (mn >= 0) & np.isfinite(angle)
    valid[:radius] = valid[-radius:] = False
    valid[:, :radius] = valid[:, -radius:] = False
    error = angle_error_degrees(grain, np.nan_to_num(angle))
    return error, valid, coherence


def summary(error, valid, coherence):
    e = error[valid]
    return "%7.1f %7.1f %7.1f %8.2f %8d" % (np.median(e), np.percentile(e, 75), 100 * np.mean(e <= 10),
                                           coherence[valid].mean(), valid.sum())


def part_field(samples, args, plane_results):
    size = args.size
    field_samples = [(n, s) for n, s in samples if n in FIELD_SAMPLES]
    if not field_samples:
        print("\n== 3. field following: no anisotropic sample given (%s) ==" % ", ".join(FIELD_SAMPLES))
        return
    print("\n== 3. field following: grain orientation (structure tensor) vs the field mapped into the image ==")
    print("error = angle between the grain and the field in texel space (deg); goal: median <= 10")
    print("%-8s %-10s %-34s %7s %7s %7s %8s %8s" % ("sample", "mesh", "synthesis field / measured against", "median",
                                                    "p75", "%<=10", "coher.", "texels"))
    for name, sample in field_samples:
        # Floors: the sample itself and the plane result, both against +y.
        g, c = grain_orientation(sample)
        valid = np.zeros(g.shape, bool)
        valid[7:-7, 7:-7] = True
        print("%-8s %-10s %-34s %s" % (name, "2D", "the sample itself / +y", summary(
            angle_error_degrees(g, np.pi / 2), valid, c)))
        if name in plane_results:
            g, c = grain_orientation(plane_results[name])
            valid = np.zeros(g.shape, bool)
            valid[7:-7, 7:-7] = True
            print("%-8s %-10s %-34s %s" % (name, "plane", "+y / +y",
                                            summary(angle_error_degrees(g, np.pi / 2), valid, c)))
    meshes = []
    reset()
    torus = build_mesh("torus", 0, major_segments=128, minor_segments=48, major_radius=1.0, minor_radius=0.4)
    torus.name = "Torus"
    smart_uv(torus, 66, size, "Smart")
    tm = mesh_arrays(torus)
    meshes.append(("torus", torus, tm, torus_rings(tm), "Smart"))
    # Suzanne as in part 2, rebuilt.
    suzanne = build_mesh("monkey", 2, calc_uvs=False)
    suzanne.name = "Suzanne"
    smart_uv(suzanne, 45, size, "Smart45")
    sm = mesh_arrays(suzanne)
    meshes.append(("suzanne", suzanne, sm, projected_z(sm), "Smart45"))
    scene = setup_render(args.render)
    rng = np.random.default_rng(args.seed)
    for mesh_name, obj, m, field, uv_name in meshes:
        density = texel_density(m, size)
        islands, texels = island_map(m, size)
        ctx = context(m, size, density)
        for other in meshes:
            other[1].hide_render = other[1] is not obj
        rnd = random_field(m, rng)
        for name, sample in field_samples:
            runs = (("field", "field", field, (("field", field),)),
                    ("turned", "field turned 90", turned(field, m), (("field", field), ("turned", turned(field, m)))),
                    ("random", "random per vertex", rnd, (("field", field), ("random", rnd))))
            for key, label, directions, against in runs:
                out = ts.round_synthesize(ctx, sample, directions, seed=args.seed)
                tag = "field_%s_%s_%s" % (mesh_name, name, key)
                write_png(os.path.join(args.out, tag + "_texture.png"), out["image"])
                for what, reference in against:
                    error, valid, coherence = field_error(out["image"], out["mask"], islands, texels, m, reference)
                    print("%-8s %-10s %-34s %s" % (name, mesh_name, "%s / %s" % (label, what),
                                                    summary(error, valid, coherence)), flush=True)
                    if what == "field":
                        write_png(os.path.join(args.out, tag + "_error.png"), error_picture(error, valid))
                if key == "field":
                    assign(obj, image_material(tag, out["image"], uv_name))
                    for view in (("top", "front") if mesh_name == "torus" else ("front", "side")):
                        set_view(scene, view)
                        render(scene, os.path.join(args.out, "%s_%s.png" % (tag, view)))


def peak_rss_mb():
    """VmHWM: the peak resident set of this process image. (ru_maxrss is not used: across fork + exec Linux
    carries the parent's peak into it, here Blender's.)"""
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmHWM:"):
                return float(line.split()[1]) / 1024.0
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def perf_worker(args):
    """Runs in a fresh python: context, synthesis, re-synthesis; prints one JSON line."""
    data = np.load(args.perf_worker)
    m = {k: data[k] for k in data.files}
    name, sample = load_sample(args.perf_sample)
    result = dict(points=0, density=float(m["density"]))
    result["base_mb"] = peak_rss_mb()
    start = time.perf_counter()
    size = int(args.perf_size)
    ctx = ts.RoundSynthesisContext(m["positions"], m["triangles"], m["corner_uvs"], width=size, height=size,
                                   texels_per_unit=float(m["density"]))
    result["context_s"] = time.perf_counter() - start
    result["context_stats"] = {k: v for k, v in ctx.stats.items()}
    result["points"] = ctx.num_points
    start, cpu = time.perf_counter(), time.process_time()
    out = ts.round_synthesize(ctx, sample, m["field"], seed=args.seed)
    result["synth_s"] = time.perf_counter() - start
    result["synth_cpu_s"] = time.process_time() - cpu
    result["synth_levels_s"] = [level["seconds"] for level in out["stats"]["levels"]]
    result["synth_estimated_bytes"] = out["stats"]["estimated_bytes"]
    if args.out:
        write_png(os.path.join(args.out, "perf_texture_%d.png" % size), out["image"])
    del out
    start = time.perf_counter()
    ts.round_synthesize(ctx, sample, m["field2"], seed=args.seed + 1)
    result["resynth_s"] = time.perf_counter() - start
    result["peak_mb"] = peak_rss_mb()
    result["ru_maxrss_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    result["sample"] = "%s %dx%d" % (name, sample.shape[1], sample.shape[0])
    print("PERF " + json.dumps(result), flush=True)


def part_perf(args):
    reset()
    sizes = [int(v) for v in str(args.perf_size).split(",")]
    start = time.perf_counter()
    obj = build_mesh("monkey", 3, calc_uvs=False)
    build_seconds = time.perf_counter() - start
    uv_seconds = smart_uv(obj, 45, sizes[0], "Smart45")
    start = time.perf_counter()
    m = mesh_arrays(obj)
    read_seconds = time.perf_counter() - start
    field = projected_z(m)
    # The Python Blender embeds (its sys.executable may be a shim of another Python without numpy).
    python = os.environ.get("TEXSYNTH_PYTHON") or ("/usr/bin/python3.11" if os.path.exists("/usr/bin/python3.11")
                                                   else shutil.which("python3.11") or sys.executable)
    print("\n== 4. time and memory: Suzanne subdivision 3 (%d vertices, %d triangles), Smart UV Project 45 deg, one "
          "sample pixel per texel; each size in a fresh %s (2 cores), sample %s =="
          % (len(m["positions"]), len(m["triangles"]), python, args.perf_sample))
    print("Blender side (not in the figures): subdivide %.2f s, Smart UV Project %.2f s, foreach_get reads %.2f s"
          % (build_seconds, uv_seconds, read_seconds))
    print("load average before: %.2f %.2f %.2f (1, 5, 15 min)" % os.getloadavg())
    results = []
    for size in sizes:
        path = os.path.join(args.out, "perf_mesh_%d.npz" % size)
        np.savez(path, positions=m["positions"], triangles=m["triangles"], corner_uvs=m["corner_uvs"], field=field,
                 field2=turned(field, m), density=np.float64(texel_density(m, size)))
        command = [python, os.path.abspath(__file__), "--perf-worker", path, "--perf-size", str(size),
                   "--perf-sample", args.perf_sample, "--seed", str(args.seed), "--out", args.out]
        run = subprocess.run(command, capture_output=True, text=True)
        lines = [l for l in run.stdout.splitlines() if l.startswith("PERF ")]
        if run.returncode or not lines:
            print("worker at %d^2 failed (%d): %s" % (size, run.returncode, run.stderr[-2000:]))
            continue
        results.append((size, json.loads(lines[0][5:])))
    if not results:
        return

    def column(f):
        return " ".join("%14s" % f(r) for _, r in results)
    print("%-46s %s %8s" % ("figure", " ".join("%14s" % ("%d^2" % size) for size, _ in results), "goal"))
    rows = [("texels per world unit", lambda r: "%.1f" % r["density"], ""),
            ("surface samples (finest texels)", lambda r: "%d" % r["points"], "~700k"),
            ("context s", lambda r: "%.2f" % r["context_s"], ""),
            ("  points / rings / order s", lambda r: "%.2f/%.2f/%.2f" % (
                r["context_stats"]["seconds_points"], r["context_stats"]["seconds_rings"],
                r["context_stats"]["seconds_order"]), ""),
            ("synthesis s", lambda r: "%.2f" % r["synth_s"], ""),
            ("  levels fine..coarse s", lambda r: "/".join("%.2f" % v for v in r["synth_levels_s"]), ""),
            ("  synthesis CPU s (all threads)", lambda r: "%.2f" % r["synth_cpu_s"], ""),
            ("context + synthesis s", lambda r: "%.2f" % (r["context_s"] + r["synth_s"]), "<= 20"),
            ("re-synthesis, field turned 90 deg, s", lambda r: "%.2f" % r["resynth_s"], "<= 5"),
            ("peak RSS MB (VmHWM of the worker)", lambda r: "%.0f" % r["peak_mb"], "<= 1500"),
            ("  of which before the context (python+numpy+module)", lambda r: "%.0f" % r["base_mb"], ""),
            ("  ru_maxrss (includes Blender's, inherited)", lambda r: "%.0f" % r["ru_maxrss_mb"], ""),
            ("estimated MB (context / synthesis)", lambda r: "%.0f/%.0f" % (
                r["context_stats"]["estimated_bytes"] / 1e6, r["synth_estimated_bytes"] / 1e6), ""),
            ("context_bytes MB", lambda r: "%.0f" % (r["context_stats"]["context_bytes"] / 1e6), "")]
    for label, f, goal in rows:
        print("%-46s %s %8s" % (label, column(f), goal))
    print(PAPER)


def parse_args():
    parser = argparse.ArgumentParser(prog="bench_round_quality")
    parser.add_argument("--sample", action="append", help="PNG path or name in blend_samples/ or 'stripes'; repeatable")
    parser.add_argument("--size", type=int, default=512, help="image target of parts 1-3")
    parser.add_argument("--render", type=int, default=512, help="render width and height (px)")
    parser.add_argument("--perf-size", default="1024,1200", help="comma-separated image sizes of part 4")
    parser.add_argument("--perf-sample", default="bricks")
    parser.add_argument("--out", default="/tmp/round_bench")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--parts", default="plane,seam,field,perf")
    parser.add_argument("--perf-worker", help=argparse.SUPPRESS)
    argv = sys.argv[sys.argv.index("--") + 1:] if (bpy is not None and "--" in sys.argv) else \
        (sys.argv[1:] if bpy is None else [])
    return parser.parse_args(argv)


def main():
    args = parse_args()
    if args.perf_worker:
        perf_worker(args)
        return
    os.makedirs(args.out, exist_ok=True)
    samples = [load_sample(s) for s in (args.sample or SAMPLES)]
    for name, sample in samples:
        write_png(os.path.join(args.out, "sample_%s.png" % name), sample)
    parts = args.parts.split(",")
    start = time.perf_counter()
    print("bench_round_quality: samples %s; size %d; seed %d; out %s"
          % (", ".join("%s %dx%d" % (n, s.shape[1], s.shape[0]) for n, s in samples), args.size, args.seed, args.out))
    plane_results = part_plane(samples, args) if "plane" in parts else {}
    if "seam" in parts:
        part_seam(samples, args)
    if "field" in parts:
        part_field(samples, args, plane_results)
    if "perf" in parts:
        part_perf(args)
    print("\nbench_round_quality: %.0f s; pictures in %s" % (time.perf_counter() - start, args.out))


if __name__ == "__main__":
    main()

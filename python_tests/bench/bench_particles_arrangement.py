# SPDX-License-Identifier: GPL-3.0-or-later
"""Texture particles (issue 15, "Quality, measured"): is the sample's arrangement reproduced on the surface?
Not a test: prints figures and leaves pictures. No Blender needed.

  PYTHONPATH=addon /usr/bin/python3.11 python_tests/bench/bench_particles_arrangement.py \\
      [--samples grid,pebbles,leaves] [--parts plane,turned,sphere] [--out out/particles_arrangement] [--seed 1]

Samples are made here (numpy, fixed seeds): `grid` 20 px squares 8 px apart in x, 12 in y (an exact
lattice); `pebbles` a jittered hexagonal lattice of ellipses of random size and orientation, plus small red
berries scattered at random (a second class); `leaves` elongated ellipses turned 30 degrees in staggered rows
(oriented boxes). Each is analysed by particle_analysis, then placed by place_particles:
- plane: a 3 x 3 world-unit plane (jittered grid of triangles), sample width 1 world unit, field +y;
- turned: the same plane with the field turned 30 degrees (the whole arrangement must turn with it);
- sphere: radius 1, sample width 0.5, field along the meridians; centres with |z| < 0.6 only.
Statistics (particle_metrics.py), per class, in local charts (the tangent plane of each particle, x along the
field's sample x, in sample pixels at scale 1): per quadrant, the (dx, dy) box gaps to the nearest neighbour
(2-D histogram total-variation distance on 2 px bins, KS D of the dx and dy marginals), the nearest-neighbour
centre distance (KS D) and the particle density (per pixel^2, ratio to the sample's). Each distance between
the sample and the synthesis is printed beside the same distance between the sample's left and right halves
(the sampling noise of the sample itself: the goal is to stay within it).
Pictures (PNG, row 0 = top): the sample, and the plane synthesis composited (sprites over the tiled filled
background) over a 2 x 2-sample window.
"""
import argparse
import math
import os
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, HERE)
sys.path.insert(0, os.environ.get("TEXSYNTH_MODULE_DIR", os.path.join(ROOT, "addon")))
import texsynth_native as tn  # noqa: E402

import particle_metrics as pm  # noqa: E402
from bench_round_quality import write_png  # noqa: E402

SAND, PEBBLE, BERRY = np.array([0.78, 0.70, 0.52]), np.array([0.35, 0.33, 0.36]), np.array([0.70, 0.12, 0.08])


# ------------------------------------------------------------------------------------------- samples

def _ellipses(shape, centres, halves, angles):
    """Boolean (H, W) mask (row 0 = bottom) of filled ellipses."""
    h, w = shape
    mask = np.zeros(shape, bool)
    ys, xs = np.mgrid[0:h, 0:w] + 0.5
    for (cx, cy), (a, b), t in zip(centres, halves, angles):
        r = int(math.ceil(max(a, b))) + 1
        x0, x1 = max(0, int(cx) - r), min(w, int(cx) + r + 1)
        y0, y1 = max(0, int(cy) - r), min(h, int(cy) + r + 1)
        if x0 >= x1 or y0 >= y1:
            continue
        dx, dy = xs[y0:y1, x0:x1] - cx, ys[y0:y1, x0:x1] - cy
        u = dx * math.cos(t) + dy * math.sin(t)
        v = -dx * math.sin(t) + dy * math.cos(t)
        mask[y0:y1, x0:x1] |= (u / a) ** 2 + (v / b) ** 2 <= 1.0
    return mask


def _ground(rng, shape, colour, amount=0.06):
    return np.clip(colour[None, None, :] * (1.0 + amount * rng.standard_normal(shape + (1,))), 0, 1)


def grid_sample():
    rng = np.random.default_rng(11)
    size = 448
    img = _ground(rng, (size, size), SAND)
    ys, xs = np.mgrid[0:size, 0:size]
    inside = ((xs % 28) < 20) & ((ys % 32) < 20)
    img[inside] = _ground(rng, (size, size), PEBBLE)[inside]
    return img.astype(np.float32), 2


def pebbles_sample():
    rng = np.random.default_rng(12)
    size, step = 384, 30.0
    centres, halves, angles = [], [], []
    for row in range(int(size / (step * 0.866)) + 2):
        for col in range(int(size / step) + 2):
            cx = col * step + (step / 2 if row % 2 else 0.0) + rng.uniform(-3, 3)
            cy = row * step * 0.866 + rng.uniform(-3, 3)
            a = rng.uniform(8, 12)
            centres.append((cx, cy))
            halves.append((a, a * rng.uniform(0.6, 0.9)))
            angles.append(rng.uniform(0, math.pi))
    img = _ground(rng, (size, size), SAND)
    pebbles = _ellipses((size, size), centres, halves, angles)
    img[pebbles] = _ground(rng, (size, size), PEBBLE, 0.1)[pebbles]
    spots = rng.uniform(0, size, (150, 2))
    spot_mask = _ellipses((size, size), spots, [(4.5, 4.5)] * len(spots), [0.0] * len(spots)) & ~pebbles
    img[spot_mask] = BERRY
    return img.astype(np.float32), 3


def leaves_sample():
    rng = np.random.default_rng(13)
    size = 320
    t = math.radians(30)
    axis, perp = np.array([math.cos(t), math.sin(t)]), np.array([-math.sin(t), math.cos(t)])
    centres = []
    for row in range(-20, 21):
        for col in range(-20, 21):
            c = np.array([size / 2, size / 2]) + axis * (col * 34.0 + (17.0 if row % 2 else 0.0)) + perp * row * 16.0
            if -20 < c[0] < size + 20 and -20 < c[1] < size + 20:
                centres.append(c + rng.uniform(-1.5, 1.5, 2))
    img = _ground(rng, (size, size), SAND)
    leaves = _ellipses((size, size), centres, [(14.0, 5.0)] * len(centres), [t] * len(centres))
    img[leaves] = _ground(rng, (size, size), np.array([0.25, 0.45, 0.15]), 0.1)[leaves]
    return img.astype(np.float32), 2


SAMPLES = {"grid": grid_sample, "pebbles": pebbles_sample, "leaves": leaves_sample}


# ------------------------------------------------------------------------------------------- meshes

def plane_mesh(side=3.0, cells=150, jitter=0.3, seed=5):
    rng = np.random.default_rng(seed)
    ys, xs = np.mgrid[0:cells + 1, 0:cells + 1].astype(np.float64)
    inner = (xs > 0) & (xs < cells) & (ys > 0) & (ys < cells)
    xs[inner] += jitter * (rng.random(inner.sum()) - 0.5)
    ys[inner] += jitter * (rng.random(inner.sum()) - 0.5)
    pos = np.zeros(((cells + 1) ** 2, 3), np.float32)
    pos[:, 0], pos[:, 1] = xs.ravel() * side / cells, ys.ravel() * side / cells
    v = np.arange((cells + 1) ** 2).reshape(cells + 1, cells + 1)
    a, b, c, d = v[:-1, :-1].ravel(), v[:-1, 1:].ravel(), v[1:, 1:].ravel(), v[1:, :-1].ravel()
    tris = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)]).astype(np.int32)
    return pos, tris


def sphere_mesh(radius=1.0, rings=160, segments=320):
    theta = np.linspace(0, math.pi, rings + 1)[1:-1]
    phi = np.linspace(0, 2 * math.pi, segments, endpoint=False)
    t, p = np.meshgrid(theta, phi, indexing="ij")
    pos = np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], -1).reshape(-1, 3) * radius
    pos = np.concatenate([[[0, 0, radius]], pos, [[0, 0, -radius]]]).astype(np.float32)
    n_inner = len(theta)
    idx = np.arange(n_inner * segments).reshape(n_inner, segments) + 1
    nxt = np.roll(idx, -1, axis=1)
    tris = [np.stack([np.zeros(segments, int), idx[0], nxt[0]], 1)]
    for r in range(n_inner - 1):
        tris.append(np.stack([idx[r], idx[r + 1], nxt[r + 1]], 1))
        tris.append(np.stack([idx[r], nxt[r + 1], nxt[r]], 1))
    last = len(pos) - 1
    tris.append(np.stack([np.full(segments, last), nxt[-1], idx[-1]], 1))
    return pos, np.concatenate(tris).astype(np.int32)


def meridian_field(pos):
    """'Up' along the meridians towards +z (the poles are the field's singularities)."""
    p = pos.astype(np.float64)
    n = p / np.linalg.norm(p, axis=1, keepdims=True)
    up = np.array([0.0, 0.0, 1.0]) - n * n[:, 2:3]
    up[np.linalg.norm(up, axis=1) < 1e-9] = (1.0, 0.0, 0.0)
    return up.astype(np.float32)


# ------------------------------------------------------------------------------------------- statistics

def sample_boxes(a, region=None, margin=None):
    """Boxes of the analysed sample (or of a region x0, x1 of it): centres inside the region at least `margin`
    px (per class) from its edges and from the sample's may be centres."""
    parts = a.particles
    c, half, cls = parts["box_centre"], parts["box_half"], parts["class"]
    x0, x1 = region if region is not None else (0.0, float(a.width))
    m = np.array([margin[k] for k in cls])
    keep = (c[:, 0] >= x0) & (c[:, 0] < x1)
    ok = parts["complete"] & (c[:, 0] >= x0 + m) & (c[:, 0] <= x1 - m) & (c[:, 1] >= m) & (c[:, 1] <= a.height - m)
    boxes = pm.Boxes.planar(c, parts["box_angle"], half, cls, ok)
    return boxes.subset(np.flatnonzero(keep))


def placed_boxes(a, placed, base_pixel, centre_ok):
    """Boxes of placed particles in their tangent charts (sample pixels at scale 1)."""
    parts = a.particles
    sprite = placed["sprite"]
    n = placed["normal"].astype(np.float64)
    axis = placed["sprite_axis"].astype(np.float64)
    phi = placed["angle"].astype(np.float64) - parts["box_angle"][sprite]
    # the sprite axis is the field's sample x turned by (theta - theta_s): turn it back
    x_axes = axis * np.cos(phi)[:, None] - np.cross(n, axis) * np.sin(phi)[:, None]
    halves = parts["box_half"][sprite] * (placed["pixel_size"] / base_pixel)[:, None]
    return pm.Boxes(placed["position"], n, x_axes, placed["angle"], halves, placed["class"], centre_ok, base_pixel)


def class_radius(a, factor=2.5):
    """Neighbour search radius per class (chart px): 2.5 x the median box diagonal. With factor 1.2: the margin
    that keeps a centre's nearest neighbours in every quadrant inside the measured region."""
    parts, out = a.particles, {}
    for k in range(a.num_classes):
        h = parts["box_half"][parts["class"] == k]
        out[k] = factor * float(np.median(2 * np.linalg.norm(h, axis=1))) if len(h) else 0.0
    return out


def fmt(x):
    return "   -  " if x is None or (isinstance(x, float) and math.isnan(x)) else "%6.3f" % x


def report(name, a, sample_gaps, halves_cmp, synth_gaps, density_ratio, counts):
    print("  class %d: sample centres %d, synthesized centres %d, density synth/sample %.3f"
          % (name, counts[0], counts[1], density_ratio))
    cmp = pm.compare(sample_gaps, synth_gaps)
    print("    %-24s %8s %8s" % ("", "synth", "halves"))
    for key in ("hist", "ks_dx", "ks_dy", "ks_nearest"):
        print("    %-24s %8s %8s" % (key, fmt(cmp[key]), fmt(halves_cmp[key])))
    for q in range(4):
        print("    q%d hist / ks dx / ks dy  %s %s %s   halves %s %s %s   (n %d / %d)"
              % (q, fmt(cmp[q]["hist"]), fmt(cmp[q]["ks_dx"]), fmt(cmp[q]["ks_dy"]), fmt(halves_cmp[q]["hist"]),
                 fmt(halves_cmp[q]["ks_dx"]), fmt(halves_cmp[q]["ks_dy"]), *cmp[q]["n"]))
    med_s = np.median(sample_gaps[:, 1:3], 0) if len(sample_gaps) else [np.nan] * 2
    med_t = np.median(synth_gaps[:, 1:3], 0) if len(synth_gaps) else [np.nan] * 2
    print("    median gap (dx, dy): sample (%.2f, %.2f), synth (%.2f, %.2f)" % (*med_s, *med_t))
    return cmp


# ------------------------------------------------------------------------------------------- picture

def composite(a, sample, placed, base_pixel, window, res):
    """(res, res, 3): sprites over the tiled filled background, world window (x0, y0, size) of the plane."""
    x0, y0, size = window
    bg = a.background[..., :3]
    ys, xs = np.mgrid[0:res, 0:res] + 0.5
    wx, wy = x0 + xs * size / res, y0 + ys * size / res
    out = bg[(wy / base_pixel).astype(int) % a.height, (wx / base_pixel).astype(int) % a.width].copy()
    parts = a.particles
    sprites = {}
    for i in range(len(placed["class"])):
        p = placed["position"][i]
        ps = float(placed["pixel_size"][i])
        s = int(placed["sprite"][i])
        if s not in sprites:
            sprites[s] = tn.particle_sprite(a, sample, s)
        sp = sprites[s]
        rgba, (ox, oy) = sp["rgba"], sp["origin"]
        reach = ps * (max(rgba.shape[:2]) + 2)
        c0, c1 = int((p[0] - reach - x0) * res / size), int((p[0] + reach - x0) * res / size) + 1
        r0, r1 = int((p[1] - reach - y0) * res / size), int((p[1] + reach - y0) * res / size) + 1
        c0, c1, r0, r1 = max(c0, 0), min(c1, res), max(r0, 0), min(r1, res)
        if c0 >= c1 or r0 >= r1:
            continue
        ax = placed["sprite_axis"][i].astype(np.float64)
        n = placed["normal"][i].astype(np.float64)
        bx = np.cross(n, ax)
        dx, dy = wx[r0:r1, c0:c1] - p[0], wy[r0:r1, c0:c1] - p[1]
        cx, cy = parts["box_centre"][s]
        u = (dx * ax[0] + dy * ax[1]) / ps + cx - ox
        v = (dx * bx[0] + dy * bx[1]) / ps + cy - oy
        ui, vi = np.floor(u).astype(int), np.floor(v).astype(int)
        inside = (ui >= 0) & (vi >= 0) & (ui < rgba.shape[1]) & (vi < rgba.shape[0])
        texel = rgba[np.clip(vi, 0, rgba.shape[0] - 1), np.clip(ui, 0, rgba.shape[1] - 1)]
        alpha = np.where(inside, texel[..., 3], 0.0)[..., None]
        out[r0:r1, c0:c1] = texel[..., :3] * alpha + out[r0:r1, c0:c1] * (1 - alpha)
    return out


# ------------------------------------------------------------------------------------------- runs

def halves_comparison(a, radius, margin, cls):
    left = pm.neighbour_gaps(sample_boxes(a, (0.0, a.width / 2), margin), cls, radius[cls])
    right = pm.neighbour_gaps(sample_boxes(a, (a.width / 2, float(a.width)), margin), cls, radius[cls])
    return pm.compare(left, right)


def run(name, part, args):
    sample, k = SAMPLES[name]()
    a = tn.particle_analysis(sample, classes=k, seed=0)
    radius, margin = class_radius(a), class_radius(a, 1.2)
    classes = [c for c in range(a.num_classes) if c != a.background_class and a.classes["has_complete"][c]]
    if part in ("plane", "turned"):
        pos, tris = plane_mesh()
        side, width_world = 3.0, 1.0
        turn = math.radians(30 if part == "turned" else 0)
        field = np.tile(np.array([-math.sin(turn), math.cos(turn), 0.0], np.float32), (len(pos), 1))
    else:
        pos, tris = sphere_mesh()
        side, width_world = None, 0.5
        field = meridian_field(pos)
    base_pixel = width_world / a.width
    mesh = tn.surface_walk_mesh(pos, tris)
    t0 = time.perf_counter()
    placed = tn.place_particles(a, mesh, field, sample_world_width=width_world, seed=args.seed)
    seconds = time.perf_counter() - t0
    print("%s / %s: %dx%d sample, %d particles analysed (%s), %d triangles, %d placed in %.3f s"
          % (name, part, a.width, a.height, len(a.particles), ", ".join("class %d: %d" % (c, a.classes["particles"][c])
                                                                       for c in classes),
             len(tris), len(placed["class"]), seconds))
    p = placed["position"]
    for cls in classes:
        m = margin[cls] * base_pixel
        if side is not None:
            ok = (p[:, 0] > m) & (p[:, 0] < side - m) & (p[:, 1] > m) & (p[:, 1] < side - m)
            area = (side - 2 * m) ** 2 / base_pixel ** 2
        else:
            ok = np.abs(p[:, 2]) < 0.6
            area = 4 * math.pi * 0.6 / base_pixel ** 2  # sphere zone |z| < 0.6: 2 pi R h, h = 1.2
        ok &= placed["class"] == cls
        synth = placed_boxes(a, placed, base_pixel, ok)
        synth_gaps = pm.neighbour_gaps(synth, cls, radius[cls])
        sample_gaps = pm.neighbour_gaps(sample_boxes(a, None, margin), cls, radius[cls])
        density = ok.sum() / area / (a.classes["particles"][cls] / (a.width * a.height))
        report(cls, a, sample_gaps, halves_comparison(a, radius, margin, cls), synth_gaps, density,
               (len(np.unique(sample_gaps[:, 4])), ok.sum()))
        if part == "turned" and ok.any():
            x = synth.x_axes[ok]
            turn_deg = np.degrees(np.arctan2(x[:, 1], x[:, 0]))
            print("    chart x axis angle: median %.2f deg (field turned %.0f)" % (np.median(turn_deg), math.degrees(turn)))
    if part == "plane" and args.out:
        os.makedirs(args.out, exist_ok=True)
        write_png(os.path.join(args.out, "%s_sample.png" % name), sample)
        res = 2 * a.width
        pic = composite(a, sample, placed, base_pixel, (0.5, 0.5, 2 * width_world), res)
        write_png(os.path.join(args.out, "%s_plane.png" % name), pic)
    print()


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--samples", default="grid,pebbles,leaves")
    parser.add_argument("--parts", default="plane,turned,sphere")
    parser.add_argument("--out", default=os.path.join(ROOT, "out", "particles_arrangement"))
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()
    for name in args.samples.split(","):
        for part in args.parts.split(","):
            run(name, part, args)


if __name__ == "__main__":
    main()

# SPDX-License-Identifier: GPL-3.0-or-later
"""Texture particles on the corpus' element-like samples (issue 30, "Use the benchmark corpus"). Not a test:
prints one row per sample (and, with --markdown, the same table in markdown) and writes a contact sheet.
No Blender needed; the sheet's JPEG is written by ImageMagick's `convert` or, failing that, `blender -b` (PNG
only without either).

  PYTHONPATH=addon /usr/bin/python3.11 python_tests/bench/bench_particles_corpus.py \\
      [--samples a,b,...] [--out out/pcorpus] [--sheet docs/benchmarks/sheet_particles_elements.jpg] [--markdown]

Samples: out/corpus/samples/<name>.png (out/corpus/manifest.json; python_tests/bench/corpus.py makes them):
every `element` sample plus the element-like near-regular and stochastic ones in SAMPLES. Each is analysed at
the add-on's defaults (addon/core/settings.py: particle_classes 4, particle_blur 1, min_area automatic,
background = the largest class, touching auto, tileable off with the repeat found at the border, seed 0), the
PNG as loaded (row 0 = top, read by the analysis as the bottom: a mirror image, which changes no statistic here). Placement: place_particles at its
defaults (seed --seed) on a flat square plane of 3 x 3 sample widths (150 x 150 jittered quads, as
bench_particles_arrangement.py's plane_mesh), field +y, sample_world_width = sample width / 512 (corpus_results'
--scale); on a plane every figure below is in sample pixels, so the scale changes none of them.

Per sample:
- particles: the analysed particles (all classes but the background), classes: the non-background classes;
- density: placed particles with centres in the plane's central 2 x 2 sample widths per px^2 / the sample's
  particles (complete or cut by its border) per px^2; share err: max over classes of |share among the placed -
  share among the sample's particles|; plane density: the same ratio over the whole plane (edges included:
  how the placement's global count control sees it);
- NN: KS D of the nearest-neighbour centre distance (all non-background classes pooled, particle_metrics), the
  sample's particles vs the placed ones (centres 1.2 median box diagonals inside the plane), beside the
  same D between the centres in the sample's left and right halves (its own noise; their neighbours are
  looked for in the whole sample, so that 64 px samples have centres in each half). On a sample analysed as
  tileable every particle is a centre and its neighbours are looked for in the sample tiled 3 x 3 (the texture
  it repeats into); on one that is not, the complete particles 1.2 median box diagonals inside its border
  are the centres, their neighbours in the sample only; "within" when synth D <=
  halves D ("few" when a half has fewer than MIN_HALF_CENTRES centres: the noise figure is then coarse and
  large, and "within" says little);
- typical: the share of placed particles whose box area (sprite area x the placed pixel size^2) and box aspect
  (long / short half extent) lie within the 10th-90th percentiles of the sample's complete particles, widened by
  touching_metrics' AREA_SLACK (x/ 1.25) and ASPECT_SLACK (x/ 1.1) (particles_corpus_metrics.typical_range).
  The placed sprites are the sample's own particles, so this is not a ground-truth "whole element" figure: it
  says how much of what is placed has the size and shape of the sample's typical particle, rather than of a
  fragment or a merged blob;
- seconds of the analysis and of the placement (wall clock, one run).
Summary: the share of samples with density within +-15 % (goal >= 90 %) and NN within noise (goal >= 75 %).
Sheet: per sample, the sample (1 sample width) and the plane's central 2 x 2 sample widths composited (sprites
over the tiled filled background, bench_particles_arrangement.composite) at the same pixel scale, labelled.
"""
import argparse
import json
import math
import os
import shutil
import subprocess
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, HERE)
sys.path.insert(0, os.environ.get("TEXSYNTH_MODULE_DIR", os.path.join(ROOT, "addon")))
import texsynth_native as tn  # noqa: E402

import particle_metrics as pm  # noqa: E402
import particles_corpus_metrics as pcm  # noqa: E402
from bench_particles_arrangement import composite, placed_boxes, plane_mesh, sample_boxes  # noqa: E402
from bench_round_quality import write_png  # noqa: E402
from sheet_text import draw_text  # noqa: E402

CORPUS = os.path.join(ROOT, "out", "corpus")
# element-like samples of other categories (issue 30's list), after every `element` one
SAMPLES = ("flagstones", "stone_wall", "dried_mud", "paving_bricks", "gravel")
SCALE_PX = 512.0          # sample pixels per world unit (corpus_results.md: --scale = width / 512)
PLANE_SAMPLES = 3         # plane side in sample widths
DENSITY_TOLERANCE = 0.15
MIN_HALF_CENTRES = 10     # fewer centres in a half: its noise figure is too coarse to judge by ("few")
JPEG_QUALITY = 70
CELL = 128                # contact sheet: one sample width in px


def defaults():
    """The add-on's particle defaults, read from addon/core/settings.py."""
    sys.path.insert(0, os.path.join(ROOT, "addon"))
    from core.settings import Settings
    s = Settings()
    return {"classes": int(s.particle_classes), "blur": float(s.particle_blur), "min_area": int(s.particle_min_area),
            "background": int(s.particle_background_class),
            "touching": {"AUTO": "auto", "ON": True, "OFF": False}[s.particle_touching],
            "tileable": bool(s.tileable), "seed": int(s.seed), "detect_repeat": True}


def analyse(sample, d):
    kwargs = dict(classes=d["classes"], blur=d["blur"], tileable=d["tileable"], seed=d["seed"])
    if d["detect_repeat"] and not d["tileable"] and pcm.looks_tileable(sample):
        kwargs.update(tileable=True, wrap_blur=False)  # the add-on's rule (particles/core.analysis_tileable)
    if d["min_area"]:
        kwargs["min_area"] = d["min_area"]
    if d["background"] >= 0:
        kwargs["background"] = d["background"]
    if d["touching"]:
        kwargs["touching"] = d["touching"]  # True or "auto"
    return tn.particle_analysis(sample, **kwargs)


def pooled(boxes):
    boxes.classes = np.zeros(len(boxes), int)
    return boxes


def pooled_radius(a, factor):
    h = a.particles["box_half"]
    return factor * float(np.median(2 * np.linalg.norm(h, axis=1))) if len(h) else 0.0


def periodic_boxes(a):
    """The pooled boxes of a sample analysed as tileable, tiled 3 x 3 (pcm.periodic_copies): every particle is
    a centre and its neighbours across the border count. Without this a small sample keeps only the few
    particles 1.2 box diagonals inside its border as centres (cobbles: 14 of 51), and those see no neighbour
    across it."""
    parts = a.particles
    centres, angles, halves, original = pcm.periodic_copies(parts["box_centre"], parts["box_angle"],
                                                            parts["box_half"], a.width, a.height)
    return pm.Boxes.planar(centres, angles, halves, np.zeros(len(centres), int), original)


def sample_centres(a, margins):
    """The sample's pooled boxes and which may be centres: periodic on a tileable analysis, else the complete
    particles 1.2 box diagonals inside the border, their neighbours in the sample only."""
    return periodic_boxes(a) if a.tileable else pooled(sample_boxes(a, None, margins))


def half_centres(a, margins, which):
    """The sample's pooled boxes with centres only in its left (0) or right (1) half; their neighbours are
    found in the whole sample (small samples leave no centre in a half cut out on its own)."""
    boxes = sample_centres(a, margins)
    x = boxes.positions[:, 0]
    boxes.centre_ok = boxes.centre_ok & ((x < a.width / 2) if which == 0 else (x >= a.width / 2))
    return boxes


def nearest(boxes, radius):
    return pm.nearest_distances(pm.neighbour_gaps(boxes, 0, radius))


def run(name, info, d, args):
    path = os.path.join(CORPUS, "samples", name + ".png")
    sample = np.ascontiguousarray(np.asarray(tn.load_image(path), np.float32)[..., :3])
    h, w = sample.shape[:2]
    start = time.perf_counter()
    a = analyse(sample, d)
    t_analysis = time.perf_counter() - start
    parts = a.particles
    classes = [c for c in range(a.num_classes) if c != a.background_class and a.classes["particles"][c] > 0]
    width_world = w / SCALE_PX
    base_pixel = 1.0 / SCALE_PX
    side = PLANE_SAMPLES * width_world
    pos, tris = plane_mesh(side=side, cells=150)
    field = np.tile(np.array([0.0, 1.0, 0.0], np.float32), (len(pos), 1))
    mesh = tn.surface_walk_mesh(pos, tris)
    start = time.perf_counter()
    placed = tn.place_particles(a, mesh, field, sample_world_width=width_world, seed=args.seed)
    t_place = time.perf_counter() - start
    p = placed["position"]
    n_sample = int(sum(a.classes["particles"][c] for c in classes))

    # density over the central 2 x 2 sample widths (away from the plane's edges)
    lo, hi = 0.5 * width_world, (PLANE_SAMPLES - 0.5) * width_world
    window = (p[:, 0] >= lo) & (p[:, 0] < hi) & (p[:, 1] >= lo) & (p[:, 1] < hi)
    density = pcm.density_ratio(int(window.sum()), ((hi - lo) / base_pixel) ** 2, n_sample, w * h)
    density_plane = pcm.density_ratio(len(p), (side / base_pixel) ** 2, n_sample, w * h)
    share_err = pcm.worst_share_error(placed["class"][window], a.classes["particles"], classes)

    # nearest neighbours, all classes pooled
    radius, margin = pooled_radius(a, 2.5), pooled_radius(a, 1.2)
    margins = {k: margin for k in range(a.num_classes)}
    ks_synth = ks_halves = float("nan")
    if len(parts["class"]):
        s_nn = nearest(sample_centres(a, margins), radius)
        m = margin * base_pixel
        ok = (p[:, 0] > m) & (p[:, 0] < side - m) & (p[:, 1] > m) & (p[:, 1] < side - m)
        t_nn = nearest(pooled(placed_boxes(a, placed, base_pixel, ok)), radius)
        left, right = (nearest(half_centres(a, margins, side_), radius) for side_ in (0, 1))
        ks_synth, ks_halves = pm.ks(s_nn, t_nn)[0], pm.ks(left, right)[0]
        n_nn = (len(s_nn), len(t_nn), len(left), len(right))
    else:
        n_nn = (0, 0, 0, 0)
    within = bool(ks_synth <= ks_halves) if ks_synth == ks_synth and ks_halves == ks_halves else False
    reliable = min(n_nn[2], n_nn[3]) >= MIN_HALF_CENTRES

    # typical elements
    complete = np.asarray(parts["complete"], bool)
    rng = pcm.typical_range(np.asarray(parts["area"], np.float64)[complete], pcm.aspect_of(parts["box_half"][complete]))
    sprite = placed["sprite"][window]
    scale2 = (placed["pixel_size"][window] / base_pixel) ** 2
    typical = pcm.in_range_share(parts["area"][sprite] * scale2, pcm.aspect_of(parts["box_half"][sprite]), rng)

    row = {"name": name, "category": info["category"], "size": "%dx%d" % (w, h), "particles": n_sample,
           "complete": int(complete.sum()), "classes": len(classes), "placed_window": int(window.sum()),
           "placed": int(len(placed["class"])), "density": density, "density_plane": density_plane,
           "share_err": share_err, "ks_synth": ks_synth, "ks_halves": ks_halves, "nn_within": within,
           "nn_reliable": reliable, "nn_counts": n_nn,
           "typical": typical, "typical_range": rng, "seconds_analysis": t_analysis, "seconds_placement": t_place}
    print("%-14s %-12s %9s: %4d particles (%d complete), %d classes; placed %5d (window %5d); density %.3f "
          "(plane %.3f), share err %.3f; NN KS %.3f vs halves %.3f (%s; n %s); typical %.2f; analysis %.3f s, "
          "placement %.3f s"
          % (name, info["category"], row["size"], n_sample, row["complete"], len(classes), row["placed"],
             row["placed_window"], density, density_plane, share_err, ks_synth, ks_halves,
             "within" if within else "OUT", "/".join(str(v) for v in n_nn), typical, t_analysis, t_place), flush=True)

    pictures = None
    if args.sheet:
        res = int(round(2 * CELL))
        pic = composite(a, sample, placed, base_pixel, (lo, lo, hi - lo), res)
        pictures = (sample, pic)
    return row, pictures


# ------------------------------------------------------------------------------------------- sheet

def resize(img, size):
    """Nearest-pixel (down) or box (up) resample of (H, W, 3) to size x size (row 0 = top)."""
    h, w = img.shape[:2]
    if h >= size and w >= size:  # box filter
        ys = (np.arange(size + 1) * h / size).astype(int)
        xs = (np.arange(size + 1) * w / size).astype(int)
        cs = np.cumsum(np.cumsum(np.pad(img, ((1, 0), (1, 0), (0, 0))), 0), 1)
        y0, y1, x0, x1 = ys[:-1], np.maximum(ys[1:], ys[:-1] + 1), xs[:-1], np.maximum(xs[1:], xs[:-1] + 1)
        total = cs[y1][:, x1] - cs[y0][:, x1] - cs[y1][:, x0] + cs[y0][:, x0]
        return total / ((y1 - y0)[:, None] * (x1 - x0)[None, :])[..., None]
    yi = (np.arange(size) * h / size).astype(int)
    xi = (np.arange(size) * w / size).astype(int)
    return img[yi][:, xi]


def sheet(rows, pictures, path, png_dir):
    label, gap, per_row = 10, 4, 2
    cell_w = CELL + 2 * CELL + gap
    n_rows = int(math.ceil(len(rows) / per_row))
    canvas = np.full((n_rows * (label + 2 * CELL + gap), per_row * (cell_w + gap), 3), 0.12)
    for i, (row, (sample, pic)) in enumerate(zip(rows, pictures)):
        y = (i // per_row) * (label + 2 * CELL + gap)
        x = (i % per_row) * (cell_w + gap)
        text = "%s d%.2f nn%.2f/%.2f t%.2f" % (row["name"], row["density"], row["ks_synth"], row["ks_halves"],
                                                row["typical"])
        draw_text(canvas, text, y + 1, x + 1, (1.0, 1.0, 1.0) if row["nn_within"] else (1.0, 0.6, 0.5))
        sample_cell = resize(np.asarray(sample, np.float64), CELL)
        canvas[y + label:y + label + CELL, x:x + CELL] = sample_cell
        canvas[y + label:y + label + 2 * CELL, x + CELL + gap:x + CELL + gap + 2 * CELL] = np.asarray(pic)[..., :3]
    os.makedirs(png_dir, exist_ok=True)
    png = os.path.join(png_dir, "sheet_particles_elements.png")
    write_png(png, canvas[::-1])  # write_png flips row 0 = bottom; the canvas is row 0 = top
    if path:
        os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
        if not to_jpeg(png, path):
            print("no JPEG writer (ImageMagick convert or blender): the sheet is only %s" % png)
            return png
        return path
    return png


def to_jpeg(png, path, quality=JPEG_QUALITY):
    """PNG -> JPEG with ImageMagick's convert, else Blender (-b); True when written."""
    if shutil.which("convert"):
        done = subprocess.run(["convert", png, "-strip", "-quality", str(quality), path], capture_output=True)
        if done.returncode == 0 and os.path.isfile(path):
            return True
    blender = shutil.which("blender")
    if blender:
        script = ("import bpy\nimg = bpy.data.images.load(%r)\ns = bpy.context.scene.render.image_settings\n"
                  "s.file_format = 'JPEG'\ns.quality = %d\ns.color_mode = 'RGB'\n"
                  "img.save_render(%r, scene=bpy.context.scene)\n" % (png, quality, path))
        done = subprocess.run([blender, "-b", "--factory-startup", "--python-exit-code", "1", "--python-expr", script],
                              capture_output=True)
        return done.returncode == 0 and os.path.isfile(path)
    return False


# ------------------------------------------------------------------------------------------- main

def fmt(x, digits=3):
    return "–" if x is None or (isinstance(x, float) and math.isnan(x)) else ("%." + str(digits) + "f") % x


def markdown(rows):
    out = ["| sample | category | size | particles (complete) | classes | placed (window) | density "
           "| plane density | share err | NN KS synth | NN KS halves | NN within | typical | analysis s "
           "| placement s |",
           "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        out.append("| %s | %s | %s | %d (%d) | %d | %d (%d) | %s | %s | %s | %s | %s | %s | %s | %s | %s |"
                   % (r["name"], r["category"], r["size"], r["particles"], r["complete"], r["classes"], r["placed"],
                      r["placed_window"], fmt(r["density"], 2), fmt(r["density_plane"], 2), fmt(r["share_err"]),
                      fmt(r["ks_synth"]), fmt(r["ks_halves"]),
                      ("yes" if r["nn_within"] else "**no**") + ("" if r["nn_reliable"] else " (few)"),
                      fmt(r["typical"], 2),
                      fmt(r["seconds_analysis"]), fmt(r["seconds_placement"])))
    return "\n".join(out)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--samples", default="", help="comma-separated names (default: elements + SAMPLES)")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--out", default=os.path.join(ROOT, "out", "pcorpus"))
    parser.add_argument("--sheet", default=os.path.join(ROOT, "docs", "benchmarks", "sheet_particles_elements.jpg"),
                        help="contact sheet JPEG ('' for none)")
    parser.add_argument("--markdown", action="store_true")
    parser.add_argument("--tileable", choices=("default", "manifest", "off"), default="default",
                        help="default: the add-on's (Tileable off, a repeat found at the border analysed as "
                        "tileable with the blur clamped); manifest: Tileable as the manifest says; off: no "
                        "repeat found (the add-on before it looked)")
    parser.add_argument("--touching", choices=("default", "on", "off"), default="default",
                        help="Touching Elements: the add-on's default (auto), always or never")
    args = parser.parse_args()
    with open(os.path.join(CORPUS, "manifest.json")) as handle:
        manifest = {s["name"]: s for s in json.load(handle)["samples"]}
    if args.samples:
        names = args.samples.split(",")
    else:
        names = [n for n, s in manifest.items() if s["category"] == "element"] + list(SAMPLES)
    d = defaults()
    if args.touching != "default":
        d["touching"] = args.touching == "on"
    print("module %s; defaults %s; scale %g px per world unit; plane %d x %d sample widths; seed %d"
          % (tn.__file__, d, SCALE_PX, PLANE_SAMPLES, PLANE_SAMPLES, args.seed))
    rows, pictures = [], []
    for name in names:
        dd = dict(d, tileable=bool(manifest[name]["tileable"])) if args.tileable == "manifest" else d
        if args.tileable == "off":
            dd = dict(d, detect_repeat=False)
        row, pic = run(name, manifest[name], dd, args)
        rows.append(row)
        pictures.append(pic)
    dens = pcm.goal_share([r["density"] for r in rows], lambda v: abs(v - 1.0) <= DENSITY_TOLERANCE)
    nn = pcm.goal_share([1.0 if r["nn_within"] else 0.0 for r in rows], lambda v: v > 0.5)
    sure = [r for r in rows if r["nn_reliable"]]
    nn_sure = pcm.goal_share([1.0 if r["nn_within"] else 0.0 for r in sure], lambda v: v > 0.5)
    print("summary: %d samples; density within +-%d %%: %.0f %% (goal >= 90 %%); NN within the sample's noise: "
          "%.0f %% (goal >= 75 %%; %.0f %% of the %d with >= %d centres per half); median typical share %.2f"
          % (len(rows), DENSITY_TOLERANCE * 100, dens * 100, nn * 100, nn_sure * 100, len(sure), MIN_HALF_CENTRES,
             float(np.nanmedian([r["typical"] for r in rows]))))
    os.makedirs(args.out, exist_ok=True)
    with open(os.path.join(args.out, "particles_corpus.json"), "w") as handle:
        json.dump(rows, handle, indent=1, default=float)
    if args.markdown:
        print(markdown(rows))
    if args.sheet:
        print("sheet: %s" % sheet(rows, pictures, args.sheet, args.out))


if __name__ == "__main__":
    main()

# SPDX-License-Identifier: GPL-3.0-or-later
"""Vector-field patches (Chen, Liu & Dong; texsynth_native.synthesize_patches) measured against issue 14's
quality goals on a flat plane. Not a test: prints figures and leaves pictures. No Blender needed.

  PYTHONPATH=addon /usr/bin/python3.11 python_tests/bench/bench_patches_quality.py \\
      [--parts structure,progressive,seams,exponent,levels,perf] [--size 256] [--out out/patches_quality] [--seed 1]
      [--perf-sizes 256,512,1024] [--perf-optimisation 256,512]

Every synthesis is "render-equivalent": the 1 x 1 plane z = 0 (normal +z), a res x res lattice of samples at
the texel centres, spacing h = 1 / res (one exemplar pixel per output pixel at scale 1), so the output IS an
image (row 0 = bottom). Field = the texture's +y; sample +x = up x normal, so field +y gives an unmirrored
rearrangement of the sample. Exemplar: patch_exemplar(sample, patch_size=32, seed), sample row 0 = bottom.
Modes: sampling (centre_spacing 0.5) and optimisation (centre_spacing 0.25, robust_exponent 0.8).

1. structure: bricks; structure-tensor grain (bench_round_quality.grain_orientation: luminance, central
   differences, tensor smoothed by three 5-wide box passes) of the result against the field. The sample's own
   grain is not along its +y (brick courses run along x), so the expected grain = field angle + the sample's
   dominant grain offset from +y (dominant_grain: coherence-weighted doubled-angle mean). Figures: median and
   75th percentile of the per-pixel error (deg, 0..90), dominant-grain error of the whole image (const fields),
   mean coherence. Floor: the sample itself against its own dominant grain. Fields: constant +y, constant
   turned 30 deg, radial (x - 0.5, y - 0.5) (pixels within 0.08 of the singular centre left out), sine
   (1, 0.8 cos(2 pi 2 y)) (paper Fig. 8). Goal: median <= 3 deg for the constant field.
2. progressive: constant field; density 1 on the left half, 2 on the right (features half as large), and
   magnitude_scale with |v| = 1 left, 0.5 right. dominant_period along y (perpendicular to the courses: the
   first autocorrelation peak of the column profiles, averaged over columns, parabolic refinement) of each
   half (|x - 0.5| >= 0.1 only). Goal: period left / right = frequency right / left = 2 +- 10 %.
3. seams: constant field; patch boundaries = where `source` jumps between 4-neighbours (source_seams:
   |delta source - expected step| > 0.5 px, both pixels marked); ratio = mean |grad L| within 1 px of a boundary
   / from 3 px on (blend_metrics.seam_ratio). Goal <= 1.10. Baseline: sampling with tolerance 1e9 (random
   patches; the band match is ignored) must fail it.
4. exponent: optimisation on bricks, robust_exponent 0.8 (Kwatra's r) vs 1.2 (the paper's literal weights):
   final stats energy (sum of d^r: not comparable across r), p11 = mean nearest 11 x 11 patch distance to the
   sample (bench_round_quality.nearest_patch: the common yardstick), seam ratio.
5. perf: each size in a fresh process: a plane of 2 x 224^2 = 100,352 triangles, res^2 samples: seconds per
   stage, synthesis total (goal <= 0.3 s at 256^2, sampling), peak RSS (ru_maxrss) and its growth over the
   process before synthesis, per sample; exemplar preprocessing of bricks upscaled to 256^2 (goal <= 5 s).
6. levels: optimisation with 1, 2 and 3 resolution levels on bricks, moss and bark: detail, seams, p11 and
   (bricks) the median grain error, with the seconds the coarser levels took.
7. corpus (only when asked: --parts corpus): sampling against optimisation, detail and p11, on --corpus samples
   (blend_samples/, else TEXSYNTH_CORPUS_SAMPLES, default out/corpus/samples).

Pictures (PNG, row 0 = top) go to --out: results, seam masks, orientation-error maps.
"""
import argparse
import json
import os
import resource
import subprocess
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.dirname(HERE))  # python_tests: addon_package
sys.path.insert(0, os.environ.get("TEXSYNTH_MODULE_DIR", os.path.join(ROOT, "addon")))
import texsynth_native as tn  # noqa: E402

import addon_package  # noqa: E402
import blend_metrics  # noqa: E402
from bench_round_quality import (angle_error_degrees, blur, error_picture, grain_orientation,  # noqa: E402
                                 load_sample, luminance, nearest_patch, write_png)

SPACING = {"sampling": 0.5, "optimisation": 0.3}
MODES = ("sampling", "optimisation")
PATCH_SIZE = 32
PERF_CELLS = 224  # 2 * 224^2 = 100,352 triangles


# ------------------------------------------------------------------------------------------- metrics

def dominant_grain(grain, coherence, valid=None):
    """The image-wide grain orientation (radians mod pi): coherence-weighted mean of the doubled angles."""
    if valid is None:
        valid = np.ones(grain.shape, bool)
    w = coherence[valid]
    return float(0.5 * np.arctan2((w * np.sin(2 * grain[valid])).sum(), (w * np.cos(2 * grain[valid])).sum())) \
        % np.pi


def grain(rgb):
    """bench_round_quality.grain_orientation of rgb pre-smoothed by two 3-wide box passes: its central
    differences turn sharp edges towards the axes (bricks turned 30 deg read 33.1 deg, 60 read 56.3); smoothed
    first, 30.1 and 58.9. Returns (grain angle mod pi, coherence)."""
    return grain_orientation(blur(np.asarray(rgb, np.float64), 3, 2))


def field_angle_error(rgb, field_angle, offset, valid):
    """Per pixel: angle (deg, 0..90) between the grain of rgb and field_angle + offset (radians); returns
    (error, coherence, the image's dominant grain over valid)."""
    grain_angle, coherence = grain(rgb)
    error = angle_error_degrees(grain_angle, np.asarray(field_angle) + offset)
    return error, coherence, dominant_grain(grain_angle, coherence, valid)


def source_seams(source, step_x=(1.0, 0.0), step_y=(0.0, 1.0), threshold=0.5):
    """(H, W) bool: pixels on a patch boundary. source (H, W, 2) exemplar coordinates (negative = uncovered);
    a 4-neighbour pair (along +x: column + 1, along +y: row + 1) is a boundary when |source difference -
    expected step| > threshold px; both pixels of the pair are marked. Pairs touching uncovered pixels are not."""
    src = np.asarray(source, np.float64)
    covered = (src >= 0).all(axis=2)
    mask = np.zeros(covered.shape, bool)
    jump_x = np.hypot(*np.moveaxis(src[:, 1:] - src[:, :-1] - np.asarray(step_x), 2, 0)) > threshold
    jump_x &= covered[:, 1:] & covered[:, :-1]
    jump_y = np.hypot(*np.moveaxis(src[1:] - src[:-1] - np.asarray(step_y), 2, 0)) > threshold
    jump_y &= covered[1:] & covered[:-1]
    mask[:, 1:] |= jump_x
    mask[:, :-1] |= jump_x
    mask[1:] |= jump_y
    mask[:-1] |= jump_y
    return mask


def seam_figure(rgb, source, margin=2, **steps):
    """(seam ratio (blend_metrics.seam_ratio, boundary <= 1 px vs >= 3 px), share of pixels on a boundary, mask)."""
    mask = source_seams(source, **steps)
    lum = luminance(rgb)
    valid = (np.asarray(source) >= 0).all(axis=2)
    valid[:margin] = valid[-margin:] = False
    valid[:, :margin] = valid[:, -margin:] = False
    distance = blend_metrics.edge_distance(mask, 4)
    ratio = blend_metrics.seam_ratio(blend_metrics.gradient_magnitude(lum), distance, valid)
    return ratio, float(mask[valid].mean()), mask


def resample(sample, source):
    """The sample read (bilinear) at continuous exemplar coordinates source (H, W, 2) (x, y; pixel centres at
    +0.5, row 0 = bottom): the result re-rendered as hard cuts between patches, no cross-fade. Uncovered
    (negative) coordinates give 0."""
    src = np.asarray(source, np.float64)
    out = bilinear(sample, src[..., 1] - 0.5, src[..., 0] - 0.5)
    out[(src < 0).any(axis=2)] = 0
    return out


def detail(rgb, reference):
    """Mean |grad L| of rgb (1 px border left out) / that of reference (blend_metrics.mean_gradient): < 1 =
    washed out."""
    def mean(image):
        lum = luminance(image)
        return blend_metrics.mean_gradient(blend_metrics.gradient_magnitude(lum), np.ones(lum.shape, bool))
    return mean(rgb) / mean(reference)


def dominant_period(image, axis=0, min_lag=2, min_peak=0.05):
    """Dominant period (px) of a 2D array along axis: the autocorrelation of each 1D profile along axis (mean
    removed, zero-padded, so no wrap-around, unbiased), averaged over the profiles and normalised by lag 0; after
    the first zero crossing and up to half the length, the first local maximum at least half as high as the
    highest one (the fundamental: a staggered brick wall repeats exactly every 2 courses, yet its courses are
    1 apart), refined by a parabola through it and its neighbours. NaN when there is no peak or the highest is
    below min_peak (no periodic structure)."""
    a = np.moveaxis(np.asarray(image, np.float64), axis, 0)
    a = a - a.mean(axis=0, keepdims=True)
    n = a.shape[0]
    spectrum = np.fft.rfft(a, n=2 * n, axis=0)
    corr = np.fft.irfft(spectrum * np.conj(spectrum), axis=0)[:n].mean(axis=1)
    corr /= np.maximum(corr[0], 1e-300)
    corr /= (n - np.arange(n)) / n  # unbiased: fewer products at long lags
    below = np.nonzero(corr[min_lag:] < 0)[0]
    if not len(below):
        return float("nan")
    start = min_lag + below[0]
    c = corr[:n // 2]
    peaks = [k for k in range(start + 1, len(c) - 1) if c[k] >= c[k - 1] and c[k] > c[k + 1]]
    if not peaks or max(c[k] for k in peaks) < min_peak:
        return float("nan")
    highest = max(c[k] for k in peaks)
    top = next(k for k in peaks if c[k] >= 0.5 * highest)  # the fundamental, not a multiple of it
    c0, c1, c2 = corr[top - 1], corr[top], corr[top + 1]
    bend = c0 - 2 * c1 + c2
    return float(top + (0.5 * (c0 - c2) / bend if bend < 0 else 0.0))


# ----------------------------------------------------------------------------------- plane and synthesis

def plane_mesh(cells):
    """The unit square z = 0 as cells x cells squares, two triangles each: (a, b, c) below the diagonal,
    (a, c, d) above it (a = lower left, counter-clockwise)."""
    ys, xs = np.mgrid[0:cells + 1, 0:cells + 1]
    pos = np.zeros(((cells + 1) ** 2, 3), np.float32)
    pos[:, 0] = xs.ravel() / cells
    pos[:, 1] = ys.ravel() / cells
    cy, cx = np.mgrid[0:cells, 0:cells]
    a = (cy * (cells + 1) + cx).ravel()
    b, c, d = a + 1, a + cells + 2, a + cells + 1
    tris = np.stack([np.stack([a, b, c], 1), np.stack([a, c, d], 1)], 1).reshape(-1, 3)
    return pos, np.ascontiguousarray(tris, np.int32)


def lattice(res, cells):
    """Samples at the texel centres of a res x res image on the plane of plane_mesh(cells), row 0 = bottom:
    positions (N, 3), triangles (N,), barycentrics (N, 2) (weights of the triangle's 2nd and 3rd vertex)."""
    jy, ix = np.mgrid[0:res, 0:res]
    px, py = (ix.ravel() + 0.5) / res, (jy.ravel() + 0.5) / res
    cx = np.minimum((px * cells).astype(np.int64), cells - 1)
    cy = np.minimum((py * cells).astype(np.int64), cells - 1)
    fx, fy = px * cells - cx, py * cells - cy
    upper = fy > fx
    tri = (cy * cells + cx) * 2 + upper
    bary = np.where(upper[:, None], np.stack([fx, fy - fx], 1), np.stack([fx - fy, fy], 1))
    positions = np.stack([px, py, np.zeros_like(px)], 1)
    return positions.astype(np.float32), tri.astype(np.int32), bary.astype(np.float32)


def field_directions(kind, x, y):
    """(N, 3) texture up at plane points (x, y) for a named field."""
    zero = np.zeros_like(x)
    if kind == "const":
        return np.stack([zero, zero + 1, zero], 1)
    if kind == "rot30":
        return np.stack([zero - np.sin(np.pi / 6), zero + np.cos(np.pi / 6), zero], 1)
    if kind == "radial":
        return np.stack([x - 0.5, y - 0.5, zero], 1)
    if kind == "sine":
        return np.stack([zero + 1, 0.8 * np.cos(2 * np.pi * 2 * y), zero], 1)
    raise ValueError(kind)


class Bench:
    """Caches exemplars, meshes and results; one synthesis = run(...)."""

    def __init__(self, args):
        self.args = args
        self.samples = {}
        self.exemplars = {}
        self.results = {}
        self.cells = 32

    def sample(self, name):
        if name not in self.samples:
            self.samples[name] = load_sample(name)[1]
        return self.samples[name]

    def exemplar(self, name):
        if name not in self.exemplars:
            start = time.perf_counter()
            self.exemplars[name] = tn.patch_exemplar(self.sample(name), patch_size=PATCH_SIZE, seed=self.args.seed)
            print("(exemplar %s %dx%d: %.2f s)" % ((name,) + self.sample(name).shape[1::-1]
                                                  + (time.perf_counter() - start,)), flush=True)
        return self.exemplars[name]

    def run(self, name, field, mode, res=None, density=None, magnitude=None, tag=None, spacing=None, **kw):
        """density / magnitude: (left, right) values on x < 0.5 / x > 0.5 (vertex sides); spacing: surface
        units per sample pixel at density 1 (default one sample's). Returns dict image (res, res, 3), source
        (res, res, 2), stats, seconds."""
        res = res or self.args.size
        spacing = spacing or 1.0 / res
        key = (name, field, mode, res, density, magnitude, spacing, tuple(sorted(kw.items())))
        if key in self.results:
            return self.results[key]
        pos, tris = plane_mesh(self.cells)
        dirs = field_directions(field, pos[:, 0].astype(np.float64), pos[:, 1].astype(np.float64))
        right = pos[:, 0] > 0.5
        if magnitude is not None:
            dirs = dirs / np.linalg.norm(dirs, axis=1, keepdims=True) * np.where(right, magnitude[1], magnitude[0])[:, None]
        dens = None if density is None else np.where(right, density[1], density[0]).astype(np.float32)
        field_obj = tn.patch_field(pos, tris, dirs.astype(np.float32), spacing=spacing, density=dens,
                                   magnitude_scale=magnitude is not None)
        P, tri, bary = lattice(res, self.cells)
        normals = np.tile(np.float32([0, 0, 1]), (len(P), 1))
        params = dict(mode=mode, seed=self.args.seed, centre_spacing=SPACING[mode])
        params.update(kw)
        start = time.perf_counter()
        r = tn.synthesize_patches(field_obj, self.exemplar(name), self.sample(name), P, normals, tri, bary, **params)
        out = dict(image=r["colour"].reshape(res, res, -1)[..., :3], source=r["source"].reshape(res, res, 2),
                   stats=r["stats"], seconds=time.perf_counter() - start)
        if tag:
            write_png(os.path.join(self.args.out, tag + ".png"), np.clip(out["image"], 0, 1))
        self.results[key] = out
        return out


def pixel_xy(res):
    """Plane coordinates of the texel centres, (res, res) each, row 0 = bottom."""
    jy, ix = np.mgrid[0:res, 0:res]
    return (ix + 0.5) / res, (jy + 0.5) / res


def margin_mask(shape, margin):
    valid = np.zeros(shape, bool)
    valid[margin:-margin, margin:-margin] = True
    return valid


# ------------------------------------------------------------------------------------------------- parts

def part_structure(bench):
    res = bench.args.size
    name = "bricks"
    sample = bench.sample(name)
    g, c = grain(sample)
    sv = margin_mask(g.shape, 8)
    offset = dominant_grain(g, c, sv) - np.pi / 2
    print("\n== 1. structure: grain (structure tensor) of the result vs field angle + the sample's grain offset; "
          "%s, %d^2 ==" % (name, res))
    print("sample's dominant grain %.1f deg from its +y (courses along x); error: per pixel (deg, 0..90), "
          "'dominant': error of the image-wide grain (constant fields); goal: median <= 3 (constant field)"
          % np.degrees(offset))
    print("per pixel from grain() (pre-smoothed); 'raw med': the same median from bench_round_quality's "
          "grain_orientation unsmoothed (sharper per pixel, but biased ~3 deg towards the axes at 30 deg)")
    print("%-14s %-13s %7s %7s %7s %7s %9s %7s %7s" % ("field", "mode", "median", "raw med", "p75", "%<=10",
                                                     "dominant", "coher.", "synth s"))
    error = angle_error_degrees(g, np.pi / 2 + offset)
    e = error[sv]
    raw = np.median(angle_error_degrees(grain_orientation(sample)[0], np.pi / 2 + offset)[sv])
    print("%-14s %-13s %7.1f %7.1f %7.1f %7.1f %9.1f %7.2f %7s" % ("(the sample)", "-", np.median(e), raw,
                                                                 np.percentile(e, 75), 100 * np.mean(e <= 10), 0.0,
                                                                 c[sv].mean(), ""))
    turned = turned_sample(sample, 30, 128)  # fits inside the 192^2 sample
    g, c = grain(turned)
    tv = margin_mask(g.shape, 8)
    e = angle_error_degrees(g, np.pi / 2 + offset + np.pi / 6)[tv]
    raw = np.median(angle_error_degrees(grain_orientation(turned)[0], np.pi / 2 + offset + np.pi / 6)[tv])
    print("%-14s %-13s %7.1f %7.1f %7.1f %7.1f %9.1f %7.2f %7s" % ("(sample tu.30)", "bilinear", np.median(e), raw,
                                                                 np.percentile(e, 75), 100 * np.mean(e <= 10),
                                                           angle_error_degrees(dominant_grain(g, c, tv),
                                                                               np.pi / 2 + offset + np.pi / 6),
                                                           c[tv].mean(), ""))
    write_png(os.path.join(bench.args.out, "structure_%s_sample_turned30.png" % name), turned)
    x, y = pixel_xy(res)
    for field in ("const", "rot30", "radial", "sine"):
        d = field_directions(field, x.ravel(), y.ravel())
        angle = np.arctan2(d[:, 1], d[:, 0]).reshape(res, res)
        valid = margin_mask((res, res), 8)
        if field == "radial":
            valid &= np.hypot(x - 0.5, y - 0.5) >= 0.08
        for mode in MODES:
            out = bench.run(name, field, mode, tag="structure_%s_%s_%s" % (name, field, mode))
            err, coh, dom = field_angle_error(out["image"], angle, offset, valid)
            e = err[valid]
            dominant = "%9.1f" % angle_error_degrees(dom, angle[0, 0] + offset) if field in ("const", "rot30") else \
                "%9s" % "-"
            raw = np.median(angle_error_degrees(grain_orientation(out["image"])[0], angle + offset)[valid])
            print("%-14s %-13s %7.1f %7.1f %7.1f %7.1f %s %7.2f %7.2f" % (
                field, mode, np.median(e), raw, np.percentile(e, 75), 100 * np.mean(e <= 10), dominant,
                coh[valid].mean(), out["seconds"]), flush=True)
            write_png(os.path.join(bench.args.out, "structure_%s_%s_%s_error.png" % (name, field, mode)),
                      error_picture(err, valid))


def part_progressive(bench):
    res = bench.args.size
    name = "bricks"
    sample = bench.sample(name)
    own = dominant_period(luminance(sample), axis=0)
    x, _ = pixel_xy(res)
    left, right = x[0] <= 0.4, x[0] >= 0.6
    print("\n== 2. progressive variation: dominant period along y (perpendicular to the courses), left half "
          "(x <= 0.4) vs right half (x >= 0.6); %s, %d^2 ==" % (name, res))
    print("sample's own period %.2f px; goal: left / right = 2 +- 10 %% (1.80..2.20)" % own)
    print("%-30s %-13s %8s %8s %8s %6s" % ("scale", "mode", "left px", "right px", "ratio", "goal"))
    # The add-on's law (surface_colour.patches.synthesize_patches): the sample is reduced by the largest
    # multiplier first, so the densest region shows one reduced-sample pixel per surface sample and the
    # rest is magnified; unreduced, density 2 asks each sample to show two pixels and bricks fall apart.
    core = addon_package.load("surface_colour.core")
    reduced, texels_per_unit = core.working_sample(sample, float(res), res / 2.0)
    bench.samples[name + "/2"] = reduced
    cases = (("density 1 | 2, add-on law", name + "/2", dict(density=(1.0, 2.0), spacing=1.0 / texels_per_unit)),
             ("density 1 | 2, unreduced", name, dict(density=(1.0, 2.0))),
             ("|v| 1 | 0.5 (magnitude_scale)", name, dict(magnitude=(1.0, 0.5))),
             ("none (control)", name, {}))
    for label, sample_name, kw in cases:
        for mode in MODES:
            kind = "density" if "density" in kw else "magnitude" if kw else "none"
            tag = "progressive_%s%s_%s" % (kind, "_reduced" if sample_name != name else "", mode)
            out = bench.run(sample_name, "const", mode, tag=tag, **kw)
            lum = luminance(out["image"])
            pl, pr = dominant_period(lum[:, left], 0), dominant_period(lum[:, right], 0)
            ratio = pl / pr
            goal = 1.0 if not kw else 2.0
            ok = "yes" if abs(ratio / goal - 1) <= 0.1 else "NO"
            print("%-30s %-13s %8.2f %8.2f %8.3f %6s" % (label, mode, pl, pr, ratio, ok), flush=True)


def part_seams(bench):
    res = bench.args.size
    print("\n== 3. seams: mean |grad L| within 1 px of a patch boundary / from 3 px on (boundaries from source "
          "jumps > 0.5 px); constant field, %d^2; goal <= 1.10 (< 0.90: the boundaries are blurred) ==" % res)
    print("ratio: the result; hard cut: the same source map re-read from the sample without the cross-fade "
          "(resample); detail: mean |grad L| / the sample's (< 1 = washed out); copy err: max |result - hard cut| "
          "from 5 px off any boundary (0 = source is exact)")
    print("%-8s %-26s %7s %9s %7s %9s %9s %7s" % ("sample", "synthesis", "ratio", "hard cut", "detail", "%boundary",
                                               "copy err", "synth s"))
    for name in ("bricks", "moss", "bark"):
        sample = bench.sample(name)
        runs = [("sampling", "sampling", {}), ("optimisation", "optimisation", {}),
                ("random patches (tol 1e9)", "sampling", dict(tolerance=1e9))]
        for label, mode, kw in runs:
            tag = "seams_%s_%s" % (name, "random" if kw else mode)
            out = bench.run(name, "const", mode, tag=tag, **kw)
            ratio, share, mask = seam_figure(out["image"], out["source"])
            hard = resample(sample, out["source"])
            hard_ratio = seam_figure(hard, out["source"])[0]
            far = (blend_metrics.edge_distance(mask, 5) > 5) & (out["source"] >= 0).all(axis=2)
            copy_err = np.abs(hard - out["image"])[far].max() if far.any() else float("nan")
            print("%-8s %-26s %7.3f %9.3f %7.3f %9.1f %9.5f %7.2f" % (name, label, ratio, hard_ratio,
                                                                     detail(out["image"], sample), 100 * share,
                                                                     copy_err, out["seconds"]), flush=True)
            overlay = np.clip(out["image"], 0, 1).copy()
            overlay[mask] = 0.5 * overlay[mask] + 0.5 * np.array([0.0, 1.0, 1.0])
            write_png(os.path.join(bench.args.out, tag + "_boundaries.png"), overlay)
            write_png(os.path.join(bench.args.out, tag + "_hardcut.png"), np.clip(hard, 0, 1))


def part_exponent(bench):
    res = bench.args.size
    name = "bricks"
    sample = bench.sample(name)
    print("\n== 4. robust exponent: optimisation on %s, %d^2 ==" % (name, res))
    print("energy = stats energy[-1] = sum of (d^2 + eps^2)^(r/2) (its scale depends on r); p11 = mean nearest "
          "11x11 patch distance to the sample (600 patches; lower = closer to the sample); seam ratio as in 3")
    print("%-28s %12s %10s %8s %7s %7s %s" % ("weights", "energy", "p11", "seams", "detail", "synth s",
                                              "changed per iteration"))
    own = nearest_patch(sample, sample, 11, 600, np.random.default_rng(bench.args.seed), leave_one_out=True)
    print("%-28s %12s %10.5f %8s %7s %7s" % ("(the sample, leave-1-out)", "-", own, "-", "1.000", ""))
    out = bench.run(name, "const", "sampling")
    print("%-28s %12s %10.5f %8.3f %7.3f %7.2f" % ("(sampling mode, reference)", "-", nearest_patch(
        out["image"], sample, 11, 600, np.random.default_rng(bench.args.seed)), seam_figure(out["image"], out["source"])[0],
        detail(out["image"], sample), out["seconds"]))
    for label, r in (("r 0.8 (Kwatra, default)", 0.8), ("r 1.2 (paper's |X-Z|^-0.8)", 1.2)):
        out = bench.run(name, "const", "optimisation", tag="exponent_%s_r%g" % (name, r), robust_exponent=r)
        p11 = nearest_patch(out["image"], sample, 11, 600, np.random.default_rng(bench.args.seed))
        ratio = seam_figure(out["image"], out["source"])[0]
        print("%-28s %12.1f %10.5f %8.3f %7.3f %7.2f %s" % (label, out["stats"]["energy"][-1], p11, ratio,
                                                           detail(out["image"], sample), out["seconds"],
                                                           " ".join("%.3f" % v for v in out["stats"]["changed"])), flush=True)


def part_levels(bench):
    res = bench.args.size
    print("\n== 6. multi-resolution optimisation: levels 1..3 (coarser levels: sample halved, step doubled); %d^2 ==" % res)
    print("detail, seams, p11 as in 3-4; grain: median structure error (raw, deg) on bricks, constant field; the "
          "sample's own p11 in brackets")
    print("%-8s %-7s %8s %8s %10s %7s %8s %7s" % ("sample", "levels", "detail", "seams", "p11", "grain", "coarse s",
                                                  "synth s"))
    for name in ("bricks", "moss", "bark"):
        sample = bench.sample(name)
        own = nearest_patch(sample, sample, 11, 600, np.random.default_rng(bench.args.seed), leave_one_out=True)
        for levels in (1, 2, 3):
            out = bench.run(name, "const", "optimisation", tag="levels_%s_%d" % (name, levels), levels=levels)
            p11 = nearest_patch(out["image"], sample, 11, 600, np.random.default_rng(bench.args.seed))
            grain_err = "-"
            if name == "bricks":  # the constant field points along +y: grain at pi/2 + the sample's offset
                g, c = grain(sample)
                offset = dominant_grain(g, c, margin_mask(g.shape, 8)) - np.pi / 2
                err = angle_error_degrees(grain_orientation(out["image"])[0], np.pi / 2 + offset)
                grain_err = "%.1f" % np.median(err[margin_mask((res, res), 8)])
            print("%-8s %-7d %8.3f %8.3f %10.5f %7s %8.2f %7.2f   (%.5f)" % (
                name, levels, detail(out["image"], sample), seam_figure(out["image"], out["source"])[0], p11, grain_err,
                out["stats"].get("seconds_coarse", 0.0), out["seconds"], own), flush=True)


CORPUS = ("brick_small,paving_bricks,slate_paving,square_tiles_grey,flagstones,gravel,grass,cracked_rock,"
          "bricks,bark,moss,pebbles,cobbles,marble_tiles_grey,dried_mud,fish_scales")


def part_corpus(bench):
    """Issue 29: optimisation against sampling, detail and p11, on blend_samples/ and the corpus samples
    (TEXSYNTH_CORPUS_SAMPLES, default out/corpus/samples; grey samples as RGB)."""
    folder = os.environ.get("TEXSYNTH_CORPUS_SAMPLES", os.path.join(ROOT, "out", "corpus", "samples"))
    print("\n== 7. corpus: sampling vs optimisation, constant field, %d^2; detail, p11 ==" % bench.args.size)
    for name in bench.args.corpus.split(","):
        path = os.path.join(ROOT, "blend_samples", name + ".png")
        path = path if os.path.exists(path) else os.path.join(folder, name + ".png")
        sample = bench.sample(path)
        if sample.shape[2] == 1:
            bench.samples[path] = sample = np.ascontiguousarray(np.repeat(sample, 3, axis=2))
        figures = []
        for mode in MODES:
            out = bench.run(path, "const", mode, tag="corpus_%s_%s" % (name, mode))
            figures.append("%s %.3f %.5f" % (mode, detail(out["image"], sample),
                                             nearest_patch(out["image"], sample, 11, 600,
                                                           np.random.default_rng(bench.args.seed))))
        print("%-18s %s" % (name, "   ".join(figures)), flush=True)


def peak_rss_mb():
    """VmHWM (peak resident set, MB); ru_maxrss where /proc is missing."""
    try:
        with open("/proc/self/status") as f:
            return next(float(line.split()[1]) / 1024.0 for line in f if line.startswith("VmHWM:"))
    except (OSError, StopIteration):
        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def reset_peak_rss():
    """Sets VmHWM to the current resident set (Linux clear_refs 5), so the next peak is the synthesis' own;
    False where that is not possible (then the peak includes the exemplar's preprocessing)."""
    try:
        with open("/proc/self/clear_refs", "w") as f:
            f.write("5")
        return True
    except OSError:
        return False


def perf_worker(args):
    """A fresh process: one synthesis at args.perf_worker = 'res,mode'; prints one JSON line."""
    res, mode = args.perf_worker.split(",")
    res = int(res)
    result = dict(res=res, mode=mode)
    name, sample = load_sample("bricks")
    pos, tris = plane_mesh(PERF_CELLS)
    P, tri, bary = lattice(res, PERF_CELLS)
    normals = np.tile(np.float32([0, 0, 1]), (len(P), 1))
    dirs = np.tile(np.float32([0, 1, 0]), (len(pos), 1))
    start = time.perf_counter()
    exemplar = tn.patch_exemplar(sample, patch_size=PATCH_SIZE, seed=args.seed)
    result["exemplar_s"] = time.perf_counter() - start
    start = time.perf_counter()
    field = tn.patch_field(pos, tris, dirs, spacing=1.0 / res)
    result["field_s"] = time.perf_counter() - start
    result["triangles"] = int(len(tris))
    result["exemplar_peak_mb"] = peak_rss_mb()
    result["peak_reset"] = reset_peak_rss()
    result["base_mb"] = peak_rss_mb()  # the resident set before synthesis when the reset worked
    start = time.perf_counter()
    r = tn.synthesize_patches(field, exemplar, sample, P, normals, tri, bary, mode=mode, seed=args.seed,
                              centre_spacing=SPACING[mode])
    result["synth_s"] = time.perf_counter() - start
    result["peak_mb"] = peak_rss_mb()
    result["samples"] = int(len(P))
    result["stats"] = {k: v for k, v in r["stats"].items() if k not in ("energy", "changed")}
    if args.out and res <= 1024:
        write_png(os.path.join(args.out, "perf_%d_%s.png" % (res, mode)),
                  np.clip(r["colour"].reshape(res, res, -1)[..., :3], 0, 1))
    print("PERF " + json.dumps(result), flush=True)


def bilinear(image, y, x):
    """image (H, W, C) read at continuous pixel coordinates (y, x) (arrays of one shape), edges clamped."""
    h, w = image.shape[:2]
    y, x = np.clip(y, 0, h - 1), np.clip(x, 0, w - 1)
    y0, x0 = np.minimum(y.astype(int), h - 2), np.minimum(x.astype(int), w - 2)
    fy, fx = (y - y0)[..., None], (x - x0)[..., None]
    s = image.astype(np.float64)
    top = s[y0, x0] * (1 - fx) + s[y0, x0 + 1] * fx
    bottom = s[y0 + 1, x0] * (1 - fx) + s[y0 + 1, x0 + 1] * fx
    return top * (1 - fy) + bottom * fy


def turned_sample(sample, degrees, size):
    """A size x size crop of the sample turned counter-clockwise by degrees about its centre (bilinear)."""
    jy, ix = np.mgrid[0:size, 0:size] - (size - 1) / 2.0
    t = np.radians(degrees)
    cy, cx = (sample.shape[0] - 1) / 2.0, (sample.shape[1] - 1) / 2.0
    return bilinear(sample, cy - np.sin(t) * ix + np.cos(t) * jy, cx + np.cos(t) * ix + np.sin(t) * jy)


def upscale(sample, size):
    """Bilinear resize of an (H, W, C) image to size x size (texel centres aligned)."""
    h, w = sample.shape[:2]
    y, x = np.meshgrid((np.arange(size) + 0.5) * h / size - 0.5, (np.arange(size) + 0.5) * w / size - 0.5,
                       indexing="ij")
    return np.ascontiguousarray(bilinear(sample, y, x), np.float32)


def part_perf(args):
    runs = [(int(s), "sampling") for s in args.perf_sizes.split(",") if s] + \
           [(int(s), "optimisation") for s in args.perf_optimisation.split(",") if s]
    print("\n== 5. speed and memory: plane of %d triangles, res^2 samples, bricks 192^2, each run in a fresh "
          "process (%d cores; load average %.2f) ==" % (2 * PERF_CELLS ** 2, os.cpu_count(), os.getloadavg()[0]))
    results = []
    for res, mode in runs:
        command = [sys.executable, os.path.abspath(__file__), "--perf-worker", "%d,%s" % (res, mode),
                   "--seed", str(args.seed), "--out", args.out]
        run = subprocess.run(command, capture_output=True, text=True)
        lines = [line for line in run.stdout.splitlines() if line.startswith("PERF ")]
        if run.returncode or not lines:
            print("worker %d^2 %s failed (%d): %s" % (res, mode, run.returncode, run.stderr[-2000:]))
            continue
        results.append(json.loads(lines[0][5:]))
    if results:
        def column(f):
            return " ".join("%12s" % f(r) for r in results)
        print("%-34s %s" % ("figure", " ".join("%12s" % ("%d^2 %s" % (r["res"], r["mode"][:4])) for r in results)))
        rows = [("samples", lambda r: "%d" % r["samples"]),
                ("patches (+ extra)", lambda r: "%d+%d" % (r["stats"]["patches"] - r["stats"]["extra_patches"],
                                                          r["stats"]["extra_patches"])),
                ("exemplar 192^2 s", lambda r: "%.2f" % r["exemplar_s"]),
                ("patch_field s", lambda r: "%.2f" % r["field_s"]),
                ("centres s", lambda r: "%.3f" % r["stats"]["seconds_centres"]),
                ("trace s", lambda r: "%.3f" % r["stats"]["seconds_trace"]),
                ("locate s", lambda r: "%.3f" % r["stats"]["seconds_locate"]),
                ("sampling s", lambda r: "%.3f" % r["stats"]["seconds_sampling"]),
                ("optimisation s", lambda r: "%.3f" % r["stats"]["seconds_optimisation"]),
                ("coarser levels s (all stages)", lambda r: "%.3f" % r["stats"].get("seconds_coarse", 0.0)),
                ("synthesis total s (wall)", lambda r: "%.2f" % r["synth_s"]),
                ("us per sample", lambda r: "%.2f" % (1e6 * r["synth_s"] / r["samples"])),
                ("peak RSS MB before (exemplar etc.)", lambda r: "%.0f" % r["exemplar_peak_mb"]),
                ("RSS before synthesis MB", lambda r: "%.0f%s" % (r["base_mb"], "" if r["peak_reset"] else "*")),
                ("peak RSS in synthesis MB", lambda r: "%.0f" % r["peak_mb"]),
                ("  growth in synthesis MB", lambda r: "%.0f" % (r["peak_mb"] - r["base_mb"])),
                ("peak RSS bytes per sample", lambda r: "%.0f" % (r["peak_mb"] * 2 ** 20 / r["samples"])),
                ("  growth bytes per sample", lambda r: "%.0f" % ((r["peak_mb"] - r["base_mb"]) * 2 ** 20
                                                                 / r["samples"])),
                ("coverage entries per sample", lambda r: "%.1f" % (r["stats"]["coverage_entries"] / r["samples"])),
                ("uncovered (extrapolated) samples", lambda r: "%d" % r["stats"]["uncovered_samples"])]
        for label, f in rows:
            print("%-34s %s" % (label, column(f)))
        print("goals: synthesis <= 0.3 s at 256^2 (preview, sampling); * = VmHWM could not be reset (peak so far)")
    sample = load_sample("bricks")[1]
    big = upscale(sample, 256)
    start = time.perf_counter()
    ex = tn.patch_exemplar(big, patch_size=PATCH_SIZE, seed=args.seed)
    seconds = time.perf_counter() - start
    print("exemplar preprocessing, bricks upscaled to 256^2: %.2f s (appearance %.2f, features %.2f, hnsw %.2f; "
          "index %.1f MB); goal <= 5 s" % (seconds, ex.stats["seconds_appearance"], ex.stats["seconds_features"],
                                          ex.stats["seconds_hnsw"], ex.stats["index_bytes"] / 1e6))


def parse_args(argv=None):
    parser = argparse.ArgumentParser(prog="bench_patches_quality")
    parser.add_argument("--parts", default="structure,progressive,seams,exponent,levels,perf")
    parser.add_argument("--size", type=int, default=256, help="lattice res of parts 1-4")
    parser.add_argument("--perf-sizes", default="256,512,1024", help="part 5, sampling mode")
    parser.add_argument("--perf-optimisation", default="256,512", help="part 5, optimisation mode")
    parser.add_argument("--out", default=os.path.join(ROOT, "out", "patches_quality"))
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--corpus", default=CORPUS, help="part corpus (not run by default): sample names")
    parser.add_argument("--perf-worker", help=argparse.SUPPRESS)
    return parser.parse_args(argv)


def main():
    args = parse_args()
    if args.perf_worker:
        perf_worker(args)
        return
    os.makedirs(args.out, exist_ok=True)
    parts = args.parts.split(",")
    start = time.perf_counter()
    print("bench_patches_quality: size %d, seed %d, patch %d, out %s" % (args.size, args.seed, PATCH_SIZE, args.out))
    bench = Bench(args)
    for name in ("bricks", "moss", "bark"):
        write_png(os.path.join(args.out, "sample_%s.png" % name), bench.sample(name))
    for part, function in (("structure", part_structure), ("progressive", part_progressive), ("seams", part_seams),
                           ("exponent", part_exponent), ("levels", part_levels), ("corpus", part_corpus)):
        if part in parts:
            function(bench)
    if "perf" in parts:
        part_perf(args)
    print("\nbench_patches_quality: %.0f s; pictures in %s" % (time.perf_counter() - start, args.out))


if __name__ == "__main__":
    main()

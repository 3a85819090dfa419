# SPDX-License-Identifier: GPL-3.0-or-later
"""bpy-free core of texture particles (Dischler et al. 2002; docs/algorithms/texture_particles.md, "In
Blender"): the analysis with its caches and the artist's edits (label image, merges, background, class
order) and the analysis view (class rows, segmentation preview). outputs.py makes the atlas and the decal
and instance arrays from a placement.

Frames: sample x right, y up, row 0 at the bottom (Blender's pixel order); a pixel (i, j) covers
[i, i + 1] x [j, j + 1], as the analysis' centroids and boxes do.
"""
import hashlib
import os

import numpy as np

from .. import native
from ..core.jobs import BoundedCache
from ..core.sample_image import repeats_across_border, synthesis_sample
from ..core.settings import PARTICLE_CLASS_RANGE, SettingsError

MAX_LABEL_COLOURS = PARTICLE_CLASS_RANGE[1]
MIN_BACKGROUND_SHARE = 0.02  # a sample whose background class holds less is "all particles"
PARTICLE_ID_NAME = "particle_id"
ROTATION_NAME, SCALE_NAME, CLASS_NAME = "rotation", "scale", "class"
ANALYSIS_CACHE_PREFIX = "particles-"
BACKGROUND_PREFIX = "particles-background-"
# Bump when scene.save_background writes other pixels for the same background array.
BACKGROUND_FORMAT = 1


def sample_for_analysis(pixels_top_first):
    """The add-on's H x W x C (row 0 = top) pixels as the analysis wants them: float32 RGB(A), row 0 = bottom
    (the surface-colour methods' convention)."""
    return synthesis_sample(pixels_top_first)


def digest(*arrays):
    hasher = hashlib.blake2b(digest_size=16)
    for array in arrays:
        if array is None:
            hasher.update(b"none")
            continue
        array = np.ascontiguousarray(array)
        hasher.update(repr((array.shape, array.dtype.str)).encode())
        hasher.update(array.tobytes())
    return hasher.hexdigest()


def labels_from_image(rgba_bottom_first, sample_width, sample_height, name="label image"):
    """An artist's label image (one flat colour per class) -> (H, W) int32 class ids, classes numbered by
    first appearance from the bottom row. Clear errors for a wrong size or too many colours."""
    pixels = np.asarray(rgba_bottom_first)
    if pixels.ndim != 3 or pixels.shape[:2] != (sample_height, sample_width):
        got = "%d x %d" % (pixels.shape[1], pixels.shape[0]) if pixels.ndim == 3 else str(pixels.shape)
        raise SettingsError("%s is %s pixels but the sample is %d x %d: paint the labels on an image of "
                                     "the sample's size" % (name, got, sample_width, sample_height))
    colour = np.round(np.clip(pixels[:, :, :3], 0.0, 1.0) * 255.0).astype(np.int32)
    key = (colour[:, :, 0] << 16) | (colour[:, :, 1] << 8) | colour[:, :, 2]
    values, first, inverse = np.unique(key.ravel(), return_index=True, return_inverse=True)
    if values.size > MAX_LABEL_COLOURS:
        raise SettingsError("%s has %d colours; at most %d classes (one flat colour each, no "
                                     "antialiasing)" % (name, values.size, MAX_LABEL_COLOURS))
    if values.size < 2:
        raise SettingsError("%s has one colour: paint at least a background and one particle class" % name)
    rank = np.empty(values.size, np.int32)
    rank[np.argsort(first, kind="stable")] = np.arange(values.size, dtype=np.int32)
    return np.ascontiguousarray(rank[inverse].reshape(key.shape))


def merged_ids(count, merges):
    """old -> new class id (-1: merged away) after merges, for `count` classes before them."""
    return merge_labels(np.arange(count, dtype=np.int32)[None, :], merges)[1] if count else np.zeros(0, np.int32)


def original_id(shown, count, merges):
    """The first pre-merge class id that became class `shown` (the view lists classes after merges)."""
    matches = np.flatnonzero(merged_ids(count, merges) == shown)
    if matches.size == 0:
        raise SettingsError("class %d does not exist after the merges" % shown)
    return int(matches[0])


def merge_labels(labels, merges):
    """Applies merges ((a, b): class a joins b, in order) and renumbers the classes 0..k-1 in order of
    their old ids; returns (labels, old -> new id array (-1: merged away))."""
    labels = np.array(labels, dtype=np.int32, copy=True)
    count = int(labels.max()) + 1 if labels.size else 0
    target = np.arange(count, dtype=np.int32)
    for a, b in merges:
        if not (0 <= a < count and 0 <= b < count):
            raise SettingsError("class merge %d -> %d names a class the analysis does not have "
                                         "(classes 0..%d)" % (a, b, count - 1))
        target[target == a] = target[b]
    kept = np.unique(target)
    renumber = np.full(count, -1, np.int32)
    renumber[kept] = np.arange(kept.size, dtype=np.int32)
    mapping = renumber[target]
    return np.ascontiguousarray(mapping[labels]), mapping


class AnalysisCache(BoundedCache):
    """The last few analyses in memory (most recent last), keyed by analysis_key; the disk copy goes
    through the native save/load_particle_analysis when the module has them (see analyse)."""

    def __init__(self, capacity=4):
        super().__init__(capacity)


analyses = AnalysisCache()


def particle_touching(settings):
    """Touching elements (texture_particles.md "Touching elements"): Settings.particle_touching as AUTO, ON or
    OFF (True and False, from scripts written when it was a checkbox, are ON and OFF)."""
    value = settings.particle_touching
    if isinstance(value, bool):
        return "ON" if value else "OFF"
    return value


def analysis_key(sample, settings, labels=None, tileable=None):
    """tileable: analysis_tileable's answer when the caller has it (it reads the whole sample's border)."""
    params = (int(settings.particle_classes) if labels is None else 0, float(settings.particle_blur),
              int(settings.particle_min_area), int(settings.particle_background_class),
              tuple(tuple(int(c) for c in pair) for pair in settings.particle_merges),
              bool(settings.tileable), int(settings.seed))
    touching = particle_touching(settings)
    if touching != "OFF":
        params += ("touching",) if touching == "ON" else ("touching-auto",)
    if not settings.tileable:  # the detected repeat: its outcome, so a change of the rule cannot reuse a file
        params += ("repeat", tileable if tileable is not None else analysis_tileable(sample, settings))
    return digest(sample, labels) + "-" + hashlib.blake2b(repr(params).encode(), digest_size=8).hexdigest()


def background_file_path(cache_dir, background, sample, labels=None):
    """Where an analysis' filled background (analysis.background) is cached as a PNG. The folder is keyed on
    the array itself: it is all the PNG is written from, so every input of the analysis (sample, label image,
    class count, blur, minimum area, merges, background class, tileable, seed) and the native code that fills
    it are covered, and only an identical background shares a file. The file name is the Blender image's name
    (and, through it, its material's and blend group's): the sample (and label image) part, then a short part
    of the folder's key. Two different backgrounds of one sample thus never share a name; with the sample
    part alone, Blender loaded the second as `<name>.png.001`; both undo / redo violations the workflow soak
    found on Blender 5.2 involved such twins (docs/benchmarks/workflow_soak.md)."""
    key = digest(np.asarray(background))
    folder = "%s%s-%d" % (BACKGROUND_PREFIX, key, BACKGROUND_FORMAT)
    name = "%s%s-%s.png" % (BACKGROUND_PREFIX, digest(sample, labels)[:16], key[:8])
    return os.path.join(cache_dir, folder, name)


def analysis_tileable(sample, settings):
    """(tileable, wrap_blur) of the native analysis. Tileable on: both. Off: a sample whose edges continue each
    other (core/sample_image.repeats_across_border) still has its particles joined across the border, which
    is what its density is counted from (texture_particles.md "Tileable samples": 10 -> 12 of the corpus' 12
    element-like samples within +-15 %), but its blur clamps as without Tileable, so k-means sees the same
    pixels and finds the same classes."""
    if settings.tileable:
        return True, True
    return repeats_across_border(sample), False


def analyse(sample, settings, labels=None, cache_dir="", cancel=None, cache=analyses):
    """(ParticleAnalysis, source 'memory' | 'disk' | 'built') of a sample from sample_for_analysis.
    Merges are applied to the first segmentation's labels, which are then analysed again as a label image."""
    module = native.require()
    tileable, wrap_blur = analysis_tileable(sample, settings)
    key = analysis_key(sample, settings, labels, (tileable, wrap_blur))
    found = cache.get(key)
    if found is not None:
        return found, "memory"
    path = os.path.join(cache_dir, ANALYSIS_CACHE_PREFIX + key + ".bin") if cache_dir else ""
    can_store = hasattr(module, "load_particle_analysis") and hasattr(module, "save_particle_analysis")
    file_key = int(hashlib.blake2b(key.encode(), digest_size=8).hexdigest(), 16)  # the native cache's u64
    if path and can_store and os.path.isfile(path):
        try:
            found = module.load_particle_analysis(path, file_key)
        except ValueError:
            found = None  # corrupt: rebuilt and overwritten below
        if found is not None:
            cache.put(key, found)
            return found, "disk"
    kwargs = dict(blur=float(settings.particle_blur), tileable=tileable, seed=int(settings.seed))
    if not wrap_blur:
        kwargs["wrap_blur"] = False
    if settings.particle_min_area:
        kwargs["min_area"] = int(settings.particle_min_area)
    touching = particle_touching(settings)
    if touching != "OFF":
        kwargs["touching"] = True if touching == "ON" else "auto"
    if cancel is not None:
        kwargs["cancel"] = cancel
    background = int(settings.particle_background_class)
    if labels is None:
        kwargs["classes"] = int(settings.particle_classes)
    if settings.particle_merges:
        first = module.particle_analysis(sample, labels=labels, **kwargs)
        labels, mapping = merge_labels(first.labels, settings.particle_merges)
        kwargs.pop("classes", None)
    if labels is not None:
        kwargs["labels"] = labels
    if background >= 0:
        count = int(labels.max()) + 1 if labels is not None else int(settings.particle_classes)
        if background >= count:
            raise SettingsError("background class %d does not exist (classes 0..%d)" % (background, count - 1))
        kwargs["background"] = background
    analysis = module.particle_analysis(sample, **kwargs)
    cache.put(key, analysis)
    if path and can_store:
        os.makedirs(cache_dir, exist_ok=True)
        module.save_particle_analysis(analysis, path, file_key)
    return analysis, "built"


def class_rows(analysis):
    """One dict per class for the analysis view: id, colour (RGB 0..1), pixels, particles, complete,
    background, random, has_complete."""
    table = analysis.classes
    rows = []
    for index in range(table.shape[0]):
        colour = np.asarray(table["colour"][index], dtype=np.float64).ravel()
        rgb = np.repeat(colour[:1], 3) if colour.size < 3 else colour[:3]
        rows.append(dict(id=index, colour=tuple(float(c) for c in np.clip(rgb, 0.0, 1.0)),
                         pixels=int(table["pixels"][index]), particles=int(table["particles"][index]),
                         complete=int(table["complete"][index]), background=bool(table["background"][index]),
                         random=bool(table["random"][index]), has_complete=bool(table["has_complete"][index])))
    return rows


# Where a sample has no separate elements, another method serves it (named as the panel and the CLI name them).
OTHER_METHODS = ("A texture without separate elements (noise, a gradient, grain) is served by Jump Maps (--method "
                 "jumpmap) or Round Neighbourhoods (--method round) instead.")


def check_usable(analysis, settings=None):
    """Raises SettingsError when the sample cannot give particles: one colour, all particles, no complete
    particle. Returns notes for what was bounded (merged tiny components) and for a repeat found with Tileable
    off (settings given)."""
    rows = class_rows(analysis)
    total = analysis.width * analysis.height
    particles = sum(row["particles"] for row in rows if not row["background"])
    if particles == 0:
        raise SettingsError(
            "the sample has no particles: it is one colour, or every component is smaller than the minimum area "
            "(%d px); use a sample of distinct elements or lower the minimum area. %s" % (analysis.min_area, OTHER_METHODS))
    background = sum(row["pixels"] for row in rows if row["background"])
    if background < MIN_BACKGROUND_SHARE * total:
        raise SettingsError(
            "the sample is all particles: the background class covers %.1f %% of it (at least %.0f %% needed); "
            "choose another background class or fewer classes" % (100.0 * background / total, 100 * MIN_BACKGROUND_SHARE))
    if not any(row["has_complete"] for row in rows if not row["background"]):
        raise SettingsError(
            "no class has a complete particle (every particle is cut by the sample's border or joined into one "
            "region): use a sample where whole elements lie inside, or mark it tileable. %s" % OTHER_METHODS)
    notes = []
    if settings is not None and analysis.tileable and not settings.tileable:
        notes.append("the sample repeats across its border: elements cut by it are joined as with Tileable on")
    if settings is not None and analysis.touching and particle_touching(settings) == "AUTO":
        if analysis.touching_fragments:
            notes.append("elements were cut into pieces of very different sizes (veins, or a core and a rim of "
                         "different colour): each element taken whole (Touching Elements: Auto; Off keeps the "
                         "pieces)")
        else:
            notes.append("elements touch (one region spanned a fifth of the sample): split at the narrow necks "
                         "between them (Touching Elements: Auto; Off keeps each region whole)")
    if analysis.merged_components:
        notes.append("%d tiny components joined the background%s" % (
            analysis.merged_components, " (beyond the cap of 20,000 particles: %d)" % analysis.merged_over_cap
            if analysis.merged_over_cap else ""))
    return notes


def segmentation_preview(analysis):
    """(H, W, 4) float32 RGBA, row 0 = bottom: each pixel in its class colour, particle outlines in black or
    white (whichever contrasts with the class), incomplete particles' outlines grey."""
    rows = class_rows(analysis)
    colours = np.array([row["colour"] for row in rows], np.float32)
    labels = analysis.labels
    components = analysis.components
    image = np.ones(labels.shape + (4,), np.float32)
    image[:, :, :3] = colours[np.clip(labels, 0, len(rows) - 1)]
    padded = np.pad(components, 1, mode="edge")
    edge = np.zeros(components.shape, bool)
    for dy, dx in ((0, 1), (2, 1), (1, 0), (1, 2)):
        edge |= padded[dy:dy + components.shape[0], dx:dx + components.shape[1]] != components
    edge &= components >= 0
    luminance = colours @ np.array([0.2126, 0.7152, 0.0722], np.float32)
    outline = np.where(luminance > 0.5, 0.0, 1.0).astype(np.float32)[np.clip(labels, 0, len(rows) - 1)]
    complete = np.asarray(analysis.particles["complete"], bool)
    incomplete = np.zeros(components.shape, bool)
    if complete.size:
        incomplete = ~complete[np.maximum(components, 0)] & (components >= 0)
    outline = np.where(incomplete, 0.5, outline)
    image[edge, :3] = outline[edge][:, None]
    return image


# Flat label colours, one per class id (8-bit exact, far apart): what --write-labels writes and --labels
# reads back (labels_from_image numbers classes by first appearance, so ids may be renumbered).
LABEL_PALETTE = np.array([[0, 0, 0], [230, 25, 75], [60, 180, 75], [255, 225, 25], [0, 130, 200], [245, 130, 48],
                          [145, 30, 180], [70, 240, 240], [240, 50, 230], [210, 245, 60], [250, 190, 212],
                          [255, 255, 255]], np.float32) / np.float32(255.0)


def label_image(analysis):
    """(H, W, 4) float32 RGBA, row 0 = bottom: the analysis' classes as flat colours (LABEL_PALETTE by class
    id, no outlines), a label image the artist can repaint and give back as --labels or Label Image."""
    labels = np.clip(np.asarray(analysis.labels), 0, len(LABEL_PALETTE) - 1)
    image = np.ones(labels.shape + (4,), np.float32)
    image[:, :, :3] = LABEL_PALETTE[labels]
    return image


# Most particles one run places on one object: their decal meshes (4 vertices each) and instance points stay
# within what Blender edits without stalling; the native placement stops there too (max_particles).
MAX_PARTICLES = 1000000


def expected_particles(analysis, sample_world_width, surface_area):
    """Particles the sample's density predicts on `surface_area` world units² (every placed class counted;
    per-face density overrides and the scale field not included)."""
    rows = class_rows(analysis)
    per_sample = sum(row["particles"] for row in rows if not row["background"])
    sample_area = float(sample_world_width) ** 2 * analysis.height / float(analysis.width)
    return per_sample * float(surface_area) / sample_area


def check_particle_count(expected, sample_world_width, name, cap=MAX_PARTICLES):
    """SettingsError naming the count and the Scale that brings it under the cap (the count goes with
    1 / scale²), before any placement."""
    if expected > cap:
        scale = float(sample_world_width) * (expected / cap) ** 0.5 * 1.01
        raise SettingsError("%s: about %d particles at this scale, more than the %d one run places: raise Scale "
                            "(CLI --scale) to at least %.3g" % (name, expected, cap, scale))


def class_at(analysis, x, y):
    """Class id of sample pixel (x, y) (x right, y up from the bottom row); SettingsError outside."""
    if not (0 <= x < analysis.width and 0 <= y < analysis.height):
        raise SettingsError("(%d, %d) is outside the %d x %d sample" % (x, y, analysis.width, analysis.height))
    return int(analysis.labels[int(y), int(x)])


def class_order(analysis, settings):
    """The classes to place, in order: the artist's order (checked), else every non-background class with a
    complete particle by decreasing particle count (the native default, written out so ranks are known)."""
    rows = class_rows(analysis)
    if settings.particle_class_order:
        order = [int(c) for c in settings.particle_class_order]
        for c in order:
            if not 0 <= c < len(rows):
                raise SettingsError("class order names class %d; the analysis has classes 0..%d"
                                             % (c, len(rows) - 1))
            if rows[c]["background"]:
                raise SettingsError("class %d is the background: it is synthesized as texture, not placed" % c)
            if not rows[c]["has_complete"]:
                raise SettingsError("class %d has no complete particle to place" % c)
        return order
    usable = [row for row in rows if not row["background"] and row["has_complete"]]
    return [row["id"] for row in sorted(usable, key=lambda row: (-row["particles"], row["id"]))]


def parse_class_list(text):
    """'2, 0 1' -> (2, 0, 1); SettingsError for anything but integers."""
    items = [item for item in text.replace(",", " ").split() if item]
    try:
        return tuple(int(item) for item in items)
    except ValueError:
        raise SettingsError("class order must be class numbers separated by commas, got %r" % text)


def parse_merges(text):
    """'3>1, 2>0' -> ((3, 1), (2, 0))."""
    merges = []
    for item in [item.strip() for item in text.split(",") if item.strip()]:
        parts = item.split(">")
        try:
            merges.append((int(parts[0]), int(parts[1])) if len(parts) == 2 else None)
        except ValueError:
            merges.append(None)
        if merges[-1] is None:
            raise SettingsError("class merges are written a>b (class a joins b), got %r" % item)
    return tuple(merges)


def format_merges(merges):
    return ", ".join("%d>%d" % (a, b) for a, b in merges)

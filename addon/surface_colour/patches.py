# SPDX-License-Identifier: GPL-3.0-or-later
"""Vector-field patches (Chen, Liu & Dong) on one mesh, bpy-free: the analysed exemplar and the patch
targets kept between runs, the memory estimate the cap refuses on, and the native synthesis call."""
import hashlib
import os
import threading

import numpy as np

from .. import native
from ..core.orientation import directions
from ..core.settings import PATCH_SIZE_RANGE, SettingsError, check_patch_boundary
from .core import MAX_OVERLAP_FRACTION, target_density, vertex_samples, working_sample


# Vector-field patches: the Poisson-disk radius of patch centres as a fraction of the patch size
# (docs/algorithms/vector_field_patches.md, "Centres"): half a patch for sampling; 0.3 for optimisation,
# which packs about as many patches as the paper's quarter did with sparser candidates (7 per sample at
# 256²) and measured more detail (moss 0.84 vs 0.75 of the sample's gradient) in half the time (README,
# Vector-field patches).
PATCH_CENTRE_SPACING = {"SAMPLING": 0.5, "OPTIMISATION": 0.3}
# Optimisation levels (coarse to fine, the sample halved per level): 3 kept brick courses whole where one
# level broke them (nearest-patch distance 0.00083 vs 0.00317 on bricks, detail 0.95 vs 0.84 on moss).
PATCH_LEVELS = 3
PATCH_MAX_MEGABYTES = 2500.0
# The analysed sample alone (appearance, patch features, HNSW): patch_exemplar's max_megabytes.
PATCH_EXEMPLAR_MAX_MEGABYTES = 1500.0
# A working sample over either limit at Synthesis Resolution Match Target is reduced until it fits, its width
# × MEMORY_FIT_STEP per try, at most MEMORY_FIT_STEPS tries (0.85^12 = 0.14); past that the run is refused.
# Corpus (issue 29): the 1024-2048 px photos were refused on the scanned bunny (1.6-6.8 GB estimated).
MEMORY_FIT_STEP = 0.85
MEMORY_FIT_STEPS = 12


class ExemplarCache:
    """Analysed samples for vector-field patches (appearance PCA, patch features, HNSW indices): the last
    one in memory (a new field or seed reuses it: the live preview), and on disk under cache_dir when
    given, keyed by the pixels and every parameter that changes the analysis."""

    def __init__(self):
        self.entry = None  # (key, exemplar)
        self.lock = threading.Lock()

    @staticmethod
    def key(sample, patch_size, tileable):
        """(file-name key, native key). The native key (patch_exemplar_key) covers the format version and
        every parameter patch_exemplar uses, defaults included; the file stores it and the load checks it."""
        native_key = int(native.require().patch_exemplar_key(sample, patch_size=int(patch_size),
                                                              tileable=bool(tileable)))
        digest = hashlib.blake2b(digest_size=16)
        digest.update(str(sample.shape).encode())
        digest.update(np.ascontiguousarray(sample).data)
        digest.update(repr((int(patch_size), bool(tileable), native_key)).encode())
        return digest.hexdigest(), native_key

    def get(self, sample, patch_size, tileable, cache_dir="", cancel=None):
        """(exemplar, how): how is 'memory', 'disk' or 'built'."""
        module = native.require()
        key, native_key = self.key(sample, patch_size, tileable)
        with self.lock:
            if self.entry is not None and self.entry[0] == key:
                return self.entry[1], "memory"
        path = os.path.join(cache_dir, "patches-%s.tsx" % key) if cache_dir else ""
        exemplar, how = None, "built"
        if path and os.path.exists(path):
            try:
                exemplar, how = module.load_patch_exemplar(path, native_key), "disk"
            except ValueError:
                exemplar = None  # another key, stale or corrupt: rebuilt and overwritten below
        if exemplar is None:
            extra = {} if cancel is None else {"cancel": cancel}
            exemplar = module.patch_exemplar(sample, patch_size=int(patch_size), tileable=bool(tileable),
                                             max_megabytes=PATCH_EXEMPLAR_MAX_MEGABYTES, **extra)
            if path:
                os.makedirs(cache_dir, exist_ok=True)
                exemplar.save(path)
        with self.lock:
            self.entry = (key, exemplar)
        return exemplar, how

    def clear(self):
        with self.lock:
            self.entry = None


exemplars = ExemplarCache()


# Peak memory of a patch synthesis (estimate_patch_megabytes). Measured (peak RSS less Blender's own 0.26 GB)
# with a 512² sample at scale 0.3, Full Sample, 32 px patches, a 512² image: 2 x 2 plane, sampling 1.33 GB
# (estimate 1.48), optimisation 2.21 GB (3.38: no extra patches were appended there); the default cube,
# sampling 4.73 GB (4.69), 189 s.
PATCH_CENTRES_PER_SPACING_SQUARED = 0.5  # Poisson-disk patch centres per spacing² of surface (measured 0.44-0.46)
PATCH_GRID_POINT_BYTES = 37  # face point 12 B + position 12 B + cell flag 1 B, and the largest of those
PATCH_COVERAGE_BYTES = 24    # a (sample, patch) pair with its grid coordinates, held both ways round
PATCH_SAMPLE_BYTES = 64      # per surface sample: position, normal, face, colour, exemplar source, flags


def patch_surface_pixels(positions, triangles, texels_per_unit, scale_multiplier=None):
    """The surface a patch field steps over, in square sample pixels: the mesh's area x texels_per_unit²,
    each triangle weighted by the square of its vertices' mean scale multiplier (clamped like the field's
    step, to [1/4, 4]: a multiplier of 2 halves the step, four times the patches)."""
    positions = np.asarray(positions, dtype=np.float64)
    triangles = np.asarray(triangles)
    if triangles.size == 0:
        return 0.0
    corners = positions[triangles]
    areas = 0.5 * np.linalg.norm(np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), axis=1)
    if scale_multiplier is not None:
        multiplier = np.clip(np.asarray(scale_multiplier, dtype=np.float64), 0.25, 4.0)
        areas = areas * multiplier[triangles].mean(axis=1) ** 2
    return float(areas.sum()) * float(texels_per_unit) ** 2


def estimate_patch_megabytes(module, samples, mode, level_sizes, surface_pixels, channels, tileable):
    """Peak memory of a patch synthesis (MB). level_sizes: the module's patch_level_sizes of the working
    sample; surface_pixels: patch_surface_pixels at its resolution.

    The patches are counted on the surface at the sample's resolution, not the target's: one per
    PATCH_CENTRES_PER_SPACING_SQUARED spacing² of it (at most one per surface sample, since the centres are
    surface samples), each traced over (patch size + 2)² grid points. A sample much finer than the target
    (Synthesis Resolution Full Sample) therefore gives a patch per surface sample, and the patches' grid
    points outnumber the samples by the patch area. Then the (sample, patch) pairs of the coverage, the
    per-sample arrays, and the sample analysis (the module's estimate) of every level: the finest is kept
    while the coarser optimisation levels run (each level's grids are freed before the next finer one's)."""
    patch_size = level_sizes[0][2]
    spacing = PATCH_CENTRE_SPACING[mode] * patch_size
    side = patch_size + 2  # grid points a side: the patch and a margin of one (patch_synth.hpp)
    patches = min(float(samples), PATCH_CENTRES_PER_SPACING_SQUARED * float(surface_pixels) / spacing ** 2)
    coverage = samples * PATCH_CENTRES_PER_SPACING_SQUARED * (side / spacing) ** 2
    analyses = sum(module.estimate_patch_exemplar_bytes(width, height, channels, patch, tileable=tileable)
                   for width, height, patch in level_sizes)
    total = (patches * side * side * PATCH_GRID_POINT_BYTES + coverage * PATCH_COVERAGE_BYTES
             + samples * PATCH_SAMPLE_BYTES + analyses)
    return total / 1e6


class MemoryPlan:
    """What a patch synthesis from one working sample needs: every level's (width, height, patch size), the
    surface in sample pixels, the whole estimate and the finest analysis' share (MB)."""

    def __init__(self, module, sample, texels_per_unit, settings, samples, mesh_arrays, triangles):
        height, width, channels = sample.shape
        try:
            self.level_sizes = module.patch_level_sizes(width, height, settings.patch_size,
                                                        tileable=bool(settings.tileable),
                                                        mode=settings.patch_mode.lower(), levels=PATCH_LEVELS)
        except ValueError as error:  # a working sample too small for any patch
            raise SettingsError(str(error))
        self.surface_pixels = patch_surface_pixels(mesh_arrays.positions, triangles, texels_per_unit,
                                                   mesh_arrays.scale_multiplier)
        self.megabytes = estimate_patch_megabytes(module, samples, settings.patch_mode, self.level_sizes,
                                                  self.surface_pixels, channels, bool(settings.tileable))
        finest = self.level_sizes[0]
        self.exemplar_megabytes = module.estimate_patch_exemplar_bytes(
            finest[0], finest[1], channels, finest[2], tileable=bool(settings.tileable)) / 1e6

    def fits(self):
        return self.megabytes <= PATCH_MAX_MEGABYTES and self.exemplar_megabytes <= PATCH_EXEMPLAR_MAX_MEGABYTES


def fit_to_memory(module, sample, texels_per_unit, settings, samples, mesh_arrays, triangles):
    """(sample, texels_per_unit, plan): the working sample as it is when it fits the memory limits, else
    the largest reduction of it (MEMORY_FIT_STEP per try) that does; plan.fits() is False when none does."""
    plan = MemoryPlan(module, sample, texels_per_unit, settings, samples, mesh_arrays, triangles)
    if plan.fits() or settings.round_resolution != "AUTO":
        return sample, texels_per_unit, plan
    for step in range(1, MEMORY_FIT_STEPS + 1):
        smaller, smaller_texels = working_sample(sample, texels_per_unit, texels_per_unit * MEMORY_FIT_STEP ** step,
                                                 "AUTO", 2 * settings.patch_size)
        if smaller.shape[1] >= sample.shape[1]:
            break  # at the smallest working sample already
        try:
            candidate = MemoryPlan(module, smaller, smaller_texels, settings, samples, mesh_arrays, triangles)
        except SettingsError:
            break
        if candidate.fits():
            return smaller, smaller_texels, candidate
    return sample, texels_per_unit, plan


def memory_advice(module, settings, target, samples, level_sizes, surface_pixels, channels, finer, sample_shape):
    """What brings a patch synthesis over PATCH_MAX_MEGABYTES under it, in the panel's words with the CLI's
    flags: only the changes that apply to these settings, and for an image target the largest image size
    whose estimate fits (the surface samples go with the image's area; the sample analysis does not)."""
    if settings.round_resolution == "FULL" and finer > 1.05:
        return ("set Synthesis Resolution to Match Target (CLI --synthesis-resolution auto): at Full Sample the "
                "%d x %d sample has %.1f pixels between neighbouring surface samples, and the patches are traced "
                "and the sample analysed at its resolution" % (sample_shape[1], sample_shape[0], finer))
    ways = []
    if target.kind == "IMAGE":
        side = max(int(target.width), int(target.height))
        for smaller in range((side - 1) // 64 * 64, 63, -64):
            fewer = samples * (smaller / float(side)) ** 2
            if estimate_patch_megabytes(module, fewer, settings.patch_mode, level_sizes, surface_pixels, channels,
                                        bool(settings.tileable)) <= PATCH_MAX_MEGABYTES:
                ways.append("an image of %d px (Size, CLI --bake-size %d)" % (smaller, smaller))
                break
    if settings.patch_mode == "OPTIMISATION":
        ways.append("Patch Sampling mode (CLI --mode sampling)")
    if settings.patch_size < PATCH_SIZE_RANGE[1]:
        ways.append("larger patches (Patch Size, CLI --patch-size)")
    ways.append("a smaller sample")
    return "use " + (", ".join(ways[:-1]) + " or " if len(ways) > 1 else "") + ways[-1]


class PatchTargetCache:
    """What a patch synthesis reads from the mesh and target alone, kept for the last mesh so a live
    preview after a comb stroke redoes only the field: the surface samples (texels through the UV map)
    and their density, and the last field, whose walk mesh the native side copies when the geometry is
    the same (these were 0.45 s of a 0.54 s preview on a 100k-face torus)."""

    def __init__(self):
        self.entry = None  # (key, density, samples)
        self.field = None
        self.lock = threading.Lock()

    @staticmethod
    def key(mesh_arrays, triangles, corner_uvs, target):
        digest = hashlib.blake2b(digest_size=16)
        for array in (mesh_arrays.positions, triangles, corner_uvs if target.kind == "IMAGE" else None):
            if array is not None:
                array = np.ascontiguousarray(array)
                digest.update(str((array.dtype, array.shape)).encode())
                digest.update(array.data)
        digest.update(repr((target.kind, int(target.width), int(target.height), int(target.margin))).encode())
        return digest.hexdigest()

    def get(self, key):
        with self.lock:
            return self.entry[1:] if self.entry is not None and self.entry[0] == key else None

    def put(self, key, density, samples):
        with self.lock:
            self.entry = (key, density, samples)

    def clear(self):
        with self.lock:
            self.entry, self.field = None, None


patch_targets = PatchTargetCache()


def synthesize_patches(sample, mesh_arrays, triangles, corner_uvs, settings, seed, texels_per_unit, target,
                       cancel=None, stage=None, cache_dir="", cache=exemplars, targets=patch_targets):
    """Vector-field patch synthesis on one mesh (same contract as synthesize_round): IMAGE target ->
    'image' (H, W, C) with the bake margin filled and 'mask' (1 covered, 2 margin); VERTICES -> 'vertex_colour'
    (V, C). ValueError on bad input (overlapping UV islands, a target above the memory limit, ...)."""
    module = native.require()
    if mesh_arrays.num_faces == 0 or triangles.shape[0] == 0:
        raise SettingsError("mesh has no faces")
    stage = stage or (lambda name: None)
    extra = {} if cancel is None else {"cancel": cancel}
    up = directions(mesh_arrays, settings)
    target_key = targets.key(mesh_arrays, triangles, corner_uvs, target)
    cached = targets.get(target_key)
    density = cached[0] if cached else target_density(mesh_arrays.positions, triangles, corner_uvs, target)
    full_width = sample.shape[1]
    # A scale field above 1 asks for features finer than the samples there: the sample is reduced by the
    # largest multiplier too, so no patch reads an exemplar finer than the surface samples can hold
    # (unfiltered, bricks at density 2 broke into fragments; README, Vector-field patches).
    finest = 1.0
    if mesh_arrays.scale_multiplier is not None and settings.round_resolution == "AUTO":
        finest = max(1.0, float(np.max(mesh_arrays.scale_multiplier)))
    sample, texels_per_unit = working_sample(sample, texels_per_unit, density / finest, settings.round_resolution,
                                             2 * settings.patch_size)
    # The patch size of every exemplar the native synthesis analyses (smaller for a small working sample and
    # optimisation's coarser levels) bounds the boundary width: refused here, before any analysis.
    try:
        level_sizes = module.patch_level_sizes(sample.shape[1], sample.shape[0], settings.patch_size,
                                               tileable=bool(settings.tileable), mode=settings.patch_mode.lower(),
                                               levels=PATCH_LEVELS)
    except ValueError as error:  # a working sample too small for any patch
        raise SettingsError(str(error))
    check_patch_boundary(settings.patch_boundary, level_sizes)
    stage("context")
    if target.kind == "IMAGE":
        texels = cached[1] if cached else module.sample_texels(
            mesh_arrays.positions, triangles, corner_uvs, int(target.width), int(target.height),
            margin=int(target.margin), **extra)
        covered = int(texels["texel"].size)
        if covered == 0:
            raise SettingsError("the UV map covers no texel of a %dx%d image" % (target.width, target.height))
        overlapping = int(texels["num_overlapping_texels"])
        if overlapping > MAX_OVERLAP_FRACTION * covered:
            raise SettingsError(
                "UV map has overlapping islands: %d of %d texels are covered twice; unwrap without overlaps "
                "(or let TexSynth make a map with Smart UV Project)" % (overlapping, covered))
        positions, normals = texels["position"], texels["normal"]
        tri, bary = texels["triangle"], texels["barycentric"]
    else:
        texels = cached[1] if cached else vertex_samples(mesh_arrays.positions, triangles)
        vertex_ids, positions, normals, tri, bary = texels
        overlapping = 0
    if not cached:
        targets.put(target_key, density, texels)
    mode = settings.patch_mode
    before = sample.shape
    sample, texels_per_unit, plan = fit_to_memory(module, sample, texels_per_unit, settings, positions.shape[0],
                                                  mesh_arrays, triangles)
    if not plan.fits():
        finer = texels_per_unit / density if density > 0.0 else 1.0
        advice = memory_advice(module, settings, target, positions.shape[0], plan.level_sizes, plan.surface_pixels,
                               sample.shape[2], finer, sample.shape)
        if plan.megabytes > PATCH_MAX_MEGABYTES:
            raise SettingsError(
                "%d surface samples with %d px patches in %s mode need about %d MB (limit %d MB): %s"
                % (positions.shape[0], plan.level_sizes[0][2], mode.lower(), plan.megabytes, PATCH_MAX_MEGABYTES,
                   advice))
        raise SettingsError("analysing the %d x %d sample with %d px patches needs about %d MB (limit %d MB): %s"
                            % (sample.shape[1], sample.shape[0], plan.level_sizes[0][2], plan.exemplar_megabytes,
                               PATCH_EXEMPLAR_MAX_MEGABYTES, advice))
    check_patch_boundary(settings.patch_boundary, plan.level_sizes)
    exemplar, exemplar_from = cache.get(sample, settings.patch_size, settings.tileable,
                                        cache_dir, cancel)
    field = module.patch_field(mesh_arrays.positions, triangles, up, spacing=1.0 / float(texels_per_unit),
                               density=mesh_arrays.scale_multiplier, reuse=targets.field, **extra)
    targets.field = field
    stage("synthesis")
    native_result = module.synthesize_patches(
        field, exemplar, sample, positions, normals, tri, bary, mode=mode.lower(), seed=int(seed),
        centre_spacing=PATCH_CENTRE_SPACING[mode], levels=PATCH_LEVELS, boundary_width=int(settings.patch_boundary),
        tolerance=float(settings.patch_tolerance),
        iterations=int(settings.patch_iterations), **extra)
    colour = native_result["colour"]
    channels = colour.shape[1]
    result = {}
    if target.kind == "IMAGE":
        image = np.zeros((int(target.height) * int(target.width), channels), np.float32)
        mask = np.zeros(int(target.height) * int(target.width), np.uint8)
        image[texels["texel"]] = colour
        mask[texels["texel"]] = 1
        image[texels["gutter_texel"]] = colour[texels["gutter_source"]]
        mask[texels["gutter_texel"]] = 2
        result["image"] = image.reshape(int(target.height), int(target.width), channels)
        result["mask"] = mask.reshape(int(target.height), int(target.width))
    else:
        vertex_colour = np.zeros((mesh_arrays.positions.shape[0], channels), np.float32)
        vertex_colour[vertex_ids] = colour
        result["vertex_colour"] = vertex_colour
    native_stats = dict(native_result["stats"])
    seconds = sum(float(native_stats[k]) for k in ("seconds_centres", "seconds_trace", "seconds_locate",
                                                    "seconds_sampling", "seconds_optimisation", "seconds_coarse"))
    result["context_reused"] = False
    result["stats"] = {
        "seconds_synthesis": seconds,
        "surface_samples": int(positions.shape[0]),
        "overlapping_texels": overlapping,
        "working_sample": [int(sample.shape[1]), int(sample.shape[0])],
        "memory_reduced_from": [int(before[1]), int(before[0])] if sample.shape != before else None,
        "estimated_megabytes": float(plan.megabytes),
        "target_density": density,
        "sample_pixels_per_spacing": float(full_width / float(sample.shape[1]) * texels_per_unit / density)
        if density > 0.0 else 0.0,
        "exemplar": exemplar_from,
        "patch_size": int(exemplar.patch_size),
        "mode": mode,
        "patches": int(native_stats["patches"]),
        "unreached_samples": int(native_stats["uncovered_samples"]),
        "native": native_stats,
    }
    return result

# SPDX-License-Identifier: GPL-3.0-or-later
"""bpy-free core of the add-on: settings validation, world scale -> texels, caching policy,
timings and reports, and the calls into texsynth_native on numpy arrays.

The bpy layer (operators, CLI) converts Blender data to the plain types here and back (mesh_io.py).
"""
import dataclasses
import math
import os
import threading
import time
import zlib

import numpy as np

from .. import native

METHODS = ("JUMPMAP", "TEXTON", "ROUND", "PATCHES", "PARTICLES")
IMPLEMENTED_METHODS = ("JUMPMAP", "TEXTON", "ROUND", "PATCHES", "PARTICLES")
UV_METHODS = ("JUMPMAP", "TEXTON")   # write coordinates into the sample + blend data (uv_methods/)
SURFACE_METHODS = ("ROUND", "PATCHES")  # write a colour per surface sample (surface_colour/)
SURFACE_TARGETS = ("IMAGE", "VERTICES")
# Preprocessing working size (native kMinWorkingSize / kMaxWorkingSize; 0 = off).
WORKING_SIZE_RANGE = (64, 4096)
# Round neighbourhoods: the native limits (round_synth.hpp) and the defaults the README measures.
ROUND_LEVEL_RANGE, ROUND_RING_RANGE, ROUND_CANDIDATE_RANGE = (1, 6), (1, 6), (0, 16)
ROUND_RESOLUTIONS = ("AUTO", "FULL")
# Vector-field patches (patches/patch_synth.hpp): SAMPLING pastes matched patches (paper §5), OPTIMISATION
# refines that result by texture optimisation (§4.3). Sizes in sample pixels. The UI properties take their
# ranges from here, before the native module is loaded; python_tests/test_native_module.py checks them
# against the module's PATCH_SIZE_RANGE. The boundary width is 1 .. half the patch size of every exemplar
# the synthesis analyses: the module's patch_level_sizes gives that plan (smaller patches for a small
# sample and for optimisation's coarser levels), and check_patch_boundary refuses before any analysis.
PATCH_MODES = ("SAMPLING", "OPTIMISATION")
PATCH_SIZE_RANGE = (8, 64)
PATCH_BOUNDARY_RANGE = (1, PATCH_SIZE_RANGE[1] // 2)
PATCH_TOLERANCE_RANGE, PATCH_ITERATION_RANGE = (1.0, 4.0), (1, 50)
# Texture particles (particles/): the analysis' limits (particles/analysis.hpp) and what Synthesize makes.
PARTICLE_CLASS_RANGE = (2, 12)
PARTICLE_MAX_BLUR = 10.0
PARTICLE_OUTPUTS = ("DECALS", "INSTANCES", "BOTH")
PARTICLE_BACKGROUNDS = ("JUMPMAP", "TEXTON", "NONE")   # how the filled background sample is synthesized
PARTICLE_MAX_JITTER = 0.9
ORIENTATIONS = ("AXIS", "FIELD", "ANCHORS")
SCALE_SOURCES = ("NONE", "ATTRIBUTE", "VERTEX_GROUP")
BLEND_MODES = ("AUTO", "HISTOGRAM", "VARIANCE", "LINEAR")  # see blend_groups.py
# AUTO: what measured best per method (README, Blending): the jump map blends up to three unrelated
# patches everywhere, and keeps its contrast only with HISTOGRAM; texton patches blend in narrow
# zones with neighbours the search matched, where LINEAR keeps detail (1.028 of tiling) and is cheaper.
AUTO_BLEND_MODE = {"JUMPMAP": "HISTOGRAM", "TEXTON": "LINEAR"}
# Auto takes VARIANCE instead of HISTOGRAM when the sample keeps less of its detail than this through
# the histogram transform's interpolation (interpolation_fidelity; moss 0.93, bark 1.00, bricks 1.04).
AUTO_HISTOGRAM_MIN_FIDELITY = 0.97
# Largest sample histogram-preserving blending serves (texsynth_native.histogram_transform's image limit).
HISTOGRAM_MAX_PIXELS = 4096 * 4096
# Auto, texton: Linear for periodic samples (the search matches patches that continue the period, so
# blending them loses nothing and rescaling over-sharpens: bricks, periodicity 0.95), Variance for
# stochastic ones (matched only along the edge, nearly independent inside: moss 0.09, bark 0.10).
AUTO_TEXTON_LINEAR_PERIODICITY = 0.5
# Texton method: each face shows its own patch beyond this distance from its edges (barycentric-like
# units, 1/3 at a triangle's centre) and fades to the vertex mappings toward them (blend_groups.py).
TEXTON_PATCH_ZONE = 0.15
MAX_UV_LAYERS = 8  # Blender's hard limit per mesh

BASE_UV_NAME = "TexSynth"  # TexSynth's only UV map: the base mapping (normal-map tangents, no-blend look)
# Before 0.2 the blend sets were UV maps TexSynth_B0..B3 (5 of Blender's 8): recognised, so Synthesize
# replaces them and Clear removes them.
LEGACY_BLEND_UV_PREFIX = "TexSynth_B"
# Blend set coordinates per corner, two sets per RGBA corner attribute: (u0, v0, u1, v1), (u2, v2, u3, v3).
# Interpolated exactly like UV maps, without using any of Blender's 8 UV map slots.
SET_ATTRIBUTE_NAMES = ("TexSynth_Sets01", "TexSynth_Sets23")
WEIGHTS_NAME = "TexSynth_Weights"
# Texton method, per corner (the edge from the corner to the next): 1 where that edge is blended, and its E_t.
EDGE_BLENDED_NAME = "TexSynth_EdgeBlended"
EDGE_ERROR_NAME = "TexSynth_EdgeError"
EXTRA_ATTRIBUTE_NAMES = (EDGE_BLENDED_NAME, EDGE_ERROR_NAME)
# Texton results: per corner, the weights summed per group of identical mappings (mapping_groups_rgba).
GROUPS_NAME = "TexSynth_Groups"
ATTRIBUTE_NAMES = (WEIGHTS_NAME,) + SET_ATTRIBUTE_NAMES + (GROUPS_NAME,) + EXTRA_ATTRIBUTE_NAMES
MAX_BLEND_SETS = 4  # the weight attribute is RGBA


class SettingsError(ValueError):
    """A setting or input is unusable; the message names it."""


@dataclasses.dataclass
class Settings:
    """Everything one Synthesize run needs, independent of where it came from (panel or CLI)."""
    method: str = "JUMPMAP"
    sample_world_size: float = 1.0   # world units covered by the sample's width
    seed: int = 0
    jump_rate: float = 20.0
    blend: bool = True
    # How the shader cross-fades the blend sets: HISTOGRAM keeps the sample's histogram (Gaussianized
    # look-ups, variance-preserving blend, inverse look-up table), VARIANCE keeps its variance, LINEAR averages.
    blend_mode: str = "AUTO"
    orientation: str = "AXIS"
    axis: tuple = (0.0, 0.0, 1.0)
    direction_attribute: str = ""    # FIELD: per-vertex vectors; ANCHORS: non-zero vectors mark anchors
    allow_oversized: bool = False    # map faces larger than the sample anyway (visible stretching/repeats)
    # Per-vertex density multiplier (progressively-variant texture): a FLOAT point attribute, or a
    # vertex group whose weight w maps to scale_min + w (scale_max - scale_min).
    scale_source: str = "NONE"
    scale_attribute: str = "TexSynth_Scale"
    scale_group: str = ""
    scale_min: float = 0.5
    scale_max: float = 2.0
    neighbourhood: int = 11
    # UV methods: the longest side of the copy the textons and jump map are computed on (0 = the
    # sample's own resolution); the material still samples the full image. README "Preprocessing".
    working_size: int = 512
    tileable: bool = False
    # TEXTON: 0 blends every interior edge; > 0 only edges whose blending metric Φ = λ·E_t·d/|camera - m|
    # (λ = render width in pixels / camera field of view, so Φ ≈ colour error × edge length in pixels)
    # exceeds it. Needs a scene camera.
    blend_threshold: float = 0.0
    # Surface-colour methods: IMAGE = texels of an image through a UV map (bake options give image,
    # UV map, size, margin), VERTICES = a FLOAT_COLOR vertex attribute of a dense mesh.
    surface_target: str = "IMAGE"
    round_levels: int = 3           # pyramid levels on the surface (paper §6)
    round_coarse_rings: int = 4     # neighbourhood radius in rings at the coarsest level
    round_fine_rings: int = 2       # ... and at the finer levels
    round_candidates: int = 2       # random candidates per point at the coarsest level
    # AUTO: a sample finer than the target is reduced to the target's density first (surface_colour/core.py)
    round_resolution: str = "AUTO"
    patch_mode: str = "SAMPLING"
    patch_size: int = 32            # w_B, a multiple of 4
    patch_boundary: int = 4         # W_E: the boundary zone matched and cross-faded
    patch_tolerance: float = 1.2    # candidates within this factor of the best match are equally likely
    patch_iterations: int = 6       # OPTIMISATION: EM iterations (the last one a discrete vote)
    # PARTICLES (particles/core.py): segmentation, then placement and output.
    particle_classes: int = 4        # k-means classes (ignored with a label image)
    particle_blur: float = 1.0       # Gaussian sigma in sample pixels before k-means
    particle_min_area: int = 0       # smaller components join the background; 0 = max(16 px, 0.02 %)
    particle_background_class: int = -1  # -1: the largest class
    particle_merges: tuple = ()      # ((a, b), ...): k-means class a joins class b, applied in order
    particle_class_order: tuple = () # placement order of class ids; () = by decreasing particle count
    particle_output: str = "DECALS"
    particle_collection: str = ""    # INSTANCES / BOTH: the collection whose objects are instanced per class
    particle_size_jitter: float = 0.0
    # Per-face overrides: a FLOAT face attribute or a vertex group of that name ('' = none).
    particle_density_source: str = ""
    particle_probability_source: str = ""
    particle_size_source: str = ""
    particle_background: str = "JUMPMAP"

    def validate(self):
        """Raises SettingsError naming the first bad setting; returns self."""
        if self.method not in METHODS:
            raise SettingsError("unknown method %r (choose one of %s)" % (self.method, ", ".join(METHODS)))
        if self.method not in IMPLEMENTED_METHODS:
            raise SettingsError("method %r is not implemented yet; use JUMPMAP" % self.method)
        if not _finite_positive(self.sample_world_size):
            raise SettingsError("scale must be a positive world size of the sample, got %r" % (self.sample_world_size,))
        if not isinstance(self.seed, int) or isinstance(self.seed, bool) or self.seed < 0 or self.seed >= 2 ** 63:
            raise SettingsError("seed must be an integer in [0, 2^63), got %r" % (self.seed,))
        if not (_finite(self.jump_rate) and self.jump_rate >= 0.0):
            raise SettingsError("jump rate must be a finite number >= 0, got %r" % (self.jump_rate,))
        if self.orientation not in ORIENTATIONS:
            raise SettingsError("unknown orientation %r (choose one of %s)" % (self.orientation, ", ".join(ORIENTATIONS)))
        if self.orientation == "AXIS":
            axis = np.asarray(self.axis, dtype=np.float64)
            if axis.shape != (3,) or not np.all(np.isfinite(axis)) or np.linalg.norm(axis) < 1e-12:
                raise SettingsError("orientation axis must be a finite non-zero 3D vector, got %r" % (tuple(self.axis),))
        elif not self.direction_attribute:
            raise SettingsError("orientation %s needs the name of a vector attribute on the mesh" % self.orientation)
        if self.blend_mode not in BLEND_MODES:
            raise SettingsError("unknown blend mode %r (choose one of %s)" % (self.blend_mode, ", ".join(BLEND_MODES)))
        if not (_finite(self.blend_threshold) and self.blend_threshold >= 0.0):
            raise SettingsError("blend threshold must be a finite number >= 0, got %r" % (self.blend_threshold,))
        if self.scale_source not in SCALE_SOURCES:
            raise SettingsError("unknown scale source %r (choose one of %s)" % (self.scale_source, ", ".join(SCALE_SOURCES)))
        if self.scale_source == "ATTRIBUTE" and not self.scale_attribute:
            raise SettingsError("scale source ATTRIBUTE needs the name of a float vertex attribute")
        if self.scale_source == "VERTEX_GROUP":
            if not self.scale_group:
                raise SettingsError("scale source VERTEX_GROUP needs a vertex group name")
            if not (_finite_positive(self.scale_min) and _finite_positive(self.scale_max)):
                raise SettingsError("scale range must be two positive numbers, got (%r, %r)" % (self.scale_min, self.scale_max))
        if not isinstance(self.neighbourhood, int) or self.neighbourhood < 3 or self.neighbourhood % 2 == 0:
            raise SettingsError("neighbourhood must be an odd integer >= 3, got %r" % (self.neighbourhood,))
        low, high = WORKING_SIZE_RANGE
        if not _is_int(self.working_size) or not (self.working_size == 0 or low <= self.working_size <= high):
            raise SettingsError("analysis size must be 0 (the sample's own) or an integer in [%d, %d], got %r"
                                % (low, high, self.working_size))
        if self.method in SURFACE_METHODS:
            if self.surface_target not in SURFACE_TARGETS:
                raise SettingsError("unknown target %r (choose one of %s)"
                                    % (self.surface_target, ", ".join(SURFACE_TARGETS)))
            if self.round_resolution not in ROUND_RESOLUTIONS:
                raise SettingsError("unknown synthesis resolution %r (choose one of %s)"
                                    % (self.round_resolution, ", ".join(ROUND_RESOLUTIONS)))
            for name, (low, high) in (("round_levels", ROUND_LEVEL_RANGE), ("round_coarse_rings", ROUND_RING_RANGE),
                                      ("round_fine_rings", ROUND_RING_RANGE),
                                      ("round_candidates", ROUND_CANDIDATE_RANGE)):
                value = getattr(self, name)
                if not isinstance(value, int) or isinstance(value, bool) or not low <= value <= high:
                    raise SettingsError("%s must be an integer in [%d, %d], got %r"
                                        % (name.replace("_", " "), low, high, value))
        if self.method == "PATCHES":
            self._validate_patches()
        if self.method == "PARTICLES":
            self._validate_particles()
        return self

    def _validate_particles(self):
        low, high = PARTICLE_CLASS_RANGE
        if not _is_int(self.particle_classes) or not low <= self.particle_classes <= high:
            raise SettingsError("particle classes must be an integer in [%d, %d], got %r"
                                % (low, high, self.particle_classes))
        if not (_finite(self.particle_blur) and 0.0 <= self.particle_blur <= PARTICLE_MAX_BLUR):
            raise SettingsError("segmentation blur must be a number in [0, %g] pixels, got %r"
                                % (PARTICLE_MAX_BLUR, self.particle_blur))
        if not _is_int(self.particle_min_area) or self.particle_min_area < 0:
            raise SettingsError("minimum particle area must be an integer >= 0 pixels (0 = automatic), got %r"
                                % (self.particle_min_area,))
        if not _is_int(self.particle_background_class) or self.particle_background_class < -1:
            raise SettingsError("background class must be a class id or -1 (largest class), got %r"
                                % (self.particle_background_class,))
        for pair in self.particle_merges:
            if (len(pair) != 2 or not all(_is_int(c) and c >= 0 for c in pair) or pair[0] == pair[1]):
                raise SettingsError("a class merge must be two different class ids, got %r" % (pair,))
        order = list(self.particle_class_order)
        if not all(_is_int(c) and c >= 0 for c in order) or len(set(order)) != len(order):
            raise SettingsError("class order must list distinct class ids, got %r" % (tuple(order),))
        if self.particle_output not in PARTICLE_OUTPUTS:
            raise SettingsError("unknown particle output %r (choose one of %s)"
                                % (self.particle_output, ", ".join(PARTICLE_OUTPUTS)))
        if self.particle_output != "DECALS" and not self.particle_collection:
            raise SettingsError("particle output %s needs an instance collection (the objects placed per class)"
                                % self.particle_output)
        if not (_finite(self.particle_size_jitter) and 0.0 <= self.particle_size_jitter <= PARTICLE_MAX_JITTER):
            raise SettingsError("size jitter must be a number in [0, %g], got %r"
                                % (PARTICLE_MAX_JITTER, self.particle_size_jitter))
        if self.particle_background not in PARTICLE_BACKGROUNDS:
            raise SettingsError("unknown particle background %r (choose one of %s)"
                                % (self.particle_background, ", ".join(PARTICLE_BACKGROUNDS)))

    def _validate_patches(self):
        if self.patch_mode not in PATCH_MODES:
            raise SettingsError("unknown patch mode %r (choose one of %s)" % (self.patch_mode, ", ".join(PATCH_MODES)))
        low, high = PATCH_SIZE_RANGE
        if not _is_int(self.patch_size) or not low <= self.patch_size <= high or self.patch_size % 4:
            raise SettingsError("patch size must be a multiple of 4 in [%d, %d] sample pixels, got %r"
                                % (low, high, self.patch_size))
        low, high = PATCH_BOUNDARY_RANGE[0], max_patch_boundary(self.patch_size)
        if not _is_int(self.patch_boundary) or not low <= self.patch_boundary <= high:
            raise SettingsError("boundary width must be an integer in [%d, %d] (at most half the patch size), got %r"
                                % (low, high, self.patch_boundary))
        low, high = PATCH_TOLERANCE_RANGE
        if not (_finite(self.patch_tolerance) and low <= self.patch_tolerance <= high):
            raise SettingsError("tolerance must be a number in [%g, %g], got %r" % (low, high, self.patch_tolerance))
        low, high = PATCH_ITERATION_RANGE
        if not _is_int(self.patch_iterations) or not low <= self.patch_iterations <= high:
            raise SettingsError("iterations must be an integer in [%d, %d], got %r" % (low, high, self.patch_iterations))

    def resolved_blend_mode(self):
        return AUTO_BLEND_MODE.get(self.method, "HISTOGRAM") if self.blend_mode == "AUTO" else self.blend_mode

    def preprocess_params(self):
        """Keyword arguments of texsynth_native.preprocess / cache_status that key the cache."""
        return {"neighbourhood": self.neighbourhood, "tileable": bool(self.tileable), "seed": 0,
                "working_size": int(self.working_size)}


def max_patch_boundary(patch_size):
    """The widest boundary zone patches of this size take (native: 1 .. patch_size / 2)."""
    return min(PATCH_BOUNDARY_RANGE[1], int(patch_size) // 2)


def check_patch_boundary(boundary, level_sizes):
    """SettingsError (naming the setting and its largest value here) unless `boundary` is at most half of
    every level's patch size (level_sizes: the module's patch_level_sizes, the plan the synthesis runs)."""
    smallest = min(range(len(level_sizes)), key=lambda level: level_sizes[level][2])
    width, height, patch = level_sizes[smallest]
    if boundary <= max_patch_boundary(patch):
        return
    where = ("the %d x %d working sample only holds %d px patches" % (width, height, patch) if smallest == 0 else
             "optimisation level %d analyses the sample halved to %d x %d, which only holds %d px patches"
             % (smallest + 1, width, height, patch))
    raise SettingsError("Boundary %d is more than half the patch size used: %s; set Boundary to at most %d "
                        "(CLI --boundary-width)" % (boundary, where, max_patch_boundary(patch)))


def _is_int(value):
    return isinstance(value, int) and not isinstance(value, bool)


def _finite(value):
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def _finite_positive(value):
    return _finite(value) and value > 0.0


def texels_per_unit(sample_width, sample_world_size):
    """Native `scale` (texels per world unit) for a sample whose width spans sample_world_size units."""
    if not (isinstance(sample_width, (int, np.integer)) and sample_width > 0):
        raise SettingsError("sample width must be a positive integer, got %r" % (sample_width,))
    if not _finite_positive(float(sample_world_size)):
        raise SettingsError("scale must be a positive world size of the sample, got %r" % (sample_world_size,))
    return float(sample_width) / float(sample_world_size)


def object_seed(seed, object_name):
    """Per-object seed from (seed, name): stable whatever the selection order, distinct per object."""
    return (int(seed) * 0x9E3779B1 + zlib.crc32(object_name.encode("utf-8"))) % (2 ** 63)


def default_cache_dir(base):
    """Cache folder under a Blender user resource folder (or any base folder)."""
    return os.path.join(base, "texsynth")


def blender_pixels_to_image(flat_pixels, width, height, channels):
    """Blender's bottom-up float RGBA(...) pixel buffer -> contiguous float32 H x W x C, row 0 = top."""
    pixels = np.asarray(flat_pixels, dtype=np.float32)
    if width <= 0 or height <= 0 or channels <= 0 or pixels.size != width * height * channels:
        raise SettingsError("image buffer has %d values, expected %d x %d x %d"
                            % (pixels.size, width, height, channels))
    if not np.all(np.isfinite(pixels)):
        raise SettingsError("image contains NaN or infinite pixel values")
    return np.ascontiguousarray(pixels.reshape(height, width, channels)[::-1])


# ---------------------------------------------------------------------------------------------
# Timings and reports


class Timings:
    """Accumulates wall-clock seconds per phase: `with timings.phase("synthesis"): ...`.
    transfer = read + write (bpy mesh I/O)."""
    PHASES = ("preprocess", "read", "synthesis", "write", "material")

    def __init__(self):
        self.seconds = {name: 0.0 for name in self.PHASES}
        self._start = time.perf_counter()

    def phase(self, name):
        timings = self

        class _Phase:
            def __enter__(self):
                self.start = time.perf_counter()

            def __exit__(self, *exc):
                timings.seconds[name] = timings.seconds.get(name, 0.0) + time.perf_counter() - self.start
                return False
        return _Phase()

    def as_dict(self):
        result = dict(self.seconds)
        result["transfer"] = result["read"] + result["write"]
        result["total"] = time.perf_counter() - self._start
        return result


@dataclasses.dataclass
class Report:
    """What one run did and could not do (shown by the operator, written by the CLI)."""
    objects: list = dataclasses.field(default_factory=list)     # names written
    failures: list = dataclasses.field(default_factory=list)    # (name, message)
    faces: int = 0
    vertices: int = 0
    corners: int = 0
    cache_hit: bool = False
    cache_status: str = ""
    native_stats: dict = dataclasses.field(default_factory=dict)  # per object name
    seconds: dict = dataclasses.field(default_factory=dict)
    blend_mode: str = ""   # the shader's blend mode actually used
    blend_reason: str = ""  # why Auto chose it
    notes: list = dataclasses.field(default_factory=list)       # warnings that did not stop the run
    outputs: list = dataclasses.field(default_factory=list)     # what was made (images, attributes)
    uses_cache: bool = True  # surface-colour methods use the sample directly (no preprocessing cache)

    def add_object(self, name, mesh_arrays, stats):
        self.objects.append(name)
        self.faces += mesh_arrays.num_faces
        self.vertices += mesh_arrays.num_vertices
        self.corners += mesh_arrays.num_corners
        self.native_stats[name] = dict(stats or {})

    def summary(self):
        if not self.objects and self.failures:
            return "TexSynth: nothing written; " + "; ".join("%s: %s" % f for f in self.failures)
        total = self.seconds.get("total", 0.0)
        text = "TexSynth: %d object(s), %d faces in %.2f s" % (len(self.objects), self.faces, total)
        if self.uses_cache:
            text += " (cache %s)" % ("hit" if self.cache_hit else "miss")
        if self.blend_reason:
            text += "; %s blending (%s)" % (self.blend_mode.lower(), self.blend_reason)
        if self.outputs or self.notes:
            text += "; " + "; ".join(self.outputs + self.notes)
        if self.failures:
            text += "; %d failed: %s" % (len(self.failures), "; ".join("%s: %s" % f for f in self.failures))
        return text

    def as_json(self):
        return {
            "objects": list(self.objects),
            "failures": [{"object": name, "error": message} for name, message in self.failures],
            "faces": self.faces, "vertices": self.vertices, "corners": self.corners,
            "cache_hit": bool(self.cache_hit), "cache_status": self.cache_status,
            "seconds": dict(self.seconds), "native": self.native_stats,
            "blend_mode": self.blend_mode, "blend_reason": self.blend_reason, "notes": list(self.notes),
            "outputs": list(self.outputs),
        }


# ---------------------------------------------------------------------------------------------
# Mesh arrays and layer planning


@dataclasses.dataclass
class MeshArrays:
    """A mesh in Blender's layout, world space, ready for the native module."""
    positions: np.ndarray          # (N,3) float32
    corner_verts: np.ndarray       # (L,) int32
    poly_starts: np.ndarray        # (P,) int32
    poly_sizes: np.ndarray         # (P,) int32
    direction: np.ndarray = None   # (N,3) float32, world space (FIELD / ANCHORS)
    scale_multiplier: np.ndarray = None  # (N,) float32 > 0, or None

    @property
    def num_vertices(self):
        return int(self.positions.shape[0])

    @property
    def num_corners(self):
        return int(self.corner_verts.shape[0])

    @property
    def num_faces(self):
        return int(self.poly_starts.shape[0])


def is_texsynth_uv_name(name):
    """TexSynth's UV map, or a blend-set UV map of an older TexSynth (TexSynth_B0..B3)."""
    if name == BASE_UV_NAME:
        return True
    suffix = name[len(LEGACY_BLEND_UV_PREFIX):]
    return name.startswith(LEGACY_BLEND_UV_PREFIX) and suffix.isdigit()


def check_uv_capacity(existing_names):
    """Raises SettingsError when the mesh has no room for TexSynth's one UV map (its own are replaced)."""
    foreign = [name for name in existing_names if not is_texsynth_uv_name(name)]
    if len(foreign) + 1 > MAX_UV_LAYERS:
        raise SettingsError(
            "mesh has %d other UV maps (%s) and Blender allows at most %d: remove one so TexSynth can add its UV map"
            % (len(foreign), ", ".join(foreign), MAX_UV_LAYERS))


# ---------------------------------------------------------------------------------------------
# Native calls


def load_sample(sample):
    """A file path (str) or an H x W x C image array (row 0 = top); returns what preprocess accepts."""
    if isinstance(sample, str):
        if not sample:
            raise SettingsError("no sample image given")
        if not os.path.isfile(sample):
            raise SettingsError("sample image not found: %s" % sample)
        return sample
    array = np.asarray(sample)
    if array.ndim != 3 or array.shape[0] < 1 or array.shape[1] < 1 or array.shape[2] not in (1, 2, 3, 4):
        raise SettingsError("sample image array must be H x W x C with C in 1..4, got shape %s" % (array.shape,))
    return np.ascontiguousarray(array, dtype=np.float32) if array.dtype != np.uint8 else np.ascontiguousarray(array)


def cache_status(sample, settings, cache_dir):
    """'fresh' | 'missing' | 'stale' for the sample's cached preprocessing."""
    module = native.require()
    return module.cache_status(load_sample(sample), cache_dir=cache_dir, **settings.preprocess_params())


def preprocess(sample, settings, cache_dir, cancel=None):
    """Preprocessed sample (from the cache when fresh). Errors: SettingsError/ValueError with a message.
    cancel: a texsynth_native.CancelToken (the call then raises texsynth_native.Cancelled when raised)."""
    module = native.require()
    if cache_dir:
        os.makedirs(cache_dir, exist_ok=True)
    extra = {} if cancel is None else {"cancel": cancel}
    return module.preprocess(load_sample(sample), cache_dir=cache_dir or None, **settings.preprocess_params(), **extra)


def sample_size(native_input):
    """(width, height) of a sample path (header only, nothing decoded) or H x W x C array."""
    if isinstance(native_input, str):
        info = native.require().image_info(native_input)
        return int(info["width"]), int(info["height"])
    shape = np.shape(native_input)
    return int(shape[1]), int(shape[0])


def sample_pixels(native_input):
    """The sample as float32 H x W x C (what synthesize_texton needs for E_t): decodes a path."""
    if isinstance(native_input, str):
        return native.require().load_image(native_input)
    array = np.asarray(native_input)
    if array.dtype == np.uint8:
        return np.ascontiguousarray(array, dtype=np.float32) / np.float32(255.0)
    return np.ascontiguousarray(array, dtype=np.float32)


def srgb_to_linear(values):
    """The sRGB transfer function inverted (what Blender does to an sRGB image before shading)."""
    values = np.asarray(values, dtype=np.float64)
    return np.where(values <= 0.04045, values / 12.92, ((np.maximum(values, 0.04045) + 0.055) / 1.055) ** 2.4)


def shader_mean(pixels, srgb, rows_per_chunk=128):
    """Mean colour (3 values) of an H x W x C sample as Blender's shaders read it: sRGB decoded when
    the image is sRGB; grey images repeat their one channel. Row chunks in float32, sums in float64:
    an 8K sample took 33 s and 5 GB as one float64 array, now about 2 s and a few MB."""
    pixels = np.asarray(pixels)
    channels = pixels.shape[2]
    used = 1 if channels <= 2 else 3
    total = np.zeros(used)
    for top in range(0, pixels.shape[0], rows_per_chunk):
        chunk = np.asarray(pixels[top:top + rows_per_chunk, :, :used], dtype=np.float32)
        if srgb:
            linear = chunk / np.float32(12.92)
            bright = chunk > np.float32(0.04045)
            linear[bright] = ((chunk[bright] + np.float32(0.055)) / np.float32(1.055)) ** np.float32(2.4)
            chunk = linear
        total += chunk.reshape(-1, used).astype(np.float64).sum(axis=0)
    mean = total / max(1, pixels.shape[0] * pixels.shape[1])
    return tuple(float(m) for m in (np.repeat(mean, 3) if used == 1 else mean))


def _autocorrelation(pixels, max_side):
    """Circular autocorrelation (by FFT) of a centred crop of max_side texels, colour channels
    standardised and averaged; None when every channel is constant."""
    pixels = np.asarray(pixels)
    top, left = max(0, (pixels.shape[0] - max_side) // 2), max(0, (pixels.shape[1] - max_side) // 2)
    pixels = pixels[top:top + max_side, left:left + max_side].astype(np.float64)
    colour = pixels[:, :, :1] if pixels.shape[2] <= 2 else pixels[:, :, :3]
    total = np.zeros(colour.shape[:2])
    used = 0
    for c in range(colour.shape[2]):
        channel = colour[:, :, c] - colour[:, :, c].mean()
        power = np.abs(np.fft.rfft2(channel)) ** 2
        auto = np.fft.irfft2(power, s=channel.shape)
        if auto[0, 0] > 1e-12:
            total += auto / auto[0, 0]
            used += 1
    return total / used if used else None


def periodicity(pixels, max_side=512):
    """The sample's largest autocorrelation at offsets beyond a quarter of its width or height (the
    render benchmark's repetition measure): ~0.95 for bricks, ~0.1 for moss or bark. 0 if constant."""
    total = _autocorrelation(pixels, max_side)
    if total is None:
        return 0.0
    height, width = total.shape
    dy = np.minimum(np.arange(height), height - np.arange(height))[:, None]
    dx = np.minimum(np.arange(width), width - np.arange(width))[None, :]
    far = (dx > width // 4) | (dy > height // 4)
    return float(total[far].max()) if far.any() else 0.0


def correlation_length(pixels, max_lag=64, max_side=512):
    """Correlation length (texels) of an H x W x C sample: the smallest offset along x or y at which
    its autocorrelation (colour channels standardised and averaged; circular, by FFT) falls below
    exp(-1/2), the value a Gaussian autocorrelation exp(-d^2 / (2 l^2)) has at d = l. Constant
    samples give 1. Lags go up to max_lag, so a centred crop of max_side texels is enough: a 4K
    sample would otherwise cost seconds and GBs of FFT buffers on every run."""
    total = _autocorrelation(pixels, max_side)
    if total is None:
        return 1.0
    height, width = total.shape
    threshold = math.exp(-0.5)
    for lag in range(1, max(2, min(max_lag, width // 2, height // 2))):
        if min(total[0, lag], total[lag, 0]) < threshold:
            # Linear interpolation between lag - 1 and lag on the axis that crossed first.
            row = total[0, lag - 1:lag + 1] if total[0, lag] < threshold else total[lag - 1:lag + 1, 0]
            return float(lag - 1 + (row[0] - threshold) / max(row[0] - row[1], 1e-12))
    return float(max_lag)


def interpolation_fidelity(pixels, gaussian, inverse_lut, shift=0.5, max_side=256):
    """How much luminance gradient survives when the sample is interpolated in Gaussianized space
    (as the histogram blend's texture look-ups do) instead of in colour space: mean |grad L| of the
    image resampled half a texel off in both axes through the Gaussian image and the inverse table,
    divided by the same resampling of the sample itself. Near 1 for most samples; well below 1 when
    the histogram is skewed (moss: rare bright speckles shrink, 0.93), where a render through the
    histogram blend loses that much detail (measured in README, "Blending"). Centred crop of max_side."""
    def crop(a):
        a = np.asarray(a, dtype=np.float64)
        top, left = max(0, (a.shape[0] - max_side) // 2), max(0, (a.shape[1] - max_side) // 2)
        a = a[top:top + max_side, left:left + max_side]
        return a[:, :, :1] if a.shape[2] <= 2 else a[:, :, :3]

    def resample(a):
        f = float(shift)
        return ((1 - f) * (1 - f) * a[:-1, :-1] + f * (1 - f) * (a[1:, :-1] + a[:-1, 1:]) + f * f * a[1:, 1:])

    def gradient(colour):
        lum = colour.mean(axis=2) if colour.shape[2] != 3 else colour @ np.array([0.2126, 0.7152, 0.0722])
        return float(np.hypot(np.diff(lum, axis=1)[:-1], np.diff(lum, axis=0)[:, :-1]).mean())

    colour, gauss = crop(pixels), crop(gaussian)
    table = np.asarray(inverse_lut, dtype=np.float64).reshape(-1, np.shape(inverse_lut)[-1])
    size = table.shape[0]
    shifted = resample(gauss)
    looked_up = np.empty_like(shifted)
    entries = np.arange(size)
    for c in range(shifted.shape[2]):
        position = np.clip(shifted[..., c] * size - 0.5, 0, size - 1)
        looked_up[..., c] = np.interp(position.ravel(), entries, table[:, min(c, table.shape[1] - 1)]).reshape(position.shape)
    reference = gradient(resample(colour))
    return gradient(looked_up) / reference if reference > 1e-9 else 1.0


@dataclasses.dataclass
class HistogramFiles:
    """The Gaussianized sample and its inverse look-up table, as files next to the cache."""
    gaussian_path: str
    lut_path: str


@dataclasses.dataclass
class BlendShading:
    """What the shader's blend needs from the sample (see blend_groups.BlendInputs)."""
    mode: str = "LINEAR"
    mean: tuple = (0.5, 0.5, 0.5)
    files: HistogramFiles = None
    correlation_length: float = 1.0  # texels, of the image the blend reads (Gaussianized for HISTOGRAM)
    note: str = ""                   # why HISTOGRAM fell back to VARIANCE, if it did (a warning)
    reason: str = ""                 # why Auto chose the mode (information)
    means: dict = None               # VARIANCE: {srgb: mean} for both readings of the sample

    def with_colour_space(self, srgb):
        """Picks the mean for how Blender reads the image (known once the bpy image is loaded)."""
        if self.means:
            self.mean = self.means[bool(srgb)]
        return self


def blend_shading(native_input, settings, cache_dir, srgb=None):
    """BlendShading for the sample: the Gaussianization is computed (or read from the cache) for
    HISTOGRAM; a sample it cannot serve falls back to VARIANCE, and `note` says why. Without `srgb`
    (the bpy image not loaded yet: it is only loaded once the native calls accepted the file) both
    means are kept; with_colour_space picks one."""
    if not settings.blend:
        return BlendShading()
    result = BlendShading(mode=settings.resolved_blend_mode())
    decoded = []  # the sample's pixels, decoded once for whichever measurements need them

    def pixels():
        if not decoded:
            decoded.append(sample_pixels(native_input))
        return decoded[0]

    if settings.blend_mode == "AUTO" and settings.method == "TEXTON":
        repeat = periodicity(pixels())
        result.mode = "LINEAR" if repeat >= AUTO_TEXTON_LINEAR_PERIODICITY else "VARIANCE"
        result.reason = "Auto: %s sample, periodicity %.2f" % (
            "periodic" if result.mode == "LINEAR" else "stochastic", repeat)
    looked_up = None
    if result.mode == "HISTOGRAM":
        width, height = sample_size(native_input)
        if width * height > HISTOGRAM_MAX_PIXELS:
            # Its Gaussianized float copy (and the EXR Blender would load) is capped at 4096²; 8K samples
            # are accepted by the analysis (working size), so they blend with the variance-preserving mode.
            result.mode = "VARIANCE"
            result.note = ("histogram-preserving blending unavailable (the sample is %dx%d, above its 4096x4096 "
                           "limit): variance-preserving used" % (width, height))
    if result.mode == "HISTOGRAM":
        transform = native.require().histogram_transform(load_sample(native_input), cache_dir=cache_dir)
        fidelity = 1.0
        if transform["ok"] and settings.blend_mode == "AUTO" and transform.get("gaussian") is not None:
            fidelity = interpolation_fidelity(pixels(), transform["gaussian"], transform["inverse_lut"])
        if transform["ok"] and fidelity >= AUTO_HISTOGRAM_MIN_FIDELITY:
            result.files = HistogramFiles(transform["gaussian_path"], transform["lut_path"])
            looked_up = transform.get("gaussian")
        elif transform["ok"]:
            result.mode = "VARIANCE"
            result.reason = "Auto: the histogram transform keeps %.0f %% of this sample's detail" % (100.0 * fidelity)
        else:
            result.mode = "VARIANCE"
            result.note = "histogram-preserving blending unavailable (%s): variance-preserving used" % (
                transform["fallback_reason"])
    if result.mode == "VARIANCE":
        looked_up = pixels()
        result.means = {space: shader_mean(looked_up, space) for space in (False, True)}
        result.with_colour_space(bool(srgb))
    if looked_up is not None and np.ndim(looked_up) == 3:
        result.correlation_length = correlation_length(looked_up)
    return result


@dataclasses.dataclass
class View:
    """The scene camera for the blending metric: world position and λ (pixels per radian)."""
    position: tuple
    pixels_per_radian: float


def synthesize(preprocessed, mesh_arrays, settings, seed, scale, pixels=None, view=None, cancel=None):
    """Runs the native synthesizer on one mesh; returns its dict after checking every shape.
    TEXTON needs `pixels` (sample_pixels) and, with a blend threshold, `view`. cancel: a
    texsynth_native.CancelToken, as for preprocess()."""
    module = native.require()
    if mesh_arrays.num_faces == 0:
        raise SettingsError("mesh has no faces")
    # pack_sets: blend sets come back as blend_set_pairs, the layout of the RGBA set attributes.
    kwargs = dict(scale=float(scale), seed=int(seed), pack_sets=True,
                  blend=bool(settings.blend), allow_oversized=bool(settings.allow_oversized))
    if settings.orientation == "AXIS":
        kwargs.update(orientation="axis", axis=tuple(float(c) for c in settings.axis))
    elif settings.orientation == "FIELD":
        kwargs.update(orientation="field", direction=_require_direction(mesh_arrays, settings))
    else:
        direction = _require_direction(mesh_arrays, settings)
        anchors = np.flatnonzero(np.linalg.norm(direction, axis=1) > 1e-12).astype(np.int32)
        if anchors.size == 0:
            raise SettingsError("attribute %r has no non-zero vectors: no anchors" % settings.direction_attribute)
        kwargs.update(orientation="anchors", anchor_vertices=anchors,
                      anchor_directions=np.ascontiguousarray(direction[anchors]))
    if mesh_arrays.scale_multiplier is not None:
        kwargs.update(scale_multiplier=mesh_arrays.scale_multiplier)
    mesh = (mesh_arrays.positions, mesh_arrays.corner_verts, mesh_arrays.poly_starts, mesh_arrays.poly_sizes)
    if cancel is not None:
        kwargs.update(cancel=cancel)
    if settings.method == "TEXTON":
        if pixels is None:
            raise SettingsError("the texton method needs the sample pixels")
        if view is not None:
            kwargs.update(camera_position=tuple(float(c) for c in view.position),
                          lambda_=float(view.pixels_per_radian))
        if settings.blend_threshold > 0.0:
            if view is None:
                raise SettingsError("a blend threshold needs a scene camera (the blending metric is view-dependent)")
            kwargs.update(blend_threshold=float(settings.blend_threshold))
        result = dict(module.synthesize_texton(preprocessed, pixels, *mesh, **kwargs))
        result["corner_attributes"] = {
            EDGE_BLENDED_NAME: np.asarray(result.pop("corner_edge_blended"), dtype=np.float32),
            EDGE_ERROR_NAME: np.asarray(result.pop("corner_edge_error"), dtype=np.float32)}
        if settings.blend and int(result["num_blend_sets"]):
            check_result(result, int(mesh_arrays.corner_verts.size))
            result["mapping_groups"] = mapping_groups_rgba(result, mesh_arrays.poly_starts, mesh_arrays.poly_sizes)
    else:
        kwargs.update(jump_rate=float(settings.jump_rate))
        result = dict(module.synthesize_jumpmap(preprocessed, *mesh, **kwargs))
    if not settings.blend:
        # Without blending the native single set is the base mapping with weight 1: write the base only.
        result.update(num_blend_sets=0, blend_uv=None, blend_set_pairs=None, blend_weights=None)
    return result  # validated by mesh_io.write_result before anything is written


def _require_direction(mesh_arrays, settings):
    if mesh_arrays.direction is None:
        raise SettingsError("mesh has no vector attribute %r for the orientation" % settings.direction_attribute)
    return mesh_arrays.direction


def check_result(result, num_corners, finite=True):
    """Validates a synthesizer result before anything is written (so a bad one changes nothing).
    finite=False checks shapes and dtypes only (the caller scans for NaN/inf with FiniteScan)."""
    base = result["base_uv"]
    sets = int(result["num_blend_sets"])
    if not (0 <= sets <= MAX_BLEND_SETS):
        raise SettingsError("native result has %d blend sets (at most %d supported)" % (sets, MAX_BLEND_SETS))
    expected = {"base_uv": (num_corners, 2)}
    if sets:
        expected.update(blend_weights=(num_corners, sets))
        if result.get("blend_set_pairs") is not None:
            expected.update(blend_set_pairs=((sets + 1) // 2, num_corners, 4))
        else:
            expected.update(blend_uv=(sets, num_corners, 2))
    for key, shape in expected.items():
        array = result[key]
        if array.shape != shape or array.dtype != np.float32:
            raise SettingsError("native result %s has shape %s %s, expected %s float32"
                                % (key, array.shape, array.dtype, shape))
        if finite and not all_finite(array):
            raise SettingsError("native result %s contains NaN or infinite values" % key)
    return base


def all_finite(array):
    """True if no NaN/inf, in one pass with no temporary the size of the array (np.isfinite would
    allocate one: hundreds of MB of fresh pages on big meshes). NaN and inf survive a sum, so a
    finite sum proves every value finite; only a sum that overflowed from finite values (never
    for UVs and weights) needs the exact min/max scan."""
    if array.size == 0:
        return True
    with np.errstate(over="ignore", invalid="ignore"):  # an inf or NaN sum is an answer, not a warning
        if np.isfinite(np.add.reduce(array, axis=None)):
            return True
    return bool(np.isfinite(array.min()) and np.isfinite(array.max()))


class FiniteScan:
    """all_finite over named arrays in a worker thread: numpy reductions release the GIL, so the scan
    (hundreds of MB on a million-face mesh) runs while the main thread writes the layers. The arrays
    must not change until wait() returns; wait() gives the first array that is not finite, or None."""

    def __init__(self, named_arrays):
        self.bad = None
        self.error = None
        self.thread = threading.Thread(target=self._run, args=(list(named_arrays),), name="TexSynth finite scan",
                                       daemon=True)
        self.thread.start()

    def _run(self, named_arrays):
        try:
            for name, array in named_arrays:
                if not all_finite(array):
                    self.bad = name
                    return
        except BaseException as error:  # re-raised by wait() on the caller's thread
            self.error = error

    def wait(self):
        self.thread.join()
        if self.error is not None:
            raise self.error
        return self.bad


def corner_attributes(result, num_corners, finite=True):
    """The method's extra per-corner FLOAT attributes {name: (L,) float32}, checked before writing
    (finite=False: shapes and dtypes only)."""
    extras = result.get("corner_attributes") or {}
    for name, values in extras.items():
        if name not in EXTRA_ATTRIBUTE_NAMES:
            raise SettingsError("native result has an unknown corner attribute %r" % name)
        if values.shape != (num_corners,) or values.dtype != np.float32 or (finite and not all_finite(values)):
            raise SettingsError("native result %s must be finite float32 of shape (%d,)" % (name, num_corners))
    return extras


def mapping_groups_rgba(result, poly_starts, poly_sizes, tolerance=1e-6):
    """Texton blending's variance in four numbers per corner, as a flat float32 RGBA buffer.

    Per polygon, the blend sets fall into groups of identical mappings: group 0 = the sets equal to
    the polygon's own patch (the base mapping), groups 1..3 the other distinct mappings (a 4th
    distinct one, possible on quads only, shares group 3). A set k in group g adds its weight w_k to
    channel g. Groups are constant over a polygon and the weights are interpolated linearly, so the
    interpolated channels are the groups' total weights G_g anywhere inside it, and the shader gets
    the blend's variance, with identical mappings fully correlated and distinct ones independent, as
    (b + (1 - b) G_0)^2 + (1 - b)^2 (G_1^2 + G_2^2 + G_3^2) (b: the base's fade-in weight): a few
    nodes instead of the pairwise correlations (render cost). Alpha holds G_3 itself: a mesh without
    the attribute reads (0, 0, 0, 1), i.e. all set weight in one independent group, a safe variance."""
    sets = int(result["num_blend_sets"])
    weights = np.asarray(result["blend_weights"], dtype=np.float32)
    base = result["base_uv"]
    num_corners = base.shape[0]
    pairs = result.get("blend_set_pairs")
    set_uv = ([pairs[k // 2][:, 2 * (k % 2):2 * (k % 2) + 2] for k in range(sets)] if pairs is not None
              else [result["blend_uv"][k] for k in range(sets)])
    starts = np.asarray(poly_starts, dtype=np.int64)
    sizes = np.asarray(poly_sizes, dtype=np.int64)

    def per_polygon_all(flags):
        return np.logical_and.reduceat(flags, starts) if starts.size else np.zeros(0, bool)

    def same(a, b):
        return per_polygon_all(np.all(np.abs(a - b) <= tolerance, axis=1))

    used = [np.logical_or.reduceat(weights[:, k] > 0, starts) if starts.size else np.zeros(0, bool)
            for k in range(sets)]
    group = []
    next_id = np.ones(starts.size, np.int64)
    for k in range(sets):
        g = np.where(same(set_uv[k], base), 0, -1)
        for j in range(k):
            join = (g < 0) & used[j] & same(set_uv[j], set_uv[k])
            g[join] = group[j][join]
        new = (g < 0) & used[k]
        g[new] = np.minimum(next_id[new], 3)
        next_id[new] += 1
        group.append(np.maximum(g, 0))
    corner_poly = np.repeat(np.arange(starts.size), sizes)
    rgba = np.zeros((num_corners, 4), dtype=np.float32)
    rows = np.arange(num_corners)
    for k in range(sets):
        rgba[rows, group[k][corner_poly]] += weights[:, k]
    return rgba.ravel()


def blend_set_rgba(result, num_corners):
    """The blend-set coordinates as two flat float32 RGBA corner buffers: (u0, v0, u1, v1) and
    (u2, v2, u3, v3); unused sets (3-set results) are 0. Views of the native result when it came
    packed (blend_set_pairs), else a repacking copy."""
    sets = int(result["num_blend_sets"])
    pairs = result.get("blend_set_pairs")
    if pairs is not None:
        return [pairs[k].ravel() for k in range(2)] if pairs.shape[0] == 2 else \
            [pairs[0].ravel(), np.zeros(num_corners * 4, np.float32)]
    blend_uv = result["blend_uv"]
    buffers = []
    for first in (0, 2):
        rgba = np.zeros((num_corners, 2, 2), dtype=np.float32)
        for k in range(first, min(first + 2, sets)):
            rgba[:, k - first, :] = blend_uv[k]
        buffers.append(rgba.ravel())
    return buffers


def weights_rgba(result, num_corners, consume=False):
    """The blend weights as a flat float32 RGBA corner buffer: R, G, B = w0, w1, w2 and A = 1 - w3.

    Alpha holds 1 - w3 (not w3) because shaders read a missing attribute as (0, 0, 0, 1): a mesh
    without weights then gets all-zero weights and the node group falls back to the base mapping.
    Unused channels are 0 (alpha 1). consume=True (4 sets) converts result["blend_weights"] in place
    and takes it out of `result`, saving a corner-sized copy on big meshes."""
    sets = int(result["num_blend_sets"])
    weights = result["blend_weights"]
    if sets == 4 and consume and weights.dtype == np.float32 and weights.flags.c_contiguous and weights.flags.writeable:
        result["blend_weights"] = None  # now RGBA: must not be read as weights again
        np.subtract(1.0, weights[:, 3], out=weights[:, 3])
        return weights.ravel()
    if sets == 4:  # one contiguous copy, then flip the alpha column
        rgba = np.array(weights, dtype=np.float32, order="C", copy=True)
        np.subtract(1.0, rgba[:, 3], out=rgba[:, 3])
        return rgba.ravel()
    rgba = np.zeros((num_corners, 4), dtype=np.float32)
    rgba[:, 3] = 1.0
    if sets:
        rgba[:, :sets] = result["blend_weights"]
    return rgba.ravel()

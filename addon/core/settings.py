# SPDX-License-Identifier: GPL-3.0-or-later
"""Settings of one Synthesize run, whichever interface filled them (panel or CLI), and their validation.
bpy-free: SettingsError names the setting and the value that would work."""
import dataclasses
import math
import numbers
import zlib


# The registered methods (methods.py fills these from each family's MethodSpec, in menu order): ids only,
# for the checks below and for callers that list them; validate() routes to each method's own check.
METHODS = []
UV_METHODS = []        # write coordinates into the sample + blend data (MethodSpec.writes_uv)
SURFACE_METHODS = []   # write a colour per surface sample (MethodSpec.colours_surface)
_METHOD_CHECKS = {}    # id -> validate(settings): the method's own settings, checked after the shared ones
SURFACE_TARGETS = ("IMAGE", "VERTICES")
# Preprocessing working size (native kMinWorkingSize / kMaxWorkingSize; 0 = off).
WORKING_SIZE_RANGE = (64, 4096)
# Round neighbourhoods: the native limits (round_synth.hpp) and the defaults the README measures.
ROUND_LEVEL_RANGE, ROUND_RING_RANGE, ROUND_CANDIDATE_RANGE = (1, 6), (1, 6), (0, 16)
ROUND_RESOLUTIONS = ("AUTO", "FULL")
# Vector-field patches (patches/patch_synth.hpp): SAMPLING pastes matched patches (paper §5), OPTIMISATION
# refines that result by texture optimisation (§4.3). Sizes in sample pixels. The UI properties take their
# ranges from here, before the native module is loaded; python_tests/native/test_native_module.py checks them
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
# Touching Elements: AUTO splits only where one region spans the sample (texture_particles.md "Touching elements").
PARTICLE_TOUCHING = ("AUTO", "ON", "OFF")
ORIENTATIONS = ("AXIS", "FIELD", "ANCHORS")
SCALE_SOURCES = ("NONE", "ATTRIBUTE", "VERTEX_GROUP")
BLEND_MODES = ("AUTO", "HISTOGRAM", "VARIANCE", "LINEAR")  # see blend_groups.py
# AUTO: what measured best per method, its MethodSpec.auto_blend_mode (uv_methods/method.py), else HISTOGRAM.
_AUTO_BLEND_MODES = {}
# Auto takes VARIANCE instead of HISTOGRAM when the sample keeps less of its detail than this through
# the histogram transform's interpolation (interpolation_fidelity; moss 0.93, bark 1.00, bricks 1.04).
AUTO_HISTOGRAM_MIN_FIDELITY = 0.97
# Largest sample histogram-preserving blending serves (texsynth_native.histogram_transform's image limit).
HISTOGRAM_MAX_PIXELS = 4096 * 4096
# Auto, texton: Linear for periodic samples (the search matches patches that continue the period, so
# blending them loses nothing and rescaling over-sharpens: bricks, periodicity 0.95), Variance for
# stochastic ones (matched only along the edge, nearly independent inside: moss 0.09, bark 0.10).
AUTO_TEXTON_LINEAR_PERIODICITY = 0.5


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
    # AUTO: a sample finer than the target is reduced to the target's density first (surface_colour/core.py working_sample)
    round_resolution: str = "AUTO"
    patch_mode: str = "SAMPLING"
    patch_size: int = 32            # w_B, a multiple of 4
    patch_boundary: int = 4         # W_E: the boundary zone matched and cross-faded
    patch_tolerance: float = 1.2    # candidates within this factor of the best match are equally likely
    patch_iterations: int = 6       # OPTIMISATION: EM iterations (each E-step a discrete vote)
    # PARTICLES (particles/core.py): segmentation, then placement and output.
    particle_classes: int = 4        # k-means classes (ignored with a label image)
    particle_blur: float = 1.0       # Gaussian sigma in sample pixels before k-means
    particle_min_area: int = 0       # smaller components join the background; 0 = max(16 px, 0.02 %)
    particle_touching: str = "AUTO"  # PARTICLE_TOUCHING: split touching elements (watershed); True / False = ON / OFF
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
    # Who reads the messages (core/messages.py INTERFACES): native advice is reworded in its terms.
    interface: str = "API"
    # Settings of a method whose family declares them itself (MethodFamily.option_defaults), by name: a new
    # method needs no field here. The families above keep theirs as fields (the panel's and CLI's names).
    method_options: dict = dataclasses.field(default_factory=dict)

    def validate(self):
        """Raises SettingsError naming the first bad setting; returns self."""
        if not _METHOD_CHECKS:
            raise SettingsError("no synthesis method is registered: import the add-on's methods.py first")
        if self.method not in _METHOD_CHECKS:
            raise SettingsError("unknown method %r (choose one of %s)" % (self.method, ", ".join(METHODS)))
        if not finite_positive(self.sample_world_size):
            raise SettingsError("scale must be a positive world size of the sample, got %r" % (self.sample_world_size,))
        if not isinstance(self.seed, int) or isinstance(self.seed, bool) or self.seed < 0 or self.seed >= 2 ** 63:
            raise SettingsError("seed must be an integer in [0, 2^63), got %r" % (self.seed,))
        if not (finite(self.jump_rate) and self.jump_rate >= 0.0):
            raise SettingsError("jump rate must be a finite number >= 0, got %r" % (self.jump_rate,))
        if self.orientation not in ORIENTATIONS:
            raise SettingsError("unknown orientation %r (choose one of %s)" % (self.orientation, ", ".join(ORIENTATIONS)))
        if self.orientation == "AXIS":
            try:
                axis = tuple(float(c) for c in self.axis)
            except (TypeError, ValueError):
                axis = ()
            if len(axis) != 3 or not all(math.isfinite(c) for c in axis) or math.sqrt(sum(c * c for c in axis)) < 1e-12:
                raise SettingsError("orientation axis must be a finite non-zero 3D vector, got %r" % (tuple(self.axis),))
        elif not self.direction_attribute:
            raise SettingsError("orientation %s needs the name of a vector attribute on the mesh" % self.orientation)
        if self.blend_mode not in BLEND_MODES:
            raise SettingsError("unknown blend mode %r (choose one of %s)" % (self.blend_mode, ", ".join(BLEND_MODES)))
        if not (finite(self.blend_threshold) and self.blend_threshold >= 0.0):
            raise SettingsError("blend threshold must be a finite number >= 0, got %r" % (self.blend_threshold,))
        if self.scale_source not in SCALE_SOURCES:
            raise SettingsError("unknown scale source %r (choose one of %s)" % (self.scale_source, ", ".join(SCALE_SOURCES)))
        if self.scale_source == "ATTRIBUTE" and not self.scale_attribute:
            raise SettingsError("scale source ATTRIBUTE needs the name of a float vertex attribute")
        if self.scale_source == "VERTEX_GROUP":
            if not self.scale_group:
                raise SettingsError("scale source VERTEX_GROUP needs a vertex group name")
            if not (finite_positive(self.scale_min) and finite_positive(self.scale_max)):
                raise SettingsError("scale range must be two positive numbers, got (%r, %r)" % (self.scale_min, self.scale_max))
        if not isinstance(self.neighbourhood, int) or self.neighbourhood < 3 or self.neighbourhood % 2 == 0:
            raise SettingsError("neighbourhood must be an odd integer >= 3, got %r" % (self.neighbourhood,))
        low, high = WORKING_SIZE_RANGE
        if not is_int(self.working_size) or not (self.working_size == 0 or low <= self.working_size <= high):
            raise SettingsError("analysis size must be 0 (the sample's own) or an integer in [%d, %d], got %r"
                                % (low, high, self.working_size))
        _METHOD_CHECKS[self.method](self)
        return self

    def resolved_blend_mode(self):
        return _AUTO_BLEND_MODES.get(self.method, "HISTOGRAM") if self.blend_mode == "AUTO" else self.blend_mode

    def preprocess_params(self):
        """Keyword arguments of texsynth_native.preprocess / cache_status that key the cache."""
        return {"neighbourhood": self.neighbourhood, "tileable": bool(self.tileable), "seed": 0,
                "working_size": int(self.working_size)}


def register_method(spec):
    """Called by methods.py for each MethodSpec: its id becomes valid and its validate() runs in validate()."""
    if spec.id not in _METHOD_CHECKS:
        METHODS.append(spec.id)
        if spec.writes_uv:
            UV_METHODS.append(spec.id)
        if spec.colours_surface:
            SURFACE_METHODS.append(spec.id)
    _METHOD_CHECKS[spec.id] = spec.validate
    _AUTO_BLEND_MODES[spec.id] = spec.auto_blend_mode


def unregister_method(method_id):
    _METHOD_CHECKS.pop(method_id, None)
    _AUTO_BLEND_MODES.pop(method_id, None)
    for ids in (METHODS, UV_METHODS, SURFACE_METHODS):
        if method_id in ids:
            ids.remove(method_id)


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


def is_int(value):
    return isinstance(value, int) and not isinstance(value, bool)


def finite(value):
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def finite_positive(value):
    return finite(value) and value > 0.0


def texels_per_unit(sample_width, sample_world_size):
    """Native `scale` (texels per world unit) for a sample whose width spans sample_world_size units."""
    if not (isinstance(sample_width, numbers.Integral) and sample_width > 0):
        raise SettingsError("sample width must be a positive integer, got %r" % (sample_width,))
    if not finite_positive(float(sample_world_size)):
        raise SettingsError("scale must be a positive world size of the sample, got %r" % (sample_world_size,))
    return float(sample_width) / float(sample_world_size)


def object_seed(seed, object_name):
    """Per-object seed from (seed, name): stable whatever the selection order, distinct per object."""
    return (int(seed) * 0x9E3779B1 + zlib.crc32(object_name.encode("utf-8"))) % (2 ** 63)
